//! Solver adapters: how a finished solver's outputs are judged.
//!
//! An adapter knows nothing about processes; the executor hands it the run directory after the
//! solver has exited with code 0 (or non-zero, for failure text). Its identity string is part of
//! every run key, so changing how outputs are judged reruns the runs.
//!
//! ```
//! use lab::execute::{Adapter, CommandAdapter};
//! let a = CommandAdapter::new("out.txt", r"tip = (\S+)", &[r"\*ERROR"]).unwrap();
//! let dir = tempfile::tempdir().unwrap();
//! std::fs::write(dir.path().join("out.txt"), "tip = 0.30472\n").unwrap();
//! assert_eq!(a.extract(dir.path()).unwrap(), 0.30472);
//! ```

use std::path::{Path, PathBuf};

use regex::Regex;

use super::{Outcome, Quality, ResponseProblem, STDERR_FILE, STDOUT_FILE};

/// A successful judgement: the response, the run's sanity figures when the adapter has them, and
/// the solver's warnings when it reports any (kept in the run's record and shown).
#[derive(Debug, Clone, PartialEq)]
pub struct Judged {
    pub response: f64,
    pub quality: Option<Quality>,
    pub warnings: Vec<String>,
}

/// How a solver's outputs are judged. Implementations must be pure functions of the run directory.
pub trait Adapter: Send + Sync {
    /// A stable string naming the adapter and every setting that changes its judgement.
    fn identity(&self) -> String;

    /// The first failure text found in the outputs, as an outcome (`Outcome::FailureText`).
    fn find_failure(&self, dir: &Path) -> Option<Outcome>;

    /// The response, or why it could not be read (an `Outcome::BadResponse`).
    fn extract(&self, dir: &Path) -> Result<f64, Outcome>;

    /// The response with the run's sanity figures (default: [`Adapter::extract`], no figures).
    fn judge(&self, dir: &Path) -> Result<Judged, Outcome> {
        self.extract(dir).map(|response| Judged {
            response,
            quality: None,
            warnings: Vec::new(),
        })
    }

    /// The output files (relative to the run directory) the judgement reads: what `--record`
    /// keeps and `--replay` serves.
    fn outputs(&self) -> Vec<PathBuf> {
        Vec::new()
    }

    /// Output files removed before each attempt (default: [`Adapter::outputs`]).
    fn cleared(&self) -> Vec<PathBuf> {
        self.outputs()
    }

    /// Files the solver writes that nothing reads (restart files), removed when an attempt ends
    /// (default: none).
    fn scratch(&self) -> Vec<PathBuf> {
        Vec::new()
    }

    /// What the executor runs after the study's command, with which environment and scratch files
    /// (OpenRadioss's engine after its starter; default: nothing).
    fn chain(&self) -> super::Chain {
        super::Chain::default()
    }
}

/// The `command` adapter: the response is the first capture group of `regex` in `response_file`;
/// failure patterns are searched line by line in the captured stdout and stderr and in the
/// response file.
#[derive(Debug, Clone)]
pub struct CommandAdapter {
    pub response_file: PathBuf,
    pub regex: Regex,
    pub failure_patterns: Vec<Regex>,
}

impl CommandAdapter {
    pub fn new(
        response_file: impl Into<PathBuf>,
        regex: &str,
        failure_patterns: &[&str],
    ) -> Result<Self, regex::Error> {
        let regex = crate::study::settings::response_regex(regex)?;
        let failure_patterns = failure_patterns
            .iter()
            .map(|p| Regex::new(p))
            .collect::<Result<_, _>>()?;
        Ok(CommandAdapter {
            response_file: response_file.into(),
            regex,
            failure_patterns,
        })
    }

    fn scanned_files(&self) -> [PathBuf; 3] {
        [
            PathBuf::from(STDOUT_FILE),
            PathBuf::from(STDERR_FILE),
            self.response_file.clone(),
        ]
    }
}

/// A response that could not be read, and why.
pub fn bad(problem: ResponseProblem, detail: impl Into<String>) -> Outcome {
    Outcome::BadResponse {
        problem,
        detail: detail.into(),
    }
}

/// A finished run's outputs judged: the first failure text found, else the adapter's judgement.
pub fn judge_outputs(adapter: &dyn Adapter, dir: &Path) -> (Outcome, Option<Judged>) {
    if let Some(failure) = adapter.find_failure(dir) {
        return (failure, None);
    }
    match adapter.judge(dir) {
        Ok(j) => (Outcome::Success, Some(j)),
        Err(outcome) => (outcome, None),
    }
}

/// The bytes of output file `rel` of the run in `dir`; a file that is not there (or cannot be
/// read) is a missing response.
pub fn read_output(dir: &Path, rel: &Path) -> Result<Vec<u8>, Outcome> {
    std::fs::read(dir.join(rel)).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => bad(ResponseProblem::Missing, format!("{} was not written", rel.display())),
        _ => bad(ResponseProblem::Missing, format!("{}: {e}", rel.display())),
    })
}

