//! Step 4: weights, the leader, and the leader against every rival.
//!
//! Weights are `exp(−½ Δscore)` over the candidates and the uncorrected model (Akaike weights,
//! Burnham & Anderson 2002, §2.9). The *leader* is the best-scored candidate whose amplitude test
//! is significant at α/K ([`super::evidence`]).
//!
//! A leader with a large weight can still be indistinguishable from a rival: weights compare fits,
//! not the data's power to separate shapes. So the leader is set against each rival in an
//! *encompassing* test (Mizon & Richard 1986; the comprehensive-model F test of non-nested
//! regressions, Davidson & MacKinnon 1981): fit both shapes together and ask whether the leader's
//! shape still reduces the misfit once the rival's is in (F on 1 and ν degrees of freedom). The
//! leader is named only when every rival is rejected this way. For a leader fixed in advance,
//! requiring every rejection at α would be an intersection-union test of level α (Berger 1982);
//! but the data chose the leader among the K candidates. Were a rival r the truth, the wrong name
//! comes from whichever of the other K − 1 the data happened to rank first and that beat r, so the
//! chance of it is at most the sum of their K − 1 tests' levels: each rival test is at α/(K − 1)
//! (Bonferroni over the leaders the data could have chosen), and the search pays for its size.
//! With too few training designs to fit two shapes, a rival is rejected only when its prediction
//! fails the validation designs (at the same share) while the leader's passes (at α).

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::candidates::{self, Model, Score};
use super::evidence::Assessed;
use super::{
    Candidate, CandidateChecks, CandidateFit, CandidateScores, CandidateShape, Context, Mode, Precision, Uncorrected,
};

/// The leader against one rival.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RivalTest {
    pub rival: String,
    /// p of the leader's shape added to the rival's model (small: the rival does not suffice).
    pub p_leader_given_rival: Option<f64>,
    /// p of the rival's shape added to the leader's model (small: the leader does not suffice).
    pub p_rival_given_leader: Option<f64>,
    /// The rival is rejected as an explanation the data cannot tell from the leader.
    pub beaten: bool,
    /// `encompassing` (both shapes fitted together) or `validation` (predictions at the
    /// validation designs, when the training designs cannot fit both).
    pub by: String,
}

/// A model with its evidence and its score.
pub(crate) struct Entry {
    pub model: Model,
    pub assessed: Assessed,
    pub score: Option<Score>,
    pub explains: bool,
    pub weight: f64,
}

/// The models ranked best first.
pub(crate) struct Ranked {
    pub base: Entry,
    pub entries: Vec<Entry>,
    /// Index into `entries` of the leader.
    pub leader: Option<usize>,
    pub rivals: Vec<RivalTest>,
}

/// Scores, weights, order, leader and rival tests.
pub(crate) fn rank(cx: &Context, base: Model, fitted: Vec<Model>, assessed: (Assessed, Vec<Assessed>)) -> Ranked {
    let (base_assessed, cand_assessed) = assessed;
    let k = fitted.len().max(1) as f64;
    let entry = |model: Model, assessed: Assessed| {
        let score = (cx.mode != Mode::TooFew)
            .then(|| candidates::score(cx, &model, assessed.validation.as_ref().map(|v| v.deviance)));
        let explains = assessed.p_value.is_some_and(|p| p * k < cx.levels().candidates());
        Entry {
            model,
            assessed,
            score,
            explains,
            weight: 0.0,
        }
    };
    let mut base = entry(base, base_assessed);
    let mut entries: Vec<Entry> = fitted
        .into_iter()
        .zip(cand_assessed)
        .map(|(m, a)| entry(m, a))
        .collect();
    set_weights(&mut base, &mut entries);
    entries.sort_by(|a, b| order_key(a).total_cmp(&order_key(b)));
    let leader = entries.iter().position(|e| e.explains);
    let rivals = leader.map_or_else(Vec::new, |l| rival_tests(cx, &entries, l));
    Ranked {
        base,
        entries,
        leader,
        rivals,
    }
}

/// Best first: by score; without scores, by the validation error (else as listed).
fn order_key(e: &Entry) -> f64 {
    match &e.score {
        Some(s) => s.score,
        None => e.assessed.validation.as_ref().map_or(0.0, |v| v.error),
    }
}

