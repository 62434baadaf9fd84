//! The Slurm executor (`lab run --executor slurm`).
//!
//! - this module: submitting (journal before sbatch), watching and re-attaching;
//! - [`lost`]: when a job that every Slurm source has forgotten is given up;
//! - [`interrupt`]: Ctrl-C — the question whether to leave the jobs running or scancel them.
//!
//! # Design note
//!
//! **States of a run handed to Slurm.**
//!
//! ```text
//! prepared ─► journaled (entry without id) ─sbatch─► journaled with id ─► running in the job
//!     ─► committed by `lab slurm-worker` ─► collected by the submitting lab (all of a job's runs:
//!        entry removed)
//! a job that ends without a run's record ─► that run gets Slurm's outcome (timeout, cancelled, ...)
//! a job no Slurm source knows for `lost_after` ─► its unrecorded runs get `lost` (see [`lost`])
//! ```
//!
//! **Invariants.** The journal entry (`OUT/slurm/<token>.json`) is written before sbatch, so every
//! job this `lab` may have submitted is on disk: by id, or by its name `lab-<token>` when `lab`
//! died between sbatch and writing the id. The run directories of journaled keys are claimed:
//! the store keeps them when it opens ([`crate::execute::open_store`]). Records are committed by
//! the worker inside the job with the store's atomic commit, without the lock; the submitting
//! `lab` only reads them (a record older than the job's submission is not this job's). A local
//! `lab run` refuses to run while the journal lists jobs.
//!
//! **What a kill leaves.** Killing the submitting `lab` at any moment leaves the jobs running and
//! the journal naming them; the next `lab run --executor slurm` re-attaches instead of submitting
//! twice, and drops an entry that never reached Slurm. Ctrl-C asks whether to leave or scancel
//! the jobs ([`interrupt`]). A worker killed with its job leaves run directories without records;
//! the job's end gives those runs Slurm's outcome, and the next `lab run` runs them again.
//!
//! **Why.** Slurm's own state is not durable enough to re-attach from (squeue and scontrol forget
//! a job after MinJobAge; the jobcomp file may rotate), so `lab` keeps its own journal, written
//! first; and the executor, not the store, owns it, so the store stays unaware of Slurm.

pub mod interrupt;
pub mod lost;

// ---------------------------------------------------------------------------------------------
// The executor.
//
// ```text
// OUT/slurm/<token>.json   journal entry of one job: {token, job_id, keys, submitted_ms}
// OUT/slurm/<token>.sh     the job's batch script (kept): `lab slurm-worker ... KEY...`
// OUT/slurm/<token>.out    the job's stdout/stderr (Slurm --output)
// OUT/runs/<key>/lab.job.sh  the run's own script (kept): the same worker for that one key
// ```
//
// A job's runs are executed inside the job by `lab slurm-worker`, which runs them with the local
// executor (same process groups, timeouts, retries, adapter checks) and commits their records
// into OUT/results atomically. The submitting `lab` only watches: it polls the job's state and the
// records. The journal entry is written *before* sbatch (without an id; the job is named
// `lab-<token>`), then again with the id: a `lab` killed at any moment finds every job it may have
// submitted, by id or by name, and re-attaches instead of submitting twice. Run directories of
// journaled keys are kept when the store is opened. An entry is removed once all its runs have
// records.
// ---------------------------------------------------------------------------------------------

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use super::store::{RESULTS_DIR, write_atomic};
use super::{Canceller, Outcome, RunRecord, RunStore, now_ms};
use crate::error::Error;
pub use crate::study::settings::{DEFAULT_LOST_AFTER, SlurmSettings};

/// Directory (under `--out`) of the journal and the batch scripts.
pub const SLURM_DIR: &str = "slurm";
/// The run's own job script, in its run directory.
pub const RUN_SCRIPT: &str = "lab.job.sh";

/// One submitted job, as journaled.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct JobEntry {
    pub token: String,
    /// `None` between the journal write and sbatch's answer.
    pub job_id: Option<String>,
    pub keys: Vec<String>,
    pub submitted_ms: u64,
}

fn journal_dir(out: &Path) -> PathBuf {
    out.join(SLURM_DIR)
}

