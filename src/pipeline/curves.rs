//! The curves stage of [`super::run`] for a study calibrated against its force–displacement curves
//! (`calibration.against: [.., curves]`):
//!
//! ```text
//! runs' rcforc/nodout ─► curve ─► (CFC filter) ─► stroke grid ─┐
//! specimens' CSVs ─────► curve ─► (CFC filter) ─► stroke grid ─┼─► per design: curve emulator
//!                                                              └─► features ─► diagnosis
//! ```
//!
//! Every run's curve is read from the same histories its response came from (its run directory,
//! or its recording), so live and replayed runs give the same curves.

use std::path::PathBuf;
use std::sync::Arc;

use nalgebra::DVector;

use crate::diagnose::Role;
use crate::diagnose::features::{CurveDesign, CurveFn, CurveHypothesis, CurveInputs, EmulatorCheck};
use crate::emulate::fits::{AcrossCurves, CurvesAcrossFit, Kind};
use crate::emulate::functional::{CurveCheck, CurveModel, DesignCurves, FunctionalSurrogate, check_error};
use crate::emulate::{self, DesignFit, Run};
use crate::error::Error;
use crate::extract::crush::ForceDisplacement;
use crate::extract::features::FeatureSpec;
use crate::extract::grid::{self, StrokeGrid};
use crate::plan::PlannedRun;
use crate::study::{HypothesisKind, Response, SolverSimulation, Study, SurrogateKind};

/// Where and how a study's curves are compared.
#[derive(Debug, Clone, Copy)]
pub struct Setting {
    pub grid: StrokeGrid,
    pub spec: FeatureSpec,
}

impl Setting {
    /// The study's grid and features; `None` unless it is calibrated against curves.
    pub fn of(study: &Study) -> Option<Setting> {
        if !study.calibration.against.curves {
            return None;
        }
        let grid = crate::study::curve_grid(&study.calibration.curve, &study.simulation)?;
        let crate::study::Simulation::Solver(sim) = &study.simulation else {
            return None;
        };
        let Response::CrushForce { window, .. } = sim.response else {
            return None;
        };
        Some(Setting {
            grid,
            spec: FeatureSpec { grid, plateau: window },
        })
    }

    /// A curve as the comparison sees it: filtered when the study says so, on the grid.
    fn prepare(&self, study: &Study, curve: &ForceDisplacement) -> Option<DVector<f64>> {
        let curve = match study.calibration.curve.filter {
            Some(f) => crate::extract::cfc::filter_curve(curve, 1000.0 * f.speed, f.cfc).ok()?,
            None => curve.clone(),
        };
        grid::resample(&curve, &self.grid).ok().map(DVector::from_vec)
    }
}

/// Each run's curve on the grid, in the order of `keys` (`None` where the run has no usable
/// response or its histories are gone).
pub fn on_grid(
    study: &Study,
    sim: &SolverSimulation,
    setting: &Setting,
    keys: &[String],
    usable: &[Option<f64>],
    dirs: &[PathBuf],
) -> Vec<Option<DVector<f64>>> {
    use rayon::prelude::*;
    let Response::CrushForce { .. } = &sim.response else {
        return vec![None; keys.len()];
    };
    keys.par_iter()
        .zip(usable)
        .map(|(key, y)| {
            y.as_ref()?;
            let curve = crate::extract::adapters::run_curve(sim, dirs, key)?;
            setting.prepare(study, &curve)
        })
        .collect()
}

/// The specimens of every training and validation design on the grid (validated at load: each
/// covers the window).
pub fn specimens(study: &Study, setting: &Setting) -> Vec<CurveDesign> {
    study
        .split
        .training
        .iter()
        .map(|n| (n, Role::Training))
        .chain(study.split.validation.iter().map(|n| (n, Role::Validation)))
        .filter_map(|(name, role)| {
            let sc = study.experiments.curves.iter().find(|c| &c.design == name)?;
            let values = study.experiments.get(name)?.values.clone();
            Some(CurveDesign {
                name: name.clone(),
                values,
                role,
                specimens: sc
                    .specimens
                    .iter()
                    .filter_map(|(_, c)| setting.prepare(study, c))
                    .collect(),
            })
        })
        .collect()
}

