//! The emulators behind [`super::Emulator`]: how each is fitted to runs and predicts.
//!
//! | emulator | output | inputs | fitted as |
//! |---|---|---|---|
//! | [`Surrogate`] | a response | θ of one design | polynomial or Gaussian process ([`Kind`]) |
//! | [`AcrossGp`] | a response | the designs' values and θ | one Gaussian process; a design's slice is a [`Surrogate`] |
//! | [`FunctionalSurrogate`] | a curve | θ of one design | principal components, each weight a [`Surrogate`] |
//! | [`CurvesAcrossFit`] | a curve | the designs' values and θ | [`CurvesAcross`]; a design's slice is a [`FunctionalSurrogate`] |
//! | [`gp::Emulator`] | one output | the run's design values (empty for one design) and x | the planner's Gaussian process |

use std::sync::Arc;

use nalgebra::{DMatrix, DVector};

use super::functional::{AcrossRun, CurvesAcross, FunctionalSurrogate};
use super::{Emulator, FitError, Run, Sliced, Surrogate, gp};
use crate::base::Bounds;
use crate::study::SurrogateKind;

/// How a per-design surrogate is fitted: its kind over a box of θ; with `fallback`, a linear one
/// where the runs it is given are too few for the kind (a joint space's first runs).
#[derive(Debug, Clone)]
pub struct Kind {
    pub kind: SurrogateKind,
    pub bounds: Bounds,
    pub fallback: bool,
}

impl Kind {
    pub fn new(kind: SurrogateKind, bounds: Bounds) -> Kind {
        Kind {
            kind,
            bounds,
            fallback: false,
        }
    }

    /// The kind `n` runs can carry ([`kind_for`] with `fallback`).
    fn for_runs(&self, n: usize) -> SurrogateKind {
        if self.fallback {
            kind_for(self.kind, n, self.bounds.dim())
        } else {
            self.kind
        }
    }
}

/// The surrogate kind a design's few runs can carry: `kind`, or linear where `n` runs are too few
/// for it (probe runs, a joint space's first runs).
pub fn kind_for(kind: SurrogateKind, n: usize, d: usize) -> SurrogateKind {
    if n >= kind.min_samples(d) {
        kind
    } else {
        SurrogateKind::Linear
    }
}

