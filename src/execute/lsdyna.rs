//! The `lsdyna` adapter: an LS-DYNA style solver (LS-DYNA itself, or the `crushsim` stand-in)
//! judged by its ASCII outputs.
//!
//! - **Failure text**: an ` E r r o r    t e r m i n a t i o n` line in messag, d3hsp or the
//!   captured stdout ([`crate::extract::lsdyna::termination`]) → `Outcome::FailureText`.
//! - **Success** needs exit code 0 (checked by the executor), the normal-termination line in one of
//!   those files (its absence is a missing response: the solver did not finish), and the declared
//!   outputs (rcforc, nodout) present and parseable.
//! - **Response**: the mean crush force (kN) = absorbed energy / stroke over the stroke window,
//!   from the contact resultant of one rcforc interface side and axis and the striker node's
//!   displacement in nodout ([`crate::extract::crush`]).
//!
//! The recorded outputs ([`Adapter::outputs`]) are exactly the files this judgement reads:
//! messag, rcforc and nodout; a replay judges them with the same code, so replayed responses are
//! bit-identical to live ones.

use std::path::{Path, PathBuf};

use super::{Adapter, Outcome, ResponseProblem, STDOUT_FILE};
use crate::extract::crush::{self, SimSource, Window};
use crate::extract::lsdyna::{nodout, rcforc, termination};

/// Files scanned for the termination line, in order.
pub const TERMINATION_FILES: [&str; 3] = ["messag", "d3hsp", STDOUT_FILE];

/// The `lsdyna` adapter's settings.
#[derive(Debug, Clone)]
pub struct LsDynaAdapter {
    pub window: Window,
    pub source: SimSource,
}

fn bad(problem: ResponseProblem, detail: impl Into<String>) -> Outcome {
    Outcome::BadResponse {
        problem,
        detail: detail.into(),
    }
}

impl LsDynaAdapter {
    fn termination(&self, dir: &Path) -> Option<(String, termination::Termination)> {
        for name in TERMINATION_FILES {
            let path = dir.join(name);
            if !path.exists() {
                continue;
            }
            match termination::read(&path) {
                Ok(termination::Termination::Missing) | Err(_) => continue,
                Ok(t) => return Some((name.to_string(), t)),
            }
        }
        None
    }
}

impl Adapter for LsDynaAdapter {
    fn identity(&self) -> String {
        let s = &self.source;
        let side = match s.side {
            rcforc::Side::SurfA => "surfa",
            rcforc::Side::SurfB => "surfb",
        };
        let parts = (
            [self.window.s0, self.window.s1],
            s.interface,
            side,
            s.force_axis,
            format!("{:?}", s.force_sign),
            s.force_to_kn,
            s.node,
            s.disp_axis,
            format!("{:?}", s.disp_sign),
            s.disp_to_mm,
        );
        format!(
            "lsdyna/1 crush_force {}",
            serde_json::to_string(&parts).expect("settings serialize")
        )
    }

    fn outputs(&self) -> Vec<PathBuf> {
        ["messag", "rcforc", "nodout"].into_iter().map(PathBuf::from).collect()
    }

    fn cleared(&self) -> Vec<PathBuf> {
        ["messag", "d3hsp", "rcforc", "nodout", "glstat"]
            .into_iter()
            .map(PathBuf::from)
            .collect()
    }

    fn find_failure(&self, dir: &Path) -> Option<Outcome> {
        match self.termination(dir) {
            Some((file, termination::Termination::Error(date))) => Some(Outcome::FailureText {
                file,
                line: format!("E r r o r    t e r m i n a t i o n {date}").trim().into(),
            }),
            _ => None,
        }
    }

    fn extract(&self, dir: &Path) -> Result<f64, Outcome> {
        match self.termination(dir) {
            Some((_, termination::Termination::Normal(_))) => {}
            _ => {
                return Err(bad(
                    ResponseProblem::Missing,
                    format!("no normal termination line in {}", TERMINATION_FILES.join(", ")),
                ));
            }
        }
        let read = |name: &str| -> Result<String, Outcome> {
            let path = dir.join(name);
            match std::fs::read(&path) {
                Ok(b) if b.is_empty() => Err(bad(ResponseProblem::Empty, format!("{name} is empty"))),
                Ok(b) => String::from_utf8(b).map_err(|_| {
                    bad(
                        ResponseProblem::Unparseable,
                        format!("{name} is not text (invalid UTF-8)"),
                    )
                }),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                    Err(bad(ResponseProblem::Missing, format!("{name} was not written")))
                }
                Err(e) => Err(bad(ResponseProblem::Missing, format!("{name}: {e}"))),
            }
        };
        let unparseable = |e: String| bad(ResponseProblem::Unparseable, e);
        let rc_text = read("rcforc")?;
        let rc = rcforc::parse(Path::new("rcforc"), &rc_text).map_err(|e| unparseable(e.to_string()))?;
        let nod_text = read("nodout")?;
        let nod = nodout::parse(Path::new("nodout"), &nod_text).map_err(|e| unparseable(e.to_string()))?;
        let curve = crush::from_lsdyna(&rc, &nod, &self.source).map_err(|e| unparseable(e.to_string()))?;
        let result = crush::crush_force(&curve, self.window).map_err(|e| unparseable(e.to_string()))?;
        if !result.mean_force.is_finite() {
            return Err(unparseable("the mean crush force is not finite".into()));
        }
        Ok(result.mean_force)
    }
}
