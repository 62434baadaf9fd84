//! Diagnosis: what the simulation gets wrong, which candidate cause explains it, how much an
//! extended model gains, and which test would settle it.
//!
//! Pure functions over arrays, like [`crate::calibrate`]: [`diagnose`] takes [`Inputs`] (built from
//! a study by [`inputs_from_study`], or by hand) and returns a serialisable [`Diagnosis`] whose
//! contract keys (`discrepancy_detected`, `cause`, `candidates`, `extended`, `next_test`) go into
//! `results.json` under `diagnosis`.
//!
//! The steps:
//! 1. **Noise** ([`noise`]): per design from the replicates; absolute or relative, whichever makes
//!    the replicate scatter more likely. Without replicates σ is estimated from the residuals of the
//!    best-ranked model, and the output says so.
//! 2. **Residuals**: measured − prediction of the uncorrected model, calibrated by weighted least
//!    squares on the training designs, at every design; trends against each design variable and
//!    against the prediction (rank correlation, and a linear trend of the standardised residuals).
//! 3. **Candidates**: every shape `g` (study hypotheses, then built-ins) is fitted jointly with θ:
//!    `y = y(d, θ) + γ g(d, θ, y)`. A built-in with the same shape as a study hypothesis (|cos| >
//!    0.999 over the training designs) is dropped: the hypothesis carries the user's name. A shape
//!    proportional to ∂y/∂θ_j (|cos| > 0.99), or lying in the span of the sensitivities, is
//!    *confounded*: the data cannot tell it from a change of θ, and it is never named the cause.
//!    A model-extension hypothesis (solver studies) is a shape too: `g = y_ext(d, θ) − y(d, θ)` from
//!    the surrogates of its runs ([`inputs_with_extensions`]; γ = 1 is the extension as specified,
//!    see [`shapes`]); it is ranked and tested like any other candidate.
//! 4. **Ranking**: by `score = ½ (AICc + D_loo)`, where D_loo is the leave-one-design-out predictive
//!    deviance. Both estimate the same out-of-sample deviance (Stone 1977: LOO and AIC are
//!    asymptotically equivalent); with few designs each is noisy, so the two are averaged. Weights
//!    are `exp(−½ Δscore)`, normalised over the candidates and the uncorrected model.
//! 5. **Detection** (α = 0.01): a candidate *explains* the misfit when the extra-sum-of-squares
//!    F test of its amplitude, against the uncorrected model, has p < α/K (Bonferroni over the K
//!    candidates). With replicates the F test uses the replicate noise (F(1, ν)), and a pure-error
//!    lack-of-fit test of the uncorrected model (χ²/(n − p) against F(n − p, ν)) is run too.
//!    `discrepancy_detected` = the best non-confounded candidate explains the misfit, or the
//!    lack-of-fit test rejects; `cause` = that candidate only when it explains the misfit.
//!    Under no model error each test has false-alarm rate ≤ α, so together ≤ 2α.
//! 6. **Extension**: the cause's joint fit; validation error before/after = mean |relative error|
//!    over the validation designs (leave-one-design-out over the training designs when there are
//!    none); gain = 1 − after/before.
//! 7. **Next test**: the design in the design box (a grid, or a Latin hypercube above three
//!    variables) where the two leading explanations differ most in units of the noise σ there.

pub mod noise;
pub mod shapes;
pub mod stats;

mod fit;
mod text;

use indexmap::IndexMap;
use nalgebra::DVector;
use serde::{Deserialize, Serialize};

pub use noise::{NoiseKind, NoiseModel};
pub use shapes::{Origin, Shape};

use crate::calibrate::{Bounds, CalibrationError, Model};
use crate::study::Study;
use fit::Data;

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
    /// Design-variable values, in the order of [`Inputs::design_names`].
    pub design: Vec<f64>,
    pub role: Role,
    /// Mean of the replicates.
    pub mean: f64,
    /// Number of replicates.
    pub count: usize,
    /// Sample standard deviation of the replicates (`None` with one test).
    pub std_dev: Option<f64>,
}

