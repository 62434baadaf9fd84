//! The run-engine stage of [`super::run`] for a solver study: where the runs come from (a live
//! solver, Slurm jobs, or recordings), the sweep over the planned runs, and how they ended.
//!
//! The run store is opened here and handed on inside [`Executed`]: its lock is held until the
//! report is written, so no second `lab run` works on the same output directory meanwhile.

use std::collections::BTreeMap;

use indexmap::IndexMap;
use std::path::{Path, PathBuf};

use super::{Engine, Event, Reporter, RunOptions};
use crate::error::Error;
use crate::execute::replay::Damaged;
use crate::execute::store::RUNS_DIR;
use crate::execute::sweep::{self, Prepared, SweepResult};
use crate::execute::{self, OutcomeClass, RunStore};
use crate::extract::lsdyna::quality::Flag;
use crate::plan::Plan;
use crate::study::{SolverSimulation, Study};

/// `--executor`: where live runs are executed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExecutorKind {
    /// Child processes of this `lab`, `--jobs` at once.
    Local,
    /// Slurm jobs (see [`crate::execute::slurm`]).
    Slurm,
}

/// Where the runs of this `lab run` come from.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    /// The solver, started by the local executor.
    Local,
    /// The solver, inside Slurm jobs.
    Slurm,
    /// Recordings in a directory; no solver is started.
    Replay(PathBuf),
}

/// The runs' source: `--replay DIR`, else the study's `simulation.replay` when the solver program
/// is not on PATH (a note says so), else the live solver through `--executor`.
pub fn source(sim: &SolverSimulation, options: &RunOptions, reporter: &mut dyn Reporter) -> Source {
    if let Some(dir) = &options.replay {
        return Source::Replay(dir.clone());
    }
    let program = &sim.execution.command[0];
    match &sim.replay {
        Some(default) if !on_path(program) => {
            reporter.report(Event::Note(format!(
                "solver `{program}` is not on PATH: replaying the study's recordings in {}",
                default.display()
            )));
            Source::Replay(default.clone())
        }
        _ if options.executor == ExecutorKind::Slurm => Source::Slurm,
        _ => Source::Local,
    }
}

/// Whether `program` would be found: a path that exists, or an executable file on PATH.
fn on_path(program: &str) -> bool {
    use std::os::unix::fs::PermissionsExt;
    let executable = |p: &Path| {
        p.metadata()
            .is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
    };
    if program.contains('/') {
        return executable(Path::new(program));
    }
    std::env::var_os("PATH").is_some_and(|path| std::env::split_paths(&path).any(|dir| executable(&dir.join(program))))
}

/// What the sweep left: the open store, every planned run's response and how the runs ended.
pub struct Executed {
    pub store: RunStore,
    pub swept: SweepResult,
    pub outcomes: RunOutcomes,
    /// The recordings the runs were replayed from, if they were.
    pub replay: Option<PathBuf>,
}

impl Executed {
    /// Where finished runs' outputs are, as `<dir>/<key>/`: the store's run directories (live
    /// runs), then the replay directory and the study's `simulation.replay` (runs replayed now or
    /// by an earlier `lab run`).
    pub fn output_dirs(&self, sim: &SolverSimulation) -> Vec<PathBuf> {
        let mut dirs = vec![self.store.out().join(RUNS_DIR)];
        dirs.extend(self.replay.iter().cloned());
        if let Some(d) = &sim.replay
            && !dirs.contains(d)
        {
            dirs.push(d.clone());
        }
        dirs
    }
}

/// How the planned runs ended: the outcome table and the failed runs.
#[derive(Debug, Clone, Default)]
pub struct RunOutcomes {
    /// Planned runs per outcome class of their record, runs finished earlier not counted.
    pub classes: BTreeMap<OutcomeClass, usize>,
    /// Planned runs finished before this `lab run`.
    pub reused: usize,
    /// Planned runs with no record (not run: interrupted, or a job given up).
    pub missing: usize,
    /// Planned runs with a record but no response, in plan order.
    pub failed: Vec<FailedRun>,
    /// Recordings of successful runs this replay could not read (none when not replaying).
    pub damaged: Vec<Damaged>,
}

