//! Affine-invariant ensemble sampler (Goodman & Weare 2010 stretch move, as in emcee).
//!
//! Chosen over a random walk because the KOH posterior is strongly curved: θ is tight when σ_d² is
//! small and wide when it is large, which a fixed-step random walk cannot follow.

use rand::{Rng, SeedableRng};
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
    log_post: &dyn Fn(&[f64]) -> f64,
    start: &[f64],
    walkers: usize,
    steps: usize,
    burn_in: usize,
    seed: u64,
) -> Chain {
    let dim = start.len();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut pos: Vec<Vec<f64>> = Vec::with_capacity(walkers);
    let mut lp: Vec<f64> = Vec::with_capacity(walkers);
    for _ in 0..walkers {
        let (x, l) = initial_walker(log_post, start, &mut rng);
        pos.push(x);
        lp.push(l);
    }
    let mut samples = Vec::with_capacity(walkers * steps.saturating_sub(burn_in));
    let mut accepted = 0usize;
    for step in 0..steps {
        for k in 0..walkers {
            // Partner: any other walker, uniformly.
            let j = (k + 1 + rng.random_range(0..walkers - 1)) % walkers;
            let z = ((STRETCH - 1.0) * rng.random::<f64>() + 1.0).powi(2) / STRETCH;
            let y: Vec<f64> = (0..dim).map(|i| pos[j][i] + z * (pos[k][i] - pos[j][i])).collect();
            let ly = log_post(&y);
            let log_ratio = (dim as f64 - 1.0) * z.ln() + ly - lp[k];
            if ly.is_finite() && rng.random::<f64>().ln() < log_ratio {
                pos[k] = y;
                lp[k] = ly;
                accepted += 1;
            }
        }
        if step >= burn_in {
            samples.extend(pos.iter().cloned());
        }
    }
    let acceptance = accepted as f64 / (walkers * steps).max(1) as f64;
    Chain { samples, acceptance }
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
