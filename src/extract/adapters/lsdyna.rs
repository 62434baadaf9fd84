//! The `lsdyna` adapter: an LS-DYNA style solver (LS-DYNA itself, or the `crushsim` stand-in)
//! judged by its time histories, from the ASCII files or from binout.
//!
//! - **Where each history is read**: from binout when the deck sends it there (the BINARY option
//!   of its `*DATABASE_...` card is 2 or 3) or when its ASCII file is absent and the run's binout
//!   (`binout`, or MPP's `binout0000…`, with continuation files) holds it; else from the ASCII
//!   file. Either way it becomes the same typed history, so the same checks, the same curve and
//!   the same quality figures follow. A binout that is cut (ends mid-record), broken (a bad
//!   record, named by offset) or missing a file of its set fails the run naming the file and the
//!   offset.
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
//! the rendered deck (which a replay renders again): messag, rcforc, nodout, glstat and the
//! binout files; a replay judges them with the same code, so replayed responses are
//! bit-identical to live ones.

use std::path::{Path, PathBuf};

use super::{deck_controls, file_name, incomplete};
use crate::error::InputError;
use crate::execute::adapter::{bad, read_output};
use crate::execute::{Adapter, Judged, Outcome, ResponseProblem, STDOUT_FILE};
use crate::extract::crush::{self, SimSource, Window};
use crate::extract::lsdyna::binout::{self, Binout, histories};
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
        let wall = s.rigid_wall.map_or_else(String::new, |id| format!(" rigid_wall {id}"));
        format!(
            "lsdyna/2 crush_force {}{wall}",
            serde_json::to_string(&parts).expect("settings serialize")
        )
    }

    fn outputs(&self) -> Vec<PathBuf> {
        ["messag", "rcforc", "nodout", "glstat"]
            .into_iter()
            .map(PathBuf::from)
            .chain(binout_files())
            .collect()
    }

    fn cleared(&self) -> Vec<PathBuf> {
        ["messag", "d3hsp", "rcforc", "nodout", "glstat"]
            .into_iter()
            .map(PathBuf::from)
            .chain(binout_files())
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
        let deck = deck_controls(dir, &self.deck, "output intervals are needed to check the outputs")?;
        let bin = open_binout(dir)?;
        let force = match self.source.rigid_wall {
            None => Force::Contact(self.rcforc(dir, &deck, bin.as_ref())?),
            Some(id) => Force::Wall(self.rwforc(dir, &deck, bin.as_ref(), id)?),
        };
        let nod = self.nodout(dir, &deck, bin.as_ref())?;
        let quality = self.glstat(dir, &deck, bin.as_ref())?;
        let curve = match &force {
            Force::Contact(rc) => crush::from_lsdyna(rc, &nod, &self.source),
            Force::Wall(w) => crush::from_wall(w, &nod, &self.source),
        };
        let curve = curve.map_err(|e| unparseable(e.to_string()))?;
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

/// Where the crush force comes from: a contact interface (rcforc) or a rigid wall (rwforc).
enum Force {
    Contact(rcforc::Rcforc),
    Wall(histories::WallSeries),
}

/// The binout file names recorded and cleared: SMP `binout` with continuation files, MPP
/// `binout0000…` (up to 16 processes, each with continuations).
fn binout_files() -> impl Iterator<Item = PathBuf> {
    let stems: Vec<String> = std::iter::once(binout::STEM.to_string())
        .chain((0..16).map(|k| format!("{}{k:04}", binout::STEM)))
        .collect();
    stems
        .into_iter()
        .flat_map(|s| std::iter::once(s.clone()).chain((1..10).map(move |k| format!("{s}%{k:03}"))))
        .map(PathBuf::from)
}

/// The run's binout, when it wrote one: a broken one, or one missing a file of its set, is a bad
/// response; one cut mid-record an incomplete output (both name the file and the offset).
fn open_binout(dir: &Path) -> Result<Option<Binout>, Outcome> {
    let bin = match binout::open_dir(dir) {
        Ok(b) => b,
        Err(e) if e.message.contains("missing from its set") => {
            return Err(Outcome::IncompleteOutput {
                file: e
                    .file
                    .file_name()
                    .map_or_else(|| e.file.display().to_string(), |n| n.to_string_lossy().into()),
                line: 0,
                detail: e.message,
            });
        }
        Err(e) => return Err(binout_error(dir, e)),
    };
    if let Some(note) = bin.as_ref().and_then(|b| b.db.notes().first()) {
        return Err(Outcome::IncompleteOutput {
            file: file_name(&note.file),
            line: 0,
            detail: format!("offset {}: {}", note.offset, note.detail),
        });
    }
    Ok(bin)
}

/// A broken binout as a bad response, its file named relative to the run directory (as the ASCII
/// files are: a replay judges in a scratch copy).
fn binout_error(dir: &Path, e: InputError) -> Outcome {
    let file = e.file.strip_prefix(dir).unwrap_or(&e.file).display().to_string();
    bad(ResponseProblem::Unparseable, format!("{file}: {}", e.message))
}

/// Where history `name` is read: from the binout (`Some`) when the deck sends it there, or its
/// ASCII file is absent and the binout holds it; else from its ASCII file (`None`). A history the
/// deck sends to binout only (BINARY 2) when no binout was written is a missing response.
fn binout_of<'b>(
    dir: &Path,
    deck: &controls::Controls,
    bin: Option<&'b Binout>,
    name: &str,
) -> Result<Option<&'b Binout>, Outcome> {
    let interval = deck.interval(name);
    match bin {
        Some(b)
            if interval.is_some_and(|i| i.to_binout())
                || (!dir.join(name).exists() && b.db.is_dir(&format!("/{name}"))) =>
        {
            Ok(Some(b))
        }
        None if interval.is_some_and(|i| i.binary == 2) => Err(bad(
            ResponseProblem::Missing,
            format!("binout was not written, though the deck sends {name} there (BINARY 2)"),
        )),
        _ => Ok(None),
    }
}