/// The first line of `files` (in the run directory `dir`, each read if it is there) that `is_failure`
/// says is a failure, as failure text (trimmed, at most 200 characters).
pub fn failure_line(dir: &Path, files: &[PathBuf], is_failure: impl Fn(&str) -> bool) -> Option<Outcome> {
    for rel in files {
        let Ok(bytes) = std::fs::read(dir.join(rel)) else {
            continue;
        };
        let text = String::from_utf8_lossy(&bytes);
        if let Some(line) = text.lines().find(|l| is_failure(l)) {
            return Some(Outcome::FailureText {
                file: rel.to_string_lossy().into_owned(),
                line: line.trim().chars().take(200).collect(),
            });
        }
    }
    None
}

impl Adapter for CommandAdapter {
    fn outputs(&self) -> Vec<PathBuf> {
        if self.failure_patterns.is_empty() {
            vec![self.response_file.clone()]
        } else {
            self.scanned_files().to_vec()
        }
    }

    fn cleared(&self) -> Vec<PathBuf> {
        vec![self.response_file.clone()]
    }

    fn identity(&self) -> String {
        // serde_json quotes each part, so no choice of strings can make two settings collide.
        let failures: Vec<&str> = self.failure_patterns.iter().map(Regex::as_str).collect();
        let parts = (self.response_file.to_string_lossy(), self.regex.as_str(), failures);
        format!(
            "command/1 {}",
            serde_json::to_string(&parts).expect("strings serialize")
        )
    }

    fn find_failure(&self, dir: &Path) -> Option<Outcome> {
        if self.failure_patterns.is_empty() {
            return None;
        }
        failure_line(dir, &self.scanned_files(), |line| {
            self.failure_patterns.iter().any(|p| p.is_match(line))
        })
    }

    fn extract(&self, dir: &Path) -> Result<f64, Outcome> {
        let name = self.response_file.display();
        let bytes = read_output(dir, &self.response_file)?;
        let text = String::from_utf8_lossy(&bytes);
        if text.trim().is_empty() {
            return Err(bad(ResponseProblem::Empty, format!("{name} is empty")));
        }
        let Some(caps) = self.regex.captures(&text) else {
            return Err(bad(
                ResponseProblem::Unparseable,
                format!("`{}` does not match {name}", self.regex),
            ));
        };
        let Some(m) = caps.get(1) else {
            return Err(bad(
                ResponseProblem::Unparseable,
                format!("`{}` matched {name} without its group", self.regex),
            ));
        };
        match m.as_str().trim().parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(bad(
                ResponseProblem::Unparseable,
                format!("`{}` in {name} is not a finite number", m.as_str()),
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn adapter() -> CommandAdapter {
        CommandAdapter::new("resp.txt", r"value\s*=\s*(\S+)", &[r"E r r o r"]).unwrap()
    }

    fn problem(r: Result<f64, Outcome>) -> ResponseProblem {
        match r {
            Err(Outcome::BadResponse { problem, .. }) => problem,
            other => panic!("expected a bad response, got {other:?}"),
        }
    }

    #[test]
    fn extracts_first_group_and_classifies_bad_responses() {
        let dir = tempfile::tempdir().unwrap();
        let a = adapter();
        assert_eq!(problem(a.extract(dir.path())), ResponseProblem::Missing);
        std::fs::write(dir.path().join("resp.txt"), " \n").unwrap();
        assert_eq!(problem(a.extract(dir.path())), ResponseProblem::Empty);
        std::fs::write(dir.path().join("resp.txt"), "garbage\n").unwrap();
        assert_eq!(problem(a.extract(dir.path())), ResponseProblem::Unparseable);
        std::fs::write(dir.path().join("resp.txt"), "value = abc\n").unwrap();
        assert_eq!(problem(a.extract(dir.path())), ResponseProblem::Unparseable);
        std::fs::write(dir.path().join("resp.txt"), "value = NaN\n").unwrap();
        assert_eq!(problem(a.extract(dir.path())), ResponseProblem::Unparseable);
        std::fs::write(dir.path().join("resp.txt"), "x\nvalue = -1.25e-3\nvalue = 9\n").unwrap();
        assert_eq!(a.extract(dir.path()).unwrap(), -1.25e-3);
    }

    #[test]
    fn failure_text_names_file_and_line() {
        let dir = tempfile::tempdir().unwrap();
        let a = adapter();
        std::fs::write(
            dir.path().join(STDOUT_FILE),
            "ok\n E r r o r    t e r m i n a t i o n\n",
        )
        .unwrap();
        match a.find_failure(dir.path()) {
            Some(Outcome::FailureText { file, line }) => {
                assert_eq!(file, STDOUT_FILE);
                assert!(line.starts_with("E r r o r"), "{line}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn regex_without_group_is_refused_and_identity_tracks_settings() {
        assert!(CommandAdapter::new("r", r"\d+", &[]).is_err());
        let a = CommandAdapter::new("r", r"(\d+)", &[]).unwrap();
        let b = CommandAdapter::new("r", r"(\d+)", &["x"]).unwrap();
        let c = CommandAdapter::new("s", r"(\d+)", &[]).unwrap();
        assert_ne!(a.identity(), b.identity());
        assert_ne!(a.identity(), c.identity());
        assert_eq!(
            a.identity(),
            CommandAdapter::new("r", r"(\d+)", &[]).unwrap().identity()
        );
    }
}
