//! `report-data.json`: what the report draws that `results.json` does not hold, recorded by
//! `lab run` beside it so that `lab report` can rebuild the page from recorded data alone.
//!
//! - the study as run (variables, bounds, the simulation, every test with its replicates), wall time;
//! - the Bayesian posterior samples (thinned to [`MAX_POSTERIOR_SAMPLES`]);
//! - for one-design-variable studies, each calibrated method's prediction over the design range
//!   (the paper's Figs 4–6); where the model only exists at the tested designs (per-design
//!   surrogates of a solver study) the points are those designs;
//! - solver studies: per design the surrogate's samples, check points and (one parameter) its curve;
//!   the run table;
//! - force–displacement curves per design: simulated runs and test specimens ([`super::curves`]);
//! - a hook for extra train/validate splits (the study's `splits` are in `results.json`).
//!
//! Every field but `study` is optional or may be empty: an older or partial file still renders.

use std::path::Path;

use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

use crate::calibrate::{Calibrated, Calibration};
use crate::emulate::Model;
use crate::emulate::SurrogateModel;
use crate::execute::store::RunStore;
pub use crate::pipeline::values::ResidualCurves;
use crate::plan::{Plan, RunRole};
use crate::study::{Simulation, SolverSimulation, Study};

pub const FILE: &str = "report-data.json";
/// Posterior rows kept for the histogram (every sample still went into the quantiles).
pub const MAX_POSTERIOR_SAMPLES: usize = 2000;
/// Points of a prediction or surrogate curve.
pub const CURVE_POINTS: usize = 61;

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
pub struct ReportData {
    pub study: StudyInfo,
    /// Seconds from the start of `lab run` to the calibration's end (runs included).
    #[serde(default)]
    pub wall_time_s: Option<f64>,
    #[serde(default)]
    pub posterior: Option<Posterior>,
    /// One per calibrated method (one-design-variable studies).
    #[serde(default)]
    pub prediction_curves: Vec<PredictionCurve>,
    /// Solver studies: each design's surrogate, every planned run, the force–displacement curves.
    #[serde(flatten)]
    pub solver: SolverData,
    /// Hook: calibration and validation errors of further train/validate splits (paper Fig. 13);
    /// the study's own split is always shown from `results.json`.
    #[serde(default)]
    pub splits: Vec<SplitErrors>,
    /// Solver in the loop: each extended model's response over its first ranged variable.
    #[serde(default)]
    pub extension_surfaces: Vec<ExtensionSurface>,
    /// Calibration against curves: per tested design, where along the stroke the model errs.
    #[serde(default)]
    pub residual_curves: Vec<ResidualCurves>,
    /// `openradioss` studies naming the stand-in's recordings: both solvers' curves compared.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub solver_comparison: Option<super::solvers::SolverComparison>,
}

/// Solver studies: each design's surrogate, every planned run, the force–displacement curves.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
pub struct SolverData {
    /// Solver studies: one per design.
    #[serde(default)]
    pub surrogates: Vec<SurrogateData>,
    /// Solver studies: every planned run.
    #[serde(default)]
    pub runs: Vec<RunRow>,
    /// Force–displacement curves per design: runs of a `crush_force` response, `experiments.curves`.
    #[serde(default)]
    pub force_displacement: Vec<DesignCurves>,
}

/// An extended model's predictions over one extension variable, the other parameters at their
/// calibrated values (`diagnosis.extensions[].parameters`), per tested design, against the tests.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct ExtensionSurface {
    pub hypothesis: String,
    pub variable: String,
    #[serde(default)]
    pub unit: Option<String>,
    pub designs: Vec<SurfaceCurve>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct SurfaceCurve {
    pub design: String,
    /// (variable value, predicted response).
    pub points: Vec<(f64, f64)>,
    /// The tests' mean and the σ of that mean (`null` with one test).
    pub measured: f64,
    pub sigma_of_mean: Option<f64>,
}

