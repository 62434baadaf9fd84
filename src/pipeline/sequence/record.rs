//! What each batch bought: `results.json` `sampling.sequence`, and `OUT/sequence.json`, written
//! before a batch starts and after it ends, so that `lab status` shows the batches done and the one
//! in flight.

use std::path::Path;

use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

use super::stage::StopReason;
use crate::error::Error;
use crate::pipeline::runs::RunOutcomes;
use crate::plan::sweep::fixed_runs;
use crate::plan::{Plan, PlannedRun, RunRole};
use crate::study::solver::Sampling;
use crate::study::{SolverSimulation, Study};

/// `OUT/sequence.json`.
pub const FILE: &str = "sequence.json";

/// The whole sequence of a study (`results.json` `sampling`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Sequence {
    pub method: String,
    /// Solver runs in all.
    pub runs: usize,
    /// One entry per batch, in order.
    pub sequence: Vec<Batch>,
    /// Why each stage stopped.
    pub stopped: Vec<Stop>,
    /// The tolerance: the emulators' error allowed at the posterior, as a fraction of the tests'
    /// noise of the mean.
    pub tolerance: f64,
    /// The fixed design the study names as the one this sequence replaces, and its runs
    /// (`sampling.replaces`; absent when the study names none).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub replaces: Option<Replaced>,
    /// The planned runs of every batch, for `lab status` (not in `results.json`).
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub planned: Vec<Planned>,
}

/// One batch: its runs and what the emulators and the posterior said once they were in.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Batch {
    /// `screening`, `probes`, or `loop: <hypothesis>`.
    pub stage: String,
    /// 0 for a stage's initial design.
    pub batch: usize,
    /// `done`, or `in flight` (written before the batch's runs start).
    pub state: BatchState,
    /// Its runs, and the runs so far (its keys inline).
    #[serde(flatten)]
    pub count: BatchCount,
    /// Runs per tested design in this batch.
    pub designs: IndexMap<String, usize>,
    /// The emulators' error once the batch was in (its keys inline).
    #[serde(flatten)]
    pub errors: BatchErrors,
    /// The posterior once the batch was in (its keys inline).
    #[serde(flatten)]
    pub posterior: BatchPosterior,
    /// Wall time the planner took to choose this batch (fitting the emulators and the posterior on
    /// the runs in hand, then the batch), seconds; 0 for a stage's fixed start.
    #[serde(default)]
    pub planning_seconds: f64,
    /// Why the stage's sequence stopped after this batch (as `stopped`); absent while it goes on.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub stopped: Option<StopReason>,
    /// Where the batch was placed when not by the planner: `the decision's fitted point` for a
    /// loop's runs at its provisional decision's fitted values, one per tested design, that check
    /// its emulators where the decision reads them.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub placed: Option<Placed>,
}

/// A batch's runs, the runs so far of every stage, and the batch's runs that failed.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct BatchCount {
    pub runs: usize,
    /// Runs so far, every stage.
    pub total: usize,
    /// The batch's runs that failed (the stage went on without them), in plan order.
    #[serde(default)]
    pub failed: Vec<Failed>,
    /// Solver starts its runs took, retries included, where more than its runs.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub attempts: Option<usize>,
}

/// A run that failed, as `sequence.json` and `results.json` keep it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Failed {
    pub design: String,
    /// Its calibration parameters and, for an extension's run, the extension's variables.
    pub parameters: IndexMap<String, f64>,
    pub key: String,
    pub outcome: crate::execute::OutcomeClass,
    /// The outcome in words: the adapter's file:line where it names one.
    pub detail: String,
    /// Replayed from a recording of a run that succeeded: the recording is damaged.
    #[serde(skip_serializing_if = "std::ops::Not::not", default)]
    pub damaged: bool,
}

