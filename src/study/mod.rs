//! The study: what to calibrate, against which tests, with which methods.
//!
//! [`load`] reads a study file and everything it references (experiments CSV, expressions) and
//! returns a validated [`Study`], or an [`InputError`](crate::error::InputError) naming file, line
//! and column. Nothing after this stage re-checks user input: a `Study` is valid by construction.
//!
//! Vocabulary follows Dakota: *variables* (design variables and calibration parameters), the
//! *simulation* (how a response is computed), *experiments* (measured responses), *methods*.

mod calibration;
pub mod experiments;
pub mod expr;
mod load;
mod schema;
pub mod sequence;
pub mod settings;
pub mod solver;
mod yaml;

use std::path::PathBuf;

pub use experiments::{Experiments, TestDesign};
pub use expr::{Expression, Symbols};
pub use load::load;
pub use solver::{
    CopiedFile, Execution, MeshSpec, OpenRadiossSettings, QualitySettings, Response, RunInputs, SamplingMethod,
    SolverSimulation, SurrogateKind, Template,
};

use crate::base::Bounds;
pub use calibration::{BayesianSettings, Method};

/// A validated study.
#[derive(Debug, Clone)]
pub struct Study {
    pub name: String,
    /// The study file; relative paths in it are relative to its directory.
    pub path: PathBuf,
    /// Named constants, visible to expressions and templates, in file order.
    pub constants: Vec<(String, f64)>,
    /// Design variables (user-controllable), in file order.
    pub design: Vec<DesignVariable>,
    /// Calibration parameters, in file order.
    pub parameters: Vec<Parameter>,
    pub simulation: Simulation,
    pub experiments: Experiments,
    /// The designs calibrated against (`training`, in the order the study lists them: Eq. 6 pairs
    /// consecutive ones) and those held out (`validation`).
    pub split: Split,
    pub calibration: CalibrationSettings,
    pub diagnosis: DiagnosisSettings,
}

impl Study {
    /// The template context of a run: design variables, parameters, constants, each by name as a
    /// number, and `design_name` (the contract's names visible to templates); with
    /// `simulation.seeds`, its variable at the first seed, 1 (a run at another sets its own).
    pub fn context(&self, design_name: &str, design: &[f64], theta: &[f64]) -> tera::Context {
        let mut ctx = tera::Context::new();
        let named = self
            .design
            .iter()
            .map(|d| &d.name)
            .zip(design)
            .chain(self.parameters.iter().map(|p| &p.name).zip(theta))
            .chain(self.constants.iter().map(|(n, v)| (n, v)));
        for (name, value) in named {
            ctx.insert(name.clone(), value);
        }
        ctx.insert("design_name", design_name);
        if let Simulation::Solver(sim) = &self.simulation
            && let Some(variable) = sim.inputs.seeds.as_ref().and_then(|s| s.variable.as_ref())
        {
            ctx.insert(variable.clone(), &1usize);
        }
        ctx
    }
}

/// A train/validate split of the tested designs.
#[derive(Debug, Clone, PartialEq)]
pub struct Split {
    pub training: Vec<String>,
    pub validation: Vec<String>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct DesignVariable {
    pub name: String,
    pub unit: Option<String>,
    /// Optional bounds; default to the range of the experiments' designs.
    pub min: Option<f64>,
    pub max: Option<f64>,
    /// `scale:` a positive number in the variable's unit that makes it dimensionless (x / scale):
    /// the discovery library tries `exp(-x/scale)` and `ln(x/scale)` only for variables that have one.
    pub scale: Option<f64>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Parameter {
    pub name: String,
    pub min: f64,
    pub max: f64,
    pub unit: Option<String>,
}

#[derive(Debug, Clone)]
#[allow(clippy::large_enum_variant)] // one per study; boxing the expression would buy nothing
pub enum Simulation {
    /// Closed form over design variables, parameters and constants.
    Expression(Expression),
    /// A program run for every planned (design, parameter sample); surrogates fitted to its runs.
    Solver(Box<SolverSimulation>),
}

#[derive(Debug, Clone)]
pub struct CalibrationSettings {
    /// Methods to run, in the order listed.
    pub methods: Vec<Method>,
    pub bayesian: BayesianSettings,
    /// What the parameters are calibrated against (`calibration.against`).
    pub against: Targets,
    /// How curves are compared (`calibration.curve`), when `against` has `curves`.
    pub curve: CurveSettings,
    /// Extra train/validate splits, calibrated from the same simulations (`splits`).
    pub splits: Vec<Split>,
}

/// `calibration.against`: the response (results.json `calibration`), the force–displacement
/// curves (`curve_calibration`, and the diagnosis then reads the curves' features), or both.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Targets {
    pub response: bool,
    pub curves: bool,
}

impl Default for Targets {
    fn default() -> Self {
        Targets {
            response: true,
            curves: false,
        }
    }
}

/// The metric curve calibration minimises (`calibration.curve.metric`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CurveMetric {
    Mse,
    Pcm,
    Frechet,
    Dtw,
    Area,
}