/// A binout history's completeness problem, its step ordinal turned into the step and offset.
fn binout_incomplete(b: &Binout, history: &str, i: Incomplete) -> Outcome {
    let place = histories::place(b, &format!("/{history}"), i.line);
    Outcome::IncompleteOutput {
        file: file_name(&b.name),
        line: 0,
        detail: format!("{history} {place}: {}", i.detail),
    }
}

/// How a history is checked for completeness, given its parse and its last line (ASCII) or its
/// number of output steps (binout).
type Check<'a, T> = &'a dyn Fn(&T, usize) -> Result<(), Incomplete>;

/// History `name` read from the binout by `read`, checked for completeness over its output steps.
fn binout_history<T>(
    dir: &Path,
    b: &Binout,
    name: &str,
    read: fn(&Binout) -> Result<Option<T>, InputError>,
    check: Check<T>,
) -> Result<T, Outcome> {
    let history = read(b).map_err(|e| binout_error(dir, e))?;
    let history = history.ok_or_else(|| missing_in_binout(b, name))?;
    check(&history, b.steps(&format!("/{name}")).len()).map_err(|i| binout_incomplete(b, name, i))?;
    Ok(history)
}

/// History `name` parsed from its ASCII file by `parse`, checked for a cut-off last line and for
/// completeness.
fn ascii_history<T>(
    dir: &Path,
    name: &str,
    parse: fn(&Path, &str) -> Result<T, InputError>,
    check: Check<T>,
) -> Result<T, Outcome> {
    let text = read(dir, name)?;
    let history = parse(Path::new(name), &text).map_err(|e| bad(ResponseProblem::Unparseable, e.to_string()))?;
    complete::ends_with_newline(name, &text).map_err(incomplete)?;
    check(&history, text.lines().count()).map_err(incomplete)?;
    Ok(history)
}

impl LsDynaAdapter {
    /// What the deck asks of history `name`: its interval and the termination time.
    fn want(deck: &controls::Controls, name: &str) -> Expected {
        Expected {
            dt: deck.interval(name).map(|i| i.dt),
            end_time: deck.end_time,
        }
    }