/// The emulators' error per tested design once a batch was in.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct BatchErrors {
    /// Per tested design: the emulators' error on its latest runs, fitted without them, in units of
    /// the tests' noise of the mean (`null`: nothing held out yet).
    pub emulator_error: IndexMap<String, Option<f64>>,
    /// Per tested design: the emulators' own predictive error at the posterior, same units
    /// (`null`: it cannot be computed, no run of the design finished).
    pub predicted_error: IndexMap<String, Option<f64>>,
    /// Per tested design, where the screening read only the measured error its parameters cannot
    /// absorb (the uncorrected model's misfit standing with it; [`super::absorbed`]): that error,
    /// same units, which decided instead of `emulator_error`. Absent otherwise.
    #[serde(skip_serializing_if = "IndexMap::is_empty", default)]
    pub unabsorbed_error: IndexMap<String, Option<f64>>,
}

/// The posterior's mean and 95 % interval of each variable of the space once a batch was in.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct BatchPosterior {
    pub estimates: IndexMap<String, f64>,
    pub interval95: IndexMap<String, [f64; 2]>,
}

/// Where a batch stands: `in flight` (written before its runs start) or `done`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum BatchState {
    #[serde(rename = "in flight")]
    InFlight,
    #[serde(rename = "done")]
    Done,
}

/// Where a batch was placed when not by the planner.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Placed {
    /// A loop's runs at its provisional decision's fitted values, one per tested design, that check
    /// its emulators where the decision reads them.
    #[serde(rename = "the decision's fitted point")]
    FittedPoint,
}

impl Placed {
    pub fn words(self) -> &'static str {
        match self {
            Placed::FittedPoint => "the decision's fitted point",
        }
    }
}

/// The fixed design a sequence replaces: what it is, and the solver runs it would have made
/// (counted from its plan, never run; [`crate::plan::sweep::fixed_runs`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Replaced {
    /// `lhs` or `grid`.
    pub method: String,
    /// Samples per design.
    pub count: usize,
    /// Check runs per design.
    pub check_runs: usize,
    /// Solver runs in all: samples, checks, the extension hypotheses' runs, and the loop's joint
    /// plan for the hypotheses the sequence took into the loop.
    pub runs: usize,
}

impl Replaced {
    /// The study's `sampling.replaces` (`None` when it names none), counted with the hypotheses the
    /// sequence took into the loop (those with runs in `joint`) and the `confirmation` runs, which the
    /// fixed design makes alike (the same models at their fitted parameters, one run per design).
    pub fn of(study: &Study, sim: &SolverSimulation, joint: Option<&Plan>, confirmation: usize) -> Option<Replaced> {
        let fixed = sim.sampling.sequential.as_ref()?.replaces.as_deref()?;
        let mut looped: Vec<usize> = joint
            .map(|p| {
                p.runs.iter().filter_map(|r| match r.role {
                    RunRole::Joint(k) | RunRole::JointCheck(k) => Some(k),
                    _ => None,
                })
            })
            .into_iter()
            .flatten()
            .collect();
        looped.sort_unstable();
        looped.dedup();
        let mut replaced = Replaced::counted(study, sim, fixed, &looped);
        replaced.runs += confirmation;
        Some(replaced)
    }

    /// The fixed design `fixed`, its runs counted with the solver in the loop for `looped`.
    pub fn counted(study: &Study, sim: &SolverSimulation, fixed: &Sampling, looped: &[usize]) -> Replaced {
        Replaced {
            method: fixed.method.key().into(),
            count: fixed.count,
            check_runs: fixed.check_runs,
            runs: fixed_runs(study, sim, fixed, looped),
        }
    }

    /// How the terminal, the summary and the report name it: `fixed lhs of 24 + 5 check runs per
    /// design`.
    pub fn design(&self) -> String {
        format!(
            "fixed {} of {} + {} check runs per design",
            self.method, self.count, self.check_runs
        )
    }
}