/// A run as a curve emulator sees it: its point in the emulator's space, its curve, and whether it
/// is a check run.
pub struct CurveRun<'a> {
    pub run: &'a PlannedRun,
    pub point: Vec<f64>,
    pub curve: Option<DVector<f64>>,
    pub check: bool,
}

/// The surrogate kind of each curve component: `calibration.curve.surrogate`, else the study's.
pub fn kind(study: &Study, sim: &SolverSimulation) -> SurrogateKind {
    study.calibration.curve.surrogate.unwrap_or(sim.surrogate)
}

/// One curve emulator per tested design over `bounds`, fitted to its sample runs among `runs` and
/// checked at its check runs; `across` (with `sampling.across_designs`), the designs' slices of one
/// emulator fitted to every run with a curve, the check runs too, each design's check runs (its
/// latest batch) predicted by the emulator fitted to every other run, as the response's are
/// ([`super::stages::fit_surrogates`]); each design's curves are then emulated in units of its
/// tests' mean force.
pub fn emulators(
    study: &Study,
    kind: SurrogateKind,
    bounds: &crate::base::Bounds,
    runs: &[CurveRun],
    across: bool,
) -> Result<CurveModel, Error> {
    let names: Vec<&String> = study.split.training.iter().chain(&study.split.validation).collect();
    let all: Vec<Run<DVector<f64>>> = runs
        .iter()
        .map(|r| Run {
            design: &r.run.design,
            values: &r.run.design_values,
            x: &r.point,
            y: r.curve.as_ref(),
        })
        .collect();
    let check = |r: &Run<DVector<f64>>| runs[all.iter().position(|a| std::ptr::eq(a.x, r.x)).expect("a run")].check;
    let fitted: Vec<Result<DesignFit<FunctionalSurrogate, DVector<f64>>, _>> = if across {
        let spec = across_spec(study, bounds, &names, &all);
        let fitted = emulate::across::<CurvesAcrossFit>(&spec, &names, &all, &check);
        if let Some(Err((_, e))) = fitted.iter().find(|f| f.is_err()) {
            return Err(Error::Failed(format!(
                "cannot fit the curve emulator across the designs: {e}"
            )));
        }
        fitted
    } else {
        emulate::by_design::<FunctionalSurrogate>(&Kind::new(kind, bounds.clone()), &names, &all, &check)
    };
    let designs = fitted
        .into_iter()
        .map(|f| {
            f.map(|f| design_curves(f, &all))
                .map_err(|(name, e)| Error::Failed(format!("design `{name}`: cannot fit its curve emulator: {e}")))
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(CurveModel { designs })
}

/// The curve emulator across the designs: their values' range and θ's box, each design's curves in
/// units of its tests' mean force.
fn across_spec(
    study: &Study,
    bounds: &crate::base::Bounds,
    names: &[&String],
    all: &[Run<DVector<f64>>],
) -> AcrossCurves {
    let scale = |name: &str| {
        let r = study
            .experiments
            .get(name)
            .map(|t| t.replicates.as_slice())
            .unwrap_or_default();
        crate::emulate::functional::unit(r.iter().sum::<f64>() / r.len().max(1) as f64)
    };
    let tested: Vec<(&String, Vec<f64>)> = names
        .iter()
        .filter_map(|n| {
            all.iter()
                .find(|r| r.y.is_some() && r.design == n.as_str())
                .map(|r| (*n, r.values.to_vec()))
        })
        .collect();
    let values: Vec<Vec<f64>> = tested.iter().map(|t| t.1.clone()).collect();
    AcrossCurves {
        joint: crate::emulate::sequential::shared::joint_bounds(&values, bounds),
        units: tested.into_iter().map(|(n, v)| (v, scale(n))).collect(),
    }
}

/// A design's curve emulator with its check runs: each held-out run's curve and the curve the
/// emulator fitted without it predicted.
fn design_curves(f: DesignFit<FunctionalSurrogate, DVector<f64>>, all: &[Run<DVector<f64>>]) -> DesignCurves {
    let checks: Vec<CurveCheck> = f
        .held
        .runs
        .iter()
        .zip(f.held.predicted)
        .map(|(&i, emulated)| CurveCheck {
            theta: all[i].x.to_vec(),
            curve: all[i].y.expect("held out with a curve").clone(),
            emulated,
        })
        .collect();
    DesignCurves {
        design: f.design,
        values: f.values,
        check: check_error(&checks),
        surrogate: f.emulator,
        samples: f.fitted,
        checks,
    }
}

/// A curve model as the diagnosis's curve function.
pub fn curve_fn(model: CurveModel) -> Arc<CurveFn> {
    Arc::new(move |d: &[f64], theta: &[f64]| model.curve(d, theta))
}

/// The diagnosis's inputs on curves: `study`'s designs, parameters and term hypotheses, the
/// simulation's curves `curve`, and the extension hypotheses' shapes `extensions`.
pub fn inputs<'s>(
    study: &'s Study,
    setting: &Setting,
    designs: Vec<CurveDesign>,
    model: &CurveModel,
    extensions: Vec<CurveHypothesis>,
) -> CurveInputs<'s> {
    let terms = study
        .diagnosis
        .hypotheses
        .iter()
        .filter(|h| matches!(h.kind, HypothesisKind::Term(_)))
        .map(|h| CurveHypothesis::Term(crate::diagnose::Shape::from_hypothesis(h, study)));
    CurveInputs {
        designs,
        spec: setting.spec,
        curve: curve_fn(model.clone()),
        checks: model
            .check_runs()
            .into_iter()
            .map(|(design, c)| EmulatorCheck {
                design,
                theta: c.theta,
                curve: c.curve,
                emulated: c.emulated,
            })
            .collect(),
        space: crate::diagnose::Space::of_study(study),
        hypotheses: terms.chain(extensions).collect(),
        settings: Default::default(),
        constants: &study.constants,
    }
}

