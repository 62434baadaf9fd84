//! Small wrappers around argmin's Nelder–Mead and Brent solvers for closures on the unit box.
//!
//! Every cost here is finite by construction (failures map to a large penalty), because argmin's
//! Nelder–Mead unwraps its first cost evaluations.

use argmin::core::{CostFunction, Error, Executor, State};
use argmin::solver::brent::BrentOpt;
use argmin::solver::neldermead::NelderMead;

/// Cost of a point that could not be evaluated (failed factorisation, non-finite value).
pub const FAILED: f64 = 1e30;

struct BoxCost<'a> {
    f: &'a dyn Fn(&[f64]) -> f64,
}

impl CostFunction for BoxCost<'_> {
    type Param = Vec<f64>;
    type Output = f64;

    /// Outside `[0, 1]^n` the cost is the value at the clamped point plus a steep penalty, so the
    /// simplex walks back in without ever evaluating the model out of bounds.
    fn cost(&self, x: &Vec<f64>) -> Result<f64, Error> {
        let clamped: Vec<f64> = x.iter().map(|v| v.clamp(0.0, 1.0)).collect();
        let excess: f64 = x.iter().zip(&clamped).map(|(a, b)| (a - b).powi(2)).sum();
        Ok(finite_or_failed((self.f)(&clamped)) + 1e6 * excess)
    }
}

fn finite_or_failed(v: f64) -> f64 {
    if v.is_finite() { v.min(FAILED) } else { FAILED }
}

/// Minimises `f` over `[0, 1]^n` by Nelder–Mead from `start`; returns the clamped best point and cost.
pub fn nelder_mead(f: &dyn Fn(&[f64]) -> f64, start: &[f64], step: f64, max_iters: u64) -> (Vec<f64>, f64) {
    let start: Vec<f64> = start.iter().map(|v| v.clamp(0.0, 1.0)).collect();
    let mut simplex = vec![start.clone()];
    for i in 0..start.len() {
        let mut p = start.clone();
        // Step inwards so that every vertex starts inside the box.
        p[i] += if p[i] + step <= 1.0 { step } else { -step };
        simplex.push(p);
    }
    let fallback = (start.clone(), finite_or_failed(f(&start)));
    let Ok(solver) = NelderMead::new(simplex).with_sd_tolerance(1e-10) else {
        return fallback;
    };
    let run = Executor::new(BoxCost { f }, solver)
        .configure(|s| s.max_iters(max_iters))
        .run();
    match run {
        Ok(res) => match res.state().get_best_param() {
            Some(p) => {
                let p: Vec<f64> = p.iter().map(|v| v.clamp(0.0, 1.0)).collect();
                let c = finite_or_failed(f(&p));
                if c <= fallback.1 { (p, c) } else { fallback }
            }
            None => fallback,
        },
        Err(_) => fallback,
    }
}

struct LineCost<'a> {
    f: &'a dyn Fn(f64) -> f64,
}

impl CostFunction for LineCost<'_> {
    type Param = f64;
    type Output = f64;

    fn cost(&self, x: &f64) -> Result<f64, Error> {
        Ok(finite_or_failed((self.f)(*x)))
    }
}

/// Minimises `f` on `[lo, hi]`: a coarse grid first (Brent alone finds only a local minimum), then
/// Brent's method in the bracket around the best grid point. Returns the best point and cost.
pub fn line_search(f: &dyn Fn(f64) -> f64, lo: f64, hi: f64, grid: usize) -> (f64, f64) {
    let grid = grid.max(2);
    let h = (hi - lo) / (grid - 1) as f64;
    let (mut best_x, mut best_c) = (lo, f64::INFINITY);
    for i in 0..grid {
        let x = lo + h * i as f64;
        let c = finite_or_failed(f(x));
        if c < best_c {
            (best_x, best_c) = (x, c);
        }
    }
    let (a, b) = ((best_x - h).max(lo), (best_x + h).min(hi));
    let solver = BrentOpt::new(a, b).set_tolerance(1e-10, 1e-12);
    if let Ok(res) = Executor::new(LineCost { f }, solver)
        .configure(|s| s.max_iters(200))
        .run()
        && let Some(&x) = res.state().get_best_param()
    {
        let c = finite_or_failed(f(x));
        if c < best_c {
            return (x, c);
        }
    }
    (best_x, best_c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nelder_mead_finds_interior_minimum() {
        let f = |x: &[f64]| (x[0] - 0.3).powi(2) + 2.0 * (x[1] - 0.7).powi(2);
        let (x, c) = nelder_mead(&f, &[0.5, 0.5], 0.1, 500);
        assert!((x[0] - 0.3).abs() < 1e-4 && (x[1] - 0.7).abs() < 1e-4, "{x:?}");
        assert!(c < 1e-8);
    }

    #[test]
    fn nelder_mead_stays_in_box() {
        let f = |x: &[f64]| x[0] + x[1];
        let (x, _) = nelder_mead(&f, &[0.5, 0.5], 0.1, 500);
        assert!(x.iter().all(|v| (0.0..=1.0).contains(v)) && x[0] < 1e-3, "{x:?}");
    }

    #[test]
    fn line_search_finds_global_of_two_minima() {
        // Local minimum near 0.2 (value 0.1), global near 0.8 (value 0).
        let f = |x: f64| ((x - 0.2).powi(2) + 0.1).min((x - 0.8).powi(2) * 4.0);
        let (x, _) = line_search(&f, 0.0, 1.0, 21);
        assert!((x - 0.8).abs() < 1e-5, "{x}");
    }
}
