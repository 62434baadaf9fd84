//! What `crushsim` reads from a rendered deck: parameters, MAT_003 and rigid materials, shell
//! sections per part, the striker's mass and velocity, termination time, output intervals, the
//! history nodes, contacts, the mesh geometry (wall length per tube part) and the test switch.
//!
//! Every problem is a [`DeckError`] naming the file and line; nothing here panics on a bad deck.

use std::collections::HashMap;
use std::fmt;
use std::path::{Path, PathBuf};

use lab::render::lsdyna::deck::{self, Block, Card, Param};

/// A deck that cannot be run, with its place.
#[derive(Debug, Clone, PartialEq)]
pub struct DeckError {
    pub file: String,
    pub line: usize,
    pub message: String,
}

impl fmt::Display for DeckError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}: {}", self.file, self.line, self.message)
    }
}

impl std::error::Error for DeckError {}

type Res<T> = Result<T, DeckError>;

/// A keyword block and the file it came from.
#[derive(Debug, Clone)]
pub struct Located {
    pub file: String,
    pub block: Block,
}

/// MAT_003 values used by the crush model (MPa, t/mm^3, 1/s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plastic {
    pub mid: i64,
    pub rho: f64,
    pub e: f64,
    pub nu: f64,
    pub sigy: f64,
    pub etan: f64,
    pub beta: f64,
    pub src: f64,
    pub srp: f64,
}

/// A tube part: its shell thickness and the wall length it has in the cross-section.
#[derive(Debug, Clone, PartialEq)]
pub struct TubePart {
    pub pid: i64,
    pub title: String,
    pub thickness: f64,
    pub wall_length: f64,
    pub elements: usize,
}

/// The striker as the deck defines it.
#[derive(Debug, Clone, PartialEq)]
pub struct Striker {
    pub pid: i64,
    pub mass: f64,
    /// Initial speed towards the tube (mm/s, positive = crushing).
    pub speed: f64,
    /// Prescribed speed curve (time, speed), when the motion is prescribed.
    pub prescribed: Option<Vec<(f64, f64)>>,
    pub node: Option<i64>,
}

/// A contact definition, in deck order.
#[derive(Debug, Clone, PartialEq)]
pub struct Contact {
    pub kind: String,
    pub ssid: i64,
    pub msid: i64,
    pub fs: f64,
    /// Which rigid part is its master, if any (striker or base).
    pub master_part: Option<i64>,
}

/// The BINARY option of each history's `*DATABASE_...` card, as LS-DYNA reads it: 1 (or
/// blank/0) the ASCII file, 2 the binout database only, 3 both.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Binary {
    pub rcforc: i64,
    pub glstat: i64,
    pub nodout: i64,
}

impl Binary {
    /// Whether some history goes to binout.
    pub fn any_binout(&self) -> bool {
        [self.rcforc, self.glstat, self.nodout].iter().any(|&b| b >= 2)
    }
}

/// Everything the run needs.
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    pub title: String,
    pub params: Vec<(String, Param)>,
    pub material: Plastic,
    /// The tube's walls and the mesh's size.
    pub mesh: TubeMesh,
    pub striker: Striker,
    pub base_pid: Option<i64>,
    /// How long the run goes, its time step and the histories it writes.
    pub run: RunControl,
    pub contacts: Vec<Contact>,
    pub test_switch: Option<(String, f64)>,
}

/// The tube's walls and the mesh's size.
#[derive(Debug, Clone, PartialEq)]
pub struct TubeMesh {
    pub tube: Vec<TubePart>,
    pub tube_length: f64,
    pub tube_diameter: f64,
    pub nodes: usize,
    pub elements: usize,
    pub min_edge: f64,
}

/// How long the run goes, its time step and the histories it writes.
#[derive(Debug, Clone, PartialEq)]
pub struct RunControl {
    pub end_time: f64,
    pub tssfac: f64,
    pub dt_rcforc: Option<f64>,
    pub dt_glstat: Option<f64>,
    pub dt_nodout: Option<f64>,
    /// Where each history goes: the BINARY field of its `*DATABASE_...` card.
    pub binary: Binary,
    /// History nodes with their initial coordinates.
    pub history_nodes: Vec<(i64, [f64; 3])>,
}

