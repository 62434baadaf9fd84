//! Step 5: the verdict, from a fixed vocabulary, decided by the tests of the earlier steps at one α.
//!
//! | verdict | when |
//! |---|---|
//! | `too_few_tests` | no test of model error is possible (no replicates and no spare designs), or the training designs barely exceed the parameters and nothing was detected (the test had almost no power), or the tests' noise is not measured (no replicates, no stated `experiments.uncertainty`) and the decision would otherwise say a model fits or a cause is decisive ([`unmeasured`]) |
//! | `no_model_error` | no candidate's amplitude test is significant at α/(2K) and neither of the uncorrected model's two lack-of-fit tests (omnibus and largest residual) rejects at α/4 |
//! | `unexplained` | the lack of fit rejects, but no candidate is significant |
//! | `partly_explained` | the leader is significant and beats every rival, but its extended model's lack of fit (either test) still rejects at α, or a rival's shape still reduces the misfit with the leader's in (encompassing test at α / number of rivals): the cause helps, but it is not the whole story |
//! | `cannot_tell_apart` | the leader is significant, but some rival survives the encompassing test (at α / number of rivals: the data chose the leader): the data cannot tell them apart (whether or not the leader's model fits: an undecided part is not named) |
//! | `cause_named` | the leader is significant, beats every rival, and its extended model fits within the noise |
//!
//! Under no model error the detection's tests share α (α/4 for each of the uncorrected model's two
//! lack-of-fit tests, α/(2K) for each of the K candidates), so their false-alarm rate together is at
//! most α.

use serde::{Deserialize, Serialize};

use super::ranking::Ranked;
use super::{Candidate, Context, Mode};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    NoModelError,
    CauseNamed,
    CannotTellApart,
    PartlyExplained,
    Unexplained,
    TooFewTests,
    /// The emulators' error, not the tests, decides: the decision with the tests' noise alone and
    /// the one with the emulators' error counted differ, or the solver's runs at the fitted
    /// parameters confirm neither ([`super::confirm::settle`]).
    EmulatorLimited,
}

impl Verdict {
    /// The verdict's fixed words.
    pub fn words(self) -> &'static str {
        match self {
            Verdict::NoModelError => "no model error beyond the noise",
            Verdict::CauseNamed => "model error: cause named",
            Verdict::CannotTellApart => "model error: leading candidates, cannot tell apart",
            Verdict::PartlyExplained => "model error: partly explained",
            Verdict::Unexplained => "model error: no listed cause explains it",
            Verdict::TooFewTests => "too few tests to tell",
            Verdict::EmulatorLimited => "undecided: the emulators' error, not the tests, decides",
        }
    }
}

/// An explanation of the tests: the uncorrected model, a candidate of the screening (an index
/// into [`Ranked::entries`]), or a model the loop calibrated with the solver (an index into the
/// loop's models, see [`super::after_loop`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Who {
    Uncorrected,
    Candidate(usize),
    Extended(usize),
}

/// The verdict and what it leaves open.
#[derive(Debug, Clone)]
pub(crate) struct Decision {
    pub verdict: Verdict,
    pub detected: bool,
    pub cause: Option<Who>,
    /// The explanations the verdict leaves open, best first.
    pub leading: Vec<Who>,
    /// The explanations the next test should tell apart.
    pub compare: Vec<Who>,
}

impl Decision {
    /// The screening candidate a [`Who`] stands for (`None`: the uncorrected model, or a loop model).
    pub fn candidate(who: Who) -> Option<usize> {
        match who {
            Who::Candidate(k) => Some(k),
            _ => None,
        }
    }
}

/// The name of an explanation: a candidate's, or `uncorrected`; a loop model is named by the
/// candidate it extends (`loop_names`).
pub(crate) fn name_of(who: Who, candidates: &[Candidate], loop_names: &[String]) -> String {
    match who {
        Who::Uncorrected => "uncorrected".to_string(),
        Who::Candidate(k) => candidates[k].shape.name.clone(),
        Who::Extended(j) => loop_names[j].clone(),
    }
}

/// No candidate explains the misfit: too few tests, unexplained model error, or none. What a further
/// test should examine is the candidate the data come nearest to detecting — the smallest p of the
/// amplitude tests that decide "explains the misfit" (the best-scored among equals) — against no
/// correction. The best-scored candidate is not that: with no amplitude significant, the scores
/// rank shapes that barely move the fit (a scale error with p = 0.45 above a listed extension with
/// p = 7.9e-4 just short of α/(2K)), and a test telling such a shape from no correction asks
/// hundreds of specimens to settle nothing.
fn without_leader(cx: &Context, ranked: &Ranked, base_rejects: bool) -> Decision {
    let p = |k: usize| {
        ranked.entries[k]
            .assessed
            .p_value
            .filter(|p| p.is_finite())
            .unwrap_or(f64::INFINITY)
    };
    let best = (0..ranked.entries.len()).min_by(|&a, &b| p(a).total_cmp(&p(b)));
    let few = cx.mode == Mode::TooFew || cx.mode == Mode::Few && !base_rejects;
    let verdict = if few {
        Verdict::TooFewTests
    } else if base_rejects {
        Verdict::Unexplained
    } else {
        Verdict::NoModelError
    };
    // The best candidate against no correction: is there model error at all?
    let best = best.map(Who::Candidate);
    let compare: Vec<Who> = best.into_iter().chain([Who::Uncorrected]).collect();
    Decision {
        verdict,
        detected: base_rejects,
        cause: None,
        leading: if verdict == Verdict::NoModelError {
            vec![Who::Uncorrected]
        } else {
            compare.clone()
        },
        compare,
    }
}

