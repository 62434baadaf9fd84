//! Bounded nonlinear least squares: minimise ‖r(θ)‖² over a box.
//!
//! Both Eq. 3 (least squares) and Eq. 6 (sensitivity) are sums of squared residuals, so both use
//! this one solver: Levenberg–Marquardt on parameters scaled to the unit cube, steps projected
//! back into the box, Jacobian by central differences, a few starts (centre plus a Latin
//! hypercube) to avoid a poor local minimum. The damping keeps the step well defined when the
//! residuals cannot tell parameters apart (Table 1's valley along L³/E).

use nalgebra::{DMatrix, DVector};

use super::{Bounds, CalibrationError};
use crate::plan::latin_hypercube;

/// Residual function: parameters → residual vector.
pub trait Residuals {
    fn residuals(&self, theta: &DVector<f64>) -> DVector<f64>;
}

impl<F: Fn(&DVector<f64>) -> DVector<f64>> Residuals for F {
    fn residuals(&self, theta: &DVector<f64>) -> DVector<f64> {
        self(theta)
    }
}

/// The best parameters found and their sum of squared residuals.
#[derive(Debug, Clone)]
pub struct Minimum {
    pub theta: DVector<f64>,
    pub cost: f64,
}

const EXTRA_STARTS: usize = 4;
const MAX_ITERATIONS: usize = 500;
/// Step for central differences in the unit cube: truncation error ~h², rounding ~eps/h.
const FD_STEP: f64 = 1e-6;

/// Minimises ‖r(θ)‖² with `bounds.lower ≤ θ ≤ bounds.upper`.
pub fn least_squares(problem: &impl Residuals, bounds: &Bounds) -> Result<Minimum, CalibrationError> {
    let dim = bounds.dim();
    let in_box = |u: &DVector<f64>| problem.residuals(&bounds.from_unit(u));
    let mut starts = vec![DVector::from_element(dim, 0.5)];
    let plan = latin_hypercube(EXTRA_STARTS, dim, 0);
    starts.extend(plan.row_iter().map(|row| row.transpose()));

    let first = in_box(&starts[0]);
    if first.iter().any(|v| !v.is_finite()) {
        return Err(CalibrationError::NonFinite(format!(
            "θ = {}",
            bounds.from_unit(&starts[0]).transpose()
        )));
    }
    let best = starts
        .iter()
        .map(|u0| levenberg_marquardt(&in_box, u0.clone()))
        .min_by(|a, b| a.cost.total_cmp(&b.cost))
        .expect("at least one start");
    Ok(Minimum {
        theta: bounds.from_unit(&best.theta),
        cost: best.cost,
    })
}

/// [`least_squares`] from one start `theta0` inside the box: a warm start, for a refit of a problem
/// whose minimum is known to be near (a model with one more term, or one design fewer).
pub fn least_squares_from(
    problem: &impl Residuals,
    bounds: &Bounds,
    theta0: &DVector<f64>,
) -> Result<Minimum, CalibrationError> {
    let in_box = |u: &DVector<f64>| problem.residuals(&bounds.from_unit(u));
    let u0 = bounds.to_unit(theta0).map(|v| v.clamp(0.0, 1.0));
    if in_box(&u0).iter().any(|v| !v.is_finite()) {
        return Err(CalibrationError::NonFinite(format!("θ = {}", theta0.transpose())));
    }
    let best = levenberg_marquardt(&in_box, u0);
    Ok(Minimum {
        theta: bounds.from_unit(&best.theta),
        cost: best.cost,
    })
}