/// Reads every block of `main` and of the files it includes (relative to `main`'s directory).
pub fn read_blocks(main: &Path) -> Res<Vec<Located>> {
    let name = main.display().to_string();
    let text = std::fs::read_to_string(main).map_err(|e| DeckError {
        file: name.clone(),
        line: 0,
        message: format!("cannot read the deck: {e}"),
    })?;
    let dir = main.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut out = Vec::new();
    collect(&name, &text, &dir, 0, &mut out)?;
    Ok(out)
}

fn collect(name: &str, text: &str, dir: &Path, depth: usize, out: &mut Vec<Located>) -> Res<()> {
    for block in deck::blocks(text) {
        if block.keyword == "INCLUDE" {
            let card = block.cards.first().ok_or_else(|| DeckError {
                file: name.to_string(),
                line: block.line,
                message: "*INCLUDE without a file name on the next line".into(),
            })?;
            let path: PathBuf = dir.join(card.text.trim());
            let included = std::fs::read_to_string(&path).map_err(|e| DeckError {
                file: name.to_string(),
                line: card.line,
                message: format!("included file {} cannot be read: {e}", path.display()),
            })?;
            if depth >= 8 {
                return Err(DeckError {
                    file: name.into(),
                    line: card.line,
                    message: "includes nested deeper than 8".into(),
                });
            }
            collect(&path.display().to_string(), &included, dir, depth + 1, out)?;
        } else {
            out.push(Located {
                file: name.to_string(),
                block,
            });
        }
    }
    Ok(())
}

/// Reads fields with parameters resolved.
pub struct Reader {
    pub params: HashMap<String, Param>,
    pub order: Vec<String>,
}

impl Reader {
    fn err(file: &str, card: &Card, message: impl Into<String>) -> DeckError {
        DeckError {
            file: file.to_string(),
            line: card.line,
            message: message.into(),
        }
    }

    /// Field `k` of a 10-column card as a real (`None` when blank).
    pub fn real(&self, file: &str, card: &Card, k: usize) -> Res<Option<f64>> {
        self.real_w(file, card, k, &[10])
    }

    pub fn real_w(&self, file: &str, card: &Card, k: usize, widths: &[usize]) -> Res<Option<f64>> {
        let fields = deck::fields(&card.text, widths);
        let Some(raw) = fields.get(k).map(|s| s.trim()) else {
            return Ok(None);
        };
        if raw.is_empty() {
            return Ok(None);
        }
        if let Some((name, neg)) = deck::reference(raw) {
            let p = self
                .params
                .get(&name)
                .ok_or_else(|| Self::err(file, card, format!("&{name} is not defined by a *PARAMETER")))?;
            let v = p
                .as_f64()
                .ok_or_else(|| Self::err(file, card, format!("&{name} is not a number")))?;
            return Ok(Some(if neg { -v } else { v }));
        }
        deck::parse_real(raw)
            .map(Some)
            .ok_or_else(|| Self::err(file, card, format!("field {} {raw:?} is not a number", k + 1)))
    }

    pub fn real_or(&self, file: &str, card: &Card, k: usize, default: f64) -> Res<f64> {
        Ok(self.real(file, card, k)?.unwrap_or(default))
    }

    /// Field `k` as an integer (`None` when blank).
    pub fn int(&self, file: &str, card: &Card, k: usize) -> Res<Option<i64>> {
        match self.real(file, card, k)? {
            None => Ok(None),
            Some(v) if v.fract() == 0.0 && v.abs() < 9e15 => Ok(Some(v as i64)),
            Some(v) => Err(Self::err(file, card, format!("field {} is {v}, not an integer", k + 1))),
        }
    }

