//! The local executor: a dispatcher and one unit task per run (see the module note in `execute`).
//!
//! ```text
//! dispatcher: for each spec ── select!(biased) ─┬─ cancel set      → stop launching (rest: not started)
//!                                               ├─ a unit ended    → collect; a store error cancels the rest
//!                                               └─ permit free     → spawn unit(spec, permit)
//! unit:       attempt ─► judge ─► retry? ─ yes ─► Retrying, backoff (cancellable) ─► slot ─► attempt
//!                                        └ no ──► commit (durable) ─► Finished
//! ```
//!
//! A permit of the semaphore is a solver slot (`--jobs`): a unit holds it only while its solver's
//! process lives. Judging the outputs and the fsynced commit happen after the slot is given back,
//! so lab's bookkeeping never keeps a solver waiting (benches/engine/utilisation.sh).
//!
//! A solver that cannot be started (program not found, not executable) counts as exit code 127,
//! as a shell would report it, with the reason written to the run's `lab.stderr`.
//!
//! # Design note
//!
//! **States of a run here.**
//!
//! ```text
//! spec ─► waiting for a slot ─► attempt: Running ─► (Terminating ─► Killed) ─► judged ─┬─► committed ─► Finished
//!   │            │                                                                   └─► backoff ─► waiting for a slot
//!   └────────────┴──── cancel ──► not started / Cancelled (no record)
//! ```
//!
//! **Invariants.** The run directory exists (the store prepared it) before the spec arrives. At the
//! start of every attempt the declared outputs and `lab.stdout`/`lab.stderr` are removed, so an
//! outcome is judged only from this attempt's files. The record is committed (durable) before
//! `Finished` is sent, and nothing is committed for a cancelled unit. A slot is held only while
//! the solver's process lives. The dispatcher and the units share nothing mutable: units send
//! events and read the cancel reason.
//!
//! **What a kill leaves.** A cancel (Ctrl-C, SIGTERM, a store error) sends every running solver's
//! group SIGTERM, then SIGKILL after the grace period; its run directory stays without a
//! record and is rerun by the next `lab run`. A `lab` killed by SIGKILL runs no cleanup: its
//! solvers (in their own process groups) may outlive it and keep writing into directories without
//! records, which the next open of the store deletes. Committed records are never affected.
//!
//! **Why.** Judging after the slot is given back keeps the solvers' slots busy (the utilisation
//! benchmark); committing before reporting means what the reporter says is finished is finished on
//! disk; one process group per solver is the only way to stop its grandchildren too.

use std::io::Write;
use std::os::unix::process::ExitStatusExt;
use std::path::Path;
use std::process::{ExitStatus, Stdio};
use std::sync::Arc;
use std::time::Duration;

use nix::sys::signal::{Signal, killpg};
use nix::unistd::Pid;
use tokio::sync::{OwnedSemaphorePermit, Semaphore, mpsc, watch};
use tokio::task::JoinSet;
use tokio::time::Instant;

use super::adapter::{Adapter, judge_outputs};
use super::store::Committer;
use super::{Outcome, RunRecord, RunSpec, STDERR_FILE, STDOUT_FILE, now_ms};

/// Why the executor stops, weakest first. A stronger reason replaces a weaker one, never the reverse.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum CancelReason {
    /// A result could not be committed: going on would only lose more work.
    StoreError,
    /// Ctrl-C or SIGTERM (or a caller's request): stop launching; running children get SIGTERM,
    /// then SIGKILL after the grace period.
    Signal,
    /// A second Ctrl-C / SIGTERM: running children get SIGKILL at once.
    SecondSignal,
}

/// The sending side of cancellation; cheap to clone.
#[derive(Debug, Clone)]
pub struct Canceller {
    tx: Arc<watch::Sender<Option<CancelReason>>>,
}

impl Default for Canceller {
    fn default() -> Self {
        Canceller {
            tx: Arc::new(watch::Sender::new(None)),
        }
    }
}

