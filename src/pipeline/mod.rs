//! `lab run` as one function: [`run`] is the place to start reading.
//!
//! ```text
//! solver study:  source ─► plan ─► render ─► execute, extract ─► fit ──┐
//!                Source    Plan    Prepared  Executed            SurrogateModel
//! closed form:   closed_form (the expression is the model) ────────────┤
//!                                                                      ▼
//! calibrate ─► diagnose ─► splits ─► results ─► report data ─► write
//! Calibration  Diagnosis   SplitResults  Results  ReportData    OUT/results.json, report-data.json, report.html
//! ```
//!
//! Each stage is one call with a typed input and a typed output. The pipeline never prints and
//! never installs anything: what the person running it should see goes to a [`Reporter`] as
//! [`Event`]s, and interruption comes in as a value ([`Engine::signals`], whose canceller the run
//! engine watches), the way cargo-nextest separates its reporter and dispatcher from its executor.
//! The command line (`crate::cli`) builds the options and the engine, calls [`run`] and prints the
//! [`RunOutcome`].
//!
//! - [`stages`]: the numerics wiring (surrogates, the training problem, the methods, diagnosis);
//! - [`runs`]: the run-engine stage (where runs come from, the sweep, how the runs ended);
//! - [`verbs`]: the other commands (`check`, `status`, `report`, `extract`, the Slurm worker).

pub mod confirm;
pub mod curves;
mod diagnosis;
pub mod extend;
mod open;
pub mod runs;
pub mod sequence;
pub mod stages;
pub mod values;
pub mod verbs;

use std::path::{Path, PathBuf};
use std::time::Instant;

pub use runs::{Executed, ExecutorKind, FailedRun, RunContext, RunOutcomes};
pub use stages::{
    calibrate, diagnose, extension_models, extension_surrogates, model, problem, simulation_data, surrogates,
};

use crate::calibrate::bayesian::SimulationData;
use crate::calibrate::{Calibration, CalibrationError, Model};
use crate::diagnose::Diagnosis;
use crate::emulate::SurrogateModel;
use crate::error::{Error, InputError};
use crate::execute::sweep::{self, Prepared, Signals};
use crate::extract::lsdyna::quality::Flag;
use crate::plan::Plan;
use crate::study::{self, Simulation, SolverSimulation, Study};

/// How `lab run` was asked to run a study.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// The output directory (run store, results.json, report).
    pub out: PathBuf,
    /// Solver runs at once (local executor).
    pub jobs: usize,
    pub executor: ExecutorKind,
    /// `--replay DIR`: serve runs from recordings; none: the study's default rule (see [`runs::source`]).
    pub replay: Option<PathBuf>,
    /// `--record DIR`: copy each finished run's outputs there.
    pub record: Option<PathBuf>,
}

/// What the run engine is given by the command line: the async runtime the executor runs on and
/// the signal state (Ctrl-C / SIGTERM as a cancellation token, see [`Signals`]).
pub struct Engine<'a> {
    pub runtime: &'a tokio::runtime::Runtime,
    pub signals: &'a Signals,
}

