//! The end of a d3hsp: the termination line and the run's own account of its time, as LS-DYNA
//! R7.1.2, R9.3.1 and R12.2.1 print it (checked on their logs in `fixtures/lsdyna-real/`):
//!
//! ```text
//!   T o t a l s            1.0000E+00  100.00     1.2730E+00  100.00
//!  Problem time       =    3.5024E-02
//!  Problem cycle      =       576
//!  Total CPU time     =         1 seconds (   0 hours  0 minutes  1 seconds)
//!  Elapsed time       0 seconds(   0 hours  0 min.  0 sec.) for     576 cycles      (R7)
//!  Elapsed time       0 second  for     576 cycles using  2 SMP threads           (R9, R12)
//!  N o r m a l    t e r m i n a t i o n                          08/31/25 16:53:38
//! ```
//!
//! Each figure is the last of its kind in the file; a figure the log does not print is `None`.

use super::termination::{self, Termination};
use super::text::{parse_number, read_text, squash_starts_with};
use crate::error::InputError;
use std::path::Path;

/// What a d3hsp says about how the run ended and how long it took.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSummary {
    pub termination: Termination,
    /// `Problem time`: the simulated time reached.
    pub problem_time: Option<f64>,
    /// `Problem cycle`: the time steps taken.
    pub problem_cycle: Option<u64>,
    /// `Total CPU time`, seconds.
    pub cpu_seconds: Option<f64>,
    /// The timing table's clock total (`T o t a l s`, second number), seconds.
    pub clock_seconds: Option<f64>,
    /// `Elapsed time N second(s)`: wall-clock seconds, whole.
    pub elapsed_seconds: Option<f64>,
    /// `... for N cycles` on the elapsed-time line.
    pub elapsed_cycles: Option<u64>,
}

/// The number after `=` on a `label = value` line.
fn after_equals(line: &str) -> Option<f64> {
    line.split_once('=')
        .and_then(|(_, v)| v.split_whitespace().next())
        .and_then(parse_number)
}

/// The whole numbers of a line, in order.
fn numbers(line: &str) -> Vec<f64> {
    line.split(|c: char| c.is_whitespace() || c == '(' || c == ')')
        .filter_map(parse_number)
        .collect()
}

/// Reads the summary from d3hsp text.
pub fn parse(text: &str) -> RunSummary {
    let mut s = RunSummary {
        termination: termination::parse(text),
        problem_time: None,
        problem_cycle: None,
        cpu_seconds: None,
        clock_seconds: None,
        elapsed_seconds: None,
        elapsed_cycles: None,
    };
    for line in text.lines() {
        let t = line.trim_start();
        if t.starts_with("Problem time") {
            s.problem_time = after_equals(t).or(s.problem_time);
        } else if t.starts_with("Problem cycle") {
            s.problem_cycle = after_equals(t).map(|v| v as u64).or(s.problem_cycle);
        } else if t.starts_with("Total CPU time") {
            s.cpu_seconds = after_equals(t).or(s.cpu_seconds);
        } else if squash_starts_with(t, "totals") {
            s.clock_seconds = numbers(t).get(2).copied().or(s.clock_seconds);
        } else if let Some(rest) = t.strip_prefix("Elapsed time") {
            let n = numbers(rest);
            s.elapsed_seconds = n.first().copied().or(s.elapsed_seconds);
            let cycles = rest
                .split_once(" for ")
                .and_then(|(_, c)| c.split_whitespace().next())
                .and_then(parse_number);
            s.elapsed_cycles = cycles.map(|c| c as u64).or(s.elapsed_cycles);
        }
    }
    s
}

/// Reads the summary of the d3hsp at `file`.
pub fn read(file: &Path) -> Result<RunSummary, InputError> {
    Ok(parse(&read_text(file)?))
}
