//! CalculiX `.dat` files: the blocks written by `*NODE PRINT` / `*EL PRINT`, read by tokens.
//!
//! A block is a header line, a blank line, then rows:
//!
//! ```text
//!  displacements (vx,vy,vz) for set NTIP and time  0.1000000E+01
//!
//!         41  1.234567E-03  3.055012E-01 -2.000000E-05
//!  total force (fx,fy,fz) for set NFIX and time  0.1000000E+01
//!
//!        0.000000E+00 -6.000000E+02  0.000000E+00
//! ```
//!
//! The header gives the block's kind (`displacements`, `forces`, `total force`, `stresses`, ...),
//! its component names (between the parentheses), the set and the time. A row is the trailing
//! value components (as many as the names that are not ids: `elem`, `integ.pnt.`, `node`) after any
//! leading integer ids (a node number; an element and integration point; none for totals).
//! Other text lines (` S T E P 1`, `INCREMENT`, ...) end a block and are otherwise ignored.
//! Every error names the file and the line.
//!
//! ```
//! use lab::extract::calculix::{parse_dat, Reduce};
//! let text = " displacements (vx,vy,vz) for set NTIP and time  0.1000000E+01\n\n\
//!             \x20       41  1.0E-03  3.0E-01 0.0E+00\n        42  1.0E-03  5.0E-01 0.0E+00\n";
//! let blocks = parse_dat("job.dat".as_ref(), text).unwrap();
//! let b = &blocks[0];
//! assert_eq!((b.kind.as_str(), b.set.as_str(), b.time), ("displacements", "NTIP", 1.0));
//! assert_eq!(b.reduce("vy", Reduce::Mean).unwrap(), 0.4);
//! ```

pub use crate::study::settings::Reduce;
use std::fmt;
use std::path::{Path, PathBuf};

/// One block of a `.dat` file.
#[derive(Debug, Clone, PartialEq)]
pub struct DatBlock {
    /// Lowercase, single-spaced: `displacements`, `forces`, `total force`, `stresses`, ...
    pub kind: String,
    /// Value component names in order (ids such as `elem` removed), lowercase: `vx`, `fy`, `sxx`.
    pub components: Vec<String>,
    /// The set, uppercase as CalculiX writes it.
    pub set: String,
    pub time: f64,
    /// The header's line number (from 1).
    pub line: usize,
    /// Value rows (each `components.len()` long); ids are dropped.
    pub rows: Vec<Vec<f64>>,
}

/// A malformed `.dat` file, at a line.
#[derive(Debug, Clone, PartialEq)]
pub struct DatError {
    pub file: PathBuf,
    pub line: usize,
    pub message: String,
}

impl fmt::Display for DatError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}: {}", self.file.display(), self.line, self.message)
    }
}

impl std::error::Error for DatError {}

const ID_NAMES: [&str; 3] = ["elem", "integ.pnt.", "node"];

/// A block header: kind words, component names, set, time.
type Header = (String, Vec<String>, String, f64);

/// Reads a header line: `<kind words> (<names>) for set <SET> and time <T>`.
fn header(line: &str) -> Option<Result<Header, String>> {
    let open = line.find('(')?;
    let close = open + line[open..].find(')')?;
    let kind: Vec<&str> = line[..open].split_whitespace().collect();
    if kind.is_empty()
        || kind
            .iter()
            .any(|w| !w.chars().all(|c| c.is_ascii_alphabetic() || c == '.'))
    {
        return None;
    }
    let rest: Vec<&str> = line[close + 1..].split_whitespace().collect();
    if rest.len() < 2 || rest[0] != "for" || rest[1] != "set" {
        return None;
    }
    // From here the line is a header: anything missing is an error, not other text.
    let (set, and, time_word, t) = match rest.as_slice() {
        [_, _, set, and, time_word, t] => (*set, *and, *time_word, *t),
        _ => {
            return Some(Err(
                "expected `for set NAME and time T` after the component names".into()
            ));
        }
    };
    if and != "and" || time_word != "time" {
        return Some(Err("expected `and time T` after the set name".into()));
    }
    let time = match parse_num(t) {
        Some(v) => v,
        None => return Some(Err(format!("time `{t}` is not a number"))),
    };
    let components: Vec<String> = line[open + 1..close]
        .split(',')
        .map(|c| c.trim().to_ascii_lowercase())
        .filter(|c| !c.is_empty() && !ID_NAMES.contains(&c.as_str()))
        .collect();
    if components.is_empty() {
        return Some(Err("no component names between the parentheses".into()));
    }
    Some(Ok((
        kind.join(" ").to_ascii_lowercase(),
        components,
        set.to_ascii_uppercase(),
        time,
    )))
}

