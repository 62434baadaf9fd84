//! The runs and tests as the planner sees them ([`crate::emulate::sequential::Site`]): per tested
//! design, the runs' points in the space and their outputs — the response, and with curves the
//! features the diagnosis reads, whitened by the specimens' scatter — and the tests' means and the
//! noise of those means, in the same units. Also the emulators' error measured on each design's
//! latest runs, which the emulator was not fitted to.

use nalgebra::DVector;

use crate::base::Bounds;
use crate::diagnose::features::{CurveDesign, Whitening};
use crate::diagnose::{NoiseModel, Observation, Role};
use crate::emulate::fits::{AcrossCurves, CurvesAcrossFit, Kind};
use crate::emulate::functional::FunctionalSurrogate;
use crate::emulate::sequential::Site;
use crate::emulate::{HeldOut, Run, Surrogate, gp, held_out};
use crate::extract::features::FeatureSpec;
use crate::study::{SolverSimulation, Study, SurrogateKind};

/// Fallback noise of a response without replicates: this fraction of its level (the tolerance is
/// then a fraction of it).
const NO_REPLICATES_CV: f64 = 0.005;

/// What the tests say, per tested design and output, in the units the planner works in.
pub struct Tests {
    /// Per tested design (training then validation): name, values, training?, observed, noise.
    pub designs: Vec<TestedDesign>,
    /// The specimens' whitening of the curve features (with curves).
    pub whitening: Option<(Whitening, FeatureSpec)>,
    /// The noise was measured (the tests have replicates), not the fallback share of the level.
    pub measured_noise: bool,
}

pub struct TestedDesign {
    pub name: String,
    pub values: Vec<f64>,
    pub training: bool,
    pub observed: Vec<f64>,
    pub noise: Vec<f64>,
}

impl TestedDesign {
    /// The unit a curve emulator across the designs takes this design's curves in: its tests' mean
    /// force ([`crate::emulate::functional::unit`]).
    pub fn scale(&self) -> f64 {
        crate::emulate::functional::unit(self.observed[0])
    }
}

impl Tests {
    /// The tests of `study`: the response's replicates (noise from the diagnosis's noise model),
    /// and the specimens' whitened features when `specimens` are given.
    pub fn of(study: &Study, specimens: Option<(&[CurveDesign], FeatureSpec)>) -> Tests {
        let alpha = crate::diagnose::Settings::default().alpha;
        let observations: Vec<Observation> = crate::plan::sweep::tested_designs(study)
            .filter_map(|(name, values)| {
                let t = study.experiments.get(name)?;
                let role = if study.split.training.contains(name) {
                    Role::Training
                } else {
                    Role::Validation
                };
                Some(Observation::from_replicates(
                    name.clone(),
                    values.clone(),
                    role,
                    &t.replicates,
                ))
            })
            .collect();
        let noise = crate::diagnose::noise::from_replicates(&observations, alpha);
        let whitening =
            specimens.and_then(|(d, spec)| Whitening::of_specimens(d, &spec, alpha).ok().map(|w| (w, spec)));
        let designs = observations
            .iter()
            .map(|o| {
                let tau = |nm: &NoiseModel| nm.sigma_at(o.mean);
                let sd = noise.as_ref().map_or(NO_REPLICATES_CV * o.mean.abs(), tau);
                let mut observed = vec![o.mean];
                let mut var = vec![(sd * sd / o.count.max(1) as f64).max(f64::MIN_POSITIVE)];
                if let (Some((w, spec)), Some((d, _))) = (&whitening, specimens) {
                    let specs = d.iter().find(|c| c.name == o.name);
                    let z: Vec<DVector<f64>> = specs
                        .map(|c| {
                            c.specimens
                                .iter()
                                .filter_map(|s| w.whiten(spec, &c.values, s.as_slice()))
                                .collect()
                        })
                        .unwrap_or_default();
                    let m = z.len().max(1) as f64;
                    for k in 0..w.read.len() {
                        observed.push(z.iter().map(|v| v[k]).sum::<f64>() / m);
                        var.push(w.variance / m);
                    }
                }
                TestedDesign {
                    name: o.name.clone(),
                    values: o.design.clone(),
                    training: o.role == Role::Training,
                    observed,
                    noise: var,
                }
            })
            .collect();
        Tests {
            designs,
            whitening,
            measured_noise: noise.is_some(),
        }
    }