impl RunOutcomes {
    /// Both sweeps' outcomes as one (the screening's, then the loop's).
    pub fn merge(mut self, more: RunOutcomes) -> RunOutcomes {
        for (class, n) in more.classes {
            *self.classes.entry(class).or_insert(0) += n;
        }
        self.reused += more.reused;
        self.missing += more.missing;
        self.failed.extend(more.failed);
        self.damaged.extend(more.damaged);
        self
    }
}

/// A planned run that has a record but no response.
#[derive(Debug, Clone)]
pub struct FailedRun {
    pub design: String,
    /// Its calibration parameters and, for an extension's run, the extension's variables.
    pub parameters: IndexMap<String, f64>,
    pub key: String,
    /// Its record's outcome class, and the outcome in words (the adapter's file:line where it
    /// names one).
    pub class: OutcomeClass,
    pub why: String,
    /// Its run directory; for a replayed run, its recording.
    pub dir: PathBuf,
    /// Replayed from a recording of a run that succeeded: the recording is damaged.
    pub damaged: bool,
}

impl FailedRun {
    /// `design `C3T7`, parameters [152.0], key 115fad52…: <outcome> (see DIR)`: what failed, how,
    /// and where to look.
    pub fn words(&self) -> String {
        let parameters: Vec<String> = self.parameters.iter().map(|(k, v)| format!("{k} = {v}")).collect();
        let place = match self.damaged {
            true => format!("damaged recording {}", self.dir.display()),
            false => format!("run directory {}", self.dir.display()),
        };
        format!(
            "design `{}`, {}, key {} ({place}): {}",
            self.design,
            parameters.join(", "),
            self.key,
            self.why
        )
    }
}

/// What making a study's runs reads: the study and its solver, where the runs come from, how `lab
/// run` was asked to run them, and the engine that runs them.
#[derive(Clone, Copy)]
pub struct RunContext<'a> {
    pub study: &'a Study,
    pub sim: &'a SolverSimulation,
    pub source: &'a Source,
    pub options: &'a RunOptions,
    pub engine: &'a Engine<'a>,
}

/// Opens the run store in `options.out` and executes (or replays) every planned run it does not
/// hold finished ([`sweep_plan`]).
pub fn execute(
    cx: RunContext,
    plan: &Plan,
    rendered: &Prepared,
    reporter: &mut dyn Reporter,
) -> Result<Executed, Error> {
    let mut store = execute::open_store(&cx.options.out)?;
    let (swept, outcomes) = sweep_plan(cx, plan, rendered, &mut store, reporter)?;
    let replay = match cx.source {
        Source::Replay(dir) => Some(dir.clone()),
        _ => None,
    };
    Ok(Executed {
        store,
        swept,
        outcomes,
        replay,
    })
}

/// Executes (or replays) every run of `plan` that `store` does not hold finished, then records
/// them (`--record`) and reports how they ended. An interrupt is [`Error::Interrupted`], a record
/// that could not be committed [`Error::Failed`]; failed runs are not errors (the outcome says so).
/// The screening's runs and the loop's more runs ([`super::extend`]) both come through here.
pub fn sweep_plan(
    cx: RunContext,
    plan: &Plan,
    rendered: &Prepared,
    store: &mut RunStore,
    reporter: &mut dyn Reporter,
) -> Result<(SweepResult, RunOutcomes), Error> {
    let (options, engine) = (cx.options, cx.engine);
    sweep::write_meshes(&options.out, rendered)?;
    let solver = crate::extract::adapters::solver(cx.sim)?;
    let (swept, damaged) = sweep_runs(cx, &solver, (plan, rendered), store, reporter)?;
    if let Some(dir) = &options.record {
        let runs = sweep::record(cx.study, &solver, plan, rendered, store, dir)?;
        reporter.report(Event::Recorded { runs, dir });
    }
    let recordings = match cx.source {
        Source::Replay(dir) => Some(dir.as_path()),
        _ => None,
    };
    let outcomes = outcomes((cx.study, plan, &rendered.keys), &swept, store, (recordings, damaged));
    if !outcomes.failed.is_empty() {
        reporter.report(Event::Failed(&outcomes.failed));
    }
    reporter.report(Event::RunsEnded(&outcomes));
    if engine.signals.interrupted() {
        reporter.report(Event::Interrupted { out: &options.out });
        return Err(Error::Interrupted);
    }
    if !swept.errors.is_empty() {
        return Err(Error::Failed(swept.errors.join("\n")));
    }
    Ok((swept, outcomes))
}

