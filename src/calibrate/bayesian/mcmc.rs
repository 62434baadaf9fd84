//! Ensemble slice sampler (Karamanis & Beutler 2021, "Ensemble slice sampling", Stat. Comput. 31:61,
//! Algorithms 2–3: the differential move, as in zeus).
//!
//! Each walker takes a slice-sampling step (Neal 2003) along the difference of two walkers of the
//! other half of the ensemble, scaled by μ. The direction follows the ensemble's shape, so linear
//! correlations cost nothing (affine invariance, as the stretch move of emcee), and the slice adapts
//! the step length to the local width, so a curved ridge, where a fixed-scale proposal is mostly
//! rejected, is crossed in a few steps. No move is ever rejected; the price is a variable number of
//! density evaluations per step (step-out and shrinkage). μ is tuned during burn-in only (Robbins–Monro
//! towards as many expansions as contractions, KB21 §4.3), then fixed, so the kept chain is a proper
//! Markov chain.
//!
//! The same ensemble can instead move by independence Metropolis–Hastings from a fixed proposal
//! ([`Ensemble::with_proposal`]): one density evaluation per move, used once a pilot's draws have
//! given a proposal close to the posterior ([`super::proposal`]).

use rand::{Rng, SeedableRng};
use rayon::prelude::*;

use super::convergence::{self, Convergence};
use super::proposal::Proposal;
use rand_chacha::ChaCha8Rng;

/// Most interval expansions on either side of one slice (KB21 cap a runaway step-out; in lab the
/// density is −∞ outside the unit box, so the cap is only a guard).
const MAX_EXPANSIONS: usize = 1000;
/// Most shrinkages of one slice before the walker stays put (a guard against a density that is
/// not finite where it should be; the current point always lies in the slice).
const MAX_SHRINKS: usize = 200;

/// The state of an ensemble run, so that it can be continued batch by batch.
pub struct Ensemble<'a> {
    log_post: &'a (dyn Fn(&[f64]) -> f64 + Sync),
    pub pos: Vec<Vec<f64>>,
    lp: Vec<f64>,
    rng: ChaCha8Rng,
    /// Scale of the differential direction.
    mu: f64,
    /// Whether `mu` is still being tuned.
    pub tuning: bool,
    /// When set, walkers move by independence Metropolis–Hastings instead of slice steps.
    independence: Option<Independence>,
    evaluations: usize,
    moves: usize,
    accepted: usize,
}

/// The independence kernel: the proposal and ln q at every walker's position (kept with the
/// position, so the Metropolis–Hastings ratio costs one evaluation of q per move, not two).
struct Independence {
    q: Proposal,
    lq: Vec<f64>,
}

/// What one walker's slice step did.
struct SliceStep {
    x: Vec<f64>,
    lp: f64,
    expansions: usize,
    contractions: usize,
    evaluations: usize,
}

impl<'a> Ensemble<'a> {
    /// Walkers in a small cloud around `start`.
    pub fn new(log_post: &'a (dyn Fn(&[f64]) -> f64 + Sync), start: &[f64], walkers: usize, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (pos, lp) = (0..walkers).map(|_| initial_walker(log_post, start, &mut rng)).unzip();
        Self::at(log_post, pos, lp, rng)
    }

    /// Walkers at the given positions (e.g. a pilot's last, mapped to new coordinates).
    pub fn from_positions(log_post: &'a (dyn Fn(&[f64]) -> f64 + Sync), pos: Vec<Vec<f64>>, seed: u64) -> Self {
        let lp = pos.iter().map(|x| log_post(x)).collect();
        Self::at(log_post, pos, lp, ChaCha8Rng::seed_from_u64(seed))
    }

    fn at(log_post: &'a (dyn Fn(&[f64]) -> f64 + Sync), pos: Vec<Vec<f64>>, lp: Vec<f64>, rng: ChaCha8Rng) -> Self {
        let walkers = pos.len();
        Ensemble {
            log_post,
            pos,
            lp,
            rng,
            mu: 1.0,
            tuning: true,
            independence: None,
            evaluations: walkers,
            moves: 0,
            accepted: 0,
        }
    }