/// A Fortran number: `1.5E+01`, `1.5D+01`, `-3`, ...
fn parse_num(token: &str) -> Option<f64> {
    let t = token.replace(['D', 'd'], "E");
    t.parse::<f64>().ok().filter(|v| v.is_finite())
}

fn starts_numeric(line: &str) -> bool {
    line.trim_start()
        .chars()
        .next()
        .is_some_and(|c| c.is_ascii_digit() || matches!(c, '-' | '+' | '.'))
}

/// Parses a whole `.dat` text. `file` is only used in errors.
pub fn parse_dat(file: &Path, text: &str) -> Result<Vec<DatBlock>, DatError> {
    let err = |line: usize, message: String| DatError {
        file: file.to_path_buf(),
        line,
        message,
    };
    let mut blocks: Vec<DatBlock> = Vec::new();
    let mut open = false; // whether rows go to the last block
    for (i, raw) in text.lines().enumerate() {
        let n = i + 1;
        let line = raw.trim_end();
        if line.trim().is_empty() {
            continue; // blank lines separate a header from its rows
        }
        if let Some(h) = header(line) {
            let (kind, components, set, time) = h.map_err(|m| err(n, m))?;
            blocks.push(DatBlock {
                kind,
                components,
                set,
                time,
                line: n,
                rows: Vec::new(),
            });
            open = true;
            continue;
        }
        if !starts_numeric(line) {
            open = false; // other text (`S T E P`, `INCREMENT`, eigenvalue titles): ends a block
            continue;
        }
        if !open {
            continue; // numbers outside any printed block (e.g. other output tables)
        }
        let block = blocks.last_mut().expect("open implies a block");
        let tokens: Vec<&str> = line.split_whitespace().collect();
        let m = block.components.len();
        if tokens.len() < m {
            return Err(err(
                n,
                format!(
                    "row of `{} for set {}` has {} number(s), expected {m} ({}): truncated?",
                    block.kind,
                    block.set,
                    tokens.len(),
                    block.components.join(",")
                ),
            ));
        }
        let (ids, values) = tokens.split_at(tokens.len() - m);
        if let Some(bad) = ids.iter().find(|t| t.parse::<i64>().is_err()) {
            return Err(err(
                n,
                format!("`{bad}` is not an id; expected {m} value(s) after integer ids"),
            ));
        }
        let row = values
            .iter()
            .map(|t| parse_num(t).ok_or_else(|| err(n, format!("`{t}` is not a finite number"))))
            .collect::<Result<Vec<f64>, _>>()?;
        block.rows.push(row);
    }
    Ok(blocks)
}

/// Why a response could not be found in parsed blocks.
#[derive(Debug, Clone, PartialEq)]
pub enum Missing {
    /// The block is there without rows (a truncated file).
    NoRows,
    /// The block has no such component.
    NoComponent(Vec<String>),
    /// `value` on a block with several rows.
    SeveralRows(usize),
}

impl DatBlock {
    /// The column `component` reduced to one number.
    pub fn reduce(&self, component: &str, reduce: Reduce) -> Result<f64, Missing> {
        let Some(c) = self.components.iter().position(|n| n == component) else {
            return Err(Missing::NoComponent(self.components.clone()));
        };
        if self.rows.is_empty() {
            return Err(Missing::NoRows);
        }
        let column = self.rows.iter().map(|r| r[c]);
        Ok(match reduce {
            Reduce::Mean => column.sum::<f64>() / self.rows.len() as f64,
            Reduce::Sum => column.sum(),
            Reduce::MaxAbs => column.fold(0.0, |m: f64, v| m.max(v.abs())),
            Reduce::Value if self.rows.len() == 1 => self.rows[0][c],
            Reduce::Value => return Err(Missing::SeveralRows(self.rows.len())),
        })
    }
}

