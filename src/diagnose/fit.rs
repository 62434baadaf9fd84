//! Joint fits of θ and discrepancy amplitudes γ by weighted least squares, and their covariance.
//!
//! The model with shapes g_1..g_m is `y(d, θ) + Σ_k γ_k g_k(d, θ, y)`. For a fixed θ the amplitudes
//! enter linearly, so they are solved in closed form and the bounded Levenberg–Marquardt of
//! [`crate::base::optimize`] only searches θ (variable projection, Golub & Pereyra 1973): γ
//! needs no bounds, and a shape the data cannot tell from θ cannot drag the search.
//!
//! The covariance of (θ, γ) is the Gauss–Newton one, s² (AᵀA)⁻¹ with A the weighted Jacobian of
//! the extended prediction (Bates & Watts 1988, §2.3); with the noise known from replicates the
//! weights already carry σ and s² = 1.

use nalgebra::{DMatrix, DVector};

use super::shapes::Shape;
use crate::calibrate::{Bounds, CalibrationError, Model, optimize};

/// The data every fit sees: designs, means and weights `w_i = √n_i / σ_i` of all observations.
pub(crate) struct Data<'a> {
    pub model: &'a dyn Model,
    pub bounds: &'a Bounds,
    pub designs: Vec<Vec<f64>>,
    pub means: Vec<f64>,
    pub weights: Vec<f64>,
}

/// A fitted (possibly extended) model.
#[derive(Debug, Clone)]
pub(crate) struct Fit {
    pub theta: DVector<f64>,
    /// One amplitude per shape, in the order the shapes were given.
    pub gamma: Vec<f64>,
    /// Σ w_i² (ȳ_i − ŷ_i)² over the fitted designs.
    pub wrss: f64,
}

impl Fit {
    /// The amplitude of the first (usually only) shape; 0 without one.
    pub fn amplitude(&self) -> f64 {
        self.gamma.first().copied().unwrap_or(0.0)
    }
}

/// Below this ratio of smallest to largest singular value of the column-scaled Jacobian, the
/// columns are numerically dependent: a shape in the span of the sensitivities to θ carries no
/// information of its own at any noise level that tests have (1e-8 in angle, 1e-16 in R²).
const DEPENDENT: f64 = 1e-8;

/// The covariance of a fit's (θ, γ): `None` where the Jacobian's columns are numerically dependent.
#[derive(Debug, Clone)]
pub(crate) struct Covariance {
    /// (p + m) × (p + m): θ first, then the amplitudes.
    pub matrix: DMatrix<f64>,
    /// For each amplitude: ‖w g‖² (AᵀA)⁻¹_γγ, the variance inflation of γ by θ and the other shapes.
    pub inflation: Vec<f64>,
}