/// The extension hypotheses of `study` as curve shapes from their screening runs' emulators
/// (`models`: `(k, model)`), but hypothesis `skip`; measured against `baseline` when given.
pub fn extension_hypotheses(
    study: &Study,
    models: &[(usize, Arc<CurveFn>)],
    baseline: Option<(Arc<CurveFn>, usize)>,
    skip: Option<usize>,
) -> Vec<CurveHypothesis> {
    models
        .iter()
        .filter(|(k, _)| Some(*k) != skip)
        .filter_map(|(k, curve)| {
            let h = &study.diagnosis.hypotheses[*k];
            Some(CurveHypothesis::Extension {
                name: h.name.clone(),
                variables: h.extension()?.to_vec(),
                ranges: h.declared_ranges(),
                curve: curve.clone(),
                baseline: baseline.clone(),
            })
        })
        .collect()
}

/// A solver study's curves: the grid, the specimens, every screening run's curve, and the curve
/// emulators of the baseline and of each extension hypothesis's screening runs.
pub struct CurveStage {
    pub setting: Setting,
    pub designs: Vec<CurveDesign>,
    /// Each planned run's curve, in plan order.
    pub runs: Vec<Option<DVector<f64>>>,
    pub baseline: CurveModel,
    /// `(k, model)` for `study.diagnosis.hypotheses[k]`, over θ.
    pub extensions: Vec<(usize, CurveModel)>,
    /// Why an extension hypothesis's curves could not be emulated (its probe runs failed): left
    /// out of the candidates, said.
    pub unscreened: Vec<String>,
}

