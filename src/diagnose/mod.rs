//! Diagnosis: what the simulation gets wrong, which candidate cause explains it, how much an
//! extended model gains, and which test would settle it.
//!
//! Pure functions over arrays, like [`crate::calibrate`]: [`diagnose`] takes [`Inputs`] (built from
//! a study by [`inputs_from_study`], or by hand) and returns a serialisable [`Diagnosis`] whose
//! contract keys (`discrepancy_detected`, `cause`, `candidates`, `extended`, `next_test`) go into
//! `results.json` under `diagnosis`.
//!
//! The stage is a pipeline of small pure steps, each with a typed output that `results.json`
//! records (read [`diagnose`] first):
//! 1. [`noise`]: σ per design from the replicates, absolute or relative by likelihood.
//! 2. [`candidates`]: the uncorrected model and every candidate shape fitted jointly with θ,
//!    scored out of sample.
//! 3. [`evidence`]: per candidate, the likelihood-ratio test against a refit of θ alone, the
//!    covariance of (θ, γ) (standard error and interval of γ, correlation with each θ_j, variance
//!    inflation) and the predictive check at the validation designs. Separability from θ is decided
//!    here, by the data, never by the angle between shapes.
//! 4. [`ranking`]: weights, the leader, and encompassing tests of the leader against every rival.
//! 5. [`verdict`]: one of a fixed vocabulary, from the tests of steps 3–4 at one α.
//! 6. [`extension`]: the leader's extended model, its lack of fit against the replicate noise, and
//!    the gains (validation and leave-one-design-out) with a flag where "before" is within the noise.
//! 7. [`next_test`]: where in the design box the leading explanations differ most against the
//!    noise, and how many specimens there make the test decisive (power at α).
//! 8. [`residuals`] and [`text`]: the residual table, its trends, and the words.
//!
//! After the verdict, when no listed hypothesis explains the misfit, [`discover`] searches a
//! [`library`] of shapes for the missing term (the verdict stays the listed hypotheses'; what it
//! finds is reported beside it, found by search, not listed, and compared by the next test).

pub mod after_loop;
pub mod candidates;
pub mod confirm;
pub mod discover;
pub mod evidence;
pub mod extension;
pub mod features;
pub mod joint;
pub mod lack_of_fit;
pub mod levels;
pub mod library;
pub mod limits;
mod mixings;
pub mod next_test;
pub mod noise;
pub mod open;
pub mod ranking;
pub mod readings;
pub mod refit;
pub mod residuals;
pub mod shapes;
pub mod stats;
pub mod verdict;

mod fit;
pub mod text;

use indexmap::IndexMap;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

pub use lack_of_fit::LackOfFit;
pub use levels::Levels;
pub use noise::{NoiseKind, NoiseModel};
pub use shapes::{Origin, Shape};

use crate::calibrate::{Bounds, CalibrationError, Model};
use crate::study::Study;
use fit::Data;
use verdict::Verdict;

/// Which role a tested design plays.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// Used for calibration and for ranking the candidates.
    Training,
    /// Held out: measures the gain of the extended model.
    Validation,
}

/// One tested design: its replicate summary.
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    pub name: String,
    /// Design-variable values, in the order of [`Space::design_names`].
    pub design: Vec<f64>,
    pub role: Role,
    /// Mean of the replicates.
    pub mean: f64,
    /// Number of replicates.
    pub count: usize,
    /// Sample standard deviation of the replicates (`None` with one test).
    pub std_dev: Option<f64>,
    /// Which of [`Inputs::outputs`] this observes (0 for a scalar response).
    pub output: usize,
    /// The tested design it belongs to (its own name, unless it is one output of several).
    pub group: String,
}

impl Observation {
    pub fn from_replicates(name: impl Into<String>, design: Vec<f64>, role: Role, replicates: &[f64]) -> Self {
        let (mean, std_dev) = crate::study::experiments::mean_sd(replicates);
        let name = name.into();
        Observation {
            group: name.clone(),
            name,
            design,
            role,
            mean,
            count: replicates.len(),
            std_dev,
            output: 0,
        }
    }

    /// The same replicates observing output `k` (named `output`) of a multi-output study (a curve
    /// feature); the design's name stays its group.
    pub fn of_output(mut self, k: usize, output: &str) -> Self {
        self.output = k;
        self.name = format!("{} · {output}", self.group);
        self
    }
}

/// Decision thresholds; the defaults are the documented rules.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// The one significance level of every test the verdict rests on (detection is Bonferroni
    /// corrected over the K candidates: α/K).
    pub alpha: f64,
    /// Power the recommended next test should reach at α.
    pub power: f64,
    /// Variance inflation of γ above which a shape that the data do not separate is described as
    /// absorbed by θ (10: the usual collinearity rule, Marquardt 1970). Words only: never a veto.
    pub absorbed_inflation: f64,
    /// |cos| between a study hypothesis and a built-in above which they are the same shape (the
    /// built-in is then dropped: the hypothesis carries the user's name). Numerically equal only.
    pub same_shape_cosine: f64,
    /// Grid points per design variable for the next-test search (up to three variables).
    pub grid_per_axis: usize,
    /// Latin-hypercube points for the next-test search above three design variables.
    pub search_points: usize,
    /// Run the library search ([`discover`]) even when no model error is detected, from the
    /// uncorrected model: how its rate of false discovery is measured on clean data. Off by default.
    pub search_without_detection: bool,
    /// The simulation's own error (its emulator's) counted in the noise of every test mean, at least
    /// this share of that noise's variance (0: only what was measured). A sequential study's loop
    /// judges its decision with the error at its tolerance's worst case.
    pub emulator_floor: f64,
    /// Count the simulation's own error (the emulators' error: `Inputs::emulator`, a curve
    /// emulator's check runs, the floor) in the noise. Off: the tests' noise alone, the decision a
    /// solver study compares with the counted one to see whether the emulators decide it.
    pub emulator_counted: bool,
    /// The measurement's uncertainty of one test the study states (`experiments.uncertainty`:
    /// `[absolute, relative]`): the noise where the tests have no replicates.
    pub measurement: Option<[f64; 2]>,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            alpha: 0.01,
            power: 0.9,
            absorbed_inflation: 10.0,
            same_shape_cosine: 1.0 - 1e-9,
            grid_per_axis: 21,
            search_points: 4000,
            search_without_detection: false,
            emulator_floor: 0.0,
            emulator_counted: true,
            measurement: None,
        }
    }
}

/// The parameters and the design variables: their names and bounds (the diagnosis's [`Inputs`]
/// and its curve inputs, [`features::CurveInputs`]).
#[derive(Debug, Clone)]
pub struct Space {
    pub parameter_names: Vec<String>,
    pub parameter_bounds: Bounds,
    pub design_names: Vec<String>,
    pub design_bounds: Bounds,
}

impl Space {
    /// A study's parameters and design variables.
    pub fn of_study(study: &Study) -> Space {
        Space {
            parameter_names: study.parameters.iter().map(|p| p.name.clone()).collect(),
            parameter_bounds: study.parameter_bounds(),
            design_names: study.design.iter().map(|d| d.name.clone()).collect(),
            design_bounds: study.design_bounds(),
        }
    }

    /// Design-variable values `d` by name.
    pub fn design_at(&self, d: &[f64]) -> IndexMap<String, f64> {
        self.design_names.iter().cloned().zip(d.iter().copied()).collect()
    }
}

