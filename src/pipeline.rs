//! `lab run`: study → model → calibrate → report, one typed value handed from stage to stage.

use nalgebra::{DMatrix, DVector};

use crate::calibrate::identifiability::{self, Identifiability};
use crate::calibrate::{
    CalibrationError, Estimate, Model, Problem, bayesian, least_squares, sensitivity,
};
use crate::diagnose::{self, Diagnosis};
use crate::model::ExpressionModel;
use crate::study::{Method, Study};

/// A method's calibrated model, whatever its kind.
pub enum Calibrated {
    /// Least squares or sensitivity: parameters plus an optional constant discrepancy.
    Point(Estimate),
    Bayesian(Box<bayesian::BayesianFit>),
}

impl Calibrated {
    pub fn theta(&self) -> &DVector<f64> {
        match self {
            Calibrated::Point(e) => &e.theta,
            Calibrated::Bayesian(fit) => &fit.theta,
        }
    }

    /// The calibrated prediction at a design, discrepancy included where the method has one.
    pub fn predict(&self, model: &dyn Model, design: &[f64]) -> f64 {
        match self {
            Calibrated::Point(e) => model.predict(design, e.theta.as_slice()) + e.discrepancy.at(design),
            Calibrated::Bayesian(fit) => fit.predict(design),
        }
    }
}

/// Everything calibration produced for a study.
pub struct Calibration {
    /// One entry per method the study asks for, in its order; a failed method keeps its error.
    pub methods: Vec<(Method, Result<Calibrated, CalibrationError>)>,
    pub identifiability: Identifiability,
}

/// The simulation of a study as a model the numerics can call.
pub fn model(study: &Study) -> Box<dyn Model> {
    Box::new(ExpressionModel::new(study))
}

/// The training problem of a study: designs in the order the study lists them, mean measurements.
pub fn problem<'a>(study: &Study, model: &'a dyn Model) -> Problem<'a> {
    let tests: Vec<_> = study
        .training
        .iter()
        .map(|name| study.experiments.get(name).expect("validated: training designs are in the experiments"))
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
pub fn calibrate(study: &Study, problem: &Problem) -> Calibration {
    let methods: Vec<_> = study
        .calibration
        .methods
        .iter()
        .map(|&method| (method, run_method(study, problem, method)))
        .collect();
    let at = match methods.iter().find(|(m, _)| *m == Method::LeastSquares) {
        Some((_, Ok(c))) => c.theta().clone(),
        _ => least_squares::calibrate(problem).map(|e| e.theta).unwrap_or_else(|_| problem.bounds.center()),
    };
    let names: Vec<String> = study.parameters.iter().map(|p| p.name.clone()).collect();
    Calibration { methods, identifiability: identifiability::analyse(problem, &names, &at) }
}

fn run_method(study: &Study, problem: &Problem, method: Method) -> Result<Calibrated, CalibrationError> {
    match method {
        Method::LeastSquares => least_squares::calibrate(problem).map(Calibrated::Point),
        Method::Sensitivity => sensitivity::calibrate(problem).map(Calibrated::Point),
        Method::Bayesian => {
            let settings = &study.calibration.bayesian;
            let design_bounds = study.design_bounds();
            let samples = bayesian::emulator_samples(problem, &design_bounds, settings);
            bayesian::calibrate(problem, &design_bounds, &samples, settings)
                .map(|fit| Calibrated::Bayesian(Box::new(fit)))
        }
    }
}

/// Diagnoses model error over every tested design of the study (training and validation).
pub fn diagnose(study: &Study, model: &dyn Model) -> Result<Diagnosis, CalibrationError> {
    diagnose::diagnose(&diagnose::inputs_from_study(study, model))
}
