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
use crate::emulate::{DesignSurrogate, Surrogate, SurrogateModel};
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

/// One surrogate per tested design (training, then validation) over `bounds`, fitted to the
/// design's successful sample runs among `runs` and checked at its successful check runs. A design
/// with no runs is left out; one whose fit fails is `Err((design, why))`.
pub fn fit_designs(
    study: &Study,
    kind: SurrogateKind,
    bounds: &Bounds,
    runs: &[FitRun],
) -> Vec<Result<DesignSurrogate, (String, String)>> {
    study
        .training
        .iter()
        .chain(&study.validation)
        .filter_map(|name| {
            let mine: Vec<&FitRun> = runs.iter().filter(|r| &r.run.design == name).collect();
            let values = mine.first()?.run.design_values.clone();
            let of = |check: bool| -> Vec<(Vec<f64>, f64)> {
                mine.iter()
                    .filter(|r| r.check == check)
                    .filter_map(|r| r.y.map(|y| (r.point.clone(), y)))
                    .collect()
            };
            let samples = of(false);
            Some(match Surrogate::fit(kind, &samples, bounds) {
                Ok(surrogate) => Ok(DesignSurrogate {
                    design: name.clone(),
                    values,
                    check: surrogate.check(&of(true)),
                    surrogate,
                    samples: samples.len(),
                }),
                Err(e) => Err((name.clone(), e.to_string())),
            })
        })
        .collect()
}

/// The study's surrogates over `bounds`, one per tested design: its own ([`fit_designs`]), or with
/// `sampling.across_designs` the designs' slices of one emulator ([`fit_across`]).
pub fn fit_surrogates(
    study: &Study,
    sim: &SolverSimulation,
    bounds: &Bounds,
    runs: &[FitRun],
) -> Vec<Result<DesignSurrogate, (String, String)>> {
    if sim.across_designs() {
        fit_across(study, bounds, runs)
    } else {
        fit_designs(study, sim.surrogate, bounds, runs)
    }
}

/// One Gaussian process across the tested designs, over their values and `bounds`, fitted to every
/// successful run, the check runs too; each design gets its slice, checked at its check runs (its
/// latest batch) by the emulator fitted to every other run: the error the sequence measured when it
/// stopped ([`crate::pipeline::sequence::sites::measured_errors_across`]).
pub fn fit_across(study: &Study, bounds: &Bounds, runs: &[FitRun]) -> Vec<Result<DesignSurrogate, (String, String)>> {
    use rayon::prelude::*;
    let rows: Vec<(&FitRun, Vec<f64>, f64)> = runs
        .iter()
        .filter_map(|r| Some((r, r.run.design_values.iter().chain(&r.point).copied().collect(), r.y?)))
        .collect();
    let names: Vec<&String> = study.training.iter().chain(&study.validation).collect();
    let values: Vec<Vec<f64>> = names
        .iter()
        .filter_map(|n| {
            rows.iter()
                .find(|r| &&r.0.run.design == n)
                .map(|r| r.0.run.design_values.clone())
        })
        .collect();
    let joint = crate::emulate::sequential::shared::joint_bounds(&values, bounds);
    let fit = |keep: &dyn Fn(usize) -> bool| {
        let kept: Vec<usize> = (0..rows.len()).filter(|&i| keep(i)).collect();
        let x = DMatrix::from_fn(kept.len(), joint.dim(), |i, k| rows[kept[i]].1[k]);
        let y = DVector::from_iterator(kept.len(), kept.iter().map(|&i| rows[i].2));
        crate::emulate::gp::Emulator::fit(&x, &y, &joint)
    };
    let whole = fit(&|_| true).map(std::sync::Arc::new);
    names
        .into_par_iter()
        .filter_map(|name| {
            let mine: Vec<usize> = (0..rows.len()).filter(|&i| &rows[i].0.run.design == name).collect();
            let values = rows.get(*mine.first()?)?.0.run.design_values.clone();
            let emulator = match &whole {
                Ok(e) => e.clone(),
                Err(e) => return Some(Err((name.clone(), e.to_string()))),
            };
            let held: Vec<usize> = mine.iter().copied().filter(|&i| rows[i].0.check).collect();
            let errors: Vec<f64> = match fit(&|j| !held.contains(&j)) {
                Ok(others) if !held.is_empty() => {
                    let x = DMatrix::from_fn(held.len(), joint.dim(), |r, k| rows[held[r]].1[k]);
                    let m = others.mean(&x);
                    held.iter()
                        .zip(m.iter())
                        .map(|(&i, m)| ((m - rows[i].2) / rows[i].2).abs())
                        .collect()
                }
                _ => Vec::new(),
            };
            Some(Ok(DesignSurrogate {
                design: name.clone(),
                values: values.clone(),
                check: crate::emulate::CheckError::of(&errors),
                surrogate: Surrogate::across(emulator, values),
                samples: mine.len(),
            }))
        })
        .collect()
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
            // linear surrogate of the extension there.
            let per_design = runs.len() / crate::plan::sweep::tested_designs(study).count().max(1);
            let kind = super::sequence::sites::kind_for(sim.surrogate, per_design, bounds.dim());
            let fitted = if crate::plan::sweep::probes_across(study, sim) {
                fit_across(study, &bounds, &runs)
            } else {
                fit_designs(study, kind, &bounds, &runs)
            };
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
