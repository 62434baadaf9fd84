//! Emulators: the simulation as a function y(d, θ) — a closed form, or emulators fitted to solver
//! runs — and where the next runs go so that the emulators learn what the answer depends on.
//!
//! ```text
//!            runs (design, point, output) ──► Emulator::fit ──► predict / mean_cov
//!                                 │
//!          held_out: fitted without some runs, predicting them ──► the emulator's error (Check)
//! ```
//!
//! Every emulator of the product sits behind one trait, [`Emulator`]: fitted to runs, predicting
//! the solver's output at points it was not run at, with its predictive covariance where it has
//! one. Behind it ([`fits`]): the per-design surrogates ([`Surrogate`]: polynomials or a Gaussian
//! process over θ), one Gaussian process across the designs ([`fits::AcrossGp`]), the curve
//! emulators of one design ([`functional::FunctionalSurrogate`]) and across the designs
//! ([`fits::CurvesAcrossFit`]), and the planner's per-output Gaussian processes
//! ([`fits::Outputs`]). What is written once on top of it:
//!
//! - [`held_out`]: the emulator fitted to every run but some, and its predictions at those: the
//!   only way the product measures an emulator's error;
//! - [`by_design`]: one emulator per tested design, checked on the runs each holds out, or one
//!   across the designs, each design's slice checked by a refit without its held-out runs; the
//!   same for the response and for the curves.
//!
//! What the calibration and the diagnosis count of an emulator's error is the [`Check`] of each
//! design (the relative errors at its held-out runs), reaching a decision as one value,
//! [`Uncertainty`], and, for curves, the held-out runs themselves.
//!
//! - [`Model`]: what the numerics call, `y(d, θ)`; [`expression`] the closed form of a study.
//! - [`gp`]: the Gaussian process itself; [`sequential`]: the sequential design of solver runs.

pub mod expression;
pub mod fits;
pub mod functional;
pub mod gp;
pub mod sequential;
pub mod surrogate;
pub mod uncertainty;

use nalgebra::{DMatrix, DVector};

pub use expression::ExpressionModel;
pub use surrogate::{CheckError, DesignSurrogate, FitError, Surrogate, SurrogateModel};
pub use uncertainty::Uncertainty;

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

/// A solver run as an emulator learns from it: the tested design it was made at (name and values),
/// its point in the design's space (θ, or θ and an extension's ranged variables), and what the
/// solver gave there (`None`: it failed, or gave no such output).
#[derive(Debug)]
pub struct Run<'a, Y> {
    pub design: &'a str,
    pub values: &'a [f64],
    pub x: &'a [f64],
    pub y: Option<&'a Y>,
}

// Every field is a reference: a run is copied whatever its output's type.
impl<Y> Clone for Run<'_, Y> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<Y> Copy for Run<'_, Y> {}

/// An emulator of the solver: fitted to runs, predicting what the solver would give where it did
/// not run.
pub trait Emulator: Sized + Send + Sync {
    /// What the solver gives at a point: a response (`f64`), a curve (`DVector<f64>`), every
    /// output of a tested design (`Vec<f64>`).
    type Y: Clone + Send + Sync;
    /// How it is fitted besides its runs: its kind, its box.
    type Spec: Sync + ?Sized;

