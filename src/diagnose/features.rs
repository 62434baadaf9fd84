//! The diagnosis on curves: the force–displacement curves of every specimen and of the simulation
//! read as named features ([`crate::extract::features`]: plateau level, initial peak, plateau
//! slope), so that the same rules as for a scalar response ([`super::conclude`]) rank the causes on
//! where along the stroke the model errs.
//!
//! **Whitening.** A specimen's scatter moves its features together (a thicker foil raises the peak
//! and the plateau alike), so features are not independent observations. The transformed features
//! φ (logarithms of the forces, the slope relative to the level) of each design are whitened by the
//! Cholesky factor L of one specimen's feature covariance; the observations are the components of
//! L⁻¹φ, in order: the plateau level, the initial peak given the plateau, the slope given both —
//! independent with unit variance, so the scalar diagnosis's tests apply unchanged. The covariance
//! is one of two:
//!
//! - *structured*: each specimen's curve is its design's mean curve times (1 + a), a ~ N(0, c²)
//!   (material and gauge scatter scale a whole curve), plus independent noise of variance σ_d²
//!   along the stroke; the features' covariance is then `J (c² m mᵀ + σ_d² I) Jᵀ` with J their
//!   Jacobian at the mean curve m (numerical). c² comes from the specimens' fitted scale factors
//!   (ν = Σ(n_d − 1) degrees of freedom), σ_d² from what the scale leaves along the stroke
//!   ((n_d − 1)(P − 1) degrees of freedom). Used only when the features' own scatter agrees with it:
//!   whitened by it, their pooled sample covariance Ŝ (ν degrees of freedom) must pass the
//!   likelihood-ratio test of Σ = I, `ρ ν [tr Ŝ − ln det Ŝ − K] ~ χ²_{K(K+1)/2}` at α, with
//!   Bartlett's correction ρ (Anderson 2003, §10.8.3). Contrasts between features then rest on the
//!   noise along the whole stroke; the tests still refer to F with ν denominator degrees of
//!   freedom, since the scale variance that dominates the plateau level is known only from the
//!   specimens (conservative for the contrasts).
//! - *pooled* (when the structure is rejected, or no stroke noise can be estimated): the pooled
//!   within-design sample covariance S of φ (ν degrees of freedom). With it estimated, a test is
//!   referred to F with ν − K + 1 denominator degrees of freedom and the variance scaled by
//!   ν / (ν − K + 1) (the F form of Hotelling's T²; Anderson 2003, §5.2): the price of estimating
//!   the correlations from the specimens alone.
//!
//! **Shapes.** A term hypothesis g(d, θ, y) acts on every point of the curve, δ(s) = γ g(d, θ,
//! y(s)); its feature shape is the directional derivative of L⁻¹φ along it (exact for the linear
//! features, first order for the peak and the logarithms). A model extension's shape is
//! L⁻¹(φ(y_ext) − φ(y)), as for a scalar response. The built-in shapes (offset, scale error, a
//! trend in each design variable) act on the curve in the same way.
//!
//! Pure: curves in, [`Inputs`] out.

use std::sync::Arc;

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use super::shapes::{Origin, Shape};
use super::{FeatureOutputs, Inputs, NoiseModel, Observation, Role, Settings, Space};
use crate::base::format::num;
use crate::emulate::Model;
use crate::extract::features::{self, FeatureSpec};

/// The simulation's curve on the grid at a design and θ (`None`: no emulator there).
pub type CurveFn = dyn Fn(&[f64], &[f64]) -> Option<DVector<f64>> + Send + Sync;

/// The features the diagnosis reads (indices into [`features::NAMES`]): the fold period is only
/// reported, since a simulated curve at an arbitrary θ need not resolve it.
const READ: [usize; 3] = [0, 1, 2];

/// One tested design: its specimens' curves on the grid.
#[derive(Debug, Clone)]
pub struct CurveDesign {
    pub name: String,
    pub values: Vec<f64>,
    pub role: Role,
    pub specimens: Vec<DVector<f64>>,
}

/// A candidate cause on curves.
#[derive(Clone)]
pub enum CurveHypothesis {
    /// An additive shape g(d, θ, y) acting on every point of the curve.
    Term(Shape),
    /// A model extension: its runs' curves (over θ), with its template variables. With
    /// `baseline` (the study's own curves and its parameter count p), the shape is measured against
    /// that baseline at θ's first p entries — for a loop model, whose own curve has the extension in.
    Extension {
        name: String,
        variables: Vec<(String, f64)>,
        /// The variables' declared ranges (name, min, max).
        ranges: Vec<(String, f64, f64)>,
        curve: Arc<CurveFn>,
        baseline: Option<(Arc<CurveFn>, usize)>,
    },
}

/// How the features' covariance was obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CovarianceKind {
    /// Scale factor plus independent noise along the stroke, checked against the features' scatter.
    Structured,
    /// The features' pooled sample covariance (Hotelling's correction).
    Pooled,
}

/// The features' covariance per design and what the tests may assume of it.
#[derive(Debug, Clone)]
pub struct Whitening {
    /// Indices into [`features::NAMES`] of the features read, in whitening order.
    pub read: Vec<usize>,
    /// Per design (by its values): the lower Cholesky factor of one specimen's feature covariance.
    factors: Vec<(Vec<f64>, DMatrix<f64>)>,
    pub kind: CovarianceKind,
    /// Variance of a whitened observation (1, or Hotelling's ν / (ν − K + 1)).
    pub variance: f64,
    /// Degrees of freedom of the tests' noise.
    pub dof: usize,
    /// ν: the specimens' degrees of freedom.
    pub specimens_dof: usize,
    /// The structured covariance's check: statistic, its χ² degrees of freedom, p.
    pub check: Option<(f64, usize, f64)>,
    /// The emulator's own error, added to the tests' noise ([`emulator_error`]).
    pub emulator: Option<EmulatorError>,
}

