//! Bounded nonlinear least squares: minimise ‖r(θ)‖² over a box.
//!
//! Both Eq. 3 (least squares) and Eq. 6 (sensitivity) are sums of squared residuals, so both use
//! this one solver: Levenberg–Marquardt on parameters scaled to the unit cube, steps projected
//! back into the box, Jacobian by central differences, a few starts (centre plus a Latin
//! hypercube) to avoid a poor local minimum. The damping keeps the step well defined when the
//! residuals cannot tell parameters apart (Table 1's valley along L³/E).

use nalgebra::{DMatrix, DVector};

use super::{Bounds, CalibrationError, latin_hypercube};

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
///
/// The damping follows the gain ratio ρ of actual to predicted decrease (Nielsen 1999; Madsen,
/// Nielsen & Tingleff 2004, §3.2), not merely whether the cost fell: where the residuals
/// at the minimum are large, Gauss–Newton's step overshoots it (JᵀJ misses Σ rᵢ∇²rᵢ) and the cost
/// falls by little each time, which a success-only rule would accept with ever less damping.
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
        let held = held_on_faces(&u, &gradient);
        let mut improved = false;
        while damping < 1e12 {
            let Some(step) = damped_step(&jtj, &gradient, damping, &held) else {
                damping *= 4.0;
                continue;
            };
            let trial = (&u + step).map(|v| v.clamp(0.0, 1.0));
            let trial_res = r(&trial);
            let trial_cost = trial_res.norm_squared();
            if trial_cost.is_finite() && trial_cost < cost {
                let h = &trial - &u;
                let predicted = -(2.0 * h.dot(&gradient) + h.dot(&(&jtj * &h)));
                let gain = if predicted > 0.0 {
                    (cost - trial_cost) / predicted
                } else {
                    0.0
                };
                let converged = (cost - trial_cost) <= 1e-15 * cost || h.amax() < 1e-13;
                (u, res, cost) = (trial, trial_res, trial_cost);
                damping = (damping * (1.0 / 3.0f64).max(1.0 - (2.0 * gain - 1.0).powi(3))).max(1e-12);
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

/// The coordinates on a face of the cube that the descent direction −Jᵀr pushes out of it: at
/// such a face the bound is active (its Karush–Kuhn–Tucker multiplier is positive), so the step
/// leaves the coordinate where it is. A step of every coordinate, clamped afterwards, would
/// instead point partly out of the box and crawl along the face (the projected Newton method of
/// Bertsekas 1982, SIAM J. Control Optim. 20:221).
fn held_on_faces(u: &DVector<f64>, gradient: &DVector<f64>) -> Vec<bool> {
    u.iter()
        .zip(gradient.iter())
        .map(|(&u, &g)| (u <= 0.0 && g > 0.0) || (u >= 1.0 && g < 0.0))
        .collect()
}

/// Solves (JᵀJ + λ·diag(JᵀJ)) δ = −Jᵀr over the coordinates not `held` (their δ is 0).
/// Marquardt's diagonal scaling, floored so a parameter the residuals do not see still gets a
/// finite, damped step.
fn damped_step(jtj: &DMatrix<f64>, gradient: &DVector<f64>, damping: f64, held: &[bool]) -> Option<DVector<f64>> {
    let floor = 1e-12 * jtj.diagonal().amax().max(f64::MIN_POSITIVE);
    let mut a = jtj.clone();
    let mut g = gradient.clone();
    for i in 0..a.nrows() {
        a[(i, i)] += damping * jtj[(i, i)].max(floor);
    }
    for i in (0..a.nrows()).filter(|&i| held[i]) {
        a.row_mut(i).fill(0.0);
        a.column_mut(i).fill(0.0);
        a[(i, i)] = 1.0;
        g[i] = 0.0;
    }
    a.cholesky().map(|c| -c.solve(&g))
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

    /// A valley leaning out of the box (unconstrained minimum at (0.5, 1.5)): the box's minimum has
    /// x₁ on its upper bound and x₀ = 0.5 / (10⁴ + 1) inside. A step of both coordinates clamped to
    /// the box would crawl along the face; the step of the free coordinate alone gets there.
    #[test]
    fn a_minimum_on_a_face_is_reached_in_a_few_steps() {
        let calls = std::cell::Cell::new(0);
        let r = |x: &DVector<f64>| {
            calls.set(calls.get() + 1);
            DVector::from_vec(vec![100.0 * (x[1] - x[0] - 1.0), x[0] - 0.5])
        };
        let m = least_squares(&r, &Bounds::new(vec![0.0, 0.0], vec![1.0, 1.0])).unwrap();
        assert_eq!(m.theta[1], 1.0);
        assert!((m.theta[0] - 0.5 / 10_001.0).abs() < 1e-10, "{}", m.theta);
        // Five starts; a start converges in a handful of iterations of 2·2 + 1 evaluations each.
        assert!(calls.get() < 400, "{} residual evaluations", calls.get());
    }

    /// Madsen, Nielsen & Tingleff's (2004, §3.1) example of Gauss–Newton's slow convergence: r(x) = (x + 1, λx² + x − 1), minimum at
    /// x = 0 with ‖r‖² = 2 for λ < 1. Gauss–Newton's step there maps x to λx: with λ = −0.98 it
    /// overshoots to the other side and comes back, for hundreds of steps. Damping by the gain
    /// ratio shortens those steps.
    #[test]
    fn a_large_residual_minimum_is_reached_in_a_few_steps() {
        let calls = std::cell::Cell::new(0);
        let lambda = -0.98;
        let r = |x: &DVector<f64>| {
            calls.set(calls.get() + 1);
            DVector::from_vec(vec![x[0] + 1.0, lambda * x[0] * x[0] + x[0] - 1.0])
        };
        let m = least_squares(&r, &Bounds::new(vec![-1.3], vec![2.0])).unwrap();
        assert!(m.theta[0].abs() < 1e-7, "{}", m.theta);
        assert!((m.cost - 2.0).abs() < 1e-12, "{}", m.cost);
        // Zig-zagging, the five starts would spend their 500 iterations of at least 3 evaluations.
        assert!(calls.get() < 1000, "{} residual evaluations", calls.get());
    }

    #[test]
    fn non_finite_model_is_an_error_not_a_panic() {
        let r = |_: &DVector<f64>| DVector::from_vec(vec![f64::NAN]);
        assert!(least_squares(&r, &Bounds::new(vec![0.0], vec![1.0])).is_err());
    }
}