    /// The same ensemble moving by independence Metropolis–Hastings from `q` (a fixed
    /// kernel: nothing is tuned): a walker at x proposes x' ~ q and moves there with probability
    /// min(1, p(x') q(x) / (p(x) q(x'))) (Tierney 1994). Walkers move independently, all in parallel.
    pub fn with_proposal(mut self, q: Proposal) -> Self {
        let lq = self.pos.iter().map(|x| q.log_density(x)).collect();
        self.independence = Some(Independence { q, lq });
        self.tuning = false;
        self
    }

    /// `steps` sweeps over the walkers; `visit` sees the positions after each sweep.
    ///
    /// Each sweep moves one half of the ensemble along directions drawn from the other half, then
    /// the other half (KB21 Alg. 3 with Foreman-Mackey et al. 2013's split): within a half the moves
    /// are independent, so they run in parallel. Each walker's random stream is seeded from the
    /// ensemble's in order, so the chain does not depend on the number of threads.
    pub fn advance(&mut self, steps: usize, visit: &mut dyn FnMut(&[Vec<f64>])) {
        let walkers = self.pos.len();
        let half = walkers / 2;
        for _ in 0..steps {
            if self.independence.is_some() {
                self.independence_step();
                visit(&self.pos);
                continue;
            }
            let (e1, c1) = self.move_half(0..half, half..walkers);
            let (e2, c2) = self.move_half(half..walkers, 0..half);
            if self.tuning {
                // KB21 Eq. 19: μ ← 2μ N_e / (N_e + N_c), N_e at least 1 so that μ can shrink.
                let (e, c) = ((e1 + e2).max(1) as f64, (c1 + c2) as f64);
                self.mu *= 2.0 * e / (e + c);
            }
            visit(&self.pos);
        }
    }

    /// Slice steps of the walkers in `active` along differences of two walkers of `others`;
    /// returns the expansions and contractions made.
    fn move_half(&mut self, active: std::ops::Range<usize>, others: std::ops::Range<usize>) -> (usize, usize) {
        let plans: Vec<(usize, Vec<f64>, u64)> = active
            .map(|k| {
                let (j, l) = two_distinct(&mut self.rng, others.clone());
                let eta = self.pos[j]
                    .iter()
                    .zip(&self.pos[l])
                    .map(|(a, b)| self.mu * (a - b))
                    .collect();
                (k, eta, self.rng.random::<u64>())
            })
            .collect();
        let log_post = self.log_post;
        let steps: Vec<(usize, SliceStep)> = plans
            .into_par_iter()
            .map(|(k, eta, seed)| {
                let mut rng = ChaCha8Rng::seed_from_u64(seed);
                (k, slice_step(log_post, &self.pos[k], self.lp[k], &eta, &mut rng))
            })
            .collect();
        let (mut expansions, mut contractions) = (0, 0);
        for (k, step) in steps {
            expansions += step.expansions;
            contractions += step.contractions;
            self.evaluations += step.evaluations;
            self.moves += 1;
            self.pos[k] = step.x;
            self.lp[k] = step.lp;
        }
        (expansions, contractions)
    }

    /// One independence Metropolis–Hastings move of every walker (the proposal draws inside the
    /// unit box only, so every move costs one density evaluation).
    fn independence_step(&mut self) {
        let Some(ind) = self.independence.as_mut() else {
            return;
        };
        let plans: Vec<(Vec<f64>, f64)> = (0..self.pos.len())
            .map(|_| {
                (
                    ind.q.sample(&mut self.rng),
                    self.rng.random_range(f64::EPSILON..1.0f64).ln(),
                )
            })
            .collect();
        let (log_post, q) = (self.log_post, &ind.q);
        let densities: Vec<(f64, f64)> = plans.par_iter().map(|(y, _)| (log_post(y), q.log_density(y))).collect();
        for (k, ((y, log_u), (ly, lqy))) in plans.into_iter().zip(densities).enumerate() {
            self.moves += 1;
            self.evaluations += 1;
            if log_u < (ly - lqy) - (self.lp[k] - ind.lq[k]) {
                self.pos[k] = y;
                self.lp[k] = ly;
                ind.lq[k] = lqy;
                self.accepted += 1;
            }
        }
    }

