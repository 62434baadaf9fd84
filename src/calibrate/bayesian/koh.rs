//! The Kennedy–O'Hagan likelihood of the tests (A8–A9) with the emulator's hyperparameters fixed.
//!
//! Conditioning A8 on the simulation runs (whose own density does not depend on θ or the
//! discrepancy) leaves, at the training designs D2,
//! `y_test ~ N(μ_emu(D2, θ) + β_d·1, Σ_emu(D2, θ) + Σ_d + jitter·I)`,
//! with Σ_d the Gaussian-kernel discrepancy covariance of A5–A7 (variance σ_d², one roughness per
//! design variable). The search space is the unit box: θ scaled by its bounds, then log σ_d² and
//! log λ_d scaled by [`HyperBox`].

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use crate::base::optim::{FAILED, line_search, nelder_mead};
use crate::calibrate::{Bounds, CalibrationError, Problem};
use crate::emulate::gp::{Emulator, cholesky_jittered, gauss_corr};

/// How the discrepancy's constant trend β_d enters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Trend {
    /// β_d profiled out by GLS (maximum likelihood).
    Profile,
    /// β_d integrated out under a flat prior (adds ½ log 1ᵀV⁻¹1); used by the MCMC, because the
    /// profile's ½ log σ_d² reward for the common level would push σ_d² onto its lower bound.
    Marginal,
}

/// Ranges of the discrepancy hyperparameters, relative to the residual scale `s` (rms of the tests
/// minus the emulator at the centre of the θ box): σ_d from 10⁻³ s to 3 s; roughness over unit-scaled
/// designs from 0.1 (nearly constant) to 100 (correlation e⁻¹ at a tenth of the range).
#[derive(Debug, Clone, PartialEq)]
pub struct HyperBox {
    pub log_var: (f64, f64),
    pub log_roughness: (f64, f64),
}

impl HyperBox {
    fn from_scale(s: f64) -> Self {
        HyperBox {
            log_var: ((1e-3 * s).powi(2).ln(), (3.0 * s).powi(2).ln()),
            log_roughness: (0.1f64.ln(), 100f64.ln()),
        }
    }
}

fn lerp(range: (f64, f64), u: f64) -> f64 {
    range.0 + u * (range.1 - range.0)
}

/// The tests, the emulator and the search box: everything the likelihood needs.
pub struct Koh<'a> {
    emu: &'a Emulator,
    designs: DMatrix<f64>,
    design_bounds: Bounds,
    unit_designs: DMatrix<f64>,
    y: DVector<f64>,
    theta_bounds: Bounds,
    pub hyper: HyperBox,
    /// Residual scale squared: sets the jitter.
    scale2: f64,
}

impl<'a> Koh<'a> {
    pub fn new(emu: &'a Emulator, problem: &Problem, design_bounds: &Bounds) -> Result<Self, CalibrationError> {
        let designs = problem.designs.clone();
        let unit_designs = DMatrix::from_fn(designs.nrows(), designs.ncols(), |i, k| {
            unit_coordinate(designs[(i, k)], design_bounds, k)
        });
        let mut koh = Koh {
            emu,
            designs,
            design_bounds: design_bounds.clone(),
            unit_designs,
            y: problem.measured.clone(),
            theta_bounds: problem.bounds.clone(),
            hyper: HyperBox::from_scale(1.0),
            scale2: 1.0,
        };
        let r = &koh.y - koh.emu.mean(&koh.inputs(&koh.theta_bounds.center()));
        let y_rms = koh.y.norm() / (koh.y.len() as f64).sqrt();
        // The floor keeps the box sensible when the model happens to fit exactly at the centre.
        let s = (r.norm() / (r.len() as f64).sqrt()).max(1e-3 * y_rms).max(1e-150);
        if !s.is_finite() {
            return Err(CalibrationError::NonFinite(
                "emulator at the centre of the parameter box".into(),
            ));
        }
        koh.hyper = HyperBox::from_scale(s);
        koh.scale2 = s * s;
        Ok(koh)
    }

