//! `results.json`: the keys fixed in the contract, plus a few extensions.
//!
//! Built from the study and the calibration; serialised with parameter and design order kept.

use std::collections::BTreeMap;
use std::path::Path;

use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

use crate::calibrate::identifiability::Identifiability;
use crate::calibrate::{Calibrated, Calibration};
use crate::calibrate::{CalibrationError, Discrepancy, Model};
use crate::diagnose::Diagnosis;
use crate::extract::lsdyna::quality::{Flag, Gates};
pub use crate::pipeline::values::{
    CurveCalibrationResult, CurveEmulatorResult, CurveFilterResult, CurveMethodResult, CurvePinned,
};
use crate::study::Study;

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Results {
    pub study: String,
    /// The verdict in an engineer's words: what the model gets wrong, what to use, what to do next,
    /// and the statistics that decided (absent without a diagnosis).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub answer: Option<super::answer::Answer>,
    /// Keyed by method name (`least_squares`, `sensitivity`, `bayesian`), in the study's order.
    pub calibration: IndexMap<String, MethodResult>,
    pub identifiability: IdentifiabilityResult,
    /// The diagnosis, or why it could not run.
    #[serde(flatten)]
    pub diagnosed: Diagnosed,
    /// Solver studies: each design's surrogate and the runs.
    #[serde(flatten)]
    pub solver: SolverRecord,
    /// What the study states beside its tests: the truth, extra splits, units.
    #[serde(flatten)]
    pub stated: Stated,
    /// Calibration against whole force–displacement curves (`calibration.against: [.., curves]`).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub curve_calibration: Option<CurveCalibrationResult>,
    /// A sequentially sampled study: what each batch of runs bought and why the sequence stopped.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub sampling: Option<crate::pipeline::sequence::Sequence>,
}

/// The diagnosis, or why it could not run.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct Diagnosed {
    /// What the simulation gets wrong and why (contract `diagnosis`); `null` if it could not run.
    pub diagnosis: Option<Diagnosis>,
    /// Why the diagnosis could not run.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub diagnosis_error: Option<String>,
}

/// Solver studies: each design's surrogate and the runs.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct SolverRecord {
    /// Solver studies: each design's surrogate and its error at the check runs.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub surrogates: Option<IndexMap<String, SurrogateResult>>,
    /// Solver studies: planned runs and how many have a successful result.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub runs: Option<RunsResult>,
}

/// What the study states beside its tests: the truth, extra splits, units.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct Stated {
    /// The study's `truth` (known parameter values of synthetic tests), when it states one.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub truth: Option<IndexMap<String, f64>>,
    /// The study's extra train/validate splits, each calibrated from the same simulations.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub splits: Option<Vec<SplitResult>>,
    /// The units the study states: each parameter's (`unit:`) and the response's (`experiments.unit`).
    #[serde(skip_serializing_if = "Units::is_empty", default)]
    pub units: Units,
}

/// Units as the study states them (absent when it states none).
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct Units {
    #[serde(skip_serializing_if = "IndexMap::is_empty", default)]
    pub parameters: IndexMap<String, String>,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub response: Option<String>,
    /// The units of the hypotheses' ranged extension variables (`etan: MPa`).
    #[serde(skip_serializing_if = "IndexMap::is_empty", default)]
    pub variables: IndexMap<String, String>,
}

impl Units {
    fn is_empty(&self) -> bool {
        self.parameters.is_empty() && self.response.is_none() && self.variables.is_empty()
    }

    fn of(study: &Study) -> Units {
        Units {
            parameters: study
                .parameters
                .iter()
                .filter_map(|p| Some((p.name.clone(), p.unit.clone()?)))
                .collect(),
            response: study.experiments.unit.clone(),
            variables: study
                .diagnosis
                .hypotheses
                .iter()
                .flat_map(|h| h.ranges())
                .filter_map(|r| Some((r.name.clone(), r.unit.clone()?)))
                .collect(),
        }
    }

    /// `name [unit]`, or `name` when the unit is not stated.
    pub fn label(unit: Option<&String>, name: &str) -> String {
        unit.map_or_else(|| name.to_string(), |u| format!("{name} [{u}]"))
    }
}

/// One train/validate split: each method's estimate and errors.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct SplitResult {
    pub training: Vec<String>,
    pub validation: Vec<String>,
    pub methods: IndexMap<String, SplitMethod>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct SplitMethod {
    pub parameters: IndexMap<String, f64>,
    /// (estimate − truth) / truth per parameter, when the study states a truth.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub parameter_error: Option<IndexMap<String, f64>>,
    pub training_error: Option<f64>,
    pub validation_error: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub error: Option<String>,
}

