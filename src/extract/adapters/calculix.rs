//! The `calculix` adapter: `ccx -i JOB` in the run directory, judged by its own rules.
//!
//! CalculiX's exit code is not enough: it exits 201 on non-convergence, but 0 after an unknown
//! keyword or a missing include (it warns and prints "Job finished"). A run succeeds only when
//! (1) the exit code is 0 (the executor checks), (2) no line of its output holds `*ERROR`, and (3)
//! `JOB.dat` holds the expected block with rows; the response is one column of that block, reduced.
//!
//! ```
//! use lab::execute::Adapter;
//! use lab::extract::adapters::calculix::{CalculixAdapter, DatResponse};
//! use lab::extract::calculix::Reduce;
//! let a = CalculixAdapter::new("beam", DatResponse {
//!     block: "displacements".into(), set: "NTIP".into(), component: "vy".into(), reduce: Reduce::Mean,
//!     window: None });
//! assert_eq!(a.argv(), ["ccx", "-i", "beam"]);
//! let dir = tempfile::tempdir().unwrap();
//! std::fs::write(dir.path().join("beam.dat"),
//!     " displacements (vx,vy,vz) for set NTIP and time 1.0\n\n 7 0.0 0.3055 0.0\n").unwrap();
//! assert_eq!(a.extract(dir.path()).unwrap(), 0.3055);
//! ```

use std::path::{Path, PathBuf};

use crate::execute::adapter::{bad, failure_line, read_output};
use crate::execute::{Adapter, Outcome, ResponseProblem, STDERR_FILE, STDOUT_FILE};
use crate::extract::calculix::{Missing, WindowMissing, find, parse_dat, window_mean};
pub use crate::study::settings::{CalculixAdapter, DatResponse, ERROR_TEXT};

impl Adapter for CalculixAdapter {
    fn identity(&self) -> String {
        let r = &self.response;
        let parts = (&self.job, &r.block, &r.set, &r.component, r.reduce.key());
        let parts = serde_json::to_string(&parts).expect("strings serialize");
        // Without a window the identity is what it was before windows existed (recorded runs stay).
        match r.window {
            None => format!("calculix/1 {parts}"),
            Some((t0, t1)) => format!("calculix/1 {parts} window [{t0}, {t1}]"),
        }
    }

    fn find_failure(&self, dir: &Path) -> Option<Outcome> {
        let files = [PathBuf::from(STDOUT_FILE), PathBuf::from(STDERR_FILE)];
        failure_line(dir, &files, |line| line.contains(ERROR_TEXT))
    }

    fn extract(&self, dir: &Path) -> Result<f64, Outcome> {
        let rel = self.dat_file();
        let bytes = read_output(dir, &rel)?;
        let text = String::from_utf8_lossy(&bytes);
        let blocks = parse_dat(&rel, &text).map_err(|e| bad(ResponseProblem::Unparseable, e.to_string()))?;
        let r = &self.response;
        let Some(block) = find(&blocks, &r.block, &r.set) else {
            return Err(bad(
                ResponseProblem::Missing,
                format!(
                    "no `{}` block for set {} in {} (ccx skips unknown keywords and missing includes with only a \
                     warning: see {STDOUT_FILE})",
                    r.block,
                    r.set,
                    rel.display()
                ),
            ));
        };
        if let Some(w) = r.window {
            return window_mean(&blocks, &r.block, &r.set, &r.component, r.reduce, w).map_err(|m| match m {
                WindowMissing::Block(line, m) => missing(&format!("{}:{line}", rel.display()), r, m),
                WindowMissing::NotCovered(span) => bad(
                    ResponseProblem::Missing,
                    format!(
                        "{}: the `{}` blocks for set {} span step times {} but the window is [{}, {}] (did the run \
                         stop early?)",
                        rel.display(),
                        r.block,
                        r.set,
                        span.map_or("nothing".into(), |(a, b)| format!("{a}..{b}")),
                        w.0,
                        w.1
                    ),
                ),
            });
        }
        let at = format!("{}:{}", rel.display(), block.line);
        block.reduce(&r.component, r.reduce).map_err(|m| missing(&at, r, m))
    }
}

/// A block that could not be reduced, as a bad response at `at` (file:line).
fn missing(at: &str, r: &DatResponse, m: Missing) -> Outcome {
    match m {
        Missing::NoRows => bad(ResponseProblem::Empty, format!("{at}: `{}` block has no rows", r.block)),
        Missing::NoComponent(names) => bad(
            ResponseProblem::Missing,
            format!(
                "{at}: `{}` block has no component `{}` (it has {})",
                r.block,
                r.component,
                names.join(", ")
            ),
        ),
        Missing::SeveralRows(n) => bad(
            ResponseProblem::Unparseable,
            format!("{at}: `reduce: value` needs a single row; the block has {n}"),
        ),
    }
}
