//! Lack of fit, both ways: does a model fit the tests within their noise?
//!
//! The omnibus test, (RSS_train + Σ z_val²) / dof against F(dof, ν) (the pure-error test of Draper &
//! Smith 1998, §2.1, with the validation designs as predictive residuals), spreads one large
//! residual over every degree of freedom: a 5σ miss among twelve residuals moves χ² by 25, which
//! on ten degrees of freedom is p ≈ 0.01. So the largest standardised residual is tested too:
//! under the model each z_i is t(ν) (the training residuals divided by √(1 − h_ii), their leverage,
//! the validation designs' predictive z as they are), and the largest of N is held to Šidák's
//! correction, p = 1 − (1 − p_min)^N (exact for independent residuals, conservative for the
//! positively correlated residuals of a fit).
//!
//! A model **fits** only when both pass. Which level each is held to depends on the claim:
//! - *detecting model error* (the study's own simulation against the tests): model error is claimed
//!   at level α in all, so the lack-of-fit tests share half of α with the candidates' amplitude
//!   tests (the other half, [`super::Context::candidates_level`]): α/4 each (Bonferroni). The clean
//!   families of `tests/diagnose_noise.rs` measure the false claims;
//! - *a cause's model* (a candidate's, the loop's extended model, a term the search found): each at
//!   α. Calling such a model a fit is what naming a cause rests on, and the stricter test of what it
//!   leaves is the conservative side: a true cause is then called partial in at most 2α of draws,
//!   never the reverse.
//!
//! Under a model with an estimated noise (ν degrees of freedom) each z_i is t(ν), not normal: with
//! the curve features' eight or so degrees of freedom a 5.3 σ miss among twelve has a corrected p
//! near 0.009, not 1e-6.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use super::stats;

/// A lack-of-fit test against the replicate noise, both ways (see the module notes).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LackOfFit {
    /// The omnibus test: χ²/dof against F(dof, noise_dof).
    pub chi2: f64,
    pub dof: usize,
    pub noise_dof: usize,
    /// The omnibus p.
    pub p_value: f64,
    /// The largest standardised residual and its corrected p (absent when no residual has
    /// a standard error: every design fitted exactly).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub largest: Option<LargestResidual>,
    /// The level each of the two tests is held to (α/4 when detecting model error, else α).
    #[serde(default)]
    pub level: f64,
    /// Both tests pass: the model fits the tests within their noise.
    #[serde(default)]
    pub fits: bool,
}

/// The largest standardised residual of a model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LargestResidual {
    pub design: String,
    pub z: f64,
    /// How many residuals it is the largest of (the Šidák correction's N).
    pub residuals: usize,
    /// Two-sided P(|t_ν| > |z|) of this one residual.
    pub p_single: f64,
    /// 1 − (1 − p_single)^N.
    pub p_corrected: f64,
}

impl LackOfFit {
    /// The two tests of `chi2` on `dof` and of the standardised residuals `z` (design, z), with the
    /// noise's `noise_dof`, each at `level`.
    pub fn new(chi2: f64, dof: usize, noise_dof: usize, z: &[(String, f64)], level: f64) -> LackOfFit {
        let p_value = stats::f_sf(chi2 / dof as f64, dof as f64, noise_dof as f64);
        let largest = largest(z, noise_dof as f64);
        let fits = p_value >= level && largest.as_ref().is_none_or(|l| l.p_corrected >= level);
        LackOfFit {
            chi2,
            dof,
            noise_dof,
            p_value,
            largest,
            level,
            fits,
        }
    }

    /// The model misses the tests beyond their noise: one of the two tests rejects.
    pub fn rejects(&self) -> bool {
        !self.fits
    }

    /// The share of the `uncorrected` model's misfit beyond the noise that this model removes:
    /// 1 − (χ² − dof) / (χ²_unc − dof_unc), in [0, 1] (`None` when the uncorrected has no excess).
    pub fn share_removed(&self, uncorrected: &LackOfFit) -> Option<f64> {
        let excess = |l: &LackOfFit| l.chi2 - l.dof as f64;
        (excess(uncorrected) > 0.0).then(|| (1.0 - excess(self).max(0.0) / excess(uncorrected)).clamp(0.0, 1.0))
    }
}

/// The largest |z| of `z` with its t(ν) and Šidák p-values.
fn largest(z: &[(String, f64)], nu: f64) -> Option<LargestResidual> {
    let (design, zmax) = z
        .iter()
        .filter(|(_, v)| v.is_finite())
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))?;
    let n = z.iter().filter(|(_, v)| v.is_finite()).count();
    let p_single = if nu > 0.0 {
        stats::t_two_sided(*zmax, nu)
    } else {
        stats::normal_two_sided(*zmax)
    };
    Some(LargestResidual {
        design: design.clone(),
        z: *zmax,
        residuals: n,
        p_single,
        p_corrected: sidak(p_single, n),
    })
}

/// The largest |z| the largest-residual test lets pass at its level, with the noise as estimated
/// (t on `noise_dof`) and were it known (the normal): the inverse of Šidák's correction at `level`
/// over the N residuals, 1 − (1 − level)^(1/N), as a two-sided quantile. `None` without a residual.
impl LackOfFit {
    pub fn passes_up_to(&self) -> Option<(f64, f64)> {
        let n = self.largest.as_ref()?.residuals.max(1) as f64;
        let single = -((-self.level).ln_1p() / n).exp_m1();
        let q = 1.0 - single / 2.0;
        Some((stats::t_quantile(q, self.noise_dof as f64), stats::normal_quantile(q)))
    }
}

