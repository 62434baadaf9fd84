//! What "no model error" leaves open: for each listed hypothesis, the range of its amplitude the
//! tests do not exclude, the calibrated parameters over that range, and the smallest effect they
//! could have detected.
//!
//! From each candidate's joint fit of θ and its amplitude γ (the screening's, [`super::evidence`]):
//!
//! - **not excluded**: γ̂ ± t(1 − α/2, ν)·SE(γ), the amplitudes a test at α would not reject;
//! - **the parameters over it**: the joint fit's regression of θ on γ, θ(γ) = θ̂ + Cov(θ, γ)/Var(γ)·(γ
//!   − γ̂), at the range's ends: where the parameters would be were the effect there;
//! - **detectable**: (t(1 − α_K/2, ν) + t(power, ν))·SE(γ), the smallest |γ| the candidates'
//!   amplitude test (at its level α_K) finds with the settings' power.
//!
//! An extension's amplitude is read as its variable (γ × the value the study set it to, the
//! baseline at 0, as the screening linearises it: exact where the response is linear in it); a
//! term's is its coefficient. The solver is not run over the range: the screening's runs at the
//! extension's probe values are what the range rests on.

use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

use super::shapes::Origin;
use super::shapes::Shape;
use super::{Candidate, Levels, stats};

/// One listed hypothesis the tests do not exclude (`diagnosis.not_excluded[]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NotExcluded {
    pub hypothesis: String,
    /// The amplitude's range the tests do not exclude at α: an extension's variable, or the
    /// term's `amplitude`.
    pub amplitude: IndexMap<String, [f64; 2]>,
    /// Each calibrated parameter over that range.
    pub parameters: IndexMap<String, [f64; 2]>,
    /// The smallest effect the tests would have detected (same names as `amplitude`).
    pub detectable: IndexMap<String, f64>,
}

/// The listed hypotheses' open ranges (`shapes`: the hypotheses, for an extension's declared
/// ranges; `nu`: the noise's degrees of freedom; `power`: the settings'); empty where no candidate
/// has an amplitude's standard error.
pub fn not_excluded(
    candidates: &[Candidate],
    shapes: &[Shape],
    nu: usize,
    (levels, power): (Levels, f64),
) -> Vec<NotExcluded> {
    let k = candidates.len();
    candidates
        .iter()
        .filter(|c| c.shape.origin == Origin::Study)
        .filter_map(|c| {
            let declared = shapes
                .iter()
                .find(|s| s.name == c.shape.name)
                .map_or(&[][..], |s| &s.ranges[..]);
            one(c, declared, nu, (levels.alpha, levels.amplitude(k)), power)
        })
        .collect()
}

fn one(
    c: &Candidate,
    declared: &[(String, f64, f64)],
    nu: usize,
    (alpha, alpha_k): (f64, f64),
    power: f64,
) -> Option<NotExcluded> {
    let se = c
        .checks
        .separability
        .amplitude_se
        .filter(|s| s.is_finite() && *s > 0.0)?;
    let nu = nu.max(1) as f64;
    let half = stats::t_quantile(1.0 - alpha / 2.0, nu) * se;
    let mut range = [c.fit.amplitude - half, c.fit.amplitude + half];
    // An extension's variable cannot leave the range the study declares for it (a hardening
    // modulus below 0): the open range is clipped to it, in γ (the variable over its probe value).
    if let (Some(e), [(name, lo, hi)]) = (c.checks.extension.as_ref().filter(|e| e.len() == 1), declared) {
        let probe = e.get(name).copied().filter(|v| *v != 0.0);
        if let Some(v) = probe {
            let (a, b) = ((lo / v).min(hi / v), (lo / v).max(hi / v));
            range = [range[0].clamp(a, b), range[1].clamp(a, b)];
        }
    }
    let detect = (stats::t_quantile(1.0 - alpha_k / 2.0, nu) + stats::t_quantile(power, nu)) * se;
    // The joint fit's slope of each parameter on γ (its shift over γ at the 95 % edge, per unit).
    let edge = c
        .checks
        .separability
        .amplitude_ci95
        .map(|[lo, hi]| if lo.abs() > hi.abs() { lo } else { hi });
    let parameters = c
        .fit
        .parameters
        .iter()
        .map(|(n, v)| {
            let shift = c.checks.separability.parameter_shift.get(n).copied().unwrap_or(0.0);
            let slope = edge.filter(|e| *e != 0.0).map_or(0.0, |e| shift / e);
            let ends = range.map(|g| v + slope * (g - c.fit.amplitude));
            (n.clone(), [ends[0].min(ends[1]), ends[0].max(ends[1])])
        })
        .collect();
    let (names, scale) = match c.checks.extension.as_ref().filter(|e| e.len() == 1) {
        Some(e) => {
            let (n, v) = e.iter().next().expect("one");
            (n.clone(), *v)
        }
        None => ("amplitude".to_string(), 1.0),
    };
    let ends = range.map(|g| g * scale);
    Some(NotExcluded {
        hypothesis: c.shape.name.clone(),
        amplitude: [(names.clone(), [ends[0].min(ends[1]), ends[0].max(ends[1])])]
            .into_iter()
            .collect(),
        parameters,
        detectable: [(names, (detect * scale).abs())].into_iter().collect(),
    })
}