/// Why a windowed mean could not be taken.
#[derive(Debug, Clone, PartialEq)]
pub enum WindowMissing {
    /// A block in the history could not be reduced (no rows, no such component, several rows).
    Block(usize, Missing),
    /// The blocks' times do not cover `[t0, t1]`: (first time, last time), `None` without blocks.
    NotCovered(Option<(f64, f64)>),
}

/// The mean of the history of `kind` for `set` (every block's column `component`, reduced) over the
/// step-time window `[t0, t1]`: the integral of the piecewise-linear history between the blocks'
/// times, divided by `t1 - t0`. Automatic increments are uneven, so a plain mean of the rows would
/// weight the slowly converging parts (the peak) more. Under a displacement ramped linearly with
/// step time this is the mean force over the stroke window (energy / stroke). Blocks at the same
/// time (a repeated print) keep the later one.
pub fn window_mean(
    blocks: &[DatBlock],
    kind: &str,
    set: &str,
    component: &str,
    reduce: Reduce,
    (t0, t1): (f64, f64),
) -> Result<f64, WindowMissing> {
    let mut history: Vec<(f64, f64)> = Vec::new();
    for b in blocks
        .iter()
        .filter(|b| b.kind == kind && b.set.eq_ignore_ascii_case(set))
    {
        let v = b
            .reduce(component, reduce)
            .map_err(|m| WindowMissing::Block(b.line, m))?;
        match history.last_mut() {
            Some(last) if last.0 == b.time => *last = (b.time, v),
            _ => history.push((b.time, v)),
        }
    }
    history.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (Some(first), Some(last)) = (history.first(), history.last()) else {
        return Err(WindowMissing::NotCovered(None));
    };
    if first.0 > t0 || last.0 < t1 {
        return Err(WindowMissing::NotCovered(Some((first.0, last.0))));
    }
    let at = |t: f64, (ta, va): (f64, f64), (tb, vb): (f64, f64)| {
        if tb == ta {
            vb
        } else {
            va + (vb - va) * (t - ta) / (tb - ta)
        }
    };
    let mut integral = 0.0;
    for pair in history.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let (lo, hi) = (a.0.max(t0), b.0.min(t1));
        if hi > lo {
            integral += 0.5 * (at(lo, a, b) + at(hi, a, b)) * (hi - lo);
        }
    }
    Ok(integral / (t1 - t0))
}

/// The last block (latest time) of `kind` for `set`, if any.
pub fn find<'a>(blocks: &'a [DatBlock], kind: &str, set: &str) -> Option<&'a DatBlock> {
    blocks
        .iter()
        .rev()
        .find(|b| b.kind == kind && b.set.eq_ignore_ascii_case(set))
}

#[cfg(test)]
mod tests {
    use super::*;

    const SAMPLE: &str = "
                        S T E P       1


                                INCREMENT     1


 displacements (vx,vy,vz) for set NTIP and time  0.1000000E+01

        41  1.000000E-03  3.000000E-01 -2.000000E-05
        42 -1.000000E-03  3.100000E-01  2.000000E-05

 forces (fx,fy,fz) for set NFIX and time  0.1000000E+01

         1  1.000000E+02 -3.000000E+02  0.000000E+00
         2 -1.000000E+02 -3.000000E+02  0.000000E+00

 total force (fx,fy,fz) for set NFIX and time  0.1000000E+01

        0.000000E+00 -6.000000E+02  0.000000E+00

 stresses (elem, integ.pnt.,sxx,syy,szz,sxy,sxz,syz) for set EALL and time  0.1000000E+01

         1   1  1.0E+01  2.0E+00  0.0E+00  0.0E+00  0.0E+00  0.0E+00
";

    #[test]
    fn reads_every_block_kind() {
        let blocks = parse_dat(Path::new("j.dat"), SAMPLE).unwrap();
        assert_eq!(blocks.len(), 4);
        let d = find(&blocks, "displacements", "ntip").unwrap();
        assert_eq!(d.components, ["vx", "vy", "vz"]);
        assert!((d.reduce("vy", Reduce::Mean).unwrap() - 0.305).abs() < 1e-12);
        assert_eq!(d.reduce("vx", Reduce::MaxAbs).unwrap(), 1e-3);
        assert_eq!(d.line, 8);
        let f = find(&blocks, "forces", "NFIX").unwrap();
        assert_eq!(f.reduce("fy", Reduce::Sum).unwrap(), -600.0);
        let t = find(&blocks, "total force", "NFIX").unwrap();
        assert_eq!(t.reduce("fy", Reduce::Value).unwrap(), -600.0);
        assert_eq!(f.reduce("fy", Reduce::Value), Err(Missing::SeveralRows(2)));
        let s = find(&blocks, "stresses", "EALL").unwrap();
        assert_eq!(s.components.len(), 6);
        assert_eq!(s.reduce("sxx", Reduce::Value).unwrap(), 10.0);
        assert!(matches!(d.reduce("fx", Reduce::Mean), Err(Missing::NoComponent(_))));
        assert!(find(&blocks, "displacements", "NFIX").is_none());
    }