impl Whitening {
    fn factor(&self, design: &[f64]) -> Option<&DMatrix<f64>> {
        self.factors.iter().find(|(d, _)| d == design).map(|(_, l)| l)
    }

    /// The specimens' whitening of their features (module notes), as the diagnosis makes it: for a
    /// planner that reads runs in the diagnosis's own units.
    pub fn of_specimens(designs: &[CurveDesign], spec: &FeatureSpec, alpha: f64) -> Result<Whitening, String> {
        whitening(designs, spec, alpha)
    }

    /// L⁻¹φ of a curve's features at a design (`None` where a feature is missing or not finite).
    pub fn whiten(&self, spec: &FeatureSpec, design: &[f64], curve: &[f64]) -> Option<DVector<f64>> {
        let v = features::measure_with(spec, curve, self.read.contains(&3)).vector(spec);
        let phi: Option<Vec<f64>> = self.read.iter().map(|&k| v[k].filter(|x| x.is_finite())).collect();
        self.factor(design)?.solve_lower_triangular(&DVector::from_vec(phi?))
    }

    /// The names of the whitened observations.
    pub fn names(&self) -> Vec<String> {
        self.read
            .iter()
            .enumerate()
            .map(|(i, &k)| match i {
                0 => features::NAMES[k].to_string(),
                1 => format!("{} given the {}", features::NAMES[k], features::NAMES[self.read[0]]),
                _ => format!("{} given the rest", features::NAMES[k]),
            })
            .collect()
    }
}

/// Per design and feature: what the specimens measured and what the models predict
/// (`results.json` `diagnosis.features.rows`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FeatureRow {
    pub design: String,
    pub feature: String,
    pub unit: String,
    /// Mean over the specimens, and the standard deviation of that mean.
    pub measured: f64,
    pub sigma: f64,
    pub specimens: usize,
    /// The uncorrected simulation's value at its calibrated parameters, and (measured −
    /// predicted) / σ.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub uncorrected: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub z_uncorrected: Option<f64>,
    /// The final model's (the named cause's extended model).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub extended: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub z_extended: Option<f64>,
}

/// `results.json` `diagnosis.features`: the curve features the diagnosis read and where along the
/// stroke the model errs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FeaturesReport {
    /// The whitened observations the tests read, in order.
    pub read: Vec<String>,
    pub covariance: CovarianceKind,
    /// The structured covariance's check (statistic, degrees of freedom, p).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub covariance_check: Option<(f64, usize, f64)>,
    pub rows: Vec<FeatureRow>,
    /// The whitened observation whose misfit the final model removed most (its share of the drop
    /// in χ² from the uncorrected model), when a cause is extended.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub decided_by: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub decided_share: Option<f64>,
    /// The curve emulator's error counted in the noise ([`emulator_error`]).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub emulator: Option<EmulatorError>,
}

/// A model's curve at a design's values (`None` where it cannot be evaluated).
pub type CurveOf<'a> = dyn Fn(&[f64]) -> Option<DVector<f64>> + 'a;

impl FeaturesReport {
    /// The report of `problem`'s features, with the uncorrected and (when there is one) final
    /// models' curves, and the diagnosis's whitened residuals before and after.
    pub fn new(
        problem: &FeatureProblem,
        designs: &[CurveDesign],
        uncorrected: &dyn Fn(&[f64]) -> Option<DVector<f64>>,
        extended: Option<&CurveOf>,
        diagnosis: &super::Diagnosis,
    ) -> FeaturesReport {
        let spec = problem.model.spec;
        let w = &problem.model.whitening;
        let value = |c: &DVector<f64>, feature: &str| -> Option<f64> {
            let k = features::NAMES.iter().position(|n| *n == feature)?;
            raw(&features::measure(&spec, c.as_slice()), k)
        };
        let rows = problem
            .rows
            .iter()
            .map(|r| {
                let d = designs.iter().find(|d| d.name == r.design);
                let at = |model: &dyn Fn(&[f64]) -> Option<DVector<f64>>| {
                    d.and_then(|d| model(&d.values)).and_then(|c| value(&c, &r.feature))
                };
                let z = |v: Option<f64>| v.map(|v| (r.measured - v) / r.sigma).filter(|z| z.is_finite());
                let before = at(uncorrected);
                let after = extended.and_then(at);
                FeatureRow {
                    uncorrected: before,
                    z_uncorrected: z(before),
                    extended: after,
                    z_extended: z(after),
                    ..r.clone()
                }
            })
            .collect();
        let (decided_by, decided_share) = decided(w, diagnosis).unzip();
        FeaturesReport {
            read: w.names(),
            covariance: w.kind,
            covariance_check: w.check,
            rows,
            decided_by,
            decided_share,
            emulator: w.emulator.clone(),
        }
    }
}

/// The whitened output with the largest share of the drop in Σz² from the uncorrected model to the
/// named cause's extended model.
fn decided(w: &Whitening, d: &super::Diagnosis) -> Option<(String, f64)> {
    let after = &d.extended_model()?.check.residual_z;
    let names = w.names();
    let drop: Vec<f64> = names
        .iter()
        .map(|name| {
            d.record
                .residuals
                .iter()
                .filter(|r| r.design.ends_with(&format!(" · {name}")))
                .map(|r| r.z.powi(2) - after.get(&r.design).map_or(r.z.powi(2), |z| z * z))
                .sum()
        })
        .collect();
    let total: f64 = drop.iter().filter(|x| **x > 0.0).sum();
    let (k, best) = drop.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1))?;
    (total > 0.0 && *best > 0.0).then(|| (names[k].clone(), best / total))
}

