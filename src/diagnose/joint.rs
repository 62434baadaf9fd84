//! The model extended with a hypothesis's physics, calibrated with the solver in the loop.
//!
//! Screening ([`super::diagnose`]) judges a model extension through its runs at one probe value,
//! linearised as `y + γ (y_ext − y)`. The loop replaces that by the extended *model*: the
//! extension's ranged template variables become parameters of the deck, new runs cover the joint
//! space (θ × extension variables), and surrogates over that space are calibrated like the study's
//! own. This module judges the result with the diagnosis's own rules, applied to the extended
//! model as if it were the simulation: its weighted least-squares fit, the Gauss–Newton precision
//! of every parameter (the enlarged set's identifiability), its lack of fit against the replicate
//! noise (training and the validation designs' predictive residuals), the gains on the validation
//! designs and leave-one-design-out, and what the diagnosis of the extended model says is left.
//!
//! Pure: the inputs are the two diagnoses (baseline and extended) and the calibration's figures.

use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

use super::{Diagnosis, Role};
use crate::base::format::num;

/// One ranged extension variable.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VariableRange {
    pub min: f64,
    pub max: f64,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub unit: Option<String>,
}

/// A calibration method's estimate of the extended model's parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MethodEstimate {
    pub parameters: IndexMap<String, f64>,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub interval95: Option<IndexMap<String, [f64; 2]>>,
    /// Why the method gave no estimate.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub error: Option<String>,
}

impl MethodEstimate {
    /// A method's estimate by parameter name (`names` in the study's order), its 95 % interval
    /// where it has one, or why it gave none.
    pub fn of(
        names: &[String],
        outcome: &Result<crate::calibrate::Calibrated, crate::calibrate::CalibrationError>,
    ) -> MethodEstimate {
        match outcome {
            Ok(c) => MethodEstimate {
                parameters: names.iter().cloned().zip(c.theta().iter().copied()).collect(),
                interval95: match c {
                    crate::calibrate::Calibrated::Bayesian(fit) => Some(
                        names
                            .iter()
                            .cloned()
                            .zip(fit.interval95.iter().map(|&(lo, hi)| [lo, hi]))
                            .collect(),
                    ),
                    crate::calibrate::Calibrated::Point(_) => None,
                },
                error: None,
            },
            Err(e) => MethodEstimate {
                parameters: IndexMap::new(),
                interval95: None,
                error: Some(e.to_string()),
            },
        }
    }
}

/// The runs of the loop for one hypothesis, and how well their surrogates reproduce the check runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LoopRuns {
    pub planned: usize,
    pub succeeded: usize,
    /// Samples per design over the joint space (the check runs not counted).
    pub samples_per_design: usize,
    /// Largest |relative error| of the joint surrogates at their check runs (absent without any).
    pub surrogate_check_error: Option<f64>,
    /// Solver runs checked the joint surrogates at the decision's fitted point (or the plan was
    /// fixed); `false` where the loop stopped first, so that its fitted values may be the
    /// emulators' rather than the solver's.
    #[serde(default = "checked_by_default")]
    pub checked: bool,
}

/// Results written before `checked` existed were checked or fixed.
fn checked_by_default() -> bool {
    true
}

/// What the calibration stage says of the extended model (the study's methods, identifiability).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Calibrated {
    pub methods: IndexMap<String, MethodEstimate>,
    pub identifiable: bool,
    pub identifiability: String,
}

/// `diagnosis.extensions[]`: one hypothesis extended with the solver in the loop.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SolverExtension {
    /// What the loop extended: the hypothesis, its ranged and fixed variables, its runs.
    #[serde(flatten)]
    pub setup: LoopSetup,
    /// The parameters and extension variables the loop calibrated, with their precision.
    #[serde(flatten)]
    pub fitted: LoopFit,
    /// The loop model's lack of fit and what it gains in prediction.
    #[serde(flatten)]
    pub judged: LoopJudged,
    /// What the loop model leaves: its residuals, predictions and what remains.
    #[serde(flatten)]
    pub left: LoopLeft,
}

