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
pub mod optimize;
pub mod outcome;
pub mod sensitivity;

pub use outcome::{Calibrated, Calibration, Method};

use nalgebra::{DMatrix, DVector};

/// The simulation as the numerics see it: a response `y(d, θ)` at design `d` and parameters `θ`.
///
/// Implemented by closed-form expressions and by surrogates fitted to solver runs.
pub trait Model: Sync {
    fn predict(&self, design: &[f64], theta: &[f64]) -> f64;
}

impl<F: Fn(&[f64], &[f64]) -> f64 + Sync> Model for F {
    fn predict(&self, design: &[f64], theta: &[f64]) -> f64 {
        self(design, theta)
    }
}

/// A box `lower ≤ x ≤ upper`, one interval per coordinate.
#[derive(Debug, Clone, PartialEq)]
pub struct Bounds {
    pub lower: DVector<f64>,
    pub upper: DVector<f64>,
}

impl Bounds {
    pub fn new(lower: Vec<f64>, upper: Vec<f64>) -> Self {
        assert_eq!(lower.len(), upper.len(), "bounds need as many lower as upper values");
        Bounds {
            lower: DVector::from_vec(lower),
            upper: DVector::from_vec(upper),
        }
    }

    pub fn dim(&self) -> usize {
        self.lower.len()
    }

    pub fn width(&self) -> DVector<f64> {
        &self.upper - &self.lower
    }

    pub fn center(&self) -> DVector<f64> {
        (&self.upper + &self.lower) / 2.0
    }

    /// Maps `x` into the unit cube.
    pub fn to_unit(&self, x: &DVector<f64>) -> DVector<f64> {
        (x - &self.lower).component_div(&self.width())
    }

    /// Maps a point of the unit cube back into the box.
    pub fn from_unit(&self, u: &DVector<f64>) -> DVector<f64> {
        &self.lower + u.component_mul(&self.width())
    }

    pub fn clamp(&self, x: &DVector<f64>) -> DVector<f64> {
        x.zip_zip_map(&self.lower, &self.upper, |v, lo, hi| v.clamp(lo, hi))
    }

    /// Whether coordinate `k` is spread uniformly in ln x ([`Bounds::spread`]): a positive range
    /// wider than [`LOG_SPREAD_RATIO`].
    pub fn spread_in_ln(&self, k: usize) -> bool {
        self.lower[k] > 0.0 && self.upper[k] > LOG_SPREAD_RATIO * self.lower[k]
    }

    /// The point of the box a sampling design puts at `u` of the unit cube: linearly, except over a
    /// positive range wider than a decade, where uniformly in ln x. Such a variable (a Cowper–Symonds
    /// C from 1,000 to 40,000 /s, a stiffness over decades) acts per decade, not per unit: spread
    /// linearly, 24 runs would put one in its lowest decade, where (ε̇/C)^(1/p) changes most.
    pub fn spread(&self, u: &[f64]) -> Vec<f64> {
        (0..self.dim())
            .map(|k| {
                let (lo, hi) = (self.lower[k], self.upper[k]);
                if self.spread_in_ln(k) {
                    (lo.ln() + u[k] * (hi.ln() - lo.ln())).exp().clamp(lo, hi)
                } else {
                    lo + u[k] * (hi - lo)
                }
            })
            .collect()
    }

    /// [`Bounds::spread`] of every row of `unit` (a sampling design in the unit cube).
    pub fn spread_rows(&self, unit: &DMatrix<f64>) -> Vec<Vec<f64>> {
        unit.row_iter()
            .map(|u| self.spread(&u.iter().copied().collect::<Vec<_>>()))
            .collect()
    }
}

/// Upper/lower ratio above which a positive range is spread uniformly in ln x ([`Bounds::spread`]).
pub const LOG_SPREAD_RATIO: f64 = 10.0;

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

/// Why a method could not produce an estimate.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CalibrationError {
    #[error("{method} needs at least {needed} training designs, the study gives {given}")]
    TooFewDesigns {
        method: &'static str,
        needed: usize,
        given: usize,
    },
    #[error("the model returned a non-finite value at the starting point ({0})")]
    NonFinite(String),
    #[error("{0}")]
    Numerics(String),
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