/// Everything the diagnosis on curves needs.
#[derive(Clone)]
pub struct CurveInputs<'a> {
    pub designs: Vec<CurveDesign>,
    pub spec: FeatureSpec,
    pub curve: Arc<CurveFn>,
    pub space: Space,
    pub hypotheses: Vec<CurveHypothesis>,
    pub settings: Settings,
    /// The study's constants, for a term's expression.
    pub constants: &'a [(String, f64)],
    /// Runs of the simulation held out of `curve`'s emulator: what it gets wrong, in the features.
    pub checks: Vec<EmulatorCheck>,
}

/// A simulation run held out of the curve emulator: its design, θ, curve on the grid, and the curve
/// the emulator predicted there without it.
#[derive(Debug, Clone)]
pub struct EmulatorCheck {
    pub design: Vec<f64>,
    pub theta: Vec<f64>,
    pub curve: DVector<f64>,
    pub emulated: DVector<f64>,
}

/// The emulator's error in the whitened features (`results.json` `diagnosis.features.emulator`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EmulatorError {
    /// Check runs it was measured on.
    pub runs: usize,
    /// Per whitened feature, the mean square of (simulation − emulator) at the check runs, in units
    /// of one specimen's noise variance.
    pub variance: Vec<f64>,
    /// The check runs pair across the designs: only the part of the error a change of θ cannot
    /// absorb is counted ([`crate::emulate::Uncertainty::beyond`]).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub paired: bool,
    /// The check runs pair nowhere (a sequential study's, each design's own near the posterior)
    /// but every design has some: each design's mean error is split as the paired errors are, the
    /// spread about it counted whole.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub by_means: bool,
}

/// The emulator's error at the check runs, whitened like the tests (Kennedy & O'Hagan 2001 count the
/// code's own uncertainty in the prediction's variance; here it is measured, not modelled): per
/// whitened feature k, s²_k = mean over the checks of (L⁻¹φ(simulated) − L⁻¹φ(emulated))_k², the
/// mean square rather than the variance, so that a bias counts too. `None` without check runs.
pub fn emulator_error(w: &Whitening, spec: &FeatureSpec, checks: &[EmulatorCheck]) -> Option<EmulatorError> {
    mean_square(w, &whitened_errors(w, spec, checks))
}

/// At each check run whose features can be read: L⁻¹φ(simulated) − L⁻¹φ(emulated).
fn whitened_errors<'c>(
    w: &Whitening,
    spec: &FeatureSpec,
    checks: &'c [EmulatorCheck],
) -> Vec<(&'c EmulatorCheck, DVector<f64>)> {
    checks
        .iter()
        .filter_map(|c| {
            let a = w.whiten(spec, &c.design, c.curve.as_slice())?;
            let b = w.whiten(spec, &c.design, c.emulated.as_slice())?;
            Some((c, a - b))
        })
        .collect()
}

/// The figures of [`emulator_error`] from the whitened `errors`.
fn mean_square(w: &Whitening, errors: &[(&EmulatorCheck, DVector<f64>)]) -> Option<EmulatorError> {
    let n = errors.len();
    (n > 0).then(|| EmulatorError {
        paired: false,
        by_means: false,
        runs: n,
        variance: (0..w.read.len())
            .map(|k| errors.iter().map(|(_, e)| e[k] * e[k]).sum::<f64>() / n as f64 / w.variance)
            .collect(),
    })
}

impl Whitening {
    /// Records the emulator's error `e` without counting it here (the diagnosis counts it).
    fn noting(mut self, e: EmulatorError) -> Whitening {
        self.emulator = (e.runs > 0).then_some(e);
        self
    }

    /// Counts the emulator's error in the noise of each design's mean features. A design's mean of m
    /// specimens has whitened variance v/m from the tests (v = [`Whitening::variance`]) plus s²_k·v
    /// from the emulator, which does not shrink with m: the k-th whitened feature is divided by
    /// √(1 + m s²_k), so that v/m stays the variance of the mean the diagnosis assumes. The tests'
    /// degrees of freedom are kept (the check runs' own count is not added: a conservative choice
    /// only where s² is well above the tests' share).
    /// With `floor` > 0 the emulator's share of a mean's variance is at least `floor`
    /// ([`super::Settings::emulator_floor`]): the factor is √(1 + max(m s²_k, floor)).
    fn with_emulator(mut self, designs: &[CurveDesign], e: EmulatorError, floor: f64) -> Whitening {
        for (values, l) in &mut self.factors {
            let m = designs
                .iter()
                .find(|d| &d.values == values)
                .map_or(1, |d| d.specimens.len().max(1));
            for (k, s2) in e.variance.iter().enumerate() {
                let c = (1.0 + (m as f64 * s2).max(floor)).sqrt();
                l.column_mut(k).scale_mut(c);
            }
        }
        if e.runs > 0 {
            self.emulator = Some(e);
        }
        self
    }
}

/// The features as a model of its own: at point (design, k), the k-th whitened feature of the
/// simulation's curve.
pub struct FeatureModel {
    curve: Arc<CurveFn>,
    spec: FeatureSpec,
    whitening: Whitening,
    cache: Memo,
}

impl FeatureModel {
    /// A curve's features at a design, whitened as the tests' (`None`: a feature cannot be read).
    pub fn whiten_curve(&self, design: &[f64], curve: &[f64]) -> Option<DVector<f64>> {
        self.whitening.whiten(&self.spec, design, curve)
    }
}

