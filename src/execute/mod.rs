//! The run engine: solver runs supervised on this machine, their results kept in a content-addressed
//! run store under `--out`.
//!
//! # Pieces
//!
//! - [`adapter`]: how a solver's outputs are judged (failure text, response extraction). The
//!   [`adapter::CommandAdapter`] reads the response from a file with a regex.
//! - [`store`]: the run store. A run's key is the hash of its rendered input files, its argv and the
//!   adapter identity; `OUT/runs/<key>/` is its work directory and `OUT/results/<key>.json` its
//!   committed record.
//! - [`lock`]: one `lab` per output directory (an `flock` that dies with its holder).
//! - [`executor`]: runs [`RunSpec`]s on tokio, at most `jobs` at once, and reports [`executor::Event`]s.
//! - [`progress`]: the reporter: a progress bar and the outcome summary, fed by the events.
//! - [`sweep`]: a solver study's plan rendered, keyed and run through the executor (`lab run`).
//!
//! # Design (after cargo-nextest's runner)
//!
//! The executor is a *dispatcher* plus one small task per run (a *unit*). The dispatcher owns the
//! concurrency limit and cancellation; it launches units while permits are free and stops launching
//! as soon as a cancel reason is set. Units talk to the outside only through messages: they send
//! events on a channel (the executor never prints; the reporter consumes the events) and read the
//! cancel reason from a watch channel. Nothing mutable is shared between units.
//!
//! Each attempt of a unit is a state machine that `select!`s over three things:
//!
//! ```text
//!             ┌──────── exit ─────────────────────────────► Exited(status) ──► judge ──► Outcome
//!  Running ───┼── timer (timeout) ─► SIGTERM to group ─► Terminating(Timeout) ─┐
//!             └── cancel ──────────► SIGTERM to group ─► Terminating(Cancel)  ─┤
//!                                                          grace timer ─► SIGKILL to group
//!                                                          exit ─► SIGKILL to group (mop-up) ─► Timeout / Cancelled
//! ```
//!
//! After an attempt: if its outcome class is in the retry policy and attempts remain, the unit waits
//! the backoff (cancellable) and tries again; otherwise it commits its [`RunRecord`] and then sends
//! `Finished`. A cancelled unit commits nothing.
//!
//! # Invariants
//!
//! - Every child runs from an argv (no shell) in its own process group (`setpgid(0, 0)`), so a
//!   signal to the group reaches its grandchildren too. Signals always go to the group, never to the
//!   leader alone; once a child has been signalled, its group is SIGKILLed when the leader exits so
//!   no straggler outlives the run.
//! - `Finished` is sent only after the record is durable (temp file, fsync, rename, fsync of the
//!   directory). A crash at any moment leaves either a complete record or none; a run directory
//!   without a record is half-done and is wiped and rerun when the store is next opened.
//! - Only successes count as finished: a failed record is kept (for `lab status`) but the run is
//!   attempted again on the next `lab run`.
//! - Cancel reasons are ordered ([`executor::CancelReason`]); a stronger one replaces a weaker one,
//!   never the reverse.
//! - Before each attempt the declared outputs and the captured stdout/stderr are removed, so an
//!   attempt is never judged by a previous attempt's files.

pub mod adapter;
pub mod executor;
pub mod lock;
pub mod progress;
pub mod quality;
pub mod replay;
pub mod slurm;
pub mod store;
pub mod sweep;

use std::path::PathBuf;
use std::time::Duration;

use serde::{Deserialize, Serialize};

pub use crate::study::settings::{Backoff, OutcomeClass, RetryPolicy};
pub use adapter::{Adapter, CommandAdapter, Judged};
pub use executor::{CancelReason, Canceller, Chain, Event, Executor, Summary, cancel_on_signals};
pub use lock::{Holder, LockError, OutLock};
pub use quality::Quality;
pub use store::RunStore;

