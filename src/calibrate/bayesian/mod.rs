//! Kennedy–O'Hagan Bayesian calibration (paper Appendix, Eqs. A1–A9).
//!
//! y_true(d) = y_pre(d, θ) + δ(d)   (A1)
//!
//! - `y_pre` is a GP emulator over (design, parameters) fitted to simulation samples (A2–A4):
//!   quadratic trend, Gaussian kernel, hyperparameters by maximum likelihood ([`gp`]), fitted to
//!   ln y over ln inputs when the data are positive, predicting back in y.
//! - The likelihood stays in y, where the discrepancy is additive (A1).
//! - `δ` is a GP discrepancy with a constant trend (A5–A7).
//! - θ by maximum likelihood of the tests given the emulator (A8–A9, [`koh`]), then the posterior of
//!   θ: by deterministic quadrature for one or two parameters ([`exact`]), else by an ensemble MCMC
//!   ([`mcmc`]) checked for convergence ([`convergence`]).
//!
//! Modular: the emulator's hyperparameters are fixed once fitted; β_d is always re-estimated with θ,
//! never frozen at a reference θ (that would drag θ towards the reference).

pub mod convergence;
pub mod coords;
pub mod cubature;
pub mod exact;
pub mod koh;
pub mod mcmc;
pub mod proposal;

use std::sync::OnceLock;

use nalgebra::{DMatrix, DVector};

use super::{Bounds, CalibrationError, Problem};
use crate::emulate::gp::Emulator;
use koh::{Discrepancy, Koh};

/// Simulation samples for the emulator: one row per run, columns = design variables then parameters.
#[derive(Debug, Clone)]
pub struct SimulationData {
    pub inputs: DMatrix<f64>,
    pub outputs: DVector<f64>,
    /// The emulator fitted to these runs and the box it was fitted over: fitted once and shared by
    /// every calibration of the same runs (a study's and each of its train/validate splits'; the
    /// fit is deterministic, so sharing changes no number).
    fitted: OnceLock<(Bounds, Emulator)>,
}

impl SimulationData {
    pub fn new(inputs: DMatrix<f64>, outputs: DVector<f64>) -> Self {
        SimulationData {
            inputs,
            outputs,
            fitted: OnceLock::new(),
        }
    }

    /// The emulator of these runs over `bounds`: the shared one when it was fitted over the same
    /// box, else a fresh fit (the first fit is kept for the next caller).
    fn emulator(&self, bounds: &Bounds) -> Result<Emulator, CalibrationError> {
        if let Some((b, e)) = self.fitted.get()
            && b == bounds
        {
            return Ok(e.clone());
        }
        if self.outputs.iter().any(|v| !v.is_finite()) {
            return Err(CalibrationError::NonFinite("emulator samples".into()));
        }
        // Each run a point of the emulator's inputs (the design's values, then θ).
        let rows: Vec<Vec<f64>> = self.inputs.row_iter().map(|r| r.iter().copied().collect()).collect();
        let runs: Vec<crate::emulate::Run<f64>> = rows
            .iter()
            .zip(self.outputs.iter())
            .map(|(x, y)| crate::emulate::Run {
                design: "",
                values: &[],
                x,
                y: Some(y),
            })
            .collect();
        let emulator = <Emulator as crate::emulate::Emulator>::fit(bounds, &runs)
            .map_err(|e| CalibrationError::Numerics(e.to_string()))?;
        let _ = self.fitted.set((bounds.clone(), emulator.clone()));
        Ok(emulator)
    }
}

/// The method's knobs are study settings (`calibration.bayesian`).
pub use crate::study::BayesianSettings as Settings;

/// Most posterior rows kept in [`BayesianFit::posterior`] (quantiles use every sample).
const MAX_POSTERIOR_ROWS: usize = 5000;