impl CurveStage {
    /// Reads and fits everything the diagnosis and the curve calibration need from the screening's
    /// runs (`usable`: each run's response, or `None` when it failed or is left out as suspect).
    pub fn build(
        study: &Study,
        sim: &SolverSimulation,
        setting: Setting,
        plan: &crate::plan::Plan,
        keys: &[String],
        usable: &[Option<f64>],
        dirs: &[PathBuf],
    ) -> Result<CurveStage, Error> {
        use crate::plan::RunRole;
        let runs = on_grid(study, sim, &setting, keys, usable, dirs);
        let kind = kind(study, sim);
        let bounds = study.parameter_bounds();
        let of = |keep: &dyn Fn(RunRole) -> bool| -> Vec<CurveRun> {
            plan.runs
                .iter()
                .zip(&runs)
                .filter(|(r, _)| keep(r.role))
                .map(|(run, c)| CurveRun {
                    run,
                    point: run.theta.clone(),
                    curve: c.clone(),
                    check: run.role == RunRole::Check,
                })
                .collect()
        };
        let baseline = emulators(
            study,
            kind,
            &bounds,
            &of(&|r| matches!(r, RunRole::Sample | RunRole::Check)),
            sim.across_designs(),
        )?;
        let probes_across = crate::plan::sweep::probes_across(study, sim);
        let mut unscreened = Vec::new();
        let extensions = study
            .extension_hypotheses()
            .filter_map(|(k, h)| {
                let runs = of(&|r| r == RunRole::Extension(k));
                // A sequential study probes each design at p + 1 points of the posterior: enough for
                // a linear emulator of the extension's curves over θ there; counted where they finished.
                let per_design = crate::plan::sweep::tested_designs(study)
                    .map(|(d, _)| runs.iter().filter(|r| &r.run.design == d && r.curve.is_some()).count())
                    .min()
                    .unwrap_or(0);
                let kind = crate::emulate::fits::kind_for(kind, per_design, bounds.dim());
                match emulators(study, kind, &bounds, &runs, probes_across) {
                    Ok(model) => Some((k, model)),
                    Err(e) => {
                        unscreened.push(format!("'{}' cannot be screened on its curves: {e}", h.name));
                        None
                    }
                }
            })
            .collect();
        Ok(CurveStage {
            designs: specimens(study, &setting),
            setting,
            runs,
            baseline,
            extensions,
            unscreened,
        })
    }

    /// The extension hypotheses' emulators as curve functions.
    pub fn extension_fns(&self) -> Vec<(usize, Arc<CurveFn>)> {
        self.extensions.iter().map(|(k, m)| (*k, curve_fn(m.clone()))).collect()
    }

    /// The emulator of hypothesis `k`'s extended model over θ and its ranged variables, from its
    /// screening runs (at the probe) and the loop's runs (`joint`, with their curves `curves`).
    pub fn loop_model(
        &self,
        study: &Study,
        sim: &SolverSimulation,
        plan: &crate::plan::Plan,
        k: usize,
        joint: &super::extend::JointRuns,
        curves: &[Option<DVector<f64>>],
    ) -> Result<CurveModel, Error> {
        use crate::plan::RunRole;
        let ranges = study.diagnosis.hypotheses[k].ranges();
        let bounds = crate::plan::sweep::joint_bounds(study, ranges);
        let runs: Vec<CurveRun> = plan
            .runs
            .iter()
            .zip(&self.runs)
            .chain(joint.plan.runs.iter().zip(curves))
            .filter_map(|(run, c)| {
                Some(CurveRun {
                    run,
                    point: joint.point(k, ranges, run)?,
                    curve: c.clone(),
                    check: run.role == RunRole::JointCheck(k),
                })
            })
            .collect();
        let model = emulators(study, kind(study, sim), &bounds, &runs, sim.across_designs())?;
        Ok(model)
    }
}

/// A model's whole curve at a design's values.
type DesignCurve<'a> = Box<crate::diagnose::features::CurveOf<'a>>;