/// Everything the diagnosis needs.
#[derive(Clone)]
pub struct Inputs<'a> {
    /// Every tested design with its role (training and validation).
    pub observations: Vec<Observation>,
    pub model: &'a dyn Model,
    pub space: Space,
    /// The user's candidate causes (study hypotheses); the built-in shapes are added by [`diagnose`].
    pub hypotheses: Vec<Shape>,
    pub settings: Settings,
    /// What the library is built from (the design variables' units and scales, the simulation's
    /// exponents), when a library of shapes is searched where no listed hypothesis explains the
    /// misfit (`diagnosis.discover`); `None`: no search.
    pub library: Option<library::LibrarySpec>,
    /// The shapes every diagnosis tries besides the hypotheses (`None`: [`Shape::built_ins`] over
    /// the design variables).
    pub built_ins: Option<Vec<Shape>>,
    /// What the observations are when they are not the response itself (whitened curve features);
    /// `None`: the response, its noise from the replicate scatter of the observations.
    pub features: Option<FeatureOutputs>,
    /// The simulation's own error at each observation (its emulators', measured at runs they were
    /// not fitted to), counted in the noise of that observation's mean where the settings count it.
    pub emulator: crate::emulate::Uncertainty,
}

/// The observations as outputs other than the response: the features of curves, whitened by
/// their covariance ([`Inputs::features`]).
#[derive(Clone)]
pub struct FeatureOutputs {
    /// The outputs each tested design is observed in: the names of the curve features. With
    /// several, the model and every shape are called with the output's index appended to the
    /// design (`[c, t, k]`).
    pub outputs: Vec<String>,
    /// The noise, known better than the replicate scatter of the observations (σ = 1 with the
    /// covariance's own degrees of freedom).
    pub noise: NoiseModel,
    /// The relative error of a prediction at an observation (the plateau level's, `None` for the
    /// other features); without features it is (predicted − measured) / measured.
    pub relative_error: RelativeError,
}

/// See [`FeatureOutputs::relative_error`].
pub type RelativeError = std::sync::Arc<dyn Fn(&Observation, f64) -> Option<f64> + Send + Sync>;

impl Inputs<'_> {
    /// The number of outputs each tested design is observed in (1 for the response).
    pub fn outputs(&self) -> usize {
        self.features.as_ref().map_or(1, |f| f.outputs.len())
    }

    /// An observation's point as the model and the shapes see it: the design, and with several
    /// outputs the output's index after it.
    pub fn point(&self, o: &Observation) -> Vec<f64> {
        if self.outputs() > 1 {
            o.design.iter().copied().chain([o.output as f64]).collect()
        } else {
            o.design.clone()
        }
    }

    /// Every candidate shape: the study's hypotheses, then the built-in terms.
    pub(crate) fn candidate_shapes(&self) -> impl Iterator<Item = Shape> + '_ {
        let built_ins = (self.built_ins.clone()).unwrap_or_else(|| Shape::built_ins(&self.space.design_names));
        self.hypotheses.iter().cloned().chain(built_ins)
    }
}

/// The diagnosis inputs of a study: its training and validation designs (replicates summarised),
/// its parameters and design bounds, and its `diagnosis.hypotheses` (a model extension without the
/// surrogate of its runs is skipped with a note: see [`inputs_with_extensions`]).
pub fn inputs_from_study<'a>(study: &Study, model: &'a dyn Model) -> Inputs<'a> {
    inputs_with_extensions(study, model, &[])
}

/// [`inputs_from_study`], with the model of each extension hypothesis's runs: `(k, y_ext)` for
/// `study.diagnosis.hypotheses[k]`. Its candidate is `y_ext(d, θ) − y(d, θ)` ([`Shape::from_extension`]).
pub fn inputs_with_extensions<'a>(
    study: &Study,
    model: &'a dyn Model,
    extensions: &[(usize, std::sync::Arc<dyn Model + Send>)],
) -> Inputs<'a> {
    let observations = study
        .split
        .training
        .iter()
        .map(|n| (n, Role::Training))
        .chain(study.split.validation.iter().map(|n| (n, Role::Validation)))
        .filter_map(|(name, role)| {
            let t = study.experiments.get(name)?;
            Some(Observation::from_replicates(
                name.clone(),
                t.values.clone(),
                role,
                &t.replicates,
            ))
        })
        .collect();
    Inputs {
        observations,
        model,
        space: Space::of_study(study),
        hypotheses: study
            .diagnosis
            .hypotheses
            .iter()
            .enumerate()
            .map(
                |(k, h)| match (h.extension(), extensions.iter().find(|(j, _)| *j == k)) {
                    (Some(variables), Some((_, ext))) => {
                        let mut shape = Shape::from_extension(h.name.clone(), variables, ext.clone());
                        shape.ranges = h.declared_ranges();
                        shape
                    }
                    _ => Shape::from_hypothesis(h, study),
                },
            )
            .collect(),
        settings: Settings {
            measurement: study.experiments.uncertainty,
            ..Settings::default()
        },
        library: study.diagnosis.discover.then(|| library::LibrarySpec {
            units: study.design.iter().map(|d| d.unit.clone()).collect(),
            scales: study.design.iter().map(|d| d.scale).collect(),
            exponents: match &study.simulation {
                crate::study::Simulation::Expression(e) => e.exponents(),
                crate::study::Simulation::Solver(_) => Vec::new(),
            },
        }),
        built_ins: None,
        features: None,
        emulator: Default::default(),
    }
}

/// The diagnosis, as written under `diagnosis` in `results.json`: four parts, each flattened into
/// the one object (the keys and their order are the record's).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Diagnosis {
    /// What the diagnosis decided, and its words.
    #[serde(flatten)]
    pub finding: Finding,
    /// The explanations weighed, the models they make, and the test that would tell them apart.
    #[serde(flatten)]
    pub explained: Explained,
    /// What was checked beyond the screening: the library search, the curves, what the tests leave
    /// open, the solver's confirmation, the emulators' part, the loop.
    #[serde(flatten)]
    pub checked: Checked,
    /// The uncorrected model and the noise it was judged against.
    #[serde(flatten)]
    pub record: Record,
}

/// What the diagnosis decided (`verdict`, `cause`, …) and its words (`headline`, `action`, …).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Finding {
    /// Whether the data show model error beyond the noise.
    pub discrepancy_detected: bool,
    /// The cause the verdict decides (`verdict` = `cause_named`); `null` otherwise, also when a
    /// listed cause explains part of the misfit (that one is `partial`).
    pub cause: Option<String>,
    /// A listed cause that explains part of the misfit but not all of it (`verdict` =
    /// `partly_explained`): what it removes and what remains. Never the answer.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub partial: Option<Partial>,
    /// The verdict, from a fixed vocabulary; `headline` is its sentence.
    pub verdict: verdict::Verdict,
    pub headline: String,
    /// The explanations the verdict leaves open, best first (the cause alone when it is decisive).
    pub leading: Vec<String>,
    /// What to do next, in one sentence.
    pub action: String,
    /// The evidence, one fact per line.
    pub evidence: Vec<String>,
    /// What the data cannot say.
    pub limits: Vec<String>,
}

/// The explanations the diagnosis weighed and what they make of the simulation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Explained {
    /// Ranked best first: the study's hypotheses and the built-in shapes.
    pub candidates: Vec<Candidate>,
    /// The leader's encompassing tests against every rival.
    pub rivals: Vec<ranking::RivalTest>,
    /// The model extended with the cause (absent when none is named; a partial explanation's is in
    /// `partial`).
    pub extended: Option<Extended>,
    /// When the final model still misses the tests: how far each parameter moves when the
    /// residuals beyond the noise are absorbed (empty when it fits).
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub parameter_limits: Vec<limits::ParameterLimit>,
    /// The hypotheses extended with the solver in the loop (ranged extension variables
    /// calibrated through new runs), best first; empty when none was.
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub extensions: Vec<joint::SolverExtension>,
    /// The test that would best tell the leading explanations apart.
    pub next_test: Option<NextTest>,
}