    /// The values of the tested design `name` (empty for a design it does not test).
    pub fn values_of(&self, name: &str) -> &[f64] {
        self.designs
            .iter()
            .find(|t| t.name == name)
            .map_or(&[], |t| t.values.as_slice())
    }

    /// The outputs of one run: its response, then its curve's whitened features (NaN where missing).
    pub fn outputs(&self, design: &[f64], response: Option<f64>, curve: Option<&DVector<f64>>) -> Vec<f64> {
        let mut y = vec![response.unwrap_or(f64::NAN)];
        if let Some((w, spec)) = &self.whitening {
            let z = curve.and_then(|c| w.whiten(spec, design, c.as_slice()));
            y.extend((0..w.read.len()).map(|k| z.as_ref().map_or(f64::NAN, |z| z[k])));
        }
        y
    }
}

/// One run as the sites are built from it: its design, point in the space, batch, response, curve.
pub struct RunData<'a> {
    pub design: &'a str,
    pub point: Vec<f64>,
    pub batch: usize,
    pub response: Option<f64>,
    pub curve: Option<&'a DVector<f64>>,
}

/// The planner's sites: every tested design with its runs' points and outputs.
pub fn sites(tests: &Tests, runs: &[RunData]) -> Vec<Site> {
    use rayon::prelude::*;
    tests
        .designs
        .par_iter()
        .map(|t| {
            let mine: Vec<&RunData> = runs.iter().filter(|r| r.design == t.name).collect();
            Site {
                name: t.name.clone(),
                training: t.training,
                x: mine.iter().map(|r| r.point.clone()).collect(),
                y: mine
                    .iter()
                    .map(|r| tests.outputs(&t.values, r.response, r.curve))
                    .collect(),
                observed: t.observed.clone(),
                noise: t.noise.clone(),
            }
        })
        .collect()
}

/// How a design's emulators did on its latest runs, fitted without them, in units of the tests'
/// noise of the mean.
#[derive(Debug, Clone, Copy)]
pub struct Held {
    /// The root mean square error, the largest over the outputs (infinite: the emulators could
    /// not be fitted without the runs, or could not predict them).
    pub rms: f64,
    /// The response's mean signed error, run − emulator (NaN where `rms` is infinite): the part of
    /// it the parameters absorb moves their fit, not the residuals ([`super::absorbed`]).
    pub bias: f64,
}

impl Held {
    const FAILED: Held = Held {
        rms: f64::INFINITY,
        bias: f64::NAN,
    };
}

/// How each tested design's emulators did on its latest runs, fitted without them ([`Held`];
/// `None`: the design has runs of one batch only, so nothing was held out yet).
pub fn measured_errors(
    tests: &Tests,
    runs: &[RunData],
    kinds: (SurrogateKind, Option<SurrogateKind>),
    bounds: &Bounds,
) -> Vec<Option<Held>> {
    use rayon::prelude::*;
    let response = Kind::new(kinds.0, bounds.clone());
    let curves = kinds.1.map(|kind| Kind {
        fallback: true,
        ..Kind::new(kind, bounds.clone())
    });
    tests
        .designs
        .par_iter()
        .map(|t| {
            let mine: Vec<&RunData> = runs.iter().filter(|r| r.design == t.name).collect();
            let last = mine.iter().map(|r| r.batch).max()?;
            if mine.iter().all(|r| r.batch == last) {
                return None;
            }
            Some(held_out_error(tests, t, &mine, last, (&response, curves.as_ref())))
        })
        .collect()
}