/// The uncorrected simulation's curve at its calibrated parameters and, when a cause is named, its
/// final model's: the loop's emulator (`loops`: `(k, model)` of the extended hypotheses) at the
/// extended parameters, or a term's shape added along the stroke.
fn model_curves<'a>(
    study: &'a Study,
    stage: &'a CurveStage,
    loops: &'a [(usize, CurveModel)],
    d: &crate::diagnose::Diagnosis,
) -> (DesignCurve<'a>, Option<DesignCurve<'a>>) {
    let theta: Vec<f64> = d.record.uncorrected.parameters.values().copied().collect();
    let uncorrected: DesignCurve<'a> = Box::new(move |values: &[f64]| stage.baseline.curve(values, &theta));
    let extended = d.extended_model().and_then(|e| -> Option<DesignCurve<'a>> {
        let k = study
            .diagnosis
            .hypotheses
            .iter()
            .position(|h| h.name == e.model.cause)?;
        let at: Vec<f64> = e.model.parameters.values().copied().collect();
        let hypothesis = &study.diagnosis.hypotheses[k];
        match loops.iter().find(|(j, _)| *j == k) {
            Some((_, model)) if e.check.solver_in_the_loop => Some(Box::new(move |v: &[f64]| model.curve(v, &at))),
            _ if matches!(hypothesis.kind, HypothesisKind::Term(_)) => {
                let shape = crate::diagnose::Shape::from_hypothesis(hypothesis, study);
                let gamma = e.model.amplitude;
                Some(Box::new(move |v: &[f64]| {
                    let y = stage.baseline.curve(v, &at)?;
                    Some(DVector::from_iterator(
                        y.len(),
                        y.iter().map(|&s| s + gamma * shape.eval(v, &at, s)),
                    ))
                }))
            }
            _ => None,
        }
    });
    (uncorrected, extended)
}

/// The diagnosis's curve features with the uncorrected simulation's curves at its calibrated
/// parameters and, when a cause is named, its final model's ([`model_curves`]).
pub fn features_report(
    study: &Study,
    stage: &CurveStage,
    problem: &crate::diagnose::features::FeatureProblem,
    loops: &[(usize, CurveModel)],
    d: &crate::diagnose::Diagnosis,
) -> crate::diagnose::features::FeaturesReport {
    let (uncorrected, extended) = model_curves(study, stage, loops, d);
    crate::diagnose::features::FeaturesReport::new(problem, &stage.designs, &*uncorrected, extended.as_deref(), d)
}

/// The report's residual curves: per tested design the specimens' band on the stroke grid, the
/// uncorrected model's curve and the named cause's ([`model_curves`]).
pub fn residual_curves(
    study: &Study,
    stage: &CurveStage,
    loops: &[(usize, CurveModel)],
    d: &crate::diagnose::Diagnosis,
) -> Vec<super::values::ResidualCurves> {
    let (uncorrected, extended) = model_curves(study, stage, loops, d);
    let stroke = stage.setting.grid.stroke();
    let vec = |c: DVector<f64>| c.as_slice().to_vec();
    stage
        .designs
        .iter()
        .filter(|design| !design.specimens.is_empty())
        .map(|design| {
            let specimens: Vec<Vec<f64>> = design.specimens.iter().map(|c| c.as_slice().to_vec()).collect();
            let validation = design.role == Role::Validation;
            let mut r = super::values::ResidualCurves::band(&design.name, validation, stroke.clone(), &specimens);
            r.before = uncorrected(&design.values).map(vec);
            r.after = extended.as_ref().and_then(|f| f(&design.values)).map(vec);
            r.after_label = r.after.as_ref().and(d.extended_model().map(|e| e.model.cause.clone()));
            r
        })
        .collect()
}

