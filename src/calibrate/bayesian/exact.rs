//! The posterior of one or two calibration parameters by deterministic quadrature, no sampling.
//!
//! The posterior over the unit box of (θ, log σ_d², log λ_d) is `exp(−ℓ_M)` with ℓ_M the
//! β_d-marginal negative log-likelihood of [`Koh::neg_log_lik`] (A8–A9) and uniform priors. The
//! density of θ integrates the hyperparameters out:
//! `m(θ) = ∫ exp(−ℓ_M(θ, h)) dh`, computed by a tensor Gauss–Legendre rule in h. The emulator's mean
//! and covariance depend on θ only, so they are computed once per θ node and every h node costs an
//! m × m Cholesky factorisation (m = number of tests). Over θ, [`cubature`] refines boxes where the
//! mass is: with two tests the density has a cusp at θ̂ (small σ_d² pins θ to the tests), so the
//! box is split at θ̂ first and the adaptive bisection follows the cusp down.
//!
//! Error estimates: the cubature's Kronrod–Gauss differences (relative to the mass; an upper
//! estimate, being the Gauss rule's error), and for the inner rule the relative difference of m(θ)
//! from a rule with twice the nodes per axis, at θ̂ and at the 95 % interval's ends.

use nalgebra::DVector;

use super::cubature::{self, Cubature, Rule, gauss_legendre};
use super::koh::Koh;

/// Gauss–Legendre nodes along log σ_d² (its range spans ~16 units of ln, the integrand varies over
/// a few) and along each log λ_d (ln 1000 ≈ 7 units, the correlation varies smoothly).
const VAR_NODES: usize = 16;
const ROUGH_NODES: usize = 6;
/// Relative tolerance of the cubature over θ and the box budgets (1-D, 2-D).
const REL_TOL: f64 = 1e-5;
const MAX_BOXES: (usize, usize) = (400, 600);
/// Points of the drawn density curve besides the rule's nodes.
const CURVE_POINTS: usize = 400;

/// The hyperparameter rule: per node its weight (summing to 1 over the unit box), σ_d² and the
/// discrepancy correlation between the tests (row-major m × m).
struct InnerGrid {
    nodes: Vec<(f64, f64, Vec<f64>)>,
}

/// Gauss–Legendre on [0, 1]: nodes and weights summing to 1.
fn unit_rule(n: usize) -> Vec<(f64, f64)> {
    let (x, w) = gauss_legendre(n);
    x.iter().zip(&w).map(|(x, w)| ((x + 1.0) / 2.0, w / 2.0)).collect()
}

fn inner_grid(koh: &Koh, var_nodes: usize, rough_nodes: usize) -> InnerGrid {
    let q = koh.n_design();
    let (vars, roughs) = (unit_rule(var_nodes), unit_rule(rough_nodes));
    let mut nodes = Vec::with_capacity(var_nodes * rough_nodes.pow(q as u32));
    for i in 0..rough_nodes.pow(q as u32) {
        let (mut unit, mut w) = (vec![0.0; q + 1], 1.0);
        let mut rest = i;
        for k in 0..q {
            let (u, wk) = roughs[rest % rough_nodes];
            unit[k + 1] = u;
            w *= wk;
            rest /= rough_nodes;
        }
        let (_, roughness) = koh.hyper_values(&unit);
        let corr: Vec<f64> = koh.design_corr(&roughness).transpose().as_slice().to_vec();
        for &(u, wv) in &vars {
            unit[0] = u;
            nodes.push((w * wv, koh.hyper_values(&unit).0, corr.clone()));
        }
    }
    InnerGrid { nodes }
}

