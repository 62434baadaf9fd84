//! `secforc`: cross-section force and moment resultants (*DATABASE_CROSS_SECTION_...).
//!
//! Source of the layout: LSTC's `l2a.c` (`translate_secforc`, the binout-to-ASCII converter, found with
//! the code search): after the preamble and legend, three header lines
//! ` line#1  section#     time        x-force     y-force     z-force    magnitude`,
//! ` line#2  resultant  moments       x-moment    y-moment    z-moment   magnitude`,
//! ` line#3  centroids                x           y           z            area`, then per section and
//! step a record of three lines and a blank line:
//! `%12d%15.5E` id, time, then `%15.4E%12.4E%12.4E%12.4E` force x, y, z, magnitude;
//! a system label (`global system`, `rb ID =%8d`, `ac ID =%8d` or `cs ID =%8d`) then moments x, y, z,
//! magnitude; 27 blanks then centroid x, y, z and area. The native solver's own writer was not found;
//! this parser reads by tokens (the last four numbers of lines 2 and 3), so column drift does not matter.

use super::text::{Tok, all_numbers, body, err, read_text, tokens, whole};
use crate::error::InputError;
use std::collections::BTreeMap;
use std::path::Path;

#[derive(Debug, Clone, Default, PartialEq)]
pub struct SectionSeries {
    pub time: Vec<f64>,
    pub force: [Vec<f64>; 3],
    pub force_magnitude: Vec<f64>,
    pub moment: [Vec<f64>; 3],
    pub moment_magnitude: Vec<f64>,
    pub centroid: [Vec<f64>; 3],
    pub area: Vec<f64>,
    /// The moment line's system label of the last record (`global system`, `rb ID = 5`, ...).
    pub system: String,
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct Secforc {
    pub title: String,
    pub sections: BTreeMap<u64, SectionSeries>,
}

pub fn read(file: &Path) -> Result<Secforc, InputError> {
    parse(file, &read_text(file)?)
}

fn last_numbers(t: &[Tok], n: usize) -> Option<(String, Vec<f64>)> {
    if t.len() < n {
        return None;
    }
    let (head, tail) = t.split_at(t.len() - n);
    let v: Option<Vec<f64>> = tail.iter().map(Tok::num).collect();
    let label = head.iter().map(Tok::text).collect::<Vec<_>>().join(" ");
    Some((label, v?))
}

pub fn parse(file: &Path, text: &str) -> Result<Secforc, InputError> {
    let b = body(file, text, "secforc")?;
    let mut out = Secforc {
        title: b.title.to_string(),
        sections: BTreeMap::new(),
    };
    let lines: Vec<(usize, &str)> = b
        .lines
        .iter()
        .copied()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().to_ascii_lowercase().starts_with("line#"))
        .collect();
    let at = |no: usize, message: &str| err(file, text, no, message);
    let mut i = 0;
    while i < lines.len() {
        let (no1, l1) = lines[i];
        let (id, time, f) = force_line(file, text, no1, l1)?;
        let Some(&(no2, l2)) = lines.get(i + 1) else {
            return Err(at(no1, "record ends early: expected a moment line after this line"));
        };
        let (system, m) = moment_line(file, text, no2, l2)?;
        let Some(&(no3, l3)) = lines.get(i + 2) else {
            return Err(at(no2, "record ends early: expected a centroid line after this line"));
        };
        let c: Vec<f64> = match all_numbers(l3) {
            Some(v) if v.len() == 4 => v,
            _ => return Err(at(no3, "expected 4 numbers: centroid x, y, z and area")),
        };
        let s = out.sections.entry(id).or_default();
        s.time.push(time);
        for k in 0..3 {
            s.force[k].push(f[k]);
            s.moment[k].push(m[k]);
            s.centroid[k].push(c[k]);
        }
        s.force_magnitude.push(f[3]);
        s.moment_magnitude.push(m[3]);
        s.area.push(c[3]);
        s.system = system;
        i += 3;
    }
    Ok(out)
}

/// A record's first line: section id, time, force x, y, z and magnitude.
fn force_line(file: &Path, text: &str, no: usize, line: &str) -> Result<(u64, f64, [f64; 4]), InputError> {
    match all_numbers(line) {
        Some(v) if v.len() == 6 && whole(v[0]).is_some() => Ok((v[0] as u64, v[1], [v[2], v[3], v[4], v[5]])),
        _ => Err(err(
            file,
            text,
            no,
            "expected `section# time x-force y-force z-force magnitude` (6 numbers)",
        )),
    }
}

/// A record's second line: the coordinate system's label, moment x, y, z and magnitude.
fn moment_line(file: &Path, text: &str, no: usize, line: &str) -> Result<(String, Vec<f64>), InputError> {
    let bad = || {
        err(
            file,
            text,
            no,
            "expected a system label and 4 numbers (moments x, y, z, magnitude)",
        )
    };
    let (system, m) = last_numbers(&tokens(line), 4).ok_or_else(bad)?;
    if system.chars().any(|c| c.is_ascii_digit()) && !system.to_ascii_lowercase().contains("id") {
        return Err(bad());
    }
    Ok((system, m))
}
