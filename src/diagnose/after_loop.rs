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
//!    the misfit at α/(m − 1) among m survivors, f does not account for what e does. For a loop
//!    model f this test is read from f's own diagnosis, in which the other open explanations' shapes
//!    are candidates. e is named when it beats every other survivor this way: were f the truth, any
//!    of the other m − 1 could be the one that beats it, so each test pays for them (Bonferroni, as
//!    step 4 does for the screening's leader). Where both directions are significant each explains
//!    a part: the better-scored is named and the verdict is "partly explained".
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
//! 6. **Runs that cannot change the decision.** While some loops are still running, [`settled`]
//!    asks whether the decision would be the same whatever their final models show: missing the
//!    tests or fitting them, checked or not, beaten by each other explanation's shape or not, scored
//!    anywhere among the rest, leaving something explained or not. Every such outcome is decided by
//!    steps 2–5; where all give the same verdict and cause, more runs of those loops can only buy
//!    their own fit, and the loop stops them (a logical invariance, not a threshold: no outcome of
//!    theirs is left that could name another cause).
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
    /// The level it is judged at: α over the other survivors (step 3).
    #[serde(default)]
    pub level: f64,
}

/// What the loop's evidence changed, in `results.json` `diagnosis.after_loop`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AfterLoop {
    /// The screening's verdict and headline: the step before the loop.
    pub screening_verdict: Verdict,
    pub screening_headline: String,
    pub explanations: Vec<Judged>,
    pub pairwise: Vec<Pairwise>,
    /// The extensions the solver's runs over their amplitudes favoured where the screening found no
    /// model error: the open explanations the loop judged in place of the screening's.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub favoured: Vec<String>,
    /// The decision is the same whatever the loops still running show ([`settled`]): their runs
    /// cannot change it. True when no loop is running.
    #[serde(skip, default)]
    pub settled: bool,
}

/// An open explanation with its final model.
#[derive(Clone)]
struct Open {
    who: Who,
    name: String,
    lof: Option<LackOfFit>,
    score: Option<f64>,
    /// A screening model, or a loop model whose emulators were checked at its fitted point.
    checked: bool,
    /// A loop model still running: what its final model will show is not known yet.
    running: bool,
    /// What its final model is assumed to show, in place of its evidence ([`settled`]).
    assumed: Option<Assumed>,
}

/// One outcome a running loop's final model may have, as the decision reads it.
#[derive(Debug, Clone)]
struct Assumed {
    misses: bool,
    /// Something listed still explains what its model leaves (step 4).
    remains: bool,
    /// The other open explanations whose shape, added to its model, is significant at α.
    beaten_by: Vec<String>,
}

impl Open {
    fn misses(&self) -> bool {
        match &self.assumed {
            Some(a) => a.misses,
            None => self.lof.as_ref().is_some_and(LackOfFit::rejects),
        }
    }

    /// Out on its lack of fit; `held`: step 5 holds an unchecked model open instead.
    fn rejected(&self, held: bool) -> bool {
        self.misses() && (!held || self.checked)
    }
}

/// The final decision, and the record of how it was reached. `loop_names[j]` is the hypothesis the
/// j-th loop model extends.
pub(crate) fn decide(screening: &Evidence, looped: &[Evidence], loop_names: &[String]) -> (Decision, AfterLoop) {
    let open = opens(screening, looped, loop_names);
    let mut readings = FromEvidence::new(screening, looped);
    let judged = judge(&mut readings, &open);
    let weights = ranking::weights(&open.iter().map(|o| o.score).collect::<Vec<_>>());
    let record = AfterLoop {
        screening_verdict: screening.decision.verdict,
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
                rejected: o.rejected(judged.step5),
                unchecked: !o.checked,
                score: o.score,
                weight: w,
            })
            .collect(),
        pairwise: judged.pairwise,
        favoured: screening.favoured.clone(),
        settled: settled(&mut readings, &open),
    };
    (judged.decision, record)
}

/// The open explanations the screening left, each with its final model: where it found no model
/// error but the solver's runs over extensions' amplitudes favoured them, those extensions first,
/// then every other the loop ran (each is as open as they were: the emulators excluded none).
fn opens(screening: &Evidence, looped: &[Evidence], loop_names: &[String]) -> Vec<Open> {
    let mut names: Vec<&String> = screening.favoured.iter().collect();
    names.extend(loop_names.iter().filter(|n| !screening.favoured.contains(n)));
    let judged: Vec<Who> = (names.into_iter())
        .filter_map(|n| screening.ranked.entries.iter().position(|e| e.model.name() == n))
        .map(Who::Candidate)
        .collect();
    let leading = match screening.decision.detected || screening.favoured.is_empty() {
        true => &screening.decision.leading,
        false => &judged,
    };
    (leading.iter())
        .filter_map(|&who| open_one(screening, looped, loop_names, who))
        .collect()
}