impl Observation {
    pub fn from_replicates(name: impl Into<String>, design: Vec<f64>, role: Role, replicates: &[f64]) -> Self {
        let n = replicates.len();
        let mean = replicates.iter().sum::<f64>() / n as f64;
        let std_dev =
            (n > 1).then(|| (replicates.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt());
        Observation {
            name: name.into(),
            design,
            role,
            mean,
            count: n,
            std_dev,
        }
    }
}

/// Decision thresholds; the defaults are the documented rules.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// Family-wise false-alarm rate of each detection test.
    pub alpha: f64,
    /// |cos| between a shape and a parameter sensitivity above which they are confounded.
    pub confounding_cosine: f64,
    /// |cos| between a study hypothesis and a built-in above which they are the same shape.
    pub same_shape_cosine: f64,
    /// Grid points per design variable for the next-test search (up to three variables).
    pub grid_per_axis: usize,
    /// Latin-hypercube points for the next-test search above three design variables.
    pub search_points: usize,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            alpha: 0.01,
            confounding_cosine: 0.99,
            same_shape_cosine: 0.999,
            grid_per_axis: 21,
            search_points: 4000,
        }
    }
}

/// Everything the diagnosis needs.
pub struct Inputs<'a> {
    /// Every tested design with its role (training and validation).
    pub observations: Vec<Observation>,
    pub model: &'a dyn Model,
    pub parameter_names: Vec<String>,
    pub parameter_bounds: Bounds,
    pub design_names: Vec<String>,
    pub design_bounds: Bounds,
    /// The user's candidate causes (study hypotheses); the built-in shapes are added by [`diagnose`].
    pub hypotheses: Vec<Shape>,
    pub settings: Settings,
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
        .training
        .iter()
        .map(|n| (n, Role::Training))
        .chain(study.validation.iter().map(|n| (n, Role::Validation)))
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
        parameter_names: study.parameters.iter().map(|p| p.name.clone()).collect(),
        parameter_bounds: study.parameter_bounds(),
        design_names: study.design.iter().map(|d| d.name.clone()).collect(),
        design_bounds: study.design_bounds(),
        hypotheses: study
            .diagnosis
            .hypotheses
            .iter()
            .enumerate()
            .map(
                |(k, h)| match (h.extension(), extensions.iter().find(|(j, _)| *j == k)) {
                    (Some(variables), Some((_, ext))) => Shape::from_extension(h.name.clone(), variables, ext.clone()),
                    _ => Shape::from_hypothesis(h, study),
                },
            )
            .collect(),
        settings: Settings::default(),
    }
}