impl Canceller {
    pub fn new() -> Self {
        Self::default()
    }

    /// Raises the cancel reason to `reason` unless a stronger one is already set.
    pub fn cancel(&self, reason: CancelReason) {
        self.tx.send_if_modified(|cur| {
            if cur.is_none_or(|c| reason > c) {
                *cur = Some(reason);
                true
            } else {
                false
            }
        });
    }

    pub fn reason(&self) -> Option<CancelReason> {
        *self.tx.borrow()
    }

    fn subscribe(&self) -> watch::Receiver<Option<CancelReason>> {
        self.tx.subscribe()
    }
}

/// Cancels on SIGINT and SIGTERM: the first as [`CancelReason::Signal`], any later one as
/// [`CancelReason::SecondSignal`]. Must be called inside a tokio runtime.
pub fn cancel_on_signals(canceller: Canceller) -> std::io::Result<tokio::task::JoinHandle<()>> {
    use tokio::signal::unix::{SignalKind, signal};
    let mut term = signal(SignalKind::terminate())?;
    let mut int = signal(SignalKind::interrupt())?;
    Ok(tokio::spawn(async move {
        let mut reason = CancelReason::Signal;
        loop {
            tokio::select! {
                _ = term.recv() => {}
                _ = int.recv() => {}
            }
            canceller.cancel(reason);
            reason = CancelReason::SecondSignal;
        }
    }))
}

/// Progress, for the reporter. Sent in order per run; runs interleave.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// Attempt `attempt` (from 1) of `key` is starting.
    Started { key: String, attempt: u32 },
    /// Attempt `attempt` ended in `outcome`; the next attempt starts after `delay`.
    Retrying {
        key: String,
        attempt: u32,
        outcome: Outcome,
        delay: Duration,
    },
    /// The run's record is committed (durable) — successful or not.
    Finished { record: RunRecord },
    /// The run was stopped by cancellation; nothing was committed for it.
    Cancelled { key: String },
}

/// What an executor pass did.
#[derive(Debug, Default)]
pub struct Summary {
    /// Records committed in this pass, in the order they were committed.
    pub records: Vec<RunRecord>,
    /// Set when the pass was cancelled.
    pub cancelled: Option<CancelReason>,
    /// Runs that were started and then stopped by cancellation (nothing committed).
    pub interrupted: Vec<String>,
    /// Runs never started because of cancellation.
    pub not_started: Vec<String>,
    /// Errors that are not outcomes of a run (a record that could not be committed).
    pub errors: Vec<String>,
}

/// Runs [`RunSpec`]s on this machine, at most `jobs` at once.
pub struct Executor {
    pub jobs: usize,
    /// Time between SIGTERM and SIGKILL to a run's process group.
    pub grace: Duration,
    pub adapter: Arc<dyn Adapter>,
    pub committer: Committer,
    pub canceller: Canceller,
    pub events: Option<mpsc::UnboundedSender<Event>>,
    /// What every run of this executor does besides its `argv` (default: nothing).
    pub chain: Chain,
}

/// The same for every run of a study: programs run after the spec's `argv` (OpenRadioss's engine
/// after its starter), environment variables for all of them, and files removed when an attempt
/// ends.
///
/// The programs run in order in the run directory, each in a process group of its own and with
/// its output appended to the attempt's `lab.stdout` / `lab.stderr`; the first that does not exit
/// 0 ends the attempt, which is judged with its status. The timeout counts from the first
/// program's start: it bounds the whole attempt. The run holds its slot until the last program
/// has exited.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Chain {
    pub then: Vec<Vec<String>>,
    /// Set on top of lab's own environment, for every program of the attempt.
    pub env: Vec<(String, String)>,
    /// Files (relative to the run directory) removed after the last program (restart files).
    pub scratch: Vec<std::path::PathBuf>,
}