/// Whitened feature vectors per (design, θ), keyed by their bits: every output k of a design asks
/// for the same vector, and fits revisit points.
struct Memo(crate::base::memo::Memo<Vec<u64>, Option<DVector<f64>>>);

impl Default for Memo {
    fn default() -> Self {
        Self(crate::base::memo::Memo::new(200_000))
    }
}

impl Memo {
    /// Entry k of the vector at (d, θ), computed once.
    fn entry(&self, d: &[f64], theta: &[f64], k: usize, compute: impl FnOnce() -> Option<DVector<f64>>) -> f64 {
        let key: Vec<u64> = d.iter().chain(theta).map(|v| v.to_bits()).collect();
        let known = |z: &Option<DVector<f64>>| z.as_ref().map_or(f64::NAN, |z| z[k]);
        self.0.read_or_compute(key, known, compute)
    }
}

impl FeatureModel {
    fn split<'p>(&self, point: &'p [f64]) -> (&'p [f64], usize) {
        if self.whitening.read.len() > 1 {
            (&point[..point.len() - 1], point[point.len() - 1] as usize)
        } else {
            (point, 0)
        }
    }
}

impl Model for FeatureModel {
    fn predict(&self, point: &[f64], theta: &[f64]) -> f64 {
        let (d, k) = self.split(point);
        self.cache.entry(d, theta, k, || {
            (self.curve)(d, theta).and_then(|c| self.whitening.whiten(&self.spec, d, c.as_slice()))
        })
    }
}

/// The diagnosis's problem on curves: the feature model and the whitened observations.
pub struct FeatureProblem {
    pub model: FeatureModel,
    pub observations: Vec<Observation>,
    pub rows: Vec<FeatureRow>,
    pub shapes: Vec<Shape>,
    pub built_ins: Vec<Shape>,
    pub noise: NoiseModel,
    /// The curve emulator's error in the whitened features when its check runs pair across the
    /// designs (then counted by the diagnosis, beyond what θ absorbs); else it is in the whitening.
    pub emulator: crate::emulate::Uncertainty,
}

impl FeatureProblem {
    /// The whitened features of every specimen, the feature model, and the hypotheses' and
    /// built-ins' shapes on them; `Err` when the specimens cannot give a covariance.
    pub fn new(ci: &CurveInputs) -> Result<FeatureProblem, String> {
        let tests = whitening(&ci.designs, &ci.spec, ci.settings.alpha)?;
        let (whitening, emulator) = match paired_emulator_error(&tests, ci) {
            Some((e, u)) => (tests.noting(e), u),
            None => (with_emulator_error(tests, ci), Default::default()),
        };
        let model = FeatureModel {
            curve: ci.curve.clone(),
            spec: ci.spec,
            whitening: whitening.clone(),
            cache: Default::default(),
        };
        let shape_of = |h: &CurveHypothesis| feature_shape(h, &model);
        let shapes = ci.hypotheses.iter().map(shape_of).collect();
        let built_ins = Shape::built_ins(&ci.space.design_names)
            .into_iter()
            .map(|s| feature_shape(&CurveHypothesis::Term(s), &model))
            .collect();
        Ok(FeatureProblem {
            emulator,
            rows: rows(&ci.designs, &ci.spec),
            noise: NoiseModel::constant(whitening.variance.sqrt(), whitening.dof, noise_source(ci, &whitening)),
            observations: observations(ci, &whitening),
            model,
            shapes,
            built_ins,
        })
    }

    /// The diagnosis's inputs over this problem.
    pub fn inputs<'a>(&'a self, ci: &CurveInputs) -> Inputs<'a> {
        Inputs {
            observations: self.observations.clone(),
            model: &self.model,
            space: ci.space.clone(),
            hypotheses: self.shapes.clone(),
            settings: ci.settings.clone(),
            library: None,
            built_ins: Some(self.built_ins.clone()),
            features: Some(FeatureOutputs {
                outputs: self.model.whitening.names(),
                noise: self.noise.clone(),
                relative_error: self.plateau_error(),
            }),
            // Paired across the designs, the emulator's error is counted by the diagnosis (beyond
            // what θ absorbs); else it is in the whitening already ([`emulator_error`]).
            emulator: self.emulator.clone(),
        }
    }

    /// The relative error of the plateau level (the mean crush force) behind a whitened
    /// prediction: its first component is ln(plateau) / L₀₀, so the ratio of predicted to measured
    /// (geometric mean) plateau is exp(L₀₀ (ŷ − ȳ)). The other outputs have none.
    fn plateau_error(&self) -> super::RelativeError {
        let w = self.model.whitening.clone();
        let plateau_first = w.read.first() == Some(&0);
        std::sync::Arc::new(move |o: &Observation, yh: f64| {
            if !plateau_first || o.output != 0 {
                return None;
            }
            let l00 = w.factor(&o.design)?[(0, 0)];
            Some((l00 * (yh - o.mean)).exp() - 1.0)
        })
    }
}