/// The calibrated Bayesian model.
#[derive(Debug, Clone)]
pub struct BayesianFit {
    /// Maximum-likelihood parameters.
    pub theta: DVector<f64>,
    /// 2.5 % and 97.5 % posterior quantiles per parameter.
    pub interval95: Vec<(f64, f64)>,
    /// Posterior median per parameter.
    pub median: DVector<f64>,
    /// Posterior mean per parameter.
    pub mean: DVector<f64>,
    /// Posterior samples after burn-in, one row per sample (thinned to at most 5000 rows); no rows
    /// when the posterior was computed by quadrature.
    pub posterior: DMatrix<f64>,
    /// The marginal density per parameter (points θ, density per unit of θ) when computed by
    /// quadrature; empty when sampled.
    pub density: Vec<(Vec<f64>, Vec<f64>)>,
    /// How the quadrature went (rule, error estimates, cost); `None` when sampled.
    pub quadrature: Option<exact::QuadratureSummary>,
    /// The fitted simulation emulator (A2–A4).
    pub emulator: Emulator,
    /// The discrepancy at the maximum-likelihood point, conditioned on the training residuals (A5–A7).
    pub discrepancy: Discrepancy,
    /// How the sampler went (its defaults when computed by quadrature).
    pub sampler: SamplerRun,
}

/// How the posterior's sampler went: its cost, its convergence and the coordinates it sampled in.
#[derive(Debug, Clone)]
pub struct SamplerRun {
    /// Density evaluations per walker move of the sampler's run (NaN when computed by quadrature).
    pub evaluations_per_move: f64,
    /// Split R-hat and effective sample size per parameter, over the walkers' kept traces (empty
    /// when the posterior was computed by quadrature).
    pub convergence: Vec<convergence::Convergence>,
    /// Sampler steps after burn-in (0 when computed by quadrature).
    pub steps: usize,
    /// Per parameter the power in whose coordinates it was sampled (1: θ itself, 0: ln θ, −1: 1/θ;
    /// empty when computed by quadrature).
    pub sampling_powers: Vec<f64>,
    /// Share of the run's independence proposals accepted (NaN with slice steps or quadrature).
    pub acceptance: f64,
    /// Density evaluations of the whole sampler, pilot and adaptation included (0 by quadrature).
    pub evaluations: usize,
}

impl Default for SamplerRun {
    /// A posterior computed by quadrature: no sampler ran.
    fn default() -> SamplerRun {
        SamplerRun {
            evaluations_per_move: f64::NAN,
            convergence: Vec::new(),
            steps: 0,
            sampling_powers: Vec::new(),
            acceptance: f64::NAN,
            evaluations: 0,
        }
    }
}

impl BayesianFit {
    /// Bias-corrected prediction at a design: emulator mean at θ̂ plus the discrepancy's posterior mean.
    pub fn predict(&self, design: &[f64]) -> f64 {
        let row: Vec<f64> = design.iter().chain(self.theta.iter()).copied().collect();
        let y = self.emulator.mean(&DMatrix::from_row_slice(1, row.len(), &row))[0];
        y + self.discrepancy.mean(design)
    }
}

/// Draws `settings.emulator_samples` Latin-hypercube points over design × parameter bounds and
/// evaluates the problem's model there.
pub fn emulator_samples(problem: &Problem, design_bounds: &Bounds, settings: &Settings) -> SimulationData {
    let bounds = joint_bounds(design_bounds, &problem.bounds);
    let plan = crate::base::latin_hypercube(settings.emulator_samples, bounds.dim(), settings.seed);
    let inputs = DMatrix::from_fn(plan.nrows(), plan.ncols(), |i, k| {
        bounds.lower[k] + plan[(i, k)] * bounds.width()[k]
    });
    let pd = design_bounds.dim();
    let outputs = DVector::from_fn(inputs.nrows(), |i, _| {
        let row: Vec<f64> = inputs.row(i).iter().copied().collect();
        problem.model.predict(&row[..pd], &row[pd..])
    });
    SimulationData::new(inputs, outputs)
}

