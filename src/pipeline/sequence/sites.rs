//! The runs and tests as the planner sees them ([`crate::emulate::sequential::Site`]): per tested
//! design, the runs' points in the space and their outputs — the response, and with curves the
//! features the diagnosis reads, whitened by the specimens' scatter — and the tests' means and the
//! noise of those means, in the same units. Also the emulators' error measured on each design's
//! latest runs, which the emulator was not fitted to.

use nalgebra::DVector;

use crate::base::Bounds;
use crate::diagnose::features::{CurveDesign, Whitening};
use crate::diagnose::{NoiseModel, Observation, Role};
use crate::emulate::Surrogate;
use crate::emulate::functional::{AcrossRun, CurvesAcross, FunctionalSurrogate};
use crate::emulate::sequential::Site;
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
                let role = if study.training.contains(name) {
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
        Tests { designs, whitening }
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

impl<'a> RunData<'a> {
    fn copy(&self) -> RunData<'a> {
        RunData {
            point: self.point.clone(),
            ..*self
        }
    }
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

/// How each tested design's emulators did on its latest runs, fitted without them: the root mean
/// square error in units of the tests' noise of the mean, the largest over the outputs (`None`:
/// the design has runs of one batch only, so nothing was held out yet; infinite: the emulators
/// could not be fitted without them).
pub fn measured_errors(
    tests: &Tests,
    runs: &[RunData],
    kinds: (SurrogateKind, Option<SurrogateKind>),
    bounds: &Bounds,
) -> Vec<Option<f64>> {
    use rayon::prelude::*;
    tests
        .designs
        .par_iter()
        .map(|t| {
            let mine: Vec<&RunData> = runs.iter().filter(|r| r.design == t.name).collect();
            let last = mine.iter().map(|r| r.batch).max()?;
            let (fit, held): (Vec<&RunData>, Vec<&RunData>) = mine.into_iter().partition(|r| r.batch < last);
            if fit.is_empty() {
                return None;
            }
            Some(held_out_error(tests, t, &fit, &held, kinds, bounds))
        })
        .collect()
}

/// With one emulator across the designs ([`crate::emulate::sequential::shared`]): per tested design,
/// the emulators fitted to every run but the design's latest batch — the response's, and with
/// curves the study's curve emulator across the designs ([`CurvesAcross`]) — their RMS error there
/// in units of the tests' noise of the mean, the largest over the outputs (`None`: the design has
/// no run yet; infinite: the emulators could not be fitted without them).
pub fn measured_errors_across(tests: &Tests, runs: &[RunData], bounds: &Bounds) -> Vec<Option<f64>> {
    use rayon::prelude::*;
    let values: Vec<Vec<f64>> = tests.designs.iter().map(|t| t.values.clone()).collect();
    let joint = crate::emulate::sequential::shared::joint_bounds(&values, bounds);
    (0..tests.designs.len())
        .into_par_iter()
        .map(|s| {
            let name = &tests.designs[s].name;
            let last = runs
                .iter()
                .filter(|r| r.design == name.as_str())
                .map(|r| r.batch)
                .max()?;
            let held = |r: &RunData| r.design == name.as_str() && r.batch == last;
            let kept: Vec<RunData> = runs.iter().filter(|r| !held(r)).map(RunData::copy).collect();
            // With curves their features come from the curve emulator below: the planner's
            // emulators are fitted for the response alone.
            let mut kept_sites = sites(tests, &kept);
            if tests.whitening.is_some() {
                kept_sites.iter_mut().for_each(response_only);
            }
            let emus = crate::emulate::sequential::shared::emulators(&values, bounds, &kept_sites);
            let curves = match tests.whitening {
                Some(_) => match curves_across(tests, &kept, &joint) {
                    Ok(c) => Some(c.at(&values[s], tests.designs[s].scale())),
                    Err(_) => return Some(f64::INFINITY),
                },
                None => None,
            };
            let t = &tests.designs[s];
            let held: Vec<&RunData> = runs.iter().filter(|r| held(r)).collect();
            let emulated = |r: &RunData| {
                let y = emus[s].predict(&r.point)?;
                let curve = curves.as_ref().map(|c| c.predict(&r.point));
                Some(tests.outputs(&t.values, Some(y[0]), curve.as_ref()))
            };
            Some(rms_in_noise(tests, t, &held, &emulated))
        })
        .collect()
}

/// A site's first output, the response, alone.
fn response_only(site: &mut Site) {
    site.y.iter_mut().for_each(|y| y.truncate(1));
    site.observed.truncate(1);
    site.noise.truncate(1);
}

/// The study's curve emulator across the designs fitted to `runs` ([`CurvesAcross`]), each design's
/// curves in units of its tests' mean force.
fn curves_across(tests: &Tests, runs: &[RunData], joint: &Bounds) -> Result<CurvesAcross, crate::emulate::FitError> {
    let rows: Vec<AcrossRun> = runs
        .iter()
        .filter_map(|r| {
            let t = tests.designs.iter().find(|t| t.name == r.design)?;
            Some(AcrossRun {
                design: &t.values,
                theta: &r.point,
                curve: r.curve?,
                scale: t.scale(),
            })
        })
        .collect();
    CurvesAcross::fit(&rows, joint)
}

/// The RMS error over `held` of the emulated outputs per output, in units of the tests' noise of
/// the mean, the largest over the outputs (infinite where nothing could be emulated).
fn rms_in_noise(
    tests: &Tests,
    t: &TestedDesign,
    held: &[&RunData],
    emulated: &dyn Fn(&RunData) -> Option<Vec<f64>>,
) -> f64 {
    let mut sq = vec![0.0; t.observed.len()];
    let mut n = 0usize;
    for r in held {
        let truth = tests.outputs(&t.values, r.response, r.curve);
        let Some(emulated) = emulated(r) else {
            return f64::INFINITY;
        };
        if truth.iter().chain(&emulated).any(|v| !v.is_finite()) {
            continue;
        }
        n += 1;
        for k in 0..sq.len() {
            sq[k] += (truth[k] - emulated[k]).powi(2) / t.noise[k];
        }
    }
    if n == 0 {
        return f64::INFINITY;
    }
    sq.iter().map(|s| (s / n as f64).sqrt()).fold(0.0, f64::max)
}

/// The study's own emulators (the response's surrogate, the curve emulator) fitted to `fit`, at
/// `held`: RMS error per output over the held-out runs, in units of √τ², the largest.
fn held_out_error(
    tests: &Tests,
    t: &TestedDesign,
    fit: &[&RunData],
    held: &[&RunData],
    (response_kind, curve_kind): (SurrogateKind, Option<SurrogateKind>),
    bounds: &Bounds,
) -> f64 {
    let samples: Vec<(Vec<f64>, f64)> = fit
        .iter()
        .filter_map(|r| r.response.map(|y| (r.point.clone(), y)))
        .collect();
    let surrogate = match Surrogate::fit(response_kind, &samples, bounds) {
        Ok(s) => s,
        Err(_) => return f64::INFINITY,
    };
    let curves = match curve_kind {
        Some(kind) => {
            let runs: Vec<(Vec<f64>, DVector<f64>)> = fit
                .iter()
                .filter_map(|r| r.curve.map(|c| (r.point.clone(), c.clone())))
                .collect();
            match FunctionalSurrogate::fit(kind_for(kind, runs.len(), bounds.dim()), &runs, bounds) {
                Ok(f) => Some(f),
                Err(_) => return f64::INFINITY,
            }
        }
        None => None,
    };
    let emulated = |r: &RunData| {
        let curve = curves.as_ref().map(|f| f.predict(&r.point));
        Some(tests.outputs(&t.values, Some(surrogate.predict(&r.point)), curve.as_ref()))
    };
    rms_in_noise(tests, t, held, &emulated)
}

/// The surrogate kind a design's few runs can carry: `kind`, or linear where `n` runs are too few
/// for it (probe runs, a joint space's first runs).
pub fn kind_for(kind: SurrogateKind, n: usize, d: usize) -> SurrogateKind {
    if n >= kind.min_samples(d) {
        kind
    } else {
        SurrogateKind::Linear
    }
}

/// The response's and the curves' surrogate kinds of a study.
pub fn kinds(study: &Study, sim: &SolverSimulation) -> (SurrogateKind, Option<SurrogateKind>) {
    let curves = study
        .calibration
        .against
        .curves
        .then(|| study.calibration.curve.surrogate.unwrap_or(sim.surrogate));
    (sim.surrogate, curves)
}
