//! Surrogates: per design, the solver's response as a function of the parameters, fitted to the
//! design's sample runs and checked at its check runs.
//!
//! - `linear`, `quadratic`: least squares (SVD) on a polynomial in the parameters scaled to
//!   [-1, 1] (scaling keeps the normal equations well conditioned whatever the units).
//! - `gp`: the Bayesian module's GP emulator ([`crate::emulate::gp::Emulator`]) over the
//!   parameters alone.
//!
//! Together the surrogates form a [`SurrogateModel`], a [`Model`] whose `predict(design, θ)` looks
//! the design up by its values, so the calibration methods work on solver studies unchanged.
//!
//! ```
//! use lab::calibrate::Bounds;
//! use lab::emulate::Surrogate;
//! use lab::study::SurrogateKind;
//! let bounds = Bounds::new(vec![0.0], vec![10.0]);
//! let samples: Vec<(Vec<f64>, f64)> = (0..4).map(|i| (vec![i as f64 * 3.0], 2.0 + 0.5 * i as f64 * 3.0)).collect();
//! let s = Surrogate::fit(SurrogateKind::Linear, &samples, &bounds).unwrap();
//! assert!((s.predict(&[5.0]) - 4.5).abs() < 1e-12);
//! ```

use nalgebra::{DMatrix, DVector};

use super::Model;
use super::gp::Emulator;
use crate::base::Bounds;
use crate::study::SurrogateKind;

/// A fitted surrogate of one design.
#[derive(Debug, Clone)]
pub struct Surrogate {
    pub kind: SurrogateKind,
    fitted: Fitted,
}

#[derive(Debug, Clone)]
enum Fitted {
    Polynomial {
        bounds: Bounds,
        quadratic: bool,
        coefficients: DVector<f64>,
    },
    Gp(Box<Emulator>),
    /// One emulator across the designs, taken at this design's values.
    Across {
        emulator: std::sync::Arc<Emulator>,
        at: Vec<f64>,
    },
}

/// Why a surrogate could not be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    #[error("{kind} surrogate over {p} parameter(s) needs at least {needed} successful runs, got {given}")]
    TooFewRuns {
        kind: &'static str,
        p: usize,
        needed: usize,
        given: usize,
    },
    #[error("a response is not a finite number")]
    NonFinite,
    #[error("{0}")]
    Numerics(String),
}

/// Polynomial features of `theta` scaled to [-1, 1]: 1, t_k, then t_j t_k (j ≤ k) if quadratic.
fn features(bounds: &Bounds, quadratic: bool, theta: &[f64]) -> Vec<f64> {
    let t: Vec<f64> = theta
        .iter()
        .enumerate()
        .map(|(k, v)| 2.0 * (v - bounds.lower[k]) / bounds.width()[k] - 1.0)
        .collect();
    let mut f = vec![1.0];
    f.extend(&t);
    if quadratic {
        for j in 0..t.len() {
            f.extend((j..t.len()).map(|k| t[j] * t[k]));
        }
    }
    f
}

impl Surrogate {
    /// Fits a surrogate of `kind` to `(θ, response)` samples in the parameter box `bounds`.
    pub fn fit(kind: SurrogateKind, samples: &[(Vec<f64>, f64)], bounds: &Bounds) -> Result<Surrogate, FitError> {
        let p = bounds.dim();
        let needed = kind.min_samples(p);
        if samples.len() < needed {
            return Err(FitError::TooFewRuns {
                kind: kind.key(),
                p,
                needed,
                given: samples.len(),
            });
        }
        if samples
            .iter()
            .any(|(t, y)| !y.is_finite() || t.iter().any(|v| !v.is_finite()))
        {
            return Err(FitError::NonFinite);
        }
        let fitted = match kind {
            SurrogateKind::Linear => polynomial(samples, bounds, false)?,
            SurrogateKind::Quadratic => polynomial(samples, bounds, true)?,
            SurrogateKind::Gp => {
                let inputs = DMatrix::from_fn(samples.len(), p, |i, k| samples[i].0[k]);
                let outputs = DVector::from_iterator(samples.len(), samples.iter().map(|s| s.1));
                let emulator =
                    Emulator::fit(&inputs, &outputs, bounds).map_err(|e| FitError::Numerics(e.to_string()))?;
                Fitted::Gp(Box::new(emulator))
            }
        };
        Ok(Surrogate { kind, fitted })
    }

    pub fn predict(&self, theta: &[f64]) -> f64 {
        match &self.fitted {
            Fitted::Polynomial {
                bounds,
                quadratic,
                coefficients,
            } => features(bounds, *quadratic, theta)
                .iter()
                .zip(coefficients.iter())
                .map(|(f, c)| f * c)
                .sum(),
            Fitted::Gp(emulator) => emulator.mean(&DMatrix::from_row_slice(1, theta.len(), theta))[0],
            Fitted::Across { emulator, at } => {
                let x: Vec<f64> = at.iter().chain(theta).copied().collect();
                emulator.mean(&DMatrix::from_row_slice(1, x.len(), &x))[0]
            }
        }
    }

    /// The design at `at` of an emulator across the designs (whose inputs are the designs' values,
    /// then θ): a Gaussian-process surrogate of that design.
    pub fn across(emulator: std::sync::Arc<Emulator>, at: Vec<f64>) -> Surrogate {
        Surrogate {
            kind: SurrogateKind::Gp,
            fitted: Fitted::Across { emulator, at },
        }
    }

    /// Relative errors (predicted − run) / run at the check runs.
    pub fn check(&self, checks: &[(Vec<f64>, f64)]) -> CheckError {
        let signed = checks
            .iter()
            .map(|(t, y)| (t.clone(), (self.predict(t) - y) / y))
            .collect();
        CheckError::signed(signed)
    }
}

