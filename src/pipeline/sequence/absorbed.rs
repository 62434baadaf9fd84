//! Which of the screening's emulator errors the decision reads.
//!
//! Every model the diagnosis weighs has the calibration parameters θ free, so an emulator error
//! that lies along the model's slope in θ at every tested design, e = J δ (J = ∂μ/∂θ, whitened by
//! the tests' noise of the mean), moves every model's fit by δ and leaves every residual, hence
//! the lack of fit and the candidates' ranking, as it was (to first order). Only its part outside
//! J's columns, ẽ = e − J (J_tᵀJ_t)⁺ J_tᵀ e_t (least squares over the training designs), can hide
//! or make a misfit. The absorbed part still biases θ̂, which is the answer only when the
//! uncorrected model fits; so where its misfit stands even with the unabsorbed error counted as
//! noise (a χ² test at the diagnosis's α), a design's runs need only bring the unabsorbed error
//! within the tolerance. Elsewhere the whole error must be.
//!
//! A design's measured error is a mean over its latest runs (the bias) and their spread about it;
//! the spread is not a shift of the design's predictions and is kept whole.

use nalgebra::{DMatrix, DVector};

use super::sites::{Held, Tests};
use crate::base::Bounds;
use crate::emulate::Uncertainty;
use crate::emulate::sequential::{Posterior, Site, SiteEmulators};

/// What the screening's planner has in hand at a step.
pub struct Screening<'a> {
    pub tests: &'a Tests,
    pub sites: &'a [Site],
    pub emulators: &'a [SiteEmulators],
    pub posterior: &'a Posterior,
    pub bounds: &'a Bounds,
}

/// Per tested design, the error that still matters, in units of the tests' noise of the mean:
/// the unabsorbed error where the uncorrected model's misfit stands with it counted (see the module
/// notes); `None` where that does not hold or cannot be read (curve features, a noise not measured
/// by replicates, fewer measured training designs than θ has entries plus one), so that the whole
/// measured error decides.
pub fn unabsorbed_errors(s: &Screening, held: &[Option<Held>], alpha: f64) -> Option<Vec<Option<f64>>> {
    if s.tests.whitening.is_some() || !s.tests.measured_noise {
        return None;
    }
    let mode = &s.posterior.mode;
    let p = mode.len();
    let measured: Vec<usize> = (0..held.len())
        .filter(|&i| held[i].is_some_and(|h| h.rms.is_finite() && h.bias.is_finite()))
        .collect();
    let train: Vec<bool> = measured.iter().map(|&i| s.sites[i].training).collect();
    if train.iter().filter(|&&t| t).count() <= p {
        return None;
    }
    let j = slope(s, &measured)?;
    let of = |f: fn(&Held) -> f64| measured.iter().map(move |&i| held[i].as_ref().map_or(0.0, f));
    let errors = Uncertainty::of_means(
        of(|h| h.rms * h.rms).collect(),
        DVector::from_iterator(measured.len(), of(|h| h.bias)),
    );
    // The spread about a design's mean error is kept whole; its mean only as far as θ leaves it.
    let error: Vec<f64> = (errors.beyond(&j, &vec![1.0; measured.len()], &rows(&train)).into_iter())
        .map(f64::sqrt)
        .collect();
    let (chi2, dof) = misfit(s, &measured, &error, p)?;
    if crate::diagnose::stats::chi2_sf(chi2, dof as f64) >= alpha {
        return None;
    }
    let mut out = vec![None; held.len()];
    for (&i, u) in measured.iter().zip(error) {
        out[i] = Some(u);
    }
    Some(out)
}

/// The indices of the `train` rows.
fn rows(train: &[bool]) -> Vec<usize> {
    (0..train.len()).filter(|&i| train[i]).collect()
}

/// The response's slope at the posterior's mode at each of the `measured` designs, whitened by the
/// tests' noise of the mean: one row per design, one column per parameter in the unit cube (a
/// column's scale leaves the span it absorbs as it is), by [`crate::base::optimize::jacobian`]
/// (`None`: a design's emulators cannot predict there).
fn slope(s: &Screening, measured: &[usize]) -> Option<DMatrix<f64>> {
    let whitened = |u: &DVector<f64>| {
        let x = s.bounds.from_unit(u);
        DVector::from_iterator(
            measured.len(),
            measured.iter().map(|&i| {
                let mu = s.emulators[i].predict(x.as_slice()).and_then(|y| y.first().copied());
                mu.map_or(f64::NAN, |m| m / s.sites[i].noise[0].sqrt())
            }),
        )
    };
    let mode = s.bounds.to_unit(&DVector::from_column_slice(&s.posterior.mode));
    let j = crate::base::optimize::jacobian(&whitened, &mode);
    j.iter().all(|v| v.is_finite()).then_some(j)
}

/// The uncorrected model's χ² at the posterior's mode over the measured designs, each residual's
/// variance the tests' noise of the mean plus the design's error that still matters (`error`, in
/// those units), on the measured designs less the parameters fitted.
fn misfit(s: &Screening, measured: &[usize], error: &[f64], p: usize) -> Option<(f64, usize)> {
    let chi2 = (measured.iter().zip(error))
        .map(|(&i, u)| {
            let site = &s.sites[i];
            let mu = s.emulators[i].predict(&s.posterior.mode)?[0];
            Some((site.observed[0] - mu).powi(2) / (site.noise[0] * (1.0 + u * u)))
        })
        .sum::<Option<f64>>()?;
    let dof = measured.len().checked_sub(p).filter(|&d| d > 0)?;
    chi2.is_finite().then_some((chi2, dof))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An error along the slope is absorbed whole; one across it is left as it was, to the
    /// component the least squares cannot reach (checked against the normal equations by hand):
    /// the split the screening reads, each design's mean error with no spread about it.
    #[test]
    fn an_error_along_the_slope_is_absorbed_and_one_across_it_is_not() {
        let j = DMatrix::from_column_slice(4, 1, &[1.0, 2.0, 3.0, 4.0]);
        let train = [true, true, true, false];
        let unabsorbed = |e: &DVector<f64>| -> Vec<f64> {
            let errors = Uncertainty::of_means(e.iter().map(|x| x * x).collect(), e.clone());
            errors
                .beyond(&j, &[1.0; 4], &rows(&train))
                .into_iter()
                .map(f64::sqrt)
                .collect()
        };
        let along = DVector::from_column_slice(&[0.5, 1.0, 1.5, 2.0]);
        let u = unabsorbed(&along);
        assert!(u.iter().all(|v| *v < 1e-12), "{u:?}");
        // e = (1, 0, 0, 0): δ = (Σ j e)/(Σ j²) over training = 1/14.
        let across = DVector::from_column_slice(&[1.0, 0.0, 0.0, 0.0]);
        let u = unabsorbed(&across);
        let expected: [f64; 4] = [1.0 - 1.0 / 14.0, -2.0 / 14.0, -3.0 / 14.0, -4.0 / 14.0];
        for (a, b) in u.iter().zip(expected) {
            assert!((a - b.abs()).abs() < 1e-12, "{u:?}");
        }
    }
}