impl ExtensionSurface {
    /// `model` over θ followed by the extension's ranged variables, swept along `variable` (index
    /// `j` in that vector, between `lo` and `hi`) at `at`, for every design the study tested.
    pub fn sweep(
        study: &crate::study::Study,
        hypothesis: &str,
        model: &dyn crate::emulate::Model,
        at: &[f64],
        (j, lo, hi): (usize, f64, f64),
        variable: &crate::study::Parameter,
    ) -> ExtensionSurface {
        let designs = study
            .split
            .training
            .iter()
            .chain(&study.split.validation)
            .filter_map(|name| {
                let t = study.experiments.get(name)?;
                let points = (0..=40)
                    .map(|i| {
                        let x = lo + (hi - lo) * i as f64 / 40.0;
                        let mut theta = at.to_vec();
                        theta[j] = x;
                        (x, model.predict(&t.values, &theta))
                    })
                    .collect();
                let n = t.replicates.len() as f64;
                Some(SurfaceCurve {
                    design: name.clone(),
                    points,
                    measured: t.mean(),
                    sigma_of_mean: t.std_dev().map(|s| s / n.sqrt()),
                })
            })
            .collect();
        ExtensionSurface {
            hypothesis: hypothesis.to_string(),
            variable: variable.name.clone(),
            unit: variable.unit.clone(),
            designs,
        }
    }
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
pub struct StudyInfo {
    pub name: String,
    /// The measured response's name (the experiments' column).
    pub response: String,
    /// Its unit, when the study gives one.
    #[serde(default)]
    pub response_unit: Option<String>,
    pub design: Vec<Variable>,
    pub parameters: Vec<Variable>,
    /// The closed-form expression, or the solver's command line.
    pub simulation: String,
    #[serde(default)]
    pub solver: Option<SolverInfo>,
    pub constants: IndexMap<String, f64>,
    pub tests: Vec<TestInfo>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
pub struct Variable {
    pub name: String,
    pub unit: Option<String>,
    pub min: Option<f64>,
    pub max: Option<f64>,
}

impl Variable {
    /// `name (unit)`, or the name alone.
    pub fn label(&self) -> String {
        match &self.unit {
            Some(u) => format!("{} ({u})", self.name),
            None => self.name.clone(),
        }
    }
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
pub struct SolverInfo {
    pub adapter: String,
    pub surrogate: String,
    /// e.g. `lhs, 12 samples + 5 check runs per design, seed 1`.
    pub sampling: String,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct TestInfo {
    pub name: String,
    /// `training`, `validation`, or `unused`.
    pub role: String,
    pub values: Vec<f64>,
    pub replicates: Vec<f64>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Posterior {
    pub parameters: Vec<String>,
    /// One column of samples per parameter (empty when the posterior was integrated).
    pub samples: Vec<Vec<f64>>,
    /// Per parameter, the marginal density computed by quadrature: points and density values
    /// (empty when the posterior was sampled).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub density: Vec<(Vec<f64>, Vec<f64>)>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct PredictionCurve {
    pub method: String,
    pub design_variable: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct SurrogateData {
    pub design: String,
    pub kind: String,
    /// (θ, response) of the successful sample runs.
    pub samples: Vec<(Vec<f64>, f64)>,
    /// (θ, response, surrogate's prediction) of the successful check runs.
    pub checks: Vec<(Vec<f64>, f64, f64)>,
    /// One-parameter studies: the surrogate over the parameter's range.
    pub curve: Option<(Vec<f64>, Vec<f64>)>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct RunRow {
    pub key: String,
    pub design: String,
    /// `sample` or `check`.
    pub role: String,
    pub theta: Vec<f64>,
    /// How the run ended: its class and words, attempts, time and response.
    #[serde(flatten)]
    pub ended: RunEnd,
    /// The quality gates a successful run breaks, in words (empty: sound or not checked).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub flags: Vec<String>,
    /// The solver's warnings the run's record keeps (`openradioss`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

/// How the run ended: its class and words, attempts, time and response.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct RunEnd {
    /// Outcome class (`success`, `timeout`, …); `null` when the run has no record.
    pub class: Option<String>,
    /// The outcome in words (failure details).
    pub outcome: String,
    pub attempts: u32,
    pub seconds: Option<f64>,
    pub response: Option<f64>,
}

/// A force–displacement curve as drawn: thinned to at most [`super::curves::MAX_POINTS`] points.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Curve {
    /// A run's parameters in words, or a specimen's file stem.
    pub label: String,
    /// mm.
    pub displacement: Vec<f64>,
    /// kN.
    pub force: Vec<f64>,
    /// A run's parameters (empty for a test).
    #[serde(default)]
    pub parameters: Vec<f64>,
    /// Mean crush force over the stroke window, kN, when there is a window.
    #[serde(default)]
    pub mean_force: Option<f64>,
    /// Points of the curve before thinning.
    #[serde(default)]
    pub points: usize,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct DesignCurves {
    pub design: String,
    /// The stroke window [s0, s1] in mm.
    pub window: Option<[f64; 2]>,
    /// Drawn runs, by increasing response: a subset of the design's runs (see `report::curves`).
    pub simulations: Vec<Curve>,
    pub tests: Vec<Curve>,
    /// Successful runs of the design, drawn or not.
    #[serde(default)]
    pub runs: usize,
    /// Index in `simulations` of the run nearest `reference`.
    #[serde(default)]
    pub nearest: Option<usize>,
    #[serde(default)]
    pub reference: Option<Reference>,
    /// Specimens of the design, drawn or not.
    #[serde(default)]
    pub tests_total: usize,
    /// The solver's run of the model the verdict recommends (`results.json` `answer.recommended`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub recommended: Option<RecommendedCurve>,
}

/// The run drawn for the recommended model at one design.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct RecommendedCurve {
    /// `uncorrected`, or the hypothesis whose model it is.
    pub model: String,
    pub curve: Curve,
    /// How far the run lies from the model's fitted point: the largest offset of a parameter or
    /// extension variable, as a fraction of its range (0: a run at the fitted point).
    pub offset: f64,
}

/// The calibrated parameters the highlighted run is nearest to.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Reference {
    /// The method that calibrated them (`least_squares`, …).
    pub method: String,
    pub parameters: Vec<f64>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct SplitErrors {
    pub training: Vec<String>,
    pub validation: Vec<String>,
    /// Per method: mean |relative error| on the training designs, then on the validation designs.
    pub methods: IndexMap<String, [Option<f64>; 2]>,
}

/// A density curve thinned to at most [`MAX_POSTERIOR_SAMPLES`] points, keeping its highest point.
fn thin_curve(x: &[f64], y: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let every = x.len().div_ceil(MAX_POSTERIOR_SAMPLES).max(1);
    let peak = (0..y.len()).max_by(|&a, &b| y[a].total_cmp(&y[b]));
    let keep = |i: &usize| i.is_multiple_of(every) || Some(*i) == peak || *i + 1 == x.len();
    let idx: Vec<usize> = (0..x.len()).filter(keep).collect();
    (idx.iter().map(|&i| x[i]).collect(), idx.iter().map(|&i| y[i]).collect())
}

impl ReportData {
    pub const FILE_NAME: &'static str = FILE;

    /// The study part and, from the calibration, the posterior and prediction curves.
    pub fn build(study: &Study, model: &dyn Model, calibration: &Calibration) -> ReportData {
        let mut data = ReportData {
            study: StudyInfo::from(study),
            ..Default::default()
        };
        for (method, outcome) in &calibration.methods {
            let Ok(calibrated) = outcome else { continue };
            if let Calibrated::Bayesian(fit) = calibrated {
                let rows = fit.posterior.nrows();
                let every = rows.div_ceil(MAX_POSTERIOR_SAMPLES).max(1);
                let samples = (0..fit.posterior.ncols())
                    .map(|k| (0..rows).step_by(every).map(|i| fit.posterior[(i, k)]).collect())
                    .collect();
                let parameters = study.parameters.iter().map(|p| p.name.clone()).collect();
                let density = fit.density.iter().map(|(x, y)| thin_curve(x, y)).collect();
                data.posterior = Some(Posterior {
                    parameters,
                    samples,
                    density,
                });
            }
            if study.design.len() == 1 {
                data.prediction_curves
                    .push(prediction_curve(study, model, method.key(), calibrated));
            }
        }
        data
    }

    /// Adds a solver study's surrogates (samples, checks, curves) and run table.
    pub fn with_runs(
        mut self,
        study: &Study,
        plan: &Plan,
        keys: &[String],
        responses: &[Option<f64>],
        surrogates: &SurrogateModel,
        store: &RunStore,
    ) -> ReportData {
        let bounds = study.parameter_bounds();
        for d in &surrogates.designs {
            let runs = plan.runs.iter().zip(responses).filter(|(r, _)| r.design == d.design);
            let samples = runs
                .clone()
                .filter(|(r, _)| r.role == RunRole::Sample)
                .filter_map(|(r, y)| y.map(|y| (r.theta.clone(), y)))
                .collect();
            let checks = runs
                .filter(|(r, _)| r.role == RunRole::Check)
                .filter_map(|(r, y)| y.map(|y| (r.theta.clone(), y, d.surrogate.predict(&r.theta))))
                .collect();
            let curve = (bounds.dim() == 1).then(|| {
                let x = grid(bounds.lower[0], bounds.upper[0]);
                let y = x.iter().map(|&t| d.surrogate.predict(&[t])).collect();
                (x, y)
            });
            self.solver.surrogates.push(SurrogateData {
                design: d.design.clone(),
                kind: d.surrogate.kind.key().to_string(),
                samples,
                checks,
                curve,
            });
        }
        for (run, key) in plan.runs.iter().zip(keys) {
            let record = store.record(key);
            self.solver.runs.push(RunRow {
                key: key.clone(),
                design: run.design.clone(),
                role: run.role.key().to_string(),
                theta: run.theta.clone(),
                flags: Vec::new(),
                warnings: record.map(|r| r.warnings.clone()).unwrap_or_default(),
                ended: RunEnd {
                    class: record.map(|r| class_key(r.outcome.class())),
                    outcome: record.map_or("not run".to_string(), |r| r.outcome.to_string()),
                    attempts: record.map_or(0, |r| r.attempts),
                    seconds: record.map(|r| r.ended_ms.saturating_sub(r.started_ms) as f64 / 1000.0),
                    response: record.and_then(|r| r.response),
                },
            });
        }
        self
    }

    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        let json = serde_json::to_string(self).map_err(std::io::Error::other)?;
        crate::report::write_atomic(path, json.as_bytes())
    }

    pub fn read(path: &Path) -> std::io::Result<ReportData> {
        serde_json::from_slice(&std::fs::read(path)?).map_err(std::io::Error::other)
    }
}

/// The parameters of the first method (in the study's order) that calibrated: the force–displacement
/// plots highlight the run nearest them.
pub fn reference(calibration: &Calibration) -> Option<Reference> {
    calibration.methods.iter().find_map(|(method, outcome)| {
        outcome.as_ref().ok().map(|c| Reference {
            method: method.key().to_string(),
            parameters: c.theta().iter().copied().collect(),
        })
    })
}

fn class_key(class: crate::execute::OutcomeClass) -> String {
    serde_json::to_value(class)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_default()
}

fn grid(lo: f64, hi: f64) -> Vec<f64> {
    (0..CURVE_POINTS)
        .map(|i| lo + (hi - lo) * i as f64 / (CURVE_POINTS - 1) as f64)
        .collect()
}

/// The method's prediction over the design range plus at every tested design; points where the
/// model has no value (a surrogate away from its design) are left out.
fn prediction_curve(study: &Study, model: &dyn Model, method: &str, calibrated: &Calibrated) -> PredictionCurve {
    let bounds = study.design_bounds();
    let mut x = grid(bounds.lower[0], bounds.upper[0]);
    x.extend(study.experiments.designs.iter().map(|t| t.values[0]));
    x.sort_by(f64::total_cmp);
    x.dedup();
    let (x, y) = x
        .into_iter()
        .map(|v| (v, calibrated.predict(model, &[v])))
        .filter(|(_, y)| y.is_finite())
        .unzip();
    PredictionCurve {
        method: method.to_string(),
        design_variable: study.design[0].name.clone(),
        x,
        y,
    }
}

impl From<&Study> for StudyInfo {
    fn from(study: &Study) -> StudyInfo {
        let bounds = study.design_bounds();
        let design = study
            .design
            .iter()
            .enumerate()
            .map(|(j, d)| Variable {
                name: d.name.clone(),
                unit: d.unit.clone(),
                min: Some(bounds.lower[j]),
                max: Some(bounds.upper[j]),
            })
            .collect();
        let parameters = study
            .parameters
            .iter()
            .map(|p| Variable {
                name: p.name.clone(),
                unit: p.unit.clone(),
                min: Some(p.min),
                max: Some(p.max),
            })
            .collect();
        let (simulation, solver) = match &study.simulation {
            Simulation::Expression(e) => (e.text().to_string(), None),
            Simulation::Solver(sim) => (sim.execution.command.join(" "), Some(solver_info(sim))),
        };
        let role = |name: &String| {
            if study.split.training.contains(name) {
                "training"
            } else if study.split.validation.contains(name) {
                "validation"
            } else {
                "unused"
            }
        };
        let tests = study
            .experiments
            .designs
            .iter()
            .map(|t| TestInfo {
                name: t.name.clone(),
                role: role(&t.name).to_string(),
                values: t.values.clone(),
                replicates: t.replicates.clone(),
            })
            .collect();
        StudyInfo {
            name: study.name.clone(),
            response: study.experiments.response.clone(),
            response_unit: study.experiments.unit.clone(),
            design,
            parameters,
            simulation,
            solver,
            constants: study.constants.iter().cloned().collect(),
            tests,
        }
    }
}

fn solver_info(sim: &SolverSimulation) -> SolverInfo {
    let s = &sim.sampling;
    let method = match s.method {
        crate::study::SamplingMethod::Lhs => "Latin hypercube",
        crate::study::SamplingMethod::Grid => "grid",
        crate::study::SamplingMethod::Sequential => "sequential",
    };
    let sampling = match &s.sequential {
        Some(q) => format!(
            "sequential batches from an initial Latin hypercube, seed {}; stopped when the emulators' error at the \
             posterior is at most {} of the tests' noise at every tested design{}",
            s.seed,
            q.tolerance,
            if q.budget > 0 {
                format!(", or at {} runs", q.budget)
            } else {
                String::new()
            }
        ),
        None => format!(
            "{method}, {} samples + {} check runs per design, seed {}",
            s.count, s.check_runs, s.seed
        ),
    };
    SolverInfo {
        adapter: sim.adapter.clone(),
        surrogate: sim.surrogate.key().to_string(),
        sampling,
    }
}