/// What the diagnosis checked beyond the screening (each absent or empty where it did not run).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Checked {
    /// The library search for a missing term, when it ran ([`discover`]): found by search, not listed.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub discovered: Option<discover::Discovered>,
    /// With curves: the features read and where along the stroke the model errs.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub features: Option<features::FeaturesReport>,
    /// With no model error: what the tests leave open of each listed hypothesis ([`open`]).
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub not_excluded: Vec<open::NotExcluded>,
    /// The verdict's models run by the solver at their fitted parameters ([`confirm`]); empty for a
    /// closed form, which has no emulator to confirm.
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub confirmation: Vec<confirm::Confirmation>,
    /// The decision with the tests' noise alone and with the emulators' error counted, and which
    /// the solver confirmed (absent for a closed form).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub emulator: Option<confirm::EmulatorReading>,
    /// How the models the loop calibrated changed the screening's verdict (absent without a loop).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub after_loop: Option<after_loop::AfterLoop>,
    /// The named cause's parameters as the solver's runs at the loop's fitted point refit them,
    /// where that refit leaves the loop's interval ([`refit`]; absent otherwise).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub solver_refit: Option<refit::SolverRefit>,
}

/// The uncorrected model, the noise it was judged against, and the rule.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Record {
    /// The verdict, the action and the evidence as one text (terminal and report).
    pub summary: String,
    pub noise: NoiseModel,
    /// The uncorrected model (least squares weighted by the noise, training designs).
    pub uncorrected: Uncorrected,
    /// The lack-of-fit test of the uncorrected model against the replicate noise (training
    /// residuals and the validation designs' predictive residuals; needs replicates).
    pub lack_of_fit: Option<LackOfFit>,
    /// Residuals of the uncorrected model at every design.
    pub residuals: Vec<Residual>,
    /// Structure of the residuals against each design variable and the prediction.
    pub structure: Vec<Trend>,
    /// One sentence per candidate the data cannot tell from a change of θ.
    pub confounded: Vec<String>,
    /// The levels the decision's tests were held to.
    pub levels: LevelsRecord,
    /// The decision rule, in words.
    pub rule: String,
    /// Anything skipped or degenerate.
    pub notes: Vec<String>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    /// What the candidate is: its name, term and origin.
    #[serde(flatten)]
    pub shape: CandidateShape,
    /// How it ranks: its information criteria, score and weight.
    #[serde(flatten)]
    pub scores: CandidateScores,
    /// Its fit with the parameters: amplitude, parameters, misfit and amplitude test.
    #[serde(flatten)]
    pub fit: CandidateFit,
    /// What its fit shows beyond the amplitude test.
    #[serde(flatten)]
    pub checks: CandidateChecks,
}

/// What the candidate is: its name, term and origin.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CandidateShape {
    pub name: String,
    pub term: String,
    pub origin: Origin,
    /// The built-in shape this study hypothesis stands in for, if any.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub replaces: Option<String>,
}

/// How it ranks: its information criteria, score and weight.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CandidateScores {
    /// Mean |relative error| of the leave-one-design-out predictions over the training designs
    /// (`null` with too few designs to leave one out).
    pub loo_error: Option<f64>,
    /// `null` when the data give no likelihood (no replicates and no spare designs).
    pub bic: Option<f64>,
    /// `null` when the designs do not exceed the fitted numbers by two.
    pub aicc: Option<f64>,
    /// Leave-one-design-out predictive deviance (−2 log predictive likelihood, up to a constant).
    pub loo_deviance: Option<f64>,
    /// The ranking key, smaller is better (see [`candidates`]); `null` when the data give none.
    pub score: Option<f64>,
    pub weight: f64,
}

/// Its fit with the parameters: amplitude, parameters, misfit and amplitude test.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CandidateFit {
    /// Fitted amplitude γ of the term.
    pub amplitude: f64,
    pub parameters: IndexMap<String, f64>,
    /// Σ w_i² r_i² of the joint fit (χ² when the noise is known).
    pub weighted_rss: f64,
    /// p-value of the amplitude: the likelihood-ratio (extra-sum-of-squares F) test of the joint fit
    /// against a refit of θ alone (`null` when the data give no test).
    pub p_value: Option<f64>,
    /// p < α / K: the data tell this shape from a change of θ and it reduces the misfit.
    pub explains_misfit: bool,
}

/// What its fit shows beyond the amplitude test.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CandidateChecks {
    /// The joint fit's covariance figures for γ.
    pub separability: evidence::Separability,
    /// The predictive check at the validation designs (absent without them).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub validation: Option<evidence::Check>,
    /// Lack of fit of this candidate's model against the replicate noise (training and validation).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub lack_of_fit: Option<LackOfFit>,
    /// Parameters the data cannot tell this shape apart from: not significant, and its amplitude's
    /// variance inflated ≥ 10 × by them (empty otherwise).
    pub confounded_with: Vec<String>,
    /// The candidate's calibrated prediction at every tested design.
    pub predictions: IndexMap<String, f64>,
    /// A model extension's template variables (absent for a term).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub extension: Option<IndexMap<String, f64>>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Uncorrected {
    pub parameters: IndexMap<String, f64>,
    /// The ranking metrics, as for a candidate (`null` when they could not be computed).
    pub loo_error: Option<f64>,
    pub bic: Option<f64>,
    pub aicc: Option<f64>,
    pub loo_deviance: Option<f64>,
    pub score: Option<f64>,
    pub weight: Option<f64>,
    pub weighted_rss: f64,
    /// The predictive check at the validation designs (absent without them).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub validation: Option<evidence::Check>,
    /// How precisely the training designs fix the parameters (absent without a covariance).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub precision: Option<Precision>,
}

/// The precision of a weighted least-squares fit's parameters, from its Gauss–Newton covariance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Precision {
    /// Standard error per parameter.
    pub se: IndexMap<String, f64>,
    /// θ ± t(0.975, ν) SE.
    pub interval95: IndexMap<String, [f64; 2]>,
    /// corr(θ_i, θ_j), row by row.
    pub correlation: IndexMap<String, IndexMap<String, f64>>,
    /// Per parameter, the standard deviation of the shift the emulators' error causes (included in
    /// `se` and `interval95`; [`Context::emulator_covariance`]). Empty where it is not known.
    #[serde(skip_serializing_if = "IndexMap::is_empty", default)]
    pub emulator_se: IndexMap<String, f64>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Extended {
    /// The extended model: the cause's term, its amplitude and the parameters.
    #[serde(flatten)]
    pub model: ExtendedFit,
    /// What the extension gains in prediction, on validation and left-out designs.
    #[serde(flatten)]
    pub gains: ExtendedGain,
    /// How the extended model fits the tests, and where it still misses.
    #[serde(flatten)]
    pub check: ExtendedCheck,
}

/// The extended model: the cause's term, its amplitude and the parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExtendedFit {
    pub cause: String,
    pub term: String,
    pub amplitude: f64,
    /// 95 % interval of the amplitude (absent when the joint fit has no covariance).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub amplitude_ci95: Option<[f64; 2]>,
    pub parameters: IndexMap<String, f64>,
    /// Standard errors of the parameters in the extended fit (absent without a covariance).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub parameter_se: Option<IndexMap<String, f64>>,
    /// Relative change of each parameter from the uncorrected calibration.
    pub parameter_change: IndexMap<String, f64>,
}