/// Šidák's correction of the smallest of `n` p-values: 1 − (1 − p)^n, computed without cancellation.
pub fn sidak(p: f64, n: usize) -> f64 {
    if n == 0 {
        return 1.0;
    }
    (-(n as f64 * (-p).ln_1p()).exp_m1()).clamp(0.0, 1.0)
}

/// The leverages h_ii of the weighted Jacobian `a` (rows: residuals): the diagonal of the hat matrix
/// A (AᵀA)⁺ Aᵀ, from the left singular vectors of A's numerical column space.
pub fn leverages(a: &DMatrix<f64>) -> Vec<f64> {
    if a.ncols() == 0 || a.iter().any(|v| !v.is_finite()) {
        return vec![0.0; a.nrows()];
    }
    let svd = a.clone().svd(true, false);
    let u = svd.u.expect("asked for U");
    let top = svd.singular_values.max();
    let kept: Vec<usize> = (0..svd.singular_values.len())
        .filter(|&k| svd.singular_values[k] > 1e-10 * top)
        .collect();
    (0..a.nrows())
        .map(|i| kept.iter().map(|&k| u[(i, k)].powi(2)).sum::<f64>().min(1.0))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sidak_matches_the_direct_formula_and_keeps_small_p() {
        for &(p, n) in &[(0.01, 12usize), (0.2, 3), (1e-9, 40)] {
            let direct = 1.0 - (1.0f64 - p).powi(n as i32);
            let ours = sidak(p, n);
            assert!(
                (ours - direct).abs() <= 1e-12 + 1e-9 * direct,
                "{p} {n}: {ours} vs {direct}"
            );
        }
        // Where 1 − (1 − p)^n cancels, the correction is n·p to first order.
        assert!((sidak(1e-15, 10) / 1e-14 - 1.0).abs() < 1e-6);
        assert_eq!(sidak(0.3, 0), 1.0);
    }

    /// A curve set's case: twelve whitened features, one at −5.3 σ; χ² = 57 on 10 dof against a
    /// noise of 8 degrees of freedom passes the omnibus test (p = 0.0106, scipy: f.sf(5.7, 10, 8))
    /// but not the residual test (12 × 2 t.sf(5.3, 8) = 0.0087).
    #[test]
    fn one_large_residual_fails_the_model_that_the_omnibus_test_passes() {
        let mut z: Vec<(String, f64)> = (0..11)
            .map(|i| (format!("d{i}"), 0.4 * ((i % 3) as f64 - 1.0)))
            .collect();
        z.push(("C3T7".into(), -5.3));
        let l = LackOfFit::new(57.0, 10, 8, &z, 0.01); // a cause's model: each test at α
        assert!((l.p_value - 0.0106).abs() < 0.0002, "omnibus p {}", l.p_value);
        let big = l.largest.as_ref().unwrap();
        assert_eq!(big.design, "C3T7");
        assert_eq!(big.residuals, 12);
        assert!((big.p_corrected - 0.0087).abs() < 0.0002, "{}", big.p_corrected);
        assert!(l.rejects());
        assert!(big.p_corrected < l.level, "the residual test rejects");
        // With the noise known far better (ν = 200) the residual is decisive: Šidák p near 1e-6.
        let known = LackOfFit::new(57.0, 10, 200, &z, 0.01);
        let p = known.largest.as_ref().unwrap().p_corrected;
        assert!(p > 1e-7 && p < 1e-5, "{p}");
    }

    #[test]
    fn a_model_within_the_noise_fits_both_ways() {
        let z: Vec<(String, f64)> = (0..10)
            .map(|i| (format!("d{i}"), 0.9 * ((i % 5) as f64 - 2.0) / 2.0))
            .collect();
        let chi2: f64 = z.iter().map(|(_, v)| v * v).sum();
        let l = LackOfFit::new(chi2, 10, 30, &z, 0.01);
        let largest_passes = l.largest.as_ref().is_none_or(|b| b.p_corrected >= 0.01);
        assert!(l.fits && l.p_value >= 0.01 && largest_passes);
    }

    /// Leverages against the hat matrix computed by the normal equations on a full-rank design.
    /// The threshold at 0.01 over 9 residuals, against scipy 1.17.1 with p = 1 − 0.99^(1/9):
    /// `t.ppf(1 − p/2, 6)` = 5.83486, `t.ppf(1 − p/2, 4)` = 8.36655, `norm.ppf(1 − p/2)` = 3.25950.
    #[test]
    fn the_largest_residual_that_passes_is_the_inverse_of_sidak() {
        let z: Vec<(String, f64)> = (0..9).map(|i| (format!("d{i}"), 0.1)).collect();
        for (nu, t) in [(6, 5.83486), (4, 8.36655)] {
            let (tc, zc) = LackOfFit::new(1.0, 8, nu, &z, 0.01).passes_up_to().unwrap();
            assert!(
                (tc - t).abs() < 1e-4 && (zc - 3.25950).abs() < 1e-4,
                "ν = {nu}: {tc}, {zc}"
            );
        }
    }

    #[test]
    fn leverages_are_the_hat_matrix_diagonal() {
        let a = DMatrix::from_row_slice(5, 2, &[1.0, 0.0, 1.0, 1.0, 1.0, 2.0, 1.0, 3.0, 1.0, 7.0]);
        let ata = a.transpose() * &a;
        let hat = &a * ata.try_inverse().unwrap() * a.transpose();
        let h = leverages(&a);
        for i in 0..5 {
            assert!((h[i] - hat[(i, i)]).abs() < 1e-12, "{i}: {} vs {}", h[i], hat[(i, i)]);
        }
        assert!((h.iter().sum::<f64>() - 2.0).abs() < 1e-12, "trace = rank");
    }
}