/// The features' covariance (see the module notes): structured when the specimens' feature scatter
/// agrees with it at `alpha`, else pooled.
fn whitening(designs: &[CurveDesign], spec: &FeatureSpec, alpha: f64) -> Result<Whitening, String> {
    let vectors: Vec<Vec<[Option<f64>; 4]>> = designs
        .iter()
        .map(|d| {
            d.specimens
                .iter()
                .map(|c| features::measure(spec, c.as_slice()).vector(spec))
                .collect()
        })
        .collect();
    let nu: usize = designs.iter().map(|d| d.specimens.len().saturating_sub(1)).sum();
    let mut read: Vec<usize> = READ
        .iter()
        .copied()
        .filter(|&k| vectors.iter().flatten().all(|v| v[k].is_some_and(f64::is_finite)))
        .collect();
    read.truncate(nu);
    if read.is_empty() {
        return Err(
            "the specimens give no replicate scatter of their curves' features (one specimen per design)".into(),
        );
    }
    // The features' deviations from their design's mean, per design.
    let deviations: Vec<Vec<DVector<f64>>> = vectors
        .iter()
        .map(|d| {
            let n = d.len() as f64;
            let mean: Vec<f64> = read
                .iter()
                .map(|&f| d.iter().map(|v| v[f].unwrap()).sum::<f64>() / n)
                .collect();
            d.iter()
                .map(|v| DVector::from_iterator(read.len(), read.iter().zip(&mean).map(|(&f, m)| v[f].unwrap() - m)))
                .collect()
        })
        .collect();
    let structured = structured(designs, spec, &read, nu).and_then(|factors| {
        let check = covariance_check(&factors, designs, &deviations, nu);
        Some((factors, check?))
    });
    match structured {
        Some((factors, check)) if check.2 >= alpha => Ok(Whitening {
            read,
            factors,
            kind: CovarianceKind::Structured,
            variance: 1.0,
            dof: nu,
            specimens_dof: nu,
            check: Some(check),
            emulator: None,
        }),
        other => pooled(designs, &deviations, read, nu, other.map(|(_, c)| c)),
    }
}

/// Per design, the Cholesky factor of `J (c² m mᵀ + σ_d² I) Jᵀ`; `None` when it cannot be formed.
fn structured(
    designs: &[CurveDesign],
    spec: &FeatureSpec,
    read: &[usize],
    nu: usize,
) -> Option<Vec<(Vec<f64>, DMatrix<f64>)>> {
    // Each specimen's scale factor a and what it leaves along the stroke.
    let mut a2 = 0.0;
    let mut noise = Vec::new();
    let mut means = Vec::new();
    for d in designs {
        let n = d.specimens.len();
        let p = d.specimens.first()?.len();
        let m = d.specimens.iter().fold(DVector::zeros(p), |acc, c| acc + c) / n as f64;
        let mm = m.norm_squared();
        let mut ss = 0.0;
        for c in &d.specimens {
            let e = c - &m;
            let a = e.dot(&m) / mm;
            a2 += a * a;
            ss += (e - &m * a).norm_squared();
        }
        let dof = (n.saturating_sub(1) * p.saturating_sub(1)).max(1);
        noise.push(ss / dof as f64);
        means.push(m);
    }
    let c2 = a2 / nu.max(1) as f64;
    let k = read.len();
    let mut out = Vec::new();
    for ((d, m), s2) in designs.iter().zip(&means).zip(&noise) {
        let j = jacobian(spec, m, read)?;
        let jm = &j * m;
        let cov = &jm * jm.transpose() * c2 + &j * j.transpose() * *s2;
        let l = cov.cholesky()?.l();
        if l.diagonal().iter().any(|v| !(v.is_finite() && *v > 0.0)) || l.nrows() != k {
            return None;
        }
        out.push((d.values.clone(), l));
    }
    Some(out)
}

/// ∂φ/∂y(s) of the read features at the curve `m`, by central differences of step 1e-6 of its level.
fn jacobian(spec: &FeatureSpec, m: &DVector<f64>, read: &[usize]) -> Option<DMatrix<f64>> {
    let h = 1e-6 * m.amax().max(f64::MIN_POSITIVE);
    let at = |c: &DVector<f64>| -> Option<Vec<f64>> {
        let v = features::measure(spec, c.as_slice()).vector(spec);
        read.iter().map(|&k| v[k]).collect()
    };
    let mut j = DMatrix::zeros(read.len(), m.len());
    for s in 0..m.len() {
        let (mut up, mut down) = (m.clone(), m.clone());
        up[s] += h;
        down[s] -= h;
        let (a, b) = (at(&up)?, at(&down)?);
        for r in 0..read.len() {
            j[(r, s)] = (a[r] - b[r]) / (2.0 * h);
        }
    }
    Some(j)
}

/// The likelihood-ratio test that the features' deviations, whitened by `factors`, have unit
/// covariance: (statistic, degrees of freedom, p).
fn covariance_check(
    factors: &[(Vec<f64>, DMatrix<f64>)],
    designs: &[CurveDesign],
    deviations: &[Vec<DVector<f64>>],
    nu: usize,
) -> Option<(f64, usize, f64)> {
    let k = factors.first()?.1.nrows();
    if nu < k {
        return None;
    }
    let mut s = DMatrix::zeros(k, k);
    for ((d, devs), (values, l)) in designs.iter().zip(deviations).zip(factors) {
        debug_assert_eq!(&d.values, values);
        for e in devs {
            let w = l.solve_lower_triangular(e)?;
            s += &w * w.transpose();
        }
    }
    s /= nu as f64;
    unit_covariance_test(&s, nu)
}

