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

pub mod curves;
pub mod extend;
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
                diagnose_with_solver(cx, runs, stage.as_ref(), reporter)
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
        joint: None,
        extended: Vec::new(),
        residual_curves: Vec::new(),
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

/// A solver study's diagnosis: the screening (the extension hypotheses judged from their runs at
/// their probe values), then the solver in the loop ([`extend`]) for the hypotheses it leaves
/// open, then one decision from all of it ([`crate::diagnose::conclude`]).
fn diagnose_with_solver(
    cx: RunContext,
    runs: &mut SolverRuns,
    stage: Option<&curves::CurveStage>,
    reporter: &mut dyn Reporter,
) -> Result<Result<Diagnosis, CalibrationError>, Error> {
    let study = cx.study;
    let extensions = extension_models(study, runs.sim, &runs.plan, &runs.usable);
    // With curves, the diagnosis reads their features; else the response.
    let curve_inputs = stage.map(|s| {
        let hypotheses = curves::extension_hypotheses(study, &s.extension_fns(), None, None);
        curves::inputs(study, &s.setting, s.designs.clone(), &s.baseline, hypotheses)
    });
    let problem = match feature_problem(curve_inputs.as_ref()) {
        Ok(p) => p,
        Err(e) => return Ok(Err(e)),
    };
    let inputs = match (&problem, &curve_inputs) {
        (Some(p), Some(ci)) => p.inputs(ci),
        _ => {
            let mut inputs = crate::diagnose::inputs_with_extensions(study, &runs.surrogates, &extensions);
            inputs.emulator_variance = crate::diagnose::emulator_variance(&runs.surrogates, &inputs.observations);
            inputs
        }
    };
    let screening = match crate::diagnose::diagnose(&inputs) {
        Ok(d) => d,
        Err(e) => return Ok(Err(e)),
    };
    if cx.engine.signals.interrupted() {
        reporter.report(Event::Interrupted { out: &cx.options.out });
        return Err(Error::Interrupted);
    }
    let chosen = extend::chosen(study, &screening);
    if chosen.is_empty() {
        let (d, residuals) = with_features(study, stage, problem.as_ref(), screening, &[]);
        runs.residual_curves = residuals;
        return Ok(Ok(d.worded()));
    }
    let dirs = runs.executed.output_dirs(runs.sim);
    let after = AfterLoop {
        study,
        sim: runs.sim,
        plan: &runs.plan,
        usable: &runs.usable,
        dirs: &dirs,
        surrogates: &runs.surrogates,
        stage,
        inputs: &inputs,
        extensions: &extensions,
    };
    let screened = Screened {
        plan: &runs.plan,
        usable: &runs.usable,
        rendered: &runs.rendered,
    };
    let store = (&mut runs.executed.store, &mut runs.sequence);
    let looped = match in_the_loop(cx, &after, &chosen, (screened, store), reporter)? {
        Ok(l) => l,
        Err(e) => return Ok(Err(e)),
    };
    let (joint, models, diagnosis, own, loop_curves) = looped;
    let records = models
        .iter()
        .zip(&own)
        .map(|(m, own)| extend::assess(study, m, &diagnosis, own))
        .collect::<Result<Vec<_>, _>>()?;
    for (m, x) in models.into_iter().zip(&records) {
        runs.extended.push((m, x.parameters.values().copied().collect()));
    }
    runs.joint = Some(joint);
    let (diagnosis, residuals) = with_features(study, stage, problem.as_ref(), diagnosis, &loop_curves);
    runs.residual_curves = residuals;
    Ok(Ok(diagnosis.with_extensions(records).worded()))
}

/// What the loop made and decided: its runs, the extended models, the decision after it, each loop
/// model's own diagnosis, and their curve models.
type Looped = (
    extend::JointRuns,
    Vec<extend::ExtendedModel>,
    Diagnosis,
    Vec<Diagnosis>,
    Vec<(usize, crate::emulate::functional::CurveModel)>,
);

/// The solver in the loop for the `chosen` hypotheses, a sequential loop asking for the decision
/// from its runs so far ([`sequence::looped`]), then the decision from all its runs.
fn in_the_loop(
    cx: RunContext,
    after: &AfterLoop,
    chosen: &[usize],
    (screened, store): (
        Screened,
        (&mut crate::execute::RunStore, &mut Option<sequence::Sequence>),
    ),
    reporter: &mut dyn Reporter,
) -> Result<Result<Looped, CalibrationError>, Error> {
    let mut decide = |joint: &extend::JointRuns, floor: f64| -> Option<sequence::Provisional> {
        let models = after.models(chosen, joint).ok()?;
        let (d, own, _) = after.conclude(&models, joint, floor).ok()?.ok()?;
        Some(provisional(chosen, &d, &own))
    };
    let joint = loop_runs(cx, screened, store, after.stage, chosen, reporter, &mut decide)?;
    let models = after.models(chosen, &joint)?;
    Ok(after
        .conclude(&models, &joint, 0.0)?
        .map(|(diagnosis, own, curves)| (joint, models, diagnosis, own, curves)))
}

