//! Functional emulation of curves (Higdon, Gattiker, Williams & Rightley 2008, "Computer model
//! calibration using high-dimensional output", JASA 103(482)): per design, the runs' curves on the
//! stroke grid are reduced to their principal components, and each kept component's weight is a
//! surrogate of the study's kind over the parameters. The emulator predicts the whole curve at
//! any parameter value:
//!
//! `η(s, θ) = m(s) + Σ_k w_k(θ) φ_k(s)`,
//!
//! with m the runs' mean curve, φ_k the leading right singular vectors of the centred curves, and as
//! many components as keep 99.9 % of the runs' variance about the mean and reproduce every run to
//! 0.1 % of its level at every point ([`POINTWISE`]). Reported like the scalar
//! surrogates: the components kept, the relative error of that reconstruction on the runs
//! themselves, and the relative error of the predicted curves at the check runs (each as
//! ‖η − y‖ / ‖y‖ over the grid).

use nalgebra::{DMatrix, DVector};

use super::{CheckError, FitError, Surrogate};
use crate::calibrate::Bounds;
use crate::study::SurrogateKind;

/// The share of the runs' variance about their mean curve the kept components hold.
pub const KEEP: f64 = 0.999;

/// The largest reconstruction error of any run at any point, relative to that run's largest force.
/// The variance share alone can drop a sharp feature (an initial peak carried by one grid point
/// holds a tiny share of the variance), which the diagnosis reads at the noise of a few tenths of a
/// percent: components are added until both hold.
pub const POINTWISE: f64 = 1e-3;

/// One design's curve emulator.
#[derive(Debug, Clone)]
pub struct FunctionalSurrogate {
    mean: DVector<f64>,
    /// One column per kept component.
    basis: DMatrix<f64>,
    weights: Vec<Surrogate>,
    /// ‖Y − reconstruction‖ / ‖Y‖ over the runs it was fitted to.
    pub reconstruction_error: f64,
}

impl FunctionalSurrogate {
    /// Fits the emulator to `(θ, curve)` runs in the parameter box `bounds`.
    pub fn fit(kind: SurrogateKind, runs: &[(Vec<f64>, DVector<f64>)], bounds: &Bounds) -> Result<Self, FitError> {
        let n = runs.len();
        let needed = kind.min_samples(bounds.dim());
        if n < needed.max(2) {
            return Err(FitError::TooFewRuns {
                kind: kind.key(),
                p: bounds.dim(),
                needed: needed.max(2),
                given: n,
            });
        }
        let points = runs[0].1.len();
        if runs
            .iter()
            .any(|r| r.1.len() != points || r.1.iter().any(|v| !v.is_finite()))
        {
            return Err(FitError::NonFinite);
        }
        let y = DMatrix::from_fn(n, points, |i, j| runs[i].1[j]);
        let mean = DVector::from_fn(points, |j, _| y.column(j).mean());
        let centred = DMatrix::from_fn(n, points, |i, j| y[(i, j)] - mean[j]);
        let svd = centred.clone().svd(false, true);
        let vt = svd.v_t.expect("asked for V");
        let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
        order.sort_by(|&a, &b| svd.singular_values[b].total_cmp(&svd.singular_values[a]));
        let total: f64 = svd.singular_values.iter().map(|s| s * s).sum();
        let scale: Vec<f64> = (0..n).map(|i| y.row(i).amax().max(f64::MIN_POSITIVE)).collect();
        let mut kept: Vec<usize> = Vec::new();
        let mut held = 0.0;
        let mut residual = centred.clone();
        for &k in &order {
            let worst = (0..n).map(|i| residual.row(i).amax() / scale[i]).fold(0.0, f64::max);
            if total <= 0.0 || (held >= KEEP * total && worst <= POINTWISE) {
                break;
            }
            held += svd.singular_values[k].powi(2);
            kept.push(k);
            let v = vt.row(k).transpose();
            let scores = &centred * &v;
            residual -= scores * v.transpose();
        }
        let basis = DMatrix::from_fn(points, kept.len(), |j, c| vt[(kept[c], j)]);
        let scores = &centred * &basis;
        let weights = (0..kept.len())
            .map(|c| {
                let samples: Vec<(Vec<f64>, f64)> = runs
                    .iter()
                    .zip(scores.column(c).iter())
                    .map(|(r, w)| (r.0.clone(), *w))
                    .collect();
                Surrogate::fit(kind, &samples, bounds)
            })
            .collect::<Result<Vec<_>, _>>()?;
        let residual = (total - held).max(0.0);
        Ok(FunctionalSurrogate {
            mean,
            basis,
            weights,
            reconstruction_error: (residual / y.norm_squared().max(f64::MIN_POSITIVE)).sqrt(),
        })
    }