struct Ctx {
    grace: Duration,
    /// Solver slots: one permit per running solver process.
    slots: Arc<Semaphore>,
    adapter: Arc<dyn Adapter>,
    committer: Committer,
    events: Option<mpsc::UnboundedSender<Event>>,
    chain: Chain,
}

impl Ctx {
    fn send(&self, event: Event) {
        if let Some(tx) = &self.events {
            let _ = tx.send(event); // a reporter that went away does not stop the runs
        }
    }
}

enum UnitEnd {
    Committed(RunRecord),
    Cancelled(String),
    Error(String),
}

impl Executor {
    pub fn new(jobs: usize, adapter: Arc<dyn Adapter>, committer: Committer) -> Self {
        Executor {
            jobs,
            grace: Duration::from_secs(5),
            adapter,
            committer,
            canceller: Canceller::new(),
            events: None,
            chain: Chain::default(),
        }
    }

    /// Runs every spec (unless cancelled) and returns what happened. Never prints.
    pub async fn run(&self, specs: Vec<RunSpec>) -> Summary {
        let permits = Arc::new(Semaphore::new(self.jobs.max(1)));
        let ctx = Arc::new(Ctx {
            grace: self.grace,
            slots: permits.clone(),
            adapter: self.adapter.clone(),
            committer: self.committer.clone(),
            events: self.events.clone(),
            chain: self.chain.clone(),
        });
        let mut cancel = self.canceller.subscribe();
        let mut units: JoinSet<UnitEnd> = JoinSet::new();
        let mut summary = Summary::default();
        let mut specs = specs.into_iter();

        'launch: while let Some(spec) = specs.next() {
            loop {
                tokio::select! {
                    biased;
                    _ = cancel.wait_for(Option::is_some) => {
                        summary.not_started.push(spec.key);
                        summary.not_started.extend(specs.by_ref().map(|s| s.key));
                        break 'launch;
                    }
                    Some(end) = units.join_next(), if !units.is_empty() => {
                        self.collect(end, &mut summary);
                    }
                    permit = permits.clone().acquire_owned() => {
                        let permit = permit.expect("the semaphore is never closed");
                        let (ctx, rx) = (ctx.clone(), self.canceller.subscribe());
                        units.spawn(unit(spec, permit, ctx, rx));
                        break;
                    }
                }
            }
        }
        while let Some(end) = units.join_next().await {
            self.collect(end, &mut summary);
        }
        summary.cancelled = self.canceller.reason();
        summary
    }

    fn collect(&self, end: Result<UnitEnd, tokio::task::JoinError>, summary: &mut Summary) {
        match end {
            Ok(UnitEnd::Committed(record)) => summary.records.push(record),
            Ok(UnitEnd::Cancelled(key)) => summary.interrupted.push(key),
            Ok(UnitEnd::Error(e)) => {
                summary.errors.push(e);
                self.canceller.cancel(CancelReason::StoreError);
            }
            Err(e) => {
                summary.errors.push(format!("a run task failed: {e}"));
                self.canceller.cancel(CancelReason::StoreError);
            }
        }
    }
}