/// The study's own emulators of a design (the response's surrogate, the curve emulator) fitted to
/// its runs before batch `last`, at that batch ([`Held`]).
fn held_out_error(
    tests: &Tests,
    t: &TestedDesign,
    mine: &[&RunData],
    last: usize,
    kinds: (&Kind, Option<&Kind>),
) -> Held {
    let held = |i: usize| mine[i].batch == last;
    let response_runs: Vec<Run<f64>> = mine.iter().map(|r| r.response_run(tests)).collect();
    let Ok(response) = held_out::<Surrogate>(kinds.0, &response_runs, &|r| held(index(&response_runs, r))) else {
        return Held::FAILED;
    };
    let curves = match kinds.1 {
        Some(kind) => {
            let curve_runs: Vec<Run<DVector<f64>>> = mine.iter().map(|r| r.curve_run(tests)).collect();
            match held_out::<FunctionalSurrogate>(kind, &curve_runs, &|r| held(index(&curve_runs, r))) {
                Ok(c) => Some(c),
                Err(_) => return Held::FAILED,
            }
        }
        None => None,
    };
    let latest: Vec<usize> = (0..mine.len()).filter(|&i| held(i)).collect();
    let emulated: Vec<Emulated> = latest
        .iter()
        .map(|&i| Emulated::at(i, &response, curves.as_ref()))
        .collect();
    let held_runs: Vec<&RunData> = latest.iter().map(|&i| mine[i]).collect();
    rms_in_noise(tests, t, &held_runs, &emulated)
}

/// With one emulator across the designs ([`crate::emulate::sequential::shared`]): per tested
/// design, the emulators fitted to every run but the design's latest batch — the planner's
/// Gaussian process of the response over the designs, and with curves the study's curve emulator
/// across the designs ([`CurvesAcrossFit`]) — their RMS error there in units of the tests' noise of
/// the mean ([`Held`]; `None`: the design has no run yet).
pub fn measured_errors_across(tests: &Tests, runs: &[RunData], bounds: &Bounds) -> Vec<Option<Held>> {
    use rayon::prelude::*;
    let values: Vec<Vec<f64>> = tests.designs.iter().map(|t| t.values.clone()).collect();
    let joint = crate::emulate::sequential::shared::joint_bounds(&values, bounds);
    let curves = AcrossCurves {
        joint: joint.clone(),
        units: tests.designs.iter().map(|t| (t.values.clone(), t.scale())).collect(),
    };
    // The planner's Gaussian process learns from the runs site by site, in the tested designs'
    // order; the curve emulator from the runs in their own order.
    let ordered: Vec<usize> = tests
        .designs
        .iter()
        .flat_map(|t| (0..runs.len()).filter(move |&i| runs[i].design == t.name))
        .collect();
    let response_runs: Vec<Run<f64>> = ordered.iter().map(|&i| runs[i].response_run(tests)).collect();
    let curve_runs: Vec<Run<DVector<f64>>> = runs.iter().map(|r| r.curve_run(tests)).collect();
    (0..tests.designs.len())
        .into_par_iter()
        .map(|s| {
            let t = &tests.designs[s];
            let last = runs.iter().filter(|r| r.design == t.name).map(|r| r.batch).max()?;
            let held = |i: usize| runs[i].design == t.name && runs[i].batch == last;
            let fitted = held_out::<gp::Emulator>(&joint, &response_runs, &|r| held(ordered[index(&response_runs, r)]));
            let Ok(mut response) = fitted else {
                return Some(Held::FAILED);
            };
            response.runs = response.runs.iter().map(|&k| ordered[k]).collect();
            let curves = match tests.whitening {
                Some(_) => match held_out::<CurvesAcrossFit>(&curves, &curve_runs, &|r| held(index(&curve_runs, r))) {
                    Ok(c) => Some(c),
                    Err(_) => return Some(Held::FAILED),
                },
                None => None,
            };
            let latest: Vec<usize> = (0..runs.len()).filter(|&i| held(i)).collect();
            let emulated: Vec<Emulated> = latest
                .iter()
                .map(|&i| Emulated::at(i, &response, curves.as_ref()))
                .collect();
            let held_runs: Vec<&RunData> = latest.iter().map(|&i| &runs[i]).collect();
            Some(rms_in_noise(tests, t, &held_runs, &emulated))
        })
        .collect()
}