/// What `lab run` tells the person running it while it works; a [`Reporter`] shows them.
#[derive(Debug)]
pub enum Event<'a> {
    /// A remark on how the study is run (replaying, nothing to submit, ...).
    Note(String),
    /// Finished runs were copied into a recording directory.
    Recorded { runs: usize, dir: &'a Path },
    /// A sweep (a fixed plan, or one batch of a sequence) ended with these runs failed: reported
    /// as soon as it ends, before anything is fitted to the rest.
    Failed(&'a [runs::FailedRun]),
    /// The sweep is over: how every planned run ended.
    RunsEnded(&'a RunOutcomes),
    /// The sweep was interrupted; the finished runs are kept in `out`.
    Interrupted { out: &'a Path },
    /// A batch of a sequential study is done: what it bought.
    Batch(&'a sequence::Batch),
}

/// Consumes the pipeline's [`Event`]s (the command line prints them on stderr) and shows the run
/// engine's progress.
pub trait Reporter {
    fn report(&mut self, event: Event<'_>);

    /// The display of a local sweep's progress over `runs` runs, driven by the executor's events;
    /// none by default.
    fn progress(&mut self, runs: u64) -> indicatif::ProgressBar {
        indicatif::ProgressBar::with_draw_target(Some(runs), indicatif::ProgressDrawTarget::hidden())
    }
}

/// Everything `lab run` produced, as domain values: the simulation (a closed form, or the solver's
/// runs and their emulators), the calibration, on whole curves too, the diagnosis and the extra
/// splits. The report builds `results.json`, `report-data.json`, the HTML and the terminal's words
/// from it (`crate::report::run`).
pub struct Outcome<'s> {
    pub simulated: Simulated<'s>,
    pub calibration: Calibration,
    pub curve_calibration: Option<values::CurveCalibrationResult>,
    pub diagnosis: Result<Diagnosis, CalibrationError>,
    /// The study's extra train/validate splits, each calibrated again from the same runs.
    pub splits: Option<Vec<SplitCalibration>>,
    /// When `lab run` started (the report gives its wall time).
    pub started: Instant,
}

/// One extra train/validate split (`splits:`): the study with the split's training and validation
/// designs, calibrated again.
pub struct SplitCalibration {
    pub study: Study,
    pub calibration: Calibration,
}

/// `lab run`: the study's simulation as a model (from its expression, or from solver runs that are
/// planned, rendered, executed and fitted), then calibration beside the curve stage, diagnosis
/// beside the extra train/validate splits (each pair independent, computed side by side), and the
/// results and report data, written into `options.out`.
pub fn run<'s>(
    study: &'s Study,
    options: &RunOptions,
    engine: &Engine,
    reporter: &mut dyn Reporter,
) -> Result<Outcome<'s>, Error> {
    let started = Instant::now();
    let (simulated, source) = match &study.simulation {
        Simulation::Expression(_) => (closed_form(study, options, engine, reporter)?, None),
        Simulation::Solver(sim) => {
            let source = runs::source(sim, options, reporter);
            let cx = RunContext {
                study,
                sim,
                source: &source,
                options,
                engine,
            };
            let runs = solver_runs(cx, sim, reporter)?;
            (Simulated::Solver(Box::new(runs)), Some(source))
        }
    };
    // The calibration and the curves need only the runs: side by side.
    let (calibration, stage) = rayon::join(
        || calibrate(study, &problem(study, simulated.model()), simulated.data()),
        || {
            let stage = curve_stage(study, &simulated)?;
            let calibrated = stage.as_ref().map(|s| curves::calibrate(study, s));
            Ok::<_, Error>((stage, calibrated))
        },
    );
    let (stage, curve_calibration) = stage?;
    // The splits need only the runs too (and the emulator the calibration fitted, which their copy
    // keeps): calibrated on a thread of their own while the diagnosis runs.
    let split_runs = simulated.split_runs();
    let mut simulated = simulated;
    let (diagnosis, splits) = std::thread::scope(|scope| {
        let splits = scope.spawn(|| {
            let (surrogates, data) = split_runs.as_ref()?;
            calibrate_splits(study, surrogates, data)
        });
        let diagnosis = match (&mut simulated, source) {
            (Simulated::Solver(runs), Some(source)) => {
                let cx = RunContext {
                    study,
                    sim: runs.sim,
                    source: &source,
                    options,
                    engine,
                };
                diagnosis::diagnose_with_solver(cx, runs, stage.as_ref(), reporter)
            }
            (simulated, _) => Ok(diagnose(study, simulated.model())),
        };
        let splits = splits.join().unwrap_or_else(|e| std::panic::resume_unwind(e));
        (diagnosis, splits)
    });
    let diagnosis = diagnosis?;
    engine.signals.sweep_done();
    Ok(Outcome {
        simulated,
        calibration,
        curve_calibration,
        diagnosis,
        splits,
        started,
    })
}

/// A solver study's screening runs: planned, rendered, executed (or replayed), and fitted.
fn solver_runs<'s>(
    cx: RunContext<'_>,
    sim: &'s SolverSimulation,
    reporter: &mut dyn Reporter,
) -> Result<SolverRuns<'s>, Error> {
    let study = cx.study;
    let (plan, rendered, executed, sequence) = if sim.sampling.sequential.is_some() {
        let s = sequence::screening(cx, reporter)?;
        (s.plan, s.rendered, s.executed, Some(s.sequence))
    } else {
        let plan = Plan::new(study, sim);
        let rendered = sweep::prepare(study, &crate::extract::adapters::solver(sim)?, &plan)?;
        let executed = runs::execute(cx, &plan, &rendered, reporter)?;
        (plan, rendered, executed, None)
    };
    // Suspect runs (a quality gate broken) are kept and shown, but feed the models only
    // with `quality.suspect: use`.
    let flags = executed.swept.flags(&sim.quality.gates);
    runs::report_suspects(&plan, &flags, sim.quality.use_suspect, reporter);
    runs::report_warnings(&rendered.keys, &executed.store, reporter);
    let usable = executed.swept.usable(&sim.quality);
    let surrogates = surrogates(study, sim, &plan, &usable)?;
    let data = simulation_data(&plan, &usable);
    Ok(SolverRuns {
        sim,
        plan,
        rendered,
        executed,
        flags,
        usable,
        surrogates,
        data,
        diagnosed: Diagnosed::default(),
        sequence,
    })
}