/// The test that the whitened sample covariance `s` on `nu` degrees of freedom comes from Σ = I: the
/// likelihood-ratio criterion ν [tr S − ln det S − K] times Bartlett's small-sample factor
/// ρ = 1 − (2K² + 3K − 1) / (6ν(K + 1)) (Anderson 2003, §10.8.3), against χ² on K(K + 1)/2 − 1:
/// the structure's scale variance c² is estimated from these same specimens, which fixes the
/// sample variance along the scale's direction, one of the K(K + 1)/2 moments the criterion reads.
/// Specimens drawn as the structure says (`the_structure_check_holds_its_level...`) are rejected in
/// 1.4 % of draws at a nominal 1 % with three per design (ν = 6), 0.8 % with four; the χ² on
/// K(K + 1)/2 without ρ rejected 2.2 % and 1.0 %, and 14 % with two (now 4.1 %).
pub fn unit_covariance_test(s: &DMatrix<f64>, nu: usize) -> Option<(f64, usize, f64)> {
    let k = s.nrows() as f64;
    let det = s.determinant();
    if det <= 0.0 || nu == 0 {
        return None;
    }
    let rho = 1.0 - (2.0 * k * k + 3.0 * k - 1.0) / (6.0 * nu as f64 * (k + 1.0));
    let t = rho * nu as f64 * (s.trace() - det.ln() - k);
    let moments = s.nrows() * (s.nrows() + 1) / 2;
    let f = if moments > 1 { moments - 1 } else { moments };
    Some((t, f, super::stats::chi2_sf(t, f as f64)))
}

/// The pooled sample covariance of the features, one factor for every design.
fn pooled(
    designs: &[CurveDesign],
    deviations: &[Vec<DVector<f64>>],
    mut read: Vec<usize>,
    nu: usize,
    check: Option<(f64, usize, f64)>,
) -> Result<Whitening, String> {
    let k = read.len();
    let mut s = DMatrix::zeros(k, k);
    for e in deviations.iter().flatten() {
        s += e * e.transpose();
    }
    s /= nu as f64;
    // A feature the specimens do not scatter in (or that the others fix) cannot be whitened: drop
    // the later ones until the covariance factors.
    while !read.is_empty() {
        let kk = read.len();
        if let Some(ch) = s.view((0, 0), (kk, kk)).clone_owned().cholesky() {
            let l = ch.l();
            if l.diagonal().iter().all(|v| *v > 1e-12 * l[(0, 0)].abs()) {
                let dof = nu + 1 - kk;
                return Ok(Whitening {
                    read,
                    factors: designs.iter().map(|d| (d.values.clone(), l.clone())).collect(),
                    kind: CovarianceKind::Pooled,
                    variance: nu as f64 / dof as f64,
                    dof,
                    specimens_dof: nu,
                    check,
                    emulator: None,
                });
            }
        }
        read.pop();
    }
    Err("the specimens' feature scatter is degenerate".into())
}

/// Feature `k` of [`features::NAMES`] as measured, untransformed.
fn raw(f: &features::Features, k: usize) -> Option<f64> {
    match k {
        0 => Some(f.plateau),
        1 => f.peak.map(|p| p.0),
        2 => Some(f.slope),
        _ => f.period,
    }
}

/// The measured features per design, unwhitened, for the report.
fn rows(designs: &[CurveDesign], spec: &FeatureSpec) -> Vec<FeatureRow> {
    let mut out = Vec::new();
    for d in designs {
        let f: Vec<features::Features> = d
            .specimens
            .iter()
            .map(|c| features::measure(spec, c.as_slice()))
            .collect();
        let n = f.len();
        for k in 0..4 {
            let v: Vec<f64> = f.iter().filter_map(|x| raw(x, k)).collect();
            if v.len() != n || n == 0 {
                continue;
            }
            let (mean, sd) = crate::study::experiments::mean_sd(&v);
            let sd = sd.unwrap_or(f64::NAN);
            out.push(FeatureRow {
                design: d.name.clone(),
                feature: features::NAMES[k].to_string(),
                unit: ["kN", "kN", "kN/mm", "mm"][k].to_string(),
                measured: mean,
                sigma: sd / (n as f64).sqrt(),
                specimens: n,
                uncorrected: None,
                z_uncorrected: None,
                extended: None,
                z_extended: None,
            });
        }
    }
    out
}

/// A hypothesis as a shape of the whitened features.
fn feature_shape(h: &CurveHypothesis, model: &FeatureModel) -> Shape {
    let curve = model.curve.clone();
    let spec = model.spec;
    let w = model.whitening.clone();
    let read = w.read.len();
    let split = move |point: &[f64]| -> (Vec<f64>, usize) {
        if read > 1 {
            (point[..point.len() - 1].to_vec(), point[point.len() - 1] as usize)
        } else {
            (point.to_vec(), 0)
        }
    };
    match h {
        CurveHypothesis::Term(g) => {
            let g = g.clone();
            let memo = Memo::default();
            let mut s = Shape::new(g.name.clone(), g.term.clone(), g.origin, move |point, theta, _| {
                let (d, k) = split(point);
                memo.entry(&d, theta, k, || {
                    let y = curve(&d, theta)?;
                    let delta = DVector::from_iterator(y.len(), y.iter().map(|&v| g.eval(&d, theta, v)));
                    let scale = delta.amax();
                    if scale == 0.0 {
                        return Some(DVector::zeros(read));
                    }
                    if !scale.is_finite() {
                        return None;
                    }
                    // A step small against the curve keeps the logarithms and the peak linear.
                    let eps = 1e-4 * y.amax() / scale;
                    let moved = &y + &delta * eps;
                    Some((w.whiten(&spec, &d, moved.as_slice())? - w.whiten(&spec, &d, y.as_slice())?) / eps)
                })
            });
            s.extension = None;
            s
        }
        CurveHypothesis::Extension {
            name,
            variables,
            ranges,
            curve: ext,
            baseline,
        } => {
            let ext = ext.clone();
            let baseline = baseline.clone();
            let memo = Memo::default();
            let set = super::shapes::setting(variables);
            let mut s = Shape::new(
                name.clone(),
                format!("y[{set}] - y"),
                Origin::Study,
                move |point, theta, _| {
                    let (d, k) = split(point);
                    memo.entry(&d, theta, k, || {
                        let (base, t) = match &baseline {
                            Some((b, p)) => (b(&d, &theta[..(*p).min(theta.len())]), &theta[..(*p).min(theta.len())]),
                            None => (curve(&d, theta), theta),
                        };
                        let (y, e) = (base?, ext(&d, t)?);
                        Some(w.whiten(&spec, &d, e.as_slice())? - w.whiten(&spec, &d, y.as_slice())?)
                    })
                },
            );
            s.extension = Some(variables.clone());
            s.ranges = ranges.clone();
            s
        }
    }
}