/// What the extension gains in prediction, on validation and left-out designs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExtendedGain {
    /// Mean |relative error| over the validation designs (leave-one-design-out over the training
    /// designs when there are none), before and after; `gain` = 1 − after / before.
    pub validation_error_before: f64,
    pub validation_error_after: f64,
    pub gain: Option<f64>,
    /// `validation` or `leave-one-out` (no validation designs).
    pub measured_on: String,
    /// The leave-one-design-out errors and gain over the training designs, beside the validation
    /// gain (absent with too few designs to leave one out).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub loo_error_before: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub loo_error_after: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub gain_loo: Option<f64>,
    /// Validation designs where the uncorrected prediction is already within the noise (|z| < 2):
    /// the gain there says nothing.
    pub before_within_noise: Vec<String>,
}

/// How the extended model fits the tests, and where it still misses.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExtendedCheck {
    /// The extended model's lack of fit against the replicate noise (training residuals and the
    /// validation designs' predictive residuals); absent without replicates.
    pub lack_of_fit_chi2: Option<f64>,
    pub lack_of_fit_dof: Option<usize>,
    pub lack_of_fit_p: Option<f64>,
    /// The same test both ways: the omnibus figures above and the largest standardised residual.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub lack_of_fit: Option<LackOfFit>,
    /// Designs where the extended model still misses by more than 2 σ (name, z).
    pub remaining: Vec<(String, f64)>,
    /// The extended model's standardised residual at every design (training: of the mean;
    /// validation: predictive); empty without a noise.
    pub residual_z: IndexMap<String, f64>,
    /// When the cause is a model extension: its variables and what the amplitude means.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub extension: Option<ExtensionEffect>,
    /// Whether the figures above are the extended model calibrated with the solver in the loop
    /// (`diagnosis.extensions`), not the screening's linearisation.
    #[serde(default)]
    pub solver_in_the_loop: bool,
}

/// The levels of the tests a diagnosis rests on (`diagnosis.levels`), as [`Levels`] derives them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LevelsRecord {
    /// The one α: model error is claimed at this level in all.
    pub alpha: f64,
    /// Each of the uncorrected model's two lack-of-fit tests (its share of α, halved).
    pub uncorrected_fit: f64,
    /// The K candidates' amplitude tests together (each at this / K).
    pub candidates: f64,
    /// Each of the two lack-of-fit tests of a cause's model.
    pub cause_fit: f64,
}

/// A listed cause that explains part of the misfit (`diagnosis.partial`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Partial {
    pub name: String,
    /// The share of the uncorrected model's misfit beyond the noise that its model removes:
    /// 1 − (χ²_ext − dof_ext) / (χ²_unc − dof_unc), in [0, 1] (`null` without both lack-of-fit tests).
    pub share_removed: Option<f64>,
    /// What remains: its final model's lack of fit, both ways.
    pub remaining: Option<LackOfFit>,
    /// Designs its model still misses by more than 2 σ (name, z).
    pub misses: Vec<(String, f64)>,
    /// Its extended model, with the figures `extended` gives for a named cause.
    pub extended: Option<Extended>,
}

impl Partial {
    fn new(name: String, extended: Option<Extended>, uncorrected: Option<&LackOfFit>) -> Partial {
        let remaining = extended.as_ref().and_then(|e| e.check.lack_of_fit.clone());
        let share_removed = uncorrected
            .zip(remaining.as_ref())
            .and_then(|(u, r)| r.share_removed(u));
        Partial {
            name,
            share_removed,
            remaining,
            misses: extended.as_ref().map_or_else(Vec::new, |e| e.check.remaining.clone()),
            extended,
        }
    }
}

impl Diagnosis {
    /// The model extended with the named cause, or with the cause that partly explains the misfit.
    pub fn extended_model(&self) -> Option<&Extended> {
        self.explained
            .extended
            .as_ref()
            .or_else(|| self.finding.partial.as_ref().and_then(|p| p.extended.as_ref()))
    }
}

/// The cause as a model extension: `y + γ (y_ext − y)`, see [`shapes`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExtensionEffect {
    /// The template variables of the extension's runs.
    pub variables: IndexMap<String, f64>,
    /// γ: 1 is the extension exactly as specified, 0 the baseline.
    pub amplitude: f64,
    /// γ in words (linearisation, and the equivalent value of a single variable).
    pub meaning: String,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NextTest {
    /// Where to test, why, and what the two explanations predict there.
    #[serde(flatten)]
    pub choice: TestChoice,
    /// How many specimens, with what power, or what else would tell.
    #[serde(flatten)]
    pub amount: TestAmount,
}

/// Where to test, why, and what the two explanations predict there.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TestChoice {
    pub design: IndexMap<String, f64>,
    pub why: String,
    /// What it takes there (specimens, power), in one clause.
    pub advice: String,
    /// The significance level at which the programme's specimens would decide (the detection's
    /// level for a candidate against the uncorrected model, α otherwise): its power is at this level.
    #[serde(default)]
    pub level: f64,
    /// The two explanations that are closest there (the second may be `uncorrected`).
    pub between: [String; 2],
    pub predictions: [f64; 2],
    /// |difference| / σ of one test there.
    pub separation: f64,
    /// Every explanation compared, with its prediction at the design.
    pub compared: IndexMap<String, f64>,
    /// The tested design at this point, if any, and its specimens.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub already_tested: Option<(String, usize)>,
    /// With several outputs (curve features), the one `predictions` and `compared` are read at:
    /// where the two differ most.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub output: Option<String>,
}

/// How many specimens, with what power, or what else would tell.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TestAmount {
    /// Specimens needed at the design for power ≥ `power` at α (`null` when no number suffices,
    /// or the noise is unknown).
    pub specimens: Option<usize>,
    /// Specimens to add to those already tested there.
    pub additional_specimens: Option<usize>,
    /// The power of the recommended test at the explanations' fitted parameters.
    pub power: Option<f64>,
    /// Its power averaged over the uncertainty of the fitted parameters (absent without their
    /// covariance).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub expected_power: Option<f64>,
    /// The recommended specimens design by design: one design, or a programme of two or three
    /// when that is cheaper or when no single design decides (empty when nothing decides).
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub programme: Vec<next_test::ProgrammeRun>,
    /// Only designs outside the design bounds decide (the programme lies there).
    #[serde(default)]
    pub outside_range: bool,
    /// Independent measurements of a parameter that would decide with the tests in hand.
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub measurements: Vec<next_test::Measurement>,
    /// No programme decides, where exact simulations would: the explanations differ by less than
    /// their emulators' own error (measured on runs they were not fitted to), so more solver runs,
    /// not more specimens, come first.
    #[serde(skip_serializing_if = "std::ops::Not::not", default)]
    pub limited_by_emulators: bool,
    /// Where the tests' noise is not measured (no replicates, none stated): the specimens are
    /// replicates that measure it, and this is the degrees of freedom of that scatter, on which
    /// the programme decides (`power` is then a t test's).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub scatter_dof: Option<usize>,
}

