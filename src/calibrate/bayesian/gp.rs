//! The simulation emulator (Eqs. A2–A4): a Gaussian process over (design, parameters) with a
//! quadratic trend, a Gaussian kernel with one roughness per input (ARD) and a small nugget.
//! Inputs are scaled to the unit cube, outputs standardised; β and σ² are profiled out by GLS,
//! roughness by maximum likelihood.

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

use super::optim::{FAILED, nelder_mead};
use crate::calibrate::{Bounds, CalibrationError};

/// log-roughness range in the unit cube: from nearly flat to wiggles of ~1/20 of the box.
const LOG_ROUGHNESS: (f64, f64) = (-4.6, 6.2);
/// Relative nugget on the correlation matrix: conditioning only, the data are deterministic.
const NUGGET: f64 = 1e-8;
/// Multi-starts of the roughness search.
const STARTS: usize = 8;

/// Gaussian correlation `exp(-Σ λ_k (a_k − b_k)²)` between the rows of `a` and `b` (A4, A7).
pub fn gauss_corr(a: &DMatrix<f64>, b: &DMatrix<f64>, roughness: &[f64]) -> DMatrix<f64> {
    DMatrix::from_fn(a.nrows(), b.nrows(), |i, j| {
        let d2: f64 = (0..a.ncols()).map(|k| roughness[k] * (a[(i, k)] - b[(j, k)]).powi(2)).sum();
        (-d2).exp()
    })
}

/// Cholesky factor of `m + jitter·I`, raising the jitter tenfold up to six times if it fails.
pub fn cholesky_jittered(m: &DMatrix<f64>, jitter: f64) -> Option<Cholesky<f64, Dyn>> {
    let mut j = jitter;
    for _ in 0..7 {
        let mut a = m.clone();
        for i in 0..a.nrows() {
            a[(i, i)] += j;
        }
        if a.iter().all(|v| v.is_finite())
            && let Some(c) = a.cholesky()
        {
            return Some(c);
        }
        j *= 10.0;
    }
    None
}

/// Trend basis: 1, x_i and x_i x_j (i ≤ j) for the quadratic trend of A2, or 1, x_i if linear.
fn basis(x: &DMatrix<f64>, quadratic: bool) -> DMatrix<f64> {
    let p = x.ncols();
    let q = basis_len(p, quadratic);
    DMatrix::from_fn(x.nrows(), q, |r, c| {
        if c == 0 {
            return 1.0;
        }
        if c <= p {
            return x[(r, c - 1)];
        }
        let (i, j) = quad_pair(p, c - p - 1);
        x[(r, i)] * x[(r, j)]
    })
}

fn basis_len(p: usize, quadratic: bool) -> usize {
    if quadratic { 1 + p + p * (p + 1) / 2 } else { 1 + p }
}

/// The `k`-th pair (i, j), i ≤ j, in row-major order.
fn quad_pair(p: usize, mut k: usize) -> (usize, usize) {
    for i in 0..p {
        let row = p - i;
        if k < row {
            return (i, i + k);
        }
        k -= row;
    }
    unreachable!("quadratic term index out of range")
}

/// Everything the GLS fit at fixed roughness gives: the pieces for prediction and the likelihood.
#[derive(Debug, Clone)]
struct GlsFit {
    chol: Cholesky<f64, Dyn>,
    /// L⁻¹F, for the trend-uncertainty term of the predictive covariance.
    lf: DMatrix<f64>,
    /// Cholesky of FᵀR⁻¹F.
    chol_a: Cholesky<f64, Dyn>,
    beta: DVector<f64>,
    /// R⁻¹(z − Fβ).
    alpha: DVector<f64>,
    sigma2: f64,
    neg_log_lik: f64,
}

