//! The stages' numerics wiring: what [`super::run`] calls between the run engine and the report.
//!
//! A closed-form study's model is its expression ([`model`]). A solver study's model is built from
//! runs: responses per planned run → [`surrogates`] (one per design) → the same calibration; the
//! Bayesian method is fed the sample runs themselves ([`simulation_data`]) instead of sampling the
//! model. Nothing here reads or writes files.

use nalgebra::{DMatrix, DVector};

use crate::calibrate::{Bounds, identifiability};
use crate::calibrate::{
    Calibrated, Calibration, CalibrationError, Method, Model, Problem, bayesian, least_squares, sensitivity,
};
use crate::diagnose::{self, Diagnosis};
use crate::emulate::ExpressionModel;
use crate::emulate::fits::{AcrossGp, Kind};
use crate::emulate::{self, DesignSurrogate, Run, Surrogate, SurrogateModel};
use crate::error::Error;
use crate::plan::{Plan, PlannedRun, RunRole};
use crate::study::solver::SurrogateKind;
use crate::study::{SolverSimulation, Study};

/// The closed-form simulation of a study as a model the numerics can call; `None` for a solver study.
pub fn model(study: &Study) -> Option<Box<dyn Model>> {
    ExpressionModel::new(study).map(|m| Box::new(m) as Box<dyn Model>)
}

/// A run as a surrogate sees it: its point in the surrogate's space (θ, or θ and an extension's
/// ranged variables), its response (`None`: failed, or left out as suspect), and whether it is a
/// check run.
pub struct FitRun<'a> {
    pub run: &'a PlannedRun,
    pub point: Vec<f64>,
    pub y: Option<f64>,
    pub check: bool,
}

/// The runs as the emulator layer takes them (their check runs held out).
fn as_runs<'a>(runs: &'a [FitRun]) -> Vec<Run<'a, f64>> {
    runs.iter()
        .map(|r| Run {
            design: &r.run.design,
            values: &r.run.design_values,
            x: &r.point,
            y: r.y.as_ref(),
        })
        .collect()
}

/// The study's surrogates over `bounds`, one per tested design (training, then validation), each
/// checked at its check runs by an emulator fitted without them: its own, fitted to the design's
/// sample runs, or with `sampling.across_designs` its slice of one Gaussian process across the
/// designs fitted to every run, checked by a refit without the design's check runs (its latest
/// batch: the error the sequence measured when it stopped). A design with no runs is left out; one
/// whose fit fails is `Err((design, why))`.
pub fn fit_surrogates(
    study: &Study,
    sim: &SolverSimulation,
    bounds: &Bounds,
    runs: &[FitRun],
) -> Vec<Result<DesignSurrogate, (String, String)>> {
    let kind = if sim.across_designs() {
        None
    } else {
        Some(sim.surrogate)
    };
    fit_kind(study, kind, bounds, runs)
}

/// [`fit_surrogates`] with the kind of each design's own surrogate, or `None`: one across them.
fn fit_kind(
    study: &Study,
    kind: Option<SurrogateKind>,
    bounds: &Bounds,
    runs: &[FitRun],
) -> Vec<Result<DesignSurrogate, (String, String)>> {
    let names: Vec<&String> = study.split.training.iter().chain(&study.split.validation).collect();
    let all = as_runs(runs);
    let check = |r: &Run<f64>| runs[index_of(&all, r)].check;
    let fitted = match kind {
        Some(kind) => emulate::by_design::<Surrogate>(&Kind::new(kind, bounds.clone()), &names, &all, &check),
        None => {
            let values: Vec<Vec<f64>> = names
                .iter()
                .filter_map(|n| runs.iter().find(|r| r.y.is_some() && &&r.run.design == n))
                .map(|r| r.run.design_values.clone())
                .collect();
            let joint = crate::emulate::sequential::shared::joint_bounds(&values, bounds);
            emulate::across::<AcrossGp>(&joint, &names, &all, &check)
        }
    };
    fitted
        .into_iter()
        .map(|f| f.map(|f| design_surrogate(f, &all)))
        .collect()
}