/// The curves' feature problem, where the study reads curves.
fn feature_problem(
    curve_inputs: Option<&crate::diagnose::features::CurveInputs>,
) -> Result<Option<crate::diagnose::features::FeatureProblem>, CalibrationError> {
    curve_inputs
        .map(crate::diagnose::features::FeatureProblem::new)
        .transpose()
        .map_err(|e| CalibrationError::Numerics(format!("the curves cannot be diagnosed: {e}")))
}

/// What the decision after the loop reads besides the loop's runs: the screening's runs, its
/// surrogates or curve stage, and the screening diagnosis's inputs.
struct AfterLoop<'a> {
    study: &'a Study,
    sim: &'a SolverSimulation,
    plan: &'a Plan,
    usable: &'a [Option<f64>],
    dirs: &'a [PathBuf],
    surrogates: &'a SurrogateModel,
    stage: Option<&'a curves::CurveStage>,
    inputs: &'a crate::diagnose::Inputs<'a>,
    extensions: &'a [(usize, std::sync::Arc<dyn Model + Send>)],
}

impl AfterLoop<'_> {
    /// The `chosen` hypotheses' extended models over the joint runs.
    fn models(&self, chosen: &[usize], joint: &extend::JointRuns) -> Result<Vec<extend::ExtendedModel>, Error> {
        chosen
            .iter()
            .map(|&k| extend::extended_model(self.study, self.sim, k, (self.plan, self.usable), joint))
            .collect()
    }

    /// The decision with the extended models, on the mean force or on the curves; `floor` is the
    /// emulators' error a provisional decision allows for (0 for the final one).
    fn conclude(
        &self,
        models: &[extend::ExtendedModel],
        joint: &extend::JointRuns,
        floor: f64,
    ) -> Result<Result<Concluded, CalibrationError>, Error> {
        let (study, inputs) = (self.study, self.inputs);
        match self.stage {
            None => Ok(conclude_on_response(
                study,
                self.surrogates,
                inputs,
                models,
                self.extensions,
                floor,
            )),
            Some(st) => conclude_on_curves(
                study,
                (self.sim, self.plan, self.dirs),
                st,
                inputs,
                models,
                joint,
                floor,
            ),
        }
    }
}

/// The loop's decision so far as the sequence compares it from batch to batch.
fn provisional(chosen: &[usize], d: &Diagnosis, own: &[Diagnosis]) -> sequence::Provisional {
    sequence::Provisional {
        decided: sequence::Decided {
            verdict: d.verdict,
            cause: d.cause.clone(),
            partial: d.partial.as_ref().map(|p| p.name.clone()),
        },
        points: fitted_points(chosen, own),
        settled: d.after_loop.as_ref().is_some_and(|a| a.settled),
    }
}

/// Each looped hypothesis's fitted values, from its model's own diagnosis.
fn fitted_points(chosen: &[usize], own: &[Diagnosis]) -> Vec<(usize, sequence::Fitted)> {
    chosen
        .iter()
        .zip(own)
        .map(|(&k, o)| {
            (
                k,
                sequence::Fitted {
                    values: o.uncorrected.parameters.clone(),
                },
            )
        })
        .collect()
}

/// The screening's runs as the loop reads them.
struct Screened<'a> {
    plan: &'a Plan,
    usable: &'a [Option<f64>],
    rendered: &'a Prepared,
}

/// The solver-in-the-loop's runs of the `chosen` hypotheses: a fixed joint plan, or a sequential
/// study's batches ([`sequence::looped`], its record carried on in `sequence`), on the screening's
/// store.
fn loop_runs(
    cx: RunContext,
    s: Screened,
    (store, sequence): (&mut crate::execute::RunStore, &mut Option<sequence::Sequence>),
    stage: Option<&curves::CurveStage>,
    chosen: &[usize],
    reporter: &mut dyn Reporter,
    decide: &mut sequence::Decide,
) -> Result<extend::JointRuns, Error> {
    let Some(record) = sequence.take() else {
        return extend::execute(cx, chosen, s.rendered, store, reporter);
    };
    let none = vec![None; s.plan.runs.len()];
    let screening = sequence::ScreeningRuns {
        plan: s.plan,
        usable: s.usable,
        curves: stage.map_or(&none, |c| &c.runs),
        rendered: s.rendered,
    };
    let (joint, record) = sequence::looped(cx, chosen, &screening, (store, record), reporter, decide)?;
    *sequence = Some(record);
    Ok(joint)
}

/// What the loop's models concluded: the diagnosis, each loop model's own, and their curve models.
type Concluded = (
    Diagnosis,
    Vec<Diagnosis>,
    Vec<(usize, crate::emulate::functional::CurveModel)>,
);