impl NextTest {
    /// The specimens in hand already decide: the programme is one tested design with none to add.
    pub fn in_hand(&self) -> bool {
        matches!(self.amount.programme.as_slice(), [one] if one.additional == 0)
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Residual {
    pub design: String,
    pub role: Role,
    pub values: IndexMap<String, f64>,
    /// The tests at the design: their mean, how many, their standard deviation.
    #[serde(flatten)]
    pub test: TestMean,
    pub predicted: f64,
    /// measured − predicted.
    pub residual: f64,
    /// (predicted − measured) / measured, as in the contract; null where it means nothing (a
    /// whitened curve feature, a measured value of zero).
    pub relative_error: Option<f64>,
    /// σ of the mean measurement.
    pub sigma: f64,
    /// residual / sigma.
    pub z: f64,
}

/// The tests at the design: their mean, how many, their standard deviation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TestMean {
    pub measured: f64,
    pub count: usize,
    pub std_dev: Option<f64>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Trend {
    /// A design variable's name, or `prediction`.
    pub against: String,
    pub rank_correlation: f64,
    pub rank_p_value: f64,
    /// Slope of the standardised residuals per unit of the variable, and its p-value.
    pub slope: f64,
    pub slope_p_value: f64,
    /// Either p-value below α.
    pub significant: bool,
}

/// How much the designs allow: decided by counts alone, before any fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Mode {
    /// Enough training designs to leave one out and to correct AICc: full ranking.
    Ranked,
    /// Replicates give the noise, but the training designs barely exceed the parameters: each
    /// candidate is tested against the replicate noise, ranked by AIC plus the validation designs'
    /// predictive deviance.
    Few,
    /// Neither replicates nor spare designs: no test of model error is possible.
    TooFew,
}

/// What every step sees: the inputs, the weighted data, the split of the designs and the mode.
pub(crate) struct Context<'a> {
    pub inputs: &'a Inputs<'a>,
    pub data: Data<'a>,
    pub train: Vec<usize>,
    pub val: Vec<usize>,
    /// Degrees of freedom of the replicate noise; 0 without replicates (then σ is estimated from
    /// the residuals of each fit, and the weights are √n_i).
    pub nu: usize,
    pub mode: Mode,
    /// Weighted RSS below this counts as zero (floating-point-exact data).
    pub rss_floor: f64,
    /// The base model is the study's own simulation: its lack of fit detects model error, with
    /// its two tests sharing α ([`lack_of_fit`]).
    pub detection: bool,
    /// The emulators' error counted in each observation's variance (empty: none counted).
    emulator: Vec<f64>,
}

impl<'a> Context<'a> {
    /// The context under `noise`, the emulators' error counted where the settings count it: only
    /// the part the parameters cannot absorb ([`crate::emulate::Uncertainty::beyond`], at the
    /// uncorrected model's fit under the tests' noise alone).
    fn new(inputs: &'a Inputs<'a>, noise: Option<&NoiseModel>, detection: bool) -> Result<Self, CalibrationError> {
        let first = Self::weighted(inputs, noise, detection, Vec::new())?;
        if !inputs.settings.emulator_counted || inputs.emulator.is_empty() {
            return Ok(first);
        }
        let emulator = match first.data.fit(&[], &first.train) {
            Ok(fit) => inputs
                .emulator
                .beyond(&first.base_jacobian(&fit), &first.data.weights, &first.train),
            Err(_) => (0..inputs.observations.len())
                .map(|i| inputs.emulator.variance(i))
                .collect(),
        };
        Self::weighted(inputs, noise, detection, emulator)
    }

    /// ∂ŷ/∂θ of the uncorrected model at `fit`, a row per observation.
    fn base_jacobian(&self, fit: &fit::Fit) -> DMatrix<f64> {
        let rows: Vec<DVector<f64>> = self
            .data
            .designs
            .iter()
            .map(|d| self.data.gradient(&[], fit, d))
            .collect();
        DMatrix::from_fn(rows.len(), fit.theta.len(), |i, j| rows[i][j])
    }

    /// The covariance of the uncorrected model's parameters that the emulators' error causes where
    /// it is counted and its shape across designs is known
    /// ([`crate::emulate::Uncertainty::parameter_covariance`]).
    pub(crate) fn emulator_covariance(&self, fit: &fit::Fit) -> Option<DMatrix<f64>> {
        if !self.inputs.settings.emulator_counted {
            return None;
        }
        let jacobian = self.base_jacobian(fit);
        self.inputs
            .emulator
            .parameter_covariance(&jacobian, &self.data.weights, &self.train)
    }

    /// The context with `emulator` the emulators' error counted at each observation (empty: none).
    fn weighted(
        inputs: &'a Inputs<'a>,
        noise: Option<&NoiseModel>,
        detection: bool,
        emulator: Vec<f64>,
    ) -> Result<Self, CalibrationError> {
        let obs = &inputs.observations;
        let train: Vec<usize> = (0..obs.len()).filter(|&i| obs[i].role == Role::Training).collect();
        let val: Vec<usize> = (0..obs.len()).filter(|&i| obs[i].role == Role::Validation).collect();
        if train.is_empty() {
            return Err(CalibrationError::TooFewDesigns {
                method: "diagnosis",
                needed: 1,
                given: 0,
            });
        }
        // The emulator's error floor, where the noise is the replicates' (a caller's noise, the curve
        // features', carries it already): the variance of each mean grows by that share.
        let counted = inputs.settings.emulator_counted;
        let floor = if inputs.features.is_none() && counted {
            inputs.settings.emulator_floor
        } else {
            0.0
        };
        let weights: Vec<f64> = obs
            .iter()
            .enumerate()
            .map(|(i, o)| {
                let n = o.count.max(1) as f64;
                let Some(nm) = noise else {
                    return (n / (1.0 + floor)).sqrt();
                };
                let test = nm.sigma_at(o.mean).powi(2) / n;
                let emulator = emulator.get(i).copied().unwrap_or(0.0);
                1.0 / (test * (1.0 + floor) + emulator).sqrt().max(f64::MIN_POSITIVE)
            })
            .collect();
        let data = Data {
            model: inputs.model,
            bounds: &inputs.space.parameter_bounds,
            designs: obs.iter().map(|o| inputs.point(o)).collect(),
            means: obs.iter().map(|o| o.mean).collect(),
            weights,
        };
        let n = train.len();
        // The residuals a fit can resolve: a minimiser locates its parameters only to about √ε
        // relative (the objective is flat to second order at its minimum), so residuals of noise-free
        // tests stop near √ε of the responses, not at ε; below that they are the optimiser's, not
        // the model's, and must not be read as misfit.
        let rss_floor = {
            let ms = train
                .iter()
                .map(|&i| (data.weights[i] * data.means[i]).powi(2))
                .sum::<f64>()
                / n as f64;
            f64::EPSILON * ms * n as f64
        };
        let nu = noise.map_or(0, |nm| nm.dof);
        let p = inputs.space.parameter_names.len();
        let mode = if nu > 0 && n >= p + 3 || nu == 0 && n >= p + 4 {
            Mode::Ranked
        } else if nu > 0 && n > p {
            Mode::Few
        } else {
            Mode::TooFew
        };
        Ok(Context {
            inputs,
            data,
            train,
            val,
            nu,
            mode,
            rss_floor,
            detection,
            emulator,
        })
    }

    /// The emulators' error counted at observation `i` (0 where none is).
    pub fn emulator_variance(&self, i: usize) -> f64 {
        self.emulator.get(i).copied().unwrap_or(0.0)
    }

    /// Mean |relative error| of predictions `yh` at observations `i` (NaN when none has one).
    pub fn mean_abs_rel(&self, pairs: impl Iterator<Item = (usize, f64)>) -> f64 {
        let errors: Vec<f64> = pairs.filter_map(|(i, yh)| self.relative_error(i, yh)).collect();
        if errors.is_empty() {
            f64::NAN
        } else {
            errors.iter().map(|e| e.abs()).sum::<f64>() / errors.len() as f64
        }
    }

    /// Σ (w_i (ȳ_i − ŷ_i))² of the leave-one-design-out predictions `loo` at the training designs.
    pub fn press(&self, loo: &[f64]) -> f64 {
        self.train
            .iter()
            .zip(loo)
            .map(|(&i, yh)| (self.data.weights[i] * (self.data.means[i] - yh)).powi(2))
            .sum()
    }

