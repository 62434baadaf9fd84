//! `spcforc`: single-point-constraint reaction forces.
//!
//! Layout (LSTC `l2a.c`, `translate_spcforc`, and facts.md): after the preamble an optional
//! ` single point constraint forces` line, then per output ` output at time =%14.5E`, rows
//! ` node=%8d local x,y,z forces =%14.4E%14.4E%14.4E` (newer: `  setid=%8d` appended) and
//! ` node=%8d local x,y,z moments=...`, closed by `             force resultants   =%14.4E%14.4E%14.4E`.

use super::text::{Tok, body, err, read_text, tokens, whole};
use crate::error::InputError;
use std::path::Path;

#[derive(Debug, Clone, PartialEq)]
pub struct SpcRow {
    pub node: u64,
    pub value: [f64; 3],
    pub setid: Option<u64>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct SpcStep {
    pub time: f64,
    pub forces: Vec<SpcRow>,
    pub moments: Vec<SpcRow>,
    pub resultant: Option<[f64; 3]>,
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct Spcforc {
    pub title: String,
    pub steps: Vec<SpcStep>,
}

pub fn read(file: &Path) -> Result<Spcforc, InputError> {
    parse(file, &read_text(file)?)
}

fn three_after(t: &[Tok], key: usize) -> Option<[f64; 3]> {
    let v: Vec<f64> = t.get(key + 1..key + 4)?.iter().map(Tok::num).collect::<Option<_>>()?;
    Some([v[0], v[1], v[2]])
}

pub fn parse(file: &Path, text: &str) -> Result<Spcforc, InputError> {
    let b = body(file, text, "spcforc")?;
    let mut out = Spcforc {
        title: b.title.to_string(),
        steps: Vec::new(),
    };
    for &(no, line) in &b.lines {
        let trimmed = line.trim();
        if trimmed.is_empty() {
            continue;
        }
        let lower = trimmed.to_ascii_lowercase();
        if lower.starts_with("single point constraint forces") {
            continue;
        }
        let t = tokens(line);
        let located = |m: &str| err(file, text, no, m.to_string());
        if lower.starts_with("output at time") {
            let time = t
                .last()
                .and_then(Tok::num)
                .ok_or_else(|| located("expected ` output at time = T`"))?;
            out.steps.push(SpcStep {
                time,
                forces: Vec::new(),
                moments: Vec::new(),
                resultant: None,
            });
            continue;
        }
        let Some(step) = out.steps.last_mut() else {
            return Err(located("expected ` output at time = T` before the data"));
        };
        if lower.starts_with("node=") {
            let (row, is_moment) = node_row(&t, &lower, &located)?;
            if is_moment {
                step.moments.push(row)
            } else {
                step.forces.push(row)
            }
            continue;
        }
        if lower.starts_with("force resultants") {
            let key = t
                .iter()
                .position(|x| x.text() == "=")
                .ok_or_else(|| located("expected `force resultants =`"))?;
            let v = three_after(&t, key).ok_or_else(|| located("expected 3 numbers after `force resultants =`"))?;
            if t.len() != key + 4 {
                return Err(located("expected exactly 3 numbers after `force resultants =`"));
            }
            step.resultant = Some(v);
            continue;
        }
        return Err(located(
            "expected ` node= ...`, ` force resultants = ...` or ` output at time = T`",
        ));
    }
    Ok(out)
}

/// A ` node= N ... forces = x y z [setid= S]` (or `moments=`) row; whether it holds moments.
fn node_row(t: &[Tok], lower: &str, located: &dyn Fn(&str) -> InputError) -> Result<(SpcRow, bool), InputError> {
    let node = t
        .get(1)
        .and_then(Tok::num)
        .and_then(whole)
        .ok_or_else(|| located("expected a node id after `node=`"))?;
    let key = t.iter().position(|x| {
        let w = x.text().to_ascii_lowercase();
        w == "=" || w == "forces=" || w == "moments="
    });
    let is_moment = lower.contains("moments");
    let value = key
        .and_then(|k| three_after(t, k))
        .ok_or_else(|| located("expected `local x,y,z forces =` or `moments=` followed by 3 numbers"))?;
    let setid = match t.iter().position(|x| x.text().eq_ignore_ascii_case("setid=")) {
        Some(p) => Some(
            t.get(p + 1)
                .and_then(Tok::num)
                .and_then(whole)
                .ok_or_else(|| located("expected a number after `setid=`"))?,
        ),
        None => None,
    };
    Ok((SpcRow { node, value, setid }, is_moment))
}
