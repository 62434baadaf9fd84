//! Step 5b: the verdict from all the evidence — the screening, then every model the loop
//! calibrated with the solver.
//!
//! The screening (steps 1–5) judges a model extension linearised around the baseline at one probe
//! value. The loop replaces that by the extended model itself, calibrated over its variables with
//! new solver runs. This step decides once, from the *final model* of every explanation the
//! screening left open (the named cause, or the candidates it could not tell apart):
//!
//! 1. The final model is the loop's extended model where the loop calibrated the explanation, else
//!    the screening's joint fit of θ and the candidate's amplitude. Term hypotheses and extensions
//!    are judged by the same rules below.
//! 2. **Lack of fit** at α: the final model's training residuals and validation predictive
//!    residuals against the replicate noise (the pure-error F test of [`super::evidence`]). A final
//!    model that fails it is out, with its χ² and p.
//! 3. **The survivors against each other**: the encompassing test of step 4, with each survivor's
//!    final model as the base — e's (screening) shape added to f's final model: if it still reduces
//!    the misfit at α, f does not account for what e does. For a loop model f this test is read from
//!    f's own diagnosis, in which the other open explanations' shapes are candidates. e is named
//!    when it beats every other survivor this way (an intersection–union test, level α; Berger
//!    1982). Where both directions are significant each explains a part: the better-scored is named
//!    and the verdict is "partly explained".
//! 4. The named cause's own final diagnosis says whether anything listed still explains what
//!    remains (α/K): then it only partly explains. No survivor: a single open explanation partly
//!    explains when its shape explained the misfit at screening; with several, which one is the
//!    part is not decided (cannot tell apart, ranked by score). Two or more survivors, none beating
//!    the rest: cannot tell apart, the survivors ranked by their score (AICc and leave-one-design-out
//!    deviance on the same training tests, step 2's score), best first.
//!
//! 5. **Unchecked loop models.** A loop model whose emulators no solver run checked at its fitted
//!    point (the loop's budget ran out first) may miss the tests, or fit them, by the emulators'
//!    error rather than its own: it is not rejected on its lack of fit, and beside another open
//!    explanation the verdict is "cannot tell apart" (nothing is decided over it, nor it over
//!    another, until runs there check it).
//!
//! Pure: the inputs are the screening's and each loop model's evidence ([`super::Evidence`]).

use serde::{Deserialize, Serialize};

use super::ranking;
use super::verdict::{Decision, Verdict, Who};
use super::{Evidence, LackOfFit};

/// The after-loop judgement of one open explanation (`results.json` `diagnosis.after_loop.explanations`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Judged {
    pub name: String,
    /// `extended` (the loop's model, calibrated with the solver) or `screening` (θ and γ fitted
    /// jointly, a term or a linearised extension).
    pub model: String,
    /// The final model's lack of fit against the replicate noise (absent without replicates).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub lack_of_fit: Option<LackOfFit>,
    /// Out: its final model misses the tests beyond the noise at α.
    pub rejected: bool,
    /// A loop model whose emulators no solver run checked at its fitted point. Beside another
    /// explanation not out, it is not out on its lack of fit and nothing is decided over it (step 5).
    #[serde(skip_serializing_if = "std::ops::Not::not", default)]
    pub unchecked: bool,
    /// The score of step 2 on the training tests (smaller is better), and its weight among the
    /// open explanations.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub score: Option<f64>,
    pub weight: f64,
}

/// One survivor against another: e's shape added to f's final model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Pairwise {
    pub shape_of: String,
    pub added_to: String,
    /// p of the shape's amplitude (F test against a refit of the final model alone).
    pub p_value: Option<f64>,
}

/// What the loop's evidence changed, in `results.json` `diagnosis.after_loop`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AfterLoop {
    /// The screening's verdict and headline: the step before the loop.
    pub screening_verdict: Verdict,
    pub screening_headline: String,
    pub explanations: Vec<Judged>,
    pub pairwise: Vec<Pairwise>,
}