    pub fn n_theta(&self) -> usize {
        self.theta_bounds.dim()
    }

    /// Dimension of the search space: θ, log σ_d², one log λ_d per design variable.
    pub fn dim(&self) -> usize {
        self.n_theta() + 1 + self.designs.ncols()
    }

    pub fn theta(&self, u: &[f64]) -> DVector<f64> {
        self.theta_bounds
            .from_unit(&DVector::from_column_slice(&u[..self.n_theta()]))
    }

    pub fn theta_bounds(&self) -> &Bounds {
        &self.theta_bounds
    }

    /// The number of design variables (one discrepancy roughness each).
    pub fn n_design(&self) -> usize {
        self.designs.ncols()
    }

    /// The measured responses at the training designs.
    pub fn measured(&self) -> &DVector<f64> {
        &self.y
    }

    /// The diagonal jitter of the tests' covariance.
    pub fn jitter(&self) -> f64 {
        1e-10 * self.scale2
    }

    /// σ_d² and λ_d at unit-box coordinates of the hyperparameters (log σ_d², then each log λ_d).
    pub fn hyper_values(&self, unit: &[f64]) -> (f64, Vec<f64>) {
        let roughness = unit[1..]
            .iter()
            .map(|&v| lerp(self.hyper.log_roughness, v).exp())
            .collect();
        (lerp(self.hyper.log_var, unit[0]).exp(), roughness)
    }

    /// Correlation of the discrepancy between the training designs (A7) at roughness λ_d.
    pub fn design_corr(&self, roughness: &[f64]) -> DMatrix<f64> {
        gauss_corr(&self.unit_designs, &self.unit_designs, roughness)
    }

    /// Emulator mean and covariance at the training designs for parameters θ (A2–A4).
    pub fn emulated(&self, theta: &DVector<f64>) -> Option<(DVector<f64>, DMatrix<f64>)> {
        self.emu.mean_cov(&self.inputs(theta))
    }

    /// Emulator inputs: each training design followed by θ.
    fn inputs(&self, theta: &DVector<f64>) -> DMatrix<f64> {
        let (m, pd) = self.designs.shape();
        DMatrix::from_fn(m, pd + theta.len(), |i, k| {
            if k < pd { self.designs[(i, k)] } else { theta[k - pd] }
        })
    }

    /// Negative log-likelihood (constants dropped) and the GLS β_d at the unit-box point `u`.
    pub fn neg_log_lik(&self, u: &[f64], trend: Trend) -> Option<(f64, f64)> {
        let (mu, cov_emu) = self.emu.mean_cov(&self.inputs(&self.theta(u)))?;
        let (var, roughness) = self.hyper_values(&u[self.n_theta()..]);
        let chol = cholesky_jittered(&(cov_emu + self.design_corr(&roughness) * var), self.jitter())?;
        let l = chol.l();
        let lr = l.solve_lower_triangular(&(&self.y - mu))?;
        let l1 = l.solve_lower_triangular(&DVector::from_element(self.y.len(), 1.0))?;
        let a = l1.norm_squared();
        let beta = l1.dot(&lr) / a;
        let e = lr - l1 * beta;
        let log_det: f64 = l.diagonal().iter().map(|v| v.ln()).sum();
        let extra = if trend == Trend::Marginal { 0.5 * a.ln() } else { 0.0 };
        let nll = log_det + 0.5 * e.norm_squared() + extra;
        nll.is_finite().then_some((nll, beta))
    }

    pub fn cost(&self, u: &[f64], trend: Trend) -> f64 {
        self.neg_log_lik(u, trend).map_or(FAILED, |v| v.0)
    }

