//! `bndout`: boundary-condition nodal forces and energies.
//!
//! Layout (LSTC `l2a.c`, `bndout_dn/_dr/_p/_vn/_vr`, and facts.md): a heading
//! ` n o d a l   f o r c e/e n e r g y    o u t p u t   t=%9.3E` per output, a section title
//! (` discrete nodal point forces`, ` pressure boundary condition forces`,
//! ` velocity boundary condition forces/rigid body moments`), rows
//! ` nd#%8d  xforce=%13.4E   yforce=%13.4E  zforce=%13.4E   energy=%13.4E` (`mt#` / `mat#` for rigid
//! bodies; some versions append `setid= N`), for `mat#` rows a following
//! `xmoment= .. ymoment= .. zmoment= ..` line, and a `xtotal= .. ytotal= .. ztotal= .. etotal= ..` line.
//! Values are read by their `key=` labels.

use super::text::{Tok, body, err, read_text, squash, tokens, whole};
use crate::error::InputError;
use std::path::Path;

#[derive(Debug, Clone, PartialEq)]
pub struct BndEntry {
    /// `nd` (node) or `mt` / `mat` (rigid body material).
    pub kind: String,
    pub id: u64,
    /// The section title the row appeared under (e.g. `discrete nodal point forces`).
    pub source: String,
    pub force: [f64; 3],
    pub energy: f64,
    pub moment: Option<[f64; 3]>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct BndTotal {
    pub source: String,
    pub force: [f64; 3],
    pub energy: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct BndoutStep {
    pub time: f64,
    pub entries: Vec<BndEntry>,
    pub totals: Vec<BndTotal>,
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct Bndout {
    pub title: String,
    pub steps: Vec<BndoutStep>,
}

impl Bndout {
    /// (time, force) of node `id` (rows `nd#`), over all steps that list it.
    pub fn node_force(&self, id: u64) -> (Vec<f64>, Vec<[f64; 3]>) {
        let mut t = Vec::new();
        let mut f = Vec::new();
        for s in &self.steps {
            for e in s.entries.iter().filter(|e| e.kind == "nd" && e.id == id) {
                t.push(s.time);
                f.push(e.force);
            }
        }
        (t, f)
    }
}

pub fn read(file: &Path) -> Result<Bndout, InputError> {
    parse(file, &read_text(file)?)
}

/// Values of `key=` labels in a token list, in order of `keys`; error names the first missing one.
pub(crate) fn keyed(t: &[Tok], keys: &[&str]) -> Result<Vec<f64>, String> {
    keys.iter()
        .map(|k| {
            let pos = t.iter().position(|x| x.text().eq_ignore_ascii_case(k));
            match pos.and_then(|p| t.get(p + 1)).and_then(Tok::num) {
                Some(v) => Ok(v),
                None => Err(format!("expected `{k}` followed by a number")),
            }
        })
        .collect()
}

pub fn parse(file: &Path, text: &str) -> Result<Bndout, InputError> {
    let b = body(file, text, "bndout")?;
    let mut out = Bndout {
        title: b.title.to_string(),
        steps: Vec::new(),
    };
    let mut source = String::new();
    for &(no, line) in &b.lines {
        let trimmed = line.trim();
        if trimmed.is_empty() {
            continue;
        }
        let sq = squash(line);
        if let Some(rest) = sq.strip_prefix("nodalforce/energyoutputt=") {
            let time = super::text::parse_number(rest)
                .ok_or_else(|| err(file, text, no, "expected a time after `t=` in the bndout heading"))?;
            out.steps.push(BndoutStep {
                time,
                entries: Vec::new(),
                totals: Vec::new(),
            });
            continue;
        }
        let t = tokens(line);
        let first = t[0].text().to_ascii_lowercase();
        let Some(step) = out.steps.last_mut() else {
            return Err(err(
                file,
                text,
                no,
                "expected the ` n o d a l   f o r c e/e n e r g y    o u t p u t   t=T` heading",
            ));
        };
        let located = |m: String| err(file, text, no, m);
        match first.as_str() {
            "nd#" | "mt#" | "mat#" => {
                let Some(id) = t.get(1).and_then(Tok::num).and_then(whole) else {
                    return Err(located(format!("expected an id after `{first}`")));
                };
                let v = keyed(&t, &["xforce=", "yforce=", "zforce=", "energy="]).map_err(located)?;
                step.entries.push(BndEntry {
                    kind: first.trim_end_matches('#').to_string(),
                    id,
                    source: source.clone(),
                    force: [v[0], v[1], v[2]],
                    energy: v[3],
                    moment: None,
                });
            }
            "xmoment=" => {
                let v = keyed(&t, &["xmoment=", "ymoment=", "zmoment="]).map_err(located)?;
                match step.entries.last_mut() {
                    Some(e) if e.moment.is_none() => e.moment = Some([v[0], v[1], v[2]]),
                    _ => return Err(located("a moment line must follow a `mat#` row".into())),
                }
            }
            "xtotal=" => {
                let v = keyed(&t, &["xtotal=", "ytotal=", "ztotal=", "etotal="]).map_err(located)?;
                step.totals.push(BndTotal {
                    source: source.clone(),
                    force: [v[0], v[1], v[2]],
                    energy: v[3],
                });
            }
            _ => {
                if t.iter().any(|x| matches!(x, Tok::Num(..))) {
                    return Err(located(format!(
                        "expected `nd#`, `mat#`, `xmoment=`, `xtotal=` or a section title, found `{trimmed}`"
                    )));
                }
                source = trimmed.split_whitespace().collect::<Vec<_>>().join(" ");
            }
        }
    }
    Ok(out)
}
