//! The loop's policy over its stages: they take turns a batch each until each one's emulators are
//! within the tolerance; the tolerance is halved while the decision after the loop could still
//! change within the emulators' remaining error; a stage stops early where nothing its runs could
//! show would change the decision; and the emulators are checked by solver runs at the decision's
//! fitted point. Every question is asked of a typed provisional decision ([`Decided`]).

use super::stage::{Stage, latest_batches, usable_counts};
use super::{Event, Made, Reporter, Runner};
use crate::error::Error;
use crate::execute::RunStore;
use crate::execute::sweep::{Prepared, SweepResult};
use crate::pipeline::extend::JointRuns;
use crate::pipeline::runs::RunOutcomes;
use crate::plan::{PlannedRun, RunRole};

/// The most times the loop's tolerance is halved for a decision that its emulators' remaining error
/// could still change.
const TIGHTENINGS: usize = 3;

/// The most times the loop's emulators are checked by solver runs at the decision's fitted point.
const VERIFICATIONS: usize = 3;

/// The decision after the loop from provisional joint runs, with the emulators' error counted at
/// least at a floor (a share of the tests' noise variance) (`None`: no decision could be made).
pub type Decide<'d> = dyn FnMut(&JointRuns, f64) -> Option<Provisional> + 'd;

/// What of a decision may not change for the loop to stop: the verdict, the cause it names and the
/// explanation it calls partial.
#[derive(Debug, Clone, PartialEq)]
pub struct Decided {
    pub verdict: crate::diagnose::verdict::Verdict,
    pub cause: Option<String>,
    pub partial: Option<String>,
}

impl std::fmt::Display for Decided {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.verdict.words())?;
        if let Some(c) = &self.cause {
            write!(f, " '{c}'")?;
        }
        if let Some(p) = &self.partial {
            write!(f, ", '{p}' partly")?;
        }
        Ok(())
    }
}

/// A provisional decision after the loop: what may not change, and where it reads the emulators.
#[derive(Debug, Clone)]
pub struct Provisional {
    pub decided: Decided,
    /// Each looped hypothesis's fitted point.
    pub points: Vec<(usize, Fitted)>,
    /// Nothing the running loops' models may show would change the verdict or the cause
    /// ([`crate::diagnose::after_loop::AfterLoop::settled`]).
    pub settled: bool,
}

/// A looped hypothesis's fitted values (θ and its ranged variables, by name).
#[derive(Debug, Clone)]
pub struct Fitted {
    pub values: indexmap::IndexMap<String, f64>,
}

impl Fitted {
    /// The fitted point in the order of `names` (`None`: a variable the fit does not have).
    fn point(&self, names: &[String]) -> Option<Vec<f64>> {
        names.iter().map(|n| self.values.get(n).copied()).collect()
    }
}

/// What a check at the decision's fitted point did; per stage, whether the point was one
/// ([`Runner::verify`]).
enum Check {
    /// Runs placed there.
    Placed(Vec<bool>),
    /// Nothing to place: every stage already checked, or without a fitted point.
    Had(Vec<bool>),
    /// The runs do not fit in the budget.
    NoRoom,
}

/// The loop's stages: each hypothesis, its stage, and its edge at the baseline.
pub(super) type Stages<'s> = [(usize, Stage<'s>, Option<super::stage::Edge>)];

/// What the loop's policy reads: its stages and their edges at the baseline.
#[derive(Clone, Copy)]
struct Looping<'a, 's> {
    stages: &'a Stages<'s>,
    edges: &'a [(usize, Vec<(String, f64)>)],
}