/// Why a stage's sequence stopped.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stop {
    pub stage: String,
    /// `converged` (the emulators' error at the posterior within the tolerance at every tested
    /// design), `settled`, `budget` (the runs allowed are spent), `nowhere to run`, `failures`
    /// (its latest batches' runs all failed), or `planned` (a stage of fixed size).
    pub reason: StopReason,
    /// Its runs, the failed ones included.
    pub runs: usize,
    /// Of those, the runs that failed.
    #[serde(default)]
    pub failed: usize,
}

/// A planned run as `sequence.json` keeps it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Planned {
    pub design: String,
    pub design_values: Vec<f64>,
    pub theta: Vec<f64>,
    pub role: String,
    pub hypothesis: Option<usize>,
    pub extension: Vec<(String, f64)>,
    /// The run's seed ([`PlannedRun::seed`]; absent: 0).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub seed: usize,
}

fn is_zero(seed: &usize) -> bool {
    *seed == 0
}

impl Planned {
    pub fn of(run: &PlannedRun) -> Planned {
        let hypothesis = match run.role {
            RunRole::Extension(k) | RunRole::Joint(k) | RunRole::JointCheck(k) | RunRole::NotExcluded(k) => Some(k),
            _ => None,
        };
        Planned {
            design: run.design.clone(),
            design_values: run.design_values.clone(),
            theta: run.theta.clone(),
            role: run.role.key().to_string(),
            hypothesis,
            extension: run.extension.clone(),
            seed: run.seed,
        }
    }

    pub fn run(&self) -> PlannedRun {
        let k = self.hypothesis.unwrap_or(0);
        let role = match self.role.as_str() {
            "check" => RunRole::Check,
            "extension" => RunRole::Extension(k),
            "joint" => RunRole::Joint(k),
            "joint_check" => RunRole::JointCheck(k),
            "confirmation" => RunRole::Confirm,
            "not_excluded" => RunRole::NotExcluded(k),
            _ => RunRole::Sample,
        };
        PlannedRun {
            design: self.design.clone(),
            design_values: self.design_values.clone(),
            theta: self.theta.clone(),
            role,
            extension: self.extension.clone(),
            seed: self.seed,
        }
    }
}

/// The solver starts of the runs `keys` (each key once), where a retry made them more than the
/// runs; `None` otherwise.
pub fn retried(store: &crate::execute::RunStore, keys: &[String]) -> Option<usize> {
    let unique: std::collections::BTreeSet<&String> = keys.iter().collect();
    let attempts: usize = (unique.iter())
        .map(|k| store.record(k).map_or(1, |r| r.attempts as usize))
        .sum();
    (attempts > unique.len()).then_some(attempts + keys.len() - unique.len())
}

impl Failed {
    /// A batch's failed runs as the sequence's record keeps them.
    pub fn of(outcomes: &RunOutcomes) -> Vec<Failed> {
        outcomes
            .failed
            .iter()
            .map(|f| Failed {
                design: f.design.clone(),
                parameters: f.parameters.clone(),
                key: f.key.clone(),
                outcome: f.class,
                detail: f.why.clone(),
                damaged: f.damaged,
            })
            .collect()
    }
}

impl Sequence {
    /// Records that `stage` stopped for `reason` after `runs` runs, on the stage's last batch too.
    pub fn stop(&mut self, stage: &str, reason: StopReason, runs: usize) {
        if let Some(last) = self.sequence.iter_mut().rev().find(|b| b.stage == stage) {
            last.stopped = Some(reason);
        }
        // A stage stopped again (the loop's tolerance tightened, or its emulators checked at the
        // decision's fitted point) has one stop: its last.
        self.stopped.retain(|s| s.stage != stage);
        let failed = self.failed_in(stage);
        self.stopped.push(Stop {
            stage: stage.to_string(),
            reason,
            runs,
            failed,
        });
    }

    /// The runs of `stage` that failed, every batch.
    pub fn failed_in(&self, stage: &str) -> usize {
        self.sequence
            .iter()
            .filter(|b| b.stage == stage)
            .map(|b| b.count.failed.len())
            .sum()
    }