/// Design bounds followed by parameter bounds: the emulator's input box.
fn joint_bounds(design: &Bounds, theta: &Bounds) -> Bounds {
    let cat = |a: &DVector<f64>, b: &DVector<f64>| a.iter().chain(b.iter()).copied().collect::<Vec<_>>();
    Bounds::new(cat(&design.lower, &theta.lower), cat(&design.upper, &theta.upper))
}

/// Calibrates θ by modular Kennedy–O'Hagan.
///
/// 1. Emulator fitted to `sim` (A2–A4), then fixed.
/// 2. θ̂ maximises the likelihood of the tests (A8–A9) jointly with β_d (GLS), σ_d² and λ_d.
/// 3. Posterior of θ with β_d, σ_d² and λ_d integrated out: by quadrature for one or two
///    parameters, by sampling for more ([`by_sampling`]).
///    Priors (all proper, independent): θ uniform on `problem.bounds`; log σ_d² uniform on
///    [ln (10⁻³ s)², ln (3 s)²] and each log λ_d uniform on [ln 0.1, ln 100] (designs scaled to the
///    unit cube), where s is the rms residual of the tests against the emulator at the centre of the
///    θ box; β_d flat. The interval depends on the σ_d² prior: with few tests the data cannot fix it.
pub fn calibrate(
    problem: &Problem,
    design_bounds: &Bounds,
    sim: &SimulationData,
    settings: &Settings,
) -> Result<BayesianFit, CalibrationError> {
    check_inputs(problem, design_bounds, sim)?;
    let emulator = sim.emulator(&joint_bounds(design_bounds, &problem.bounds))?;
    let koh = Koh::new(&emulator, problem, design_bounds)?;
    let (u_hat, _) = koh.fit_ml(settings.seed.wrapping_add(0x6b6f68));
    let theta = koh.theta(&u_hat);
    let discrepancy = koh
        .discrepancy(&u_hat)
        .ok_or_else(|| CalibrationError::Numerics("discrepancy covariance is singular".into()))?;

    let base = BayesianFit {
        interval95: vec![],
        median: theta.clone(),
        mean: theta.clone(),
        posterior: DMatrix::zeros(0, theta.len()),
        density: vec![],
        quadrature: None,
        sampler: SamplerRun::default(),
        theta,
        emulator: emulator.clone(),
        discrepancy,
    };
    Ok(if koh.n_theta() <= settings.quadrature_max_params {
        by_quadrature(&koh, &u_hat, base)
    } else {
        by_sampling(&koh, &u_hat, settings, base)
    })
}

/// The posterior by quadrature ([`exact`]).
fn by_quadrature(koh: &Koh, u_hat: &[f64], base: BayesianFit) -> BayesianFit {
    let post = exact::posterior(koh, u_hat);
    BayesianFit {
        interval95: post.interval95,
        median: post.median,
        mean: post.mean,
        density: post.density,
        quadrature: Some(post.summary),
        ..base
    }
}