    /// Mean |relative error| of the leave-one-design-out predictions `loo` at the training designs.
    pub fn loo_error(&self, loo: &[f64]) -> f64 {
        self.mean_abs_rel(self.train.iter().zip(loo).map(|(&i, &yh)| (i, yh)))
    }

    /// The relative error of `yh` at observation `i` (see [`FeatureOutputs::relative_error`]).
    pub fn relative_error(&self, i: usize, yh: f64) -> Option<f64> {
        let o = &self.inputs.observations[i];
        match &self.inputs.features {
            Some(f) => (f.relative_error)(o, yh),
            None => Some((yh - o.mean) / o.mean),
        }
    }

    /// Whether σ comes from replicates.
    pub fn known(&self) -> bool {
        self.nu > 0
    }

    pub fn p(&self) -> usize {
        self.inputs.space.parameter_names.len()
    }

    pub fn alpha(&self) -> f64 {
        self.inputs.settings.alpha
    }

    /// The levels of this diagnosis's tests ([`Levels`]).
    pub fn levels(&self) -> Levels {
        Levels::new(self.inputs.settings.alpha, self.detection)
    }

    pub fn param_map(&self, theta: &DVector<f64>) -> IndexMap<String, f64> {
        self.inputs
            .space
            .parameter_names
            .iter()
            .cloned()
            .zip(theta.iter().copied())
            .collect()
    }

    /// The parameters' standard errors from a fit's covariance (θ first), by name.
    pub fn standard_errors(&self, c: &fit::Covariance) -> IndexMap<String, f64> {
        self.param_map(&c.matrix.diagonal().map(f64::sqrt))
    }

    /// A test of a drop in weighted RSS by `extra` fitted numbers: F(extra, ν) against the replicate
    /// noise, or, without replicates, against the residual of the larger model (`rss`, `dof`).
    pub fn drop_test(&self, drop: f64, extra: usize, rss: f64, dof: usize) -> Option<f64> {
        let drop = drop.max(0.0);
        let d1 = extra as f64;
        if self.known() {
            Some(stats::f_sf(drop / d1, d1, self.nu as f64))
        } else if dof == 0 {
            None
        } else if drop <= 0.0 {
            Some(1.0)
        } else {
            Some(stats::f_sf(
                drop / d1 / (rss.max(self.rss_floor) / dof as f64),
                d1,
                dof as f64,
            ))
        }
    }
}

const RULE: &str = "noise: sigma^2 = a^2 + (b y)^2 from the replicates' likelihood, at the likelier pure form (constant \
sigma or constant coefficient of variation) unless the combined model beats it by a likelihood-ratio test at alpha; if \
the uncorrected model misses the tests there, another mixing the replicates allow (99.9 % set) under which it fits and \
no candidate explains a misfit is used instead (without replicates: from the residuals of the best fit); detection of \
model error shares alpha = 0.01: the uncorrected model's omnibus lack of fit (chi^2 against F) and its largest \
standardised residual (Sidak-corrected for their number) at alpha/4 each, each candidate's amplitude test (F, against \
a refit of the parameters alone) at alpha/(2K) for K candidates, whatever the angle between its shape and the \
parameters' sensitivities; ranking: score = (AICc + leave-one-design-out deviance)/2 (with few designs: AIC + the \
validation designs' predictive deviance), weights exp(-score/2); the leader is the best-scored candidate that \
explains the misfit, and it is named only when it beats every rival in an encompassing test (leader added to the \
rival: p < alpha/(K-1), since the data chose the leader among the K) and its final model fits both ways at alpha, on the noise detection chose; a listed cause whose \
model does not fit only partly explains the misfit: it is reported as partial, never as the cause";

/// Runs the diagnosis, step by step (see the module notes). Errors only when there are no training
/// designs or the model cannot be evaluated.
pub fn diagnose(inputs: &Inputs) -> Result<Diagnosis, CalibrationError> {
    Ok(Evidence::gather(inputs, true)?.conclusion(&[], &[]))
}

/// The library search alone ([`discover`]), from the screening's decision, as [`diagnose`] runs it
/// when no loop ran (`None`: the decision does not call for one, or `inputs.discover` is off); no
/// next test, no words. For timing the search (`benches/discover.rs`) and for callers that want
/// only `diagnosis.discovered`.
pub fn discover(inputs: &Inputs) -> Result<Option<discover::Discovered>, CalibrationError> {
    let evidence = Evidence::gather(inputs, true)?;
    let mut notes = Vec::new();
    let search = discover::run(&evidence, &[], &[], &evidence.decision, &mut notes);
    Ok(search.map(|s| s.discovered))
}

/// Step 1: the noise and the uncorrected model fitted under it. A noise the caller knows is taken
/// as it is; else the replicates' at the chosen mixing ([`noise`]). Model error is claimed only
/// when it is detected under every mixing the replicates allow (the p-value maximised over a
/// confidence set of the nuisance, Berger & Boos 1994): when the uncorrected model misses the tests
/// at the chosen mixing, each mixing of the set under which it fits is tried, and the first under
/// which no candidate explains the misfit either is the one the diagnosis runs with.
fn noise_and_base<'a>(
    inputs: &'a Inputs<'a>,
    detection: bool,
    mixing: Option<f64>,
) -> Result<(Context<'a>, candidates::Model, Option<NoiseModel>), CalibrationError> {
    let fitted = |nm: Option<NoiseModel>| -> Result<_, CalibrationError> {
        let cx = Context::new(inputs, nm.as_ref(), detection)?;
        let base = candidates::uncorrected(&cx)?;
        Ok((cx, base, nm))
    };
    if let Some(f) = &inputs.features {
        return fitted(Some(f.noise.clone()));
    }
    let Some(scatter) = noise::Scatter::of(&inputs.observations) else {
        return fitted(inputs.settings.measurement.map(NoiseModel::stated));
    };
    let alpha = inputs.settings.alpha;
    if let Some(lambda) = mixing {
        return fitted(Some(scatter.model_at(lambda, alpha)));
    }
    let chosen = scatter.chosen_mixing(alpha);
    let first = fitted(Some(scatter.model_at(chosen, alpha)))?;
    // The other mixings the replicates allow may spare the uncorrected model a claim of model
    // error (detection). A cause's final model (the loop's, `detection` false) is judged on the
    // noise the detection chose: re-choosing the noise per model would let a wrong cause hide its
    // misfit where the noise form is least certain, and its rivals be judged on another noise.
    if !detection || fits(&first.0, &first.1) {
        return Ok(first);
    }
    for lambda in scatter.set_points(alpha) {
        let (cx, base, nm) = fitted(Some(scatter.model_at(lambda, alpha)))?;
        if fits(&cx, &base) && !candidate_explains(&cx, &base) {
            let mut nm = nm.expect("a replicate noise");
            nm.note.push_str(&format!(
                "; under the mixing λ = {chosen:.2} the uncorrected simulation would miss the tests, but under λ = \
                 {lambda:.2}, which the replicates allow as well, it fits them and no candidate explains a misfit: model \
                 error is not claimed on the noise model's account"
            ));
            return Ok((cx, base, Some(nm)));
        }
    }
    Ok(first)
}

/// The uncorrected model fits the tests (both ways; trivially without a lack-of-fit test).
fn fits(cx: &Context, base: &candidates::Model) -> bool {
    evidence::assess_one(cx, base, None).lack_of_fit.is_none_or(|l| l.fits)
}