/// The run store of `out` as `lab run` opens it: the directories of runs journaled as handed to
/// Slurm jobs are kept (the jobs may be using them), whichever executor this `lab run` uses.
pub fn open_store(out: &std::path::Path) -> Result<RunStore, store::StoreError> {
    RunStore::open_keeping(out, slurm::journaled_keys)
}

/// File (in the run directory) that receives the solver's standard output.
pub const STDOUT_FILE: &str = "lab.stdout";
/// File (in the run directory) that receives the solver's standard error.
pub const STDERR_FILE: &str = "lab.stderr";

/// One run to execute: where, what, and under which limits.
#[derive(Debug, Clone)]
pub struct RunSpec {
    /// The run's key in the store (see [`store::run_key`]).
    pub key: String,
    /// The work directory, already holding the rendered inputs. The solver runs with it as cwd.
    pub dir: PathBuf,
    /// The program and its arguments; `argv[0]` is looked up on `PATH`. Never passed to a shell.
    pub argv: Vec<String>,
    /// Wall-clock limit of one attempt; `None` means no limit.
    pub timeout: Option<Duration>,
    /// Output files (relative to `dir`) the solver writes; removed before each attempt.
    pub outputs: Vec<PathBuf>,
    pub retry: RetryPolicy,
}

/// What became of one attempt of a run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "class", rename_all = "snake_case")]
pub enum Outcome {
    Success,
    /// The solver exited with a non-zero code.
    NonZeroExit {
        code: i32,
    },
    /// An adapter-defined failure text was found in an output file.
    FailureText {
        file: String,
        line: String,
    },
    /// A history output parsed but is not complete: a gap in its times, an end short of the
    /// termination time, unpaired rcforc rows, a nodout block without a requested node, a
    /// cut-off last line. `line` is 1-based in `file`.
    IncompleteOutput {
        file: String,
        line: usize,
        detail: String,
    },
    /// The response was missing, empty or not a number.
    BadResponse {
        problem: ResponseProblem,
        detail: String,
    },
    /// The attempt ran past its timeout and was killed.
    Timeout,
    /// The solver was killed by a signal it did not get from us.
    Signal {
        signal: i32,
    },
    /// `--executor slurm`: the run's job was cancelled with scancel from `lab`'s Ctrl-C question
    /// before the run finished.
    Cancelled {
        job: String,
    },
    /// `--executor slurm`: the run's job vanished from every place Slurm reports jobs for longer
    /// than `slurm.lost_after`, without the run committing a record.
    Lost {
        job: String,
        detail: String,
    },
}

/// Why a response could not be read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ResponseProblem {
    Missing,
    Empty,
    Unparseable,
}

impl Outcome {
    pub fn class(&self) -> OutcomeClass {
        match self {
            Outcome::Success => OutcomeClass::Success,
            Outcome::NonZeroExit { .. } => OutcomeClass::NonZeroExit,
            Outcome::FailureText { .. } => OutcomeClass::FailureText,
            Outcome::BadResponse { .. } => OutcomeClass::BadResponse,
            Outcome::IncompleteOutput { .. } => OutcomeClass::IncompleteOutput,
            Outcome::Timeout => OutcomeClass::Timeout,
            Outcome::Signal { .. } => OutcomeClass::Signal,
            Outcome::Cancelled { .. } => OutcomeClass::Cancelled,
            Outcome::Lost { .. } => OutcomeClass::Lost,
        }
    }

    pub fn is_success(&self) -> bool {
        matches!(self, Outcome::Success)
    }
}