/// Steps 2–5 over the open explanations, and the pairwise tests they read.
struct Judgement {
    decision: Decision,
    pairwise: Vec<Pairwise>,
    /// Step 5 held an unchecked model open.
    step5: bool,
}

/// What steps 2–5 read besides the open explanations' own facts: the screening's tests and the
/// loop models' own diagnoses ([`FromEvidence`]), or a table in the tests.
trait Readings {
    fn alpha(&self) -> f64;
    /// p of e's shape added to f's final model.
    fn added_to(&mut self, e: &Open, f: &Open) -> Option<f64>;
    /// Something listed still explains what `one`'s final model leaves (step 4).
    fn remains(&mut self, one: &Open) -> bool;
    /// The screening's closest rival to confirm `one` against, when no rival still adds.
    fn rival(&self, one: &Open) -> Option<Who>;
    /// The decision when nothing is open: the screening's.
    fn screening(&self) -> Decision;
}

/// Steps 2–5.
fn judge(r: &mut dyn Readings, open: &[Open]) -> Judgement {
    let alpha = r.alpha();
    let held = unsettled(open);
    let step5 = held.is_some();
    let mut survivors: Vec<&Open> = open.iter().filter(|o| !o.rejected(step5)).collect();
    survivors.sort_by(|a, b| key(a.score).total_cmp(&key(b.score)));
    let mut pairwise = Vec::new();
    let decision = match (held, survivors.as_slice()) {
        (Some(d), _) => d,
        (None, []) => all_rejected(r, open),
        (None, [one]) => named(r, one, None),
        (None, many) => {
            // Any of the other survivors could beat a true one: each pair at α/(m − 1), the
            // screening's rival level.
            let level = super::levels::Levels::new(alpha, false).rival(many.len() - 1);
            let mut p = |r: &mut dyn Readings, e: &Open, f: &Open| {
                let value = match &f.assumed {
                    Some(a) => Some(if a.beaten_by.contains(&e.name) { 0.0 } else { 1.0 }),
                    None => r.added_to(e, f),
                };
                pairwise.push(Pairwise {
                    shape_of: e.name.clone(),
                    added_to: f.name.clone(),
                    p_value: value,
                    level,
                });
                value.is_some_and(|p| p < level)
            };
            against_each_other(r, many, &mut p)
        }
    };
    Judgement {
        decision,
        pairwise,
        step5,
    }
}

/// Step 3: two or more survivors, each against the others. `beats(e, f)`: e's shape added to f's
/// final model is significant at α.
fn against_each_other(
    r: &mut dyn Readings,
    many: &[&Open],
    beats: &mut dyn FnMut(&mut dyn Readings, &Open, &Open) -> bool,
) -> Decision {
    let mut significant: Vec<(String, String)> = Vec::new();
    let mut beats_all = Vec::new();
    for (i, e) in many.iter().enumerate() {
        let all = many.iter().enumerate().filter(|(j, _)| *j != i).all(|(_, f)| {
            let s = beats(r, e, f);
            if s {
                significant.push((e.name.clone(), f.name.clone()));
            }
            s
        });
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
                .find(|f| significant.iter().any(|(e, g)| *e == f.name && *g == one.name))
                .map(|f| f.who);
            named(r, one, also)
        }
        // Both (or more) beat each other: each explains a part; the best-scored is named.
        [first, ..] => named(r, first, beats_all.get(1).map(|o| o.who)),
        [] => apart(many.to_vec()),
    }
}

