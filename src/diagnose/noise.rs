//! The measurement noise from the replicate scatter: one model with both components,
//! σ²(y) = a² + (b·y)², of which a constant σ (b = 0) and a constant coefficient of variation
//! (a = 0) are the edges.
//!
//! With replicates y_ik (k = 1..n_i) at design i, the scatter about each design's own mean carries
//! SS_i = Σ_k (y_ik − ȳ_i)² with ν_i = n_i − 1 degrees of freedom. Write σ_i² = s² v_i(λ) with
//! v_i(λ) = (1 − λ) + λ (ȳ_i / m)², m the root mean square of the replicated levels, so that the
//! mixing λ ∈ [0, 1] runs from the absolute edge to the relative one without units. The restricted
//! log-likelihood of the deviations, −½ Σ_i [ν_i ln σ_i² + SS_i / σ_i²], is maximised over s² in
//! closed form (ŝ² = Σ SS_i / v_i / ν) and profiled over λ on a fine grid. The edges are the
//! simpler models (one number each, the combined model two): the combined one is used only when its
//! likelihood-ratio test against the likelier edge rejects at α; with few replicates a free λ
//! wanders inside, and the weights with it, where the data do not ask for both components.
//!
//! **No coin toss.** With two or three replicates per design the profile is flat: the data cannot
//! tell a constant σ from a constant CV, and picking the likelier edge decides by luck (about one
//! clean draw in sixty then calls a proportional scatter constant, and the high-level designs look
//! like misfit). So the replicates give a set of mixings, not one: every λ whose likelihood ratio
//! to the best is within χ²₁(1 − β)/2, β = α/10 ([`super::Levels::mixing_set`]). A model is called wrong only
//! when it misses the tests under every noise model of that set (the p-value maximised over a
//! confidence set of the nuisance, Berger & Boos 1994, JASA 89:1012, which adds at most β to the
//! test's level): the diagnosis runs with the chosen mixing (the likelier edge, or the combined
//! model where its test rejects the edge), unless the uncorrected model's lack of fit rejects there,
//! another mixing of the set lets it fit, and no candidate explains a misfit under it; then with
//! that mixing (`super::noise_and_base`). A cause's final model is judged on the noise detection
//! chose, never on a mixing re-chosen for it.

use serde::{Deserialize, Serialize};

use super::Observation;
use crate::base::format::num;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NoiseKind {
    /// The same σ at every design (the mixing λ = 0).
    Absolute,
    /// σ grows with the level: a constant coefficient of variation (λ = 1).
    Relative,
    /// Both components: σ² = a² + (b·y)² (0 < λ < 1).
    Combined,
    /// No replicates: σ (absolute) estimated from the residuals of the best-ranked model.
    FromResiduals,
    /// No replicates: the measurement's uncertainty the study states (`experiments.uncertainty`),
    /// σ² = a² + (b·y)², taken as known.
    Stated,
}

/// The degrees of freedom a known noise is given (a stated measurement uncertainty): its tests are
/// then χ² and normal, which F and t reach at this many.
pub const KNOWN_DOF: usize = 1_000_000;

/// The noise model and the evidence for it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseModel {
    pub kind: NoiseKind,
    /// σ of one test: absolute units for `absolute`, `combined` (σ at the replicated levels' root
    /// mean square) and `from_residuals`, a fraction of the level for `relative`.
    pub scale: f64,
    /// a: the absolute component of σ² = a² + (b·y)² (`scale` for `from_residuals`).
    #[serde(default)]
    pub absolute: f64,
    /// b: the relative component (a fraction of the level).
    #[serde(default)]
    pub relative: f64,
    /// Degrees of freedom behind the scale: Σ(n_i − 1) from replicates, else n − k of the residuals.
    pub dof: usize,
    /// The replicates' evidence on the noise's form: the likelihoods at the edges and the mixings (absent without replicates).
    #[serde(flatten)]
    pub evidence: MixingEvidence,
    pub note: String,
}

/// The replicates' evidence on the noise's form: the likelihoods at the edges and the mixings (absent without replicates).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MixingEvidence {
    /// Maximised replicate log-likelihoods at the two edges (absent without replicates).
    pub loglik_absolute: Option<f64>,
    pub loglik_relative: Option<f64>,
    /// The mixing λ the diagnosis uses (0: absolute, 1: relative).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub mixing: Option<f64>,
    /// The maximum-likelihood mixing and the set of mixings the replicates allow at 1 − β.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub mixing_ml: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub mixing_set: Option<[f64; 2]>,
}