/// The study's methods on the curve problem, by key, and the first estimate (what the curves pin
/// down is measured there).
fn curve_methods(
    study: &Study,
    problem: &crate::calibrate::curves::CurveProblem,
    names: &[String],
) -> (
    indexmap::IndexMap<String, super::values::CurveMethodResult>,
    Option<DVector<f64>>,
) {
    use super::values::CurveMethodResult;
    use crate::calibrate::curves as cc;
    use crate::calibrate::outcome::Method;
    let named = |t: &DVector<f64>| names.iter().cloned().zip(t.iter().copied()).collect();
    let finite = |v: f64| v.is_finite().then_some(v);
    let mut methods = indexmap::IndexMap::new();
    let mut first = None;
    for m in &study.calibration.methods {
        let est = match m {
            Method::LeastSquares => cc::least_squares(problem),
            Method::Sensitivity => cc::sensitivity(problem),
            Method::Bayesian => cc::bayesian(problem),
        };
        let result = match est {
            Ok(e) => {
                first.get_or_insert_with(|| e.theta.clone());
                CurveMethodResult {
                    parameters: named(&e.theta),
                    intervals: e
                        .interval
                        .as_ref()
                        .map(|iv| names.iter().cloned().zip(iv.iter().map(|(a, b)| [*a, *b])).collect()),
                    train: finite(problem.value(&e, true)),
                    validation: finite(problem.value(&e, false)),
                    offset_mean: e.offset.as_ref().map(|d| d.mean()),
                    discrepancy_sd: e.discrepancy_sd,
                    error: None,
                }
            }
            Err(e) => CurveMethodResult {
                parameters: Default::default(),
                intervals: None,
                train: None,
                validation: None,
                offset_mean: None,
                discrepancy_sd: None,
                error: Some(e.to_string()),
            },
        };
        methods.insert(m.key().to_string(), result);
    }
    (methods, first)
}

/// `curve_calibration`: the study's methods on the curves through the baseline's curve emulator,
/// the metric at the training and validation designs, and what the curves pin down.
pub fn calibrate(study: &Study, stage: &CurveStage) -> super::values::CurveCalibrationResult {
    use super::values::{CurveCalibrationResult, CurveEmulatorResult, CurveFilterResult, CurvePinned};
    use crate::calibrate::curves::{self as cc, CurveProblem, CurveTarget};
    let designs: Vec<&CurveDesign> = stage.designs.iter().filter(|d| !d.specimens.is_empty()).collect();
    let model = &stage.baseline;
    let predict = |i: usize, theta: &[f64]| model.curve(&designs[i].values, theta);
    let targets = CurveTarget::new(
        designs
            .iter()
            .map(|d| {
                (
                    d.name.clone(),
                    d.role == crate::diagnose::Role::Training,
                    d.specimens.clone(),
                )
            })
            .collect(),
    );
    let grid = stage.setting.grid;
    let problem = CurveProblem {
        targets,
        predict: &predict,
        bounds: study.parameter_bounds(),
        stroke: grid.stroke(),
        metric: study.calibration.curve.metric,
    };
    let names: Vec<String> = study.parameters.iter().map(|p| p.name.clone()).collect();
    let finite = |v: f64| v.is_finite().then_some(v);
    let (methods, first) = curve_methods(study, &problem, &names);
    let stroke = grid.stroke();
    let window = stage.setting.spec.plateau;
    let inside: Vec<usize> = (0..stroke.len())
        .filter(|&k| stroke[k] >= window.s0 && stroke[k] <= window.s1)
        .collect();
    let range = inside.first().copied().unwrap_or(0)..inside.last().map_or(0, |k| k + 1);
    let identifiability = first
        .map(|t| cc::pinned(&problem, &t, &names, range))
        .unwrap_or_default()
        .into_iter()
        .map(|p| CurvePinned {
            parameter: p.parameter,
            curves_se: finite(p.curves_se),
            mean_force_se: finite(p.mean_force_se),
        })
        .collect();
    CurveCalibrationResult {
        metric: study.calibration.curve.metric.key().to_string(),
        points: grid.points,
        window: [grid.s0, grid.s1],
        filter: study.calibration.curve.filter.map(|f| CurveFilterResult {
            cfc: f.cfc,
            speed: f.speed,
        }),
        emulator: CurveEmulatorResult {
            components: model
                .designs
                .iter()
                .map(|d| (d.design.clone(), d.surrogate.components()))
                .collect(),
            reconstruction_error: model
                .designs
                .iter()
                .map(|d| d.surrogate.reconstruction_error)
                .fold(0.0, f64::max),
            check_error: model
                .designs
                .iter()
                .filter_map(|d| d.check.max_relative_error)
                .reduce(f64::max),
        },
        methods,
        identifiability,
    }
}
