//! The stages' numerics wiring: what [`super::run`] calls between the run engine and the report.
//!
//! A closed-form study's model is its expression ([`model`]). A solver study's model is built from
//! runs: responses per planned run → [`surrogates`] (one per design) → the same calibration; the
//! Bayesian method is fed the sample runs themselves ([`simulation_data`]) instead of sampling the
//! model. Nothing here reads or writes files.

use nalgebra::{DMatrix, DVector};

use crate::calibrate::identifiability;
use crate::calibrate::{
    Calibrated, Calibration, CalibrationError, Method, Model, Problem, bayesian, least_squares, sensitivity,
};
use crate::diagnose::{self, Diagnosis};
use crate::error::Error;
use crate::fit::{DesignSurrogate, Surrogate, SurrogateModel};
use crate::model::ExpressionModel;
use crate::plan::{Plan, RunRole};
use crate::study::{SolverSimulation, Study};

/// The closed-form simulation of a study as a model the numerics can call; `None` for a solver study.
pub fn model(study: &Study) -> Option<Box<dyn Model>> {
    ExpressionModel::new(study).map(|m| Box::new(m) as Box<dyn Model>)
}

/// One surrogate per planned design, fitted to its successful sample runs and checked at its
/// successful check runs. `responses` follows the plan's order.
pub fn surrogates(
    study: &Study,
    sim: &SolverSimulation,
    plan: &Plan,
    responses: &[Option<f64>],
) -> Result<SurrogateModel, Error> {
    let bounds = study.parameter_bounds();
    let mut designs: Vec<DesignSurrogate> = Vec::new();
    for name in study.training.iter().chain(&study.validation) {
        let runs = |role| -> Vec<(Vec<f64>, f64)> {
            plan.runs
                .iter()
                .zip(responses)
                .filter(|(r, _)| &r.design == name && r.role == role)
                .filter_map(|(r, y)| y.map(|y| (r.theta.clone(), y)))
                .collect()
        };
        let Some(values) = plan
            .runs
            .iter()
            .find(|r| &r.design == name)
            .map(|r| r.design_values.clone())
        else {
            continue;
        };
        let samples = runs(RunRole::Sample);
        let surrogate = Surrogate::fit(sim.surrogate, &samples, &bounds)
            .map_err(|e| Error::Failed(format!("design `{name}`: cannot fit its surrogate: {e}")))?;
        let check = surrogate.check(&runs(RunRole::Check));
        designs.push(DesignSurrogate {
            design: name.clone(),
            values,
            surrogate,
            check,
            samples: samples.len(),
        });
    }
    Ok(SurrogateModel { designs })
}

/// The successful sample runs as emulator data for the Bayesian method: design values then
/// parameters per row, the response as output.
pub fn simulation_data(plan: &Plan, responses: &[Option<f64>]) -> bayesian::SimulationData {
    let rows: Vec<(Vec<f64>, f64)> = plan
        .runs
        .iter()
        .zip(responses)
        .filter(|(r, _)| r.role == RunRole::Sample)
        .filter_map(|(r, y)| y.map(|y| (r.design_values.iter().chain(&r.theta).copied().collect(), y)))
        .collect();
    let cols = rows.first().map_or(0, |r| r.0.len());
    bayesian::SimulationData::new(
        DMatrix::from_fn(rows.len(), cols, |i, k| rows[i].0[k]),
        DVector::from_iterator(rows.len(), rows.iter().map(|r| r.1)),
    )
}

/// The training problem of a study: designs in the order the study lists them, mean measurements.
pub fn problem<'a>(study: &Study, model: &'a dyn Model) -> Problem<'a> {
    let tests: Vec<_> = study
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
            let mut designs = Vec::new();
            for name in study.training.iter().chain(&study.validation) {
                let runs: Vec<(&crate::plan::PlannedRun, f64)> = plan
                    .runs
                    .iter()
                    .zip(responses)
                    .filter(|(r, _)| &r.design == name && r.role == RunRole::Extension(k))
                    .filter_map(|(r, y)| y.map(|y| (r, y)))
                    .collect();
                let Some(values) = runs.first().map(|(r, _)| r.design_values.clone()) else {
                    continue;
                };
                let samples: Vec<(Vec<f64>, f64)> = runs.iter().map(|(r, y)| (r.theta.clone(), *y)).collect();
                let Ok(surrogate) = Surrogate::fit(sim.surrogate, &samples, &bounds) else {
                    continue;
                };
                let check = surrogate.check(&[]);
                designs.push(DesignSurrogate {
                    design: name.clone(),
                    values,
                    surrogate,
                    check,
                    samples: samples.len(),
                });
            }
            (k, SurrogateModel { designs })
        })
        .collect()
}

/// [`diagnose()`] for a solver study: its model-extension hypotheses become candidates
/// `y_ext(d, θ) − y(d, θ)` from the surrogates of their runs.
pub fn diagnose_solver(
    study: &Study,
    sim: &SolverSimulation,
    plan: &Plan,
    responses: &[Option<f64>],
    model: &dyn Model,
) -> Result<Diagnosis, CalibrationError> {
    let extensions: Vec<(usize, std::sync::Arc<dyn Model + Send>)> = extension_surrogates(study, sim, plan, responses)
        .into_iter()
        .map(|(k, m)| (k, std::sync::Arc::new(m) as std::sync::Arc<dyn Model + Send>))
        .collect();
    diagnose::diagnose(&diagnose::inputs_with_extensions(study, model, &extensions))
}
