//! Calibration: find the parameters θ that make the simulation agree with the tests.
//!
//! The three methods of Qiu et al. (2018), each a pure function over arrays:
//!
//! - [`least_squares`]: Eq. 3, match the measured values themselves.
//! - [`sensitivity`]: Eq. 6, match the differences between consecutive training designs, then
//!   Eq. 7, a constant discrepancy `d` for the level.
//! - [`bayesian`]: Kennedy–O'Hagan (Appendix, Eqs. A1–A9): a GP emulator of the simulation plus a
//!   GP discrepancy, parameters by maximum likelihood, a posterior by MCMC.
//!
//! [`identifiability`] says which parameter combinations the training data can pin down.
//!
//! A [`Problem`] is data plus a [`Model`]; a method is a function `Problem -> Estimate`. Nothing
//! here reads files, so every method tests in milliseconds.

pub mod bayesian;
pub mod curves;
pub mod identifiability;
pub mod least_squares;
pub mod outcome;
pub mod sensitivity;

/// The box and the numerics' error live in the shared leaves; named here too, where the methods use them.
pub use crate::base::{Bounds, CalibrationError, optimize};
pub use crate::emulate::Model;
pub use outcome::{Calibrated, Calibration, Method};

use nalgebra::{DMatrix, DVector};

/// What every method needs: the training tests, the model, and the parameter bounds.
pub struct Problem<'a> {
    /// Training designs, one row per test design, in the order the study lists them.
    pub designs: DMatrix<f64>,
    /// Mean measured response at each training design.
    pub measured: DVector<f64>,
    /// Parameter bounds; every estimate stays inside.
    pub bounds: Bounds,
    pub model: &'a dyn Model,
}

impl Problem<'_> {
    pub fn design(&self, i: usize) -> Vec<f64> {
        self.designs.row(i).iter().copied().collect()
    }

    /// Simulation predictions at every training design for parameters `theta`.
    pub fn predictions(&self, theta: &DVector<f64>) -> DVector<f64> {
        DVector::from_iterator(
            self.designs.nrows(),
            (0..self.designs.nrows()).map(|i| self.model.predict(&self.design(i), theta.as_slice())),
        )
    }
}

/// A calibrated model: parameters plus, for methods that have one, a discrepancy.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate {
    pub theta: DVector<f64>,
    pub discrepancy: Discrepancy,
}

/// The model-error term a method adds to the simulation's prediction.
#[derive(Debug, Clone, PartialEq)]
pub enum Discrepancy {
    None,
    /// Eq. 7: `y_true(d) = y_pre(d, θ) + d`.
    Constant(f64),
}

impl Discrepancy {
    pub fn at(&self, _design: &[f64]) -> f64 {
        match self {
            Discrepancy::None => 0.0,
            Discrepancy::Constant(d) => *d,
        }
    }
}

/// The paper's cantilever (Sec. 3) as a ready-made problem, for the numerics' own tests.
#[cfg(test)]
pub(crate) mod testing {
    use super::*;

    pub const F: f64 = 600.0;
    pub const B: f64 = 2.0;
    pub const NU: f64 = 0.36;
    pub const E0: f64 = 68_000.0;
    pub const L0: f64 = 20.0;

    /// Eq. 10: the Euler–Bernoulli tip deflection (the simulation).
    pub fn euler(h: f64, e: f64, l: f64) -> f64 {
        4.0 * F * l.powi(3) / (e * B * h.powi(3))
    }

    /// Eq. 11: the Timoshenko tip deflection with E0 (the "tests").
    pub fn timoshenko(h: f64) -> f64 {
        euler(h, E0, L0) + F * L0 * (4.0 + 5.0 * NU) / (2.0 * E0 * B * h)
    }

    fn problem(hs: &[f64], bounds: Bounds, model: &'static dyn Model) -> Problem<'static> {
        Problem {
            designs: DMatrix::from_column_slice(hs.len(), 1, hs),
            measured: DVector::from_iterator(hs.len(), hs.iter().map(|&h| timoshenko(h))),
            bounds,
            model,
        }
    }

    /// E calibrated in [50,000, 80,000] against Timoshenko tests at `hs`.
    pub fn cantilever(hs: &[f64]) -> Problem<'static> {
        static MODEL: fn(&[f64], &[f64]) -> f64 = |d, th| euler(d[0], th[0], L0);
        problem(hs, Bounds::new(vec![50_000.0], vec![80_000.0]), &MODEL)
    }

    /// E and L calibrated together (Table 1).
    pub fn cantilever_el(hs: &[f64]) -> Problem<'static> {
        static MODEL: fn(&[f64], &[f64]) -> f64 = |d, th| euler(d[0], th[0], th[1]);
        problem(hs, Bounds::new(vec![50_000.0, 15.0], vec![80_000.0, 25.0]), &MODEL)
    }
}

#[cfg(test)]
mod tests {
    use super::Bounds;

    /// A range wider than a decade is spread uniformly in ln x, a narrower one linearly; the ends of
    /// the unit interval are the bounds either way, and strata of equal width in u hold equal
    /// ratios in x.
    #[test]
    fn a_range_wider_than_a_decade_is_spread_in_ln_x() {
        let b = Bounds::new(vec![1000.0, 100.0, -1.0], vec![40000.0, 250.0, 1.0]);
        assert!(b.spread_in_ln(0) && !b.spread_in_ln(1) && !b.spread_in_ln(2));
        let mid = b.spread(&[0.5, 0.5, 0.5]);
        assert!((mid[0] - (1000.0f64 * 40000.0).sqrt()).abs() < 1e-9, "{mid:?}");
        assert_eq!(&mid[1..], &[175.0, 0.0]);
        assert_eq!(b.spread(&[0.0, 0.0, 0.0]), vec![1000.0, 100.0, -1.0]);
        let top = b.spread(&[1.0, 1.0, 1.0]);
        assert!(
            (top[0] - 40000.0).abs() < 1e-9 && top[1] == 250.0 && top[2] == 1.0,
            "{top:?}"
        );
        let q = |u: f64| b.spread(&[u, 0.0, 0.0])[0];
        assert!((q(0.25) / q(0.0) - q(1.0) / q(0.75)).abs() < 1e-9);
        // Exactly a decade is still spread linearly (the emulators log it: ln x is measured
        // harmless there).
        assert!(!Bounds::new(vec![1.0], vec![10.0]).spread_in_ln(0));
    }
}