/// The curve emulator's error when its shape across designs is known — its check runs pair across
/// the designs (each design checked at the same points θ, as a fixed design's are), or every design
/// has its own (a sequential study's) — and no floor is asked for: its figures, and the errors in
/// the whitened features as the diagnosis reads them (per observation, in the order of
/// [`observations`]), so that the part a change of θ absorbs is not counted
/// ([`crate::emulate::Uncertainty::beyond`]). `None`: counted in the whitening instead.
fn paired_emulator_error(tests: &Whitening, ci: &CurveInputs) -> Option<(EmulatorError, crate::emulate::Uncertainty)> {
    if !ci.settings.emulator_counted || ci.settings.emulator_floor > 0.0 {
        return None;
    }
    let whitened = whitened_errors(tests, &ci.spec, &ci.checks);
    let errors: Vec<(&[f64], &[f64], DVector<f64>)> = whitened
        .iter()
        .map(|(c, e)| (c.design.as_slice(), c.theta.as_slice(), e.clone()))
        .collect();
    let at: Vec<(&[f64], usize)> = ci
        .designs
        .iter()
        .flat_map(|d| (0..tests.read.len()).map(move |k| (d.values.as_slice(), k)))
        .collect();
    let u = crate::emulate::Uncertainty::of_outputs(&at, &errors);
    if !u.has_shape() {
        return None;
    }
    let mut e = mean_square(tests, &whitened)?;
    (e.paired, e.by_means) = (u.is_paired(), !u.is_paired());
    Some((e, u))
}

/// The specimens' whitening with the curve emulator's own error counted (its check runs), at least
/// at the settings' floor.
fn with_emulator_error(whitening: Whitening, ci: &CurveInputs) -> Whitening {
    if !ci.settings.emulator_counted {
        return whitening;
    }
    let floor = ci.settings.emulator_floor;
    match emulator_error(&whitening, &ci.spec, &ci.checks) {
        Some(e) => whitening.with_emulator(&ci.designs, e, floor),
        None if floor > 0.0 => {
            let none = EmulatorError {
                paired: false,
                by_means: false,
                runs: 0,
                variance: vec![0.0; whitening.read.len()],
            };
            whitening.with_emulator(&ci.designs, none, floor)
        }
        None => whitening,
    }
}

/// Each design's specimens' whitened features, one observation per design and feature.
fn observations(ci: &CurveInputs, whitening: &Whitening) -> Vec<Observation> {
    let k = whitening.read.len();
    let mut observations = Vec::new();
    for d in &ci.designs {
        let z: Vec<DVector<f64>> = d
            .specimens
            .iter()
            .filter_map(|c| whitening.whiten(&ci.spec, &d.values, c.as_slice()))
            .collect();
        for j in 0..k {
            let reps: Vec<f64> = z.iter().map(|v| v[j]).collect();
            observations.push(
                Observation::from_replicates(d.name.clone(), d.values.clone(), d.role, &reps)
                    .of_output(j, &whitening.names()[j]),
            );
        }
    }
    observations
}

/// Where the features' noise comes from, in words: the features read, the specimens, how they
/// were whitened, and the emulator's error counted in it.
fn noise_source(ci: &CurveInputs, whitening: &Whitening) -> String {
    let k = whitening.read.len();
    let names = whitening
        .read
        .iter()
        .map(|&i| features::NAMES[i])
        .collect::<Vec<_>>()
        .join(", ");
    let specimens: usize = ci.designs.iter().map(|d| d.specimens.len()).sum();
    let how = match (whitening.kind, whitening.check) {
        (CovarianceKind::Structured, Some((t, f, p))) => format!(
            "whitened by a scale factor per specimen plus independent noise along the stroke, which the features' \
             own scatter does not reject (χ² = {} on {f} degrees of freedom, p = {}); the tests take the \
             specimens' {} degrees of freedom",
            num(t),
            num(p),
            whitening.dof
        ),
        (_, check) => format!(
            "whitened by their pooled covariance ({} degrees of freedom; {} left for the tests once the {k} × {k} \
             covariance is estimated{})",
            whitening.specimens_dof,
            whitening.dof,
            check.map_or(String::new(), |(t, f, p)| format!(
                "; a scale factor plus independent noise along the stroke was rejected: χ² = {} on {f} degrees of \
                 freedom, p = {}",
                num(t),
                num(p)
            ))
        ),
    };
    let how = match &whitening.emulator {
        Some(e) => format!(
            "{how}; plus the emulator's own error, measured at {} check run(s) (mean square {} of one \
             specimen's noise variance, per whitened feature), which more specimens do not reduce{}",
            e.runs,
            e.variance.iter().map(|v| num(*v)).collect::<Vec<_>>().join(", "),
            match e.paired || e.by_means {
                true => " (only its part that a change of the parameters cannot absorb)",
                false => "",
            }
        ),
        None => how,
    };
    format!(
        "curve features ({names}) of {specimens} specimens at {} designs, {how}",
        ci.designs.len()
    )
}