impl Data<'_> {
    /// The (extended) prediction at `design`.
    pub fn predict(&self, shapes: &[&Shape], theta: &[f64], gamma: &[f64], design: &[f64]) -> f64 {
        let y = self.model.predict(design, theta);
        shapes
            .iter()
            .zip(gamma)
            .filter(|(_, g)| **g != 0.0)
            .fold(y, |acc, (s, g)| acc + g * s.eval(design, theta, y))
    }

    /// The best γ at this θ over the designs `idx`, and the weighted residuals it leaves.
    fn profile(&self, shapes: &[&Shape], theta: &DVector<f64>, idx: &[usize]) -> (Vec<f64>, DVector<f64>) {
        let th = theta.as_slice();
        let mut r = DVector::zeros(idx.len());
        let mut g = DMatrix::zeros(idx.len(), shapes.len());
        for (row, &i) in idx.iter().enumerate() {
            let y = self.model.predict(&self.designs[i], th);
            r[row] = self.weights[i] * (self.means[i] - y);
            for (k, s) in shapes.iter().enumerate() {
                g[(row, k)] = self.weights[i] * s.eval(&self.designs[i], th, y);
            }
        }
        if shapes.is_empty() || g.iter().any(|v| !v.is_finite()) {
            return (vec![0.0; shapes.len()], r);
        }
        let svd = g.clone().svd(true, true);
        let tol = 1e-12 * svd.singular_values.max().max(f64::MIN_POSITIVE);
        let gamma = svd.solve(&r, tol).unwrap_or_else(|_| DVector::zeros(shapes.len()));
        let left = &r - &g * &gamma;
        (gamma.iter().copied().collect(), left)
    }

    /// Weighted least squares over the designs `idx`, jointly in θ and the amplitudes of `shapes`.
    pub fn fit(&self, shapes: &[&Shape], idx: &[usize]) -> Result<Fit, CalibrationError> {
        self.fit_with(shapes, idx, None)
    }

    /// [`Data::fit`] from a warm start θ₀ (one Levenberg–Marquardt run from there instead of the
    /// multi-start search): a refit of a model close to one already fitted. From the θ of a fit
    /// whose shapes are a subset of `shapes`, the weighted RSS can only go down.
    pub fn fit_from(&self, shapes: &[&Shape], idx: &[usize], theta0: &DVector<f64>) -> Result<Fit, CalibrationError> {
        self.fit_with(shapes, idx, Some(theta0))
    }

    fn fit_with(
        &self,
        shapes: &[&Shape],
        idx: &[usize],
        theta0: Option<&DVector<f64>>,
    ) -> Result<Fit, CalibrationError> {
        let residuals = |theta: &DVector<f64>| self.profile(shapes, theta, idx).1;
        let best = match theta0 {
            Some(t) => optimize::least_squares_from(&residuals, self.bounds, t)?,
            None => optimize::least_squares(&residuals, self.bounds)?,
        };
        let (gamma, r) = self.profile(shapes, &best.theta, idx);
        Ok(Fit {
            theta: best.theta,
            gamma,
            wrss: r.norm_squared(),
        })
    }

    /// Leave-one-design-out: for each design of `idx`, the prediction there of a refit to the
    /// others, warm-started at θ₀, the fit to all of `idx`. Dropping one design moves the minimum
    /// a little, not to another basin: where it could, the model is not identified without that
    /// design and a multi-start would pick among near-equal minima by chance. So one
    /// Levenberg–Marquardt run per design (five times fewer than a fresh multi-start search; on the
    /// main job the leave-one-out errors agree with the multi-start's to 5e-6 relative).
    pub fn leave_one_out(
        &self,
        shapes: &[&Shape],
        idx: &[usize],
        theta0: &DVector<f64>,
    ) -> Result<Vec<f64>, CalibrationError> {
        idx.iter()
            .map(|&left| {
                let rest: Vec<usize> = idx.iter().copied().filter(|&i| i != left).collect();
                let fit = self.fit_from(shapes, &rest, theta0)?;
                Ok(self.predict(shapes, fit.theta.as_slice(), &fit.gamma, &self.designs[left]))
            })
            .collect()
    }

    /// ∂ŷ/∂(θ, γ) of the extended prediction at `design` (central differences in θ, one-sided at
    /// the bounds; exact in γ).
    pub fn gradient(&self, shapes: &[&Shape], fit: &Fit, design: &[f64]) -> DVector<f64> {
        let p = fit.theta.len();
        let mut out = DVector::zeros(p + shapes.len());
        for j in 0..p {
            let h = 1e-6 * (self.bounds.upper[j] - self.bounds.lower[j]).abs().max(1e-12);
            let (mut up, mut down) = (fit.theta.clone(), fit.theta.clone());
            up[j] = (fit.theta[j] + h).min(self.bounds.upper[j]);
            down[j] = (fit.theta[j] - h).max(self.bounds.lower[j]);
            let step = up[j] - down[j];
            out[j] = (self.predict(shapes, up.as_slice(), &fit.gamma, design)
                - self.predict(shapes, down.as_slice(), &fit.gamma, design))
                / step;
        }
        let th = fit.theta.as_slice();
        let y = self.model.predict(design, th);
        for (k, s) in shapes.iter().enumerate() {
            out[p + k] = s.eval(design, th, y);
        }
        out
    }

    /// The weighted Jacobian A over `idx`: rows w_i ∂ŷ_i/∂(θ, γ).
    pub fn jacobian(&self, shapes: &[&Shape], fit: &Fit, idx: &[usize]) -> DMatrix<f64> {
        let cols = fit.theta.len() + shapes.len();
        let mut a = DMatrix::zeros(idx.len(), cols);
        for (row, &i) in idx.iter().enumerate() {
            let g = self.gradient(shapes, fit, &self.designs[i]);
            a.set_row(row, &(g * self.weights[i]).transpose());
        }
        a
    }

    /// s² (AᵀA)⁻¹ over `idx`; `None` when A's scaled columns are numerically dependent or not finite.
    pub fn covariance(&self, shapes: &[&Shape], fit: &Fit, idx: &[usize], s2: f64) -> Option<Covariance> {
        let a = self.jacobian(shapes, fit, idx);
        if a.nrows() < a.ncols() || a.iter().any(|v| !v.is_finite()) {
            return None;
        }
        // Scale the columns to unit length so that the dependence test does not see units.
        let norms: Vec<f64> = a.column_iter().map(|c| c.norm()).collect();
        if norms.contains(&0.0) {
            return None;
        }
        let scaled = DMatrix::from_fn(a.nrows(), a.ncols(), |i, j| a[(i, j)] / norms[j]);
        let svd = scaled.svd(false, true);
        let (lo, hi) = svd
            .singular_values
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        if hi == 0.0 || lo / hi < DEPENDENT {
            return None;
        }
        let vt = svd.v_t.expect("asked for V");
        let inv_s2 = svd.singular_values.map(|v| 1.0 / (v * v));
        // (SᵀS)⁻¹ = V diag(1/σ²) Vᵀ for the scaled columns; undo the scaling.
        let scaled_inv = vt.transpose() * DMatrix::from_diagonal(&inv_s2) * &vt;
        let p = fit.theta.len();
        let matrix = DMatrix::from_fn(a.ncols(), a.ncols(), |i, j| {
            s2 * scaled_inv[(i, j)] / (norms[i] * norms[j])
        });
        let inflation = (0..shapes.len()).map(|k| scaled_inv[(p + k, p + k)]).collect();
        Some(Covariance { matrix, inflation })
    }
}
