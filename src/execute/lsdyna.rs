//! The `lsdyna` adapter: an LS-DYNA style solver (LS-DYNA itself, or the `crushsim` stand-in)
//! judged by its ASCII outputs.
//!
//! - **Failure text**: an ` E r r o r    t e r m i n a t i o n` line in messag, d3hsp or the
//!   captured stdout ([`crate::extract::lsdyna::termination`]) → `Outcome::FailureText`.
//! - **Success** needs exit code 0 (checked by the executor), the normal-termination line in one of
//!   those files (its absence is a missing response: the solver did not finish), the declared
//!   outputs (rcforc, nodout; glstat when the deck asks for it) present and parseable, and each of
//!   them complete against what the run's main deck asks ([`crate::extract::lsdyna::controls`],
//!   [`crate::extract::lsdyna::complete`]): otherwise `Outcome::IncompleteOutput` with the file,
//!   the line and what is missing.
//! - **Response**: the mean crush force (kN) = absorbed energy / stroke over the stroke window,
//!   from the contact resultant of one rcforc interface side and axis and the striker node's
//!   displacement in nodout ([`crate::extract::crush`]).
//! - **Sanity figures**: hourglass ratio, energy error and added mass from glstat
//!   ([`crate::extract::lsdyna::quality`]), kept in the run's record; the study's gates flag
//!   a run `suspect` from them later, without rerunning it.
//!
//! The recorded outputs ([`Adapter::outputs`]) are exactly the files this judgement reads besides
//! the rendered deck (which a replay renders again): messag, rcforc, nodout and glstat; a replay
//! judges them with the same code, so replayed responses are bit-identical to live ones.

use std::path::{Path, PathBuf};

use super::{Adapter, Judged, Outcome, ResponseProblem, STDOUT_FILE};
use crate::extract::crush::{self, SimSource, Window};
use crate::extract::lsdyna::complete::{self, Expected, Incomplete};
use crate::extract::lsdyna::{controls, glstat, nodout, quality, rcforc, termination};

/// Files scanned for the termination line, in order.
pub const TERMINATION_FILES: [&str; 3] = ["messag", "d3hsp", STDOUT_FILE];

/// The `lsdyna` adapter's settings.
#[derive(Debug, Clone)]
pub struct LsDynaAdapter {
    pub window: Window,
    pub source: SimSource,
    /// The main deck, relative to the run directory (the first template, rendered): where the
    /// termination time and output intervals are read.
    pub deck: PathBuf,
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
            self.deck.to_string_lossy(),
        );
        format!(
            "lsdyna/2 crush_force {}",
            serde_json::to_string(&parts).expect("settings serialize")
        )
    }

    fn outputs(&self) -> Vec<PathBuf> {
        ["messag", "rcforc", "nodout", "glstat"]
            .into_iter()
            .map(PathBuf::from)
            .collect()
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
        self.judge(dir).map(|j| j.response)
    }

    fn judge(&self, dir: &Path) -> Result<Judged, Outcome> {
        match self.termination(dir) {
            Some((_, termination::Termination::Normal(_))) => {}
            _ => {
                return Err(bad(
                    ResponseProblem::Missing,
                    format!("no normal termination line in {}", TERMINATION_FILES.join(", ")),
                ));
            }
        }
        let unparseable = |e: String| bad(ResponseProblem::Unparseable, e);
        let rc_text = read(dir, "rcforc")?;
        let rc = rcforc::parse(Path::new("rcforc"), &rc_text).map_err(|e| unparseable(e.to_string()))?;
        let nod_text = read(dir, "nodout")?;
        let nod = nodout::parse(Path::new("nodout"), &nod_text).map_err(|e| unparseable(e.to_string()))?;
        let deck = self.controls(dir)?;
        let want = |file: &str| Expected {
            dt: deck.interval(file).map(|i| i.dt),
            end_time: deck.end_time,
        };
        complete::ends_with_newline("rcforc", &rc_text).map_err(incomplete)?;
        complete::rcforc(&rc, want("rcforc"), rc_text.lines().count()).map_err(incomplete)?;
        complete::ends_with_newline("nodout", &nod_text).map_err(incomplete)?;
        complete::nodout(&nod, &deck.history_nodes, want("nodout"), nod_text.lines().count()).map_err(incomplete)?;
        let quality = self.glstat(dir, &deck, want("glstat"))?;
        let curve = crush::from_lsdyna(&rc, &nod, &self.source).map_err(|e| unparseable(e.to_string()))?;
        let result = crush::crush_force(&curve, self.window).map_err(|e| unparseable(e.to_string()))?;
        if !result.mean_force.is_finite() {
            return Err(unparseable("the mean crush force is not finite".into()));
        }
        Ok(Judged {
            response: result.mean_force,
            quality,
            warnings: Vec::new(),
        })
    }
}

impl LsDynaAdapter {
    /// What the run's main deck asks of its outputs.
    fn controls(&self, dir: &Path) -> Result<controls::Controls, Outcome> {
        let path = dir.join(&self.deck);
        if !path.is_file() {
            return Err(bad(
                ResponseProblem::Missing,
                format!(
                    "the deck {} is not in the run directory: its termination time and output intervals are needed to check the outputs",
                    self.deck.display()
                ),
            ));
        }
        controls::read(&path).map_err(|e| bad(ResponseProblem::Unparseable, format!("the deck: {e}")))
    }

    /// glstat checked for completeness, and its sanity figures; `None` when the deck does not ask
    /// for glstat and the solver wrote none.
    fn glstat(
        &self,
        dir: &Path,
        deck: &controls::Controls,
        want: Expected,
    ) -> Result<Option<quality::Quality>, Outcome> {
        if !dir.join("glstat").exists() {
            return match deck.glstat {
                None => Ok(None),
                Some(asked) => Err(incomplete(Incomplete {
                    file: "glstat".into(),
                    line: 0,
                    detail: format!(
                        "not written, though *DATABASE_GLSTAT at {} line {} asks for it",
                        self.deck.display(),
                        asked.line
                    ),
                })),
            };
        }
        let text = read(dir, "glstat")?;
        let gl =
            glstat::parse(Path::new("glstat"), &text).map_err(|e| bad(ResponseProblem::Unparseable, e.to_string()))?;
        complete::ends_with_newline("glstat", &text).map_err(incomplete)?;
        complete::glstat(&gl, want, text.lines().count()).map_err(incomplete)?;
        Ok(Some(quality::figures(&gl)))
    }
}

fn incomplete(i: Incomplete) -> Outcome {
    Outcome::IncompleteOutput {
        file: i.file,
        line: i.line,
        detail: i.detail,
    }
}

/// An output file's text: missing, empty and non-UTF-8 files are bad responses.
fn read(dir: &Path, name: &str) -> Result<String, Outcome> {
    match std::fs::read(dir.join(name)) {
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
}
