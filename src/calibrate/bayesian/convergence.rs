//! Convergence of a sampled posterior: split R-hat and effective sample size per parameter
//! (Gelman et al., *Bayesian Data Analysis*, 3rd ed., §11.4–11.5).
//!
//! Each walker of the ensemble is a chain; each chain is split in halves, so a drift within a chain
//! shows as disagreement between halves. With m half-chains of length n, W the mean within-chain
//! variance and B/n the variance of the chain means, `var⁺ = (n−1)/n W + B/n` and
//! `R̂ = √(var⁺/W)`. The effective sample size is `m n / (1 + 2 Σ ρ_t)`, the autocorrelations
//! `ρ_t = 1 − (W − mean_j γ_jt)/var⁺` summed over Geyer's initial positive pairs. Walkers of an
//! ensemble move together, so these are the usual ensemble diagnostics, not exact ones; the
//! thresholds lab reports against are R̂ ≤ 1.01 and ESS ≥ 1000 (Vehtari et al. 2021).

use serde::{Deserialize, Serialize};

/// R-hat at or below this, and ESS at or above the next, count as converged.
pub const RHAT_LIMIT: f64 = 1.01;
pub const ESS_LIMIT: f64 = 1000.0;

/// The diagnostics of one parameter.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Convergence {
    pub split_rhat: f64,
    pub ess: f64,
}

impl Convergence {
    pub fn converged(&self) -> bool {
        self.split_rhat <= RHAT_LIMIT && self.ess >= ESS_LIMIT
    }
}

/// The diagnostics of one parameter from its chains (each a trace after burn-in, equal lengths).
pub fn diagnose(chains: &[Vec<f64>]) -> Convergence {
    let half = chains.first().map_or(0, |c| c.len() / 2);
    let split: Vec<&[f64]> = chains.iter().flat_map(|c| [&c[..half], &c[half..2 * half]]).collect();
    let (m, n) = (split.len() as f64, half as f64);
    if half < 4 || split.len() < 2 {
        return Convergence {
            split_rhat: f64::INFINITY,
            ess: 0.0,
        };
    }
    let means: Vec<f64> = split.iter().map(|c| c.iter().sum::<f64>() / n).collect();
    let grand = means.iter().sum::<f64>() / m;
    let b = n / (m - 1.0) * means.iter().map(|x| (x - grand).powi(2)).sum::<f64>();
    let w = split
        .iter()
        .zip(&means)
        .map(|(c, mu)| c.iter().map(|x| (x - mu).powi(2)).sum::<f64>() / (n - 1.0))
        .sum::<f64>()
        / m;
    if w <= 0.0 {
        // Every chain constant: converged only if they agree.
        let agree = b <= 0.0;
        return Convergence {
            split_rhat: if agree { 1.0 } else { f64::INFINITY },
            ess: if agree { m * n } else { 0.0 },
        };
    }
    let var_plus = (n - 1.0) / n * w + b / n;
    let rho = |t: usize| {
        let gamma = split
            .iter()
            .zip(&means)
            .map(|(c, mu)| (0..half - t).map(|i| (c[i] - mu) * (c[i + t] - mu)).sum::<f64>() / n)
            .sum::<f64>()
            / m;
        1.0 - (w - gamma) / var_plus
    };
    // Geyer's initial positive sequence: sum pairs ρ_{2k} + ρ_{2k+1} while positive.
    let mut sum = 0.0;
    let mut t = 1;
    while t + 1 < half {
        let pair = rho(t) + rho(t + 1);
        if pair <= 0.0 {
            break;
        }
        sum += pair;
        t += 2;
    }
    Convergence {
        split_rhat: (var_plus / w).sqrt(),
        ess: (m * n / (1.0 + 2.0 * sum)).min(m * n),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn gauss(rng: &mut ChaCha8Rng) -> f64 {
        let u1: f64 = rng.random_range(f64::EPSILON..1.0);
        let u2: f64 = rng.random();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }

    /// AR(1) chains x_t = φ x_{t−1} + e_t: ESS = N (1 − φ)/(1 + φ) exactly in the limit.
    fn ar1(phi: f64, chains: usize, len: usize, offset: impl Fn(usize) -> f64) -> Vec<Vec<f64>> {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        (0..chains)
            .map(|c| {
                let mut x = gauss(&mut rng) / (1.0 - phi * phi).sqrt();
                (0..len)
                    .map(|_| {
                        x = phi * x + gauss(&mut rng);
                        x + offset(c)
                    })
                    .collect()
            })
            .collect()
    }

    /// Tolerance: the ESS estimate of 16 chains × 2000 draws scatters by about 10 %; 20 % leaves room.
    #[test]
    fn ar1_chains_have_their_theoretical_ess_and_rhat_near_one() {
        for phi in [0.0, 0.5, 0.9] {
            let c = diagnose(&ar1(phi, 16, 2000, |_| 0.0));
            let expected = 16.0 * 2000.0 * (1.0 - phi) / (1.0 + phi);
            assert!(
                (c.ess / expected - 1.0).abs() < 0.2,
                "phi {phi}: ess {} vs {expected}",
                c.ess
            );
            assert!(c.split_rhat < 1.01, "phi {phi}: rhat {}", c.split_rhat);
        }
    }

    #[test]
    fn chains_stuck_apart_are_not_converged() {
        let c = diagnose(&ar1(0.5, 8, 1000, |k| k as f64));
        assert!(c.split_rhat > 1.5, "{c:?}");
        assert!(!c.converged());
    }
}
