//! `rcforc`: resultant contact forces per interface and side over time.
//!
//! Data lines (LSTC `l2a.c`, `translate_rcforc`, and facts.md):
//! `  master%11d time%12.5E  x %12.5E  y %12.5E  z %12.5E mass %12.5E`
//! (or `  slave %11d time ...`), optionally followed by `  mx %12.5E  my %12.5E  mz %12.5E` and/or
//! `  tied %10d  tied area %12.5E`. Newer LS-DYNA versions write `SURFA` (the former slave side) and
//! `SURFB` (the former master side). Lines ` interface number, N,is single surface-resultants are undefined`
//! are recorded in [`Rcforc::single_surface`]. Parsed by tokens and labels, not columns.

use super::text::{Tok, body, err, read_text, tokens_into, whole};
use crate::error::InputError;
pub use crate::study::settings::Side;
use std::collections::BTreeMap;
use std::path::Path;

impl Side {
    fn from_label(w: &str) -> Option<Side> {
        let is = |a: &str, b: &str| w.eq_ignore_ascii_case(a) || w.eq_ignore_ascii_case(b);
        if is("slave", "surfa") {
            Some(Side::SurfA)
        } else if is("master", "surfb") {
            Some(Side::SurfB)
        } else {
            None
        }
    }
}

/// One interface side's resultant history.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContactSeries {
    pub time: Vec<f64>,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub z: Vec<f64>,
    pub mass: Vec<f64>,
    /// `mx my mz` when the file has them (all rows of this series, or none).
    pub moments: Option<[Vec<f64>; 3]>,
}

impl ContactSeries {
    /// Force component by axis index 0 = x, 1 = y, 2 = z.
    pub fn component(&self, axis: usize) -> Option<&[f64]> {
        match axis {
            0 => Some(&self.x),
            1 => Some(&self.y),
            2 => Some(&self.z),
            _ => None,
        }
    }
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct Rcforc {
    pub title: String,
    pub interfaces: BTreeMap<(Side, u64), ContactSeries>,
    /// Interface numbers reported as single-surface (resultants undefined).
    pub single_surface: Vec<u64>,
    /// Every data row in file order, with its line: what the completeness check walks.
    pub rows: Vec<RowAt>,
}

/// Where one data row of an rcforc file is, and what it holds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowAt {
    pub line: usize,
    pub side: Side,
    pub interface: u64,
    pub time: f64,
}

pub fn read(file: &Path) -> Result<Rcforc, InputError> {
    parse(file, &read_text(file)?)
}

pub fn parse(file: &Path, text: &str) -> Result<Rcforc, InputError> {
    parse_keeping(file, text, None)
}

/// [`parse`] keeping one interface side: the data rows of the others are passed over once their
/// label and interface number are read (unchecked: what reads a run's curve after the run was
/// judged whole; the judgement itself uses [`parse`]).
pub fn parse_interface(file: &Path, text: &str, side: Side, interface: u64) -> Result<Rcforc, InputError> {
    parse_keeping(file, text, Some((side, interface)))
}

/// The side and interface number a data line starts with, when its first two words say so.
fn row_owner(line: &str) -> Option<(Side, u64)> {
    let mut words = line.split_ascii_whitespace();
    let side = Side::from_label(words.next()?)?;
    Some((side, words.next()?.parse().ok()?))
}

