//! The measurement noise, from the replicate scatter: absolute (one σ for every design) or relative
//! (one coefficient of variation, σ_i = c·|level_i|), whichever makes the replicates more likely.
//!
//! With replicates y_ik (k = 1..n_i) at design i, the scatter about each design's own mean carries
//! SS_i = Σ_k (y_ik − ȳ_i)² with n_i − 1 degrees of freedom. For σ_i known up to one scale, the
//! restricted log-likelihood of those deviations is −½ Σ_i [(n_i − 1) ln σ_i² + SS_i / σ_i²]; each
//! model's scale is its maximiser (σ² = ΣSS_i / ν, resp. c² = Σ(SS_i/ȳ_i²) / ν with ν = Σ(n_i − 1)).
//! Both models have one free number, so their maximised likelihoods compare directly.

use serde::{Deserialize, Serialize};

use super::Observation;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NoiseKind {
    /// The same σ at every design.
    Absolute,
    /// σ grows with the level: a constant coefficient of variation.
    Relative,
    /// No replicates: σ (absolute) estimated from the residuals of the best-ranked model.
    FromResiduals,
}

/// The noise model and the evidence for it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseModel {
    pub kind: NoiseKind,
    /// σ of one test: absolute units for `absolute` and `from_residuals`, a fraction of the level
    /// for `relative`.
    pub scale: f64,
    /// Degrees of freedom behind `scale`: Σ(n_i − 1) from replicates, else n − k of the residuals.
    pub dof: usize,
    /// Maximised replicate log-likelihoods of the two models (absent without replicates).
    pub loglik_absolute: Option<f64>,
    pub loglik_relative: Option<f64>,
    pub note: String,
}

impl NoiseModel {
    /// σ of one test at a design whose response level is `level`.
    pub fn sigma_at(&self, level: f64) -> f64 {
        match self.kind {
            NoiseKind::Relative => self.scale * level.abs(),
            _ => self.scale,
        }
    }

    /// Whether the scale comes from replicates (then it is an independent noise estimate).
    pub fn from_replicates(&self) -> bool {
        self.kind != NoiseKind::FromResiduals
    }
}

/// Chooses the noise model from the replicate scatter of all designs (training and validation:
/// the scatter of a design about its own mean says nothing about the model, only about the tests).
/// Returns `None` when no design has two or more distinct replicates.
pub fn from_replicates(observations: &[Observation]) -> Option<NoiseModel> {
    let with: Vec<(f64, f64, f64)> = observations
        .iter()
        .filter(|o| o.count >= 2)
        .map(|o| {
            let dof = (o.count - 1) as f64;
            let s = o.std_dev.unwrap_or(0.0);
            (dof, dof * s * s, o.mean)
        })
        .collect();
    let nu: f64 = with.iter().map(|w| w.0).sum();
    let ss: f64 = with.iter().map(|w| w.1).sum();
    if nu == 0.0 || ss.is_nan() || ss <= 0.0 {
        return None;
    }
    let var_abs = ss / nu;
    let ll_abs = -0.5 * (nu * var_abs.ln() + nu);
    let relative_possible = with.iter().all(|w| w.2 != 0.0 && w.2.is_finite());
    let (ll_rel, cv2) = if relative_possible {
        let cv2 = with.iter().map(|w| w.1 / (w.2 * w.2)).sum::<f64>() / nu;
        let ll = -0.5 * (with.iter().map(|w| w.0 * (cv2 * w.2 * w.2).ln()).sum::<f64>() + nu);
        (Some(ll), cv2)
    } else {
        (None, f64::NAN)
    };
    let designs = with.len();
    let levels = with
        .iter()
        .map(|w| w.2.abs())
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
    let (kind, scale, note) = match ll_rel {
        Some(lr) if lr > ll_abs => (
            NoiseKind::Relative,
            cv2.sqrt(),
            format!(
                "replicates at {designs} designs ({} degrees of freedom): the scatter grows with the level \
                 (constant coefficient of variation {:.3} %; log-likelihood {lr:.1} against {ll_abs:.1} for a constant σ)",
                nu as usize,
                100.0 * cv2.sqrt()
            ),
        ),
        _ => (
            NoiseKind::Absolute,
            var_abs.sqrt(),
            format!(
                "replicates at {designs} designs ({} degrees of freedom): the scatter does not grow with the level \
                 (constant σ = {:.4}; log-likelihood {ll_abs:.1}{})",
                nu as usize,
                var_abs.sqrt(),
                ll_rel
                    .map(|l| format!(" against {l:.1} for a constant coefficient of variation"))
                    .unwrap_or_default()
            ),
        ),
    };
    let note = if designs < 2 || levels.1 <= levels.0 * 1.05 {
        format!("{note}; the replicated levels hardly differ, so the two forms cannot really be told apart")
    } else {
        note
    };
    Some(NoiseModel {
        kind,
        scale,
        dof: nu as usize,
        loglik_absolute: Some(ll_abs),
        loglik_relative: ll_rel,
        note,
    })
}