impl std::fmt::Display for Outcome {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Outcome::Success => write!(f, "success"),
            Outcome::NonZeroExit { code } => write!(f, "exit code {code}"),
            Outcome::FailureText { file, line } => write!(f, "failure text in {file}: {line}"),
            Outcome::BadResponse { problem, detail } => {
                let what = match problem {
                    ResponseProblem::Missing => "missing",
                    ResponseProblem::Empty => "empty",
                    ResponseProblem::Unparseable => "unparseable",
                };
                write!(f, "{what} response: {detail}")
            }
            // Line 0: about the whole file, or a binary file (whose detail names the offset).
            Outcome::IncompleteOutput { file, line: 0, detail } => write!(f, "incomplete output: {file}: {detail}"),
            Outcome::IncompleteOutput { file, line, detail } => {
                write!(f, "incomplete output: {file}:{line}: {detail}")
            }
            Outcome::Timeout => write!(f, "timeout"),
            Outcome::Signal { signal } => write!(f, "killed by signal {signal}"),
            Outcome::Cancelled { job } => write!(f, "cancelled with scancel (Slurm job {job})"),
            Outcome::Lost { detail, .. } => write!(f, "lost: {detail}"),
        }
    }
}

/// The committed result of a run: its last attempt's outcome and response.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    pub key: String,
    pub outcome: Outcome,
    /// Attempts made (1 when the first attempt was final).
    pub attempts: u32,
    /// Start of the first attempt, milliseconds since the Unix epoch.
    pub started_ms: u64,
    /// End of the last attempt, milliseconds since the Unix epoch.
    pub ended_ms: u64,
    /// The extracted response; `Some` exactly when the outcome is a success.
    pub response: Option<f64>,
    /// The run's physical-sanity figures (glstat energies), when its adapter reports them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub quality: Option<Quality>,
    /// The solver's warnings, when its adapter reports them (`openradioss`: each distinct warning
    /// of the starter's and the engine's listings, with its count).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

impl RunRecord {
    /// The record of a run that ended now after `attempts` attempts, with the response, figures
    /// and warnings of its judgement when it has one.
    pub fn ended(key: &str, outcome: Outcome, attempts: u32, started_ms: u64, judged: Option<Judged>) -> RunRecord {
        RunRecord {
            key: key.to_string(),
            outcome,
            attempts,
            started_ms,
            ended_ms: now_ms(),
            response: judged.as_ref().map(|j| j.response),
            quality: judged.as_ref().and_then(|j| j.quality),
            warnings: judged.map(|j| j.warnings).unwrap_or_default(),
        }
    }
}

/// Milliseconds since the Unix epoch (0 if the clock is before it).
pub(crate) fn now_ms() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}

impl RetryPolicy {
    /// Whether an attempt numbered `attempt` (from 1) that ended in `outcome` is tried again.
    pub fn retries(&self, attempt: u32, outcome: &Outcome) -> bool {
        !outcome.is_success() && attempt < self.max_attempts && self.retry_on.contains(&outcome.class())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exponential_backoff_doubles_then_caps() {
        let b = Backoff::Exponential {
            initial: Duration::from_millis(100),
            max: Duration::from_millis(350),
        };
        assert_eq!(b.delay(1), Duration::from_millis(100));
        assert_eq!(b.delay(2), Duration::from_millis(200));
        assert_eq!(b.delay(3), Duration::from_millis(350));
        assert_eq!(b.delay(40), Duration::from_millis(350));
    }

    #[test]
    fn retries_only_listed_classes_within_attempts() {
        let p = RetryPolicy {
            max_attempts: 3,
            retry_on: vec![OutcomeClass::NonZeroExit],
            backoff: Backoff::Fixed(Duration::ZERO),
        };
        let fail = Outcome::NonZeroExit { code: 1 };
        assert!(p.retries(1, &fail));
        assert!(p.retries(2, &fail));
        assert!(!p.retries(3, &fail));
        assert!(!p.retries(1, &Outcome::Timeout));
        assert!(!p.retries(1, &Outcome::Success));
    }

    #[test]
    fn outcome_serializes_with_its_class() {
        let o = Outcome::NonZeroExit { code: 3 };
        let text = serde_json::to_string(&o).unwrap();
        assert_eq!(text, r#"{"class":"non_zero_exit","code":3}"#);
        assert_eq!(serde_json::from_str::<Outcome>(&text).unwrap(), o);
    }
}
