//! Affine-invariant ensemble sampler (Goodman & Weare 2010 stretch move, as in emcee).
//!
//! Chosen over a random walk because the KOH posterior is strongly curved: θ is tight when σ_d² is
//! small and wide when it is large, which a fixed-step random walk cannot follow.

use rand::{Rng, SeedableRng};
use rayon::prelude::*;

use super::convergence::{self, Convergence};
use rand_chacha::ChaCha8Rng;

/// Stretch scale `a` of the proposal `z ~ g(z) ∝ 1/√z` on `[1/a, a]` (the usual choice).
const STRETCH: f64 = 2.0;

/// Samples of a run, step-major: `samples[s * walkers + w]`, after burn-in.
pub struct Chain {
    pub samples: Vec<Vec<f64>>,
    pub acceptance: f64,
}

/// Runs `walkers` walkers for `steps` steps from a small cloud around `start` (inside the unit box,
/// reflected at its faces) and keeps the states after `burn_in` steps. `log_post` is −∞ where the
/// prior vanishes. Reproducible: the same seed gives the same chain.
pub fn stretch_sample(
    log_post: &(dyn Fn(&[f64]) -> f64 + Sync),
    start: &[f64],
    walkers: usize,
    steps: usize,
    burn_in: usize,
    seed: u64,
) -> Chain {
    let mut ensemble = Ensemble::new(log_post, start, walkers, seed);
    ensemble.advance(burn_in.min(steps), &mut |_| {});
    let mut samples = Vec::with_capacity(walkers * steps.saturating_sub(burn_in));
    ensemble.advance(steps.saturating_sub(burn_in), &mut |pos| {
        samples.extend(pos.iter().cloned())
    });
    Chain {
        samples,
        acceptance: ensemble.acceptance(),
    }
}

/// The state of an ensemble run, so that it can be continued batch by batch.
pub struct Ensemble<'a> {
    log_post: &'a (dyn Fn(&[f64]) -> f64 + Sync),
    pub pos: Vec<Vec<f64>>,
    lp: Vec<f64>,
    rng: ChaCha8Rng,
    accepted: usize,
    proposed: usize,
}

impl<'a> Ensemble<'a> {
    pub fn new(log_post: &'a (dyn Fn(&[f64]) -> f64 + Sync), start: &[f64], walkers: usize, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (pos, lp) = (0..walkers).map(|_| initial_walker(log_post, start, &mut rng)).unzip();
        Ensemble {
            log_post,
            pos,
            lp,
            rng,
            accepted: 0,
            proposed: 0,
        }
    }

    /// `steps` stretch-move sweeps over the walkers; `visit` sees the positions after each sweep.
    ///
    /// Each sweep moves one half of the ensemble against the other, then the other against the
    /// first (Foreman-Mackey et al. 2013, Alg. 3): within a half the moves are independent, so
    /// their densities are evaluated in parallel. The random numbers are drawn in order before,
    /// so the chain does not depend on the number of threads.
    pub fn advance(&mut self, steps: usize, visit: &mut dyn FnMut(&[Vec<f64>])) {
        let walkers = self.pos.len();
        let half = walkers / 2;
        for _ in 0..steps {
            self.move_half(0..half, half..walkers);
            self.move_half(half..walkers, 0..half);
            self.proposed += walkers;
            visit(&self.pos);
        }
    }

    /// Stretch moves of the walkers in `active`, each towards a partner drawn from `others`.
    fn move_half(&mut self, active: std::ops::Range<usize>, others: std::ops::Range<usize>) {
        let dim = self.pos.first().map_or(0, Vec::len);
        let proposals: Vec<(usize, Vec<f64>, f64, f64)> = active
            .map(|k| {
                let j = others.start + self.rng.random_range(0..others.len());
                let z = ((STRETCH - 1.0) * self.rng.random::<f64>() + 1.0).powi(2) / STRETCH;
                let y = (0..dim)
                    .map(|i| self.pos[j][i] + z * (self.pos[k][i] - self.pos[j][i]))
                    .collect();
                (k, y, z, self.rng.random::<f64>().ln())
            })
            .collect();
        let log_post = self.log_post;
        let densities: Vec<f64> = proposals.par_iter().map(|(_, y, _, _)| log_post(y)).collect();
        for ((k, y, z, log_u), ly) in proposals.into_iter().zip(densities) {
            let log_ratio = (dim as f64 - 1.0) * z.ln() + ly - self.lp[k];
            if ly.is_finite() && log_u < log_ratio {
                self.pos[k] = y;
                self.lp[k] = ly;
                self.accepted += 1;
            }
        }
    }

    /// Fraction of accepted stretch moves so far.
    pub fn acceptance(&self) -> f64 {
        self.accepted as f64 / self.proposed.max(1) as f64
    }
}

/// What [`sample_until_converged`] returns: per walker the projected trace of the kept half.
pub struct Converged {
    /// `traces[w][s]`: walker w's projected state at kept step s.
    pub traces: Vec<Vec<Vec<f64>>>,
    pub convergence: Vec<Convergence>,
    pub acceptance: f64,
    /// Steps run after burn-in (twice the kept steps, give or take one).
    pub steps: usize,
}