/// Levenberg–Marquardt in the unit cube from `u`, with projected steps.
fn levenberg_marquardt(r: &impl Fn(&DVector<f64>) -> DVector<f64>, mut u: DVector<f64>) -> Minimum {
    let mut res = r(&u);
    let mut cost = res.norm_squared();
    let mut damping = 1e-3;
    for _ in 0..MAX_ITERATIONS {
        if !cost.is_finite() || cost == 0.0 {
            break;
        }
        let jac = jacobian_around(r, &u, res.len());
        let jtj = jac.transpose() * &jac;
        let gradient = jac.transpose() * &res;
        let mut improved = false;
        while damping < 1e12 {
            let Some(step) = damped_step(&jtj, &gradient, damping) else {
                damping *= 4.0;
                continue;
            };
            let trial = (&u + step).map(|v| v.clamp(0.0, 1.0));
            let trial_res = r(&trial);
            let trial_cost = trial_res.norm_squared();
            if trial_cost.is_finite() && trial_cost < cost {
                let converged = (cost - trial_cost) <= 1e-15 * cost || (&trial - &u).amax() < 1e-13;
                (u, res, cost) = (trial, trial_res, trial_cost);
                damping = (damping / 3.0).max(1e-12);
                improved = !converged;
                break;
            }
            damping *= 4.0;
        }
        if !improved {
            break;
        }
    }
    Minimum { theta: u, cost }
}

/// Solves (JᵀJ + λ·diag(JᵀJ)) δ = −Jᵀr. Marquardt's diagonal scaling, floored so a parameter the
/// residuals do not see still gets a finite, damped step.
fn damped_step(jtj: &DMatrix<f64>, gradient: &DVector<f64>, damping: f64) -> Option<DVector<f64>> {
    let floor = 1e-12 * jtj.diagonal().amax().max(f64::MIN_POSITIVE);
    let mut a = jtj.clone();
    for i in 0..a.nrows() {
        a[(i, i)] += damping * jtj[(i, i)].max(floor);
    }
    a.cholesky().map(|c| -c.solve(gradient))
}

/// Central-difference Jacobian of `r` at `u`, one-sided at the box faces.
pub fn jacobian(r: &impl Fn(&DVector<f64>) -> DVector<f64>, u: &DVector<f64>) -> DMatrix<f64> {
    jacobian_around(r, u, r(u).len())
}

/// [`jacobian`] for a caller that knows how many residuals `r` returns (central differences do
/// not need r(u) itself).
fn jacobian_around(r: &impl Fn(&DVector<f64>) -> DVector<f64>, u: &DVector<f64>, rows: usize) -> DMatrix<f64> {
    let mut jac = DMatrix::zeros(rows, u.len());
    for j in 0..u.len() {
        let (mut up, mut down) = (u.clone(), u.clone());
        up[j] = (u[j] + FD_STEP).min(1.0);
        down[j] = (u[j] - FD_STEP).max(0.0);
        let column = (r(&up) - r(&down)) / (up[j] - down[j]);
        jac.set_column(j, &column);
    }
    jac
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_an_interior_minimum_of_a_curved_problem() {
        // Rosenbrock as residuals: minimum at (1, 1).
        let rosen = |x: &DVector<f64>| DVector::from_vec(vec![10.0 * (x[1] - x[0] * x[0]), 1.0 - x[0]]);
        let m = least_squares(&rosen, &Bounds::new(vec![-2.0, -1.0], vec![2.0, 3.0])).unwrap();
        assert!(
            (m.theta[0] - 1.0).abs() < 1e-8 && (m.theta[1] - 1.0).abs() < 1e-8,
            "{}",
            m.theta
        );
    }

    #[test]
    fn stops_at_the_bound_when_the_minimum_is_outside() {
        let r = |x: &DVector<f64>| DVector::from_vec(vec![x[0] - 5.0]);
        let m = least_squares(&r, &Bounds::new(vec![0.0], vec![2.0])).unwrap();
        assert_eq!(m.theta[0], 2.0);
    }

    #[test]
    fn non_finite_model_is_an_error_not_a_panic() {
        let r = |_: &DVector<f64>| DVector::from_vec(vec![f64::NAN]);
        assert!(least_squares(&r, &Bounds::new(vec![0.0], vec![1.0])).is_err());
    }
}