    /// Share of independence proposals accepted so far (NaN before any).
    pub fn acceptance(&self) -> f64 {
        if self.independence.is_none() {
            return f64::NAN;
        }
        self.accepted as f64 / self.moves.max(1) as f64
    }

    /// Density evaluations per walker move so far (the slice's cost; about 4–6 when μ is tuned).
    pub fn evaluations_per_move(&self) -> f64 {
        self.evaluations as f64 / self.moves.max(1) as f64
    }
}

/// Two different indices from `range` (which has at least two).
fn two_distinct(rng: &mut ChaCha8Rng, range: std::ops::Range<usize>) -> (usize, usize) {
    let n = range.len();
    let j = rng.random_range(0..n);
    let l = (j + 1 + rng.random_range(0..n - 1)) % n;
    (range.start + j, range.start + l)
}

/// One slice-sampling step from `x` along `eta` (KB21 Alg. 2: Neal's step-out and shrinkage on the
/// line x + s·η): the slice level ln y = ln p(x) − Exp(1), an interval of unit length placed at
/// random around s = 0, stepped out until both ends leave the slice, then sampled uniformly with
/// the interval shrunk towards 0 at every rejected point.
fn slice_step(
    log_post: &(dyn Fn(&[f64]) -> f64 + Sync),
    x: &[f64],
    lp: f64,
    eta: &[f64],
    rng: &mut ChaCha8Rng,
) -> SliceStep {
    let at = |s: f64| -> Vec<f64> { x.iter().zip(eta).map(|(a, e)| a + s * e).collect() };
    let level = lp + rng.random_range(f64::EPSILON..1.0f64).ln();
    let mut left = -rng.random::<f64>();
    let mut right = left + 1.0;
    // Moves `end` by `by` until it leaves the slice; the expansions made (each end costs one
    // density evaluation more than its expansions).
    let step_out = |end: &mut f64, by: f64| {
        let mut expansions = 0;
        while expansions < MAX_EXPANSIONS && level < log_post(&at(*end)) {
            *end += by;
            expansions += 1;
        }
        expansions
    };
    let expansions = step_out(&mut left, -1.0) + step_out(&mut right, 1.0);
    let (mut contractions, mut evaluations) = (0, expansions + 2);
    for _ in 0..MAX_SHRINKS {
        let s = left + rng.random::<f64>() * (right - left);
        let y = at(s);
        let ly = log_post(&y);
        evaluations += 1;
        if level < ly {
            return SliceStep {
                x: y,
                lp: ly,
                expansions,
                contractions,
                evaluations,
            };
        }
        if s < 0.0 {
            left = s
        } else {
            right = s
        }
        contractions += 1;
    }
    SliceStep {
        x: x.to_vec(),
        lp,
        expansions,
        contractions,
        evaluations,
    }
}

/// What [`sample_until_converged`] returns: per walker the projected trace after burn-in.
pub struct Converged {
    /// `traces[w][s]`: walker w's projected state at step s after burn-in.
    pub traces: Vec<Vec<Vec<f64>>>,
    pub convergence: Vec<Convergence>,
    /// Density evaluations per walker move, burn-in included.
    pub evaluations_per_move: f64,
    /// Share of independence proposals accepted (NaN for slice steps).
    pub acceptance: f64,
    /// Steps run after burn-in.
    pub steps: usize,
    /// Density evaluations, burn-in included.
    pub evaluations: usize,
}

/// Runs the ensemble for `burn_in` steps (tuning μ of slice steps), then `first` steps, then
/// extends the run by a quarter until every coordinate of `project` (the quantities of interest) has
/// split R-hat ≤ 1.01 and ESS ≥ 1000 over the draws after burn-in, or until `budget` steps after
/// burn-in. Split R-hat compares the halves of every chain, so a chain still drifting from its
/// start fails it (Vehtari et al. 2021 §4); the caller's burn-in is what it was not asked to judge.
pub fn sample_until_converged(
    mut ensemble: Ensemble,
    (burn_in, first, budget): (usize, usize, usize),
    project: &dyn Fn(&[f64]) -> Vec<f64>,
) -> Converged {
    let walkers = ensemble.pos.len();
    ensemble.advance(burn_in, &mut |_| {});
    ensemble.tuning = false;
    let mut traces: Vec<Vec<Vec<f64>>> = vec![Vec::new(); walkers];
    let mut batch = first.max(8).min(budget.max(8));
    loop {
        ensemble.advance(batch, &mut |pos| {
            for (t, u) in traces.iter_mut().zip(pos) {
                t.push(project(u));
            }
        });
        let done = traces[0].len();
        let convergence = diagnose(&traces);
        if convergence.iter().all(Convergence::converged) || done >= budget {
            return Converged {
                traces,
                convergence,
                evaluations_per_move: ensemble.evaluations_per_move(),
                acceptance: ensemble.acceptance(),
                steps: done,
                evaluations: ensemble.evaluations,
            };
        }
        batch = (done / 4).max(8).min(budget - done);
    }
}