impl Runner<'_> {
    /// The stages converged ([`Runner::converge`]), then checked at the decision's fitted point
    /// ([`Runner::verify`]) until the check passes ([`VERIFICATIONS`] times at most): the looped
    /// hypotheses whose latest fit no run checked.
    pub(super) fn converge_and_check(
        &mut self,
        stages: &Stages,
        edges: &[(usize, Vec<(String, f64)>)],
        decide: &mut Decide,
        store: &mut RunStore,
        reporter: &mut dyn Reporter,
    ) -> Result<Vec<usize>, Error> {
        let l = Looping { stages, edges };
        let mut decision = self.converge(l, decide, store, reporter)?;
        // The stages stop where the emulators are within the tolerance at the posterior; the decision
        // reads them at its own fitted point, which may lie where no run checked them (a fit that ends
        // at a bound, a feature the posterior weighs little). A run per tested design there, held out,
        // is the check; where it fails, the stages go on with it. A stage is checked when its runs at
        // the fitted point were the last it made and it converged with them held out: its emulators
        // (so its fit) are the ones the check passed.
        let mut checked = vec![false; stages.len()];
        for _ in 0..VERIFICATIONS {
            let Some(d) = decision.take() else { break };
            let at = match self.verify(stages, &d, &checked, store, reporter)? {
                Check::NoRoom => break,
                Check::Had(at) => {
                    checked = at;
                    break;
                }
                Check::Placed(at) => at,
            };
            let before = self.made.counts(stages);
            decision = self.converge(l, decide, store, reporter)?;
            let after = self.made.counts(stages);
            // Passed: no run since, because the stage converged with the check held out (not because
            // the budget stopped it).
            checked = stages
                .iter()
                .zip(at.iter().zip(before.iter().zip(&after)))
                .map(|((_, stage, _), (a, (b, c)))| *a && b == c && self.sequence.converged(&stage.name))
                .collect();
            if before == after {
                break;
            }
        }
        Ok(self.unchecked(stages, &checked, reporter))
    }

    /// The looped hypotheses whose latest fit no run checked; said of each not parked.
    fn unchecked(&self, stages: &Stages, checked: &[bool], reporter: &mut dyn Reporter) -> Vec<usize> {
        let unchecked: Vec<usize> = stages
            .iter()
            .zip(checked)
            .filter(|(_, c)| !**c)
            .map(|((k, _, _), _)| *k)
            .collect();
        for (k, stage, _) in stages {
            if !unchecked.contains(k) || self.parked.contains(&stage.id) {
                continue;
            }
            reporter.report(Event::Note(format!(
                "'{}': no solver run checked the loop's emulators at the decision's fitted point (or the last check \
                 missed and the budget left no room for another), so its fit there may be theirs: beside another \
                 explanation, the decision neither rejects it nor names it over that one",
                self.set.study().diagnosis.hypotheses[*k].name
            )));
        }
        unchecked
    }

    /// The loop's stages, taking turns a batch each (so that one hypothesis's loop, a wrong one
    /// chasing its own misfit, cannot spend the budget the others need), until each one's emulators
    /// are within the tolerance; the tolerance halved while the decision after the loop could still
    /// change within their remaining error ([`TIGHTENINGS`] times at most). The decision then, with
    /// the error as measured.
    fn converge(
        &mut self,
        l: Looping,
        decide: &mut Decide,
        store: &mut RunStore,
        reporter: &mut dyn Reporter,
    ) -> Result<Option<Provisional>, Error> {
        let mut round = 0;
        loop {
            self.take_turns(l, decide, store, reporter)?;
            if l.stages.is_empty() {
                return Ok(None);
            }
            let provisional = self.provisional(l);
            let measured = decide(&provisional, 0.0);
            if round == TIGHTENINGS || self.sequence.runs >= self.set.limits.budget {
                return Ok(measured);
            }
            let f = self.tolerance;
            let worst = decide(&provisional, f * f);
            let decided = |d: &Option<Provisional>| d.as_ref().map(|d| d.decided.clone());
            if decided(&measured) == decided(&worst) {
                return Ok(measured);
            }
            self.tolerance = f / 2.0;
            round += 1;
            let word = |d: Option<Decided>| d.map_or("no decision".to_string(), |d| d.to_string());
            reporter.report(Event::Note(format!(
                "the decision after the loop could still change within the emulators' remaining error ({} with it as \
                 measured, {} at the tolerance's worst case): the loop goes on at a tolerance of {}",
                word(decided(&measured)),
                word(decided(&worst)),
                self.tolerance
            )));
        }
    }

    /// One round of the stages taking turns, until none is open.
    fn take_turns(
        &mut self,
        l: Looping,
        decide: &mut Decide,
        store: &mut RunStore,
        reporter: &mut dyn Reporter,
    ) -> Result<(), Error> {
        let stages = l.stages;
        let mut open: Vec<bool> = stages
            .iter()
            .map(|(_, stage, _)| !self.parked.contains(&stage.id))
            .collect();
        while open.iter().any(|&o| o) {
            let mut settled = self.settled(l, &mut open, decide, reporter);
            for (i, (_, stage, _)) in stages.iter().enumerate() {
                if !open[i] {
                    continue;
                }
                open[i] = self.step(stage, settled, store, reporter)?.is_none();
                if settled && !self.sequence.converged(&stage.name) {
                    self.parked.push(stage.id);
                }
                // A stage that stopped leaves fewer running: where only stages yet to take their
                // turn in this round are open, they ask again before they run another batch.
                let later = open[i + 1..].iter().any(|&o| o) && !open[..=i].iter().any(|&o| o);
                if !settled && !open[i] && later {
                    settled = self.settled(l, &mut open, decide, reporter);
                }
            }
        }
        Ok(())
    }

    /// Whether nothing the still running stages' runs may show could change the decision: the
    /// provisional decision from the runs in hand, with the open and the parked stages' loop models
    /// running ([`crate::diagnose::after_loop`], step 6). When it holds, the open stages stop
    /// (`settled`) and join the parked; when it does not, the parked reopen, unless the decision is
    /// settled whatever the parked alone show (the others taken as they are).
    fn settled(&mut self, l: Looping, open: &mut [bool], decide: &mut Decide, reporter: &mut dyn Reporter) -> bool {
        let stages = l.stages;
        let ask = |this: &Self, running: &dyn Fn(usize, &Stage) -> bool, decide: &mut Decide| {
            let mut joint = this.provisional(l);
            joint.running = stages
                .iter()
                .enumerate()
                .filter(|(i, (_, stage, _))| running(*i, stage))
                .map(|(_, (k, _, _))| *k)
                .collect();
            decide(&joint, 0.0).is_some_and(|d| d.settled)
        };
        // Before the loop's own first runs the question waits a round: a stage stopped with none of
        // its own would leave its model fitted to the probes alone, unchecked by any run of its own.
        if !open.iter().any(|&o| o) || self.made.plan.runs.is_empty() {
            return false;
        }
        let all = |i: usize, stage: &Stage| open[i] || self.parked.contains(&stage.id);
        if ask(self, &all, decide) {
            let names: Vec<String> = stages
                .iter()
                .zip(open.iter())
                .filter(|(_, o)| **o)
                .map(|((k, _, _), _)| format!("'{}'", self.set.study().diagnosis.hypotheses[*k].name))
                .collect();
            reporter.report(Event::Note(format!(
                "{}: whatever the loop's further runs would show of {}, the verdict and the cause after the loop \
                 are the same: those runs are not made (its fit stays unchecked, and beside another explanation the \
                 decision neither rejects it nor names it over that one)",
                names.join(", "),
                if names.len() == 1 { "its model" } else { "their models" }
            )));
            return true;
        }
        let parked = |_: usize, stage: &Stage| self.parked.contains(&stage.id);
        if !self.parked.is_empty() && !ask(self, &parked, decide) {
            for ((_, stage, _), o) in stages.iter().zip(open.iter_mut()) {
                if self.parked.contains(&stage.id) {
                    *o = true;
                }
            }
            self.parked.clear();
        }
        false
    }

    /// Runs at the provisional decision's fitted point (`d`), one per tested design, as a batch of
    /// each looped stage's own: held out when the stage next assesses its emulators, they measure
    /// the emulators' error where the decision reads them. A stage already `checked` (no run of its
    /// own since its last check, which it passed) is not run again: its emulators, so its fit, are
    /// the ones that check measured.
    fn verify(
        &mut self,
        stages: &Stages,
        d: &Provisional,
        checked: &[bool],
        store: &mut RunStore,
        reporter: &mut dyn Reporter,
    ) -> Result<Check, Error> {
        let (at, placed) = self.fitted_point_runs(stages, d, checked);
        let n: usize = placed.iter().map(|(_, runs)| runs.len()).sum();
        if n == 0 {
            return Ok(Check::Had(at));
        }
        let budget = self.set.limits.budget;
        if self.sequence.runs + n > budget {
            reporter.report(Event::Note(format!(
                "the loop's emulators were not checked by solver runs at the decision's fitted point: the {n} run(s) \
                 it takes do not fit in the budget ({} of {budget} spent)",
                self.sequence.runs
            )));
            return Ok(Check::NoRoom);
        }
        for (stage, runs) in placed {
            let b = self.made.next_batch();
            self.batch(stage, runs, b, store, reporter)?;
            if let Some(last) = self.sequence.sequence.last_mut() {
                last.placed = Some(super::Placed::FittedPoint);
            }
        }
        self.sequence.write(&self.set.cx.options.out)?;
        Ok(Check::Placed(at))
    }

    /// The runs at the decision's fitted point of every stage not yet checked nor parked (a parked
    /// stage is not checked: nothing its fit shows could change the decision), and per stage
    /// whether it will be checked.
    fn fitted_point_runs<'s, 'b>(
        &self,
        stages: &'b Stages<'s>,
        d: &Provisional,
        checked: &[bool],
    ) -> (Vec<bool>, Vec<(&'b Stage<'s>, Vec<PlannedRun>)>) {
        let mut at = checked.to_vec();
        let mut placed = Vec::new();
        for (i, (k, stage, _)) in stages.iter().enumerate() {
            if checked[i] || self.parked.contains(&stage.id) {
                continue;
            }
            let Some(x) = d
                .points
                .iter()
                .find(|(j, _)| j == k)
                .and_then(|(_, f)| f.point(&stage.names))
            else {
                continue;
            };
            let runs: Vec<PlannedRun> = self
                .set
                .tests
                .designs
                .iter()
                .map(|t| stage.run_at(self.set.sim(), &t.name, &t.values, &x))
                .collect();
            at[i] = true;
            placed.push((stage, runs));
        }
        (at, placed)
    }

    /// The loop's runs so far as joint runs, each stage's latest batch per design as its checks,
    /// for a provisional decision (read from what the batches left, nothing swept again).
    fn provisional(&self, l: Looping) -> JointRuns {
        let Made {
            plan,
            batch_of,
            responses,
            rendered,
            ..
        } = &self.made;
        let mut plan = plan.clone();
        let names: Vec<String> = self.set.tests.designs.iter().map(|t| t.name.clone()).collect();
        for (k, stage, _) in l.stages {
            let prior = usable_counts(&stage.prior);
            for i in latest_batches(&plan, batch_of, &|r| stage.mine(r), &names, &prior, self.least(stage)) {
                plan.runs[i].role = RunRole::JointCheck(*k);
            }
        }
        let n = plan.runs.len();
        let keys = rendered.as_ref().map_or_else(Vec::new, |r| r.keys.clone());
        JointRuns {
            plan,
            rendered: Prepared {
                keys,
                ..super::empty_prepared()
            },
            swept: SweepResult {
                responses: responses.clone(),
                classes: vec![None; n],
                quality: vec![None; n],
                reused: 0,
                errors: Vec::new(),
            },
            outcomes: RunOutcomes::default(),
            flags: vec![Vec::new(); n],
            usable: responses.clone(),
            edges: l.edges.to_vec(),
            unchecked: Vec::new(),
            running: Vec::new(),
        }
    }
}
