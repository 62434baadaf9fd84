//! Force–displacement curves for the report, recorded by `lab run` into `report-data.json`.
//!
//! Per tested design of the study: the simulated curves of its runs (a `crush_force` response: the
//! same rcforc/nodout histories the response was extracted from, read from the run's directory or,
//! for a replayed run, its recording) and the test machine's curves of its specimens
//! (`experiments.curves`). Both in mm and kN, compression positive.
//!
//! What is kept, so that the page stays small whatever the study's size:
//! - at most [`MAX_RUNS`] runs per design: the run nearest the calibrated parameters, the runs with
//!   the lowest and highest response (the family's envelope) and runs evenly spaced in response
//!   between them — a faithful picture of the spread without drawing every run;
//! - at most [`MAX_TESTS`] specimens per design;
//! - at most [`MAX_POINTS`] points per curve: the points are cut into equal runs and each run keeps
//!   its lowest and highest force, in order, so peaks and troughs survive the thinning.

use std::path::PathBuf;

use super::answer::Model;
use super::data::{Curve, DesignCurves, Reference};
use crate::extract::crush::{self, ForceDisplacement, SimSource, Window};
use crate::plan::{Plan, RunRole};
use crate::study::{Response, Simulation, Study};

/// Simulated curves drawn per design.
pub const MAX_RUNS: usize = 9;
/// Test specimens drawn per design.
pub const MAX_TESTS: usize = 12;
/// Points per drawn curve.
pub const MAX_POINTS: usize = 300;

/// Where a solver study's runs and their outputs are.
pub struct RunOutputs<'a> {
    pub plan: &'a Plan,
    /// Run keys, in plan order.
    pub keys: &'a [String],
    /// Responses, in plan order (`None`: the run failed or has no record).
    pub responses: &'a [Option<f64>],
    /// Directories holding outputs as `<dir>/<key>/`, searched in order: the run store's run
    /// directories first (live runs), then the replay directories (replayed runs).
    pub dirs: Vec<PathBuf>,
}

/// The curves of every tested design that has any: the study's training then validation designs.
/// `reference`: the calibrated parameters the nearest run is picked for.
pub fn design_curves(study: &Study, runs: Option<&RunOutputs>, reference: Option<&Reference>) -> Vec<DesignCurves> {
    let crush = match &study.simulation {
        Simulation::Solver(sim) => match &sim.response {
            Response::CrushForce { window, source } => Some((*window, source)),
            _ => None,
        },
        Simulation::Expression(_) => None,
    };
    // Only a crush-force response has a stroke window; the tests' curves are drawn without one otherwise.
    let window = crush.map(|(w, _)| w);
    let mut out = Vec::new();
    for design in study.split.training.iter().chain(&study.split.validation) {
        let (simulations, nearest, count) = match (runs, crush) {
            (Some(runs), Some((w, source))) => simulated(study, runs, design, w, source, reference),
            _ => (Vec::new(), None, 0),
        };
        let (tests, tests_total) = tested(study, design, window);
        if simulations.is_empty() && tests.is_empty() {
            continue;
        }
        out.push(DesignCurves {
            design: design.clone(),
            window: window.map(|w| [w.s0, w.s1]),
            simulations,
            tests,
            runs: count,
            nearest,
            reference: nearest.and(reference.cloned()),
            tests_total,
            recommended: None,
        });
    }
    out
}