/// The noise model the diagnosis reports: the replicates' when there are any; else σ (absolute)
/// from the residuals of the best-scored model, with the degrees of freedom it leaves.
pub(crate) fn finalise(
    replicates: Option<NoiseModel>,
    cx: &super::Context,
    ranked: &super::ranking::Ranked,
) -> NoiseModel {
    if let Some(nm) = replicates {
        return nm;
    }
    let n = cx.train.len();
    let score = |e: &super::ranking::Entry| e.score.as_ref().map_or(f64::INFINITY, |s| s.score);
    let best = ranked
        .entries
        .iter()
        .filter(|e| score(e) < score(&ranked.base))
        .min_by(|a, b| score(a).total_cmp(&score(b)))
        .unwrap_or(&ranked.base);
    let who = match &best.model.shape {
        Some(s) => format!("'{}'", s.name),
        None => "the uncorrected model".to_string(),
    };
    let dof = n.saturating_sub(best.model.k());
    if dof == 0 {
        return NoiseModel {
            kind: NoiseKind::FromResiduals,
            scale: 0.0,
            dof: 0,
            loglik_absolute: None,
            loglik_relative: None,
            note: "no replicates and no spare designs: the noise cannot be estimated".to_string(),
        };
    }
    let rss = best.model.fit.wrss;
    let exact = rss <= cx.rss_floor;
    let sigma = (rss.max(cx.rss_floor) / dof as f64).sqrt();
    let note = if exact {
        format!(
            "no replicates: σ estimated from the residuals of {who}, which are at floating-point level (the tests look \
             noise-free); σ floored at {sigma:.3e}"
        )
    } else {
        format!(
            "no replicates: σ = {} estimated from the residuals of {who} ({dof} degrees of freedom)",
            super::text::num(sigma)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::Role;

    /// Replicates whose scatter is exactly ±s around levels 1, 10, 100.
    fn observations(scatter: impl Fn(f64) -> f64) -> Vec<Observation> {
        [1.0, 10.0, 100.0]
            .iter()
            .enumerate()
            .map(|(i, &m)| {
                let s = scatter(m);
                Observation::from_replicates(format!("d{i}"), vec![m], Role::Training, &[m - s, m, m + s])
            })
            .collect()
    }

    #[test]
    fn scatter_proportional_to_the_level_is_relative() {
        let nm = from_replicates(&observations(|m| 0.02 * m)).unwrap();
        assert_eq!(nm.kind, NoiseKind::Relative);
        assert!((nm.scale - 0.02).abs() < 1e-12, "{}", nm.scale);
        assert_eq!(nm.dof, 6);
    }

    #[test]
    fn constant_scatter_is_absolute() {
        let nm = from_replicates(&observations(|_| 0.5)).unwrap();
        assert_eq!(nm.kind, NoiseKind::Absolute);
        assert!((nm.scale - 0.5).abs() < 1e-12, "{}", nm.scale);
    }

    #[test]
    fn no_replicates_or_no_scatter_gives_none() {
        let single = vec![Observation::from_replicates("a", vec![1.0], Role::Training, &[3.0])];
        assert!(from_replicates(&single).is_none());
        assert!(from_replicates(&observations(|_| 0.0)).is_none());
    }
}
