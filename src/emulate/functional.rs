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

use std::sync::Arc;

use nalgebra::{DMatrix, DVector};

use super::gp::Emulator;
use super::{CheckError, FitError, Surrogate};
use crate::base::Bounds;
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
    /// The unit the curves were emulated in (a design's slice of [`CurvesAcross`]; else 1).
    scale: f64,
    /// ‖Y − reconstruction‖ / ‖Y‖ over the runs it was fitted to.
    pub reconstruction_error: f64,
}

impl FunctionalSurrogate {
    /// Fits the emulator to `(θ, curve)` runs in the parameter box `bounds`.
    pub fn fit(kind: SurrogateKind, runs: &[(Vec<f64>, DVector<f64>)], bounds: &Bounds) -> Result<Self, FitError> {
        let needed = kind.min_samples(bounds.dim()).max(2);
        let curves: Vec<&DVector<f64>> = runs.iter().map(|r| &r.1).collect();
        let basis = Basis::of(&curves, needed, kind.key(), bounds.dim())?;
        let weights = (0..basis.basis.ncols())
            .map(|c| {
                let samples: Vec<(Vec<f64>, f64)> = runs
                    .iter()
                    .zip(basis.scores.column(c).iter())
                    .map(|(r, w)| (r.0.clone(), *w))
                    .collect();
                Surrogate::fit(kind, &samples, bounds)
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(FunctionalSurrogate {
            mean: basis.mean,
            basis: basis.basis,
            weights,
            scale: 1.0,
            reconstruction_error: basis.reconstruction_error,
        })
    }

    /// Components kept.
    pub fn components(&self) -> usize {
        self.weights.len()
    }

    /// The predicted curve at θ.
    pub fn predict(&self, theta: &[f64]) -> DVector<f64> {
        let w = DVector::from_iterator(self.weights.len(), self.weights.iter().map(|s| s.predict(theta)));
        (&self.mean + &self.basis * w) * self.scale
    }

    /// The check runs `(θ, curve)` with this emulator's predictions there.
    pub fn checks(&self, runs: Vec<(Vec<f64>, DVector<f64>)>) -> Vec<CurveCheck> {
        runs.into_iter()
            .map(|(theta, curve)| CurveCheck {
                emulated: self.predict(&theta),
                theta,
                curve,
            })
            .collect()
    }
}

/// A run held out of a curve emulator: θ, its curve, and the curve the emulator predicted there.
#[derive(Debug, Clone)]
pub struct CurveCheck {
    pub theta: Vec<f64>,
    pub curve: DVector<f64>,
    pub emulated: DVector<f64>,
}

/// Relative errors ‖η − y‖ / ‖y‖ of the predicted curves at the check runs.
pub fn check_error(checks: &[CurveCheck]) -> CheckError {
    let errors: Vec<f64> = checks
        .iter()
        .map(|c| (&c.emulated - &c.curve).norm() / c.curve.norm().max(f64::MIN_POSITIVE))
        .collect();
    CheckError::of(&errors)
}

/// The runs' mean curve, the kept principal components and each run's weights on them.
struct Basis {
    mean: DVector<f64>,
    /// One column per kept component.
    basis: DMatrix<f64>,
    /// One row per run, one column per kept component.
    scores: DMatrix<f64>,
    reconstruction_error: f64,
}

impl Basis {
    /// The components of `curves` ([`KEEP`], [`POINTWISE`]); `needed` runs at least (for the
    /// error: the weights' surrogate `kind` over `p` variables).
    fn of(curves: &[&DVector<f64>], needed: usize, kind: &'static str, p: usize) -> Result<Basis, FitError> {
        let n = curves.len();
        if n < needed {
            return Err(FitError::TooFewRuns {
                kind,
                p,
                needed,
                given: n,
            });
        }
        let points = curves[0].len();
        if curves
            .iter()
            .any(|c| c.len() != points || c.iter().any(|v| !v.is_finite()))
        {
            return Err(FitError::NonFinite);
        }
        let y = DMatrix::from_fn(n, points, |i, j| curves[i][j]);
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
        let residual = (total - held).max(0.0);
        Ok(Basis {
            mean,
            basis,
            scores,
            reconstruction_error: (residual / y.norm_squared().max(f64::MIN_POSITIVE)).sqrt(),
        })
    }
}

/// One curve emulator across the designs: the basis of every design's runs, each in units of its
/// design's `scale` (the tests' mean force there, so that one emulator's error is relative at every
/// design, as the tests' noise is), and each component's weight one Gaussian process over
/// (design, θ) — Higdon et al. 2008's η(x, θ) with the designs' values as x. A design's slice is a
/// [`FunctionalSurrogate`] ([`CurvesAcross::at`]).
#[derive(Debug, Clone)]
pub struct CurvesAcross {
    mean: DVector<f64>,
    basis: DMatrix<f64>,
    weights: Vec<Arc<Emulator>>,
    pub reconstruction_error: f64,
}

/// The unit a design's curves are emulated in across the designs: its tests' mean force `mean`
/// where that is a positive number, else 1.
pub fn unit(mean: f64) -> f64 {
    if mean.is_finite() && mean > 0.0 { mean } else { 1.0 }
}

/// A run as [`CurvesAcross`] is fitted to it: its design's values, θ, its curve and its design's scale.
pub struct AcrossRun<'a> {
    pub design: &'a [f64],
    pub theta: &'a [f64],
    pub curve: &'a DVector<f64>,
    pub scale: f64,
}

impl CurvesAcross {
    /// Fits the emulator to `runs` over `joint`, the designs' range then the parameter box
    /// ([`crate::emulate::sequential::shared::joint_bounds`]).
    pub fn fit(runs: &[AcrossRun], joint: &Bounds) -> Result<CurvesAcross, FitError> {
        let scaled: Vec<DVector<f64>> = runs.iter().map(|r| r.curve / r.scale).collect();
        let refs: Vec<&DVector<f64>> = scaled.iter().collect();
        let needed = SurrogateKind::Gp.min_samples(joint.dim()).max(2);
        let basis = Basis::of(&refs, needed, SurrogateKind::Gp.key(), joint.dim())?;
        let rows: Vec<Vec<f64>> = runs
            .iter()
            .map(|r| r.design.iter().chain(r.theta).copied().collect())
            .collect();
        let x = DMatrix::from_fn(runs.len(), joint.dim(), |i, k| rows[i][k]);
        let weights = (0..basis.basis.ncols())
            .map(|c| {
                let y = DVector::from_iterator(runs.len(), basis.scores.column(c).iter().copied());
                Emulator::fit(&x, &y, joint)
                    .map(Arc::new)
                    .map_err(|e| FitError::Numerics(e.to_string()))
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(CurvesAcross {
            mean: basis.mean,
            basis: basis.basis,
            weights,
            reconstruction_error: basis.reconstruction_error,
        })
    }

    /// The design at `values`, whose curves are in units of `scale`.
    pub fn at(&self, values: &[f64], scale: f64) -> FunctionalSurrogate {
        FunctionalSurrogate {
            mean: self.mean.clone(),
            basis: self.basis.clone(),
            weights: self
                .weights
                .iter()
                .map(|e| Surrogate::across(e.clone(), values.to_vec()))
                .collect(),
            scale,
            reconstruction_error: self.reconstruction_error,
        }
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
    /// The check runs held out of the fit, with its predictions there.
    pub checks: Vec<CurveCheck>,
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

    /// Every design's check runs: (design values, check).
    pub fn check_runs(&self) -> Vec<(Vec<f64>, CurveCheck)> {
        self.designs
            .iter()
            .flat_map(|d| d.checks.iter().map(|c| (d.values.clone(), c.clone())))
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
        let check = check_error(&f.checks(vec![(vec![0.77], curve(0.77)), (vec![1.31], curve(1.31))]));
        assert!(check.max_relative_error.unwrap() < 1e-3, "{check:?}");
    }

    /// Curves whose level grows tenfold over the designs and whose shape changes with θ and d, two
    /// runs per design at six designs (too few for a Gaussian process per design over θ): one
    /// emulator across the designs, each design's curves in units of its level, predicts a curve at
    /// a design and θ it has no run at to a tenth of a percent, where the same twelve runs pooled
    /// without the units (scale 1) do worse.
    #[test]
    fn one_emulator_across_the_designs_predicts_a_design_between_its_runs() {
        let s: Vec<f64> = (0..60).map(|i| i as f64 / 59.0).collect();
        let level = |d: f64| d.powf(5.0 / 3.0);
        let curve = |d: f64, t: f64| {
            DVector::from_iterator(
                60,
                s.iter()
                    .map(|&x| level(d) * t * (1.0 - (-8.0 * x).exp() + 0.2 * t * d * x)),
            )
        };
        let designs = [1.0, 1.5, 2.0, 2.5, 3.0, 4.0];
        // c in [1, 4], θ in [1, 2].
        let joint = Bounds::new(vec![1.0, 1.0], vec![4.0, 2.0]);
        let rows: Vec<(Vec<f64>, Vec<f64>, DVector<f64>)> = designs
            .iter()
            .enumerate()
            .flat_map(|(i, &d)| {
                [0.13, 0.61].iter().map(move |u| {
                    let t = 1.0 + ((u + 0.29 * i as f64) % 1.0);
                    (vec![d], vec![t], curve(d, t))
                })
            })
            .collect();
        let fit = |unit: &dyn Fn(f64) -> f64| {
            let runs: Vec<AcrossRun> = rows
                .iter()
                .map(|(d, t, c)| AcrossRun {
                    design: d,
                    theta: t,
                    curve: c,
                    scale: unit(d[0]),
                })
                .collect();
            CurvesAcross::fit(&runs, &joint).unwrap()
        };
        let error = |e: &CurvesAcross, unit: &dyn Fn(f64) -> f64| {
            let (d, t) = (2.0, 1.37);
            let f = e.at(&[d], unit(d));
            let truth = curve(d, t);
            (f.predict(&[t]) - &truth).norm() / truth.norm()
        };
        let scaled = error(&fit(&level), &level);
        let pooled = error(&fit(&|_| 1.0), &|_| 1.0);
        assert!(scaled < 1e-3, "in units of each design's level: {scaled}");
        assert!(scaled < pooled, "{scaled} vs {pooled} without the units");
    }
}