fn gls(x: &DMatrix<f64>, z: &DVector<f64>, f: &DMatrix<f64>, roughness: &[f64]) -> Option<GlsFit> {
    let n = x.nrows() as f64;
    let chol = cholesky_jittered(&gauss_corr(x, x, roughness), NUGGET)?;
    let l = chol.l();
    let lf = l.solve_lower_triangular(f)?;
    let lz = l.solve_lower_triangular(z)?;
    let chol_a = cholesky_jittered(&(lf.transpose() * &lf), 1e-12)?;
    let beta = chol_a.solve(&(lf.transpose() * &lz));
    let e = &lz - &lf * &beta;
    let sigma2 = e.norm_squared() / n;
    let alpha = chol.solve(&(z - f * &beta));
    let log_det: f64 = l.diagonal().iter().map(|v| v.ln()).sum();
    let neg_log_lik = 0.5 * n * sigma2.max(1e-300).ln() + log_det;
    neg_log_lik.is_finite().then_some(GlsFit { chol, lf, chol_a, beta, alpha, sigma2, neg_log_lik })
}

/// A fitted emulator, owning everything it needs to predict.
#[derive(Debug, Clone)]
pub struct Emulator {
    bounds: Bounds,
    y_mean: f64,
    y_sd: f64,
    x: DMatrix<f64>,
    quadratic: bool,
    roughness: Vec<f64>,
    fit: GlsFit,
}

impl Emulator {
    /// Fits the emulator to `inputs` (one row per run, in the box `bounds`) and `outputs`.
    /// Roughness by maximum likelihood: multi-start Nelder–Mead in log space.
    pub fn fit(inputs: &DMatrix<f64>, outputs: &DVector<f64>, bounds: &Bounds) -> Result<Self, CalibrationError> {
        let (n, p) = inputs.shape();
        if outputs.iter().chain(inputs.iter()).any(|v| !v.is_finite()) {
            return Err(CalibrationError::NonFinite("emulator samples".into()));
        }
        let x = DMatrix::from_fn(n, p, |i, k| (inputs[(i, k)] - bounds.lower[k]) / bounds.width()[k]);
        let y_mean = outputs.mean();
        let y_sd = outputs.variance().sqrt().max(1e-300);
        let z = outputs.map(|v| (v - y_mean) / y_sd);
        // A quadratic trend needs clearly more runs than terms; else fall back to linear.
        let quadratic = basis_len(p, true) + 2 <= n;
        let f = basis(&x, quadratic);
        if basis_len(p, quadratic) >= n {
            return Err(CalibrationError::Numerics(format!("{n} emulator samples are too few for {p} inputs")));
        }
        let to_roughness = |u: &[f64]| -> Vec<f64> {
            u.iter().map(|v| (LOG_ROUGHNESS.0 + v * (LOG_ROUGHNESS.1 - LOG_ROUGHNESS.0)).exp()).collect()
        };
        let cost = |u: &[f64]| gls(&x, &z, &f, &to_roughness(u)).map_or(FAILED, |g| g.neg_log_lik);
        let starts = crate::plan::latin_hypercube(STARTS, p, 0x5eed);
        let best = (0..STARTS)
            .map(|s| nelder_mead(&cost, starts.row(s).transpose().as_slice(), 0.1, 400))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("STARTS > 0");
        let roughness = to_roughness(&best.0);
        let fit = gls(&x, &z, &f, &roughness)
            .ok_or_else(|| CalibrationError::Numerics("emulator correlation matrix is singular".into()))?;
        Ok(Emulator { bounds: bounds.clone(), y_mean, y_sd, x, quadratic, roughness, fit })
    }

    pub fn roughness(&self) -> &[f64] {
        &self.roughness
    }

    fn scale(&self, points: &DMatrix<f64>) -> DMatrix<f64> {
        let w = self.bounds.width();
        DMatrix::from_fn(points.nrows(), points.ncols(), |i, k| (points[(i, k)] - self.bounds.lower[k]) / w[k])
    }

    /// Predictive mean at each row of `points` (original units).
    pub fn mean(&self, points: &DMatrix<f64>) -> DVector<f64> {
        let u = self.scale(points);
        let r = gauss_corr(&u, &self.x, &self.roughness);
        let z = basis(&u, self.quadratic) * &self.fit.beta + r * &self.fit.alpha;
        z.map(|v| self.y_mean + self.y_sd * v)
    }

