//! The run plan of a solver study: for every training and validation design, the parameter
//! samples of `simulation.sampling` (Latin hypercube or full grid) plus `check_runs` extra Latin
//! hypercube points from a different seed stream, at which the fitted surrogate is checked; then,
//! for each model-extension hypothesis, the sample runs again with the extension's variables (its
//! screening runs).
//!
//! The solver-in-the-loop step plans more runs once the screening has ranked the hypotheses
//! ([`Plan::joint`]): for an extension whose variables have ranges, a Latin hypercube over the
//! joint space (calibration parameters × the extension's ranged variables) at every tested design,
//! sized for the study's surrogate over that larger space, plus check runs.
//!
//! Every design gets the same parameter samples (the paper's "12 yield-stress samples per design"),
//! so the plan is a fixed function of the study: the same study always plans the same runs.

use nalgebra::DMatrix;

use super::latin_hypercube;
use crate::base::Bounds;
pub use crate::study::sequence::{SequenceFloor, initial_samples, probes_across, sequential_budget, tested_designs};
use crate::study::solver::{Sampling, SamplingMethod, SurrogateKind};
use crate::study::{Parameter, SolverSimulation, Study};

/// Added to the sampling seed for the check points, so they are not the samples' stream.
const CHECK_SEED_OFFSET: u64 = 0x636865636b; // "check"
/// Added to the sampling seed (and the hypothesis's index) for the joint runs of an extension.
const JOINT_SEED_OFFSET: u64 = 0x6a6f696e74; // "joint"

/// Why a run is planned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RunRole {
    /// A sample the surrogate is fitted to.
    Sample,
    /// A point the fitted surrogate is checked at (not used to fit it).
    Check,
    /// A screening run of the model extension of hypothesis `k` (`study.diagnosis.hypotheses[k]`):
    /// the same design and parameters as a baseline sample, rendered with the extension's
    /// variables at their screening values.
    Extension(usize),
    /// A sample of hypothesis `k`'s extended model over the joint space (parameters × the
    /// extension's ranged variables), which its surrogate is fitted to.
    Joint(usize),
    /// A check point of hypothesis `k`'s joint surrogate.
    JointCheck(usize),
    /// A run at the fitted parameters of a model a verdict rests on, checking the verdict by the
    /// solver itself (not fitted to).
    Confirm,
    /// A run of hypothesis `k`'s extension at a value of its amplitude, reading what no model error
    /// leaves open of it (not fitted to).
    NotExcluded(usize),
}

impl RunRole {
    pub fn key(self) -> &'static str {
        match self {
            RunRole::Sample => "sample",
            RunRole::Check => "check",
            RunRole::Extension(_) => "extension",
            RunRole::Joint(_) => "joint",
            RunRole::JointCheck(_) => "joint_check",
            RunRole::Confirm => "confirmation",
            RunRole::NotExcluded(_) => "not_excluded",
        }
    }

    /// The stage a run of this role belongs to, as `sequence.json`, `results.json` `runs.outcomes`
    /// and `lab status` name it: `screening` (samples and checks), `probes` (the extension
    /// hypotheses' screening runs), `loop: <hypothesis>`, `confirmation`, `not_excluded`.
    pub fn stage(self, study: &Study) -> String {
        match self {
            RunRole::Sample | RunRole::Check => "screening".into(),
            RunRole::Extension(_) => "probes".into(),
            RunRole::Joint(k) | RunRole::JointCheck(k) => format!("loop: {}", study.diagnosis.hypotheses[k].name),
            RunRole::Confirm => "confirmation".into(),
            RunRole::NotExcluded(_) => "not_excluded".into(),
        }
    }
}

/// One planned solver run.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedRun {
    pub design: String,
    pub design_values: Vec<f64>,
    pub theta: Vec<f64>,
    pub role: RunRole,
    /// The template variables of a model extension set for this run (empty for the baseline).
    pub extension: Vec<(String, f64)>,
    /// The seed of the run's random imperfection, from 0 (`simulation.seeds`, rendered as
    /// seed + 1): 0 but for the confirmation runs, which are made at every seed.
    pub seed: usize,
}

impl PlannedRun {
    /// The run's point in the joint space of hypothesis `ranges`: θ, then each ranged variable.
    pub fn joint_point(&self, ranges: &[Parameter]) -> Vec<f64> {
        let value = |name: &str| self.extension.iter().find(|(n, _)| n == name).map_or(f64::NAN, |v| v.1);
        self.theta
            .iter()
            .copied()
            .chain(ranges.iter().map(|r| value(&r.name)))
            .collect()
    }
}

/// Every run a study needs, designs in study order (training, then validation); per design the
/// samples, then the check points.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    pub runs: Vec<PlannedRun>,
}

