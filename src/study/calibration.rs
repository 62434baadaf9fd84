//! The calibration settings a study names: its methods and the Bayesian method's knobs.

/// A calibration method, as a study names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    LeastSquares,
    Sensitivity,
    Bayesian,
}

impl Method {
    /// The name used in the study file and in `results.json`.
    pub fn key(self) -> &'static str {
        match self {
            Method::LeastSquares => "least_squares",
            Method::Sensitivity => "sensitivity",
            Method::Bayesian => "bayesian",
        }
    }

    pub fn from_key(key: &str) -> Option<Method> {
        [Method::LeastSquares, Method::Sensitivity, Method::Bayesian]
            .into_iter()
            .find(|m| m.key() == key)
    }
}

/// Knobs of the Bayesian method; defaults follow the paper (24 emulator samples).
///
/// The sampler (`calibrate::bayesian`'s sampler): `mcmc_walkers` walkers take `mcmc_burn_in / 2` ensemble slice
/// steps (about five density evaluations each), then two adaptation rounds of `mcmc_burn_in`
/// independence steps (one evaluation each); then `mcmc_chains` of them run on with the adapted
/// kernel, checked for convergence first after `mcmc_steps` steps and stopped at `mcmc_max_steps`.
/// Quadrature (one or two parameters) ignores them.
#[derive(Debug, Clone, PartialEq)]
pub struct BayesianSettings {
    pub emulator_samples: usize,
    pub seed: u64,
    pub mcmc_walkers: usize,
    /// Chains of the run after adaptation: split R-hat ≤ 1.01 asks each for an ESS near 50, so
    /// fewer, longer chains reach it with fewer evaluations (Vehtari et al. 2021 use four).
    pub mcmc_chains: usize,
    pub mcmc_steps: usize,
    pub mcmc_burn_in: usize,
    /// The sampler's budget: it stops here if R-hat ≤ 1.01 and ESS ≥ 1000 are not met before
    /// (never before `mcmc_steps`).
    pub mcmc_max_steps: usize,
    /// Up to this many parameters the posterior is computed by quadrature, not sampled (0: always
    /// sample).
    pub quadrature_max_params: usize,
}

impl Default for BayesianSettings {
    fn default() -> Self {
        BayesianSettings {
            emulator_samples: 24,
            seed: 1,
            mcmc_walkers: 16,
            mcmc_chains: 8,
            mcmc_steps: 300,
            mcmc_burn_in: 100,
            mcmc_max_steps: 5_000,
            quadrature_max_params: 2,
        }
    }
}