    /// Maximum likelihood over (θ, log σ_d², log λ_d): multi-start Nelder–Mead in the unit box (starts in parallel), then a
    /// polish of θ at the found hyperparameters. The optimum sits on a hyperparameter bound with few
    /// tests, where a joint search stops short in θ; the polish finishes the job in θ alone.
    pub fn fit_ml(&self, seed: u64) -> (Vec<f64>, f64) {
        let starts = crate::base::latin_hypercube(10, self.dim(), seed);
        let cost = |u: &[f64]| self.cost(u, Trend::Profile);
        let mut best = (0..starts.nrows())
            .into_par_iter()
            .map(|s| nelder_mead(&cost, starts.row(s).transpose().as_slice(), 0.1, 800))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("ten starts");
        // Restart once from the best point: Nelder–Mead's simplex often collapses early.
        let again = nelder_mead(&cost, &best.0, 0.05, 800);
        if again.1 < best.1 {
            best = again;
        }
        self.polish_theta(best)
    }

    /// Coordinate-wise bounded line searches in θ (two sweeps), then Nelder–Mead in θ alone.
    fn polish_theta(&self, (mut u, mut c): (Vec<f64>, f64)) -> (Vec<f64>, f64) {
        let p = self.n_theta();
        for _ in 0..2 {
            for k in 0..p {
                let line = |t: f64| {
                    let mut v = u.clone();
                    v[k] = t;
                    self.cost(&v, Trend::Profile)
                };
                let (t, ct) = line_search(&line, 0.0, 1.0, 41);
                if ct <= c {
                    (u[k], c) = (t, ct);
                }
            }
        }
        if p > 1 {
            let hyper = u[p..].to_vec();
            let in_theta = |t: &[f64]| self.cost(&[t, &hyper[..]].concat(), Trend::Profile);
            let (t, ct) = nelder_mead(&in_theta, &u[..p], 0.02, 800);
            if ct < c {
                u[..p].copy_from_slice(&t);
                c = ct;
            }
        }
        (u, c)
    }

    /// The discrepancy's posterior given the training residuals at the unit-box point `u`.
    pub fn discrepancy(&self, u: &[f64]) -> Option<Discrepancy> {
        let (mu, cov_emu) = self.emu.mean_cov(&self.inputs(&self.theta(u)))?;
        let (var, roughness) = self.hyper_values(&u[self.n_theta()..]);
        let chol = cholesky_jittered(&(cov_emu + self.design_corr(&roughness) * var), self.jitter())?;
        let (_, beta) = self.neg_log_lik(u, Trend::Profile)?;
        let weights = chol.solve(&(&self.y - mu).add_scalar(-beta));
        Some(Discrepancy {
            design_bounds: self.design_bounds.clone(),
            unit_designs: self.unit_designs.clone(),
            var,
            roughness,
            beta,
            weights,
        })
    }
}

/// The discrepancy δ(d) of A5–A7 conditioned on the training residuals: its posterior mean is
/// `β_d + σ_d² r(d)ᵀ V⁻¹ (y − μ_emu − β_d·1)`.
#[derive(Debug, Clone)]
pub struct Discrepancy {
    design_bounds: Bounds,
    unit_designs: DMatrix<f64>,
    pub var: f64,
    pub roughness: Vec<f64>,
    pub beta: f64,
    weights: DVector<f64>,
}

/// A design variable scaled to [0, 1] over its bounds; one that all tested designs share (zero
/// width) is 0 everywhere, so it adds nothing to the distances of the discrepancy's kernel.
fn unit_coordinate(v: f64, bounds: &Bounds, k: usize) -> f64 {
    let width = bounds.width()[k];
    if width > 0.0 {
        (v - bounds.lower[k]) / width
    } else {
        0.0
    }
}

impl Discrepancy {
    pub fn mean(&self, design: &[f64]) -> f64 {
        let u = DMatrix::from_fn(1, design.len(), |_, k| {
            unit_coordinate(design[k], &self.design_bounds, k)
        });
        let r = gauss_corr(&u, &self.unit_designs, &self.roughness);
        self.beta + self.var * (r * &self.weights)[0]
    }
}