/// The posterior by sampling ([`mcmc`]) over θ alone, the discrepancy's hyperparameters
/// integrated out at every step by the quadrature's inner rule ([`exact::Marginal`]).
///
/// 1. A pilot of ensemble slice steps from θ̂ in θ's unit box ([`slice_pilot`]).
/// 2. Adaptation ([`adapt`]): from the last draws, the sampling coordinates (a power of each
///    parameter, [`coords`]) and an independence proposal in them ([`proposal`]); a round of
///    independence Metropolis–Hastings gives better draws, from which both are chosen again.
/// 3. The run: `mcmc_chains` of the walkers go on with that kernel fixed, from where the
///    adaptation left them, until every θ_k converges (R-hat ≤ 1.01, ESS ≥ 1000) or
///    `mcmc_max_steps` ([`mcmc::sample_until_converged`]). Everything before it is burn-in. Without
///    a proposal (draws too few or degenerate), every walker goes on with slice steps.
fn by_sampling(koh: &Koh, u_hat: &[f64], settings: &Settings, base: BayesianFit) -> BayesianFit {
    let marginal = exact::Marginal::new(koh);
    let p = koh.n_theta();
    let walkers = settings.mcmc_walkers.max(2 * p).next_multiple_of(2);
    let round = settings.mcmc_burn_in.max(8);
    let first = settings.mcmc_steps.max(8);
    let budget = settings.mcmc_max_steps.max(first);
    let pilot = slice_pilot(&marginal, &u_hat[..p], walkers, round / 2, settings.seed);
    let adapted = adapt(&marginal, pilot, round, settings.seed);
    let coords = &adapted.coords;
    let density = in_coords(&marginal, coords);
    let start = adapted.positions.iter().map(|u| coords.to_z(u));
    let seed = settings.seed.wrapping_add(ADAPT_ROUNDS + 1);
    let ensemble = match adapted.proposal {
        Some(q) => {
            let chains = settings.mcmc_chains.max(2);
            mcmc::Ensemble::from_positions(&density, start.take(chains).collect(), seed).with_proposal(q)
        }
        None => mcmc::Ensemble::from_positions(&density, start.collect(), seed),
    };
    let project = |z: &[f64]| koh.theta(&coords.to_u(z).0).as_slice().to_vec();
    let run = mcmc::sample_until_converged(ensemble, (0, first, budget), &project);
    let traces: Vec<Vec<DVector<f64>>> = run
        .traces
        .iter()
        .map(|t| t.iter().map(|v| DVector::from_column_slice(v)).collect())
        .collect();
    let sampler = SamplerRun {
        evaluations_per_move: run.evaluations_per_move,
        convergence: run.convergence,
        steps: run.steps,
        sampling_powers: coords.power.clone(),
        acceptance: run.acceptance,
        evaluations: adapted.evaluations + run.evaluations,
    };
    BayesianFit {
        sampler,
        ..sampled_fit(&traces, base)
    }
}

/// Rounds of independence sampling between the slice pilot and the run.
const ADAPT_ROUNDS: u64 = 2;

/// The slice pilot: `steps` ensemble slice steps from a small cloud at θ̂ (unit box).
fn slice_pilot(marginal: &exact::Marginal, u_hat: &[f64], walkers: usize, steps: usize, seed: u64) -> mcmc::Pilot {
    let bounds = marginal.theta_bounds();
    let identity = coords::Coords::identity(bounds.lower.as_slice(), bounds.upper.as_slice());
    let density = in_coords(marginal, &identity);
    mcmc::pilot(mcmc::Ensemble::new(&density, u_hat, walkers, seed), steps)
}

/// What adaptation ends with: the sampling coordinates, the proposal in them (`None` when the
/// draws could not give one), the walkers' positions (θ's unit box) and the density evaluations
/// spent since the pilot began.
struct Adapted {
    coords: coords::Coords,
    proposal: Option<proposal::Proposal>,
    positions: Vec<Vec<f64>>,
    evaluations: usize,
}

/// From the pilot's draws, [`ADAPT_ROUNDS`] rounds of: choose coordinates and fit the proposal
/// to the draws, then `steps` independence steps in them; the last round's draws choose the final
/// coordinates and proposal. Each round's draws follow the posterior more closely than the last's
/// (the first pilot starts in a small cloud at θ̂), so the choice improves round by round.
fn adapt(marginal: &exact::Marginal, pilot: mcmc::Pilot, steps: usize, seed: u64) -> Adapted {
    let bounds = marginal.theta_bounds();
    let (lower, upper) = (bounds.lower.as_slice(), bounds.upper.as_slice());
    let mcmc::Pilot {
        mut draws,
        last: mut positions,
        mut evaluations,
    } = pilot;
    for round in 0..=ADAPT_ROUNDS {
        let coords = coords::Coords::choose(lower, upper, &draws);
        let proposal = proposal::Proposal::fit(&draws.iter().map(|u| coords.to_z(u)).collect::<Vec<_>>());
        let Some(q) = proposal.clone().filter(|_| round < ADAPT_ROUNDS) else {
            return Adapted {
                coords,
                proposal,
                positions,
                evaluations,
            };
        };
        let density = in_coords(marginal, &coords);
        let start = positions.iter().map(|u| coords.to_z(u)).collect();
        let ensemble = mcmc::Ensemble::from_positions(&density, start, seed.wrapping_add(1 + round)).with_proposal(q);
        let next = mcmc::pilot(ensemble, steps);
        let in_u = |z: &Vec<f64>| coords.to_u(z).0;
        draws = next.draws.iter().map(in_u).collect();
        positions = next.last.iter().map(in_u).collect();
        evaluations += next.evaluations;
    }
    unreachable!("the last round returns")
}