/// Some candidate's amplitude test is significant at α/K (step 3's rule, on a scratch fit).
fn candidate_explains(cx: &Context, base: &candidates::Model) -> bool {
    let mut notes = Vec::new();
    let shapes = candidates::shapes(cx, base, &mut notes);
    let fitted = candidates::fit_all(cx, shapes, &mut notes);
    let k = fitted.len().max(1) as f64;
    fitted.iter().any(|m| {
        evidence::assess_one(cx, m, Some(base))
            .p_value
            .is_some_and(|p| p * k < cx.levels().candidates())
    })
}

/// A hypothesis the loop calibrated with the solver, as the diagnosis sees it.
pub struct LoopModel<'a> {
    /// The screening candidate it extends.
    pub hypothesis: String,
    /// The extended model taken as the simulation: its parameters are θ and the extension's
    /// variables; its candidates are the study's terms and the other hypotheses' screening shapes
    /// (so that each can be tested with the extended model as the base).
    pub inputs: Inputs<'a>,
    /// Its emulators were checked by solver runs at its fitted point. Unchecked, its lack of fit
    /// may be theirs: the decision does not reject it on it ([`after_loop`]).
    pub checked: bool,
    /// Its loop is still running (its emulators not yet within the tolerance): the decision then
    /// says whether anything its final model may show could change it ([`after_loop::AfterLoop::settled`]).
    pub running: bool,
    /// Where the solver's confirmation moved its parameters ([`refit`]): the point handed over, at
    /// which the next test reads it (not its fit through the emulators).
    pub refit: Option<IndexMap<String, f64>>,
}

/// The diagnosis from all the evidence: the screening of `inputs`, then every model the loop
/// calibrated (`looped`), decided once ([`after_loop`]). Also returns each loop model's own
/// diagnosis (what it leaves unexplained). `favoured`: the extensions the solver's runs over their
/// amplitudes favoured where the screening found no model error; the loop over them judges them.
pub fn conclude(
    inputs: &Inputs,
    looped: &[LoopModel],
    favoured: &[String],
) -> Result<(Diagnosis, Vec<Diagnosis>), CalibrationError> {
    let mut screening = Evidence::gather(inputs, true)?;
    screening.favoured = favoured.to_vec();
    let gather = |mixing: Option<f64>| -> Result<Vec<Evidence>, CalibrationError> {
        looped
            .iter()
            .map(|m| {
                Evidence::gather_at(&m.inputs, false, mixing).map(|e| Evidence {
                    checked: m.checked,
                    running: m.running,
                    refit: m.refit.clone(),
                    ..e
                })
            })
            .collect()
    };
    let names: Vec<String> = looped.iter().map(|m| m.hypothesis.clone()).collect();
    let evidence = mixings::judged(&mut screening, gather(None)?, &names, &gather)?;
    let own: Vec<Diagnosis> = evidence.iter().map(|e| e.conclusion(&[], &[])).collect();
    Ok((screening.conclusion(&evidence, &names), own))
}

/// What the conclusion found besides the decision, as the words read it.
pub(crate) struct Found<'f> {
    pub candidates: &'f [Candidate],
    pub residuals: &'f [Residual],
    pub structure: &'f [Trend],
    pub confounded: &'f [String],
}

/// The evidence for one model taken as the simulation: every candidate fitted with it, tested,
/// ranked, and the screening decision (steps 1–5).
pub(crate) struct Evidence<'a> {
    pub cx: Context<'a>,
    pub ranked: ranking::Ranked,
    pub decision: verdict::Decision,
    pub noise: NoiseModel,
    pub notes: Vec<String>,
    /// A loop model's emulators were checked at its fitted point ([`LoopModel::checked`]).
    pub checked: bool,
    /// A loop model whose loop is still running ([`LoopModel::running`]).
    pub running: bool,
    /// The extensions the solver's runs over their amplitudes favoured where this evidence found no
    /// model error ([`open::Favoured`]): what the loop judges in its place ([`after_loop`]).
    pub favoured: Vec<String>,
    /// A loop model's parameters as the solver's confirmation refitted them ([`LoopModel::refit`]).
    pub refit: Option<IndexMap<String, f64>>,
}

impl<'a> Evidence<'a> {
    /// `detection`: the simulation is the study's own, so the uncorrected model's lack of fit
    /// detects model error (a loop model's is judged as a cause's model).
    fn gather(inputs: &'a Inputs<'a>, detection: bool) -> Result<Self, CalibrationError> {
        Evidence::gather_at(inputs, detection, None)
    }

    /// [`Evidence::gather`] with the replicates' noise at mixing λ (`Some`), in place of the one
    /// the noise model chooses.
    fn gather_at(inputs: &'a Inputs<'a>, detection: bool, mixing: Option<f64>) -> Result<Self, CalibrationError> {
        let mut notes = Vec::new();
        let (cx, base, replicate_noise) = noise_and_base(inputs, detection, mixing)?;
        let shapes = candidates::shapes(&cx, &base, &mut notes);
        let fitted = candidates::fit_all(&cx, shapes, &mut notes);
        let assessed = evidence::assess(&cx, &base, &fitted);
        let ranked = ranking::rank(&cx, base, fitted, assessed);
        let noise = noise::finalise(replicate_noise, &cx, &ranked);
        let decision = verdict::decide(&cx, &ranked);
        Ok(Evidence {
            cx,
            ranked,
            decision,
            noise,
            notes,
            checked: true,
            running: false,
            favoured: Vec::new(),
            refit: None,
        })
    }

    /// The diagnosis: this evidence's decision, or with loop models the decision after the loop
    /// (steps 5b–8), each step a named call with a typed result.
    fn conclusion(&self, looped: &[Evidence], loop_names: &[String]) -> Diagnosis {
        let (decision, after) = self.final_decision(looped, loop_names);
        let candidates = self.ranked.candidates(&self.cx);
        let extended = self.extended_of(&decision, looped, loop_names);
        // Once the decision is final: the library search for a missing term (step 7b), when the
        // verdict leaves the misfit unexplained or no hypothesis is listed.
        let mut notes = self.notes.clone();
        let search = discover::run(self, looped, loop_names, &decision, &mut notes);
        let next_test = self.next_test(&decision, search.as_ref(), looped, loop_names, &candidates);
        let residuals = residuals::table(&self.cx, &self.ranked.base.model.fit, &self.noise);
        let structure = residuals::trends(&self.cx, &residuals);
        let confounded = evidence::absorbed_sentences(&candidates);
        let parameter_limits = self.parameter_limits(&decision, looped);
        let found = Found {
            candidates: &candidates,
            residuals: &residuals,
            structure: &structure,
            confounded: &confounded,
        };
        let after = after.map(|mut a| {
            a.screening_headline = text::headline(&self.facts(&self.decision, &found, None, None, &[], &[]));
            a
        });
        let mut facts = self.facts(
            &decision,
            &found,
            extended.as_ref(),
            next_test.as_ref(),
            loop_names,
            &parameter_limits,
        );
        facts.after_loop = after.as_ref();
        let discovered = search
            .as_ref()
            .map_or(&[][..], |s| s.discovered.search.evidence.as_slice());
        let (words, not_excluded) = self.words(&facts, &candidates, discovered);
        let name = |who| verdict::name_of(who, &candidates, loop_names);
        // `cause` is the decided cause only; a partial explanation goes to `partial`.
        let (cause, extended, partial) = match (decision.verdict, decision.cause) {
            (Verdict::CauseNamed, who) => (who.map(name), extended, None),
            (_, Some(who)) => {
                let uncorrected = self.ranked.base.assessed.lack_of_fit.as_ref();
                (None, None, Some(Partial::new(name(who), extended, uncorrected)))
            }
            (_, None) => (None, extended, None),
        };
        Diagnosis {
            finding: Finding {
                discrepancy_detected: decision.detected,
                cause,
                partial,
                verdict: decision.verdict,
                headline: words.headline,
                leading: decision.leading.iter().map(|&w| name(w)).collect(),
                action: words.action,
                evidence: words.evidence,
                limits: words.limits,
            },
            explained: Explained {
                candidates,
                rivals: self.ranked.rivals.clone(),
                extended,
                parameter_limits,
                extensions: Vec::new(),
                next_test,
            },
            checked: Checked {
                discovered: search.map(|s| s.discovered),
                features: None,
                not_excluded,
                confirmation: Vec::new(),
                emulator: None,
                after_loop: after,
                solver_refit: None,
            },
            record: self.record(words.summary, (residuals, structure, confounded), notes),
        }
    }