    /// Whether every run of `stage`'s latest two batches failed (of its only one, when it has one).
    pub fn failing(&self, stage: &str) -> bool {
        let mine: Vec<&Batch> = self.sequence.iter().filter(|b| b.stage == stage).collect();
        let latest = &mine[mine.len().saturating_sub(2)..];
        !latest.is_empty()
            && latest
                .iter()
                .all(|b| b.count.runs > 0 && b.count.failed.len() == b.count.runs)
    }

    /// Solver starts in all, retries included (`runs` when no run was retried).
    pub fn attempts(&self) -> usize {
        self.sequence
            .iter()
            .map(|b| b.count.attempts.unwrap_or(b.count.runs))
            .sum()
    }

    /// The runs that failed, every stage.
    pub fn failed(&self) -> usize {
        self.sequence.iter().map(|b| b.count.failed.len()).sum()
    }

    /// Whether `stage` last stopped with its emulators within the tolerance.
    pub fn converged(&self, stage: &str) -> bool {
        self.stopped
            .iter()
            .any(|s| s.stage == stage && s.reason == StopReason::Converged)
    }

    /// Writes `OUT/sequence.json` (atomically).
    pub fn write(&self, out: &Path) -> Result<(), Error> {
        let bytes = serde_json::to_vec_pretty(self).map_err(|e| Error::Failed(e.to_string()))?;
        crate::execute::store::write_atomic(&out.join(FILE), &bytes)
            .map_err(|e| Error::Failed(format!("{}: {e}", out.join(FILE).display())))
    }

    /// `OUT/sequence.json` as the last `lab run` left it (`None`: none yet).
    pub fn read(out: &Path) -> Option<Sequence> {
        serde_json::from_slice(&std::fs::read(out.join(FILE)).ok()?).ok()
    }

    /// The record as `results.json` gives it (without the planned runs).
    pub fn for_results(&self) -> Sequence {
        Sequence {
            planned: Vec::new(),
            ..self.clone()
        }
    }
}

impl Sequence {
    /// Records a batch of fixed size (no planner chose it) of `stage` before its runs start.
    pub fn planned_batch(&mut self, stage: &str, plan: &Plan, out: &Path) -> Result<(), Error> {
        let b = self.sequence.last().map_or(0, |l| l.batch + 1);
        self.planned.extend(plan.runs.iter().map(Planned::of));
        self.runs += plan.runs.len();
        self.sequence.push(Batch::in_flight(stage, plan, b, self.runs, 0.0));
        self.write(out)
    }

    /// `stage`'s batch of fixed size done with its `runs` runs, `failed` of them failed: stopped as
    /// planned; the batch.
    pub fn finish_planned(
        &mut self,
        stage: &str,
        (runs, failed): (usize, Vec<Failed>),
        out: &Path,
    ) -> Result<Option<&Batch>, Error> {
        if let Some(last) = self.sequence.last_mut() {
            last.state = BatchState::Done;
            last.count.failed = failed;
        }
        // A planned stage may come in several batches (the rounds over an amplitude, a confirmation
        // after a loop that started late): its stop counts them all.
        let earlier: usize = (self.sequence.iter().rev().skip(1))
            .filter(|b| b.stage == stage)
            .map(|b| b.count.runs)
            .sum();
        self.stop(stage, StopReason::Planned, earlier + runs);
        self.write(out)?;
        Ok(self.sequence.last())
    }
}

impl Batch {
    /// The record of batch `b` of stage `stage` before its runs start (`total`: runs so far, every
    /// stage; `planning`: what choosing it took).
    pub fn in_flight(stage: &str, batch: &Plan, b: usize, total: usize, planning: f64) -> Batch {
        let mut designs = IndexMap::new();
        for r in &batch.runs {
            *designs.entry(r.design.clone()).or_insert(0) += 1;
        }
        Batch {
            stage: stage.to_string(),
            batch: b,
            state: BatchState::InFlight,
            count: BatchCount {
                runs: batch.runs.len(),
                total,
                failed: Vec::new(),
                attempts: None,
            },
            designs,
            errors: Default::default(),
            posterior: Default::default(),
            stopped: None,
            planning_seconds: planning,
            placed: None,
        }
    }