/// The replicates' scatter: per design (ν_i, SS_i, ȳ_i), with two or more distinct replicates.
#[derive(Debug, Clone)]
pub struct Scatter {
    groups: Vec<(f64, f64, f64)>,
    nu: f64,
    /// Root mean square of the replicated levels (λ's unit).
    m: f64,
}

impl NoiseModel {
    /// σ of one test at a design whose response level is `level`.
    pub fn sigma_at(&self, level: f64) -> f64 {
        match self.kind {
            NoiseKind::FromResiduals => self.scale,
            _ => self.absolute.hypot(self.relative * level),
        }
    }

    /// Whether the scale comes from replicates (then it is an independent noise estimate).
    pub fn from_replicates(&self) -> bool {
        self.kind != NoiseKind::FromResiduals
    }

    /// A constant σ of `scale` with `dof` degrees of freedom, described by `note` (a noise known
    /// otherwise than from a scalar response's replicates, e.g. whitened curve features).
    pub fn constant(scale: f64, dof: usize, note: String) -> NoiseModel {
        NoiseModel {
            kind: NoiseKind::Absolute,
            scale,
            absolute: scale,
            relative: 0.0,
            dof,
            note,
            evidence: MixingEvidence::default(),
        }
    }
}

impl NoiseModel {
    /// The study's stated measurement uncertainty of one test: σ² = a² + (b·y)² (`[a, b]`), known.
    pub fn stated([a, b]: [f64; 2]) -> NoiseModel {
        let mut nm = NoiseModel::constant(
            a,
            KNOWN_DOF,
            format!(
                "no replicates: the measurement's uncertainty the study states, σ = {}{} (`experiments.uncertainty`), taken \
                 as known",
                num(a),
                if b > 0.0 {
                    format!(" ⊕ {} of the level", num(b))
                } else {
                    String::new()
                }
            ),
        );
        nm.kind = NoiseKind::Stated;
        nm.relative = b;
        nm
    }
}

impl Scatter {
    /// The scatter of the designs with two or more replicates (training and validation: the
    /// scatter of a design about its own mean says nothing about the model, only about the tests);
    /// `None` when none has distinct replicates.
    pub fn of(observations: &[Observation]) -> Option<Scatter> {
        let groups: Vec<(f64, f64, f64)> = observations
            .iter()
            .filter(|o| o.count >= 2)
            .map(|o| {
                let dof = (o.count - 1) as f64;
                let s = o.std_dev.unwrap_or(0.0);
                (dof, dof * s * s, o.mean)
            })
            .collect();
        let nu: f64 = groups.iter().map(|g| g.0).sum();
        let ss: f64 = groups.iter().map(|g| g.1).sum();
        if nu == 0.0 || !ss.is_finite() || ss <= 0.0 {
            return None;
        }
        let m = (groups.iter().map(|g| g.2 * g.2).sum::<f64>() / groups.len() as f64).sqrt();
        Some(Scatter { groups, nu, m })
    }

    /// The largest mixing with σ_i > 0 at every design (below 1 when a replicated level is 0).
    fn max_mixing(&self) -> f64 {
        if self.m > 0.0 && self.groups.iter().all(|g| g.2 != 0.0 && g.2.is_finite()) {
            1.0
        } else {
            0.0
        }
    }

    /// (ŝ², profile log-likelihood) at mixing λ.
    fn profile(&self, lambda: f64) -> (f64, f64) {
        let v = |level: f64| (1.0 - lambda) + lambda * (level / self.m).powi(2);
        let s2 = self.groups.iter().map(|g| g.1 / v(g.2)).sum::<f64>() / self.nu;
        let ll = -0.5 * (self.groups.iter().map(|g| g.0 * (s2 * v(g.2)).ln()).sum::<f64>() + self.nu);
        (s2, ll)
    }

    /// The maximum-likelihood mixing (a grid of 1,001 points over [0, max]).
    pub fn ml_mixing(&self) -> f64 {
        let top = self.max_mixing();
        (0..=1000)
            .map(|k| top * k as f64 / 1000.0)
            .max_by(|a, b| self.profile(*a).1.total_cmp(&self.profile(*b).1))
            .unwrap_or(0.0)
    }