/// The drawn runs of `design` (sorted by response), the index of the one nearest `reference`, and
/// how many successful runs the design has.
fn simulated(
    study: &Study,
    runs: &RunOutputs,
    design: &str,
    window: Window,
    source: &SimSource,
    reference: Option<&Reference>,
) -> (Vec<Curve>, Option<usize>, usize) {
    let ok: Vec<(usize, f64)> = runs
        .plan
        .runs
        .iter()
        .enumerate()
        .filter(|(_, r)| r.design == design && matches!(r.role, RunRole::Sample | RunRole::Check))
        .filter_map(|(i, _)| runs.responses.get(i).copied().flatten().map(|y| (i, y)))
        .collect();
    let bounds = study.parameter_bounds();
    let scale: Vec<f64> = (0..bounds.dim())
        .map(|k| (bounds.upper[k] - bounds.lower[k]).abs().max(f64::MIN_POSITIVE))
        .collect();
    let thetas: Vec<&[f64]> = ok.iter().map(|&(i, _)| runs.plan.runs[i].theta.as_slice()).collect();
    let near = reference.and_then(|r| nearest(&thetas, &r.parameters, &scale));
    let responses: Vec<f64> = ok.iter().map(|p| p.1).collect();
    let mut picked = pick(&responses, near, MAX_RUNS);
    picked.sort_by(|&a, &b| responses[a].total_cmp(&responses[b]));
    // Read side by side (each read parses two history files).
    let read: Vec<_> = {
        use rayon::prelude::*;
        picked
            .par_iter()
            .map(|&j| match &study.simulation {
                Simulation::Solver(sim) => crate::extract::adapters::run_curve(sim, &runs.dirs, &runs.keys[ok[j].0]),
                Simulation::Expression(_) => crush::read_run(&runs.dirs, &runs.keys[ok[j].0], source),
            })
            .collect()
    };
    let mut curves = Vec::new();
    let mut nearest_at = None;
    for (j, curve) in picked.into_iter().zip(read) {
        let (i, y) = ok[j];
        let Some(curve) = curve else {
            continue;
        };
        if Some(j) == near {
            nearest_at = Some(curves.len());
        }
        let theta = runs.plan.runs[i].theta.clone();
        let label = parameter_text(study, &theta);
        let mut c = thin(label, &curve);
        c.parameters = theta;
        c.mean_force = crush::crush_force(&curve, window)
            .ok()
            .map(|r| r.mean_force)
            .or(Some(y));
        curves.push(c);
    }
    (curves, nearest_at, ok.len())
}

/// The specimens of `design` (at most [`MAX_TESTS`]) and how many it has.
fn tested(study: &Study, design: &str, window: Option<Window>) -> (Vec<Curve>, usize) {
    let Some(sc) = study.experiments.curves.iter().find(|c| c.design == design) else {
        return (Vec::new(), 0);
    };
    let curves = sc
        .specimens
        .iter()
        .take(MAX_TESTS)
        .map(|(file, curve)| {
            let label = file
                .file_stem()
                .map_or_else(|| file.display().to_string(), |s| s.to_string_lossy().into_owned());
            let mut c = thin(label, curve);
            c.mean_force = window
                .and_then(|w| crush::crush_force(curve, w).ok())
                .map(|r| r.mean_force);
            c
        })
        .collect();
    (curves, sc.specimens.len())
}