    #[test]
    fn later_time_wins_and_truncated_blocks_are_empty() {
        let text = " displacements (vx,vy,vz) for set A and time 0.5\n\n 1 0 1 0\n \
                    displacements (vx,vy,vz) for set A and time 1.0\n";
        let blocks = parse_dat(Path::new("j.dat"), text).unwrap();
        let b = find(&blocks, "displacements", "A").unwrap();
        assert_eq!(b.time, 1.0);
        assert_eq!(b.reduce("vy", Reduce::Mean), Err(Missing::NoRows));
    }

    #[test]
    fn errors_name_file_and_line() {
        // Two numbers where three values are due (a row cut short).
        let text = " displacements (vx,vy,vz) for set A and time 1.0\n\n 1 0.0\n";
        let e = parse_dat(Path::new("run/j.dat"), text).unwrap_err();
        assert_eq!((e.line, e.file.as_path()), (3, Path::new("run/j.dat")));
        assert!(e.to_string().starts_with("run/j.dat:3: "), "{e}");
        let text = " displacements (vx,vy,vz) for set A and time 1.0\n\n 1 0.0 1.0 x.5\n";
        assert!(
            parse_dat(Path::new("j.dat"), text)
                .unwrap_err()
                .message
                .contains("`x.5`")
        );
        let text = " displacements (vx,vy,vz) for set A and time\n";
        assert_eq!(parse_dat(Path::new("j.dat"), text).unwrap_err().line, 1);
        let text = " displacements (vx,vy,vz) for set A and time 1.0\n\n 1.5 0 1 2\n";
        assert!(
            parse_dat(Path::new("j.dat"), text)
                .unwrap_err()
                .message
                .contains("not an id")
        );
    }

    #[test]
    fn window_mean_integrates_the_history_between_increments() {
        // A peak at t = 0.1, then a plateau of 10 from 0.3: uneven increments, as ccx writes them.
        let mut text = String::new();
        for (t, f) in [(0.05, 20.0), (0.1, 40.0), (0.3, 10.0), (0.6, 10.0), (1.0, 10.0)] {
            text.push_str(&format!(
                " total force (fx,fy,fz) for set NBOT and time {t}\n\n 0 0 {f}\n"
            ));
        }
        let b = parse_dat(Path::new("j.dat"), &text).unwrap();
        let mean = |w| window_mean(&b, "total force", "nbot", "fz", Reduce::Value, w);
        assert!((mean((0.3, 1.0)).unwrap() - 10.0).abs() < 1e-12);
        // 0.2..0.3: linear from 25 to 10, mean 17.5; 0.3..0.4: 10.
        assert!((mean((0.2, 0.4)).unwrap() - 13.75).abs() < 1e-12);
        assert_eq!(mean((0.0, 1.0)), Err(WindowMissing::NotCovered(Some((0.05, 1.0)))));
        assert_eq!(
            window_mean(&b, "total force", "NTOP", "fz", Reduce::Value, (0.3, 1.0)),
            Err(WindowMissing::NotCovered(None))
        );
        assert!(matches!(
            window_mean(&b, "total force", "NBOT", "vz", Reduce::Value, (0.3, 1.0)),
            Err(WindowMissing::Block(1, Missing::NoComponent(_)))
        ));
    }

    #[test]
    fn fortran_d_exponent() {
        let text = " total force (fx,fy,fz) for set A and time 0.1D+01\n\n 1.0D+02 2.0D+00 0\n";
        let b = parse_dat(Path::new("j.dat"), text).unwrap();
        assert_eq!(b[0].rows[0], [100.0, 2.0, 0.0]);
    }
}