    /// Fits the emulator to the runs that have an output, in their order.
    fn fit(spec: &Self::Spec, runs: &[Run<'_, Self::Y>]) -> Result<Self, FitError>;

    /// The predictive mean at each run's point (its design's values and x).
    fn predict(&self, at: &[Run<'_, Self::Y>]) -> Vec<Self::Y>;

    /// The predictive mean and covariance of output `k` at the rows of `points` (each a point of
    /// the emulator's own inputs); `None` for an emulator without a variance of its own (a
    /// polynomial, whose error is only measured on held-out runs).
    fn mean_cov(&self, _k: usize, _points: &DMatrix<f64>) -> Option<(DVector<f64>, DMatrix<f64>)> {
        None
    }
}

/// Runs held out of an emulator and what it predicted at each.
#[derive(Debug, Clone)]
pub struct HeldOut<Y> {
    /// The held-out runs' indices among the runs given.
    pub runs: Vec<usize>,
    pub predicted: Vec<Y>,
}

/// The held-out check, written once: `E` fitted to every run that `held` does not pick, and its
/// predictions at the ones it picks that have an output. `Err`: it could not be fitted without
/// them.
pub fn held_out<E: Emulator>(
    spec: &E::Spec,
    runs: &[Run<'_, E::Y>],
    held: &dyn Fn(&Run<'_, E::Y>) -> bool,
) -> Result<HeldOut<E::Y>, FitError> {
    let kept: Vec<Run<E::Y>> = runs.iter().filter(|r| !held(r)).copied().collect();
    let emulator = E::fit(spec, &kept)?;
    Ok(predicted_at(&emulator, runs, &|r| held(r) && r.y.is_some()))
}

/// `emulator`'s predictions at the runs `pick` picks.
fn predicted_at<E: Emulator>(
    emulator: &E,
    runs: &[Run<'_, E::Y>],
    pick: &dyn Fn(&Run<'_, E::Y>) -> bool,
) -> HeldOut<E::Y> {
    let picked: Vec<usize> = (0..runs.len()).filter(|&i| pick(&runs[i])).collect();
    let at: Vec<Run<E::Y>> = picked.iter().map(|&i| runs[i]).collect();
    HeldOut {
        predicted: if at.is_empty() {
            Vec::new()
        } else {
            emulator.predict(&at)
        },
        runs: picked,
    }
}

/// An emulator across the tested designs, whose slice at one design is that design's emulator.
pub trait Sliced: Emulator {
    type Slice;
    fn slice(&self, values: &[f64]) -> Self::Slice;
}

/// One tested design's emulator, checked on the runs it held out.
#[derive(Debug, Clone)]
pub struct DesignFit<S, Y> {
    pub design: String,
    pub values: Vec<f64>,
    pub emulator: S,
    /// The held-out runs (indices among the runs given) and the predictions there of an emulator
    /// fitted without them.
    pub held: HeldOut<Y>,
    /// Runs of this design the emulator was fitted to.
    pub fitted: usize,
}

/// Why a design's emulator could not be fitted: (design, why).
pub type DesignError = (String, String);

/// Each tested design's emulator, or why it could not be fitted.
pub type Fits<S, Y> = Vec<Result<DesignFit<S, Y>, DesignError>>;

/// One emulator per tested design (`designs`, in order; a design without runs is left out), each
/// fitted to its runs that `held` does not pick and checked at those it picks.
pub fn by_design<E: Emulator>(
    spec: &E::Spec,
    designs: &[&String],
    runs: &[Run<'_, E::Y>],
    held: &(dyn Fn(&Run<'_, E::Y>) -> bool + Sync),
) -> Fits<E, E::Y> {
    designs
        .iter()
        .filter_map(|name| {
            let mine: Vec<usize> = (0..runs.len()).filter(|&i| runs[i].design == name.as_str()).collect();
            let values = runs[*mine.first()?].values.to_vec();
            let own: Vec<Run<E::Y>> = mine.iter().map(|&i| runs[i]).collect();
            let kept: Vec<Run<E::Y>> = own.iter().filter(|r| !held(r)).copied().collect();
            Some(match E::fit(spec, &kept) {
                Ok(emulator) => {
                    let mut checked = predicted_at(&emulator, &own, &|r| held(r) && r.y.is_some());
                    checked.runs = checked.runs.iter().map(|&j| mine[j]).collect();
                    Ok(DesignFit {
                        design: (*name).clone(),
                        values,
                        emulator,
                        held: checked,
                        fitted: kept.iter().filter(|r| r.y.is_some()).count(),
                    })
                }
                Err(e) => Err(((*name).clone(), e.to_string())),
            })
        })
        .collect()
}

/// One emulator across the tested designs, fitted to every run with an output (the held-out ones
/// too); each design gets its slice, checked at the runs of its own that `held` picks by the
/// emulator fitted to every other run. A design without runs is left out; where the whole cannot
/// be fitted, every design says why.
pub fn across<E: Sliced>(
    spec: &E::Spec,
    designs: &[&String],
    runs: &[Run<'_, E::Y>],
    held: &(dyn Fn(&Run<'_, E::Y>) -> bool + Sync),
) -> Fits<E::Slice, E::Y>
where
    E::Slice: Send,
{
    use rayon::prelude::*;
    let whole = E::fit(spec, runs);
    designs
        .par_iter()
        .filter_map(|name| {
            let mine: Vec<usize> = (0..runs.len())
                .filter(|&i| runs[i].design == name.as_str() && runs[i].y.is_some())
                .collect();
            let values = runs[*mine.first()?].values.to_vec();
            let whole = match &whole {
                Ok(e) => e,
                Err(e) => return Some(Err(((*name).clone(), e.to_string()))),
            };
            let own = |r: &Run<E::Y>| r.design == name.as_str() && held(r);
            let none = HeldOut {
                runs: Vec::new(),
                predicted: Vec::new(),
            };
            // Nothing held out: nothing to refit for.
            let checked = match runs.iter().any(|r| own(r) && r.y.is_some()) {
                true => held_out::<E>(spec, runs, &own).unwrap_or(none),
                false => none,
            };
            Some(Ok(DesignFit {
                design: (*name).clone(),
                emulator: whole.slice(&values),
                values,
                held: checked,
                fitted: mine.len(),
            }))
        })
        .collect()
}
