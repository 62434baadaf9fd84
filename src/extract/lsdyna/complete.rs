//! Whether parsed histories are complete: what a run that stopped writing for a while, or ended
//! "normally" before its termination time, leaves behind.
//!
//! - **Times** (every history): the output times start at 0, step by the deck's interval DT
//!   (each gap within ± [`TIME_TOLERANCE`] × DT; only the last gap may be shorter, for a final
//!   output at the termination time), and the last reaches the termination time within one interval.
//! - **rcforc**: at every output time, every interface the file names has exactly one row per side.
//! - **nodout**: every block holds every node `*DATABASE_HISTORY_NODE` requests, once.
//! - **glstat**: every step has the labels of the first step, and no others.
//! - **Every file** ends with a line break (a cut-off last line may still parse as numbers).
//!
//! A violation is an [`Incomplete`]: the file, the line, and what was missing. The checks read the
//! values the readers parsed, never columns.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;

use super::glstat::Glstat;
use super::nodout::Nodout;
use super::rcforc::{Rcforc, Side};

/// How far (a fraction of the interval) a gap between outputs may stray from the interval.
/// LS-DYNA writes at the first cycle past each multiple of DT, so gaps differ from DT by about a
/// solver time step; a single missing output doubles a gap.
pub const TIME_TOLERANCE: f64 = 0.25;

/// A history that is not complete.
#[derive(Debug, Clone, PartialEq)]
pub struct Incomplete {
    pub file: String,
    /// 1-based line in the file (the nearest line to what is missing).
    pub line: usize,
    pub detail: String,
}

impl fmt::Display for Incomplete {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}: {}", self.file, self.line, self.detail)
    }
}

/// What the deck asks of one history file: its interval and the termination time, when known.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Expected {
    pub dt: Option<f64>,
    pub end_time: Option<f64>,
}

/// The file's text ends with a line break (else its last line was cut short).
pub fn ends_with_newline(file: &str, text: &str) -> Result<(), Incomplete> {
    if text.is_empty() || text.ends_with('\n') {
        return Ok(());
    }
    Err(Incomplete {
        file: file.into(),
        line: text.lines().count(),
        detail: "the last line has no line break: the file was cut off while being written".into(),
    })
}

/// Checks output times `(line, time)` in file order against the interval and termination time.
pub fn times(file: &str, points: &[(usize, f64)], want: Expected, last_line: usize) -> Result<(), Incomplete> {
    let at = |line: usize, detail: String| Incomplete {
        file: file.into(),
        line,
        detail,
    };
    let Some(&(first_line, first)) = points.first() else {
        return Err(at(last_line, "no output at any time".into()));
    };
    let Some(dt) = want.dt.filter(|d| *d > 0.0 && d.is_finite()) else {
        return Ok(()); // times from a load curve (DT = 0) or unknown: nothing to compare against
    };
    let tol = TIME_TOLERANCE * dt;
    if first.is_nan() || first.abs() > tol {
        return Err(at(
            first_line,
            format!("the first output is at time {first:e}, expected 0"),
        ));
    }
    for (k, w) in points.windows(2).enumerate() {
        let ((_, t0), (line, t1)) = (w[0], w[1]);
        let gap = t1 - t0;
        let last = k + 2 == points.len();
        if gap.is_nan() || gap <= 0.0 {
            return Err(at(
                line,
                format!("time {t1:e} does not follow {t0:e}: times must increase"),
            ));
        }
        if gap > dt + tol {
            let missing = (gap / dt).round() as i64 - 1;
            return Err(at(
                line,
                format!(
                    "gap in the history: no output between times {t0:e} and {t1:e} (about {} output(s) missing at interval {dt:e})",
                    missing.max(1)
                ),
            ));
        }
        if gap < dt - tol && !last {
            return Err(at(
                line,
                format!("output at time {t1:e} only {gap:e} after the previous one: expected the interval {dt:e}"),
            ));
        }
    }
    let (line, end) = *points.last().expect("not empty");
    if let Some(end_time) = want.end_time.filter(|e| e.is_finite() && *e > 0.0) {
        if end < end_time - dt - tol {
            return Err(at(
                line,
                format!(
                    "the history ends at time {end:e}, short of the termination time {end_time:e} by more than one interval ({dt:e})"
                ),
            ));
        }
        if end > end_time + tol {
            return Err(at(
                line,
                format!("output at time {end:e}, past the termination time {end_time:e}"),
            ));
        }
    }
    Ok(())
}

/// The rows of one output time: its first line, the time, and the line of each (interface, side).
type TimeGroup = (usize, f64, BTreeMap<(u64, Side), usize>);

/// rcforc: complete master/slave pairs for every interface at every time, then the times.
pub fn rcforc(rc: &Rcforc, want: Expected, last_line: usize) -> Result<(), Incomplete> {
    let expected: BTreeSet<(u64, Side)> = rc.rows.iter().map(|r| (r.interface, r.side)).collect();
    let mut groups: Vec<TimeGroup> = Vec::new();
    for r in &rc.rows {
        let same_time = groups.last().is_some_and(|g| g.1 == r.time);
        if !same_time {
            groups.push((r.line, r.time, BTreeMap::new()));
        }
        let g = groups.last_mut().expect("pushed");
        if let Some(first) = g.2.insert((r.interface, r.side), r.line) {
            return Err(Incomplete {
                file: "rcforc".into(),
                line: r.line,
                detail: format!(
                    "a second {} row of interface {} at time {:e} (the first at line {first}): rows of another time are missing between them",
                    side_name(r.side),
                    r.interface,
                    r.time
                ),
            });
        }
    }
    for (line, time, seen) in &groups {
        if let Some((id, side)) = expected.iter().find(|k| !seen.contains_key(k)) {
            let has = |s: Side| seen.contains_key(&(*id, s));
            let what = if has(Side::SurfA) || has(Side::SurfB) {
                format!(
                    "interface {id} has a {} row but no {} row",
                    side_name(other(*side)),
                    side_name(*side)
                )
            } else {
                format!("interface {id} has no rows")
            };
            return Err(Incomplete {
                file: "rcforc".into(),
                line: *line,
                detail: format!("at time {time:e} (rows from this line) {what}"),
            });
        }
    }
    let points: Vec<(usize, f64)> = groups.iter().map(|g| (g.0, g.1)).collect();
    times("rcforc", &points, want, last_line)
}