/// `ℓ_M` of the tests (A8–A9, β_d integrated out under a flat prior) for the covariance
/// `V = S + var·C + jitter·I` and residual r = y − μ_emu:
/// `½ ln|V| + ½ (rᵀV⁻¹r − (1ᵀV⁻¹r)²/1ᵀV⁻¹1) + ½ ln 1ᵀV⁻¹1`. The jitter is raised tenfold up
/// to six times if V is not positive definite (as [`super::gp::cholesky_jittered`]). `work` holds
/// m² + 2m values. This runs hundreds of times per θ, so it takes one logarithm where it can.
fn marginal_nll(s: &[f64], c: &[f64], var: f64, jitter: f64, r: &[f64], work: &mut [f64]) -> f64 {
    let m = r.len();
    let mut j = jitter;
    for _ in 0..7 {
        let (l, rest) = work.split_at_mut(m * m);
        for i in 0..m * m {
            l[i] = s[i] + var * c[i];
        }
        if let Some(log_det) = cholesky_in_place(l, m, j) {
            let (u, w) = rest.split_at_mut(m);
            forward_r_and_ones(l, m, r, u, w);
            let (a, b, q) = (dot(w, w), dot(w, u), dot(u, u));
            return log_det + 0.5 * (q - b * b / a) + 0.5 * a.ln();
        }
        j *= 10.0;
    }
    f64::INFINITY
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Lower Cholesky factor of `a + jitter·I` in place (row-major); returns ½ ln|a + jitter·I| as the
/// logarithm of the product of the pivots' roots (flushed into the sum before it could leave the
/// range of f64, so one `ln` serves many pivots).
fn cholesky_in_place(a: &mut [f64], m: usize, jitter: f64) -> Option<f64> {
    let (mut log_det, mut product) = (0.0, 1.0);
    for i in 0..m {
        for j in 0..=i {
            let mut sum = a[i * m + j] + if i == j { jitter } else { 0.0 };
            for k in 0..j {
                sum -= a[i * m + k] * a[j * m + k];
            }
            if i == j {
                if sum.is_nan() || sum <= 0.0 || !sum.is_finite() {
                    return None;
                }
                let d = sum.sqrt();
                a[i * m + i] = d;
                product *= d;
                if !(1e-100..=1e100).contains(&product) {
                    log_det += product.ln();
                    product = 1.0;
                }
            } else {
                a[i * m + j] = sum / a[j * m + j];
            }
        }
    }
    Some(log_det + product.ln())
}

/// Solves L u = r and L w = 1 by one forward substitution (L row-major lower triangular).
fn forward_r_and_ones(l: &[f64], m: usize, r: &[f64], u: &mut [f64], w: &mut [f64]) {
    for i in 0..m {
        let row = &l[i * m..i * m + i];
        let (su, sw) = row
            .iter()
            .zip(&u[..i])
            .zip(&w[..i])
            .fold((0.0, 0.0), |(a, b), ((lk, uk), wk)| (a + lk * uk, b + lk * wk));
        let d = l[i * m + i];
        u[i] = (r[i] - su) / d;
        w[i] = (1.0 - sw) / d;
    }
}

/// ln m(θ) at θ (original units): log-sum-exp of −ℓ_M over the inner rule.
fn log_marginal(koh: &Koh, grid: &InnerGrid, theta: &DVector<f64>) -> f64 {
    let Some((mu, cov)) = koh.emulated(theta) else {
        return f64::NEG_INFINITY;
    };
    let r: Vec<f64> = (koh.measured() - mu).iter().copied().collect();
    let s: Vec<f64> = cov.transpose().as_slice().to_vec();
    let m = r.len();
    let mut work = vec![0.0; m * m + 2 * m];
    let nll: Vec<f64> = grid
        .nodes
        .iter()
        .map(|(_, var, c)| marginal_nll(&s, c, *var, koh.jitter(), &r, &mut work))
        .collect();
    let lowest = nll.iter().copied().fold(f64::INFINITY, f64::min);
    if !lowest.is_finite() {
        return f64::NEG_INFINITY;
    }
    let sum: f64 = grid
        .nodes
        .iter()
        .zip(&nll)
        .map(|((w, _, _), l)| w * (lowest - l).exp())
        .sum();
    sum.ln() - lowest
}

/// The hyperparameter-marginal log density of θ, ln m(θ) up to a constant, on the unit θ box (zero
/// prior outside): what the sampler explores when there are too many parameters for quadrature.
/// Integrating σ_d² and λ_d by the same rule as [`posterior`] removes the funnel they make with θ
/// (small σ_d² pins θ, large σ_d² frees it), which a sampler over the joint space crosses slowly.
pub struct Marginal<'a, 'b> {
    koh: &'b Koh<'a>,
    grid: InnerGrid,
}

impl<'a, 'b> Marginal<'a, 'b> {
    pub fn new(koh: &'b Koh<'a>) -> Self {
        Marginal {
            koh,
            grid: inner_grid(koh, VAR_NODES, ROUGH_NODES),
        }
    }

    /// θ's box.
    pub fn theta_bounds(&self) -> &crate::base::Bounds {
        self.koh.theta_bounds()
    }

    /// ln m(θ) at unit-box coordinates `t` of θ; −∞ outside the box.
    pub fn log_density(&self, t: &[f64]) -> f64 {
        if !t.iter().all(|v| (0.0..=1.0).contains(v)) {
            return f64::NEG_INFINITY;
        }
        log_marginal(self.koh, &self.grid, &self.koh.theta(t))
    }
}

/// What the quadrature reports about itself (written to results.json as it is).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct QuadratureSummary {
    /// Which rules: e.g. "adaptive Gauss–Kronrod 7-15 in θ, Gauss–Legendre 24 × 8 in (log σ_d², log λ_d)".
    pub rule: String,
    /// Estimated relative error of the posterior mass over θ (Kronrod − Gauss, summed over boxes).
    pub relative_error: f64,
    /// Largest relative difference of m(θ) from a rule with twice the hyperparameter nodes per axis
    /// (at θ̂ and the interval's ends).
    pub inner_relative_error: f64,
    pub boxes: usize,
    /// Likelihood evaluations: θ nodes × hyperparameter nodes.
    pub evaluations: usize,
    /// Whether the cubature met its tolerance within its box budget.
    pub converged: bool,
}