/// A solver study's curves (`None` unless it is calibrated against curves): the specimens, every
/// screening run's curve and the curve emulators.
fn curve_stage(study: &Study, simulated: &Simulated) -> Result<Option<curves::CurveStage>, Error> {
    let (Simulated::Solver(runs), Some(setting)) = (simulated, curves::Setting::of(study)) else {
        return Ok(None);
    };
    let dirs = runs.executed.output_dirs(runs.sim);
    let stage = curves::CurveStage::build(
        study,
        runs.sim,
        setting,
        &runs.plan,
        &runs.rendered.keys,
        &runs.usable,
        &dirs,
    )?;
    Ok(Some(stage))
}

/// The simulation as the numerics see it, with what it was built from.
pub enum Simulated<'s> {
    /// The study's expression.
    ClosedForm(Box<dyn Model>),
    /// Surrogates fitted to solver runs.
    Solver(Box<SolverRuns<'s>>),
}

/// A solver study's runs and the surrogates fitted to them. The run store in `executed` stays
/// open (and its lock held) until the report is written.
pub struct SolverRuns<'s> {
    pub sim: &'s SolverSimulation,
    pub plan: Plan,
    pub rendered: Prepared,
    pub executed: Executed,
    /// The quality gates each run breaks (empty: sound).
    pub flags: Vec<Vec<Flag>>,
    /// The responses the models may use (suspect runs left out unless the study says otherwise).
    pub usable: Vec<Option<f64>>,
    pub surrogates: SurrogateModel,
    /// The sample runs as the Bayesian method's emulator data.
    pub data: SimulationData,
    /// What the diagnosis ran and made beyond the screening.
    pub diagnosed: Diagnosed,
    /// A sequential study's batches (`None` for a fixed plan).
    pub sequence: Option<sequence::Sequence>,
}

/// What a solver study's diagnosis ran and made beyond the screening: the loop's runs and models,
/// the confirmation runs, and the residual curves the report draws.
#[derive(Default)]
pub struct Diagnosed {
    /// The solver-in-the-loop runs, when the screening chose a hypothesis to extend.
    pub joint: Option<extend::JointRuns>,
    /// The extended models they made, with their calibrated parameters (θ, then the extension's).
    pub extended: Vec<(extend::ExtendedModel, Vec<f64>)>,
    /// Calibration against curves: where along the stroke the model errs, per tested design.
    pub residual_curves: Vec<values::ResidualCurves>,
    /// The solver at the fitted parameters of the models the verdict rests on ([`confirm`]).
    pub confirmation: Option<confirm::ConfirmRuns>,
}