    /// The batch done: per tested design (`designs`) the emulators' measured and predicted errors,
    /// and the posterior's mean and interval of each variable (`names`).
    pub fn done(
        &mut self,
        designs: &[String],
        (measured, predicted): (&[Option<f64>], &[f64]),
        unabsorbed: Option<&[Option<f64>]>,
        names: &[String],
        posterior: &crate::emulate::sequential::Posterior,
    ) {
        self.state = BatchState::Done;
        for (d, (m, p)) in designs.iter().zip(measured.iter().zip(predicted)) {
            self.errors.emulator_error.insert(d.clone(), *m);
            self.errors
                .predicted_error
                .insert(d.clone(), p.is_finite().then_some(*p));
        }
        for (d, u) in designs.iter().zip(unabsorbed.into_iter().flatten()) {
            self.errors.unabsorbed_error.insert(d.clone(), *u);
        }
        for (j, n) in names.iter().enumerate() {
            self.posterior.estimates.insert(n.clone(), posterior.mean[j]);
            self.posterior.interval95.insert(n.clone(), posterior.interval[j]);
        }
    }

    /// The tested design whose emulators are furthest from the tests' noise after this batch (by
    /// the larger of measured and predicted error; nothing held out counts as furthest), with its
    /// measured error (`None`: nothing held out yet) and its predicted one (`None`: no run of the
    /// design finished).
    pub fn worst(&self) -> Option<(&str, Option<f64>, Option<f64>)> {
        let size = |(_, m, p): &(&str, Option<f64>, Option<f64>)| match (m, p) {
            (Some(m), Some(p)) => m.max(*p),
            _ => f64::INFINITY,
        };
        self.errors
            .emulator_error
            .iter()
            .map(|(d, m)| (d.as_str(), *m, self.errors.predicted_error.get(d).copied().flatten()))
            .max_by(|a, b| size(a).total_cmp(&size(b)))
    }