/// The posterior of θ by quadrature: summaries per parameter and the drawn density.
#[derive(Debug, Clone)]
pub struct ExactPosterior {
    pub mean: DVector<f64>,
    pub median: DVector<f64>,
    pub interval95: Vec<(f64, f64)>,
    /// Per parameter: points θ and the marginal density there (per unit of θ).
    pub density: Vec<(Vec<f64>, Vec<f64>)>,
    pub summary: QuadratureSummary,
}

/// The initial boxes: the unit θ box split at θ̂ along every axis where θ̂ is inside.
fn initial_boxes(u_hat: &[f64]) -> Vec<(Vec<f64>, Vec<f64>)> {
    let mut boxes = vec![(vec![0.0; u_hat.len()], vec![1.0; u_hat.len()])];
    for (k, &u) in u_hat.iter().enumerate() {
        if !(0.001..=0.999).contains(&u) {
            continue;
        }
        boxes = boxes
            .into_iter()
            .flat_map(|(lo, hi)| {
                let (mut hi_l, mut lo_r) = (hi.clone(), lo.clone());
                hi_l[k] = u;
                lo_r[k] = u;
                [(lo, hi_l), (lo_r, hi)]
            })
            .collect();
    }
    boxes
}

/// The posterior of θ (one or two parameters) by quadrature around the ML point `u_hat` (unit box).
pub fn posterior(koh: &Koh, u_hat: &[f64]) -> ExactPosterior {
    posterior_with(koh, u_hat, VAR_NODES, ROUGH_NODES)
}

/// [`posterior`] with a given number of hyperparameter nodes per axis.
fn posterior_with(koh: &Koh, u_hat: &[f64], var_nodes: usize, rough_nodes: usize) -> ExactPosterior {
    let p = koh.n_theta();
    let grid = inner_grid(koh, var_nodes, rough_nodes);
    let theta_of = |t: &[f64]| koh.theta(t);
    let reference = log_marginal(koh, &grid, &theta_of(&u_hat[..p]));
    let density = |t: &[f64]| (log_marginal(koh, &grid, &theta_of(t)) - reference).exp();
    let (rule, budget) = if p == 1 {
        (Rule::k15(), MAX_BOXES.0)
    } else {
        (Rule::k7(), MAX_BOXES.1)
    };
    let cub = cubature::integrate(&density, initial_boxes(&u_hat[..p]), rule, REL_TOL, budget);
    summarise(koh, &grid, &cub, u_hat)
}