impl Plan {
    /// Plans the runs of a solver study: with `method: sequential`, its initial design only
    /// ([`Plan::initial`]); the rest comes batch by batch (`crate::pipeline::sequence`).
    pub fn new(study: &Study, sim: &SolverSimulation) -> Plan {
        if sim.sampling.method == SamplingMethod::Sequential {
            return Plan::initial(study, sim);
        }
        let bounds = study.parameter_bounds();
        let p = bounds.dim();
        let samples = planned_points(sim, &bounds, unit_samples(&sim.sampling, p));
        let checks = planned_points(
            sim,
            &bounds,
            latin_hypercube(
                sim.sampling.check_runs,
                p,
                sim.sampling.seed.wrapping_add(CHECK_SEED_OFFSET),
            ),
        );
        let mut runs = Vec::new();
        for (name, values) in tested_designs(study) {
            let at = |theta: &Vec<f64>, role| PlannedRun {
                design: name.clone(),
                design_values: values.clone(),
                theta: theta.clone(),
                role,
                extension: Vec::new(),
                seed: 0,
            };
            runs.extend(samples.iter().map(|t| at(t, RunRole::Sample)));
            runs.extend(checks.iter().map(|t| at(t, RunRole::Check)));
        }
        runs.extend(extension_runs(study, &runs));
        Plan { runs }
    }

    /// With one emulator across the designs: a run at every tested design, their θ one Latin
    /// hypercube (each design in its own stratum), and more round the designs until the emulator's
    /// linear trend over the designs' values and θ has a run to spare (`sampling.initial`, if given,
    /// is the number in all).
    fn initial_across(study: &Study, sim: &SolverSimulation) -> Plan {
        let bounds = study.parameter_bounds();
        let designs: Vec<(&String, &Vec<f64>)> = tested_designs(study).collect();
        let n = crate::study::sequence::initial_across(study, sim);
        let samples = planned_points(sim, &bounds, latin_hypercube(n, bounds.dim(), sim.sampling.seed));
        let runs = samples
            .into_iter()
            .enumerate()
            .map(|(i, theta)| {
                let (name, values) = designs[i % designs.len()];
                PlannedRun {
                    design: name.clone(),
                    design_values: values.clone(),
                    theta,
                    role: RunRole::Sample,
                    extension: Vec::new(),
                    seed: 0,
                }
            })
            .collect();
        Plan { runs }
    }

    /// A sequential study's initial design: at every tested design the same
    /// [`initial_samples`] Latin-hypercube points over θ, no check runs (each design's latest batch
    /// checks its emulator) and no extension runs (the probes are planned from the screening's
    /// posterior).
    pub fn initial(study: &Study, sim: &SolverSimulation) -> Plan {
        if sim.across_designs() {
            return Plan::initial_across(study, sim);
        }
        let bounds = study.parameter_bounds();
        let n = initial_samples(study, sim, bounds.dim());
        let samples = planned_points(sim, &bounds, latin_hypercube(n, bounds.dim(), sim.sampling.seed));
        let runs = tested_designs(study)
            .flat_map(|(name, values)| {
                samples.iter().map(move |t| PlannedRun {
                    design: name.clone(),
                    design_values: values.clone(),
                    theta: t.clone(),
                    role: RunRole::Sample,
                    extension: Vec::new(),
                    seed: 0,
                })
            })
            .collect();
        Plan { runs }
    }

    /// The solver-in-the-loop runs of the extension hypotheses `hypotheses` (indices into
    /// `study.diagnosis.hypotheses`; those without ranged variables plan nothing): per hypothesis,
    /// [`joint_samples`] Latin-hypercube points over θ × its ranges and `max(check_runs, 1)` check
    /// points, the same at every tested design.
    pub fn joint(study: &Study, sim: &SolverSimulation, hypotheses: &[usize]) -> Plan {
        let mut runs = Vec::new();
        for &k in hypotheses {
            let Some(extension) = study.diagnosis.hypotheses.get(k).and_then(|h| h.extension_spec()) else {
                continue;
            };
            if extension.ranges.is_empty() {
                continue;
            }
            let bounds = joint_bounds(study, &extension.ranges);
            let d = bounds.dim();
            let seed = sim.sampling.seed.wrapping_add(JOINT_SEED_OFFSET).wrapping_add(k as u64);
            let n = joint_samples(study, sim, d);
            let samples = planned_points(sim, &bounds, latin_hypercube(n, d, seed));
            let checks = planned_points(
                sim,
                &bounds,
                latin_hypercube(sim.sampling.check_runs.max(1), d, seed.wrapping_add(CHECK_SEED_OFFSET)),
            );
            let p = study.parameters.len();
            for (name, values) in tested_designs(study) {
                let at = |point: &Vec<f64>, role| PlannedRun {
                    design: name.clone(),
                    design_values: values.clone(),
                    theta: point[..p].to_vec(),
                    role,
                    extension: extension.at(&point[p..]),
                    seed: 0,
                };
                runs.extend(samples.iter().map(|x| at(x, RunRole::Joint(k))));
                runs.extend(checks.iter().map(|x| at(x, RunRole::JointCheck(k))));
            }
        }
        Plan { runs }
    }
}

/// The box of an extension's joint space: the study's parameters, then its ranged variables.
pub fn joint_bounds(study: &Study, ranges: &[Parameter]) -> Bounds {
    let all = study.parameters.iter().chain(ranges);
    Bounds::new(all.clone().map(|p| p.min).collect(), all.map(|p| p.max).collect())
}