    /// The uncorrected model's record under this evidence, with the residuals' table and the
    /// conclusion's `summary` and `notes`.
    fn record(
        &self,
        summary: String,
        (residuals, structure, confounded): (Vec<Residual>, Vec<Trend>, Vec<String>),
        notes: Vec<String>,
    ) -> Record {
        Record {
            summary,
            noise: self.noise.clone(),
            uncorrected: self.ranked.uncorrected(&self.cx),
            lack_of_fit: self.ranked.base.assessed.lack_of_fit.clone(),
            residuals,
            structure,
            confounded,
            levels: self.cx.levels().record(),
            rule: RULE.to_string(),
            notes,
        }
    }

    /// The words of a final decision, with what "no model error" leaves open (the listed
    /// hypotheses these tests do not exclude) in its limits and its action.
    fn words(
        &self,
        facts: &text::Facts,
        candidates: &[Candidate],
        discovered: &[String],
    ) -> (text::Words, Vec<open::NotExcluded>) {
        let mut words = text::describe(facts, discovered);
        let not_excluded = match facts.decision.verdict {
            Verdict::NoModelError => {
                let levels = (self.cx.levels(), self.cx.inputs.settings.power);
                open::not_excluded(candidates, &self.cx.inputs.hypotheses, self.noise.dof, levels)
            }
            _ => Vec::new(),
        };
        words.limits.extend(not_excluded.iter().map(text::not_excluded_line));
        if !not_excluded.is_empty() {
            words.action = text::action_with_open(facts, &not_excluded);
        }
        words.summary = text::summary(&words.headline, &words.action, &words.evidence, &words.limits);
        (words, not_excluded)
    }

    /// Step 5b: the screening's decision, or with loop models the decision after the loop.
    fn final_decision(
        &self,
        looped: &[Evidence],
        loop_names: &[String],
    ) -> (verdict::Decision, Option<after_loop::AfterLoop>) {
        if looped.is_empty() {
            (self.decision.clone(), None)
        } else {
            let (d, a) = after_loop::decide(self, looped, loop_names);
            (verdict::unmeasured(&self.cx, d), Some(a))
        }
    }

    /// Step 6: the model extended with the decision's cause (its loop model where the loop
    /// calibrated it).
    fn extended_of(
        &self,
        decision: &verdict::Decision,
        looped: &[Evidence],
        loop_names: &[String],
    ) -> Option<Extended> {
        let (cx, ranked) = (&self.cx, &self.ranked);
        decision.cause.and_then(|who| match who {
            verdict::Who::Candidate(k) => extension::extend(cx, ranked, k),
            verdict::Who::Extended(j) => {
                let k = ranked.entries.iter().position(|e| e.model.name() == loop_names[j])?;
                let screening = extension::extend(cx, ranked, k)?;
                Some(extension::from_loop(screening, &looped[j]))
            }
            verdict::Who::Uncorrected => None,
        })
    }

    /// Step 7: the test that would best tell apart the explanations the decision leaves open (or a
    /// term the search found from its base).
    fn next_test(
        &self,
        decision: &verdict::Decision,
        search: Option<&discover::Search>,
        looped: &[Evidence],
        loop_names: &[String],
        candidates: &[Candidate],
    ) -> Option<NextTest> {
        let (cx, ranked) = (&self.cx, &self.ranked);
        let name = |who| verdict::name_of(who, candidates, loop_names);
        let explanations: Vec<next_test::Explanation> = match search.map(|s| s.compared()) {
            // A found term is a hypothesis like any other: the next test tells it from its base.
            Some(found) if !found.is_empty() => found,
            _ => decision
                .compare
                .iter()
                .map(|&who| match who {
                    verdict::Who::Uncorrected => next_test::Explanation::from_entry(cx, &ranked.base, name(who), true),
                    verdict::Who::Candidate(k) => {
                        next_test::Explanation::from_entry(cx, &ranked.entries[k], name(who), false)
                    }
                    verdict::Who::Extended(j) => {
                        next_test::Explanation::from_entry(&looped[j].cx, &looped[j].ranked.base, name(who), false)
                            .simulated_by(&loop_names[j])
                            .at(looped[j].refit.as_ref())
                    }
                })
                .collect(),
        };
        // A confirming test may count the tests in hand; where they left it open, new tests must
        // decide on their own. So must a test of a term the search found: the tests that chose it
        // cannot also confirm it.
        let found = search.is_some_and(|s| s.found.is_some());
        // Under "no model error" the tests in hand did not show the candidate: a test that would must
        // do so on its own specimens too.
        let fresh = found || decision.verdict != Verdict::CauseNamed;
        // Telling a candidate from no correction is a detection: its test would run at the level
        // detection gives each candidate, α/(2K), and the programme must have its power there.
        let detects = decision.compare.contains(&verdict::Who::Uncorrected) && cx.detection;
        let level = if detects {
            cx.levels().amplitude(ranked.entries.len())
        } else {
            cx.alpha()
        };
        next_test::recommend(cx, &explanations, &self.noise, fresh, level)
    }

    /// How far the final model's parameters move when its misfit is absorbed ([`limits`]): for the
    /// cause that partly explains (its loop model where the loop calibrated it), or the uncorrected
    /// model when nothing explains; only when that model misses the tests.
    fn parameter_limits(&self, decision: &verdict::Decision, looped: &[Evidence]) -> Vec<limits::ParameterLimit> {
        use verdict::Who;
        let (cx, entry) = match (decision.verdict, decision.cause) {
            (Verdict::PartlyExplained, Some(Who::Candidate(k))) => (&self.cx, &self.ranked.entries[k]),
            (Verdict::PartlyExplained, Some(Who::Extended(j))) => (&looped[j].cx, &looped[j].ranked.base),
            (Verdict::Unexplained, _) => (&self.cx, &self.ranked.base),
            _ => return Vec::new(),
        };
        let a = &entry.assessed;
        if !a.lack_of_fit.as_ref().is_some_and(LackOfFit::rejects) {
            return Vec::new();
        }
        let z = evidence::standardised(cx, &entry.model, a.s2.unwrap_or(1.0), a.validation.as_ref());
        limits::limits(cx, &entry.model, &z, a.cov.as_ref())
    }

    fn facts<'f>(
        &'f self,
        decision: &'f verdict::Decision,
        found: &'f Found<'f>,
        extended: Option<&'f Extended>,
        next_test: Option<&'f NextTest>,
        loop_names: &'f [String],
        parameter_limits: &'f [limits::ParameterLimit],
    ) -> text::Facts<'f> {
        text::Facts {
            cx: &self.cx,
            noise: &self.noise,
            found,
            ranked: &self.ranked,
            decision,
            extended,
            next_test,
            loop_names,
            after_loop: None,
            parameter_limits,
        }
    }
}