    /// One line for the terminal: the batch, its runs, the worst emulator error and the estimates.
    pub fn line(&self) -> String {
        // The largest over the designs measured; those not measured are counted apart (an infinite
        // "error" would say nothing the engineer can act on): nothing held out yet, or the runs held
        // out at the design all failed.
        let measured: Vec<f64> = self.errors.emulator_error.values().flatten().copied().collect();
        let unmeasured: Vec<&String> = (self.errors.emulator_error.iter())
            .filter(|(_, m)| m.is_none())
            .map(|(d, _)| d)
            .collect();
        // Held out at a design are this batch's runs there: unmeasured because they failed when
        // every one of them failed.
        let failed_at = |d: &String| {
            let failed = self.count.failed.iter().filter(|f| f.design == *d).count();
            failed > 0 && failed == self.designs.get(d).copied().unwrap_or(0)
        };
        let (failed, unheld) = (
            unmeasured.iter().filter(|d| failed_at(d)).count(),
            unmeasured.iter().filter(|d| !failed_at(d)).count(),
        );
        let mut apart = Vec::new();
        if unheld > 0 {
            apart.push(format!("{unheld} design(s) with nothing held out yet"));
        }
        if failed > 0 {
            apart.push(format!("{failed} design(s) whose runs held out failed"));
        }
        let error = match (measured.is_empty(), failed) {
            (true, 0) => "nothing held out yet".to_string(),
            (true, _) => format!("emulator error not measured ({})", apart.join(", ")),
            (false, _) => {
                let worst = measured.iter().copied().fold(0.0, f64::max);
                let rest = match apart.is_empty() {
                    true => String::new(),
                    false => format!(" ({})", apart.join(", ")),
                };
                format!(
                    "emulator error ≤ {} of the tests' noise{rest}",
                    crate::base::format::num(worst)
                )
            }
        };
        let estimates: Vec<String> = self
            .posterior
            .estimates
            .iter()
            .map(|(n, v)| match self.posterior.interval95.get(n) {
                Some([lo, hi]) => format!(
                    "{n} {} [{}, {}]",
                    crate::base::format::num(*v),
                    crate::base::format::num(*lo),
                    crate::base::format::num(*hi)
                ),
                None => format!("{n} {}", crate::base::format::num(*v)),
            })
            .collect();
        let placed = self.placed.map_or_else(String::new, |p| format!(" at {}", p.words()));
        let mut line = format!(
            "{} batch {}: {} run(s){placed}, {} in all; {error}",
            self.stage, self.batch, self.count.runs, self.count.total
        );
        if !estimates.is_empty() {
            line += &format!("; {}", estimates.join(", "));
        }
        if !self.count.failed.is_empty() {
            line += &format!("; {} failed", self.count.failed.len());
        }
        if let Some(reason) = self.stopped {
            line += &format!("; stopped: {}", reason.key());
        }
        line
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn batch(stage: &str, runs: usize, failed: usize) -> Batch {
        let mut b = Batch::in_flight(stage, &Plan { runs: Vec::new() }, 0, 0, 0.0);
        b.count.runs = runs;
        let f = Failed {
            design: "d".into(),
            parameters: IndexMap::new(),
            key: "k".into(),
            outcome: crate::execute::OutcomeClass::Timeout,
            detail: "timeout".into(),
            damaged: false,
        };
        b.count.failed = vec![f; failed];
        b
    }

    /// A planned stage run in two batches (two rounds over an amplitude, a second confirmation)
    /// stops once, with the runs of both; another stage between them is its own.
    #[test]
    fn a_planned_stage_in_two_batches_stops_with_the_runs_of_both() {
        let dir = tempfile::tempdir().unwrap();
        let mut s = Sequence::default();
        let plan = |n: usize| Plan {
            runs: vec![
                crate::plan::PlannedRun {
                    design: "d".into(),
                    design_values: vec![1.0],
                    theta: vec![2.0],
                    role: crate::plan::RunRole::Confirm,
                    extension: Vec::new(),
                    seed: 0,
                };
                n
            ],
        };
        for (stage, n) in [("not_excluded", 7), ("confirmation", 9), ("not_excluded", 14)] {
            s.planned_batch(stage, &plan(n), dir.path()).unwrap();
            s.finish_planned(stage, (n, Vec::new()), dir.path()).unwrap();
        }
        let runs = |stage: &str| s.stopped.iter().find(|x| x.stage == stage).map(|x| x.runs);
        assert_eq!(runs("not_excluded"), Some(21));
        assert_eq!(runs("confirmation"), Some(9));
        assert_eq!(s.stopped.len(), 2);
        assert_eq!(s.runs, 30);
    }

    #[test]
    fn a_stage_is_failing_when_its_latest_two_batches_all_failed() {
        let with = |batches: Vec<Batch>| Sequence {
            sequence: batches,
            ..Sequence::default()
        };
        assert!(!with(vec![]).failing("s"));
        assert!(with(vec![batch("s", 12, 12)]).failing("s"));
        assert!(!with(vec![batch("s", 12, 11)]).failing("s"));
        assert!(!with(vec![batch("s", 12, 3), batch("s", 3, 3)]).failing("s"));
        assert!(
            with(vec![
                batch("s", 12, 3),
                batch("s", 3, 3),
                batch("t", 3, 0),
                batch("s", 3, 3)
            ])
            .failing("s")
        );
        assert!(!with(vec![batch("s", 3, 3), batch("s", 3, 2)]).failing("s"));
        let s = with(vec![batch("s", 12, 3), batch("t", 3, 1), batch("s", 3, 2)]);
        assert_eq!((s.failed_in("s"), s.failed_in("t"), s.failed()), (5, 1, 6));
    }
}