/// What the loop extended: the hypothesis, its ranged and fixed variables, its runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LoopSetup {
    pub hypothesis: String,
    /// The ranged template variables, now parameters of the extended model.
    pub variables: IndexMap<String, VariableRange>,
    /// The extension's template variables held at a value.
    pub fixed: IndexMap<String, f64>,
    pub runs: LoopRuns,
}

/// The parameters and extension variables the loop calibrated, with their precision.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LoopFit {
    /// Weighted least squares over the training designs (the diagnosis's fit): θ, then the
    /// extension variables.
    pub parameters: IndexMap<String, f64>,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub parameter_se: Option<IndexMap<String, f64>>,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub interval95: Option<IndexMap<String, [f64; 2]>>,
    /// corr(θ_i, θ_j) of the enlarged parameter set.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub correlation: Option<IndexMap<String, IndexMap<String, f64>>>,
    /// The study's calibration methods run on the extended model, and its identifiability.
    pub calibration: Calibrated,
}

/// The loop model's lack of fit and what it gains in prediction.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LoopJudged {
    /// The extended model against the replicate noise (absent without replicates).
    pub lack_of_fit_chi2: Option<f64>,
    pub lack_of_fit_dof: Option<usize>,
    pub lack_of_fit_p: Option<f64>,
    /// The same test both ways: the omnibus figures above and the largest standardised residual.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub lack_of_fit: Option<super::LackOfFit>,
    /// Mean |relative error| over the validation designs of the baseline and the extended model.
    pub validation_error_before: Option<f64>,
    pub validation_error_after: Option<f64>,
    pub gain: Option<f64>,
    /// The same, leave-one-design-out over the training designs.
    pub loo_error_before: Option<f64>,
    pub loo_error_after: Option<f64>,
    pub gain_loo: Option<f64>,
}

/// What the loop model leaves: its residuals, predictions and what remains.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LoopLeft {
    /// Standardised residual at every design (training: of the mean; validation: predictive).
    pub residual_z: IndexMap<String, f64>,
    /// Designs where the extended model still misses by more than 2 σ.
    pub remaining: Vec<(String, f64)>,
    /// The extended model's calibrated prediction at every tested design.
    pub predictions: IndexMap<String, f64>,
    /// The screening's linearised amplitude γ at the probe values, for comparison.
    pub screening_amplitude: Option<f64>,
    /// The diagnosis of the extended model: what is left (`no_model_error` when nothing).
    pub what_remains: super::verdict::Verdict,
    pub what_remains_headline: String,
}

impl SolverExtension {
    /// The extended model judged from its own diagnosis (`extended`, made with the study's terms
    /// as candidates) against the baseline's (`baseline`).
    pub fn assess(
        hypothesis: &str,
        variables: IndexMap<String, VariableRange>,
        fixed: IndexMap<String, f64>,
        runs: LoopRuns,
        calibration: Calibrated,
        baseline: &Diagnosis,
        extended: &Diagnosis,
    ) -> SolverExtension {
        let (before, after) = (&baseline.record.uncorrected, &extended.record.uncorrected);
        let val = |u: &super::Uncorrected| u.validation.as_ref().map(|v| v.error);
        let gain = |b: Option<f64>, a: Option<f64>| b.zip(a).filter(|(b, _)| *b > 0.0).map(|(b, a)| 1.0 - a / b);
        let residual_z = standardised(extended);
        let lof = extended.record.lack_of_fit.as_ref();
        let precision = after.precision.as_ref();
        SolverExtension {
            setup: LoopSetup {
                hypothesis: hypothesis.to_string(),
                variables,
                fixed,
                runs,
            },
            fitted: LoopFit {
                parameters: after.parameters.clone(),
                parameter_se: precision.map(|p| p.se.clone()),
                interval95: precision.map(|p| p.interval95.clone()),
                correlation: precision.map(|p| p.correlation.clone()),
                calibration,
            },
            judged: LoopJudged {
                lack_of_fit_chi2: lof.map(|l| l.chi2),
                lack_of_fit_dof: lof.map(|l| l.dof),
                lack_of_fit_p: lof.map(|l| l.p_value),
                lack_of_fit: lof.cloned(),
                validation_error_before: val(before),
                validation_error_after: val(after),
                gain: gain(val(before), val(after)),
                loo_error_before: before.loo_error,
                loo_error_after: after.loo_error,
                gain_loo: gain(before.loo_error, after.loo_error),
            },
            left: LoopLeft {
                remaining: residual_z
                    .iter()
                    .filter(|(_, z)| z.abs() > 2.0)
                    .map(|(n, z)| (n.clone(), *z))
                    .collect(),
                residual_z,
                predictions: extended
                    .record
                    .residuals
                    .iter()
                    .map(|r| (r.design.clone(), r.predicted))
                    .collect(),
                screening_amplitude: baseline
                    .explained
                    .candidates
                    .iter()
                    .find(|c| c.shape.name == hypothesis)
                    .map(|c| c.fit.amplitude),
                what_remains: extended.finding.verdict, // The extended model's diagnosis calls it "the uncorrected simulation".
                what_remains_headline: extended
                    .finding
                    .headline
                    .replace("the uncorrected simulation", "the extended model"),
            },
        }
    }