/// Noise that is not measured is not assumed. Without replicates or a stated measurement
/// uncertainty the noise is estimated from the residuals of the models being judged, so a model
/// "fits" by construction: the uncorrected model's lack of fit has nothing to be held against, and
/// a cause's final model fits its own residuals. A candidate's amplitude test stays valid (an F
/// test of nested models, the larger model's residuals the denominator), so model error may still
/// be detected; but "no model error" becomes too few tests to tell, and a cause that would be named
/// stays a leading candidate, ranked, beside the explanation the next test sets it against.
pub(crate) fn unmeasured(cx: &Context, d: Decision) -> Decision {
    if cx.known() || !matches!(d.verdict, Verdict::NoModelError | Verdict::CauseNamed) {
        return d;
    }
    let mut leading = d.leading.clone();
    for w in &d.compare {
        if !leading.contains(w) {
            leading.push(*w);
        }
    }
    Decision {
        verdict: Verdict::TooFewTests,
        cause: None,
        leading,
        ..d
    }
}

pub(crate) fn decide(cx: &Context, ranked: &Ranked) -> Decision {
    unmeasured(cx, decide_on(cx, ranked))
}

fn decide_on(cx: &Context, ranked: &Ranked) -> Decision {
    let rejects = |l: Option<&super::LackOfFit>| l.is_some_and(super::LackOfFit::rejects);
    let base_rejects = rejects(ranked.base.assessed.lack_of_fit.as_ref());
    let Some(l) = ranked.leader else {
        return without_leader(cx, ranked, base_rejects);
    };
    let unbeaten: Vec<usize> = ranked
        .rivals
        .iter()
        .filter(|r| !r.beaten)
        .filter_map(|r| ranked.entries.iter().position(|e| e.model.name() == r.rival))
        .collect();
    // The rival the leader beat least clearly: where a confirming test should look.
    let closest = ranked
        .rivals
        .iter()
        .max_by(|a, b| {
            let p = |r: &super::ranking::RivalTest| r.p_leader_given_rival.unwrap_or(1.0);
            p(a).total_cmp(&p(b))
        })
        .and_then(|r| ranked.entries.iter().position(|e| e.model.name() == r.rival));
    // A rival whose shape still counts with the leader in: the leader alone does not suffice (tested
    // at α over the rivals, Bonferroni).
    let bound = cx.levels().rival(ranked.rivals.len());
    let adds = ranked
        .rivals
        .iter()
        .filter(|r| r.p_rival_given_leader.is_some_and(|p| p < bound))
        .filter_map(|r| ranked.entries.iter().position(|e| e.model.name() == r.rival))
        .next();
    let named = |k: usize| Who::Candidate(k);
    let (verdict, cause, leading, compare) =
        if rejects(ranked.entries[l].assessed.lack_of_fit.as_ref()) || adds.is_some() {
            let next = adds.or(unbeaten.first().copied()).or(closest);
            // Without a rival to set it against, the cause against no correction. A rival whose
            // shape still adds is left open beside the cause: the loop judges it too.
            let compare = vec![named(l), next.map_or(Who::Uncorrected, named)];
            // So are the rivals the leader did not beat; and where the leader's own model misses
            // the tests, its wins say little: every candidate that explains the misfit may be the
            // whole story, and is judged by its own model after the loop. (An unbeaten rival is open
            // either way: it is why the part is not decided.)
            let misses = rejects(ranked.entries[l].assessed.lack_of_fit.as_ref());
            let mut open: Vec<usize> = std::iter::once(l).chain(adds).collect();
            let others =
                (0..ranked.entries.len()).filter(|&k| unbeaten.contains(&k) || misses && ranked.entries[k].explains);
            for k in others {
                if !open.contains(&k) {
                    open.push(k);
                }
            }
            let open = open.into_iter().map(named).collect();
            // The part is named only when it is decided: a leader that has not beaten every rival
            // may be the wrong part (a shape that happens to remove most of a misfit it does not
            // cause); then the candidates that explain are open, none named.
            if unbeaten.is_empty() {
                (Verdict::PartlyExplained, Some(named(l)), open, compare)
            } else {
                (Verdict::CannotTellApart, None, open, compare)
            }
        } else if unbeaten.is_empty() {
            let compare = vec![named(l), closest.map_or(Who::Uncorrected, named)];
            (Verdict::CauseNamed, Some(named(l)), vec![named(l)], compare)
        } else {
            let mut tied = vec![l];
            tied.extend(unbeaten.iter().copied());
            tied.sort_unstable();
            let open: Vec<Who> = tied.iter().map(|&k| named(k)).collect();
            let compare = open.iter().take(2).copied().collect();
            (Verdict::CannotTellApart, None, open, compare)
        };
    Decision {
        verdict,
        detected: true,
        cause,
        leading,
        compare,
    }
}