async fn unit(
    spec: RunSpec,
    first_slot: OwnedSemaphorePermit,
    ctx: Arc<Ctx>,
    mut cancel: watch::Receiver<Option<CancelReason>>,
) -> UnitEnd {
    let started_ms = now_ms();
    let mut attempt = 1;
    let mut slot = Some(first_slot);
    loop {
        let held = match slot.take() {
            Some(s) => Some(s),
            None => tokio::select! {
                s = ctx.slots.clone().acquire_owned() => s.ok(),
                _ = cancel.wait_for(Option::is_some) => None,
            },
        };
        let Some(held) = held.filter(|_| cancel.borrow_and_update().is_none()) else {
            ctx.send(Event::Cancelled { key: spec.key.clone() });
            return UnitEnd::Cancelled(spec.key);
        };
        ctx.send(Event::Started {
            key: spec.key.clone(),
            attempt,
        });
        let (outcome, response) = match run_attempt(&spec, held, &ctx, &mut cancel).await {
            Attempt::Judged(outcome, response) => (outcome, response),
            Attempt::Cancelled => {
                ctx.send(Event::Cancelled { key: spec.key.clone() });
                return UnitEnd::Cancelled(spec.key);
            }
            Attempt::Error(e) => return UnitEnd::Error(format!("run {}: {e}", spec.key)),
        };
        if spec.retry.retries(attempt, &outcome) {
            let delay = spec.retry.backoff.delay(attempt);
            ctx.send(Event::Retrying {
                key: spec.key.clone(),
                attempt,
                outcome,
                delay,
            });
            tokio::select! {
                _ = tokio::time::sleep(delay) => {}
                _ = cancel.wait_for(Option::is_some) => {}  // the check at the loop's top reports it
            }
            attempt += 1;
            continue;
        }
        let record = RunRecord::ended(&spec.key, outcome, attempt, started_ms, response);
        let committer = ctx.committer.clone();
        let to_commit = record.clone();
        match tokio::task::spawn_blocking(move || committer.commit(&to_commit)).await {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return UnitEnd::Error(e.to_string()),
            Err(e) => return UnitEnd::Error(format!("commit task failed: {e}")),
        }
        ctx.send(Event::Finished { record: record.clone() });
        return UnitEnd::Committed(record);
    }
}

enum Attempt {
    Judged(Outcome, Option<super::Judged>),
    Cancelled,
    Error(String),
}

/// Why we signalled a child.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Why {
    Timeout,
    Cancel,
}

#[derive(Debug, Clone, Copy)]
enum Phase {
    Running,
    /// SIGTERM sent to the group; SIGKILL at `kill_at`.
    Terminating {
        why: Why,
        kill_at: Instant,
    },
    /// SIGKILL sent to the group; waiting for the leader to be reaped.
    Killed {
        why: Why,
    },
}

/// Kills the process group if dropped before the leader was reaped (the unit's future was dropped).
struct GroupGuard(Option<Pid>);

impl GroupGuard {
    fn signal(&self, signal: Signal) {
        if let Some(pgid) = self.0 {
            let _ = killpg(pgid, signal); // ESRCH: the group is already empty
        }
    }
}

impl Drop for GroupGuard {
    fn drop(&mut self) {
        self.signal(Signal::SIGKILL);
    }
}

fn remove_if_present(path: &Path) -> std::io::Result<()> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(e),
        _ => Ok(()),
    }
}

async fn sleep_until(at: Option<Instant>) {
    match at {
        Some(at) => tokio::time::sleep_until(at).await,
        None => std::future::pending().await,
    }
}

/// One attempt: start the solver (then each program of the chain while the last exited 0),
/// supervise it, give its slot back as soon as the last has exited, remove the scratch files, judge.
async fn run_attempt(
    spec: &RunSpec,
    slot: OwnedSemaphorePermit,
    ctx: &Ctx,
    cancel: &mut watch::Receiver<Option<CancelReason>>,
) -> Attempt {
    let deadline = spec.timeout.map(|t| Instant::now() + t);
    let programs = std::iter::once(&spec.argv).chain(&ctx.chain.then);
    let mut status = None;
    for (step, argv) in programs.enumerate() {
        let child = match start(spec, argv, &ctx.chain.env, step > 0) {
            Ok(child) => child,
            Err(attempt) => return *attempt,
        };
        let left = deadline.map(|d| d.saturating_duration_since(Instant::now()));
        match supervise_program(child, left, ctx.grace, cancel).await {
            Ok((s, None)) if s.success() => status = Some(s),
            Ok((s, None)) => {
                status = Some(s);
                break;
            }
            Ok((_, Some(Why::Cancel))) => return Attempt::Cancelled,
            Ok((_, Some(Why::Timeout))) => return Attempt::Judged(Outcome::Timeout, None),
            Err(e) => return Attempt::Error(format!("waiting for the solver: {e}")),
        }
    }
    drop(slot);
    for rel in &ctx.chain.scratch {
        let _ = remove_if_present(&spec.dir.join(rel)); // a left-over restart file harms no judgement
    }
    let Some(status) = status else {
        return Attempt::Error("no program to run".to_string());
    };
    let adapter = ctx.adapter.clone();
    let dir = spec.dir.clone();
    let judged = tokio::task::spawn_blocking(move || judge(status, adapter.as_ref(), &dir)).await;
    match judged {
        Ok((outcome, response)) => Attempt::Judged(outcome, response),
        Err(e) => Attempt::Error(format!("judging outputs: {e}")),
    }
}