    /// The ranged variables with their 95 % intervals, in words: `etan = 201.3 (95 % 170.2 to 232.4)`.
    pub fn variables_text(&self) -> String {
        self.setup
            .variables
            .keys()
            .map(|name| {
                let v = self.fitted.parameters.get(name).copied().unwrap_or(f64::NAN);
                match self.fitted.interval95.as_ref().and_then(|i| i.get(name)) {
                    Some([lo, hi]) => format!("{name} = {} (95 % {} to {})", num(v), num(*lo), num(*hi)),
                    None => format!("{name} = {}", num(v)),
                }
            })
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// One line of evidence: the calibrated extension, its fit and its gain.
    pub fn evidence_line(&self) -> String {
        let params: Vec<String> = self
            .fitted
            .parameters
            .iter()
            .filter(|(n, _)| !self.setup.variables.contains_key(*n))
            .map(|(n, v)| format!("{n} = {}", num(*v)))
            .collect();
        let mut line = format!(
            "'{}' calibrated with the solver in the loop ({} runs over {}): {}, {}",
            self.setup.hypothesis,
            self.setup.runs.succeeded,
            self.fitted.parameters.keys().cloned().collect::<Vec<_>>().join(" × "),
            self.variables_text(),
            params.join(", ")
        );
        if let Some(l) = &self.judged.lack_of_fit {
            line.push_str(&format!(
                "; lack of fit against the replicate noise {}",
                crate::diagnose::text::lack_of_fit(l)
            ));
        }
        if let (Some(b), Some(a)) = (self.judged.validation_error_before, self.judged.validation_error_after) {
            line.push_str(&format!("; validation error {:.2} % → {:.2} %", 100.0 * b, 100.0 * a));
        }
        if let (Some(b), Some(a)) = (self.judged.loo_error_before, self.judged.loo_error_after) {
            line.push_str(&format!(
                ", leave-one-design-out {:.2} % → {:.2} %",
                100.0 * b,
                100.0 * a
            ));
        }
        if !self.setup.runs.checked {
            line.push_str(
                "; no solver run checked its emulators at this fitted point (the loop stopped first), so these \
                 values may be the emulators' rather than the solver's",
            );
        }
        line.push('.');
        line
    }
}

impl Diagnosis {
    /// The diagnosis with the loop's records (its runs, calibration methods and figures) under
    /// `extensions` (worded by [`Diagnosis::worded`]). The verdict already rests on the loop's
    /// models ([`super::conclude`]); this adds what only the run engine knows.
    pub fn with_extensions(mut self, extensions: Vec<SolverExtension>) -> Diagnosis {
        self.explained.extensions = extensions;
        self
    }
}

/// Training residuals in units of the noise of the mean, validation designs by their predictive z.
fn standardised(d: &Diagnosis) -> IndexMap<String, f64> {
    let predictive = d.record.uncorrected.validation.as_ref().map(|v| &v.z);
    d.record
        .residuals
        .iter()
        .map(|r| {
            let z = match (r.role, predictive.and_then(|z| z.get(&r.design))) {
                (Role::Validation, Some(z)) => *z,
                _ => r.z,
            };
            (r.design.clone(), z)
        })
        .collect()
}
