//! Step 3: the evidence for each fitted model, from the likelihood and the joint fit's covariance.
//!
//! - **Does the shape beat a refit of θ alone?** The extra-sum-of-squares (likelihood-ratio) F
//!   test of γ: `F = (RSS_θ − RSS_θ,γ) / s²` on (1, ν) degrees of freedom, s² from the replicates
//!   (ν = Σ(n_i − 1)) or from the joint fit's residuals (ν = n − p − 1) (Bates & Watts 1988, §3.5).
//!   This is the whole of "can the data tell this shape from a change of θ": a shape nearly in the
//!   span of the sensitivities has a small orthogonal part, and the test sees exactly that part
//!   against the noise. No angle overrules it.
//! - **The covariance of (θ, γ)**, s² (AᵀA)⁻¹: the standard error and 95 % interval of γ, its
//!   correlation with each θ_j, and its variance inflation 1/(1 − R²) by θ. These describe *why* a
//!   shape is or is not separated; a shape not separated and inflated ≥ 10 × is reported as absorbed
//!   by θ, with the shift of θ it would cause at the edge of its interval (what an independent
//!   measurement of θ would have to resolve).
//! - **The predictive check at the validation designs**: z_i = (ȳ_i − ŷ_i) / √(σ_i²/n_i + g_iᵀ C g_i),
//!   with g_i = ∂ŷ_i/∂(θ, γ): the noise of the test plus the uncertainty of the calibrated prediction.
//! - **Lack of fit against the replicate noise**: (RSS_train + Σ z_val²) / dof against F(dof, ν),
//!   dof = n_train − k + n_val (the pure-error test of Draper & Smith 1998, §2.1, with the
//!   validation designs as predictive residuals).

use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

use super::candidates::Model;
use super::fit::Covariance;
use super::{Candidate, Context, LackOfFit, stats};
use crate::base::format::num;

/// The joint fit's figures for γ.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Separability {
    pub amplitude_se: Option<f64>,
    pub amplitude_ci95: Option<[f64; 2]>,
    /// corr(γ, θ_j) in the joint fit.
    pub correlation: IndexMap<String, f64>,
    /// 1 / (1 − R²) of the shape regressed on the sensitivities to θ; `null` when numerically
    /// infinite (the shape is a change of θ over these designs).
    pub variance_inflation: Option<f64>,
    /// The shift of each θ_j that ignoring the shape at the edge of its 95 % interval would cause.
    pub parameter_shift: IndexMap<String, f64>,
}

/// A predictive check at the validation designs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Check {
    pub chi2: f64,
    pub dof: usize,
    pub p_value: Option<f64>,
    /// Predictive z per validation design.
    pub z: IndexMap<String, f64>,
    /// Mean |relative error| at the validation designs.
    pub error: f64,
    /// Σ [z² + ln(v_i / σ_i²)]: the predictive deviance, relative to the noise alone.
    pub deviance: f64,
}

/// The evidence for one model.
pub(crate) struct Assessed {
    /// σ² scale of the weights: 1 with replicate noise, the residual variance without.
    pub s2: Option<f64>,
    pub cov: Option<Covariance>,
    /// The shape is numerically in the span of the sensitivities to θ.
    pub collinear: bool,
    /// Against the uncorrected model (candidates only).
    pub p_value: Option<f64>,
    pub validation: Option<Check>,
    pub lack_of_fit: Option<LackOfFit>,
    pub separability: Separability,
}

/// The evidence for the uncorrected model and for every candidate (same order as `fitted`).
pub(crate) fn assess(cx: &Context, base: &Model, fitted: &[Model]) -> (Assessed, Vec<Assessed>) {
    (
        assess_one(cx, base, None),
        fitted.iter().map(|m| assess_one(cx, m, Some(base))).collect(),
    )
}