/// Supervises one program of an attempt until it exits or is stopped: its exit status, and why it
/// was stopped (`None`: it exited on its own).
async fn supervise_program(
    mut child: tokio::process::Child,
    timeout: Option<Duration>,
    grace: Duration,
    cancel: &mut watch::Receiver<Option<CancelReason>>,
) -> std::io::Result<(ExitStatus, Option<Why>)> {
    let group = GroupGuard(child.id().map(|pid| Pid::from_raw(pid as i32)));
    let (status, phase) = supervise(&mut child, &group, timeout, grace, cancel).await;
    let mut group = group;
    let why = match phase {
        Phase::Running => None,
        Phase::Terminating { why, .. } | Phase::Killed { why } => {
            // The leader is gone; anything left in its group dies now, not after the grace period.
            group.signal(Signal::SIGKILL);
            Some(why)
        }
    };
    group.0 = None;
    Ok((status?, why))
}

/// Clears what a previous attempt left (declared outputs, captured stdout/stderr) and starts the
/// solver in the run directory, in a process group of its own; a later program of the chain
/// (`append`) appends to the attempt's stdout/stderr instead. A solver that cannot be started is
/// judged at once (exit code 127, as a shell reports it).
fn start(
    spec: &RunSpec,
    argv: &[String],
    env: &[(String, String)],
    append: bool,
) -> Result<tokio::process::Child, Box<Attempt>> {
    let dir = &spec.dir;
    if !append {
        for rel in spec
            .outputs
            .iter()
            .map(|p| p.as_path())
            .chain([Path::new(STDOUT_FILE), Path::new(STDERR_FILE)])
        {
            if let Err(e) = remove_if_present(&dir.join(rel)) {
                return Err(Box::new(Attempt::Error(format!(
                    "removing {}: {e}",
                    dir.join(rel).display()
                ))));
            }
        }
    }
    let open = |name: &str| {
        std::fs::OpenOptions::new()
            .create(true)
            .append(append)
            .write(true)
            .truncate(!append)
            .open(dir.join(name))
    };
    let (stdout, stderr) = match (open(STDOUT_FILE), open(STDERR_FILE)) {
        (Ok(o), Ok(e)) => (o, e),
        (Err(e), _) | (_, Err(e)) => return Err(Box::new(Attempt::Error(format!("{}: {e}", dir.display())))),
    };
    let Some((program, args)) = argv.split_first() else {
        return Err(Box::new(Attempt::Error("empty argv".to_string())));
    };
    let mut command = tokio::process::Command::new(program);
    command
        .args(args)
        .envs(env.iter().map(|(k, v)| (k, v)))
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(stdout)
        .stderr(stderr)
        .process_group(0);
    match command.spawn() {
        Ok(c) => Ok(c),
        Err(e) => {
            if let Ok(mut f) = open(STDERR_FILE) {
                let _ = writeln!(f, "lab: cannot start `{program}`: {e}");
            }
            Err(Box::new(Attempt::Judged(Outcome::NonZeroExit { code: 127 }, None)))
        }
    }
}