    /// The mixing the diagnosis starts from: the likelier edge, or the maximum-likelihood mixing
    /// when it beats that edge by more than χ²₁(1 − α)/2 in log-likelihood.
    pub fn chosen_mixing(&self, alpha: f64) -> f64 {
        let ll = |l: f64| self.profile(l).1;
        let edge = if self.max_mixing() == 1.0 && ll(1.0) > ll(0.0) {
            1.0
        } else {
            0.0
        };
        let ml = self.ml_mixing();
        if ll(ml) - ll(edge) > 0.5 * super::stats::chi2_quantile(1.0 - alpha, 1.0) {
            ml
        } else {
            edge
        }
    }

    /// The mixings whose likelihood ratio to the best is within χ²₁(1 − β)/2: [lo, hi].
    fn mixing_set(&self, beta: f64) -> [f64; 2] {
        let top = self.max_mixing();
        let best = self.profile(self.ml_mixing()).1;
        let cut = best - 0.5 * super::stats::chi2_quantile(1.0 - beta, 1.0);
        let inside: Vec<f64> = (0..=1000)
            .map(|k| top * k as f64 / 1000.0)
            .filter(|l| self.profile(*l).1 >= cut)
            .collect();
        [
            inside.first().copied().unwrap_or(0.0),
            inside.last().copied().unwrap_or(top),
        ]
    }

    /// Mixings to try when the maximum-likelihood one says the uncorrected model misses: five
    /// evenly over the set, its ends included.
    pub fn set_points(&self, alpha: f64) -> Vec<f64> {
        let [lo, hi] = self.mixing_set(super::Levels::new(alpha, false).mixing_set());
        (0..5).map(|k| lo + (hi - lo) * k as f64 / 4.0).collect()
    }

    /// The noise model at mixing λ, with the evidence for it (the set at level α).
    pub fn model_at(&self, lambda: f64, alpha: f64) -> NoiseModel {
        let (s2, _) = self.profile(lambda);
        let (a, b) = ((s2 * (1.0 - lambda)).sqrt(), (s2 * lambda).sqrt() / self.m);
        let ml = self.ml_mixing();
        let set = self.mixing_set(super::Levels::new(alpha, false).mixing_set());
        let ll_abs = self.profile(0.0).1;
        let ll_rel = (self.max_mixing() == 1.0).then(|| self.profile(1.0).1);
        let kind = if lambda <= 0.0 {
            NoiseKind::Absolute
        } else if lambda >= 1.0 {
            NoiseKind::Relative
        } else {
            NoiseKind::Combined
        };
        let scale = match kind {
            NoiseKind::Relative => b,
            _ => s2.sqrt(),
        };
        NoiseModel {
            kind,
            scale,
            absolute: a,
            relative: b,
            dof: self.nu as usize,
            note: self.note(lambda, set, (a, b), (ll_abs, ll_rel)),
            evidence: MixingEvidence {
                loglik_absolute: Some(ll_abs),
                loglik_relative: ll_rel,
                mixing: Some(lambda),
                mixing_ml: Some(ml),
                mixing_set: Some(set),
            },
        }
    }

    fn note(&self, lambda: f64, set: [f64; 2], (a, b): (f64, f64), (ll_abs, ll_rel): (f64, Option<f64>)) -> String {
        let designs = self.groups.len();
        let form = format!(
            "σ² = a² + (b·y)² with a = {}, b = {} (a coefficient of variation of {:.3} %)",
            num(a),
            num(b),
            100.0 * b
        );
        let edges = match ll_rel {
            Some(lr) => {
                format!("log-likelihood {ll_abs:.1} for a constant σ, {lr:.1} for a constant coefficient of variation")
            }
            None => format!(
                "log-likelihood {ll_abs:.1} for a constant σ; a replicated level is zero, so no constant coefficient of variation"
            ),
        };
        let mut note = format!(
            "replicates at {designs} designs ({} degrees of freedom): {form}; mixing λ = {:.2} (0: constant σ, 1: constant \
             coefficient of variation), the replicates allow {:.2} to {:.2} ({edges})",
            self.nu as usize, lambda, set[0], set[1]
        );
        let levels = self
            .groups
            .iter()
            .map(|g| g.2.abs())
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
        if designs < 2 || levels.1 <= levels.0 * 1.05 {
            note.push_str("; the replicated levels hardly differ, so the two components cannot really be told apart");
        }
        note
    }
}