/// What [`pilot`] returns.
pub struct Pilot {
    /// The positions of the second half of the steps, walker after walker.
    pub draws: Vec<Vec<f64>>,
    /// The last positions.
    pub last: Vec<Vec<f64>>,
    /// Density evaluations.
    pub evaluations: usize,
}

/// Runs `steps` steps (tuning μ of slice steps) and keeps the second half's positions.
pub fn pilot(mut ensemble: Ensemble, steps: usize) -> Pilot {
    let mut draws = Vec::new();
    let mut step = 0;
    ensemble.advance(steps, &mut |pos| {
        step += 1;
        if 2 * step > steps {
            draws.extend(pos.iter().cloned());
        }
    });
    Pilot {
        draws,
        last: ensemble.pos,
        evaluations: ensemble.evaluations,
    }
}

/// Split R-hat and ESS per coordinate over the walkers' traces.
fn diagnose(traces: &[Vec<Vec<f64>>]) -> Vec<Convergence> {
    let p = traces.first().and_then(|t| t.first()).map_or(0, Vec::len);
    (0..p)
        .map(|k| {
            let chains: Vec<Vec<f64>> = traces.iter().map(|t| t.iter().map(|v| v[k]).collect()).collect();
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

    fn in_box(x: &[f64]) -> bool {
        x.iter().all(|v| (0.0..=1.0).contains(v))
    }

    /// The kept draws of coordinate k, all walkers.
    fn draws(run: &Converged, k: usize) -> Vec<f64> {
        run.traces.iter().flat_map(|t| t.iter().map(move |v| v[k])).collect()
    }

    fn mean_sd(x: &[f64]) -> (f64, f64) {
        let n = x.len() as f64;
        let m = x.iter().sum::<f64>() / n;
        (m, (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt())
    }

    #[test]
    fn runs_until_converged_on_a_gaussian() {
        // A correlated 3-D Gaussian in the unit box: the run must extend past its first 20 steps
        // until R-hat ≤ 1.01 and ESS ≥ 1000 hold for every coordinate, and the kept draws then
        // give the mean to ~3 sd / √ESS.
        let (s, rho) = (0.05f64, 0.8f64);
        let lp = |x: &[f64]| {
            if !in_box(x) {
                return f64::NEG_INFINITY;
            }
            let d: Vec<f64> = x.iter().map(|v| (v - 0.5) / s).collect();
            let q = d[0] * d[0] - 2.0 * rho * d[0] * d[1] + d[1] * d[1];
            -q / (2.0 * (1.0 - rho * rho)) - d[2] * d[2] / 2.0
        };
        let run = sample_until_converged(Ensemble::new(&lp, &[0.5; 3], 16, 3), (50, 20, 50_000), &|u| u.to_vec());
        assert!(run.steps > 20 && run.steps < 50_000, "{} steps", run.steps);
        for (k, c) in run.convergence.iter().enumerate() {
            assert!(c.split_rhat <= 1.01 && c.ess >= 1000.0, "{k}: {c:?}");
            let (mean, _) = mean_sd(&draws(&run, k));
            assert!((mean - 0.5).abs() < 3.0 * s / c.ess.sqrt(), "{k}: mean {mean}");
        }
    }

    #[test]
    fn budget_ends_the_run_unconverged() {
        let lp = |x: &[f64]| -x.iter().map(|v| ((v - 0.5) / 0.05).powi(2)).sum::<f64>() / 2.0;
        let run = sample_until_converged(Ensemble::new(&lp, &[0.5; 3], 16, 3), (0, 10, 10), &|u| u.to_vec());
        assert_eq!(run.steps, 10);
        assert!(run.convergence.iter().any(|c| !c.converged()));
    }

    /// A banana (a Gaussian in x bent by a parabola in y, Haario et al. 1999's twisted Gaussian):
    /// x ~ N(½, s_x²), y | x ~ N(0.3 + b (x − ½)², s_y²), so E y = 0.3 + b s_x² and
    /// var y = s_y² + 2 b² s_x⁴ exactly. The box cuts the ridge where y > 1, |x − ½| > 4.2 s_x:
    /// that mass (3e-5) moves the moments far less than the sampling error bounds used here.
    const BANANA: (f64, f64, f64) = (0.1, 0.01, 4.0);

    fn banana(v: &[f64]) -> f64 {
        let (sx, sy, b) = BANANA;
        if !in_box(v) {
            return f64::NEG_INFINITY;
        }
        let r = v[1] - 0.3 - b * (v[0] - 0.5).powi(2);
        -((v[0] - 0.5) / sx).powi(2) / 2.0 - (r / sy).powi(2) / 2.0
    }

    /// The banana's exact E y and var y.
    fn banana_y_moments() -> (f64, f64) {
        let (sx, sy, b) = BANANA;
        (0.3 + b * sx * sx, sy * sy + 2.0 * b * b * sx.powi(4))
    }

    /// The run's means and variances of x and y against the banana's exact ones, each within 4 of
    /// its Monte Carlo error (sd over √ESS).
    fn assert_banana_moments(run: &Converged) {
        let sx = BANANA.0;
        let (ey, vy) = banana_y_moments();
        let (my, _) = mean_sd(&draws(run, 1));
        assert!(
            (my - ey).abs() < 4.0 * vy.sqrt() / run.convergence[1].ess.sqrt(),
            "mean y {my} vs {ey}"
        );
        let (mx, _) = mean_sd(&draws(run, 0));
        assert!(
            (mx - 0.5).abs() < 4.0 * sx / run.convergence[0].ess.sqrt(),
            "mean x {mx}"
        );
        assert_variance_within_its_error(run, 0, sx * sx, 0.5);
        assert_variance_within_its_error(run, 1, vy, ey);
    }

    /// The banana's curved ridge is what the slice follows.
    #[test]
    fn samples_a_curved_ridge_with_its_exact_moments() {
        // A fixed, long run (τ ≈ 50–75 steps on this ridge): this test is about the distribution
        // sampled, the errors allowed follow from the run's own ESS; when to stop is
        // `runs_until_converged_on_a_gaussian`'s.
        let run = sample_until_converged(Ensemble::new(&banana, &[0.5, 0.3], 32, 5), (200, 8000, 8000), &|u| {
            u.to_vec()
        });
        assert_banana_moments(&run);
    }

    /// The variance as the mean of (v − mean)², within 4 of its Monte Carlo errors: that quantity's
    /// own sd over its own ESS, since the tails a variance depends on mix more slowly than the mean.
    fn assert_variance_within_its_error(run: &Converged, k: usize, exact: f64, mean: f64) {
        let sq: Vec<Vec<f64>> = run
            .traces
            .iter()
            .map(|t| t.iter().map(|v| (v[k] - mean).powi(2)).collect())
            .collect();
        let ess = convergence::diagnose(&sq).ess;
        let (var, sd) = mean_sd(&sq.concat());
        assert!(
            (var - exact).abs() < 4.0 * sd / ess.sqrt(),
            "{k}: variance {var} vs {exact} (ESS {ess:.0})"
        );
    }

    /// The banana of [`samples_a_curved_ridge_with_its_exact_moments`] sampled by independence
    /// moves from a proposal fitted to draws of a different law (a straight, uncorrelated Gaussian
    /// with the banana's x spread and twice its y spread, shifted): the chain must give the
    /// banana's exact moments, not the proposal's. That is the Metropolis–Hastings ratio's job,
    /// q(x)/q(y) included; a ratio without it would return the proposal.
    #[test]
    fn independence_moves_sample_the_target_not_the_proposal() {
        use rand_distr::StandardNormal;
        let sx = BANANA.0;
        let (ey, vy) = banana_y_moments();
        let mut rng = ChaCha8Rng::seed_from_u64(21);
        let other: Vec<Vec<f64>> = (0..2000)
            .map(|_| {
                let (g, h): (f64, f64) = (rng.sample(StandardNormal), rng.sample(StandardNormal));
                vec![0.52 + sx * g, ey - 0.01 + 2.0 * vy.sqrt() * h]
            })
            .collect();
        let q = Proposal::fit(&other).unwrap();
        let start: Vec<Vec<f64>> = other[..8].to_vec();
        let ens = Ensemble::from_positions(&banana, start, 6).with_proposal(q);
        let run = sample_until_converged(ens, (50, 4000, 4000), &|u| u.to_vec());
        // A proposal of the wrong law is accepted part of the time, never always (that would mean
        // the ratio ignored the target) and not almost never (the chain would not move).
        assert!(run.acceptance > 0.05 && run.acceptance < 1.0, "{}", run.acceptance);
        assert!(
            (run.evaluations_per_move - 1.0).abs() < 0.01,
            "{}",
            run.evaluations_per_move
        );
        assert_banana_moments(&run);
    }

    #[test]
    fn samples_a_density_cut_by_the_box() {
        // A half-normal against the face x = 0: N(0, 0.1²) truncated to [0, 1], mean 0.1·√(2/π).
        let s = 0.1f64;
        let lp = |v: &[f64]| {
            if in_box(v) {
                -(v[0] / s).powi(2) / 2.0 - ((v[1] - 0.5) / s).powi(2) / 2.0
            } else {
                f64::NEG_INFINITY
            }
        };
        let run = sample_until_converged(Ensemble::new(&lp, &[0.05, 0.5], 16, 9), (100, 100, 100_000), &|u| {
            u.to_vec()
        });
        let c = run.convergence[0];
        assert!(c.converged(), "{c:?}");
        let (m, _) = mean_sd(&draws(&run, 0));
        let exact = s * (2.0 / std::f64::consts::PI).sqrt();
        // sd of the half-normal: s·√(1 − 2/π) ≈ 0.6 s.
        assert!((m - exact).abs() < 4.0 * 0.61 * s / c.ess.sqrt(), "mean {m} vs {exact}");
    }

    #[test]
    fn the_chain_does_not_depend_on_the_thread_count() {
        let lp = |x: &[f64]| {
            if in_box(x) {
                -((x[0] - x[1]) / 0.05).powi(2)
            } else {
                f64::NEG_INFINITY
            }
        };
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                sample_until_converged(Ensemble::new(&lp, &[0.5, 0.5], 8, 4), (10, 30, 30), &|u| u.to_vec()).traces
            })
        };
        assert_eq!(run(1), run(2));
    }

    #[test]
    fn independence_chains_do_not_depend_on_the_thread_count() {
        let lp = |x: &[f64]| {
            if in_box(x) {
                -((x[0] - x[1]) / 0.05).powi(2)
            } else {
                f64::NEG_INFINITY
            }
        };
        let draws: Vec<Vec<f64>> = (0..100)
            .map(|i| vec![i as f64 / 100.0, (i * 37 % 100) as f64 / 100.0])
            .collect();
        let q = Proposal::fit(&draws).unwrap();
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                let ens = Ensemble::from_positions(&lp, draws[..6].to_vec(), 4).with_proposal(q.clone());
                sample_until_converged(ens, (10, 30, 30), &|u| u.to_vec()).traces
            })
        };
        assert_eq!(run(1), run(2));
    }

    #[test]
    fn tuned_slices_cost_a_few_evaluations_per_move() {
        // KB21 report about 5 evaluations per move once μ is tuned (2 ends + ~1 expansion + shrinks).
        let lp = |x: &[f64]| {
            if in_box(x) {
                -x.iter().map(|v| ((v - 0.5) / 0.05).powi(2)).sum::<f64>() / 2.0
            } else {
                f64::NEG_INFINITY
            }
        };
        let mut ens = Ensemble::new(&lp, &[0.5; 4], 16, 2);
        ens.advance(200, &mut |_| {});
        let per_move = ens.evaluations_per_move();
        assert!((3.0..8.0).contains(&per_move), "{per_move}");
    }
}