/// Runs the ensemble for `burn_in` steps, then `first` steps, then doubles the run until every
/// coordinate of `project` (the quantities of interest, e.g. θ of (θ, hyperparameters)) has split
/// R-hat ≤ 1.01 and ESS ≥ 1000 over the last half of the draws (the first half counts as warm-up,
/// BDA3 §11.4), or until `budget` steps after burn-in. The last half is kept either way.
pub fn sample_until_converged(
    log_post: &(dyn Fn(&[f64]) -> f64 + Sync),
    start: &[f64],
    walkers: usize,
    (burn_in, first, budget): (usize, usize, usize),
    seed: u64,
    project: &dyn Fn(&[f64]) -> Vec<f64>,
) -> Converged {
    let mut ensemble = Ensemble::new(log_post, start, walkers, seed);
    ensemble.advance(burn_in, &mut |_| {});
    let mut traces: Vec<Vec<Vec<f64>>> = vec![Vec::new(); walkers];
    let mut batch = first.max(8).min(budget.max(8));
    loop {
        ensemble.advance(batch, &mut |pos| {
            for (t, u) in traces.iter_mut().zip(pos) {
                t.push(project(u));
            }
        });
        let done = traces[0].len();
        let convergence = diagnose_last_half(&traces);
        if convergence.iter().all(Convergence::converged) || done >= budget {
            let traces = traces.into_iter().map(|t| t[done / 2..].to_vec()).collect();
            return Converged {
                traces,
                convergence,
                acceptance: ensemble.acceptance(),
                steps: done,
            };
        }
        batch = done.min(budget - done);
    }
}

/// Split R-hat and ESS per coordinate over the last half of each walker's trace.
fn diagnose_last_half(traces: &[Vec<Vec<f64>>]) -> Vec<Convergence> {
    let len = traces.first().map_or(0, Vec::len);
    let p = traces.first().and_then(|t| t.first()).map_or(0, Vec::len);
    (0..p)
        .map(|k| {
            let chains: Vec<Vec<f64>> = traces
                .iter()
                .map(|t| t[len / 2..].iter().map(|v| v[k]).collect())
                .collect();
            convergence::diagnose(&chains)
        })
        .collect()
}

/// A point within ±0.02 of `start` (reflected into the unit box) with finite posterior; the
/// start itself if ten tries fail.
fn initial_walker(log_post: &dyn Fn(&[f64]) -> f64, start: &[f64], rng: &mut ChaCha8Rng) -> (Vec<f64>, f64) {
    for _ in 0..10 {
        let x: Vec<f64> = start
            .iter()
            .map(|&s| reflect(s + 0.04 * (rng.random::<f64>() - 0.5)))
            .collect();
        let l = log_post(&x);
        if l.is_finite() {
            return (x, l);
        }
    }
    (start.to_vec(), log_post(start))
}

fn reflect(x: f64) -> f64 {
    let x = x.abs();
    if x > 1.0 { (2.0 - x).max(0.0) } else { x }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_until_converged_on_a_gaussian() {
        // A correlated 3-D Gaussian in the unit box: the run must extend past its first 200 steps
        // until R-hat ≤ 1.01 and ESS ≥ 1000 hold for every coordinate, and the kept draws then
        // give the mean to ~3 sd / √ESS.
        let (s, rho) = (0.05f64, 0.8f64);
        let lp = |x: &[f64]| {
            let d: Vec<f64> = x.iter().map(|v| (v - 0.5) / s).collect();
            let q = d[0] * d[0] - 2.0 * rho * d[0] * d[1] + d[1] * d[1];
            -q / (2.0 * (1.0 - rho * rho)) - d[2] * d[2] / 2.0
        };
        let run = sample_until_converged(&lp, &[0.5; 3], 16, (200, 200, 50_000), 3, &|u| u.to_vec());
        assert!(run.steps > 200 && run.steps < 50_000, "{} steps", run.steps);
        for (k, c) in run.convergence.iter().enumerate() {
            assert!(c.split_rhat <= 1.01 && c.ess >= 1000.0, "{k}: {c:?}");
            let draws: Vec<f64> = run.traces.iter().flat_map(|t| t.iter().map(|v| v[k])).collect();
            let mean = draws.iter().sum::<f64>() / draws.len() as f64;
            assert!((mean - 0.5).abs() < 3.0 * s / c.ess.sqrt(), "{k}: mean {mean}");
        }
    }

    #[test]
    fn budget_ends_the_run_unconverged() {
        let lp = |x: &[f64]| -x.iter().map(|v| ((v - 0.5) / 0.05).powi(2)).sum::<f64>() / 2.0;
        let run = sample_until_converged(&lp, &[0.5; 3], 16, (0, 40, 40), 3, &|u| u.to_vec());
        assert_eq!(run.steps, 40);
        assert!(run.convergence.iter().any(|c| !c.converged()));
    }

    #[test]
    fn samples_a_correlated_gaussian() {
        // N(0.5, Σ) with strong correlation, well inside the unit box: mean and variance to ~10 %.
        let (s1, s2, rho) = (0.05f64, 0.1f64, 0.9f64);
        let lp = |x: &[f64]| {
            let (a, b) = ((x[0] - 0.5) / s1, (x[1] - 0.5) / s2);
            -(a * a - 2.0 * rho * a * b + b * b) / (2.0 * (1.0 - rho * rho))
        };
        let chain = stretch_sample(&lp, &[0.5, 0.5], 16, 3000, 500, 7);
        let n = chain.samples.len() as f64;
        let m1 = chain.samples.iter().map(|x| x[1]).sum::<f64>() / n;
        let v1 = chain.samples.iter().map(|x| (x[1] - m1).powi(2)).sum::<f64>() / n;
        assert!((m1 - 0.5).abs() < 0.02, "mean {m1}");
        assert!((v1.sqrt() / s2 - 1.0).abs() < 0.15, "sd {}", v1.sqrt());
        assert!(chain.acceptance > 0.2 && chain.acceptance < 0.9, "{}", chain.acceptance);
    }
}