/// A run's index among `all` (the runs are borrowed from one slice: found by their point's address).
fn index<Y>(all: &[Run<'_, Y>], r: &Run<'_, Y>) -> usize {
    all.iter()
        .position(|a| std::ptr::eq(a.x, r.x))
        .expect("a run of the slice")
}

/// What the emulators predicted at a held-out run: its response (`None`: the run has none to
/// compare), and with curves its curve (`Some(None)`: the run has no curve).
struct Emulated {
    response: Option<f64>,
    curve: Option<Option<DVector<f64>>>,
}

impl Emulated {
    /// The predictions at run `i` (an index of the runs the checks were made on).
    fn at(i: usize, response: &HeldOut<f64>, curves: Option<&HeldOut<DVector<f64>>>) -> Emulated {
        let of = |h: &HeldOut<DVector<f64>>| h.runs.iter().position(|&j| j == i).map(|k| h.predicted[k].clone());
        Emulated {
            response: response
                .runs
                .iter()
                .position(|&j| j == i)
                .map(|k| response.predicted[k]),
            curve: curves.map(of),
        }
    }
}

impl RunData<'_> {
    /// The run as the response's emulators take it.
    fn response_run<'t>(&'t self, tests: &'t Tests) -> Run<'t, f64> {
        Run {
            design: self.design,
            values: tests.values_of(self.design),
            x: &self.point,
            y: self.response.as_ref(),
        }
    }

    /// The run as the curves' emulators take it.
    fn curve_run<'t>(&'t self, tests: &'t Tests) -> Run<'t, DVector<f64>> {
        Run {
            design: self.design,
            values: tests.values_of(self.design),
            x: &self.point,
            y: self.curve,
        }
    }
}

/// The errors over `held` of the emulated outputs, in units of the tests' noise of the mean
/// ([`Held`]: failed where nothing could be compared, or an emulator could not predict). A run
/// without an output is skipped: its truth is not there.
fn rms_in_noise(tests: &Tests, t: &TestedDesign, held: &[&RunData], emulated: &[Emulated]) -> Held {
    let mut sq = vec![0.0; t.observed.len()];
    let mut sum = 0.0;
    let mut n = 0usize;
    for (r, e) in held.iter().zip(emulated) {
        let Some(y) = e.response else { continue };
        if y.is_nan() {
            return Held::FAILED;
        }
        let curve = match &e.curve {
            Some(None) => continue,
            Some(Some(c)) => Some(c),
            None => None,
        };
        let truth = tests.outputs(&t.values, r.response, r.curve);
        let emulated = tests.outputs(&t.values, Some(y), curve);
        if truth.iter().chain(&emulated).any(|v| !v.is_finite()) {
            continue;
        }
        n += 1;
        sum += (truth[0] - emulated[0]) / t.noise[0].sqrt();
        for k in 0..sq.len() {
            sq[k] += (truth[k] - emulated[k]).powi(2) / t.noise[k];
        }
    }
    if n == 0 {
        return Held::FAILED;
    }
    Held {
        rms: sq.iter().map(|s| (s / n as f64).sqrt()).fold(0.0, f64::max),
        bias: sum / n as f64,
    }
}

pub use crate::emulate::fits::kind_for;

/// The response's and the curves' surrogate kinds of a study.
pub fn kinds(study: &Study, sim: &SolverSimulation) -> (SurrogateKind, Option<SurrogateKind>) {
    let curves = study
        .calibration
        .against
        .curves
        .then(|| study.calibration.curve.surrogate.unwrap_or(sim.surrogate));
    (sim.surrogate, curves)
}