impl SplitResult {
    /// The split's results from a full `Results` built for a study whose training and validation
    /// are the split's.
    pub fn from_results(study: &Study, results: &Results) -> SplitResult {
        let methods = results
            .calibration
            .iter()
            .map(|(name, m)| {
                let parameter_error = (!study.experiments.truth.is_empty() && m.error.is_none()).then(|| {
                    study
                        .experiments
                        .truth
                        .iter()
                        .filter_map(|(p, t)| m.parameters.get(p).map(|v| (p.clone(), (v - t) / t)))
                        .collect()
                });
                let entry = SplitMethod {
                    parameters: m.parameters.clone(),
                    parameter_error,
                    training_error: m.training_error,
                    validation_error: m.validation_error,
                    error: m.error.clone(),
                };
                (name.clone(), entry)
            })
            .collect();
        SplitResult {
            training: study.split.training.clone(),
            validation: study.split.validation.clone(),
            methods,
        }
    }
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct SurrogateResult {
    /// `linear`, `quadratic` or `gp`.
    pub kind: String,
    /// Successful sample runs it was fitted to.
    pub samples: usize,
    /// Successful check runs it was checked at.
    pub check_runs: usize,
    /// max |predicted − run| / |run| over the check runs; `null` without check runs.
    pub check_max_relative_error: Option<f64>,
    pub check_mean_relative_error: Option<f64>,
}

impl RunsResult {
    /// When runs failed: `23 of 54 solver runs failed (screening 18, probes 3, confirmation 2); the
    /// emulators, the calibration and the verdict rest on the 31 that finished`.
    pub fn failed_words(&self) -> Option<String> {
        if self.failed == 0 {
            return None;
        }
        let stages: Vec<String> = (self.outcomes.iter())
            .filter_map(|(stage, classes)| {
                let failed: usize = (classes.iter()).filter(|(c, _)| *c != "success").map(|(_, n)| n).sum();
                (failed > 0).then(|| format!("{stage} {failed}"))
            })
            .collect();
        Some(format!(
            "{} of {} solver runs failed ({}); the emulators, the calibration and the verdict rest on the {} that \
             finished",
            self.failed,
            self.planned,
            stages.join(", "),
            self.succeeded
        ))
    }
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct RunsResult {
    /// Every run of the study: the screening's, the solver-in-the-loop's and the confirmation's.
    pub planned: usize,
    pub succeeded: usize,
    pub failed: usize,
    /// Of `planned`, the runs of the solver in the loop (`diagnosis.extensions`).
    #[serde(default)]
    pub in_the_loop: usize,
    /// Of `planned`, the confirmation runs: the solver at the fitted parameters of the models the
    /// verdict rests on, one run per tested design each (`diagnosis.confirmation`).
    #[serde(default)]
    pub confirmation: usize,
    /// Of `planned`, the runs over an open extension's amplitude after no model error
    /// (`diagnosis.not_excluded[].runs`).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub not_excluded: usize,
    /// The recordings the runs were replayed from (`--replay` or the study's `simulation.replay`);
    /// absent when a solver ran. Run times of a replay are the replay's, not the solver's.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub replayed_from: Option<String>,
    /// Runs that succeeded but break a quality gate (counted in `succeeded` too).
    #[serde(default)]
    pub suspect: usize,
    /// The gates the runs were judged by (`simulation.quality`), when the runs report figures.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub gates: Option<Gates>,
    /// Every suspect run, with the gates it breaks and whether the surrogates used it.
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub suspect_runs: Vec<SuspectRun>,
    /// The planned runs per stage (`screening`, `probes`, `loop: <hypothesis>`, `confirmation`) and
    /// outcome class of their record (`success`, `bad_response`, `timeout`, ...; `not_run` for a run
    /// with no record).
    #[serde(default)]
    pub outcomes: IndexMap<String, BTreeMap<String, usize>>,
}

/// A run that broke a quality gate: kept and shown, used only with `quality.suspect: use`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct SuspectRun {
    pub key: String,
    pub design: String,
    /// `sample`, `check` or `extension`.
    pub role: String,
    pub parameters: IndexMap<String, f64>,
    pub response: f64,
    pub flags: Vec<Flag>,
    /// Whether the surrogates were fitted with it.
    pub used: bool,
}

/// One parameter's sampler diagnostics in `results.json`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct ConvergenceResult {
    pub split_rhat: f64,
    pub ess: f64,
    pub converged: bool,
}

