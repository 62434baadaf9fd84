//! Kennedy–O'Hagan Bayesian calibration (paper Appendix, Eqs. A1–A9).
//!
//! y_true(d) = y_pre(d, θ) + δ(d)   (A1)
//!
//! - `y_pre` is a GP emulator over (design, parameters) fitted to simulation samples (A2–A4):
//!   quadratic trend, Gaussian kernel, hyperparameters by maximum likelihood.
//! - `δ` is a GP discrepancy with a constant trend (A5–A7).
//! - θ by maximum likelihood of the tests given the emulator (A8–A9), then MCMC samples of the
//!   posterior of θ for a 95 % interval.

mod gp;
mod optim;

use nalgebra::{DMatrix, DVector};

use super::{Bounds, CalibrationError, Problem};

/// Simulation samples for the emulator: one row per run, columns = design variables then parameters.
#[derive(Debug, Clone)]
pub struct SimulationData {
    pub inputs: DMatrix<f64>,
    pub outputs: DVector<f64>,
}

/// Knobs of the Bayesian method; defaults follow the paper (24 emulator samples).
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    pub emulator_samples: usize,
    pub seed: u64,
    pub mcmc_walkers: usize,
    pub mcmc_steps: usize,
    pub mcmc_burn_in: usize,
}

impl Default for Settings {
    fn default() -> Self {
        Settings { emulator_samples: 24, seed: 1, mcmc_walkers: 16, mcmc_steps: 2000, mcmc_burn_in: 500 }
    }
}

/// The calibrated Bayesian model.
#[derive(Debug, Clone)]
pub struct BayesianFit {
    /// Maximum-likelihood parameters.
    pub theta: DVector<f64>,
    /// 2.5 % and 97.5 % posterior quantiles per parameter.
    pub interval95: Vec<(f64, f64)>,
    /// Posterior median per parameter.
    pub median: DVector<f64>,
    /// Posterior samples after burn-in, one row per sample.
    pub posterior: DMatrix<f64>,
}

impl BayesianFit {
    /// Bias-corrected prediction at a design: emulator mean at θ̂ plus the discrepancy's posterior mean.
    pub fn predict(&self, _design: &[f64]) -> f64 {
        todo!("bayesian predict")
    }
}

/// Draws `settings.emulator_samples` Latin-hypercube points over design × parameter bounds and
/// evaluates the problem's model there.
pub fn emulator_samples(_problem: &Problem, _design_bounds: &Bounds, _settings: &Settings) -> SimulationData {
    todo!("emulator samples")
}

/// Calibrates θ by modular Kennedy–O'Hagan.
pub fn calibrate(
    _problem: &Problem,
    _design_bounds: &Bounds,
    _sim: &SimulationData,
    _settings: &Settings,
) -> Result<BayesianFit, CalibrationError> {
    todo!("bayesian calibrate")
}