/// Live journal entries of `out` (unreadable entries are skipped).
pub fn journal(out: &Path) -> Vec<JobEntry> {
    let Ok(entries) = std::fs::read_dir(journal_dir(out)) else {
        return Vec::new();
    };
    let mut jobs: Vec<JobEntry> = entries
        .filter_map(|e| e.ok())
        .filter(|e| e.path().extension().is_some_and(|x| x == "json"))
        .filter_map(|e| serde_json::from_slice(&std::fs::read(e.path()).ok()?).ok())
        .collect();
    jobs.sort_by_key(|j| j.submitted_ms);
    jobs
}

/// Keys of runs journaled as submitted to Slurm: their run directories must be kept.
pub fn journaled_keys(out: &Path) -> BTreeSet<String> {
    journal(out).into_iter().flat_map(|j| j.keys).collect()
}

fn write_entry(out: &Path, entry: &JobEntry) -> Result<(), Error> {
    let path = journal_dir(out).join(format!("{}.json", entry.token));
    write_atomic(&path, &serde_json::to_vec_pretty(entry).expect("entries serialize"))
        .map_err(|e| Error::Failed(format!("{}: {e}", path.display())))
}

fn remove_entry(out: &Path, token: &str) {
    let _ = std::fs::remove_file(journal_dir(out).join(format!("{token}.json")));
}

/// POSIX-shell single quoting.
fn quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