/// Akaike-type weights over the candidates and the uncorrected model; equal weights when the data
/// give no scores (nothing to weigh them by).
fn set_weights(base: &mut Entry, entries: &mut [Entry]) {
    let scores: Vec<Option<f64>> = std::iter::once(&*base)
        .chain(entries.iter())
        .map(|e| e.score.as_ref().map(|s| s.score))
        .collect();
    let w = weights(&scores);
    base.weight = w[0];
    for (e, wi) in entries.iter_mut().zip(&w[1..]) {
        e.weight = *wi;
    }
}

/// Akaike-type weights `exp(−½ Δscore)` over `scores`, normalised; a model without a score (or
/// every model, when none has one) weighs as the best.
pub(crate) fn weights(scores: &[Option<f64>]) -> Vec<f64> {
    let all = scores.len() as f64;
    let best = scores.iter().flatten().copied().fold(f64::INFINITY, f64::min);
    let raw: Vec<f64> = scores
        .iter()
        .map(|s| match s {
            Some(s) if best.is_finite() => (-0.5 * (s - best)).exp(),
            _ => 1.0,
        })
        .collect();
    let total: f64 = raw.iter().sum();
    raw.iter()
        .map(|r| if total > 0.0 { r / total } else { 1.0 / all })
        .collect()
}

pub(crate) fn rival_tests(cx: &Context, entries: &[Entry], l: usize) -> Vec<RivalTest> {
    let leader = &entries[l];
    let n = cx.train.len();
    let both_fit = n >= cx.p() + 2 && (cx.known() || n > cx.p() + 2);
    let level = cx.levels().rival(entries.len().saturating_sub(1));
    entries
        .par_iter()
        .enumerate()
        .filter(|(r, _)| *r != l)
        .map(|(_, rival)| {
            if both_fit {
                encompassing(cx, leader, rival, level)
            } else {
                by_validation(cx, leader, rival, level)
            }
        })
        .collect()
}

/// Both shapes fitted together; the leader beats the rival when its shape still counts at `level`.
fn encompassing(cx: &Context, leader: &Entry, rival: &Entry, level: f64) -> RivalTest {
    let (p_l, p_r) = both_shapes(cx, leader, rival);
    RivalTest {
        rival: rival.model.name().to_string(),
        p_leader_given_rival: p_l,
        p_rival_given_leader: p_r,
        beaten: p_l.is_some_and(|p| p < level),
        by: "encompassing".into(),
    }
}

/// The comprehensive model's two F tests (Davidson & MacKinnon 1981): p of `one`'s shape added to
/// `other`'s model, and p of `other`'s added to `one`'s.
pub(crate) fn both_shapes(cx: &Context, one: &Entry, other: &Entry) -> (Option<f64>, Option<f64>) {
    let (ls, rs) = (one.model.shape.as_ref(), other.model.shape.as_ref());
    let shapes: Vec<&super::Shape> = ls.into_iter().chain(rs).collect();
    let dof = cx.train.len().saturating_sub(cx.p() + 2);
    match cx.data.fit(&shapes, &cx.train) {
        Ok(both) => (
            cx.drop_test(other.model.fit.wrss - both.wrss, 1, both.wrss, dof),
            cx.drop_test(one.model.fit.wrss - both.wrss, 1, both.wrss, dof),
        ),
        Err(_) => (None, None),
    }
}

/// The rival's prediction fails the validation designs at `level` while the leader's passes at α.
fn by_validation(cx: &Context, leader: &Entry, rival: &Entry, level: f64) -> RivalTest {
    let p = |e: &Entry| e.assessed.validation.as_ref().and_then(|v| v.p_value);
    let (pl, pr) = (p(leader), p(rival));
    RivalTest {
        rival: rival.model.name().to_string(),
        p_leader_given_rival: None,
        p_rival_given_leader: None,
        beaten: matches!((pl, pr), (Some(a), Some(b)) if a >= cx.alpha() && b < level),
        by: "validation".into(),
    }
}

impl Ranked {
    /// The candidates as `results.json` records them, best first.
    pub fn candidates(&self, cx: &Context) -> Vec<Candidate> {
        self.entries.iter().map(|e| candidate(cx, e)).collect()
    }

    pub fn uncorrected(&self, cx: &Context) -> Uncorrected {
        let b = &self.base;
        let s = b.score.as_ref();
        Uncorrected {
            parameters: cx.param_map(&b.model.fit.theta),
            loo_error: s.and_then(|s| s.loo_error),
            bic: s.map(|s| s.bic),
            aicc: s.and_then(|s| s.aicc),
            loo_deviance: s.and_then(|s| s.loo_deviance),
            score: s.map(|s| s.score),
            weight: s.map(|_| b.weight),
            weighted_rss: b.model.fit.wrss,
            validation: b.assessed.validation.clone(),
            precision: b.assessed.cov.as_ref().map(|c| precision(cx, &b.model.fit, &c.matrix)),
        }
    }
}