/// A run's index among `all` (the runs are borrowed from one slice: found by address).
fn index_of<Y>(all: &[Run<'_, Y>], r: &Run<'_, Y>) -> usize {
    all.iter()
        .position(|a| std::ptr::eq(a.x, r.x))
        .expect("a run of the slice")
}

/// A design's fitted surrogate with its check: the signed relative errors at its held-out runs.
fn design_surrogate(f: emulate::DesignFit<Surrogate, f64>, all: &[Run<'_, f64>]) -> DesignSurrogate {
    let signed = f
        .held
        .runs
        .iter()
        .zip(&f.held.predicted)
        .map(|(&i, m)| {
            let y = *all[i].y.expect("held out with an output");
            (all[i].x.to_vec(), (m - y) / y)
        })
        .collect();
    DesignSurrogate {
        design: f.design,
        values: f.values,
        check: crate::emulate::CheckError::signed(signed),
        surrogate: f.emulator,
        samples: f.fitted,
    }
}

/// The sample runs among `runs` that succeeded, as emulator data for the Bayesian method: design
/// values then the run's point per row, the response as output.
pub fn emulator_data(runs: &[FitRun]) -> bayesian::SimulationData {
    let rows: Vec<(Vec<f64>, f64)> = runs
        .iter()
        .filter(|r| !r.check)
        .filter_map(|r| {
            r.y.map(|y| (r.run.design_values.iter().chain(&r.point).copied().collect(), y))
        })
        .collect();
    let cols = rows.first().map_or(0, |r| r.0.len());
    bayesian::SimulationData::new(
        DMatrix::from_fn(rows.len(), cols, |i, k| rows[i].0[k]),
        DVector::from_iterator(rows.len(), rows.iter().map(|r| r.1)),
    )
}

/// The baseline's runs (samples and checks) over θ. `responses` follows the plan's order.
fn baseline_runs<'a>(plan: &'a Plan, responses: &[Option<f64>]) -> Vec<FitRun<'a>> {
    plan.runs
        .iter()
        .zip(responses)
        .filter(|(r, _)| matches!(r.role, RunRole::Sample | RunRole::Check))
        .map(|(run, y)| FitRun {
            run,
            point: run.theta.clone(),
            y: *y,
            check: run.role == RunRole::Check,
        })
        .collect()
}

/// One surrogate per planned design, fitted to its successful sample runs and checked at its
/// successful check runs. `responses` follows the plan's order.
pub fn surrogates(
    study: &Study,
    sim: &SolverSimulation,
    plan: &Plan,
    responses: &[Option<f64>],
) -> Result<SurrogateModel, Error> {
    let runs = baseline_runs(plan, responses);
    let designs = fit_surrogates(study, sim, &study.parameter_bounds(), &runs)
        .into_iter()
        .map(|d| d.map_err(|(name, e)| Error::Failed(format!("design `{name}`: cannot fit its surrogate: {e}"))))
        .collect::<Result<_, _>>()?;
    Ok(SurrogateModel { designs })
}

/// The successful sample runs as emulator data for the Bayesian method: design values then
/// parameters per row, the response as output.
pub fn simulation_data(plan: &Plan, responses: &[Option<f64>]) -> bayesian::SimulationData {
    emulator_data(&baseline_runs(plan, responses))
}

/// The training problem of a study: designs in the order the study lists them, mean measurements.
pub fn problem<'a>(study: &Study, model: &'a dyn Model) -> Problem<'a> {
    let tests: Vec<_> = study
        .split
        .training
        .iter()
        .map(|name| {
            study
                .experiments
                .get(name)
                .expect("validated: training designs are in the experiments")
        })
        .collect();
    let designs = DMatrix::from_fn(tests.len(), study.design.len(), |i, j| tests[i].values[j]);
    Problem {
        designs,
        measured: DVector::from_iterator(tests.len(), tests.iter().map(|t| t.mean())),
        bounds: study.parameter_bounds(),
        model,
    }
}