/// An open explanation with its final model.
struct Open {
    who: Who,
    name: String,
    lof: Option<LackOfFit>,
    score: Option<f64>,
    /// A screening model, or a loop model whose emulators were checked at its fitted point.
    checked: bool,
}

impl Open {
    fn misses(&self) -> bool {
        self.lof.as_ref().is_some_and(LackOfFit::rejects)
    }

    /// Out on its lack of fit; `held`: step 5 holds an unchecked model open instead.
    fn rejected(&self, held: bool) -> bool {
        self.misses() && (!held || self.checked)
    }
}

/// The final decision, and the record of how it was reached. `loop_names[j]` is the hypothesis the
/// j-th loop model extends.
pub(crate) fn decide(screening: &Evidence, looped: &[Evidence], loop_names: &[String]) -> (Decision, AfterLoop) {
    let s = &screening.decision;
    let alpha = screening.cx.alpha();
    let open: Vec<Open> = s
        .leading
        .iter()
        .filter_map(|&who| open_one(screening, looped, loop_names, who))
        .collect();
    let held = unsettled(&open);
    let step5 = held.is_some();
    let rejected = |o: &Open| o.rejected(step5);
    let mut survivors: Vec<&Open> = open.iter().filter(|o| !rejected(o)).collect();
    survivors.sort_by(|a, b| key(a.score).total_cmp(&key(b.score)));
    let mut pairwise = Vec::new();
    let decision = match (held, survivors.as_slice()) {
        (Some(d), _) => d,
        (None, []) => all_rejected(screening, &open, alpha),
        (None, [one]) => named(screening, looped, one, None),
        (None, many) => {
            let p = |e: &Open, f: &Open, out: &mut Vec<Pairwise>| {
                let p = added_to(screening, looped, e, f);
                out.push(Pairwise {
                    shape_of: e.name.clone(),
                    added_to: f.name.clone(),
                    p_value: p,
                });
                p
            };
            let mut beats_all = Vec::new();
            for (i, e) in many.iter().enumerate() {
                let all = many
                    .iter()
                    .enumerate()
                    .filter(|(j, _)| *j != i)
                    .all(|(_, f)| p(e, f, &mut pairwise).is_some_and(|p| p < alpha));
                if all {
                    beats_all.push(*e);
                }
            }
            match beats_all.as_slice() {
                [one] => {
                    // A rival's shape that still counts with the cause in: the cause is only a part.
                    let also = many
                        .iter()
                        .filter(|f| f.who != one.who)
                        .find(|f| {
                            pairwise.iter().any(|x| {
                                x.shape_of == f.name && x.added_to == one.name && x.p_value.is_some_and(|p| p < alpha)
                            })
                        })
                        .map(|f| f.who);
                    named(screening, looped, one, also)
                }
                // Both (or more) beat each other: each explains a part; the best-scored is named.
                [first, ..] => named(screening, looped, first, beats_all.get(1).map(|o| o.who)),
                [] => Decision {
                    verdict: Verdict::CannotTellApart,
                    detected: true,
                    cause: None,
                    leading: many.iter().map(|o| o.who).collect(),
                    compare: many.iter().take(2).map(|o| o.who).collect(),
                },
            }
        }
    };
    let weights = weights(&open);
    let record = AfterLoop {
        screening_verdict: s.verdict,
        screening_headline: String::new(),
        explanations: open
            .iter()
            .zip(weights)
            .map(|(o, w)| Judged {
                name: o.name.clone(),
                model: if matches!(o.who, Who::Extended(_)) {
                    "extended"
                } else {
                    "screening"
                }
                .into(),
                lack_of_fit: o.lof.clone(),
                rejected: rejected(o),
                unchecked: !o.checked,
                score: o.score,
                weight: w,
            })
            .collect(),
        pairwise,
    };
    (decision, record)
}

fn key(score: Option<f64>) -> f64 {
    score.unwrap_or(f64::INFINITY)
}

