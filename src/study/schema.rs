//! The study file's YAML schema (serde), before validation.
//!
//! Every struct denies unknown keys. Values a later semantic check must point at are [`Spanned`].
//! No `flatten` and no untagged enums: serde buffers those and the locations would be lost.

use indexmap::IndexMap;
use serde::Deserialize;
use serde::de::IgnoredAny;

use super::yaml::Spanned;

/// A name (map key or list item) with its location.
pub type Name = Spanned<String>;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudyFile {
    pub name: Name,
    #[serde(default)]
    pub constants: IndexMap<Name, Spanned<f64>>,
    pub design: Spanned<IndexMap<Name, Option<DesignFile>>>,
    pub parameters: Spanned<IndexMap<Name, ParameterFile>>,
    pub simulation: Spanned<SimulationFile>,
    pub experiments: ExperimentsFile,
    pub training: Spanned<Vec<Name>>,
    #[serde(default)]
    pub validation: Vec<Name>,
    pub calibration: Option<CalibrationFile>,
    pub diagnosis: Option<DiagnosisFile>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignFile {
    pub unit: Option<String>,
    pub min: Option<Spanned<f64>>,
    pub max: Option<Spanned<f64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParameterFile {
    pub min: Spanned<f64>,
    pub max: Spanned<f64>,
    pub unit: Option<String>,
}

/// `simulation:`. Only `expression` is supported for now; the solver keys are accepted by the
/// schema so that a study using them gets a "not supported yet" error rather than "unknown key".
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimulationFile {
    pub expression: Option<Spanned<String>>,
    pub solver: Option<Spanned<IgnoredAny>>,
    pub response: Option<Spanned<IgnoredAny>>,
    pub sampling: Option<Spanned<IgnoredAny>>,
    pub surrogate: Option<Spanned<IgnoredAny>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentsFile {
    pub file: Spanned<String>,
    pub response: Spanned<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationFile {
    pub methods: Option<Spanned<Vec<Name>>>,
    #[serde(default)]
    pub bayesian: BayesianFile,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BayesianFile {
    pub emulator_samples: Option<Spanned<usize>>,
    pub seed: Option<u64>,
    pub mcmc_walkers: Option<Spanned<usize>>,
    pub mcmc_steps: Option<Spanned<usize>>,
    pub mcmc_burn_in: Option<Spanned<usize>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiagnosisFile {
    #[serde(default)]
    pub hypotheses: Vec<HypothesisFile>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HypothesisFile {
    pub name: Name,
    pub term: Spanned<String>,
}