fn candidate(cx: &Context, e: &Entry) -> Candidate {
    let shape = e.model.shape.as_ref().expect("a candidate has a shape");
    let s = e.score.as_ref();
    Candidate {
        shape: CandidateShape {
            name: shape.name.clone(),
            term: shape.term.clone(),
            origin: shape.origin,
            replaces: e.model.replaces.clone(),
        },
        scores: CandidateScores {
            loo_error: s.and_then(|s| s.loo_error),
            bic: s.map(|s| s.bic),
            aicc: s.and_then(|s| s.aicc),
            loo_deviance: s.and_then(|s| s.loo_deviance),
            score: s.map(|s| s.score),
            weight: e.weight,
        },
        fit: CandidateFit {
            amplitude: e.model.fit.amplitude(),
            parameters: cx.param_map(&e.model.fit.theta),
            weighted_rss: e.model.fit.wrss,
            p_value: e.assessed.p_value,
            explains_misfit: e.explains,
        },
        checks: CandidateChecks {
            separability: e.assessed.separability.clone(),
            validation: e.assessed.validation.clone(),
            lack_of_fit: e.assessed.lack_of_fit.clone(),
            confounded_with: super::evidence::absorbed_by(cx, &e.model, &e.assessed, e.explains),
            predictions: cx
                .inputs
                .observations
                .iter()
                .zip(&cx.data.designs)
                .map(|(o, point)| (o.name.clone(), e.model.predict(cx, point)))
                .collect(),
            extension: shape.extension.as_ref().map(|v| v.iter().cloned().collect()),
        },
    }
}

/// Standard errors, 95 % intervals (Student t on the noise's degrees of freedom, or the fit's
/// residual ones without replicates) and correlations of the parameters from the covariance
/// `cov` of a fit at `theta` (Bates & Watts 1988, §2.3). An interval is cut at the parameter's
/// range: the study says the value lies in it, so the cut part holds no truth (the coverage can
/// only gain), and an interval reaching past a range a study set (a Cowper–Symonds C to 67,000
/// from a range to 40,000) reads as a fault.
fn precision(cx: &Context, fit: &super::fit::Fit, tests: &nalgebra::DMatrix<f64>) -> Precision {
    let theta = &fit.theta;
    let names = &cx.inputs.space.parameter_names;
    let p = names.len();
    // The tests' covariance of θ, plus the shift the emulators' error causes where it is known.
    let emulator = cx.emulator_covariance(fit).filter(|e| e.nrows() == p);
    let mut cov = tests.view((0, 0), (p, p)).into_owned();
    if let Some(e) = &emulator {
        cov += e;
    }
    let bounds = &cx.inputs.space.parameter_bounds;
    let range = |j: usize| match (bounds.lower.get(j), bounds.upper.get(j)) {
        (Some(&lo), Some(&hi)) => (lo, hi),
        _ => (f64::NEG_INFINITY, f64::INFINITY),
    };
    let dof = if cx.known() {
        cx.nu
    } else {
        cx.train.len().saturating_sub(cx.p())
    };
    let q = super::stats::t_quantile(0.975, dof as f64);
    let se: Vec<f64> = (0..names.len()).map(|j| cov[(j, j)].max(0.0).sqrt()).collect();
    Precision {
        se: names.iter().cloned().zip(se.iter().copied()).collect(),
        interval95: names
            .iter()
            .enumerate()
            .map(|(j, n)| {
                let (lo, hi) = range(j);
                (
                    n.clone(),
                    [(theta[j] - q * se[j]).max(lo), (theta[j] + q * se[j]).min(hi)],
                )
            })
            .collect(),
        correlation: names
            .iter()
            .enumerate()
            .map(|(i, a)| {
                let row = names
                    .iter()
                    .enumerate()
                    .map(|(j, b)| (b.clone(), cov[(i, j)] / (se[i] * se[j])))
                    .collect();
                (a.clone(), row)
            })
            .collect(),
        emulator_se: emulator.map_or_else(indexmap::IndexMap::new, |e| {
            names
                .iter()
                .enumerate()
                .map(|(j, n)| (n.clone(), e[(j, j)].max(0.0).sqrt()))
                .collect()
        }),
    }
}