fn parse_keeping(file: &Path, text: &str, keep: Option<(Side, u64)>) -> Result<Rcforc, InputError> {
    let b = body(file, text, "rcforc")?;
    let mut out = Rcforc {
        title: b.title.to_string(),
        ..Default::default()
    };
    let mut t = Vec::new();
    for &(no, line) in &b.lines {
        if line.trim().is_empty() {
            continue;
        }
        // The letter-spaced heading ` r e s u l t a n t   i n t e r f a c e   f o r c e s`.
        if super::text::squash_eq(line, "resultantinterfaceforces") {
            continue;
        }
        if let Some(want) = keep
            && row_owner(line).is_some_and(|owner| owner != want)
        {
            continue;
        }
        tokens_into(line, &mut t);
        let fail = |message: String| err(file, text, no, message);
        let first = t[0].text();
        if first.eq_ignore_ascii_case("interface") {
            let n = t.iter().find_map(|k| k.num()).filter(|v| v.fract() == 0.0 && *v >= 0.0);
            match n {
                Some(n) => out.single_surface.push(n as u64),
                None => return Err(fail("expected `interface number, N,is single surface...`".into())),
            }
            continue;
        }
        let Some(side) = Side::from_label(first) else {
            return Err(fail(format!(
                "expected a data line starting with master/slave/SURFA/SURFB, found `{first}`"
            )));
        };
        let row = data_row(&t).map_err(fail)?;
        let s = out.interfaces.entry((side, row.id)).or_default();
        match (&mut s.moments, row.moments) {
            (Some(m), Some(r)) => {
                for k in 0..3 {
                    m[k].push(r[k]);
                }
            }
            (None, Some(r)) if s.time.is_empty() => {
                s.moments = Some([vec![r[0]], vec![r[1]], vec![r[2]]]);
            }
            (None, None) => {}
            _ => {
                return Err(fail(
                    "moment columns `mx my mz` must be on every line of an interface side or on none".into(),
                ));
            }
        }
        out.rows.push(RowAt {
            line: no,
            side,
            interface: row.id,
            time: row.time,
        });
        s.time.push(row.time);
        s.x.push(row.f[0]);
        s.y.push(row.f[1]);
        s.z.push(row.f[2]);
        s.mass.push(row.mass);
    }
    Ok(out)
}

struct Row {
    id: u64,
    time: f64,
    f: [f64; 3],
    mass: f64,
    moments: Option<[f64; 3]>,
}

/// The labels of a data line, in the slots [`data_row`] keeps their values in.
const LABELS: [&str; 10] = ["time", "x", "y", "z", "mass", "mx", "my", "mz", "tied", "tied area"];

fn data_row(t: &[Tok]) -> Result<Row, String> {
    let Some(id) = t.get(1).and_then(Tok::num).and_then(whole) else {
        return Err("expected an interface number after the side label".into());
    };
    // Label-value pairs after the id: time, x, y, z, mass, then optional mx, my, mz, tied, tied area.
    let mut vals: [Option<f64>; LABELS.len()] = [None; LABELS.len()];
    let mut i = 2;
    while i < t.len() {
        let label = match &t[i] {
            Tok::Word(w) => *w,
            Tok::Num(_, s) => return Err(format!("expected a label (time, x, y, z, mass, mx, ...), found `{s}`")),
        };
        let Some(mut slot) = LABELS[..9].iter().position(|k| label.eq_ignore_ascii_case(k)) else {
            return Err(format!(
                "unknown label `{}` in an rcforc data line",
                label.to_ascii_lowercase()
            ));
        };
        // `tied N  tied area A`: the `area` word following makes it the second.
        if LABELS[slot] == "tied" && t.get(i + 1).map(|k| k.text().eq_ignore_ascii_case("area")) == Some(true) {
            i += 1;
            slot += 1;
        }
        let v = t
            .get(i + 1)
            .and_then(Tok::num)
            .ok_or_else(|| format!("expected a number after `{label}`"))?;
        if vals[slot].replace(v).is_some() {
            return Err(format!("label `{label}` appears twice"));
        }
        i += 2;
    }
    let need = |k: usize| {
        vals[k].ok_or_else(|| {
            format!(
                "missing `{}`: expected labels time, x, y, z and mass, each followed by a number",
                LABELS[k]
            )
        })
    };
    let moments = match (vals[5], vals[6], vals[7]) {
        (Some(a), Some(b), Some(c)) => Some([a, b, c]),
        (None, None, None) => None,
        _ => return Err("expected all three moments `mx my mz` or none".into()),
    };
    Ok(Row {
        id,
        time: need(0)?,
        f: [need(1)?, need(2)?, need(3)?],
        mass: need(4)?,
        moments,
    })
}