/// Samples per design for a surrogate over `d` variables: twice the coefficients of a linear or
/// quadratic response surface (so that its fit has as many residual degrees of freedom as
/// coefficients), ten per dimension for a Gaussian process (Loeppky, Sacks & Welch 2009); never
/// fewer than the study's own `sampling.count`; the most any of the study's surrogates needs (its
/// curve components' too, when it is calibrated against curves).
pub fn joint_samples(study: &Study, sim: &SolverSimulation, d: usize) -> usize {
    let needed = |kind: SurrogateKind| match kind {
        SurrogateKind::Linear => 2 * (d + 1),
        SurrogateKind::Quadratic => (d + 1) * (d + 2),
        SurrogateKind::Gp => 10 * d,
    };
    // A study calibrated against curves fits its curve components' surrogates to the same runs.
    let curves = if study.calibration.against.curves {
        study.calibration.curve.surrogate.map_or(0, needed)
    } else {
        0
    };
    needed(sim.surrogate).max(curves).max(sim.sampling.count)
}

/// A point as the solver's fixed-width fields write it (the value the run will see), so that a
/// sequential batch's runs are fitted at exactly what the solver read.
pub fn as_written(sim: &SolverSimulation, point: &[f64]) -> Vec<f64> {
    point
        .iter()
        .map(|&v| match sim.inputs.parameter_width {
            Some(w) => lsdyna_keyword::field::fit_real(v, w).unwrap_or(v),
            None => v,
        })
        .collect()
}

/// The solver runs the fixed design `fixed` would have made in place of a sequential study's:
/// its samples and check runs, the extension hypotheses' runs at every sample, and the
/// solver-in-the-loop's joint plan for the hypotheses the sequence took into the loop (`looped`).
/// Planned, never run: the other side of the terminal's `246 → 45 solver runs`.
pub fn fixed_runs(study: &Study, sim: &SolverSimulation, fixed: &Sampling, looped: &[usize]) -> usize {
    let sim = SolverSimulation {
        sampling: fixed.clone(),
        surrogate: fixed.surrogate.unwrap_or(sim.surrogate),
        ..sim.clone()
    };
    Plan::new(study, &sim).runs.len() + Plan::joint(study, &sim, looped).runs.len()
}

/// Points of the unit cube (one per row) scaled to `bounds`; with a solver whose fixed-width number
/// fields read a rounded value, that value, so the surrogates are fitted at exactly what the solver
/// saw.
fn planned_points(sim: &SolverSimulation, bounds: &Bounds, unit: DMatrix<f64>) -> Vec<Vec<f64>> {
    let fit = |v: f64| match sim.inputs.parameter_width {
        Some(w) => lsdyna_keyword::field::fit_real(v, w).unwrap_or(v),
        None => v,
    };
    bounds
        .spread_rows(&unit)
        .into_iter()
        .map(|x| x.into_iter().map(fit).collect())
        .collect()
}

/// For each model-extension hypothesis, in study order, a copy of every baseline sample run with
/// the role [`RunRole::Extension`]: the same designs and parameter samples, so the extension's
/// surrogate lives on the baseline's points. They come after all baseline runs, so adding an
/// extension leaves the baseline's plan (and its run keys) as it was.
fn extension_runs(study: &Study, baseline: &[PlannedRun]) -> Vec<PlannedRun> {
    study
        .extension_hypotheses()
        .flat_map(|(k, h)| {
            let variables = h.extension().unwrap_or_default();
            baseline
                .iter()
                .filter(|r| r.role == RunRole::Sample)
                .map(move |r| PlannedRun {
                    role: RunRole::Extension(k),
                    extension: variables.to_vec(),
                    ..r.clone()
                })
        })
        .collect()
}

/// The samples in the unit cube, one row each.
fn unit_samples(sampling: &Sampling, p: usize) -> DMatrix<f64> {
    match sampling.method {
        SamplingMethod::Lhs | SamplingMethod::Sequential => latin_hypercube(sampling.count, p, sampling.seed),
        SamplingMethod::Grid => grid(Sampling::grid_side(sampling.count, p).unwrap_or(1), p),
    }
}

/// A full grid with `side` points per axis, ends included (one point: the centre).
pub fn grid(side: usize, p: usize) -> DMatrix<f64> {
    let n = side.pow(p as u32);
    let coordinate = |i: usize| {
        if side < 2 { 0.5 } else { i as f64 / (side - 1) as f64 }
    };
    DMatrix::from_fn(n, p, |row, k| coordinate(row / side.pow(k as u32) % side))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_covers_every_combination_with_ends() {
        let g = grid(3, 2);
        assert_eq!(g.nrows(), 9);
        let mut points: Vec<(u32, u32)> = (0..9)
            .map(|i| ((g[(i, 0)] * 2.0).round() as u32, (g[(i, 1)] * 2.0).round() as u32))
            .collect();
        points.sort();
        points.dedup();
        assert_eq!(points.len(), 9);
        assert_eq!(grid(1, 1)[(0, 0)], 0.5);
    }
}