/// Step 6: whether the decision is the same whatever the running loops' final models show (each
/// may miss the tests or fit them, be checked or not, be beaten or not by each other open
/// explanation's shape, score anywhere among them, leave something explained or not).
///
/// Nothing running: it is. One explanation open and running: its outcome decides (a fit is named, a
/// miss only partly explains): it is not. Two or more open: every outcome that names no cause is
/// "cannot tell apart" (step 5, every model out, or none beating the rest), so the decision is
/// settled exactly when no outcome names a cause. And where some outcome names a cause e, so does
/// the outcome `C_e` ([`naming`]) in which every other running loop misses and is checked (out of
/// the survivors and of step 5's standing explanations) and e, if running, fits and is checked:
/// `C_e`'s standing explanations and survivors are subsets of that outcome's, e among them, and e
/// beats each survivor by the same tests (a non-running model's tests do not depend on what the
/// loops show). So the n outcomes `C_e` decide it: n judgements, where enumerating every outcome
/// grows as (8 · 2^(n−1) · n) to the power of the running loops.
fn settled(r: &mut dyn Readings, open: &[Open]) -> bool {
    if !open.iter().any(|o| o.running) {
        return true;
    }
    if open.len() < 2 {
        return false;
    }
    (0..open.len()).all(|e| judge(r, &naming(open, e)).decision.cause.is_none())
}

/// The outcome of the running loops most favourable to naming explanation `e` ([`settled`]):
/// every other running loop misses and is checked; `e`, if running, fits, is checked and is beaten
/// by none.
fn naming(open: &[Open], e: usize) -> Vec<Open> {
    let mut case = open.to_vec();
    for (i, o) in case.iter_mut().enumerate().filter(|(_, o)| o.running) {
        let named = i == e;
        o.assumed = Some(Assumed {
            misses: !named,
            remains: false,
            beaten_by: Vec::new(),
        });
        o.checked = true;
    }
    case
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
                running: looped[j].running,
                assumed: None,
            }
        }
        None => Open {
            who,
            name,
            lof: entry.assessed.lack_of_fit.clone(),
            score: entry.score.as_ref().map(|s| s.score),
            checked: true,
            running: false,
            assumed: None,
        },
    })
}

/// The readings from the evidence: the screening's tests (each made once: the outcomes
/// [`settled`] tries read them again and again) and the loop models' own diagnoses.
struct FromEvidence<'e, 'a> {
    screening: &'e Evidence<'a>,
    looped: &'e [Evidence<'a>],
    known: Vec<((String, String), Option<f64>)>,
}

impl<'e, 'a> FromEvidence<'e, 'a> {
    fn new(screening: &'e Evidence<'a>, looped: &'e [Evidence<'a>]) -> Self {
        FromEvidence {
            screening,
            looped,
            known: Vec::new(),
        }
    }
}

impl Readings for FromEvidence<'_, '_> {
    fn alpha(&self) -> f64 {
        self.screening.cx.alpha()
    }

    fn added_to(&mut self, e: &Open, f: &Open) -> Option<f64> {
        let pair = (e.name.clone(), f.name.clone());
        if let Some((_, v)) = self.known.iter().find(|(k, _)| *k == pair) {
            return *v;
        }
        let v = match f.who {
            // f's own diagnosis fitted e's shape as a candidate.
            Who::Extended(j) => self.looped[j]
                .ranked
                .entries
                .iter()
                .find(|x| x.model.name() == e.name)
                .and_then(|x| x.assessed.p_value),
            Who::Candidate(fk) => {
                let entries = &self.screening.ranked.entries;
                entries
                    .iter()
                    .position(|x| x.model.name() == e.name)
                    .and_then(|ek| ranking::both_shapes(&self.screening.cx, &entries[ek], &entries[fk]).0)
            }
            Who::Uncorrected => None,
        };
        self.known.push((pair, v));
        v
    }

    fn remains(&mut self, one: &Open) -> bool {
        // Anything listed still explaining what the cause's final model leaves, at α over the rivals:
        // a loop model's own diagnosis has the other candidates as its candidates (α/K); a screening
        // candidate is set against every other candidate as the screening sets its leader (step 4).
        let s = self.screening;
        match one.who {
            Who::Extended(j) => self.looped[j].ranked.leader.is_some(),
            Who::Candidate(k) => {
                let rivals = ranking::rival_tests(&s.cx, &s.ranked.entries, k);
                let bound = s.cx.levels().rival(rivals.len());
                rivals.iter().any(|r| r.p_rival_given_leader.is_some_and(|p| p < bound))
            }
            Who::Uncorrected => false,
        }
    }

    fn rival(&self, one: &Open) -> Option<Who> {
        let s = self.screening;
        let is_same = |who: Who| Decision::candidate(who).is_some_and(|k| s.ranked.entries[k].model.name() == one.name);
        s.decision
            .compare
            .iter()
            .copied()
            .find(|w| *w != one.who && !is_same(*w))
    }

    fn screening(&self) -> Decision {
        self.screening.decision.clone()
    }
}