impl CheckError {
    /// The figures of relative errors `errors` (one per check run).
    pub fn of(errors: &[f64]) -> CheckError {
        let n = errors.len();
        CheckError {
            runs: n,
            max_relative_error: (n > 0).then(|| errors.iter().copied().fold(0.0, f64::max)),
            mean_relative_error: (n > 0).then(|| errors.iter().sum::<f64>() / n as f64),
            signed: Vec::new(),
        }
    }

    /// The figures of signed relative errors at their check points (θ, error).
    pub fn signed(signed: Vec<(Vec<f64>, f64)>) -> CheckError {
        let errors: Vec<f64> = signed.iter().map(|(_, e)| e.abs()).collect();
        CheckError {
            signed,
            ..CheckError::of(&errors)
        }
    }
}

fn polynomial(samples: &[(Vec<f64>, f64)], bounds: &Bounds, quadratic: bool) -> Result<Fitted, FitError> {
    let rows: Vec<Vec<f64>> = samples.iter().map(|(t, _)| features(bounds, quadratic, t)).collect();
    let a = DMatrix::from_fn(rows.len(), rows[0].len(), |i, j| rows[i][j]);
    let b = DVector::from_iterator(samples.len(), samples.iter().map(|s| s.1));
    let coefficients = a
        .svd(true, true)
        .solve(&b, 1e-12)
        .map_err(|e| FitError::Numerics(format!("least squares of the surrogate: {e}")))?;
    Ok(Fitted::Polynomial {
        bounds: bounds.clone(),
        quadratic,
        coefficients,
    })
}

/// A surrogate's error at the check runs (`None` without check runs).
#[derive(Debug, Clone, PartialEq)]
pub struct CheckError {
    pub runs: usize,
    pub max_relative_error: Option<f64>,
    pub mean_relative_error: Option<f64>,
    /// Each check run's point θ and signed relative error (predicted − run) / run, where known: the
    /// error's shape across designs ([`super::Uncertainty::beyond`]).
    pub signed: Vec<(Vec<f64>, f64)>,
}

/// The surrogate of one design, with its check.
#[derive(Debug, Clone)]
pub struct DesignSurrogate {
    pub design: String,
    pub values: Vec<f64>,
    pub surrogate: Surrogate,
    pub check: CheckError,
    /// Successful sample runs it was fitted to.
    pub samples: usize,
}

/// Per-design surrogates as one model. A design that was not planned has no surrogate: its
/// prediction is NaN (the numerics report non-finite values rather than use a made-up number).
#[derive(Debug, Clone)]
pub struct SurrogateModel {
    pub designs: Vec<DesignSurrogate>,
}

impl Model for SurrogateModel {
    fn predict(&self, design: &[f64], theta: &[f64]) -> f64 {
        self.designs
            .iter()
            .find(|d| d.values == design)
            .map_or(f64::NAN, |d| d.surrogate.predict(theta))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn samples(f: impl Fn(f64, f64) -> f64) -> Vec<(Vec<f64>, f64)> {
        let plan = crate::base::latin_hypercube(12, 2, 3);
        (0..12)
            .map(|i| {
                let t = vec![1.0 + 2.0 * plan[(i, 0)], 100.0 + 50.0 * plan[(i, 1)]];
                let y = f(t[0], t[1]);
                (t, y)
            })
            .collect()
    }

    fn bounds() -> Bounds {
        Bounds::new(vec![1.0, 100.0], vec![3.0, 150.0])
    }

    #[test]
    fn quadratic_reproduces_a_quadratic_exactly() {
        let f = |a: f64, b: f64| 1.0 + a * a - 0.01 * a * b + 0.001 * b * b;
        let s = Surrogate::fit(SurrogateKind::Quadratic, &samples(f), &bounds()).unwrap();
        let check = s.check(&[(vec![2.5, 120.0], f(2.5, 120.0)), (vec![1.1, 149.0], f(1.1, 149.0))]);
        // Exact up to rounding: a few ulps of the ~10 response, through an SVD solve.
        assert!(check.max_relative_error.unwrap() < 1e-12, "{check:?}");
    }

    #[test]
    fn linear_check_error_sees_curvature() {
        let f = |a: f64, _b: f64| 1.0 / a;
        let s = Surrogate::fit(SurrogateKind::Linear, &samples(f), &bounds()).unwrap();
        let check = s.check(&[(vec![1.0, 120.0], 1.0), (vec![2.0, 120.0], 0.5)]);
        // 1/a over [1, 3] is far from linear: the check must say so (more than 5 %).
        assert!(check.max_relative_error.unwrap() > 0.05, "{check:?}");
    }

    #[test]
    fn gp_interpolates_a_smooth_response() {
        let f = |a: f64, b: f64| (a * 0.5).sin() + b / 100.0;
        let s = Surrogate::fit(SurrogateKind::Gp, &samples(f), &bounds()).unwrap();
        // A smooth function on a 12-point plan in 2-D: the GP is good to well under 1 %.
        let check = s.check(&[(vec![2.2, 130.0], f(2.2, 130.0))]);
        assert!(check.max_relative_error.unwrap() < 0.01, "{check:?}");
    }

    #[test]
    fn too_few_runs_is_an_error() {
        let e = Surrogate::fit(SurrogateKind::Quadratic, &samples(|a, _| a)[..5], &bounds()).unwrap_err();
        assert!(
            matches!(
                e,
                FitError::TooFewRuns {
                    needed: 6,
                    given: 5,
                    ..
                }
            ),
            "{e}"
        );
    }
}