/// ln m(θ) in the sampling coordinates z (their unit box), with the Jacobian of the map to θ.
fn in_coords<'m>(marginal: &'m exact::Marginal, coords: &'m coords::Coords) -> impl Fn(&[f64]) -> f64 + Sync + 'm {
    move |z: &[f64]| {
        if !z.iter().all(|v| (0.0..=1.0).contains(v)) {
            return f64::NEG_INFINITY;
        }
        let (u, log_jacobian) = coords.to_u(z);
        marginal.log_density(&u) + log_jacobian
    }
}

/// The posterior summaries from the walkers' kept traces.
fn sampled_fit(traces: &[Vec<DVector<f64>>], base: BayesianFit) -> BayesianFit {
    let len = traces.first().map_or(0, Vec::len);
    // Step-major, as the thinning below expects: step s of every walker, then step s + 1.
    let thetas: Vec<&DVector<f64>> = (0..len).flat_map(|s| traces.iter().map(move |t| &t[s])).collect();
    let p = base.theta.len();
    let quantile = |k: usize, q: f64| quantile(thetas.iter().map(|t| t[k]).collect(), q);
    let n = thetas.len().max(1) as f64;
    let every = thetas.len().div_ceil(MAX_POSTERIOR_ROWS).max(1);
    let kept: Vec<&DVector<f64>> = thetas.iter().step_by(every).copied().collect();
    BayesianFit {
        interval95: (0..p).map(|k| (quantile(k, 0.025), quantile(k, 0.975))).collect(),
        median: DVector::from_fn(p, |k, _| quantile(k, 0.5)),
        mean: DVector::from_fn(p, |k, _| thetas.iter().map(|t| t[k]).sum::<f64>() / n),
        posterior: DMatrix::from_fn(kept.len(), p, |i, k| kept[i][k]),
        ..base
    }
}

fn check_inputs(problem: &Problem, design_bounds: &Bounds, sim: &SimulationData) -> Result<(), CalibrationError> {
    let m = problem.designs.nrows();
    if m < 2 {
        return Err(CalibrationError::TooFewDesigns {
            method: "bayesian",
            needed: 2,
            given: m,
        });
    }
    let cols = design_bounds.dim() + problem.bounds.dim();
    if problem.designs.ncols() != design_bounds.dim()
        || sim.inputs.ncols() != cols
        || sim.inputs.nrows() != sim.outputs.len()
    {
        return Err(CalibrationError::Numerics(format!(
            "shape mismatch: designs have {} columns, design bounds {}, simulation inputs {} (expected {cols})",
            problem.designs.ncols(),
            design_bounds.dim(),
            sim.inputs.ncols()
        )));
    }
    if problem.measured.len() != m {
        return Err(CalibrationError::Numerics(format!(
            "{m} training designs but {} measured values",
            problem.measured.len()
        )));
    }
    if problem.measured.iter().any(|v| !v.is_finite()) {
        return Err(CalibrationError::NonFinite("measured responses".into()));
    }
    Ok(())
}

/// Linear-interpolation quantile (type 7) of `v`.
fn quantile(mut v: Vec<f64>, q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let h = q * (v.len() - 1) as f64;
    let (i, frac) = (h.floor() as usize, h - h.floor());
    if i + 1 < v.len() {
        v[i] + frac * (v[i + 1] - v[i])
    } else {
        v[i]
    }
}

#[cfg(test)]
mod tests;