/// The final model of an open explanation: the loop's when it extended it.
fn open_one(screening: &Evidence, looped: &[Evidence], loop_names: &[String], who: Who) -> Option<Open> {
    let k = Decision::candidate(who)?;
    let entry = &screening.ranked.entries[k];
    let name = entry.model.name().to_string();
    Some(match loop_names.iter().position(|n| *n == name) {
        Some(j) => {
            let base = &looped[j].ranked.base;
            Open {
                who: Who::Extended(j),
                name,
                lof: base.assessed.lack_of_fit.clone(),
                score: base.score.as_ref().map(|s| s.score),
                checked: looped[j].checked,
            }
        }
        None => Open {
            who,
            name,
            lof: entry.assessed.lack_of_fit.clone(),
            score: entry.score.as_ref().map(|s| s.score),
            checked: true,
        },
    })
}

/// p of e's shape added to f's final model.
fn added_to(screening: &Evidence, looped: &[Evidence], e: &Open, f: &Open) -> Option<f64> {
    match f.who {
        // f's own diagnosis fitted e's shape as a candidate.
        Who::Extended(j) => looped[j]
            .ranked
            .entries
            .iter()
            .find(|x| x.model.name() == e.name)
            .and_then(|x| x.assessed.p_value),
        Who::Candidate(fk) => {
            let entries = &screening.ranked.entries;
            let ek = entries.iter().position(|x| x.model.name() == e.name)?;
            ranking::encompassing(&screening.cx, &entries[ek], &entries[fk]).p_leader_given_rival
        }
        Who::Uncorrected => None,
    }
}

/// `one` named; `also`: a rival that still explains part of what remains.
fn named(screening: &Evidence, looped: &[Evidence], one: &Open, also: Option<Who>) -> Decision {
    // Anything listed still explaining what the cause's final model leaves, at α over the rivals:
    // a loop model's own diagnosis has the other candidates as its candidates (α/K); a screening
    // candidate is set against every other candidate as the screening sets its leader (step 4).
    let remains = match one.who {
        Who::Extended(j) => looped[j].ranked.leader.is_some(),
        Who::Candidate(k) => {
            let rivals = ranking::rival_tests(&screening.cx, &screening.ranked.entries, k);
            let bound = screening.cx.alpha() / rivals.len().max(1) as f64;
            rivals.iter().any(|r| r.p_rival_given_leader.is_some_and(|p| p < bound))
        }
        Who::Uncorrected => false,
    };
    let partly = also.is_some() || remains;
    // To confirm it: against the rival that still adds, else the screening's closest rival.
    let rival = also.or_else(|| {
        screening
            .decision
            .compare
            .iter()
            .copied()
            .find(|w| *w != one.who && !is_same(screening, looped_name(one), *w))
    });
    Decision {
        verdict: if partly {
            Verdict::PartlyExplained
        } else {
            Verdict::CauseNamed
        },
        detected: true,
        cause: Some(one.who),
        leading: vec![one.who],
        compare: vec![one.who, rival.unwrap_or(Who::Uncorrected)],
    }
}

fn looped_name(one: &Open) -> &str {
    &one.name
}

/// Whether `who` is the screening candidate named `name`.
fn is_same(screening: &Evidence, name: &str, who: Who) -> bool {
    Decision::candidate(who).is_some_and(|k| screening.ranked.entries[k].model.name() == name)
}

/// Step 5: an unchecked loop model beside another explanation not out (every one but a checked
/// model that misses) leaves those open, ranked by score. `None`: no such model, or nothing beside
/// it: alone, it is judged by steps 2–4 (a miss partly explains, never a fit).
fn unsettled(open: &[Open]) -> Option<Decision> {
    let standing: Vec<&Open> = open.iter().filter(|o| !(o.checked && o.misses())).collect();
    if standing.len() < 2 || standing.iter().all(|o| o.checked) {
        return None;
    }
    let mut ranked = standing;
    ranked.sort_by(|a, b| key(a.score).total_cmp(&key(b.score)));
    let leading: Vec<Who> = ranked.iter().map(|o| o.who).collect();
    Some(Decision {
        verdict: Verdict::CannotTellApart,
        detected: true,
        cause: None,
        compare: leading.iter().take(2).copied().collect(),
        leading,
    })
}

