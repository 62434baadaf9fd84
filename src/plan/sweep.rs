//! The run plan of a solver study: for every training and validation design, the parameter
//! samples of `simulation.sampling` (Latin hypercube or full grid) plus `check_runs` extra Latin
//! hypercube points from a different seed stream, at which the fitted surrogate is checked; then,
//! for each model-extension hypothesis, the sample runs again with the extension's variables.
//!
//! Every design gets the same parameter samples (the paper's "12 yield-stress samples per design"),
//! so the plan is a fixed function of the study: the same study always plans the same runs.

use nalgebra::DMatrix;

use super::latin_hypercube;
use crate::study::solver::{Sampling, SamplingMethod};
use crate::study::{SolverSimulation, Study};

/// Added to the sampling seed for the check points, so they are not the samples' stream.
const CHECK_SEED_OFFSET: u64 = 0x636865636b; // "check"

/// Why a run is planned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RunRole {
    /// A sample the surrogate is fitted to.
    Sample,
    /// A point the fitted surrogate is checked at (not used to fit it).
    Check,
    /// A sample of the model extension of hypothesis `k` (`study.diagnosis.hypotheses[k]`): the
    /// same design and parameters as a baseline sample, rendered with the extension's variables.
    Extension(usize),
}

impl RunRole {
    pub fn key(self) -> &'static str {
        match self {
            RunRole::Sample => "sample",
            RunRole::Check => "check",
            RunRole::Extension(_) => "extension",
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
}

/// Every run a study needs, designs in study order (training, then validation); per design the
/// samples, then the check points.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    pub runs: Vec<PlannedRun>,
}

impl Plan {
    /// Plans the runs of a solver study.
    pub fn new(study: &Study, sim: &SolverSimulation) -> Plan {
        let bounds = study.parameter_bounds();
        let p = bounds.dim();
        let scale = |unit: DMatrix<f64>| -> Vec<Vec<f64>> {
            (0..unit.nrows())
                .map(|i| {
                    (0..p)
                        .map(|k| bounds.lower[k] + unit[(i, k)] * bounds.width()[k])
                        .collect()
                })
                .collect()
        };
        // A solver with fixed-width number fields reads a rounded value: plan that value, so the
        // surrogates are fitted at exactly what the solver saw.
        let fit = |v: f64| match sim.parameter_width {
            Some(w) => crate::render::lsdyna::field::fit_real(v, w).unwrap_or(v),
            None => v,
        };
        let rounded = |rows: Vec<Vec<f64>>| -> Vec<Vec<f64>> {
            rows.into_iter().map(|r| r.into_iter().map(fit).collect()).collect()
        };
        let samples = rounded(scale(unit_samples(&sim.sampling, p)));
        let checks = rounded(scale(latin_hypercube(
            sim.sampling.check_runs,
            p,
            sim.sampling.seed.wrapping_add(CHECK_SEED_OFFSET),
        )));
        let mut runs = Vec::new();
        for name in study.training.iter().chain(&study.validation) {
            let Some(test) = study.experiments.get(name) else {
                continue;
            }; // validated: always there
            let at = |theta: &Vec<f64>, role| PlannedRun {
                design: name.clone(),
                design_values: test.values.clone(),
                theta: theta.clone(),
                role,
            };
            runs.extend(samples.iter().map(|t| at(t, RunRole::Sample)));
            runs.extend(checks.iter().map(|t| at(t, RunRole::Check)));
        }
        runs.extend(extension_runs(study, &runs));
        Plan { runs }
    }
}

/// For each model-extension hypothesis, in study order, a copy of every baseline sample run with
/// the role [`RunRole::Extension`]: the same designs and parameter samples, so the extension's
/// surrogate lives on the baseline's points. They come after all baseline runs, so adding an
/// extension leaves the baseline's plan (and its run keys) as it was.
fn extension_runs(study: &Study, baseline: &[PlannedRun]) -> Vec<PlannedRun> {
    study
        .extension_hypotheses()
        .flat_map(|(k, _)| {
            baseline
                .iter()
                .filter(|r| r.role == RunRole::Sample)
                .map(move |r| PlannedRun {
                    role: RunRole::Extension(k),
                    ..r.clone()
                })
        })
        .collect()
}

/// The samples in the unit cube, one row each.
fn unit_samples(sampling: &Sampling, p: usize) -> DMatrix<f64> {
    match sampling.method {
        SamplingMethod::Lhs => latin_hypercube(sampling.count, p, sampling.seed),
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