/// A Slurm command's stdout, or why it failed.
fn slurm_cmd(program: &str, args: &[&str]) -> Result<String, String> {
    let out = Command::new(program)
        .args(args)
        .output()
        .map_err(|e| format!("cannot run `{program}`: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "`{program} {}`: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// A job's state as Slurm says it, and its exit code when given.
#[derive(Debug, Clone, PartialEq)]
pub struct JobState {
    pub state: String,
    pub exit_code: Option<i32>,
}

impl JobState {
    pub fn is_final(&self) -> bool {
        !matches!(
            self.state.as_str(),
            "PENDING"
                | "RUNNING"
                | "CONFIGURING"
                | "COMPLETING"
                | "SUSPENDED"
                | "REQUEUED"
                | "RESIZING"
                | "STAGE_OUT"
                | "SIGNALING"
                | "REQUEUE_HOLD"
                | "REQUEUE_FED"
                | "RESV_DEL_HOLD"
                | "STOPPED"
        )
    }
}

fn field<'a>(line: &'a str, name: &str) -> Option<&'a str> {
    line.split_whitespace()
        .find_map(|t| t.strip_prefix(name)?.strip_prefix('='))
}

/// The jobcomp file's path, from `scontrol show config` (JobCompLoc).
fn jobcomp_file() -> Option<PathBuf> {
    let config = slurm_cmd("scontrol", &["show", "config"]).ok()?;
    config.lines().find_map(|l| {
        let (k, v) = l.split_once('=')?;
        (k.trim() == "JobCompLoc").then(|| PathBuf::from(v.trim()))
    })
}

/// What one poll of Slurm learnt about a set of jobs.
#[derive(Debug, Default)]
pub struct Poll {
    /// The jobs some source knows; ids no source knows are left out.
    pub states: BTreeMap<String, JobState>,
    /// Whether squeue answered (with the jobs, or that it does not know them): without an answer
    /// a job's absence means nothing (see [`lost`]).
    pub answered: bool,
}

/// Whether a failed squeue still answered: for a single unknown id it exits 1 with "Invalid job id
/// specified"; anything else (no controller, no config) is no answer.
fn squeue_answered(result: &Result<String, String>) -> bool {
    match result {
        Ok(_) => true,
        Err(e) => e.contains("Invalid job id"),
    }
}

/// States of `ids`: `squeue -h -t all`, then `scontrol -o show job`, then the jobcomp record
/// (after MinJobAge the first two forget the job).
pub fn job_states(ids: &[String]) -> Poll {
    let mut poll = Poll::default();
    if ids.is_empty() {
        poll.answered = true;
        return poll;
    }
    let squeue = slurm_cmd("squeue", &["-h", "-t", "all", "-j", &ids.join(","), "-o", "%i %T"]);
    poll.answered = squeue_answered(&squeue);
    if let Ok(text) = squeue {
        for line in text.lines() {
            if let Some((id, state)) = line.trim().split_once(' ') {
                poll.states.insert(
                    id.to_string(),
                    JobState {
                        state: state.trim().to_string(),
                        exit_code: None,
                    },
                );
            }
        }
    }
    let mut jobcomp: Option<String> = None;
    for id in ids {
        let known = poll.states.get(id).cloned();
        if known.as_ref().is_some_and(|s| !s.is_final()) {
            continue;
        }
        // Final (or unknown to squeue): the exit code from scontrol, or the jobcomp record.
        let line = slurm_cmd("scontrol", &["-o", "show", "job", id])
            .ok()
            .filter(|l| field(l, "JobState").is_some());
        let line = line.or_else(|| {
            let text = jobcomp.get_or_insert_with(|| {
                jobcomp_file()
                    .and_then(|p| std::fs::read_to_string(p).ok())
                    .unwrap_or_default()
            });
            text.lines()
                .rev()
                .find(|l| field(l, "JobId") == Some(id.as_str()))
                .map(str::to_string)
        });
        if let Some(line) = line {
            let state = field(&line, "JobState").unwrap_or("UNKNOWN").to_string();
            let exit_code = field(&line, "ExitCode").and_then(|c| c.split(':').next()?.parse().ok());
            poll.states.insert(id.clone(), JobState { state, exit_code });
        }
    }
    poll
}

/// The id of the job named `lab-<token>`, if Slurm (or its jobcomp record) knows one.
fn find_by_name(token: &str) -> Option<String> {
    let name = format!("lab-{token}");
    if let Ok(text) = slurm_cmd("squeue", &["-h", "-t", "all", "-n", &name, "-o", "%i"])
        && let Some(id) = text.split_whitespace().next()
    {
        return Some(id.to_string());
    }
    let text = std::fs::read_to_string(jobcomp_file()?).ok()?;
    text.lines()
        .rev()
        .find(|l| field(l, "Name") == Some(name.as_str()))
        .and_then(|l| field(l, "JobId"))
        .map(str::to_string)
}

/// What `lab` runs inside a job: `lab slurm-worker --study S --out O --jobs N KEY...`.
fn worker_argv(study: &Path, out: &Path, jobs: u32, keys: &[String]) -> Result<Vec<String>, Error> {
    let lab = std::env::current_exe().map_err(|e| Error::Failed(format!("cannot find the lab binary: {e}")))?;
    let mut argv = vec![
        lab.display().to_string(),
        "slurm-worker".into(),
        "--study".into(),
        study.display().to_string(),
        "--out".into(),
        out.display().to_string(),
        "--jobs".into(),
        jobs.to_string(),
    ];
    argv.extend(keys.iter().cloned());
    Ok(argv)
}

/// Writes a shell script at `path` that runs `argv` (each argument quoted), with `comment` on top.
fn write_script(path: &Path, comment: &str, argv: &[String]) -> Result<(), Error> {
    let line: Vec<String> = argv.iter().map(|a| quote(a)).collect();
    let text = format!("#!/bin/sh\n# {comment}\nexec {}\n", line.join(" "));
    std::fs::write(path, text).map_err(|e| Error::Failed(format!("{}: {e}", path.display())))
}

fn make_token(keys: &[String]) -> String {
    let mut h = blake3::Hasher::new();
    h.update(&now_ms().to_le_bytes());
    h.update(&std::process::id().to_le_bytes());
    for k in keys {
        h.update(k.as_bytes());
    }
    h.finalize().to_hex()[..12].to_string()
}

/// Writes the scripts, journals the job, submits it; the journal entry (with its id).
fn submit(
    settings: &SlurmSettings,
    study: &Path,
    out: &Path,
    store: &RunStore,
    keys: Vec<String>,
) -> Result<JobEntry, Error> {
    let token = make_token(&keys);
    for key in &keys {
        let argv = worker_argv(study, out, 1, std::slice::from_ref(key))?;
        let comment = format!("lab: run {key} (submitted in Slurm job lab-{token}); run by hand: sh {RUN_SCRIPT}");
        write_script(&store.run_dir(key).join(RUN_SCRIPT), &comment, &argv)?;
    }
    let dir = journal_dir(out);
    let batch = dir.join(format!("{token}.sh"));
    let comment = format!("lab: Slurm job lab-{token}, {} run(s)", keys.len());
    write_script(&batch, &comment, &worker_argv(study, out, settings.cpus, &keys)?)?;
    let mut entry = JobEntry {
        token: token.clone(),
        job_id: None,
        keys,
        submitted_ms: now_ms(),
    };
    write_entry(out, &entry)?; // before sbatch: a lab killed now finds the job by its name
    let mut args: Vec<String> = vec![
        "--parsable".into(),
        format!("--job-name=lab-{token}"),
        format!("--chdir={}", dir.display()),
        format!("--output={}", dir.join(format!("{token}.out")).display()),
        format!("--cpus-per-task={}", settings.cpus),
        "--ntasks=1".into(),
    ];
    if let Some(p) = &settings.partition {
        args.push(format!("--partition={p}"));
    }
    if let Some(t) = settings.time_limit_minutes {
        args.push(format!("--time={t}"));
    }
    if let Some(m) = settings.memory_mb {
        args.push(format!("--mem={m}M"));
    }
    args.extend(settings.options.iter().cloned());
    args.push(batch.display().to_string());
    let arg_refs: Vec<&str> = args.iter().map(String::as_str).collect();
    match slurm_cmd("sbatch", &arg_refs) {
        Ok(text) => {
            // --parsable: `id` or `id;cluster`.
            let id = text.trim().split(';').next().unwrap_or_default().to_string();
            entry.job_id = Some(id);
            write_entry(out, &entry)?;
            Ok(entry)
        }
        Err(e) => {
            remove_entry(out, &token);
            Err(Error::Failed(format!("submitting to Slurm: {e}")))
        }
    }
}

/// The committed record of `key` in OUT/results, if any.
fn read_record(out: &Path, key: &str) -> Option<RunRecord> {
    serde_json::from_slice(&std::fs::read(out.join(RESULTS_DIR).join(format!("{key}.json"))).ok()?).ok()
}

/// The outcome of a run whose job ended without committing its record.
fn lost_outcome(state: &JobState) -> Outcome {
    match state.state.as_str() {
        "TIMEOUT" | "DEADLINE" => Outcome::Timeout,
        "CANCELLED" | "PREEMPTED" => Outcome::Signal { signal: 15 },
        "OUT_OF_MEMORY" => Outcome::Signal { signal: 9 },
        _ => Outcome::NonZeroExit {
            code: state.exit_code.filter(|c| *c != 0).unwrap_or(-1),
        },
    }
}

/// What a Slurm pass did.
#[derive(Debug, Default)]
pub struct SlurmSummary {
    pub records: Vec<RunRecord>,
    pub submitted_jobs: usize,
    pub reattached_jobs: usize,
    /// Jobs left running when the pass was cancelled.
    pub left_running: Vec<String>,
    pub errors: Vec<String>,
}

/// Submits the runs of `keys` that are neither finished nor journaled, re-attaches to journaled
/// jobs, and waits for every run's record (or cancellation: then jobs are left running).
pub fn run(
    settings: &SlurmSettings,
    study: &Path,
    store: &mut RunStore,
    keys: &[String],
    canceller: &Canceller,
    inputs: &dyn Fn(&str) -> Result<(), Error>,
) -> Result<SlurmSummary, Error> {
    // Absolute: the job runs with its own working directory.
    let out = std::path::absolute(store.out()).map_err(|e| Error::Failed(format!("{}: {e}", store.out().display())))?;
    std::fs::create_dir_all(journal_dir(&out)).map_err(|e| Error::Failed(format!("{}: {e}", out.display())))?;
    let mut summary = SlurmSummary::default();
    let wanted: BTreeSet<&String> = keys.iter().filter(|k| !store.is_finished(k)).collect();
    // Re-attach.
    let mut active: Vec<JobEntry> = Vec::new();
    for mut entry in journal(&out) {
        if entry.job_id.is_none() {
            entry.job_id = find_by_name(&entry.token);
            match &entry.job_id {
                Some(_) => write_entry(&out, &entry)?,
                None => {
                    remove_entry(&out, &entry.token); // never reached Slurm
                    continue;
                }
            }
        }
        eprintln!(
            "re-attached to Slurm job {} ({} run(s))",
            entry.job_id.as_deref().unwrap_or("?"),
            entry.keys.len()
        );
        summary.reattached_jobs += 1;
        active.push(entry);
    }
    let journaled: BTreeSet<String> = active.iter().flat_map(|j| j.keys.iter().cloned()).collect();
    // Submit the rest, `runs_per_job` per job.
    let fresh: Vec<String> = wanted
        .into_iter()
        .filter(|k| !journaled.contains(*k))
        .cloned()
        .collect();
    for chunk in fresh.chunks(settings.runs_per_job.max(1)) {
        if canceller.reason().is_some() {
            break;
        }
        for key in chunk {
            store.forget(key).map_err(Error::from)?; // an old failed record is not this job's
            inputs(key)?;
        }
        let entry = submit(settings, study, &out, store, chunk.to_vec())?;
        summary.submitted_jobs += 1;
        active.push(entry);
    }
    if summary.submitted_jobs > 0 {
        eprintln!(
            "submitted {} run(s) in {} Slurm job(s)",
            fresh.len(),
            summary.submitted_jobs
        );
    }
    watch(settings, &out, store, active, canceller, &mut summary)?;
    Ok(summary)
}

/// Polls the `active` jobs until every run has a record or the pass is cancelled (then the jobs
/// still active are left running, in `summary.left_running`).
fn watch(
    settings: &SlurmSettings,
    out: &Path,
    store: &mut RunStore,
    mut active: Vec<JobEntry>,
    canceller: &Canceller,
    summary: &mut SlurmSummary,
) -> Result<(), Error> {
    let mut delay = Duration::from_millis(200);
    let mut last_report = Instant::now();
    let mut watches: BTreeMap<String, lost::Watch> = BTreeMap::new();
    while !active.is_empty() {
        let ids: Vec<String> = active.iter().filter_map(|j| j.job_id.clone()).collect();
        let poll = job_states(&ids);
        let mut still = Vec::new();
        for entry in active {
            let id = entry.job_id.clone().unwrap_or_default();
            let state = poll.states.get(&id);
            let sighting = match (state, poll.answered) {
                (Some(_), _) => lost::Sighting::Known,
                (None, true) => lost::Sighting::Absent,
                (None, false) => lost::Sighting::NoAnswer,
            };
            let was_missing = watches.get(&entry.token).is_some_and(|w| *w != lost::Watch::default());
            let verdict =
                watches
                    .entry(entry.token.clone())
                    .or_default()
                    .observe(sighting, now_ms(), settings.lost_after);
            if !was_missing && matches!(verdict, lost::Verdict::Missing { .. }) {
                eprintln!(
                    "Slurm job {id} is unknown to squeue, scontrol and the jobcomp record; its runs are given up \
                     as lost if it stays so for {} s (slurm.lost_after)",
                    settings.lost_after.as_secs()
                );
            }
            let gone = match verdict {
                lost::Verdict::Lost { absent_ms } => Some(lost_detail(&id, absent_ms, settings.lost_after)),
                _ => None,
            };
            if collect(out, store, &entry, state, gone.as_deref(), summary)? {
                still.push(entry);
            } else {
                remove_entry(out, &entry.token);
            }
        }
        active = still;
        // Checked after a poll, so that the jobs left running are those still queued or running.
        if canceller.reason().is_some() {
            summary.left_running = active.iter().filter_map(|j| j.job_id.clone()).collect();
            break;
        }
        if active.is_empty() {
            break;
        }
        if last_report.elapsed() > Duration::from_secs(10) {
            eprintln!("waiting for {} Slurm job(s)...", active.len());
            last_report = Instant::now();
        }
        sleep_unless_cancelled(delay, canceller);
        delay = (delay * 3 / 2).min(Duration::from_secs(2));
    }
    Ok(())
}

/// Sleeps `total`, waking early when the pass is cancelled (Ctrl-C is answered at once).
fn sleep_unless_cancelled(total: Duration, canceller: &Canceller) {
    let end = Instant::now() + total;
    while canceller.reason().is_none() {
        let left = end.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return;
        }
        std::thread::sleep(left.min(Duration::from_millis(50)));
    }
}