/// Every open explanation's final model misses the tests: the best-scored partly explains.
fn all_rejected(screening: &Evidence, open: &[Open], _alpha: f64) -> Decision {
    let best = open.iter().min_by(|a, b| key(a.score).total_cmp(&key(b.score)));
    if open.len() > 1 {
        // Every final model misses: which one is the part is not decided by a score alone.
        let mut ranked: Vec<&Open> = open.iter().collect();
        ranked.sort_by(|a, b| key(a.score).total_cmp(&key(b.score)));
        let leading: Vec<Who> = ranked.iter().map(|o| o.who).collect();
        return Decision {
            verdict: Verdict::CannotTellApart,
            detected: true,
            cause: None,
            compare: leading.iter().take(2).copied().collect(),
            leading,
        };
    }
    match best {
        Some(b) => Decision {
            verdict: Verdict::PartlyExplained,
            detected: true,
            cause: Some(b.who),
            leading: vec![b.who],
            compare: vec![b.who, Who::Uncorrected],
        },
        None => screening.decision.clone(),
    }
}

/// Akaike-type weights over the open explanations' scores (equal without scores).
fn weights(open: &[Open]) -> Vec<f64> {
    let best = open.iter().filter_map(|o| o.score).fold(f64::INFINITY, f64::min);
    let raw: Vec<f64> = open
        .iter()
        .map(|o| match o.score {
            Some(s) if best.is_finite() => (-0.5 * (s - best)).exp(),
            _ => 1.0,
        })
        .collect();
    let total: f64 = raw.iter().sum();
    raw.iter().map(|r| r / total.max(f64::MIN_POSITIVE)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn open(k: usize, score: f64, fits: bool, checked: bool) -> Open {
        Open {
            who: Who::Extended(k),
            name: format!("h{k}"),
            lof: Some(LackOfFit {
                chi2: if fits { 1.0 } else { 40.0 },
                dof: 4,
                noise_dof: 10,
                p_value: if fits { 0.4 } else { 1e-6 },
                largest: None,
                level: 0.05,
                fits,
            }),
            score: Some(score),
            checked,
        }
    }

    /// A loop model with its emulators unchecked at its fitted point is neither out nor beaten, nor
    /// named over another: the two stay open, the better-scored first. Checked, a miss is out.
    #[test]
    fn an_unchecked_miss_leaves_the_explanations_open() {
        let both = [open(0, 12.0, true, true), open(1, 30.0, false, false)];
        let d = unsettled(&both).expect("left open");
        assert_eq!(d.verdict, Verdict::CannotTellApart);
        assert_eq!(d.cause, None);
        assert_eq!(d.leading, vec![Who::Extended(0), Who::Extended(1)]);
        assert!(!both[1].rejected(true));

        let checked = [open(0, 12.0, true, true), open(1, 30.0, false, true)];
        assert!(unsettled(&checked).is_none());
        assert!(checked[1].rejected(false));

        // Beside a checked model that misses (out), an unchecked one stands alone: judged as any.
        let alone = [open(0, 12.0, false, true), open(1, 30.0, false, false)];
        assert!(unsettled(&alone).is_none());
        assert!(alone[1].rejected(false), "alone, its miss is a miss: never called a fit");

        let fits = [open(0, 30.0, true, true), open(1, 12.0, true, false)];
        let d = unsettled(&fits).expect("an unchecked model that fits is not named over the other");
        assert_eq!(d.leading, vec![Who::Extended(1), Who::Extended(0)]);
        assert!(unsettled(&[open(1, 30.0, false, false)]).is_none(), "alone, nothing else is open");
    }
}