    /// Predictive mean and covariance at the rows of `points` (original units), including the
    /// uncertainty of the GLS trend coefficients (universal kriging).
    pub fn mean_cov(&self, points: &DMatrix<f64>) -> Option<(DVector<f64>, DMatrix<f64>)> {
        let u = self.scale(points);
        let r = gauss_corr(&self.x, &u, &self.roughness);
        let fs = basis(&u, self.quadratic);
        let z = &fs * &self.fit.beta + r.transpose() * &self.fit.alpha;
        let w = self.fit.chol.l().solve_lower_triangular(&r)?;
        let g = fs.transpose() - self.fit.lf.transpose() * &w;
        let h = self.fit.chol_a.l().solve_lower_triangular(&g)?;
        let c = gauss_corr(&u, &u, &self.roughness) - w.transpose() * &w + h.transpose() * h;
        let s2 = self.fit.sigma2 * self.y_sd * self.y_sd;
        Some((z.map(|v| self.y_mean + self.y_sd * v), c * s2))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid_data(f: impl Fn(f64, f64) -> f64, n: usize) -> (DMatrix<f64>, DVector<f64>, Bounds) {
        let plan = crate::plan::latin_hypercube(n, 2, 3);
        let bounds = Bounds::new(vec![7.0, 50_000.0], vec![13.0, 80_000.0]);
        let x = DMatrix::from_fn(n, 2, |i, k| bounds.lower[k] + plan[(i, k)] * bounds.width()[k]);
        let y = DVector::from_fn(n, |i, _| f(x[(i, 0)], x[(i, 1)]));
        (x, y, bounds)
    }

    #[test]
    fn quadratic_basis_terms() {
        let x = DMatrix::from_row_slice(1, 2, &[2.0, 3.0]);
        assert_eq!(basis(&x, true).as_slice(), &[1.0, 2.0, 3.0, 4.0, 6.0, 9.0]);
    }

    #[test]
    fn reproduces_a_quadratic_and_interpolates() {
        // A quadratic lies in the trend space: predictions away from the data are near exact.
        let f = |h: f64, e: f64| 1.0 + 0.1 * h * h - 2e-5 * e + 1e-6 * h * e;
        let (x, y, b) = grid_data(f, 20);
        let emu = Emulator::fit(&x, &y, &b).unwrap();
        let p = DMatrix::from_row_slice(2, 2, &[9.0, 61_000.0, 12.5, 52_000.0]);
        let m = emu.mean(&p);
        assert!((m[0] - f(9.0, 61_000.0)).abs() < 1e-6 && (m[1] - f(12.5, 52_000.0)).abs() < 1e-6, "{m}");
        // At a training point the variance is ~0 (nugget only).
        let (_, c) = emu.mean_cov(&x.rows(0, 1).into_owned()).unwrap();
        assert!(c[(0, 0)].abs() < 1e-8, "{c}");
    }

    #[test]
    fn cantilever_emulator_is_accurate() {
        // 24 samples of the Euler deflection: mean error below 0.3 % of the response at h=8, 10.
        let f = |h: f64, e: f64| 4.0 * 600.0 * 8000.0 / (e * 2.0 * h.powi(3));
        let (x, y, b) = grid_data(f, 24);
        let emu = Emulator::fit(&x, &y, &b).unwrap();
        let p = DMatrix::from_row_slice(2, 2, &[8.0, 65_000.0, 10.0, 65_000.0]);
        let (m, c) = emu.mean_cov(&p).unwrap();
        for (i, h) in [8.0, 10.0].into_iter().enumerate() {
            let rel = (m[i] - f(h, 65_000.0)).abs() / f(h, 65_000.0);
            assert!(rel < 3e-3, "h={h}: rel error {rel}");
            assert!(c[(i, i)] >= 0.0);
        }
    }
}