    /// rcforc, from binout or its ASCII file, checked for completeness.
    fn rcforc(&self, dir: &Path, deck: &controls::Controls, bin: Option<&Binout>) -> Result<rcforc::Rcforc, Outcome> {
        let want = Self::want(deck, "rcforc");
        let check = |rc: &rcforc::Rcforc, last| complete::rcforc(rc, want, last);
        match binout_of(dir, deck, bin, "rcforc")? {
            Some(b) => binout_history(dir, b, "rcforc", histories::rcforc, &check),
            None => ascii_history(dir, "rcforc", rcforc::parse, &check),
        }
    }

    /// Rigid wall `id`'s force history from binout's rwforc, its times checked against the deck's
    /// `*DATABASE_RWFORC` interval. (LS-DYNA's ASCII rwforc is not read: binout only.)
    fn rwforc(
        &self,
        dir: &Path,
        deck: &controls::Controls,
        bin: Option<&Binout>,
        id: u64,
    ) -> Result<histories::WallSeries, Outcome> {
        let Some(b) = bin else {
            let detail = if dir.join("rwforc").exists() {
                "the rigid-wall force is read from binout only: rwforc is ASCII; set BINARY = 2 or 3 on *DATABASE_RWFORC"
            } else {
                "no binout with rwforc (the rigid-wall force) was written"
            };
            return Err(bad(ResponseProblem::Missing, detail));
        };
        let rw = histories::rwforc(b).map_err(|e| binout_error(dir, e))?;
        let mut rw = rw.ok_or_else(|| missing_in_binout(b, "rwforc"))?;
        complete::times("rwforc", &rw.steps, Self::want(deck, "rwforc"), rw.steps.len())
            .map_err(|i| binout_incomplete(b, "rwforc/forces", i))?;
        rw.walls.remove(&id).ok_or_else(|| {
            let have: Vec<String> = rw.walls.keys().map(|k| k.to_string()).collect();
            bad(
                ResponseProblem::Unparseable,
                format!("binout rwforc has no rigid wall {id} (walls: {})", have.join(", ")),
            )
        })
    }

    /// nodout, from binout or its ASCII file, checked for completeness.
    fn nodout(&self, dir: &Path, deck: &controls::Controls, bin: Option<&Binout>) -> Result<nodout::Nodout, Outcome> {
        let want = Self::want(deck, "nodout");
        let check = |nod: &nodout::Nodout, last| complete::nodout(nod, &deck.history_nodes, want, last);
        match binout_of(dir, deck, bin, "nodout")? {
            Some(b) => binout_history(dir, b, "nodout", histories::nodout, &check),
            None => ascii_history(dir, "nodout", nodout::parse, &check),
        }
    }

    /// glstat checked for completeness, and its sanity figures; `None` when the deck does not ask
    /// for glstat and the solver wrote none.
    fn glstat(
        &self,
        dir: &Path,
        deck: &controls::Controls,
        bin: Option<&Binout>,
    ) -> Result<Option<quality::Quality>, Outcome> {
        let want = Self::want(deck, "glstat");
        let check = |gl: &glstat::Glstat, last| complete::glstat(gl, want, last);
        let gl = match binout_of(dir, deck, bin, "glstat")? {
            Some(b) => binout_history(dir, b, "glstat", histories::glstat, &check)?,
            None if !dir.join("glstat").exists() => {
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
            None => ascii_history(dir, "glstat", glstat::parse, &check)?,
        };
        Ok(Some(quality::figures(&gl)))
    }
}

/// A history the deck sends to binout but the binout lacks.
fn missing_in_binout(b: &Binout, history: &str) -> Outcome {
    Outcome::IncompleteOutput {
        file: file_name(&b.name),
        line: 0,
        detail: format!("no /{history} in the binout, though the deck sends {history} there (BINARY 2 or 3)"),
    }
}

/// An output file's text: missing, empty and non-UTF-8 files are bad responses.
fn read(dir: &Path, name: &str) -> Result<String, Outcome> {
    let bytes = read_output(dir, Path::new(name))?;
    if bytes.is_empty() {
        return Err(bad(ResponseProblem::Empty, format!("{name} is empty")));
    }
    String::from_utf8(bytes).map_err(|_| {
        bad(
            ResponseProblem::Unparseable,
            format!("{name} is not text (invalid UTF-8)"),
        )
    })
}