/// The noise model of the replicates at the chosen mixing ([`Scatter::chosen_mixing`]);
/// `None` when no design has two or more distinct replicates.
pub fn from_replicates(observations: &[Observation], alpha: f64) -> Option<NoiseModel> {
    let scatter = Scatter::of(observations)?;
    Some(scatter.model_at(scatter.chosen_mixing(alpha), alpha))
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
        let mut nm = NoiseModel::constant(
            0.0,
            0,
            "no replicates and no spare designs: the noise cannot be estimated".into(),
        );
        nm.kind = NoiseKind::FromResiduals;
        return nm;
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
            num(sigma)
        )
    };
    let mut nm = NoiseModel::constant(sigma, dof, note);
    nm.kind = NoiseKind::FromResiduals;
    nm
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
        let nm = from_replicates(&observations(|m| 0.02 * m), 0.01).unwrap();
        assert_eq!(nm.kind, NoiseKind::Relative);
        assert!((nm.relative - 0.02).abs() < 1e-12 && nm.absolute < 1e-12, "{nm:?}");
        assert!((nm.sigma_at(50.0) - 1.0).abs() < 1e-10);
        assert_eq!(nm.dof, 6);
    }

    #[test]
    fn constant_scatter_is_absolute() {
        let nm = from_replicates(&observations(|_| 0.5), 0.01).unwrap();
        assert_eq!(nm.kind, NoiseKind::Absolute);
        assert!((nm.scale - 0.5).abs() < 1e-12 && nm.relative == 0.0, "{nm:?}");
    }

    /// The two edges are the old closed forms (σ² = ΣSS/ν, c² = Σ(SS/ȳ²)/ν), and a scatter with
    /// both components lands inside with σ² = a² + (b·y)² reproducing the per-design variances.
    #[test]
    fn the_edges_are_the_closed_forms_and_both_components_land_inside() {
        let obs = observations(|m| (0.3f64.powi(2) + (0.02 * m).powi(2)).sqrt());
        let scatter = Scatter::of(&obs).unwrap();
        let ss: Vec<f64> = obs.iter().map(|o| 2.0 * o.std_dev.unwrap().powi(2)).collect();
        let abs = scatter.model_at(0.0, 0.01);
        assert!((abs.absolute.powi(2) - ss.iter().sum::<f64>() / 6.0).abs() < 1e-12);
        let rel = scatter.model_at(1.0, 0.01);
        let c2 = ss.iter().zip(&obs).map(|(s, o)| s / o.mean.powi(2)).sum::<f64>() / 6.0;
        assert!((rel.relative.powi(2) - c2).abs() < 1e-12);
        let ml = from_replicates(&obs, 0.01).unwrap();
        assert_eq!(ml.kind, NoiseKind::Combined, "{}", ml.note);
        for o in &obs {
            let want = o.std_dev.unwrap();
            assert!(
                (ml.sigma_at(o.mean) / want - 1.0).abs() < 0.02,
                "{} vs {want}",
                ml.sigma_at(o.mean)
            );
        }
        let set = ml.evidence.mixing_set.unwrap();
        assert!(set[0] <= ml.evidence.mixing.unwrap() && ml.evidence.mixing.unwrap() <= set[1]);
    }

    /// With two replicates at three nearby levels the replicates cannot tell the edges apart: the
    /// set of mixings spans both.
    #[test]
    fn few_replicates_allow_both_edges() {
        let obs: Vec<Observation> = [(10.0, 0.3), (12.0, 0.1), (14.0, 0.4)]
            .iter()
            .enumerate()
            .map(|(i, &(m, s))| Observation::from_replicates(format!("d{i}"), vec![m], Role::Training, &[m - s, m + s]))
            .collect();
        let nm = from_replicates(&obs, 0.01).unwrap();
        assert_eq!(nm.evidence.mixing_set, Some([0.0, 1.0]), "{}", nm.note);
    }

    #[test]
    fn no_replicates_or_no_scatter_gives_none() {
        let single = vec![Observation::from_replicates("a", vec![1.0], Role::Training, &[3.0])];
        assert!(from_replicates(&single, 0.01).is_none());
        assert!(from_replicates(&observations(|_| 0.0), 0.01).is_none());
    }
}