    /// Components kept.
    pub fn components(&self) -> usize {
        self.weights.len()
    }

    /// The predicted curve at θ.
    pub fn predict(&self, theta: &[f64]) -> DVector<f64> {
        let w = DVector::from_iterator(self.weights.len(), self.weights.iter().map(|s| s.predict(theta)));
        &self.mean + &self.basis * w
    }

    /// Relative errors ‖η − y‖ / ‖y‖ of the predicted curves at the check runs.
    pub fn check(&self, checks: &[(Vec<f64>, DVector<f64>)]) -> CheckError {
        let errors: Vec<f64> = checks
            .iter()
            .map(|(t, y)| (self.predict(t) - y).norm() / y.norm().max(f64::MIN_POSITIVE))
            .collect();
        CheckError::of(&errors)
    }
}

/// One design's curve emulator, with its check.
#[derive(Debug, Clone)]
pub struct DesignCurves {
    pub design: String,
    pub values: Vec<f64>,
    pub surrogate: FunctionalSurrogate,
    pub check: CheckError,
    pub samples: usize,
    /// The check runs held out of the fit: (θ, curve).
    pub checks: Vec<(Vec<f64>, DVector<f64>)>,
}

/// The simulation's curve at a design and θ: per-design emulators as one model (like
/// [`super::SurrogateModel`]; `None` at a design without one).
#[derive(Debug, Clone, Default)]
pub struct CurveModel {
    pub designs: Vec<DesignCurves>,
}

impl CurveModel {
    pub fn curve(&self, design: &[f64], theta: &[f64]) -> Option<DVector<f64>> {
        self.designs
            .iter()
            .find(|d| d.values == design)
            .map(|d| d.surrogate.predict(theta))
    }

    /// Every design's check runs: (design values, θ, curve).
    pub fn check_runs(&self) -> Vec<(Vec<f64>, Vec<f64>, DVector<f64>)> {
        self.designs
            .iter()
            .flat_map(|d| d.checks.iter().map(|(t, c)| (d.values.clone(), t.clone(), c.clone())))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Curves a(θ) sin + b(θ) s on 50 points: two components reproduce them exactly, and a GP over
    /// θ predicts a curve between the runs.
    #[test]
    fn two_component_family_is_reproduced_and_predicted() {
        let s: Vec<f64> = (0..50).map(|i| i as f64 / 49.0).collect();
        let curve = |t: f64| DVector::from_iterator(50, s.iter().map(|&x| (1.0 + t) * (3.0 * x).sin() + t * t * x));
        let bounds = Bounds::new(vec![0.0], vec![2.0]);
        let runs: Vec<(Vec<f64>, DVector<f64>)> = (0..10)
            .map(|i| {
                let t = 2.0 * i as f64 / 9.0;
                (vec![t], curve(t))
            })
            .collect();
        let f = FunctionalSurrogate::fit(SurrogateKind::Gp, &runs, &bounds).unwrap();
        assert_eq!(f.components(), 2);
        assert!(f.reconstruction_error < 1e-10, "{}", f.reconstruction_error);
        let check = f.check(&[(vec![0.77], curve(0.77)), (vec![1.31], curve(1.31))]);
        assert!(check.max_relative_error.unwrap() < 1e-3, "{check:?}");
    }
}