/// How the Bayesian posterior was integrated, when by quadrature (one or two parameters): the
/// quadrature's own summary, written as it is.
pub type QuadratureResult = crate::calibrate::bayesian::exact::QuadratureSummary;

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct SamplerResult {
    pub steps: usize,
    pub evaluations_per_move: f64,
    /// The run's move: "independence" (Metropolis–Hastings from the fitted proposal) or "slice".
    #[serde(default)]
    pub kernel: String,
    /// Share of independence proposals accepted (absent with slice steps).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub acceptance: Option<f64>,
    /// Density evaluations of the whole sampler, pilot and adaptation included.
    #[serde(default)]
    pub evaluations: usize,
    /// Per parameter: 1 for θ itself, 0 for ln θ, −1 for 1/θ, ±½ for the roots.
    pub power: IndexMap<String, f64>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct MethodResult {
    pub parameters: IndexMap<String, f64>,
    /// `null` for least squares; `{"constant": d}` for sensitivity; the GP's summary for Bayesian.
    pub discrepancy: Option<serde_json::Value>,
    /// The Bayesian method's posterior summary (absent for the point estimates).
    #[serde(flatten)]
    pub posterior: PosteriorResult,
    pub predictions: Vec<Prediction>,
    /// Mean |relative error| over the training designs.
    pub training_error: Option<f64>,
    /// Mean |relative error| over the validation designs; `null` when the study names none.
    pub validation_error: Option<f64>,
    /// Why the method produced no estimate; the other keys are then empty.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub error: Option<String>,
}

/// The Bayesian method's posterior summary (absent for the point estimates).
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct PosteriorResult {
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub interval95: Option<IndexMap<String, [f64; 2]>>,
    /// Posterior median (Bayesian only).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub median: Option<IndexMap<String, f64>>,
    /// The sampler's split R-hat and effective sample size per parameter (Bayesian, when sampled),
    /// with whether both meet their limits (R-hat ≤ 1.01, ESS ≥ 1000).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub convergence: Option<IndexMap<String, ConvergenceResult>>,
    /// How the sampler ran (Bayesian, when sampled): steps after burn-in, density evaluations per
    /// walker move, and per parameter the power of θ it was sampled in.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub sampler: Option<SamplerResult>,
    /// Posterior mean (Bayesian only).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub mean: Option<IndexMap<String, f64>>,
    /// The quadrature's rule, error estimates and cost (Bayesian, when not sampled).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub quadrature: Option<QuadratureResult>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Prediction {
    pub design: String,
    pub role: Role,
    pub measured: f64,
    pub predicted: f64,
    /// (predicted − measured) / measured.
    pub relative_error: f64,
    /// Number of replicate tests averaged into `measured`.
    pub replicates: usize,
    /// Sample standard deviation of the replicates (the noise estimate); `null` with one test.
    pub measured_std: Option<f64>,
}

#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    Training,
    Validation,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct IdentifiabilityResult {
    pub identifiable: bool,
    pub note: String,
    /// The parameter combinations the training tests determine, when not every parameter is.
    pub combinations: Vec<String>,
    pub singular_values: Vec<f64>,
}

impl From<&Identifiability> for IdentifiabilityResult {
    fn from(i: &Identifiability) -> Self {
        IdentifiabilityResult {
            identifiable: i.identifiable,
            note: i.note.clone(),
            combinations: i.combinations.clone(),
            singular_values: i.singular_values.clone(),
        }
    }
}

impl Results {
    pub fn build(
        study: &Study,
        model: &dyn Model,
        calibration: &Calibration,
        diagnosis: Result<Diagnosis, CalibrationError>,
    ) -> Results {
        let methods = calibration
            .methods
            .iter()
            .map(|(method, outcome)| {
                let result = match outcome {
                    Ok(calibrated) => method_result(study, model, calibrated),
                    Err(e) => MethodResult::failed(e.to_string()),
                };
                (method.key().to_string(), result)
            })
            .collect();
        Results {
            study: study.name.clone(),
            answer: None,
            calibration: methods,
            identifiability: (&calibration.identifiability).into(),
            curve_calibration: None,
            sampling: None,
            diagnosed: Diagnosed {
                diagnosis_error: diagnosis.as_ref().err().map(|e| e.to_string()),
                diagnosis: diagnosis.ok(),
            },
            solver: SolverRecord::default(),
            stated: Stated {
                truth: (!study.experiments.truth.is_empty()).then(|| study.experiments.truth.iter().cloned().collect()),
                splits: None,
                units: Units::of(study),
            },
        }
    }

    /// Adds the surrogates of a solver study, keyed by design name.
    pub fn with_surrogates(mut self, model: &crate::emulate::SurrogateModel) -> Results {
        let entries = model.designs.iter().map(|d| {
            let result = SurrogateResult {
                kind: d.surrogate.kind.key().to_string(),
                samples: d.samples,
                check_runs: d.check.runs,
                check_max_relative_error: d.check.max_relative_error,
                check_mean_relative_error: d.check.mean_relative_error,
            };
            (d.design.clone(), result)
        });
        self.solver.surrogates = Some(entries.collect());
        self
    }

    /// Whether any method failed (the run then exits 1).
    pub fn any_failed(&self) -> bool {
        self.calibration.values().any(|m| m.error.is_some())
    }

    /// Writes `results.json` atomically: a reader never sees a half-written file.
    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        let json = serde_json::to_string_pretty(self).map_err(std::io::Error::other)?;
        crate::report::write_atomic(path, json.as_bytes())
    }

    pub fn read(path: &Path) -> std::io::Result<Results> {
        serde_json::from_slice(&std::fs::read(path)?).map_err(std::io::Error::other)
    }
}