impl Simulated<'_> {
    pub fn model(&self) -> &dyn Model {
        match self {
            Simulated::ClosedForm(model) => model.as_ref(),
            Simulated::Solver(runs) => &runs.surrogates,
        }
    }

    /// Simulation runs for the Bayesian emulator; without them it samples the model.
    pub fn data(&self) -> Option<&SimulationData> {
        match self {
            Simulated::ClosedForm(_) => None,
            Simulated::Solver(runs) => Some(&runs.data),
        }
    }

    /// What the train/validate splits are calibrated from: a copy of the surrogates and runs
    /// (`None` for a closed-form study, which has no splits).
    fn split_runs(&self) -> Option<(SurrogateModel, SimulationData)> {
        match self {
            Simulated::ClosedForm(_) => None,
            Simulated::Solver(runs) => Some((runs.surrogates.clone(), runs.data.clone())),
        }
    }

    pub fn into_outcomes(self) -> Option<RunOutcomes> {
        match self {
            Simulated::ClosedForm(_) => None,
            Simulated::Solver(runs) => {
                let screening = runs.executed.outcomes;
                let d = runs.diagnosed;
                let looped = match d.joint {
                    Some(joint) => screening.merge(joint.outcomes),
                    None => screening,
                };
                Some(match d.confirmation {
                    Some(c) => looped.merge(c.outcomes),
                    None => looped,
                })
            }
        }
    }
}

/// A closed-form study: no runs, so nothing to record, replay or submit, and nothing to cancel (a
/// signal ends `lab` at once). Creates the output directory.
fn closed_form<'s>(
    study: &Study,
    options: &RunOptions,
    engine: &Engine,
    reporter: &mut dyn Reporter,
) -> Result<Simulated<'s>, Error> {
    engine.signals.sweep_done();
    if options.replay.is_some() || options.record.is_some() {
        reporter.report(Event::Note(format!(
            "`{}` has a closed-form simulation; nothing to record or replay",
            study.name
        )));
    }
    if options.executor == ExecutorKind::Slurm {
        reporter.report(Event::Note(format!(
            "`{}` has a closed-form simulation; nothing to submit to Slurm",
            study.name
        )));
    }
    std::fs::create_dir_all(&options.out)
        .map_err(|e| InputError::file(&options.out, format!("cannot create the output directory: {e}")))?;
    let model = model(study).ok_or_else(|| Error::Failed("internal: a closed-form run of a solver study".into()))?;
    Ok(Simulated::ClosedForm(model))
}

/// The study's extra train/validate splits (`splits:`), each calibrated again from the same runs;
/// `None` when it names none or has no runs.
fn calibrate_splits(
    study: &Study,
    surrogates: &SurrogateModel,
    data: &SimulationData,
) -> Option<Vec<SplitCalibration>> {
    if study.calibration.splits.is_empty() {
        return None;
    }
    // Each split is calibrated on its own from the same runs and emulator: in parallel, in order.
    use rayon::prelude::*;
    Some(
        study
            .calibration
            .splits
            .par_iter()
            .map(|split| calibrate_split(study, split, surrogates, data))
            .collect(),
    )
}

/// Calibrates the study again with a split's training and validation designs.
fn calibrate_split(
    study: &Study,
    split: &study::Split,
    surrogates: &SurrogateModel,
    runs: &SimulationData,
) -> SplitCalibration {
    let mut s = study.clone();
    s.split.training = split.training.clone();
    s.split.validation = split.validation.clone();
    let problem = problem(&s, surrogates as &dyn Model);
    let calibration = calibrate(&s, &problem, Some(runs));
    SplitCalibration { study: s, calibration }
}