/// The evidence for `m`; its amplitude test is against `base` (the drop in RSS on the numbers `m`
/// fits beyond `base`'s: one for a candidate against the uncorrected model).
pub(crate) fn assess_one(cx: &Context, m: &Model, base: Option<&Model>) -> Assessed {
    let n = cx.train.len();
    let dof = n.saturating_sub(m.k());
    // Without replicates and spare designs the residuals measure nothing: no noise, no covariance.
    let s2 = if cx.known() {
        Some(1.0)
    } else {
        (dof > 0 && cx.mode != super::Mode::TooFew).then(|| m.fit.wrss.max(cx.rss_floor) / dof as f64)
    };
    let shapes = m.shapes();
    let cov = s2.and_then(|s2| cx.data.covariance(&shapes, &m.fit, &cx.train, s2));
    let collinear = m.shape.is_some() && cov.is_none() && s2.is_some();
    let p_value = base.filter(|_| cx.mode != super::Mode::TooFew).and_then(|b| {
        if collinear {
            // No part of the shape lies outside the sensitivities: the drop in RSS is round-off.
            return Some(1.0);
        }
        let extra = m.k().saturating_sub(b.k()).max(1);
        cx.drop_test(b.fit.wrss - m.fit.wrss, extra, m.fit.wrss, n.saturating_sub(m.k()))
    });
    let validation = s2.and_then(|s2| check(cx, m, cov.as_ref(), s2, dof));
    let lack_of_fit = cx.known().then(|| lack_of_fit(cx, m, validation.as_ref())).flatten();
    let separability = match (&m.shape, &cov) {
        (Some(_), Some(c)) => separability(cx, m, c, dof),
        _ => Separability::default(),
    };
    Assessed {
        s2,
        cov,
        collinear,
        p_value,
        validation,
        lack_of_fit,
        separability,
    }
}

/// The predictive check of `m` at the validation designs.
fn check(cx: &Context, m: &Model, cov: Option<&Covariance>, s2: f64, dof: usize) -> Option<Check> {
    if cx.val.is_empty() {
        return None;
    }
    let shapes = m.shapes();
    let (mut chi2, mut deviance) = (0.0, 0.0);
    let mut z = IndexMap::new();
    for &i in &cx.val {
        let d = &cx.data.designs[i];
        let yh = m.predict(cx, d);
        let noise = s2 / cx.data.weights[i].powi(2);
        let spread = cov.map_or(0.0, |c| {
            let g = cx.data.gradient(&shapes, &m.fit, d);
            (g.transpose() * &c.matrix * &g)[(0, 0)].max(0.0)
        });
        let zi = (cx.data.means[i] - yh) / (noise + spread).sqrt();
        chi2 += zi * zi;
        deviance += zi * zi + ((noise + spread) / noise).ln();
        z.insert(cx.inputs.observations[i].name.clone(), zi);
    }
    let nv = cx.val.len();
    let noise_dof = if cx.known() { cx.nu } else { dof };
    let p_value = (noise_dof > 0).then(|| stats::f_sf(chi2 / nv as f64, nv as f64, noise_dof as f64));
    let error = cx.mean_abs_rel(cx.val.iter().map(|&i| (i, m.predict(cx, &cx.data.designs[i]))));
    Some(Check {
        chi2,
        dof: nv,
        p_value,
        z,
        error,
        deviance,
    })
}

/// The model against the replicate noise, both ways ([`super::lack_of_fit`]): (RSS_train + Σ z_val²)
/// / dof against F(dof, ν), and the largest standardised residual.
fn lack_of_fit(cx: &Context, m: &Model, validation: Option<&Check>) -> Option<LackOfFit> {
    let dof = cx.train.len().saturating_sub(m.k()) + validation.map_or(0, |v| v.dof);
    let chi2 = m.fit.wrss + validation.map_or(0.0, |v| v.chi2);
    let z: Vec<(String, f64)> = standardised(cx, m, 1.0, validation).into_iter().collect();
    // The base model's fit detects model error (its share of α split over the two tests); any
    // other model's fit is a claim about a cause: each test at α, the stricter side.
    let base = m.shape.is_none() && m.more.is_empty();
    let level = if base { cx.levels().base_fit() } else { cx.alpha() };
    (dof > 0).then(|| LackOfFit::new(chi2, dof, cx.nu, &z, level))
}

/// The model's residuals in units of their own standard error: a training residual w_i (ȳ_i − ŷ_i)
/// divided by √(s² (1 − h_ii)), h_ii its leverage in the fit (a design the fit passes through
/// exactly carries none and is left out); a validation design by its predictive z.
pub(crate) fn standardised(cx: &Context, m: &Model, s2: f64, validation: Option<&Check>) -> IndexMap<String, f64> {
    let shapes = m.shapes();
    let h = super::lack_of_fit::leverages(&cx.data.jacobian(&shapes, &m.fit, &cx.train));
    let mut z: IndexMap<String, f64> = cx
        .train
        .iter()
        .zip(h)
        .filter(|(_, h)| 1.0 - h > 1e-9)
        .map(|(&i, h)| {
            let r = cx.data.weights[i] * (cx.data.means[i] - m.predict(cx, &cx.data.designs[i]));
            (cx.inputs.observations[i].name.clone(), r / (s2 * (1.0 - h)).sqrt())
        })
        .collect();
    if let Some(v) = validation {
        z.extend(v.z.iter().map(|(n, z)| (n.clone(), *z)));
    }
    z
}