/// The diagnosis, as written under `diagnosis` in `results.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Diagnosis {
    /// Whether the data show model error beyond the noise.
    pub discrepancy_detected: bool,
    /// The named cause: the best-ranked, non-confounded candidate that explains the misfit.
    pub cause: Option<String>,
    /// Ranked best first: the study's hypotheses and the built-in shapes.
    pub candidates: Vec<Candidate>,
    /// The model extended with the cause (absent when there is none).
    pub extended: Option<Extended>,
    /// The test that would best tell the two leading explanations apart.
    pub next_test: Option<NextTest>,
    /// Plain-language summary generated from the numbers below.
    pub summary: String,
    pub noise: NoiseModel,
    /// The uncorrected model (least squares weighted by the noise, training designs).
    pub uncorrected: Uncorrected,
    /// The pure-error lack-of-fit test of the uncorrected model (needs replicates).
    pub lack_of_fit: Option<LackOfFit>,
    /// Residuals of the uncorrected model at every design.
    pub residuals: Vec<Residual>,
    /// Structure of the residuals against each design variable and the prediction.
    pub structure: Vec<Trend>,
    /// One sentence per confounded candidate.
    pub confounded: Vec<String>,
    /// The decision rule, in words.
    pub rule: String,
    /// Anything skipped or degenerate.
    pub notes: Vec<String>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    pub name: String,
    pub term: String,
    pub origin: Origin,
    /// The built-in shape this study hypothesis stands in for, if any.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub replaces: Option<String>,
    /// Mean |relative error| of the leave-one-design-out predictions over the training designs.
    pub loo_error: f64,
    pub bic: f64,
    pub aicc: f64,
    /// Leave-one-design-out predictive deviance (−2 log predictive likelihood, up to a constant).
    pub loo_deviance: f64,
    /// ½ (AICc + loo_deviance): the ranking key, smaller is better.
    pub score: f64,
    pub weight: f64,
    /// Fitted amplitude γ of the term.
    pub amplitude: f64,
    pub parameters: IndexMap<String, f64>,
    /// Σ w_i² r_i² of the joint fit (χ² when the noise is known).
    pub weighted_rss: f64,
    /// p-value of the amplitude (extra-sum-of-squares F test against the uncorrected model).
    pub p_value: f64,
    /// p < α / K.
    pub explains_misfit: bool,
    /// Parameters the shape cannot be told apart from (empty when none).
    pub confounded_with: Vec<String>,
    /// A model extension's template variables (absent for a term).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub extension: Option<IndexMap<String, f64>>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Uncorrected {
    pub parameters: IndexMap<String, f64>,
    /// The ranking metrics, as for a candidate (`null` when there were too few designs to rank).
    pub loo_error: Option<f64>,
    pub bic: Option<f64>,
    pub aicc: Option<f64>,
    pub loo_deviance: Option<f64>,
    pub score: Option<f64>,
    pub weight: Option<f64>,
    pub weighted_rss: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LackOfFit {
    pub chi2: f64,
    pub dof: usize,
    pub noise_dof: usize,
    pub p_value: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Extended {
    pub cause: String,
    pub term: String,
    pub amplitude: f64,
    pub parameters: IndexMap<String, f64>,
    /// Relative change of each parameter from the uncorrected calibration.
    pub parameter_change: IndexMap<String, f64>,
    pub validation_error_before: f64,
    pub validation_error_after: f64,
    /// 1 − after / before (`null` when before is 0).
    pub gain: Option<f64>,
    /// `validation` or `leave-one-out` (no validation designs).
    pub measured_on: String,
    /// When the cause is a model extension: its variables and what the amplitude means.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub extension: Option<ExtensionEffect>,
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
    pub design: IndexMap<String, f64>,
    pub why: String,
    /// The two explanations compared (the second may be `uncorrected`).
    pub between: [String; 2],
    pub predictions: [f64; 2],
    /// |difference| / σ of one test there.
    pub separation: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Residual {
    pub design: String,
    pub role: Role,
    pub values: IndexMap<String, f64>,
    pub measured: f64,
    pub count: usize,
    pub std_dev: Option<f64>,
    pub predicted: f64,
    /// measured − predicted.
    pub residual: f64,
    /// (predicted − measured) / measured, as in the contract.
    pub relative_error: f64,
    /// σ of the mean measurement.
    pub sigma: f64,
    /// residual / sigma.
    pub z: f64,
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

/// Metrics of one fitted model (candidate or uncorrected).
struct Scored {
    fit: fit::Fit,
    loo_error: f64,
    aicc: f64,
    bic: f64,
    loo_deviance: f64,
    score: f64,
}

const RULE: &str = "noise: absolute or relative by the replicate likelihood (from the residuals of the best model \
without replicates); ranking: score = (AICc + leave-one-design-out deviance)/2, weights exp(-score/2); a candidate \
explains the misfit when the F test of its amplitude against the uncorrected model has p < alpha/K (alpha = 0.01, \
K candidates); discrepancy detected when the best non-confounded candidate explains the misfit or the pure-error \
lack-of-fit test rejects at alpha; confounded candidates (shape proportional to a parameter sensitivity) are never \
named the cause";

/// Runs the diagnosis. Errors only when there are no training designs or the model cannot be
/// evaluated; too few designs to rank candidates give a diagnosis with a note instead.
pub fn diagnose(inputs: &Inputs) -> Result<Diagnosis, CalibrationError> {
    let s = &inputs.settings;
    let obs = &inputs.observations;
    let train: Vec<usize> = (0..obs.len()).filter(|&i| obs[i].role == Role::Training).collect();
    let val: Vec<usize> = (0..obs.len()).filter(|&i| obs[i].role == Role::Validation).collect();
    let p = inputs.parameter_names.len();
    let n = train.len();
    if n == 0 {
        return Err(CalibrationError::TooFewDesigns {
            method: "diagnosis",
            needed: 1,
            given: 0,
        });
    }
    let mut notes = Vec::new();

    // 1. Noise and weights. Without replicates the weights are √n_i and σ is found later.
    let replicate_noise = noise::from_replicates(obs);
    let weights: Vec<f64> = obs
        .iter()
        .map(|o| {
            let sqrt_n = (o.count.max(1) as f64).sqrt();
            match &replicate_noise {
                Some(nm) => sqrt_n / nm.sigma_at(o.mean).max(f64::MIN_POSITIVE),
                None => sqrt_n,
            }
        })
        .collect();
    let data = Data {
        model: inputs.model,
        bounds: &inputs.parameter_bounds,
        designs: obs.iter().map(|o| o.design.clone()).collect(),
        means: obs.iter().map(|o| o.mean).collect(),
        weights,
    };
    let known = replicate_noise.is_some();
    let nu = replicate_noise.as_ref().map_or(0, |nm| nm.dof) as f64;
    // Weighted RSS below this counts as zero (floating-point-exact data).
    let rss_floor = {
        let ms = train
            .iter()
            .map(|&i| (data.weights[i] * data.means[i]).powi(2))
            .sum::<f64>()
            / n as f64;
        (1e-12_f64).powi(2) * ms * n as f64
    };

    // 2. The uncorrected model.
    let fit0 = data.fit(None, &train)?;
    let names = &inputs.parameter_names;
    let param_map =
        |theta: &DVector<f64>| -> IndexMap<String, f64> { names.iter().cloned().zip(theta.iter().copied()).collect() };

    // 3. Candidate shapes: study hypotheses first, then built-ins not duplicated by one.
    let sens = data.sensitivities(&fit0.theta, &train);
    let mut shapes: Vec<(Shape, Option<String>, Vec<f64>)> = Vec::new();
    for shape in inputs
        .hypotheses
        .iter()
        .cloned()
        .chain(Shape::built_ins(&inputs.design_names))
    {
        let v = data.shape_vector(&shape, &fit0.theta, &train);
        if v.iter().any(|x| !x.is_finite()) {
            notes.push(format!(
                "candidate '{}' ({}) is not finite at every training design: skipped",
                shape.name, shape.term
            ));
            continue;
        }
        if v.iter().all(|&x| x == 0.0) {
            notes.push(format!(
                "candidate '{}' ({}) vanishes at every training design: skipped",
                shape.name, shape.term
            ));
            continue;
        }
        if shape.origin == Origin::BuiltIn
            && let Some(k) = shapes
                .iter()
                .position(|(h, _, hv)| h.origin == Origin::Study && stats::cosine(hv, &v).abs() > s.same_shape_cosine)
        {
            if shapes[k].1.is_none() {
                shapes[k].1 = Some(shape.name.clone());
            }
            continue;
        }
        shapes.push((shape, None, v));
    }

    let k_extra = if known { 0 } else { 1 }; // σ is a fitted number without replicates
    let min_n = p + 3 + k_extra;
    if n < min_n || shapes.is_empty() {
        if n < min_n {
            notes.push(format!(
                "{n} training designs cannot rank candidate causes: a joint fit of {p} parameter(s) and an amplitude \
                 needs at least {min_n} (leave-one-design-out and AICc need spare designs)"
            ));
        }
        return Ok(unranked(
            inputs,
            &data,
            &fit0,
            replicate_noise,
            &train,
            notes,
            rss_floor,
        ));
    }

    // 4. Fit and score every model.
    let score_model = |shape: Option<&Shape>| -> Result<Scored, CalibrationError> {
        let fit = data.fit(shape, &train)?;
        let loo = data.leave_one_out(shape, &train)?;
        let k = (p + usize::from(shape.is_some()) + k_extra) as f64;
        let nf = n as f64;
        let press: f64 = train
            .iter()
            .zip(&loo)
            .map(|(&i, yh)| (data.weights[i] * (data.means[i] - yh)).powi(2))
            .sum();
        let (m2ll, dloo) = if known {
            (fit.wrss, press)
        } else {
            let dev = |rss: f64| nf * (2.0 * std::f64::consts::PI * rss.max(rss_floor) / nf).ln() + nf;
            (dev(fit.wrss), dev(press))
        };
        let aicc = m2ll + 2.0 * k + 2.0 * k * (k + 1.0) / (nf - k - 1.0);
        let bic = m2ll + k * nf.ln();
        let loo_error = mean_abs_rel(train.iter().zip(&loo).map(|(&i, &yh)| (yh, data.means[i])));
        Ok(Scored {
            fit,
            loo_error,
            aicc,
            bic,
            loo_deviance: dloo,
            score: 0.5 * (aicc + dloo),
        })
    };
    let base = score_model(None)?;
    let mut scored = Vec::new();
    for (shape, replaces, v) in shapes {
        match score_model(Some(&shape)) {
            Ok(sc) => scored.push((shape, replaces, v, sc)),
            Err(e) => notes.push(format!("candidate '{}' could not be fitted: {e}", shape.name)),
        }
    }
    if scored.is_empty() {
        return Ok(unranked(
            inputs,
            &data,
            &fit0,
            replicate_noise,
            &train,
            notes,
            rss_floor,
        ));
    }
    let best_score = scored.iter().map(|c| c.3.score).fold(base.score, f64::min);
    let total: f64 = scored
        .iter()
        .map(|c| (-0.5 * (c.3.score - best_score)).exp())
        .sum::<f64>()
        + (-0.5 * (base.score - best_score)).exp();
    let weight = |score: f64| (-0.5 * (score - best_score)).exp() / total;
    scored.sort_by(|a, b| a.3.score.total_cmp(&b.3.score));

    // The noise, final: without replicates, from the residuals of the best-ranked model.
    let noise_model = match replicate_noise {
        Some(nm) => nm,
        None => {
            let (rss, k, who) = if base.score <= scored[0].3.score {
                (base.fit.wrss, p, "the uncorrected model".to_string())
            } else {
                (scored[0].3.fit.wrss, p + 1, format!("'{}'", scored[0].0.name))
            };
            let dof = n.saturating_sub(k).max(1);
            let exact = rss <= rss_floor;
            let sigma = (rss.max(rss_floor) / dof as f64).sqrt();
            let note = if exact {
                format!(
                    "no replicates: σ estimated from the residuals of {who}, which are at floating-point level \
                     (the tests look noise-free); σ floored at {sigma:.3e}"
                )
            } else {
                format!(
                    "no replicates: σ = {} estimated from the residuals of {who} ({dof} degrees of freedom)",
                    text::num(sigma)
                )
            };
            NoiseModel {
                kind: NoiseKind::FromResiduals,
                scale: sigma,
                dof,
                loglik_absolute: None,
                loglik_relative: None,
                note,
            }
        }
    };

    // 5. Detection.
    let kc = scored.len() as f64;
    let p_value = |sc: &Scored| -> f64 {
        let drop = (base.fit.wrss - sc.fit.wrss).max(0.0);
        if known {
            stats::f_sf(drop, 1.0, nu)
        } else {
            let df2 = (n - p - 1) as f64;
            if drop <= 0.0 {
                1.0
            } else {
                stats::f_sf(drop / (sc.fit.wrss.max(rss_floor) / df2), 1.0, df2)
            }
        }
    };
    let lack_of_fit = known.then(|| {
        let dof = n - p;
        LackOfFit {
            chi2: base.fit.wrss,
            dof,
            noise_dof: nu as usize,
            p_value: stats::f_sf(base.fit.wrss / dof as f64, dof as f64, nu),
        }
    });

    let mut candidates = Vec::new();
    let mut confounded_notes = Vec::new();
    let mut shapes_ranked = Vec::new();
    for (shape, replaces, v, sc) in scored {
        let mut with: Vec<String> = sens
            .iter()
            .enumerate()
            .filter(|(_, sj)| stats::cosine(&v, sj).abs() > s.confounding_cosine)
            .map(|(j, _)| names[j].clone())
            .collect();
        if with.is_empty() && p > 1 && span_fraction(&v, &sens) > s.confounding_cosine.powi(2) {
            with.push(format!("a combination of {}", names.join(", ")));
        }
        if !with.is_empty() {
            confounded_notes.push(format!(
                "'{}' ({}) has the shape of the prediction's sensitivity to {}: the data cannot tell it apart from a \
                 change of {}, so it is not named as a cause",
                shape.name,
                shape.term,
                with.join(" and "),
                with.join(" and ")
            ));
        }
        let pv = p_value(&sc);
        candidates.push(Candidate {
            name: shape.name.clone(),
            term: shape.term.clone(),
            origin: shape.origin,
            replaces,
            loo_error: sc.loo_error,
            bic: sc.bic,
            aicc: sc.aicc,
            loo_deviance: sc.loo_deviance,
            score: sc.score,
            weight: weight(sc.score),
            amplitude: sc.fit.gamma,
            parameters: param_map(&sc.fit.theta),
            weighted_rss: sc.fit.wrss,
            p_value: pv,
            explains_misfit: pv * kc < s.alpha,
            confounded_with: with,
            extension: shape.extension.as_ref().map(|v| v.iter().cloned().collect()),
        });
        shapes_ranked.push((shape, sc));
    }
    let uncorrected = Uncorrected {
        parameters: param_map(&base.fit.theta),
        loo_error: Some(base.loo_error),
        bic: Some(base.bic),
        aicc: Some(base.aicc),
        loo_deviance: Some(base.loo_deviance),
        score: Some(base.score),
        weight: Some(weight(base.score)),
        weighted_rss: base.fit.wrss,
    };
    let leader = candidates.iter().position(|c| c.confounded_with.is_empty());
    let cause_idx = leader.filter(|&k| candidates[k].explains_misfit);
    let misfit = lack_of_fit.as_ref().is_some_and(|l| l.p_value < s.alpha);
    let detected = cause_idx.is_some() || misfit;

    // 6. Residuals of the uncorrected model, and their structure.
    let sigma_of_one = |level: f64| noise_model.sigma_at(level).max(f64::MIN_POSITIVE);
    let residuals = residual_table(inputs, &data, &base.fit, &sigma_of_one);
    let structure = trends(inputs, &residuals, known, s.alpha);

    // 7. Extension.
    let extended = cause_idx.map(|k| {
        let (shape, sc) = &shapes_ranked[k];
        let (before, after, on) = if val.is_empty() {
            (base.loo_error, sc.loo_error, "leave-one-out")
        } else {
            let err = |sh: Option<&Shape>, f: &fit::Fit| {
                mean_abs_rel(val.iter().map(|&i| {
                    (
                        data.predict(sh, f.theta.as_slice(), f.gamma, &data.designs[i]),
                        data.means[i],
                    )
                }))
            };
            (err(None, &base.fit), err(Some(shape), &sc.fit), "validation")
        };
        Extended {
            cause: shape.name.clone(),
            term: shape.term.clone(),
            amplitude: sc.fit.gamma,
            parameters: param_map(&sc.fit.theta),
            parameter_change: names
                .iter()
                .enumerate()
                .map(|(j, nm)| (nm.clone(), sc.fit.theta[j] / base.fit.theta[j] - 1.0))
                .collect(),
            validation_error_before: before,
            validation_error_after: after,
            gain: (before > 0.0).then(|| 1.0 - after / before),
            measured_on: on.to_string(),
            extension: shape.amplitude_meaning(sc.fit.gamma).map(|meaning| ExtensionEffect {
                variables: shape.extension.iter().flatten().cloned().collect(),
                amplitude: sc.fit.gamma,
                meaning,
            }),
        }
    });

    // 8. Next test: the two leading non-confounded explanations, or the leader against no correction.
    let plausible: Vec<usize> = (0..candidates.len())
        .filter(|&k| candidates[k].confounded_with.is_empty())
        .collect();
    let next_test = match (plausible.first(), plausible.get(1)) {
        (Some(&a), Some(&b)) if detected => {
            let (sa, fa) = (&shapes_ranked[a].0, &shapes_ranked[a].1.fit);
            let (sb, fb) = (&shapes_ranked[b].0, &shapes_ranked[b].1.fit);
            next_test(
                inputs,
                &data,
                (&sa.name, Some(sa), fa),
                (&sb.name, Some(sb), fb),
                &sigma_of_one,
            )
        }
        (Some(&a), _) => {
            let (sa, fa) = (&shapes_ranked[a].0, &shapes_ranked[a].1.fit);
            next_test(
                inputs,
                &data,
                (&sa.name, Some(sa), fa),
                ("uncorrected", None, &base.fit),
                &sigma_of_one,
            )
        }
        _ => None,
    };

    let summary = text::summary(&text::Facts {
        inputs,
        residuals: &residuals,
        structure: &structure,
        noise: &noise_model,
        lack_of_fit: lack_of_fit.as_ref(),
        candidates: &candidates,
        leader,
        cause: cause_idx.map(|k| candidates[k].name.as_str()),
        detected,
        extended: extended.as_ref(),
        confounded: &confounded_notes,
    });
    Ok(Diagnosis {
        discrepancy_detected: detected,
        cause: cause_idx.map(|k| candidates[k].name.clone()),
        candidates,
        extended,
        next_test,
        summary,
        noise: noise_model,
        uncorrected,
        lack_of_fit,
        residuals,
        structure,
        confounded: confounded_notes,
        rule: RULE.to_string(),
        notes,
    })
}

/// A diagnosis with residuals but no ranking (too few designs, or no usable candidate).
fn unranked(
    inputs: &Inputs,
    data: &Data,
    fit0: &fit::Fit,
    replicate_noise: Option<NoiseModel>,
    train: &[usize],
    notes: Vec<String>,
    rss_floor: f64,
) -> Diagnosis {
    let p = inputs.parameter_names.len();
    let n = train.len();
    let lack_of_fit = replicate_noise.as_ref().filter(|_| n > p).map(|nm| {
        let dof = n - p;
        LackOfFit {
            chi2: fit0.wrss,
            dof,
            noise_dof: nm.dof,
            p_value: stats::f_sf(fit0.wrss / dof as f64, dof as f64, nm.dof as f64),
        }
    });
    let noise_model = replicate_noise.unwrap_or_else(|| {
        let dof = n.saturating_sub(p);
        let sigma = if dof > 0 {
            (fit0.wrss.max(rss_floor) / dof as f64).sqrt()
        } else {
            f64::NAN
        };
        NoiseModel {
            kind: NoiseKind::FromResiduals,
            scale: if sigma.is_finite() { sigma } else { 0.0 },
            dof,
            loglik_absolute: None,
            loglik_relative: None,
            note: if dof > 0 {
                format!(
                    "no replicates: σ = {} estimated from the residuals of the uncorrected model",
                    text::num(sigma)
                )
            } else {
                "no replicates and no spare designs: the noise cannot be estimated".to_string()
            },
        }
    });
    let detected = lack_of_fit.as_ref().is_some_and(|l| l.p_value < inputs.settings.alpha);
    let known = noise_model.from_replicates();
    let sigma_of_one = |level: f64| noise_model.sigma_at(level).max(f64::MIN_POSITIVE);
    let residuals = residual_table(inputs, data, fit0, &sigma_of_one);
    let structure = trends(inputs, &residuals, known, inputs.settings.alpha);
    let names = &inputs.parameter_names;
    let summary = text::summary(&text::Facts {
        inputs,
        residuals: &residuals,
        structure: &structure,
        noise: &noise_model,
        lack_of_fit: lack_of_fit.as_ref(),
        candidates: &[],
        leader: None,
        cause: None,
        detected,
        extended: None,
        confounded: &[],
    });
    let summary = if notes.is_empty() {
        summary
    } else {
        format!("{summary} {}", notes.join("; "))
    };
    Diagnosis {
        discrepancy_detected: detected,
        cause: None,
        candidates: Vec::new(),
        extended: None,
        next_test: None,
        summary,
        noise: noise_model,
        uncorrected: Uncorrected {
            parameters: names.iter().cloned().zip(fit0.theta.iter().copied()).collect(),
            loo_error: None,
            bic: None,
            aicc: None,
            loo_deviance: None,
            score: None,
            weight: None,
            weighted_rss: fit0.wrss,
        },
        lack_of_fit,
        residuals,
        structure,
        confounded: Vec::new(),
        rule: RULE.to_string(),
        notes,
    }
}

/// Mean |(predicted − measured) / measured| over (predicted, measured) pairs.
fn mean_abs_rel(pairs: impl Iterator<Item = (f64, f64)>) -> f64 {
    let (sum, count) = pairs.fold((0.0, 0usize), |(s, c), (yh, y)| (s + ((yh - y) / y).abs(), c + 1));
    if count == 0 { f64::NAN } else { sum / count as f64 }
}

/// Fraction of ‖v‖² that lies in the span of the sensitivity vectors (least-squares projection).
fn span_fraction(v: &[f64], sens: &[Vec<f64>]) -> f64 {
    let rows = v.len();
    let j = nalgebra::DMatrix::from_fn(rows, sens.len(), |i, k| sens[k][i]);
    let y = DVector::from_column_slice(v);
    let svd = j.clone().svd(true, true);
    let Ok(coef) = svd.solve(&y, 1e-12 * svd.singular_values.max().max(f64::MIN_POSITIVE)) else {
        return 0.0;
    };
    let proj = j * coef;
    let vv = y.norm_squared();
    if vv == 0.0 { 0.0 } else { proj.norm_squared() / vv }
}

fn residual_table(inputs: &Inputs, data: &Data, fit: &fit::Fit, sigma_of_one: &dyn Fn(f64) -> f64) -> Vec<Residual> {
    inputs
        .observations
        .iter()
        .map(|o| {
            let predicted = data.predict(None, fit.theta.as_slice(), 0.0, &o.design);
            let residual = o.mean - predicted;
            let sigma = sigma_of_one(o.mean) / (o.count.max(1) as f64).sqrt();
            Residual {
                design: o.name.clone(),
                role: o.role,
                values: inputs
                    .design_names
                    .iter()
                    .cloned()
                    .zip(o.design.iter().copied())
                    .collect(),
                measured: o.mean,
                count: o.count,
                std_dev: o.std_dev,
                predicted,
                residual,
                relative_error: (predicted - o.mean) / o.mean,
                sigma,
                z: residual / sigma,
            }
        })
        .collect()
}

/// Rank correlation and linear trend of the standardised residuals against each design variable
/// and the prediction. With replicate noise the residuals have unit variance under no model error,
/// so the slope's standard error is 1/√Sxx (normal test); without, the scatter about the trend line
/// gives it (t test, n − 2 degrees of freedom).
fn trends(inputs: &Inputs, residuals: &[Residual], known: bool, alpha: f64) -> Vec<Trend> {
    let z: Vec<f64> = residuals.iter().map(|r| r.z).collect();
    let mut against: Vec<(String, Vec<f64>)> = inputs
        .design_names
        .iter()
        .enumerate()
        .map(|(j, name)| (name.clone(), inputs.observations.iter().map(|o| o.design[j]).collect()))
        .collect();
    against.push((
        "prediction".to_string(),
        residuals.iter().map(|r| r.predicted).collect(),
    ));
    let n = z.len();
    against
        .into_iter()
        .filter(|(_, x)| n >= 3 && x.iter().any(|&v| v != x[0]))
        .map(|(name, x)| {
            let (rho, rho_p) = stats::spearman(&x, &z);
            let nf = n as f64;
            let (mx, mz) = (x.iter().sum::<f64>() / nf, z.iter().sum::<f64>() / nf);
            let sxx: f64 = x.iter().map(|v| (v - mx).powi(2)).sum();
            let slope = x.iter().zip(&z).map(|(a, b)| (a - mx) * (b - mz)).sum::<f64>() / sxx;
            let slope_p = if known {
                stats::normal_two_sided(slope * sxx.sqrt())
            } else {
                let ss: f64 = x.iter().zip(&z).map(|(a, b)| (b - mz - slope * (a - mx)).powi(2)).sum();
                let se = (ss / (nf - 2.0) / sxx).sqrt();
                if se > 0.0 {
                    stats::t_two_sided(slope / se, nf - 2.0)
                } else {
                    0.0
                }
            };
            Trend {
                against: name,
                rank_correlation: rho,
                rank_p_value: rho_p,
                slope,
                slope_p_value: slope_p,
                significant: rho_p < alpha || slope_p < alpha,
            }
        })
        .collect()
}

type Explanation<'s> = (&'s str, Option<&'s Shape>, &'s fit::Fit);

/// Where in the design box two explanations differ most, in units of one test's σ there.
fn next_test(
    inputs: &Inputs,
    data: &Data,
    a: Explanation,
    b: Explanation,
    sigma_of_one: &dyn Fn(f64) -> f64,
) -> Option<NextTest> {
    let bounds = &inputs.design_bounds;
    let dim = bounds.dim();
    if dim == 0 {
        return None;
    }
    let points: Vec<Vec<f64>> = if dim <= 3 {
        let m = inputs.settings.grid_per_axis.max(2);
        let total = m.pow(dim as u32);
        (0..total)
            .map(|mut k| {
                (0..dim)
                    .map(|j| {
                        let t = (k % m) as f64 / (m - 1) as f64;
                        k /= m;
                        bounds.lower[j] + t * (bounds.upper[j] - bounds.lower[j])
                    })
                    .collect()
            })
            .collect()
    } else {
        let plan = crate::plan::latin_hypercube(inputs.settings.search_points, dim, 0);
        plan.row_iter()
            .map(|r| bounds.from_unit(&r.transpose()).iter().copied().collect())
            .collect()
    };
    let mut best: Option<(f64, Vec<f64>, f64, f64)> = None;
    for d in points {
        let ya = data.predict(a.1, a.2.theta.as_slice(), a.2.gamma, &d);
        let yb = data.predict(b.1, b.2.theta.as_slice(), b.2.gamma, &d);
        let sep = (ya - yb).abs() / sigma_of_one(0.5 * (ya + yb));
        if sep.is_finite() && best.as_ref().is_none_or(|x| sep > x.0) {
            best = Some((sep, d, ya, yb));
        }
    }
    let (sep, d, ya, yb) = best?;
    let at = inputs
        .design_names
        .iter()
        .zip(&d)
        .map(|(n, v)| format!("{n} = {}", text::num(*v)))
        .collect::<Vec<_>>()
        .join(", ");
    let rel = (ya - yb).abs() / (0.5 * (ya.abs() + yb.abs())).max(f64::MIN_POSITIVE);
    let who = if b.1.is_none() {
        format!("'{}' and the uncorrected simulation", a.0)
    } else {
        format!("the two leading explanations, '{}' and '{}',", a.0, b.0)
    };
    let why = format!(
        "At {at} {who} predict {} and {} ({} apart, {} noise standard deviations of one test): the largest separation \
         inside the design bounds, so a test there tells them apart.",
        text::num(ya),
        text::num(yb),
        text::pct_pub(rel),
        text::num(sep)
    );
    Some(NextTest {
        design: inputs.design_names.iter().cloned().zip(d).collect(),
        why,
        between: [a.0.to_string(), b.0.to_string()],
        predictions: [ya, yb],
        separation: sep,
    })
}
