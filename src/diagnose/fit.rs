//! Joint fits of θ and a discrepancy amplitude γ by weighted least squares.
//!
//! For a fixed θ the amplitude enters linearly, so it is solved in closed form and the bounded
//! Levenberg–Marquardt of [`crate::calibrate::optimize`] only searches θ (variable projection,
//! Golub & Pereyra 1973): γ needs no bounds, and a confounded γ cannot drag the search.

use nalgebra::DVector;

use super::shapes::Shape;
use crate::calibrate::{Bounds, CalibrationError, Model, optimize};

/// The data every fit sees: designs, means and weights `w_i = 1/σ(ȳ_i)` of all observations.
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
    pub gamma: f64,
    /// Σ w_i² (ȳ_i − ŷ_i)² over the fitted designs.
    pub wrss: f64,
}

impl Data<'_> {
    /// The (extended) prediction at `design`.
    pub fn predict(&self, shape: Option<&Shape>, theta: &[f64], gamma: f64, design: &[f64]) -> f64 {
        let y = self.model.predict(design, theta);
        match shape {
            Some(s) if gamma != 0.0 => y + gamma * s.eval(design, theta, y),
            _ => y,
        }
    }

    /// The best γ at this θ over the designs `idx`, and the weighted residuals it leaves.
    fn profile(&self, shape: Option<&Shape>, theta: &DVector<f64>, idx: &[usize]) -> (f64, DVector<f64>) {
        let th = theta.as_slice();
        let mut r = Vec::with_capacity(idx.len());
        let mut g = Vec::with_capacity(idx.len());
        for &i in idx {
            let y = self.model.predict(&self.designs[i], th);
            r.push(self.weights[i] * (self.means[i] - y));
            g.push(shape.map_or(0.0, |s| self.weights[i] * s.eval(&self.designs[i], th, y)));
        }
        let gg: f64 = g.iter().map(|v| v * v).sum();
        let gamma = if shape.is_some() && gg > 0.0 && gg.is_finite() {
            g.iter().zip(&r).map(|(a, b)| a * b).sum::<f64>() / gg
        } else {
            0.0
        };
        (
            gamma,
            DVector::from_iterator(idx.len(), r.iter().zip(&g).map(|(ri, gi)| ri - gamma * gi)),
        )
    }

    /// Weighted least squares over the designs `idx`, jointly in θ and (with a shape) γ.
    pub fn fit(&self, shape: Option<&Shape>, idx: &[usize]) -> Result<Fit, CalibrationError> {
        let residuals = |theta: &DVector<f64>| self.profile(shape, theta, idx).1;
        let best = optimize::least_squares(&residuals, self.bounds)?;
        let (gamma, r) = self.profile(shape, &best.theta, idx);
        Ok(Fit {
            theta: best.theta,
            gamma,
            wrss: r.norm_squared(),
        })
    }

    /// Leave-one-design-out: for each design of `idx`, the prediction there of a fit to the others.
    pub fn leave_one_out(&self, shape: Option<&Shape>, idx: &[usize]) -> Result<Vec<f64>, CalibrationError> {
        idx.iter()
            .map(|&left| {
                let rest: Vec<usize> = idx.iter().copied().filter(|&i| i != left).collect();
                let fit = self.fit(shape, &rest)?;
                Ok(self.predict(shape, fit.theta.as_slice(), fit.gamma, &self.designs[left]))
            })
            .collect()
    }

    /// Weighted sensitivities w_i ∂y_i/∂θ_j at `theta` over `idx` (central differences, one-sided at
    /// the bounds), one vector per parameter.
    pub fn sensitivities(&self, theta: &DVector<f64>, idx: &[usize]) -> Vec<Vec<f64>> {
        (0..theta.len())
            .map(|j| {
                let h = 1e-6 * (self.bounds.upper[j] - self.bounds.lower[j]).abs().max(1e-12);
                let (mut up, mut down) = (theta.clone(), theta.clone());
                up[j] = (theta[j] + h).min(self.bounds.upper[j]);
                down[j] = (theta[j] - h).max(self.bounds.lower[j]);
                let step = up[j] - down[j];
                idx.iter()
                    .map(|&i| {
                        let d = &self.designs[i];
                        let dy = self.model.predict(d, up.as_slice()) - self.model.predict(d, down.as_slice());
                        self.weights[i] * dy / step
                    })
                    .collect()
            })
            .collect()
    }

    /// The weighted shape w_i g(d_i, θ, y_i) over `idx`.
    pub fn shape_vector(&self, shape: &Shape, theta: &DVector<f64>, idx: &[usize]) -> Vec<f64> {
        let th = theta.as_slice();
        idx.iter()
            .map(|&i| {
                let d = &self.designs[i];
                self.weights[i] * shape.eval(d, th, self.model.predict(d, th))
            })
            .collect()
    }
}