/// The runs that have an output, as `(x, y)` pairs.
fn samples<Y: Clone>(runs: &[Run<'_, Y>]) -> Vec<(Vec<f64>, Y)> {
    runs.iter()
        .filter_map(|r| r.y.map(|y| (r.x.to_vec(), y.clone())))
        .collect()
}

/// A run's point as an emulator over the designs takes it: its design's values, then x.
fn joint_point<Y>(r: &Run<'_, Y>) -> Vec<f64> {
    r.values.iter().chain(r.x).copied().collect()
}

impl Emulator for Surrogate {
    type Y = f64;
    type Spec = Kind;

    fn fit(spec: &Kind, runs: &[Run<'_, f64>]) -> Result<Self, FitError> {
        let samples = samples(runs);
        Surrogate::fit(spec.for_runs(samples.len()), &samples, &spec.bounds)
    }

    fn predict(&self, at: &[Run<'_, f64>]) -> Vec<f64> {
        at.iter().map(|r| Surrogate::predict(self, r.x)).collect()
    }
}

impl Emulator for FunctionalSurrogate {
    type Y = DVector<f64>;
    type Spec = Kind;

    fn fit(spec: &Kind, runs: &[Run<'_, DVector<f64>>]) -> Result<Self, FitError> {
        let samples = samples(runs);
        FunctionalSurrogate::fit(spec.for_runs(samples.len()), &samples, &spec.bounds)
    }

    fn predict(&self, at: &[Run<'_, DVector<f64>>]) -> Vec<DVector<f64>> {
        at.iter().map(|r| FunctionalSurrogate::predict(self, r.x)).collect()
    }
}

/// One Gaussian process of the response across the tested designs, over their values and θ
/// (`Spec`: that joint box); a design's slice is a Gaussian-process [`Surrogate`] of it.
#[derive(Debug, Clone)]
pub struct AcrossGp(pub Arc<gp::Emulator>);

impl Emulator for AcrossGp {
    type Y = f64;
    type Spec = Bounds;

    fn fit(joint: &Bounds, runs: &[Run<'_, f64>]) -> Result<Self, FitError> {
        let rows: Vec<(Vec<f64>, f64)> = runs.iter().filter_map(|r| Some((joint_point(r), *r.y?))).collect();
        let x = DMatrix::from_fn(rows.len(), joint.dim(), |i, k| rows[i].0[k]);
        let y = DVector::from_iterator(rows.len(), rows.iter().map(|r| r.1));
        gp::Emulator::fit(&x, &y, joint)
            .map(|e| AcrossGp(Arc::new(e)))
            .map_err(|e| FitError::Numerics(e.to_string()))
    }

    fn predict(&self, at: &[Run<'_, f64>]) -> Vec<f64> {
        let rows: Vec<Vec<f64>> = at.iter().map(joint_point).collect();
        let x = DMatrix::from_fn(rows.len(), rows[0].len(), |i, k| rows[i][k]);
        self.0.mean(&x).iter().copied().collect()
    }

    fn mean_cov(&self, _k: usize, points: &DMatrix<f64>) -> Option<(DVector<f64>, DMatrix<f64>)> {
        self.0.mean_cov(points)
    }
}

impl Sliced for AcrossGp {
    type Slice = Surrogate;

    fn slice(&self, values: &[f64]) -> Surrogate {
        Surrogate::across(self.0.clone(), values.to_vec())
    }
}

/// How the curves are emulated across the designs: the joint box (the designs' values, then θ) and
/// each design's unit, its tests' mean force (`(values, unit)`; 1 for a design not listed).
#[derive(Debug, Clone)]
pub struct AcrossCurves {
    pub joint: Bounds,
    pub units: Vec<(Vec<f64>, f64)>,
}

impl AcrossCurves {
    fn unit(&self, values: &[f64]) -> f64 {
        self.units.iter().find(|(v, _)| v == values).map_or(1.0, |u| u.1)
    }
}

/// The curve emulator across the designs ([`CurvesAcross`]) with the units of its designs.
#[derive(Debug, Clone)]
pub struct CurvesAcrossFit {
    pub emulator: CurvesAcross,
    spec: AcrossCurves,
}

impl Emulator for CurvesAcrossFit {
    type Y = DVector<f64>;
    type Spec = AcrossCurves;

    fn fit(spec: &AcrossCurves, runs: &[Run<'_, DVector<f64>>]) -> Result<Self, FitError> {
        let rows: Vec<AcrossRun> = runs
            .iter()
            .filter_map(|r| {
                Some(AcrossRun {
                    design: r.values,
                    theta: r.x,
                    curve: r.y?,
                    scale: spec.unit(r.values),
                })
            })
            .collect();
        Ok(CurvesAcrossFit {
            emulator: CurvesAcross::fit(&rows, &spec.joint)?,
            spec: spec.clone(),
        })
    }

    fn predict(&self, at: &[Run<'_, DVector<f64>>]) -> Vec<DVector<f64>> {
        let mut slice: Option<(&[f64], FunctionalSurrogate)> = None;
        at.iter()
            .map(|r| {
                if slice.as_ref().is_none_or(|(v, _)| *v != r.values) {
                    slice = Some((r.values, self.slice(r.values)));
                }
                slice.as_ref().map(|(_, s)| s.predict(r.x)).expect("set above")
            })
            .collect()
    }
}

impl Sliced for CurvesAcrossFit {
    type Slice = FunctionalSurrogate;

    fn slice(&self, values: &[f64]) -> FunctionalSurrogate {
        self.emulator.at(values, self.spec.unit(values))
    }
}

/// The planner's Gaussian process of one output over a run's design values (empty for a design's
/// own emulator) and x, in the box `Spec`: it predicts one point at a time
/// ([`gp::Emulator::mean_var_at`]), as its optimisers and candidates ask. A point it cannot predict
/// at is NaN.
impl Emulator for gp::Emulator {
    type Y = f64;
    type Spec = Bounds;

    fn fit(bounds: &Bounds, runs: &[Run<'_, f64>]) -> Result<Self, FitError> {
        let rows: Vec<(Vec<f64>, f64)> = runs
            .iter()
            .filter_map(|r| r.y.filter(|y| y.is_finite()).map(|y| (joint_point(r), *y)))
            .collect();
        let x = DMatrix::from_fn(rows.len(), bounds.dim(), |i, k| rows[i].0[k]);
        let y = DVector::from_iterator(rows.len(), rows.iter().map(|r| r.1));
        gp::Emulator::fit(&x, &y, bounds).map_err(|e| FitError::Numerics(e.to_string()))
    }

    fn predict(&self, at: &[Run<'_, f64>]) -> Vec<f64> {
        at.iter()
            .map(|r| self.mean_var_at(&joint_point(r)).map_or(f64::NAN, |m| m.0))
            .collect()
    }

    fn mean_cov(&self, _k: usize, points: &DMatrix<f64>) -> Option<(DVector<f64>, DMatrix<f64>)> {
        gp::Emulator::mean_cov(self, points)
    }
}