/// Runs every method the study names, then the identifiability check at the least-squares point.
/// `runs`: a solver study's sample runs, which the Bayesian method's emulator is fitted to; without
/// them it samples the model (a closed form) on a Latin hypercube.
pub fn calibrate(study: &Study, problem: &Problem, runs: Option<&bayesian::SimulationData>) -> Calibration {
    let methods: Vec<_> = study
        .calibration
        .methods
        .iter()
        .map(|&method| (method, run_method(study, problem, method, runs)))
        .collect();
    let at = match methods.iter().find(|(m, _)| *m == Method::LeastSquares) {
        Some((_, Ok(c))) => c.theta().clone(),
        _ => least_squares::calibrate(problem)
            .map(|e| e.theta)
            .unwrap_or_else(|_| problem.bounds.center()),
    };
    let names: Vec<String> = study.parameters.iter().map(|p| p.name.clone()).collect();
    Calibration {
        methods,
        identifiability: identifiability::analyse(problem, &names, &at),
    }
}

fn run_method(
    study: &Study,
    problem: &Problem,
    method: Method,
    runs: Option<&bayesian::SimulationData>,
) -> Result<Calibrated, CalibrationError> {
    match method {
        Method::LeastSquares => least_squares::calibrate(problem).map(Calibrated::Point),
        Method::Sensitivity => sensitivity::calibrate(problem).map(Calibrated::Point),
        Method::Bayesian => {
            let settings = &study.calibration.bayesian;
            let design_bounds = study.design_bounds();
            let sampled;
            let samples = match runs {
                Some(runs) => runs,
                None => {
                    sampled = bayesian::emulator_samples(problem, &design_bounds, settings);
                    &sampled
                }
            };
            bayesian::calibrate(problem, &design_bounds, samples, settings)
                .map(|fit| Calibrated::Bayesian(Box::new(fit)))
        }
    }
}

/// Diagnoses model error over every tested design of the study (training and validation).
pub fn diagnose(study: &Study, model: &dyn Model) -> Result<Diagnosis, CalibrationError> {
    diagnose::diagnose(&diagnose::inputs_from_study(study, model))
}

/// The surrogates of each model-extension hypothesis's runs ([`RunRole::Extension`]): per design,
/// the same kind as the study's surrogate, fitted over θ to the design's successful extension runs.
/// `(k, model)` for `study.diagnosis.hypotheses[k]`; a design whose extension runs cannot be fitted
/// (failed runs) is left out, so the candidate is not finite there and the diagnosis skips it with
/// a note rather than guess.
pub fn extension_surrogates(
    study: &Study,
    sim: &SolverSimulation,
    plan: &Plan,
    responses: &[Option<f64>],
) -> Vec<(usize, SurrogateModel)> {
    let bounds = study.parameter_bounds();
    study
        .extension_hypotheses()
        .map(|(k, _)| {
            let runs: Vec<FitRun> = plan
                .runs
                .iter()
                .zip(responses)
                .filter(|(r, _)| r.role == RunRole::Extension(k))
                .map(|(run, y)| FitRun {
                    run,
                    point: run.theta.clone(),
                    y: *y,
                    check: false,
                })
                .collect();
            // A sequential study probes each design at p + 1 points of the posterior: enough for a
            // linear surrogate of the extension there; counted where they finished.
            let per_design = crate::plan::sweep::tested_designs(study)
                .map(|(d, _)| runs.iter().filter(|r| &r.run.design == d && r.y.is_some()).count())
                .min()
                .unwrap_or(0);
            let kind = super::sequence::sites::kind_for(sim.surrogate, per_design, bounds.dim());
            let across = crate::plan::sweep::probes_across(study, sim);
            let fitted = fit_kind(study, (!across).then_some(kind), &bounds, &runs);
            let designs = fitted.into_iter().filter_map(Result::ok).collect();
            (k, SurrogateModel { designs })
        })
        .collect()
}

/// Each model-extension hypothesis's screening runs as a model over θ (the surrogates of
/// [`extension_surrogates`]), shareable with the loop models' diagnoses.
pub fn extension_models(
    study: &Study,
    sim: &SolverSimulation,
    plan: &Plan,
    responses: &[Option<f64>],
) -> Vec<(usize, std::sync::Arc<dyn Model + Send>)> {
    extension_surrogates(study, sim, plan, responses)
        .into_iter()
        .map(|(k, m)| (k, std::sync::Arc::new(m) as std::sync::Arc<dyn Model + Send>))
        .collect()
}