fn summarise(koh: &Koh, grid: &InnerGrid, cub: &Cubature, u_hat: &[f64]) -> ExactPosterior {
    let p = koh.n_theta();
    let lower = koh.theta(&vec![0.0; p]);
    let width = koh.theta(&vec![1.0; p]) - &lower;
    let marginals: Vec<_> = (0..p).map(|k| cub.marginal(k)).collect();
    let to_theta = |k: usize, u: f64| lower[k] + u * width[k];
    let quantile = |k: usize, q: f64| marginals[k].quantile(q, 0.0, 1.0);
    let interval_unit: Vec<(f64, f64)> = (0..p).map(|k| (quantile(k, 0.025), quantile(k, 0.975))).collect();
    let density = (0..p)
        .map(|k| {
            let (u, d) = marginals[k].curve(0.0, 1.0, CURVE_POINTS);
            (
                u.iter().map(|&v| to_theta(k, v)).collect(),
                d.iter().map(|&v| v / width[k]).collect(),
            )
        })
        .collect();
    let mut checks = vec![u_hat[..p].to_vec()];
    for (k, &(lo, hi)) in interval_unit.iter().enumerate() {
        for end in [lo, hi] {
            let mut t = u_hat[..p].to_vec();
            t[k] = end;
            checks.push(t);
        }
    }
    let n = grid.nodes.len();
    let fine = inner_grid(koh, 2 * VAR_NODES, 2 * ROUGH_NODES);
    let inner_relative_error = checks
        .iter()
        .map(|t| {
            let th = koh.theta(t);
            ((log_marginal(koh, grid, &th) - log_marginal(koh, &fine, &th)).exp() - 1.0).abs()
        })
        .fold(0.0, f64::max);
    let rule_name = if p == 1 { "7-15" } else { "3-7 (tensor)" };
    let rough = if koh.n_design() == 1 {
        format!(" × {ROUGH_NODES}")
    } else {
        format!(" × {ROUGH_NODES}^{}", koh.n_design())
    };
    ExactPosterior {
        mean: DVector::from_fn(p, |k, _| to_theta(k, marginals[k].mean())),
        median: DVector::from_fn(p, |k, _| to_theta(k, quantile(k, 0.5))),
        interval95: interval_unit
            .iter()
            .enumerate()
            .map(|(k, &(lo, hi))| (to_theta(k, lo), to_theta(k, hi)))
            .collect(),
        density,
        summary: QuadratureSummary {
            rule: format!(
                "adaptive Gauss–Kronrod {rule_name} in θ; Gauss–Legendre {VAR_NODES}{rough} in (log σ_d², log λ_d)"
            ),
            relative_error: cub.error / cub.integral,
            inner_relative_error,
            boxes: cub.panels.len(),
            evaluations: cub.evaluations * n,
            converged: cub.error <= REL_TOL * cub.integral,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibrate::bayesian::koh::Trend;
    use crate::calibrate::testing::cantilever;
    use crate::calibrate::{Bounds, bayesian};

    #[test]
    fn small_likelihood_matches_koh() {
        // The allocation-free ℓ_M against Koh::neg_log_lik (nalgebra, same formula) at a few points
        // of the unit box: the same numbers to rounding.
        let p = cantilever(&[8.0, 10.0, 12.0]);
        let db = Bounds::new(vec![7.0], vec![13.0]);
        let sim = bayesian::emulator_samples(&p, &db, &bayesian::Settings::default());
        let emu = sim.emulator(&bayesian::joint_bounds(&db, &p.bounds)).unwrap();
        let koh = Koh::new(&emu, &p, &db).unwrap();
        for u in [[0.5, 0.5, 0.5], [0.3, 0.1, 0.9], [0.8, 0.7, 0.2]] {
            let expected = koh.neg_log_lik(&u, Trend::Marginal).unwrap().0;
            let (mu, cov) = koh.emulated(&koh.theta(&u)).unwrap();
            let (var, rough) = koh.hyper_values(&u[1..]);
            let c = koh.design_corr(&rough).transpose().as_slice().to_vec();
            let r: Vec<f64> = (koh.measured() - mu).iter().copied().collect();
            let mut work = vec![0.0; 15];
            let got = marginal_nll(cov.transpose().as_slice(), &c, var, koh.jitter(), &r, &mut work);
            assert!(
                (got - expected).abs() < 1e-9 * expected.abs().max(1.0),
                "{u:?}: {got} vs {expected}"
            );
        }
    }
}

#[cfg(test)]
mod convergence_tests {
    use super::*;
    use crate::calibrate::testing::cantilever;
    use crate::calibrate::{Bounds, bayesian};

    #[test]
    fn finer_hyperparameter_rule_changes_the_interval_little() {
        // The cantilever (h = 8, 10): the default inner rule (16 × 6) against a much finer one (48 × 16). Measured with 16 × 6: median 4e-9, 95 % ends 2e-5
        // relative; bound 1e-4.
        let p = cantilever(&[8.0, 10.0]);
        let db = Bounds::new(vec![7.0], vec![13.0]);
        let sim = bayesian::emulator_samples(&p, &db, &bayesian::Settings::default());
        let emu = sim.emulator(&bayesian::joint_bounds(&db, &p.bounds)).unwrap();
        let koh = Koh::new(&emu, &p, &db).unwrap();
        let (u_hat, _) = koh.fit_ml(7);
        let (a, b) = (posterior(&koh, &u_hat), posterior_with(&koh, &u_hat, 48, 16));
        eprintln!(
            "default {:?} {:?}, fine {:?} {:?}",
            a.interval95, a.median, b.interval95, b.median
        );
        let close = |x: f64, y: f64| (x / y - 1.0).abs() < 1e-4;
        assert!(close(a.interval95[0].0, b.interval95[0].0) && close(a.interval95[0].1, b.interval95[0].1));
        assert!(close(a.median[0], b.median[0]) && close(a.mean[0], b.mean[0]));
        assert!(a.summary.converged && a.summary.relative_error < 1e-5);
    }
}