fn separability(cx: &Context, m: &Model, c: &Covariance, dof: usize) -> Separability {
    let p = cx.p();
    let var = c.matrix[(p, p)];
    let se = var.sqrt();
    let gamma = m.fit.amplitude();
    let q = stats::t_quantile(0.975, if cx.known() { cx.nu } else { dof } as f64);
    let ci = [gamma - q * se, gamma + q * se];
    let edge = if ci[0].abs() > ci[1].abs() { ci[0] } else { ci[1] };
    let names = &cx.inputs.space.parameter_names;
    Separability {
        amplitude_se: Some(se),
        amplitude_ci95: Some(ci),
        correlation: names
            .iter()
            .enumerate()
            .map(|(j, nm)| (nm.clone(), c.matrix[(j, p)] / (c.matrix[(j, j)] * var).sqrt()))
            .collect(),
        variance_inflation: Some(c.inflation[0]),
        parameter_shift: names
            .iter()
            .enumerate()
            .map(|(j, nm)| (nm.clone(), c.matrix[(j, p)] / var * edge))
            .collect(),
    }
}

/// The parameters the data cannot tell `m`'s shape apart from: only when its test is not
/// significant, and its variance is inflated ≥ `absorbed_inflation` × by θ (or infinitely).
pub(crate) fn absorbed_by(cx: &Context, m: &Model, a: &Assessed, explains: bool) -> Vec<String> {
    let limit = cx.inputs.settings.absorbed_inflation;
    let names = &cx.inputs.space.parameter_names;
    if explains || m.shape.is_none() {
        return Vec::new();
    }
    if a.collinear {
        return collinear_with(cx, m);
    }
    if a.separability.variance_inflation.is_none_or(|v| v < limit) {
        return Vec::new();
    }
    let r_min = (1.0 - 1.0 / limit).sqrt();
    let single: Vec<String> = a
        .separability
        .correlation
        .iter()
        .filter(|(_, r)| r.abs() >= r_min)
        .map(|(n, _)| n.clone())
        .collect();
    or_combination(single, names)
}

/// The single parameters found, or else their combination.
fn or_combination(single: Vec<String>, names: &[String]) -> Vec<String> {
    if single.is_empty() {
        vec![format!("a combination of {}", names.join(", "))]
    } else {
        single
    }
}

/// For a shape numerically in the span of the sensitivities: the single parameters whose
/// sensitivity it is proportional to, or their combination.
fn collinear_with(cx: &Context, m: &Model) -> Vec<String> {
    let shapes = m.shapes();
    let a = cx.data.jacobian(&shapes, &m.fit, &cx.train);
    let p = cx.p();
    let g: Vec<f64> = a.column(p).iter().copied().collect();
    let names = &cx.inputs.space.parameter_names;
    let single: Vec<String> = (0..p)
        .filter(|&j| {
            let col: Vec<f64> = a.column(j).iter().copied().collect();
            stats::cosine(&g, &col).abs() > 1.0 - 1e-10
        })
        .map(|j| names[j].clone())
        .collect();
    or_combination(single, names)
}

/// One sentence per candidate the data cannot tell from a change of θ.
pub(crate) fn absorbed_sentences(candidates: &[Candidate]) -> Vec<String> {
    candidates
        .iter()
        .filter(|c| !c.checks.confounded_with.is_empty())
        .map(|c| {
            let with = c.checks.confounded_with.join(" and ");
            let shift = c
                .checks.separability
                .parameter_shift
                .iter()
                .filter(|(n, _)| c.checks.confounded_with.contains(n))
                .map(|(n, v)| {
                    let own = c.fit.parameters.get(n).copied().unwrap_or(f64::INFINITY).abs();
                    if v.abs() > own {
                        format!("{n} by more than its own value")
                    } else {
                        format!("{n} by up to {}", num(v.abs()))
                    }
                })
                .collect::<Vec<_>>();
            let extent = if shift.is_empty() {
                String::new()
            } else {
                format!(" (present at the edge of its 95 % interval, it would shift {})", shift.join(", "))
            };
            format!(
                "'{}' ({}) cannot be told from a change of {with} with these tests: a refit of {with} absorbs it{extent}; \
                 an independent measurement of {with}, or tests where the shapes part, would separate them",
                c.shape.name, c.shape.term
            )
        })
        .collect()
}