/// `sigma_y = 198.9 MPa, …`: a run's parameters with their units.
fn parameter_text(study: &Study, theta: &[f64]) -> String {
    study
        .parameters
        .iter()
        .zip(theta)
        .map(|(p, v)| {
            let v = super::plots::short(*v, 4);
            match &p.unit {
                Some(u) => format!("{} = {v} {u}", p.name),
                None => format!("{} = {v}", p.name),
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Per tested design, the solver's run of the recommended `model` nearest its fitted point (among
/// the runs of `sets`: the study's, the loop's and the confirmation's), with how far it lies from
/// that point (the largest offset, as a fraction of each variable's range). A model that adds a
/// correction term to the simulation has no run of its own: none is drawn.
pub fn recommended_curves(study: &Study, sets: &[RunOutputs], model: &Model) -> Vec<(String, Curve, f64)> {
    if model.correction.is_some() {
        return Vec::new();
    }
    let Simulation::Solver(sim) = &study.simulation else {
        return Vec::new();
    };
    let ranges: Vec<(&str, f64, f64)> = study
        .parameters
        .iter()
        .map(|p| (p.name.as_str(), p.min, p.max))
        .chain(
            study
                .diagnosis
                .hypotheses
                .iter()
                .flat_map(|h| h.ranges())
                .map(|r| (r.name.as_str(), r.min, r.max)),
        )
        .collect();
    let target: Vec<(&str, f64)> = model
        .parameters
        .iter()
        .chain(&model.variables)
        .map(|q| (q.name.as_str(), q.value))
        .collect();
    let offset = |run: &crate::plan::PlannedRun| -> Option<f64> {
        // A run of this model: the model's extension variables set, and no others.
        if run.extension.len() != model.variables.len() {
            return None;
        }
        let value = |name: &str| {
            let k = study.parameters.iter().position(|p| p.name == name);
            k.map(|k| run.theta[k])
                .or(run.extension.iter().find(|(n, _)| n == name).map(|v| v.1))
        };
        target.iter().try_fold(0.0_f64, |worst, (name, at)| {
            let (_, lo, hi) = ranges.iter().find(|r| r.0 == *name)?;
            Some(worst.max((value(name)? - at).abs() / (hi - lo).abs().max(f64::MIN_POSITIVE)))
        })
    };
    let mut out = Vec::new();
    for design in study.split.training.iter().chain(&study.split.validation) {
        let best = sets
            .iter()
            .flat_map(|set| set.plan.runs.iter().enumerate().map(move |(i, r)| (set, i, r)))
            .filter(|(set, i, r)| &r.design == design && set.responses.get(*i).copied().flatten().is_some())
            .filter_map(|(set, i, r)| Some((set, i, offset(r)?)))
            .min_by(|a, b| a.2.total_cmp(&b.2));
        let Some((set, i, far)) = best else {
            continue;
        };
        let Some(curve) = crate::extract::adapters::run_curve(sim, &set.dirs, &set.keys[i]) else {
            continue;
        };
        let run = &set.plan.runs[i];
        let mut c = thin(parameter_text(study, &run.theta), &curve);
        for (name, v) in &run.extension {
            let unit = study
                .diagnosis
                .hypotheses
                .iter()
                .flat_map(|h| h.ranges())
                .find(|r| &r.name == name);
            let unit = unit
                .and_then(|r| r.unit.as_ref())
                .map_or(String::new(), |u| format!(" {u}"));
            c.label
                .push_str(&format!(", {name} = {}{unit}", super::plots::short(*v, 4)));
        }
        c.parameters = run.theta.clone();
        if let Response::CrushForce { window, .. } = &sim.response {
            c.mean_force = crush::crush_force(&curve, *window).ok().map(|r| r.mean_force);
        }
        out.push((design.clone(), c, far));
    }
    out
}

/// Index of the point of `thetas` nearest `at`, each parameter scaled by its range.
fn nearest(thetas: &[&[f64]], at: &[f64], scale: &[f64]) -> Option<usize> {
    let distance = |t: &[f64]| -> f64 {
        t.iter()
            .zip(at)
            .zip(scale)
            .map(|((a, b), s)| ((a - b) / s).powi(2))
            .sum()
    };
    (0..thetas.len()).min_by(|&a, &b| distance(thetas[a]).total_cmp(&distance(thetas[b])))
}

/// At most `cap` of the indices of `values`: `keep` (when given), the lowest and the highest, and
/// the rest evenly spaced in rank between them.
fn pick(values: &[f64], keep: Option<usize>, cap: usize) -> Vec<usize> {
    let n = values.len();
    if n <= cap {
        return (0..n).collect();
    }
    let mut by_rank: Vec<usize> = (0..n).collect();
    by_rank.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
    let spread = cap - usize::from(keep.is_some());
    let mut out: Vec<usize> = keep.into_iter().collect();
    for j in 0..spread {
        let rank = (j as f64 * (n - 1) as f64 / (spread - 1).max(1) as f64).round() as usize;
        out.push(by_rank[rank]);
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// The curve thinned to at most [`MAX_POINTS`] points.
fn thin(label: String, curve: &ForceDisplacement) -> Curve {
    let (displacement, force) = decimate(&curve.displacement, &curve.force, MAX_POINTS);
    Curve {
        label,
        displacement,
        force,
        parameters: Vec::new(),
        mean_force: None,
        points: curve.displacement.len(),
    }
}

/// At most `max` (≥ 4) of the points (d, f), in order: the first and the last, and from each of
/// (max − 2) / 2 equal runs of the points between them, the points of lowest and highest force.
pub fn decimate(d: &[f64], f: &[f64], max: usize) -> (Vec<f64>, Vec<f64>) {
    let n = d.len().min(f.len());
    if n <= max {
        return (d[..n].to_vec(), f[..n].to_vec());
    }
    let inner = n - 2;
    let bins = (max.max(4) - 2) / 2;
    let mut keep = vec![0];
    for b in 0..bins {
        let (lo, hi) = (1 + b * inner / bins, 1 + (b + 1) * inner / bins);
        if lo >= hi {
            continue;
        }
        let by_force = |a: &usize, b: &usize| f[*a].total_cmp(&f[*b]);
        let low = (lo..hi).min_by(by_force).expect("non-empty run");
        let high = (lo..hi).max_by(by_force).expect("non-empty run");
        keep.push(low.min(high));
        if low != high {
            keep.push(low.max(high));
        }
    }
    keep.push(n - 1);
    (
        keep.iter().map(|&i| d[i]).collect(),
        keep.iter().map(|&i| f[i]).collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_keeps_every_peak_and_trough_of_its_bin() {
        // A fold-like signal: 5000 points, a spike at one sample.
        let n = 5000;
        let d: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
        let mut f: Vec<f64> = d.iter().map(|x| 10.0 + (7.0 * x).sin()).collect();
        f[1234] = 50.0;
        f[3000] = -5.0;
        let (dd, ff) = decimate(&d, &f, 300);
        assert!(dd.len() <= 300, "{}", dd.len());
        assert_eq!((dd[0], *dd.last().unwrap()), (0.0, d[n - 1]));
        assert!(ff.contains(&50.0) && ff.contains(&-5.0), "the extremes survive");
        assert!(dd.windows(2).all(|w| w[1] > w[0]), "order kept");
        let max_in = |v: &[f64]| v.iter().copied().fold(f64::MIN, f64::max);
        assert_eq!(max_in(&ff), max_in(&f));
        // Short curves are kept whole.
        let (d2, f2) = decimate(&d[..100], &f[..100], 300);
        assert_eq!((d2.len(), f2.len()), (100, 100));
    }

    #[test]
    fn picks_the_envelope_the_nearest_and_an_even_spread() {
        let values: Vec<f64> = (0..17).map(|i| ((i * 7) % 17) as f64).collect();
        let picked = pick(&values, Some(5), 9);
        assert!(picked.len() <= 9 && picked.len() >= 8, "{picked:?}");
        assert!(picked.contains(&5), "the nearest run is kept");
        let lowest = (0..17).min_by(|&a, &b| values[a].total_cmp(&values[b])).unwrap();
        let highest = (0..17).max_by(|&a, &b| values[a].total_cmp(&values[b])).unwrap();
        assert!(picked.contains(&lowest) && picked.contains(&highest), "{picked:?}");
        assert_eq!(pick(&values[..4], None, 9), vec![0, 1, 2, 3]);
    }

    #[test]
    fn nearest_scales_each_parameter_by_its_range() {
        let a = [100.0, 0.5];
        let b = [190.0, 0.1];
        let thetas: Vec<&[f64]> = vec![&a, &b];
        // Unscaled, a is nearer (10 against 80 in the first coordinate); scaled by the ranges, the
        // second coordinate's 0.4 outweighs that and b is.
        assert_eq!(nearest(&thetas, &[110.0, 0.1], &[1000.0, 1.0]), Some(1));
        assert_eq!(nearest(&thetas, &[110.0, 0.5], &[1000.0, 1.0]), Some(0));
        assert_eq!(nearest(&[], &[1.0], &[1.0]), None);
    }
}
