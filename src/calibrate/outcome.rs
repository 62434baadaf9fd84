//! What calibrating a study produced: per method its calibrated model (or why it failed), and the
//! identifiability check. The methods themselves are [`super::least_squares`],
//! [`super::sensitivity`] and [`super::bayesian`]; this is the value handed on to diagnosis and report.

use nalgebra::DVector;

use super::identifiability::Identifiability;
use super::{CalibrationError, Estimate, Model, bayesian};

pub use crate::study::Method;

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