/// The decision after the loop on the mean force: each extended model through its surrogate.
fn conclude_on_response(
    study: &Study,
    surrogates: &SurrogateModel,
    inputs: &crate::diagnose::Inputs,
    models: &[extend::ExtendedModel],
    extensions: &[(usize, std::sync::Arc<dyn Model + Send>)],
    floor: f64,
) -> Result<Concluded, CalibrationError> {
    let baseline: std::sync::Arc<dyn Model + Send> = std::sync::Arc::new(surrogates.clone());
    let looped: Vec<_> = models
        .iter()
        .map(|m| {
            let mut l = extend::loop_model(study, m, &baseline, extensions);
            l.inputs.settings.emulator_floor = floor;
            l
        })
        .collect();
    let (d, own) = crate::diagnose::conclude(inputs, &looped)?;
    Ok((d, own, Vec::new()))
}

/// The decision after the loop on the curves: each extended model's curve emulator over the joint
/// runs, its features with the other hypotheses' shapes as candidates.
fn conclude_on_curves(
    study: &Study,
    (sim, plan, dirs): (&SolverSimulation, &Plan, &[PathBuf]),
    stage: &curves::CurveStage,
    inputs: &crate::diagnose::Inputs,
    models: &[extend::ExtendedModel],
    joint: &extend::JointRuns,
    floor: f64,
) -> Result<Result<Concluded, CalibrationError>, Error> {
    let joint_curves = curves::on_grid(study, sim, &stage.setting, &joint.rendered.keys, &joint.usable, dirs);
    let baseline = curves::curve_fn(stage.baseline.clone());
    let p = study.parameters.len();
    let mut loop_curves = Vec::new();
    for m in models {
        let model = stage.loop_model(study, sim, plan, m.hypothesis, joint, &joint_curves)?;
        loop_curves.push((m.hypothesis, model));
    }
    let loop_inputs: Vec<_> = models
        .iter()
        .zip(&loop_curves)
        .map(|(m, (_, model))| {
            let others = curves::extension_hypotheses(
                study,
                &stage.extension_fns(),
                Some((baseline.clone(), p)),
                Some(m.hypothesis),
            );
            let mut ci = curves::inputs(&m.study, &stage.setting, stage.designs.clone(), model, others);
            ci.settings.emulator_floor = floor;
            ci
        })
        .collect();
    let problems = loop_inputs
        .iter()
        .map(crate::diagnose::features::FeatureProblem::new)
        .collect::<Result<Vec<_>, _>>()
        .map_err(Error::Failed)?;
    let looped: Vec<_> = models
        .iter()
        .zip(problems.iter().zip(&loop_inputs))
        .map(|(m, (p, ci))| crate::diagnose::LoopModel {
            hypothesis: study.diagnosis.hypotheses[m.hypothesis].name.clone(),
            inputs: p.inputs(ci),
            checked: m.checked,
            running: m.running,
        })
        .collect();
    Ok(crate::diagnose::conclude(inputs, &looped).map(|(d, own)| (d, own, loop_curves)))
}

/// With curves: the diagnosis with the features it read, and the residual curves the report draws.
fn with_features(
    study: &Study,
    stage: Option<&curves::CurveStage>,
    problem: Option<&crate::diagnose::features::FeatureProblem>,
    d: Diagnosis,
    loops: &[(usize, crate::emulate::functional::CurveModel)],
) -> (Diagnosis, Vec<values::ResidualCurves>) {
    match (stage, problem) {
        (Some(stage), Some(problem)) => {
            let residuals = curves::residual_curves(study, stage, loops, &d);
            let report = curves::features_report(study, stage, problem, loops, &d);
            (d.with_features(report), residuals)
        }
        _ => (d, Vec::new()),
    }
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
    /// The solver-in-the-loop runs, when the screening chose a hypothesis to extend.
    pub joint: Option<extend::JointRuns>,
    /// The extended models they made, with their calibrated parameters (θ, then the extension's).
    pub extended: Vec<(extend::ExtendedModel, Vec<f64>)>,
    /// Calibration against curves: where along the stroke the model errs, per tested design.
    pub residual_curves: Vec<values::ResidualCurves>,
    /// A sequential study's batches (`None` for a fixed plan).
    pub sequence: Option<sequence::Sequence>,
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
                Some(match runs.joint {
                    Some(joint) => screening.merge(joint.outcomes),
                    None => screening,
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
    if study.splits.is_empty() {
        return None;
    }
    // Each split is calibrated on its own from the same runs and emulator: in parallel, in order.
    use rayon::prelude::*;
    Some(
        study
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
    s.training = split.training.clone();
    s.validation = split.validation.clone();
    let problem = problem(&s, surrogates as &dyn Model);
    let calibration = calibrate(&s, &problem, Some(runs));
    SplitCalibration { study: s, calibration }
}