/// The sweep itself, by source.
fn sweep_runs(
    cx: RunContext,
    solver: &sweep::Solver,
    (plan, rendered): (&Plan, &Prepared),
    store: &mut RunStore,
    reporter: &mut dyn Reporter,
) -> Result<(SweepResult, Vec<Damaged>), Error> {
    let engine = cx.engine;
    let swept = match cx.source {
        Source::Replay(dir) => return replay(cx.study, solver, (plan, rendered), store, dir, reporter),
        Source::Slurm => sweep::run_slurm(store, cx.study, solver.sim, rendered, engine.signals),
        Source::Local => sweep::run(
            engine.runtime,
            store,
            solver,
            rendered,
            cx.options.jobs,
            &engine.signals.canceller,
            &mut |runs| reporter.progress(runs),
        ),
    };
    Ok((swept?, Vec::new()))
}

/// Serves the runs from recordings; a planned run without one is an error naming it, except a
/// confirmation run: the recordings of another study's settings (other gates, other tests) cannot
/// hold the solver at this study's fitted parameters, so those runs fail, named, and the verdict
/// says it is not confirmed. Where recordings this replay read are damaged, the error says so
/// first: a damaged run changes what a sequence plans next, which is why runs have no recording.
fn replay(
    study: &Study,
    solver: &sweep::Solver,
    (plan, rendered): (&Plan, &Prepared),
    store: &mut RunStore,
    dir: &Path,
    reporter: &mut dyn Reporter,
) -> Result<(SweepResult, Vec<Damaged>), Error> {
    if !dir.is_dir() {
        return Err(Error::Failed(format!(
            "replay directory {} does not exist",
            dir.display()
        )));
    }
    let replayed = sweep::replay_runs(study, solver, plan, rendered, store, dir)?;
    let misses = &replayed.misses;
    if misses.is_empty() {
        return Ok((replayed.swept, replayed.damaged));
    }
    let listed = listed(misses);
    use crate::plan::RunRole;
    if plan.runs.iter().all(|r| r.role == RunRole::Confirm) {
        reporter.report(Event::Note(format!(
            "{} confirmation run(s) have no recording, so they failed and the verdict is not confirmed by the \
             solver there (run the study live to confirm it):\n{listed}",
            misses.len()
        )));
        return Ok((replayed.swept, replayed.damaged));
    }
    if plan.runs.iter().all(|r| matches!(r.role, RunRole::NotExcluded(_))) {
        reporter.report(Event::Note(format!(
            "{} run(s) over an open extension's amplitude have no recording, so they failed and what no model \
             error leaves open rests on the runs that have (run the study live to read it from them all):\n{listed}",
            misses.len()
        )));
        return Ok((replayed.swept, replayed.damaged));
    }
    let missing = format!("{} planned run(s) have no recording:\n{listed}", misses.len());
    match replayed.damaged.is_empty() {
        true => Err(Error::Failed(missing)),
        false => Err(damaged_error(solver, store, dir, &replayed.damaged, Some(&missing))),
    }
}

/// At most five lines of `items` as a list, then a count of the rest.
fn listed(items: &[String]) -> String {
    let mut text = items
        .iter()
        .take(5)
        .map(|m| format!("- {m}"))
        .collect::<Vec<_>>()
        .join("\n");
    if items.len() > 5 {
        text += &format!("\n... and {} more", items.len() - 5);
    }
    text
}