    pub fn int_or(&self, file: &str, card: &Card, k: usize, default: i64) -> Res<i64> {
        Ok(self.int(file, card, k)?.unwrap_or(default))
    }
}

/// Builds the parameter table from every `*PARAMETER` block, in deck order.
pub fn parameters(blocks: &[Located]) -> Res<Reader> {
    let mut params = HashMap::new();
    let mut order = Vec::new();
    for b in blocks.iter().filter(|b| b.block.keyword == "PARAMETER") {
        for card in &b.block.cards {
            let before: Vec<String> = params.keys().cloned().collect();
            deck::read_parameter_card(card, &mut params).map_err(|e| DeckError {
                file: b.file.clone(),
                line: e.line,
                message: e.message,
            })?;
            let mut new: Vec<String> = params.keys().filter(|k| !before.contains(k)).cloned().collect();
            new.sort();
            order.extend(new);
        }
    }
    for b in blocks.iter().filter(|b| b.block.keyword == "PARAMETER_EXPRESSION") {
        for card in &b.block.cards {
            let (name, value) = expression(&params, card).map_err(|message| DeckError {
                file: b.file.clone(),
                line: card.line,
                message,
            })?;
            if !params.contains_key(&name) {
                order.push(name.clone());
            }
            params.insert(name, value);
        }
    }
    Ok(Reader { params, order })
}

/// One `*PARAMETER_EXPRESSION` card, as LS-DYNA reads it: the type letter and name in the first 10
/// columns, the expression in the next 70, over the parameters defined before it (names compared
/// in upper case, `**` a power, functions such as `sqrt` and `sin`). An `I` entry is rounded.
fn expression(params: &HashMap<String, Param>, card: &Card) -> Result<(String, Param), String> {
    let text = card.text.as_str();
    let head = text.get(..10.min(text.len())).unwrap_or(text).trim();
    let body = text.get(10.min(text.len())..).unwrap_or("").trim();
    let kind = head.chars().next().unwrap_or(' ').to_ascii_uppercase();
    let name = head.get(1..).unwrap_or("").trim().to_ascii_uppercase();
    if name.is_empty() || !matches!(kind, 'R' | 'I') {
        return Err(format!(
            "*PARAMETER_EXPRESSION: `{head}` is not a type letter R or I and a name"
        ));
    }
    // Parameters by their upper-case names; everything else (function names) in lower case.
    let mut spelled = String::new();
    let mut word = String::new();
    for c in body.replace("**", "^").chars().chain([' ']) {
        if c.is_ascii_alphanumeric() || c == '_' || (c == '.' && word.chars().all(|d| d.is_ascii_digit())) {
            word.push(c);
            continue;
        }
        let upper = word.to_ascii_uppercase();
        spelled.push_str(&if params.contains_key(&upper) {
            upper
        } else {
            word.to_ascii_lowercase()
        });
        word.clear();
        spelled.push(c);
    }
    let names: Vec<String> = params.keys().cloned().collect();
    let symbols = lab::study::Symbols::new(names.clone());
    let compiled = lab::study::Expression::compile(spelled.trim(), &symbols)
        .map_err(|e| format!("*PARAMETER_EXPRESSION {name}: `{body}`: {}", e.message))?;
    let values: Vec<f64> = names.iter().map(|n| params[n].as_f64().unwrap_or(f64::NAN)).collect();
    let v = compiled.eval(&values);
    if !v.is_finite() {
        return Err(format!("*PARAMETER_EXPRESSION {name}: `{body}` is not a finite number"));
    }
    let value = if kind == 'I' {
        Param::Int(v.round() as i64)
    } else {
        Param::Real(v)
    };
    Ok((name, value))
}

/// A card of a block, or an error saying which card is missing.
pub fn card(b: &Located, k: usize) -> Res<&Card> {
    b.block.cards.get(k).ok_or_else(|| DeckError {
        file: b.file.clone(),
        line: b.block.line,
        message: format!("*{} needs at least {} card(s)", b.block.keyword, k + 1),
    })
}