/// `one` named; `also`: a rival that still explains part of what remains.
fn named(r: &mut dyn Readings, one: &Open, also: Option<Who>) -> Decision {
    let remains = match &one.assumed {
        Some(a) => a.remains,
        None => r.remains(one),
    };
    let partly = also.is_some() || remains;
    // To confirm it: against the rival that still adds, else the screening's closest rival.
    let rival = also.or_else(|| r.rival(one));
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

/// Step 5: an unchecked loop model beside another explanation not out (every one but a checked
/// model that misses) leaves those open, ranked by score. `None`: no such model, or nothing beside
/// it: alone, it is judged by steps 2–4 (a miss partly explains, never a fit).
fn unsettled(open: &[Open]) -> Option<Decision> {
    let standing: Vec<&Open> = open.iter().filter(|o| !(o.checked && o.misses())).collect();
    if standing.len() < 2 || standing.iter().all(|o| o.checked) {
        return None;
    }
    Some(apart(standing))
}

/// "Cannot tell apart" between `open`, ranked by score (best first).
fn apart(mut open: Vec<&Open>) -> Decision {
    open.sort_by(|a, b| key(a.score).total_cmp(&key(b.score)));
    let leading: Vec<Who> = open.iter().map(|o| o.who).collect();
    Decision {
        verdict: Verdict::CannotTellApart,
        detected: true,
        cause: None,
        compare: leading.iter().take(2).copied().collect(),
        leading,
    }
}

/// Every open explanation's final model misses the tests: the best-scored partly explains.
fn all_rejected(r: &dyn Readings, open: &[Open]) -> Decision {
    let best = open.iter().min_by(|a, b| key(a.score).total_cmp(&key(b.score)));
    if open.len() > 1 {
        // Every final model misses: which one is the part is not decided by a score alone.
        return apart(open.iter().collect());
    }
    match best {
        Some(b) => Decision {
            verdict: Verdict::PartlyExplained,
            detected: true,
            cause: Some(b.who),
            leading: vec![b.who],
            compare: vec![b.who, Who::Uncorrected],
        },
        None => r.screening(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The enumeration [`settled`] replaced: every combination of the running loops' outcomes
    /// judged and compared (`None` above 2^16 combinations), the oracle of its tests.
    fn settled_by_enumeration(r: &mut dyn Readings, open: &[Open]) -> Option<bool> {
        let running: Vec<usize> = (0..open.len()).filter(|&i| open[i].running).collect();
        let choices: Vec<Vec<(Assumed, bool, f64)>> = running.iter().map(|&i| outcomes(open, i)).collect();
        let n = choices.iter().map(Vec::len).try_fold(1usize, |n, c| n.checked_mul(c))?;
        if n > 1 << 16 {
            return None;
        }
        let mut first = None;
        for index in 0..n {
            let mut case = open.to_vec();
            let mut at = index;
            for (c, &i) in running.iter().enumerate() {
                let (assumed, checked, score) = choices[c][at % choices[c].len()].clone();
                at /= choices[c].len();
                case[i].assumed = Some(assumed);
                case[i].checked = checked;
                case[i].score = Some(score);
            }
            let d = judge(r, &case).decision;
            match &first {
                None => first = Some((d.verdict, d.cause)),
                Some(f) if *f != (d.verdict, d.cause) => return Some(false),
                Some(_) => {}
            }
        }
        Some(true)
    }

    /// Every outcome open explanation `i` (a running loop model) may have beside the others.
    fn outcomes(open: &[Open], i: usize) -> Vec<(Assumed, bool, f64)> {
        let others: Vec<&Open> = open
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != i)
            .map(|(_, o)| o)
            .collect();
        let finite: Vec<f64> = others
            .iter()
            .filter_map(|o| o.score)
            .filter(|s| s.is_finite())
            .collect();
        let worst = finite.iter().copied().fold(0.0, f64::max);
        let mut scores: Vec<f64> = finite.iter().map(|s| s - 1e-9 * (1.0 + s.abs())).collect();
        scores.push(worst + 1.0);
        let mut all = Vec::new();
        for misses in [false, true] {
            for checked in [true, false] {
                for remains in [false, true] {
                    for mask in 0..(1usize << others.len()) {
                        let beaten_by: Vec<String> = (0..others.len())
                            .filter(|b| mask >> b & 1 == 1)
                            .map(|b| others[b].name.clone())
                            .collect();
                        for &score in &scores {
                            let assumed = Assumed {
                                misses,
                                remains,
                                beaten_by: beaten_by.clone(),
                            };
                            all.push((assumed, checked, score));
                        }
                    }
                }
            }
        }
        all
    }

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
            running: false,
            assumed: None,
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
        assert!(
            alone[1].rejected(false),
            "alone, its miss is a miss: never called a fit"
        );

        let fits = [open(0, 30.0, true, true), open(1, 12.0, true, false)];
        let d = unsettled(&fits).expect("an unchecked model that fits is not named over the other");
        assert_eq!(d.leading, vec![Who::Extended(1), Who::Extended(0)]);
        assert!(
            unsettled(&[open(1, 30.0, false, false)]).is_none(),
            "alone, nothing else is open"
        );
    }

    /// The screening's and the loop models' readings as a table: p of (shape of, added to).
    struct Table {
        p: Vec<(&'static str, &'static str, f64)>,
    }

    impl Table {
        /// Neither loop model's shape beats `t`, nor `t`'s `h1`, nor either loop model the other; `t`
        /// against `h0`'s final model at `p`.
        fn with_t_against_h0(p: f64) -> Self {
            let mut p = vec![("h0", "t", 0.2), ("h1", "t", 0.6), ("t", "h0", p), ("t", "h1", 0.8)];
            p.extend([("h1", "h0", 0.5), ("h0", "h1", 0.5)]);
            Table { p }
        }
    }

    impl Readings for Table {
        fn alpha(&self) -> f64 {
            0.05
        }
        fn added_to(&mut self, e: &Open, f: &Open) -> Option<f64> {
            self.p
                .iter()
                .find(|(a, b, _)| *a == e.name && *b == f.name)
                .map(|x| x.2)
        }
        fn remains(&mut self, _: &Open) -> bool {
            false
        }
        fn rival(&self, _: &Open) -> Option<Who> {
            None
        }
        fn screening(&self) -> Decision {
            Decision {
                verdict: Verdict::CannotTellApart,
                detected: true,
                cause: None,
                leading: Vec::new(),
                compare: Vec::new(),
            }
        }
    }

    /// A screening candidate `t` that fits, and two loop models: `h0` that fits (checked), `h1`.
    fn three(running: [bool; 2]) -> Vec<Open> {
        let mut t = open(0, 15.0, true, true);
        t.who = Who::Candidate(0);
        t.name = "t".into();
        let mut h0 = open(0, 18.0, true, true);
        let mut h1 = open(1, 17.0, true, true);
        h0.running = running[0];
        h1.running = running[1];
        vec![t, h0, h1]
    }

    /// Three survivors that fit: `t` is named over the other two only when its shape beats each at
    /// α/2 (either of the two could be the one that beats a true explanation); with one of them
    /// out, one rival is left and α is its level.
    #[test]
    fn each_pair_pays_for_the_other_survivors() {
        let table = |p: f64| Table {
            p: vec![
                ("t", "h0", p),
                ("t", "h1", p),
                ("h0", "t", 0.5),
                ("h1", "t", 0.5),
                ("h0", "h1", 0.5),
                ("h1", "h0", 0.5),
            ],
        };
        let named = |p: f64, open: &[Open]| judge(&mut table(p), open).decision.cause;
        let all = three([false, false]);
        assert_eq!(named(0.02, &all), Some(Who::Candidate(0)), "0.02 < α/2 = 0.025");
        let d = judge(&mut table(0.03), &all).decision;
        assert_eq!((d.verdict, d.cause), (Verdict::CannotTellApart, None), "0.03 ≥ α/2");
        assert!(judge(&mut table(0.03), &all).pairwise.iter().all(|p| p.level == 0.025));
        let mut one_out = all.clone();
        one_out[2] = open(1, 17.0, false, true);
        assert_eq!(
            named(0.03, &one_out),
            Some(Who::Candidate(0)),
            "0.03 < α with one rival"
        );
    }

    /// The honeycomb diagnosis draw 8's case: neither loop model's shape beats the term `t`
    /// (screening tests, which no loop run changes), and `t`'s shape does not beat `h0`'s final
    /// model. Whatever `h1`'s runs show (out, in, beaten by either, anywhere in the ranking,
    /// checked or not), the verdict is "cannot tell apart": settled.
    #[test]
    fn a_loop_whose_every_outcome_leaves_the_verdict_is_settled() {
        let mut r = Table::with_t_against_h0(0.3);
        let open = three([false, true]);
        assert_eq!(judge(&mut r, &open).decision.verdict, Verdict::CannotTellApart);
        assert!(settled(&mut r, &open));
        assert!(settled(&mut r, &three([false, false])), "nothing running: settled");
    }

    /// Where `t`'s shape beats `h0`'s final model, `h1` decides: out, `t` beats every survivor and
    /// is named; in and not beaten by `t`, the three stay apart. Not settled: its runs go on.
    #[test]
    fn a_loop_whose_outcome_can_name_a_cause_is_not_settled() {
        let mut r = Table::with_t_against_h0(0.001);
        assert!(!settled(&mut r, &three([false, true])));
        let mut out = three([false, false]);
        out[2].lof.as_mut().unwrap().fits = false;
        assert_eq!(
            judge(&mut r, &out).decision.cause,
            Some(Who::Candidate(0)),
            "h1 out: t named"
        );
    }

    /// Settled for each running loop alone is not settled for both together: with `h0` and `h1`
    /// both out, `t` is named; with `h0` as it is (fits, not beaten), it is not.
    #[test]
    fn running_loops_are_settled_together() {
        let mut r = Table::with_t_against_h0(0.3);
        assert!(settled(&mut r, &three([false, true])));
        assert!(!settled(&mut r, &three([true, true])));
    }

    /// A loop model alone: whether it fits decides between a named cause and a partial one.
    #[test]
    fn a_lone_running_loop_is_not_settled() {
        let mut r = Table { p: Vec::new() };
        let mut one = open(0, 10.0, true, true);
        one.running = true;
        assert!(!settled(&mut r, &[one]));
    }

    /// Readings drawn at random: each pair's p, and whether something remains after each model.
    struct Drawn {
        p: Vec<(String, String, Option<f64>)>,
        remains: Vec<String>,
    }

    impl Readings for Drawn {
        fn alpha(&self) -> f64 {
            0.05
        }
        fn added_to(&mut self, e: &Open, f: &Open) -> Option<f64> {
            self.p
                .iter()
                .find(|(a, b, _)| *a == e.name && *b == f.name)
                .and_then(|x| x.2)
        }
        fn remains(&mut self, one: &Open) -> bool {
            self.remains.contains(&one.name)
        }
        fn rival(&self, _: &Open) -> Option<Who> {
            None
        }
        fn screening(&self) -> Decision {
            Table { p: Vec::new() }.screening()
        }
    }

    /// The n judgements of [`settled`] decide as every outcome enumerated does, on 3,000 drawn
    /// sets of open explanations (one to four, up to two of them running, screening candidates and
    /// loop models, fitting or missing, checked or not) and drawn readings; both classes occur.
    #[test]
    fn the_bounded_check_decides_as_the_enumeration() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(20261128);
        let (mut agree, mut settled_seen, mut open_seen) = (0, 0, 0);
        for _ in 0..3000 {
            let n = rng.random_range(1..=4usize);
            let mut open: Vec<Open> = (0..n)
                .map(|k| {
                    let mut o = open(
                        k,
                        rng.random_range(5.0..30.0),
                        rng.random_bool(0.6),
                        rng.random_bool(0.7),
                    );
                    if rng.random_bool(0.3) {
                        o.who = Who::Candidate(k);
                    }
                    o
                })
                .collect();
            let running = rng.random_range(0..=n.min(2));
            for o in open.iter_mut().take(running) {
                o.running = true;
            }
            let names: Vec<String> = open.iter().map(|o| o.name.clone()).collect();
            let mut p = Vec::new();
            for a in &names {
                for b in names.iter().filter(|b| *b != a) {
                    let v = [Some(0.001), Some(0.3), None][rng.random_range(0..3usize)];
                    p.push((a.clone(), b.clone(), v));
                }
            }
            let remains = names.iter().filter(|_| rng.random_bool(0.3)).cloned().collect();
            let mut r = Drawn { p, remains };
            let Some(expected) = settled_by_enumeration(&mut r, &open) else {
                continue;
            };
            let got = settled(&mut r, &open);
            assert_eq!(
                got,
                expected,
                "open: {:?}",
                open.iter()
                    .map(|o| (&o.name, o.running, o.checked, o.misses()))
                    .collect::<Vec<_>>()
            );
            agree += 1;
            if got && running > 0 {
                settled_seen += 1;
            } else if !got {
                open_seen += 1;
            }
        }
        assert!(agree > 2500, "{agree} cases compared");
        assert!(
            settled_seen > 20 && open_seen > 200,
            "settled {settled_seen}, not settled {open_seen}"
        );
    }
}