/// The `lost` outcome's message: the job, what was checked, for how long.
fn lost_detail(id: &str, absent_ms: u64, lost_after: Duration) -> String {
    let jobcomp = jobcomp_file().map_or("no JobCompLoc configured".to_string(), |p| p.display().to_string());
    format!(
        "Slurm job {id} was unknown to squeue, scontrol and the jobcomp record ({jobcomp}) for {:.0} s \
         (slurm.lost_after: {} s) and the run committed no record; the next `lab run --executor slurm` \
         submits it again",
        absent_ms as f64 / 1000.0,
        lost_after.as_secs()
    )
}

/// Collects the records of one job's runs. A run without a record gets one when its job has
/// ended (the outcome Slurm gives) or is lost (`gone`: the message). Returns whether the job is
/// still awaited.
fn collect(
    out: &Path,
    store: &mut RunStore,
    entry: &JobEntry,
    state: Option<&JobState>,
    gone: Option<&str>,
    summary: &mut SlurmSummary,
) -> Result<bool, Error> {
    let ended = state.is_some_and(JobState::is_final);
    let mut open = false;
    for key in &entry.keys {
        if store.is_finished(key) || (store.record(key).is_some() && ended) {
            continue;
        }
        let outcome = if let Some(record) = read_record(out, key).filter(|r| r.ended_ms >= entry.submitted_ms) {
            store.remember(record.clone());
            summary.records.push(record);
            continue;
        } else if let (true, Some(state)) = (ended, state) {
            lost_outcome(state)
        } else if let Some(detail) = gone {
            Outcome::Lost {
                job: entry.job_id.clone().unwrap_or_default(),
                detail: detail.to_string(),
            }
        } else {
            open = true;
            continue;
        };
        let record = RunRecord::ended(key, outcome, 1, entry.submitted_ms, None);
        store.commit(record.clone()).map_err(Error::from)?;
        summary.records.push(record);
    }
    Ok(open)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unknown_id_is_an_answer_a_missing_controller_is_not() {
        assert!(squeue_answered(&Ok(String::new())));
        let unknown = "`squeue -h -t all -j 9 -o %i %T`: slurm_load_jobs error: Invalid job id specified";
        assert!(squeue_answered(&Err(unknown.into())));
        let down = "`squeue ...`: slurm_load_jobs error: Unable to contact slurm controller (connect failure)";
        assert!(!squeue_answered(&Err(down.into())));
        assert!(!squeue_answered(&Err(
            "cannot run `squeue`: No such file or directory".into()
        )));
    }

    fn entry(keys: &[&str]) -> JobEntry {
        JobEntry {
            token: "t".into(),
            job_id: Some("42".into()),
            keys: keys.iter().map(|k| k.to_string()).collect(),
            submitted_ms: 1000,
        }
    }

    #[test]
    fn a_lost_job_gives_its_unrecorded_runs_the_lost_outcome() {
        let dir = tempfile::tempdir().unwrap();
        let mut store = RunStore::open(dir.path()).unwrap();
        let done = RunRecord {
            key: "a".into(),
            outcome: Outcome::Success,
            attempts: 1,
            started_ms: 2000,
            ended_ms: 3000,
            response: Some(1.5),
            quality: None,
            warnings: Vec::new(),
        };
        super::super::store::Committer::new(dir.path().join(RESULTS_DIR))
            .commit(&done)
            .unwrap();
        let job = entry(&["a", "b"]);
        let mut summary = SlurmSummary::default();
        // Absent but not yet lost: the run without a record keeps the job awaited.
        assert!(collect(dir.path(), &mut store, &job, None, None, &mut summary).unwrap());
        assert!(store.is_finished("a"));
        assert!(store.record("b").is_none());
        // Lost: `b` gets the outcome, `a` keeps its success, the job is no longer awaited.
        assert!(!collect(dir.path(), &mut store, &job, None, Some("gone"), &mut summary).unwrap());
        assert_eq!(
            store.record("b").unwrap().outcome,
            Outcome::Lost {
                job: "42".into(),
                detail: "gone".into()
            }
        );
        assert!(!store.is_finished("b"), "a lost run is submitted again");
        assert!(store.is_finished("a"));
        let reread = read_record(dir.path(), "b").unwrap();
        assert_eq!(reread.outcome.class(), crate::execute::OutcomeClass::Lost);
    }
}
