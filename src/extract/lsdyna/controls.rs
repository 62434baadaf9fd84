//! What a rendered keyword deck asks of its ASCII outputs: the termination time
//! (`*CONTROL_TERMINATION` ENDTIM), the output interval of each history file
//! (`*DATABASE_RCFORC` / `_NODOUT` / `_GLSTAT` / `_RWFORC` DT, the first field of their first
//! card), where each goes (their BINARY, the second field: 1 the ASCII file, 2 binout, 3 both) and
//! the nodes `*DATABASE_HISTORY_NODE` requests in nodout.
//!
//! Fields are read as LS-DYNA reads them (10-character fixed fields, or comma free format), with
//! `*PARAMETER` references (`&TEND`) resolved. Only the main deck is read, not its `*INCLUDE`s: the
//! controls belong there, and a run's mesh include may be large or (in a replay) absent.

use std::collections::HashMap;
use std::path::Path;

use crate::error::InputError;
use lsdyna_keyword::deck::{self, Block, Card, Param};

/// An output interval, where the output goes, and the deck line that set them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    pub dt: f64,
    pub line: usize,
    /// BINARY: 1 (also blank or 0) the ASCII file, 2 binout only, 3 both.
    pub binary: i64,
}

impl Interval {
    /// Whether the deck sends this history to binout (BINARY 2 or 3).
    pub fn to_binout(&self) -> bool {
        self.binary >= 2
    }
}

/// The output requests of a deck. `None` where the deck does not say.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Controls {
    pub end_time: Option<f64>,
    pub rcforc: Option<Interval>,
    pub nodout: Option<Interval>,
    pub glstat: Option<Interval>,
    pub rwforc: Option<Interval>,
    /// `*DATABASE_HISTORY_NODE` ids, in deck order.
    pub history_nodes: Vec<u64>,
}

impl Controls {
    /// The interval the deck sets for a history file by name (`rcforc`, `nodout`, `glstat`,
    /// `rwforc`).
    pub fn interval(&self, file: &str) -> Option<Interval> {
        match file {
            "rcforc" => self.rcforc,
            "nodout" => self.nodout,
            "glstat" => self.glstat,
            "rwforc" => self.rwforc,
            _ => None,
        }
    }
}

/// Reads the controls of the deck at `file`.
pub fn read(file: &Path) -> Result<Controls, InputError> {
    let text =
        std::fs::read_to_string(file).map_err(|e| InputError::file(file, format!("cannot read the deck: {e}")))?;
    parse(file, &text)
}

/// Reads the controls of deck `text` (named `file` in errors).
pub fn parse(file: &Path, text: &str) -> Result<Controls, InputError> {
    let blocks = deck::blocks(text);
    let params = parameters(file, text, &blocks)?;
    let field = |card: &Card, k: usize| -> Result<Option<f64>, InputError> { real(file, text, &params, card, k) };
    let mut out = Controls::default();
    for b in &blocks {
        let first = b.cards.first();
        match b.keyword.as_str() {
            "CONTROL_TERMINATION" => {
                if let Some(c) = first {
                    out.end_time = field(c, 0)?;
                }
            }
            "DATABASE_RCFORC" | "DATABASE_NODOUT" | "DATABASE_GLSTAT" | "DATABASE_RWFORC" => {
                let Some(c) = first else { continue };
                let binary = match field(c, 1)? {
                    None => 1,
                    Some(v) if v == 0.0 || v == 1.0 => 1,
                    Some(v) if v == 2.0 || v == 3.0 => v as i64,
                    Some(v) => {
                        return Err(InputError::at(
                            file,
                            text,
                            c.line,
                            11,
                            format!(
                                "*{}: BINARY is {v}, expected 1 (ASCII), 2 (binout) or 3 (both)",
                                b.keyword
                            ),
                        ));
                    }
                };
                let interval = field(c, 0)?.map(|dt| Interval {
                    dt,
                    line: c.line,
                    binary,
                });
                match b.keyword.as_str() {
                    "DATABASE_RCFORC" => out.rcforc = interval,
                    "DATABASE_NODOUT" => out.nodout = interval,
                    "DATABASE_RWFORC" => out.rwforc = interval,
                    _ => out.glstat = interval,
                }
            }
            "DATABASE_HISTORY_NODE" => {
                for c in &b.cards {
                    for k in 0..8 {
                        match field(c, k)? {
                            Some(v) if v > 0.0 && v.fract() == 0.0 && v < 1e18 => out.history_nodes.push(v as u64),
                            Some(v) if v != 0.0 => {
                                return Err(InputError::at(
                                    file,
                                    text,
                                    c.line,
                                    1,
                                    format!("*DATABASE_HISTORY_NODE: field {} is {v}, not a node id", k + 1),
                                ));
                            }
                            _ => {}
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(out)
}

fn parameters(file: &Path, text: &str, blocks: &[Block]) -> Result<HashMap<String, Param>, InputError> {
    let mut table = HashMap::new();
    for b in blocks.iter().filter(|b| b.keyword == "PARAMETER") {
        for card in &b.cards {
            deck::read_parameter_card(card, &mut table)
                .map_err(|e| InputError::at(file, text, e.line, e.column, e.message))?;
        }
    }
    Ok(table)
}

/// Field `k` of a 10-column card as a real, `&NAME` resolved; `None` when blank.
fn real(
    file: &Path,
    text: &str,
    params: &HashMap<String, Param>,
    card: &Card,
    k: usize,
) -> Result<Option<f64>, InputError> {
    let fields = deck::fields(&card.text, &[10]);
    let raw = match fields.get(k).map(|s| s.trim()) {
        None | Some("") => return Ok(None),
        Some(r) => r,
    };
    let bad = |m: String| InputError::at(file, text, card.line, 10 * k + 1, m);
    if let Some((name, negated)) = deck::reference(raw) {
        let value = params
            .get(&name)
            .ok_or_else(|| bad(format!("&{name} is not defined by a *PARAMETER")))?
            .as_f64()
            .ok_or_else(|| bad(format!("&{name} is not a number")))?;
        return Ok(Some(if negated { -value } else { value }));
    }
    deck::parse_real(raw)
        .map(Some)
        .ok_or_else(|| bad(format!("field {} `{raw}` is not a number", k + 1)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_times_intervals_and_nodes_through_parameters() {
        let deck = "*KEYWORD\n*PARAMETER\nR TEND         0.061R DTOUT       0.0005\n\
                    *CONTROL_TERMINATION\n$ endtim\n     &TEND         0\n\
                    *DATABASE_RCFORC\n    &DTOUT         1\n*DATABASE_GLSTAT\n1.0e-3,3\n\
                    *DATABASE_HISTORY_NODE\n   9000005         7\n*END\n";
        let c = parse(Path::new("main.k"), deck).unwrap();
        assert_eq!(c.end_time, Some(0.061));
        assert_eq!(
            c.rcforc,
            Some(Interval {
                dt: 0.0005,
                line: 8,
                binary: 1
            })
        );
        assert_eq!(c.glstat.map(|i| (i.dt, i.to_binout())), Some((1.0e-3, true)));
        assert_eq!(c.nodout, None);
        assert_eq!(c.history_nodes, vec![9000005, 7]);
    }

    #[test]
    fn an_undefined_reference_names_its_line() {
        let e = parse(Path::new("main.k"), "*CONTROL_TERMINATION\n     &TEND\n").unwrap_err();
        assert_eq!(e.span.as_ref().map(|s| s.line), Some(2), "{e}");
        assert!(e.to_string().contains("&TEND"), "{e}");
    }
}