fn side_name(s: Side) -> &'static str {
    match s {
        Side::SurfA => "slave (SURFA)",
        Side::SurfB => "master (SURFB)",
    }
}

fn other(s: Side) -> Side {
    match s {
        Side::SurfA => Side::SurfB,
        Side::SurfB => Side::SurfA,
    }
}

/// nodout: every block holds each requested node once (`requested` empty: the nodes of the first
/// block), then the times.
pub fn nodout(nod: &Nodout, requested: &[u64], want: Expected, last_line: usize) -> Result<(), Incomplete> {
    let nodes: BTreeSet<u64> = if requested.is_empty() {
        nod.blocks
            .first()
            .map(|b| b.nodes.iter().copied().collect())
            .unwrap_or_default()
    } else {
        requested.iter().copied().collect()
    };
    for b in &nod.blocks {
        let mut seen = BTreeSet::new();
        for id in &b.nodes {
            if !seen.insert(*id) {
                return Err(Incomplete {
                    file: "nodout".into(),
                    line: b.line,
                    detail: format!(
                        "node {id} appears twice in the block at time {:e}: the next block's heading is missing",
                        b.time
                    ),
                });
            }
        }
        if let Some(id) = nodes.iter().find(|id| !seen.contains(id)) {
            return Err(Incomplete {
                file: "nodout".into(),
                line: b.line,
                detail: format!("the block at time {:e} has no row for requested node {id}", b.time),
            });
        }
    }
    let points: Vec<(usize, f64)> = nod.blocks.iter().map(|b| (b.line, b.time)).collect();
    times("nodout", &points, want, last_line)
}

/// glstat: every step has the labels of the first step, then the times.
pub fn glstat(gl: &Glstat, want: Expected, last_line: usize) -> Result<(), Incomplete> {
    if let Some(first) = gl.steps.first() {
        for s in &gl.steps[1..] {
            if let Some(label) = first.values.keys().find(|k| !s.values.contains_key(*k)) {
                return Err(Incomplete {
                    file: "glstat".into(),
                    line: s.line,
                    detail: format!("the step at time {:e} has no `{label}` line", s.time),
                });
            }
            if let Some((label, line)) = s.lines.iter().find(|(k, _)| !first.values.contains_key(*k)) {
                return Err(Incomplete {
                    file: "glstat".into(),
                    line: *line,
                    detail: format!(
                        "`{label}` in the step at time {:e} is not in the first step: the steps must have the same lines",
                        s.time
                    ),
                });
            }
        }
    }
    let points: Vec<(usize, f64)> = gl.steps.iter().map(|s| (s.line, s.time)).collect();
    times("glstat", &points, want, last_line)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn want(dt: f64, end: f64) -> Expected {
        Expected {
            dt: Some(dt),
            end_time: Some(end),
        }
    }

    fn pts(ts: &[f64]) -> Vec<(usize, f64)> {
        ts.iter().enumerate().map(|(i, t)| (10 + i, *t)).collect()
    }

    #[test]
    fn even_times_to_the_end_pass() {
        let t: Vec<f64> = (0..=10).map(|k| k as f64 * 0.1).collect();
        assert_eq!(times("f", &pts(&t), want(0.1, 1.0), 99), Ok(()));
        // A final output at the termination time, closer than one interval.
        let mut t2: Vec<f64> = (0..=9).map(|k| k as f64 * 0.1).collect();
        t2.push(0.95);
        assert_eq!(times("f", &pts(&t2), want(0.1, 0.95), 99), Ok(()));
    }

    #[test]
    fn a_gap_names_its_line_and_the_missing_count() {
        let t = [0.0, 0.1, 0.2, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0];
        let e = times("rcforc", &pts(&t), want(0.1, 1.0), 99).unwrap_err();
        assert_eq!(e.line, 13);
        assert!(e.detail.contains("about 2 output(s) missing"), "{e}");
    }

    #[test]
    fn an_early_end_and_a_late_start_are_caught() {
        let t: Vec<f64> = (0..=7).map(|k| k as f64 * 0.1).collect();
        let e = times("f", &pts(&t), want(0.1, 1.0), 99).unwrap_err();
        assert!(e.detail.contains("short of the termination time"), "{e}");
        let t: Vec<f64> = (1..=10).map(|k| k as f64 * 0.1).collect();
        let e = times("f", &pts(&t), want(0.1, 1.0), 99).unwrap_err();
        assert!(e.detail.contains("expected 0"), "{e}");
        assert_eq!(times("f", &[], want(0.1, 1.0), 99).unwrap_err().line, 99);
    }

    #[test]
    fn a_cut_last_line_is_caught() {
        assert!(ends_with_newline("f", "a\nb\n").is_ok());
        assert_eq!(ends_with_newline("f", "a\nb 1.0E+0").unwrap_err().line, 2);
    }
}