impl MethodResult {
    fn failed(error: String) -> Self {
        MethodResult {
            parameters: IndexMap::new(),
            discrepancy: None,
            predictions: vec![],
            training_error: None,
            validation_error: None,
            error: Some(error),
            posterior: PosteriorResult::default(),
        }
    }
}

fn method_result(study: &Study, model: &dyn Model, calibrated: &Calibrated) -> MethodResult {
    let names = || study.parameters.iter().map(|p| p.name.clone());
    let predictions = predictions(study, model, calibrated);
    let mean_error = |role| {
        let errors: Vec<f64> = predictions
            .iter()
            .filter(|p| p.role == role)
            .map(|p| p.relative_error.abs())
            .collect();
        (!errors.is_empty()).then(|| errors.iter().sum::<f64>() / errors.len() as f64)
    };
    let (training_error, validation_error) = (mean_error(Role::Training), mean_error(Role::Validation));
    let mut result = MethodResult {
        parameters: names().zip(calibrated.theta().iter().copied()).collect(),
        discrepancy: None,
        predictions,
        training_error,
        validation_error,
        error: None,
        posterior: PosteriorResult::default(),
    };
    match calibrated {
        Calibrated::Point(e) => {
            if let Discrepancy::Constant(d) = e.discrepancy {
                result.discrepancy = Some(serde_json::json!({ "constant": d }));
            }
        }
        Calibrated::Bayesian(fit) => {
            result.posterior.interval95 = Some(names().zip(fit.interval95.iter().map(|&(lo, hi)| [lo, hi])).collect());
            result.posterior.median = Some(names().zip(fit.median.iter().copied()).collect());
            result.posterior.mean = Some(names().zip(fit.mean.iter().copied()).collect());
            result.posterior.quadrature = fit.quadrature.clone();
            result.posterior.convergence = (!fit.sampler.convergence.is_empty()).then(|| {
                names()
                    .zip(&fit.sampler.convergence)
                    .map(|(n, c)| {
                        let result = ConvergenceResult {
                            split_rhat: c.split_rhat,
                            ess: c.ess,
                            converged: c.converged(),
                        };
                        (n, result)
                    })
                    .collect()
            });
            result.posterior.sampler = (!fit.sampler.sampling_powers.is_empty()).then(|| SamplerResult {
                steps: fit.sampler.steps,
                evaluations_per_move: fit.sampler.evaluations_per_move,
                kernel: if fit.sampler.acceptance.is_nan() {
                    "slice"
                } else {
                    "independence"
                }
                .into(),
                acceptance: (!fit.sampler.acceptance.is_nan()).then_some(fit.sampler.acceptance),
                evaluations: fit.sampler.evaluations,
                power: names().zip(fit.sampler.sampling_powers.iter().copied()).collect(),
            });
            let d = &fit.discrepancy;
            result.discrepancy = Some(serde_json::json!({
                "gaussian_process": { "mean": d.beta, "std_dev": d.var.sqrt(), "roughness": d.roughness }
            }));
        }
    }
    result
}

/// Calibrated predictions at every training, then validation, design.
fn predictions(study: &Study, model: &dyn Model, calibrated: &Calibrated) -> Vec<Prediction> {
    let roles = study
        .split
        .training
        .iter()
        .map(|n| (n, Role::Training))
        .chain(study.split.validation.iter().map(|n| (n, Role::Validation)));
    roles
        .map(|(name, role)| {
            let test = study
                .experiments
                .get(name)
                .expect("validated: designs are in the experiments");
            let (measured, predicted) = (test.mean(), calibrated.predict(model, &test.values));
            Prediction {
                design: name.clone(),
                role,
                measured,
                predicted,
                relative_error: (predicted - measured) / measured,
                replicates: test.replicates.len(),
                measured_std: test.std_dev(),
            }
        })
        .collect()
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}