impl CurveMetric {
    pub const KEYS: [&'static str; 5] = ["mse", "pcm", "frechet", "dtw", "area"];

    pub fn from_key(key: &str) -> Option<CurveMetric> {
        use CurveMetric::*;
        [Mse, Pcm, Frechet, Dtw, Area].into_iter().find(|m| m.key() == key)
    }

    pub fn key(self) -> &'static str {
        Self::KEYS[self as usize]
    }
}

/// `calibration.curve`.
#[derive(Debug, Clone, PartialEq)]
pub struct CurveSettings {
    pub metric: CurveMetric,
    pub points: usize,
    /// SAE J211 CFC (Hz) and the crush speed (m/s) that gives a stroke-sampled curve its time base.
    pub filter: Option<CfcFilter>,
    /// The grid's stroke window, mm (`None`: the response's window).
    pub window: Option<[f64; 2]>,
    /// Each curve component's surrogate (`None`: the study's `simulation.surrogate`).
    pub surrogate: Option<SurrogateKind>,
}

impl Default for CurveSettings {
    fn default() -> Self {
        CurveSettings {
            metric: CurveMetric::Mse,
            points: 200,
            filter: None,
            window: None,
            surrogate: None,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CfcFilter {
    pub cfc: f64,
    pub speed: f64,
}

#[derive(Debug, Clone, Default)]
pub struct DiagnosisSettings {
    pub hypotheses: Vec<Hypothesis>,
    /// `diagnosis.discover`, resolved: search a library of shapes when no listed hypothesis explains
    /// the misfit. The file's value, else true exactly when the study lists no hypothesis; `lab run
    /// --discover` sets it for one run.
    pub discover: bool,
}

/// A candidate cause of model error: an additive discrepancy shape, or a model extension.
#[derive(Debug, Clone)]
pub struct Hypothesis {
    pub name: String,
    pub kind: HypothesisKind,
}

#[derive(Debug, Clone)]
#[allow(clippy::large_enum_variant)] // a few per study; boxing the expression would buy nothing
pub enum HypothesisKind {
    /// `term:` over design variables, constants, parameters and `y`; compiled against
    /// [`Study::term_symbols`].
    Term(Expression),
    /// `extension:` (solver studies only): template variables set for the extra runs of this
    /// hypothesis; each one changes what a template renders.
    Extension(Extension),
}

/// A model extension's template variables.
#[derive(Debug, Clone, PartialEq)]
pub struct Extension {
    /// Every variable, in file order, at its screening value: its value, or a range's probe. The
    /// screening runs ([`crate::plan::RunRole::Extension`]) are rendered with these.
    pub screening: Vec<(String, f64)>,
    /// The variables given a range: the extension's own parameters, calibrated through new solver
    /// runs over the joint space with the study's parameters ([`crate::plan::RunRole::Joint`]).
    pub ranges: Vec<Parameter>,
    /// The baseline is the edge of the joint space: the templates render the same bytes without
    /// the extension as with its ranged variables at their lower bounds and its fixed ones at their
    /// values (checked by `lab check` at the first training design, parameters at the centre of
    /// their bounds). Then a baseline run is a run of the extended model there, with the same run
    /// key, and the solver in the loop reuses the baseline's runs.
    pub baseline_at_edge: bool,
}

impl Extension {
    /// The template variables of a joint run: the fixed ones, and each ranged one at `values`
    /// (in the order of [`Extension::ranges`]).
    pub fn at(&self, values: &[f64]) -> Vec<(String, f64)> {
        self.screening
            .iter()
            .map(|(name, v)| {
                let ranged = self.ranges.iter().position(|r| &r.name == name);
                (name.clone(), ranged.map_or(*v, |k| values[k]))
            })
            .collect()
    }

    /// [`Extension::at`] the ranges' lower bounds: the joint space's edge the baseline may be
    /// ([`Extension::baseline_at_edge`]).
    pub fn at_lower_bounds(&self) -> Vec<(String, f64)> {
        self.at(&self.ranges.iter().map(|r| r.min).collect::<Vec<_>>())
    }
}

impl Hypothesis {
    /// The extension's template variables at their screening values, if this hypothesis is a
    /// model extension.
    pub fn extension(&self) -> Option<&[(String, f64)]> {
        self.extension_spec().map(|e| &e.screening[..])
    }

    /// The model extension, if this hypothesis is one.
    pub fn extension_spec(&self) -> Option<&Extension> {
        match &self.kind {
            HypothesisKind::Extension(e) => Some(e),
            HypothesisKind::Term(_) => None,
        }
    }

    /// The extension variables given a range (none for a term or a fixed extension).
    pub fn ranges(&self) -> &[Parameter] {
        self.extension_spec().map_or(&[], |e| &e.ranges)
    }

    /// The ranges as (name, min, max): what the extension's amplitude can physically be.
    pub fn declared_ranges(&self) -> Vec<(String, f64, f64)> {
        self.ranges().iter().map(|r| (r.name.clone(), r.min, r.max)).collect()
    }
}

impl Study {
    /// Parameter values by name, in the study's order.
    pub fn parameter_values(&self, theta: &[f64]) -> indexmap::IndexMap<String, f64> {
        self.parameters
            .iter()
            .map(|p| p.name.clone())
            .zip(theta.iter().copied())
            .collect()
    }

    /// Symbols of the simulation expression: design variables, parameters, constants.
    pub fn symbols(&self) -> Symbols {
        symbols(&self.design, &self.parameters, &self.constants)
    }

    /// Symbols of a hypothesis term: the simulation's symbols plus `y`, the prediction.
    pub fn term_symbols(&self) -> Symbols {
        Symbols::new(self.symbols().names().iter().cloned().chain(["y".to_string()]))
    }

    /// The hypotheses that are model extensions, with their index in `diagnosis.hypotheses` (the
    /// index names their runs and surrogates).
    pub fn extension_hypotheses(&self) -> impl Iterator<Item = (usize, &Hypothesis)> {
        self.diagnosis
            .hypotheses
            .iter()
            .enumerate()
            .filter(|(_, h)| h.extension().is_some())
    }

    pub fn parameter_bounds(&self) -> Bounds {
        Bounds::new(
            self.parameters.iter().map(|p| p.min).collect(),
            self.parameters.iter().map(|p| p.max).collect(),
        )
    }

    /// Design bounds: the study's `min`/`max` where given, else the range of the tested designs.
    pub fn design_bounds(&self) -> Bounds {
        let (lower, upper) = self
            .design
            .iter()
            .enumerate()
            .map(|(j, var)| {
                let values = self.experiments.designs.iter().map(|t| t.values[j]);
                let lo = var.min.unwrap_or_else(|| values.clone().fold(f64::INFINITY, f64::min));
                let hi = var.max.unwrap_or_else(|| values.fold(f64::NEG_INFINITY, f64::max));
                (lo, hi)
            })
            .unzip();
        Bounds::new(lower, upper)
    }
}

/// The stroke grid curves are compared on: `calibration.curve.window` (default: the crush-force
/// response's window) with `calibration.curve.points`; `None` without a crush-force response.
pub fn curve_grid(settings: &CurveSettings, simulation: &Simulation) -> Option<crate::base::grid::StrokeGrid> {
    let Simulation::Solver(sim) = simulation else {
        return None;
    };
    let Response::CrushForce { window, .. } = sim.response else {
        return None;
    };
    let [s0, s1] = settings.window.unwrap_or([window.s0, window.s1]);
    Some(crate::base::grid::StrokeGrid {
        s0,
        s1,
        points: settings.points,
    })
}

/// The symbols expressions may use, in the order of [`Study::symbols`]: design variables,
/// parameters, constants (also before the study they belong to is made, while it is loaded).
fn symbols(design: &[DesignVariable], parameters: &[Parameter], constants: &[(String, f64)]) -> Symbols {
    Symbols::new(
        design
            .iter()
            .map(|d| d.name.clone())
            .chain(parameters.iter().map(|p| p.name.clone()))
            .chain(constants.iter().map(|(n, _)| n.clone())),
    )
}