impl super::Diagnosis {
    /// The diagnosis with the curve features it read (worded by [`super::Diagnosis::worded`]).
    pub fn with_features(mut self, report: FeaturesReport) -> super::Diagnosis {
        self.checked.features = Some(report);
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::extract::crush::Window;
    use crate::extract::grid::StrokeGrid;

    fn spec() -> FeatureSpec {
        FeatureSpec {
            grid: StrokeGrid {
                s0: 0.0,
                s1: 60.0,
                points: 121,
            },
            plateau: Window { s0: 5.0, s1: 60.0 },
        }
    }

    /// The plateau level alone, one specimen's standard deviation 0.1 kN at design [1].
    fn whitening() -> Whitening {
        Whitening {
            read: vec![0],
            factors: vec![(vec![1.0], DMatrix::from_element(1, 1, 0.1))],
            kind: CovarianceKind::Pooled,
            variance: 1.0,
            dof: 6,
            specimens_dof: 6,
            check: None,
            emulator: None,
        }
    }

    fn flat(level: f64) -> DVector<f64> {
        DVector::from_element(121, level)
    }

    /// An emulator that predicts a flat curve at θ₀ = 2 kN misses three check runs by +0.05, −0.05
    /// and +0.1 kN. The feature is ln plateau, so the mean square in units of one specimen's variance
    /// is Σ ln(1 + e/2)² / 3 / 0.1²; a design's mean of 4 specimens then has its whitened feature
    /// divided by √(1 + 4 s²).
    #[test]
    fn the_emulators_error_is_the_mean_square_at_the_check_runs_added_to_the_means_variance() {
        let w = whitening();
        let checks: Vec<EmulatorCheck> = [0.05, -0.05, 0.1]
            .iter()
            .map(|e| EmulatorCheck {
                design: vec![1.0],
                theta: vec![2.0],
                curve: flat(2.0 + e),
                emulated: flat(2.0),
            })
            .collect();
        let e = emulator_error(&w, &spec(), &checks).unwrap();
        assert_eq!(e.runs, 3);
        let s2 = [0.05f64, -0.05, 0.1]
            .iter()
            .map(|e| (1.0 + e / 2.0).ln().powi(2))
            .sum::<f64>()
            / 3.0
            / 0.01;
        assert!((e.variance[0] - s2).abs() < 1e-12, "{:?} vs {s2}", e.variance);
        let design = CurveDesign {
            name: "d".into(),
            values: vec![1.0],
            role: Role::Training,
            specimens: vec![flat(0.0); 4],
        };
        let before = w.whiten(&spec(), &[1.0], flat(3.0).as_slice()).unwrap()[0];
        let inflated = w.with_emulator(std::slice::from_ref(&design), e, 0.0);
        let after = inflated.whiten(&spec(), &[1.0], flat(3.0).as_slice()).unwrap()[0];
        assert!((before - 3f64.ln() / 0.1).abs() < 1e-9, "{before}");
        assert!((after - before / (1.0 + 4.0 * s2).sqrt()).abs() < 1e-9, "{after}");
        assert!(emulator_error(&whitening(), &spec(), &[]).is_none());
    }

    /// A specimen curve of `fixtures/honeycomb/tests` on the features' grid (0–60 mm, 121 points),
    /// read and resampled as the diagnosis reads the tests.
    fn fixture_curve(name: &str) -> DVector<f64> {
        let path = format!("{}/fixtures/honeycomb/tests/{name}.csv", env!("CARGO_MANIFEST_DIR"));
        let curve = crate::base::curve::read_test_csv(path.as_ref(), Default::default()).unwrap();
        DVector::from_vec(crate::base::grid::resample(&curve, &spec().grid).unwrap())
    }

    /// The structure check's level, on specimens drawn exactly as the structure says: the mean
    /// curves of the main job's three designs (the mean of their fixture specimens), each
    /// specimen that curve times (1 + 0.02 z) plus noise of 0.5 % of its level per point (as
    /// `examples/make_honeycomb_tests.rs` draws), 1,000 seeded draws of three and of four
    /// specimens per design. The share of draws rejected at α = 0.01 lies in 0.3–2 % (binomial
    /// standard deviation 0.3 %; measured 1.4 % and 0.8 % over 3,000). The χ² reference without
    /// Bartlett's ρ and the lost degree of freedom rejected 2.1 % of these draws at three
    /// specimens, and fails here.
    #[test]
    fn the_structure_check_holds_its_level_on_specimens_drawn_as_it_says() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let means: Vec<DVector<f64>> = ["C6T5", "C3T7", "C3T8"]
            .iter()
            .map(|d| {
                (1..=3)
                    .map(|k| fixture_curve(&format!("{d}-{k}")))
                    .sum::<DVector<f64>>()
                    / 3.0
            })
            .collect();
        let mut normal = move || rng.sample::<f64, _>(rand_distr::StandardNormal);
        for specimens in [3, 4] {
            let draws = 1000;
            let mut rejected = 0;
            for _ in 0..draws {
                let designs: Vec<CurveDesign> = means
                    .iter()
                    .enumerate()
                    .map(|(i, m)| CurveDesign {
                        name: format!("D{i}"),
                        values: vec![i as f64],
                        role: Role::Training,
                        specimens: (0..specimens)
                            .map(|_| {
                                let a = 1.0 + 0.02 * normal();
                                m.map(|y| y * a + 0.005 * m.mean() * normal())
                            })
                            .collect(),
                    })
                    .collect();
                let w = super::whitening(&designs, &spec(), 0.01).unwrap();
                rejected += usize::from(w.check.unwrap().2 < 0.01);
            }
            let share = rejected as f64 / draws as f64;
            assert!(
                (0.003..=0.02).contains(&share),
                "{specimens} specimens: {share} rejected"
            );
        }
    }
}