/// Waits for the solver to exit: on timeout or cancel its group gets SIGTERM, then SIGKILL after
/// the grace period (at once on a second signal). Returns its exit status and the phase it ended
/// in: `Running` when it exited on its own, else it was stopped (and the phase says why).
async fn supervise(
    child: &mut tokio::process::Child,
    group: &GroupGuard,
    timeout: Option<Duration>,
    grace: Duration,
    cancel: &mut watch::Receiver<Option<CancelReason>>,
) -> (std::io::Result<ExitStatus>, Phase) {
    let deadline = timeout.map(|t| Instant::now() + t);
    let mut phase = Phase::Running;
    let mut cancel_open = true;
    // Cancellation already requested before this point is seen by the first `borrow`.
    let mut pending_cancel = cancel.borrow_and_update().is_some();
    let status: std::io::Result<ExitStatus> = loop {
        if std::mem::take(&mut pending_cancel) {
            phase = on_cancel(phase, *cancel.borrow(), group, grace);
        }
        let timer = match phase {
            Phase::Running => deadline,
            Phase::Terminating { kill_at, .. } => Some(kill_at),
            Phase::Killed { .. } => None,
        };
        tokio::select! {
            status = child.wait() => break status,
            _ = sleep_until(timer) => {
                phase = match phase {
                    Phase::Running => {
                        group.signal(Signal::SIGTERM);
                        Phase::Terminating { why: Why::Timeout, kill_at: Instant::now() + grace }
                    }
                    Phase::Terminating { why, .. } | Phase::Killed { why } => {
                        group.signal(Signal::SIGKILL);
                        Phase::Killed { why }
                    }
                };
            }
            changed = cancel.changed(), if cancel_open => {
                match changed {
                    Ok(()) => pending_cancel = cancel.borrow_and_update().is_some(),
                    Err(_) => cancel_open = false,
                }
            }
        }
    };
    (status, phase)
}

/// The next phase after a cancel request of strength `reason`.
fn on_cancel(phase: Phase, reason: Option<CancelReason>, group: &GroupGuard, grace: Duration) -> Phase {
    let Some(reason) = reason else { return phase };
    match phase {
        _ if reason >= CancelReason::SecondSignal => {
            group.signal(Signal::SIGKILL);
            Phase::Killed { why: Why::Cancel }
        }
        Phase::Running => {
            group.signal(Signal::SIGTERM);
            Phase::Terminating {
                why: Why::Cancel,
                kill_at: Instant::now() + grace,
            }
        }
        // Already being stopped (timeout): it ends as it was going to; it is not retried (the
        // unit checks the cancel reason before every attempt).
        other => other,
    }
}

/// Classifies an exited attempt. Order: signal, failure text, exit code, response.
/// Failure text comes before the exit code because it says more, and because some solvers exit 0
/// after an error (the exit code is not a reliable signal).
fn judge(status: ExitStatus, adapter: &dyn Adapter, dir: &Path) -> (Outcome, Option<super::Judged>) {
    if let Some(signal) = status.signal() {
        return (Outcome::Signal { signal }, None);
    }
    match status.code() {
        Some(0) => judge_outputs(adapter, dir),
        code => {
            let exit = Outcome::NonZeroExit {
                code: code.unwrap_or(-1),
            };
            (adapter.find_failure(dir).unwrap_or(exit), None)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stronger_cancel_reason_replaces_weaker_never_the_reverse() {
        let c = Canceller::new();
        assert_eq!(c.reason(), None);
        c.cancel(CancelReason::Signal);
        c.cancel(CancelReason::StoreError);
        assert_eq!(c.reason(), Some(CancelReason::Signal));
        c.cancel(CancelReason::SecondSignal);
        c.cancel(CancelReason::Signal);
        assert_eq!(c.reason(), Some(CancelReason::SecondSignal));
    }
}