/// Why a replay cannot go on: the damaged recordings it read, every other recording in `dir` that
/// is damaged too (judged now, so that all of them are named at once), and what to do.
pub fn damaged_error(
    solver: &sweep::Solver,
    store: &RunStore,
    dir: &Path,
    damaged: &[Damaged],
    missing: Option<&str>,
) -> Error {
    let read: std::collections::BTreeSet<String> = damaged.iter().map(|d| d.key.clone()).collect();
    let others = sweep::damaged_recordings(solver.adapter.as_ref(), store.out(), dir, &read);
    let words = |d: &[Damaged]| {
        d.iter()
            .map(|d| format!("- {}", d.words()))
            .collect::<Vec<_>>()
            .join("\n")
    };
    let mut text = format!(
        "{} recording(s) in {} are damaged: the live runs they record succeeded, but their outputs as they are now \
         fail as a live run would:\n{}",
        damaged.len(),
        dir.display(),
        words(damaged)
    );
    if !others.is_empty() {
        text += &format!(
            "\n{} other recording(s) there are damaged too (not yet asked for):\n{}",
            others.len(),
            words(&others)
        );
    }
    text += "\nA live sequence plans its next runs around a failed run; a replay can serve only the runs that were \
             recorded, so it stops here. Restore these recordings from where they were made, or make them again with \
             `lab run STUDY --record DIR` where the solver is installed.";
    if let Some(m) = missing {
        text += &format!("\n(what the replay asked for next: {m})");
    }
    Error::Failed(text)
}

/// How the planned runs ended, from the sweep and the store's records; `recordings`: the replay's
/// directory and the recordings in it found damaged.
fn outcomes(
    (study, plan, keys): (&Study, &Plan, &[String]),
    swept: &SweepResult,
    store: &RunStore,
    (recordings, damaged): (Option<&Path>, Vec<Damaged>),
) -> RunOutcomes {
    let mut classes = BTreeMap::new();
    for class in swept.classes.iter().flatten() {
        *classes.entry(*class).or_insert(0) += 1;
    }
    if let Some(n) = classes.get_mut(&OutcomeClass::Success) {
        *n -= swept.reused.min(*n);
    }
    let failed = (0..plan.runs.len())
        .filter(|&i| swept.classes[i].is_some() && swept.responses[i].is_none())
        .map(|i| {
            let (run, key) = (&plan.runs[i], &keys[i]);
            let record = store.record(key);
            let mut parameters = study.parameter_values(&run.theta);
            parameters.extend(run.extension.iter().cloned());
            FailedRun {
                design: run.design.clone(),
                parameters,
                key: key.clone(),
                class: swept.classes[i].unwrap_or(OutcomeClass::BadResponse),
                why: record.map(|r| r.outcome.to_string()).unwrap_or_default(),
                dir: recordings.map_or_else(|| store.run_dir(key), |d| d.join(key)),
                damaged: damaged.iter().any(|d| &d.key == key),
            }
        })
        .collect();
    RunOutcomes {
        classes,
        reused: swept.reused,
        missing: swept.classes.iter().filter(|c| c.is_none()).count(),
        failed,
        damaged,
    }
}

/// Notes for the runs that break a quality gate (at most 5, then a count).
pub fn report_suspects(plan: &Plan, flags: &[Vec<Flag>], used: bool, reporter: &mut dyn Reporter) {
    let suspect: Vec<usize> = (0..flags.len()).filter(|&i| !flags[i].is_empty()).collect();
    for &i in suspect.iter().take(5) {
        let texts: Vec<&str> = flags[i].iter().map(|f| f.text.as_str()).collect();
        reporter.report(Event::Note(format!(
            "suspect: design `{}`, parameters {:?}: {}",
            plan.runs[i].design,
            plan.runs[i].theta,
            texts.join("; ")
        )));
    }
    if !suspect.is_empty() {
        reporter.report(Event::Note(format!(
            "{} suspect run(s) {} (simulation.quality)",
            suspect.len(),
            if used {
                "used by the surrogates as the study says"
            } else {
                "left out of the surrogates"
            }
        )));
    }
}

/// A note for each distinct solver warning the runs' records keep (`openradioss`), with how many
/// runs gave it: the warnings are kept in every run's record and shown in the report's run table.
pub fn report_warnings(keys: &[String], store: &RunStore, reporter: &mut dyn Reporter) {
    let mut seen: Vec<(&str, usize)> = Vec::new();
    let mut runs = std::collections::BTreeSet::new();
    for key in keys {
        if !runs.insert(key) {
            continue;
        }
        for w in store.record(key).map(|r| r.warnings.as_slice()).unwrap_or_default() {
            match seen.iter_mut().find(|(t, _)| *t == w.as_str()) {
                Some((_, n)) => *n += 1,
                None => seen.push((w, 1)),
            }
        }
    }
    for (text, n) in seen {
        reporter.report(Event::Note(format!(
            "solver warning in {n} of {} run(s): {text}",
            runs.len()
        )));
    }
}
