//! The plan → execute → fit loop of a study sampled sequentially (`sampling.method: sequential`),
//! written once for its two uses: the screening's runs over θ, and the solver-in-the-loop's runs of
//! an extension over θ and its ranged variables.
//!
//! ```text
//! initial design ─► sweep ─► sites (runs, tests) ─► emulators, posterior ─► Stage::next ─┬─► Stop(reason)
//!        ▲                                                                                │
//!        └──────────────── sweep ◄── the next batch (emulate::sequential::choose) ◄───────┘
//! ```
//!
//! A stage ([`stage::Stage`]) is a value: given what the runs in hand showed, it returns the next
//! batch or a typed reason to stop. One driver ([`Runner`]) runs its batches, records them in
//! `sequence.json` and reports each as an event; what it reads and never changes ([`Settings`]) is
//! kept apart from the runs it has made ([`Made`]). The loop's policy over its stages — taking
//! turns, the tolerance tightened while the decision could still change, the check at the
//! decision's fitted point — is [`converge`], decided on typed decisions ([`Decided`]).
//!
//! Each batch is planned from the finished runs' results, the study and the seed alone, so that a
//! `lab run` after an interrupt plans the same batches again and finds their runs finished in the
//! store (or in the recordings, with `--replay`): the sequence resumes exactly. Every batch goes
//! through the same sweep as a fixed plan ([`super::runs::sweep_plan`]): the local executor, Slurm
//! (one batch submitted at a time) or a replay.
//!
//! Once a stage stops, each design's latest batch becomes its check runs (`RunRole::Check`, or
//! `JointCheck` in the loop): the emulators the rest of the pipeline fits are the ones whose error
//! was measured on runs they were not fitted to. Between the screening and the loop, the
//! extension hypotheses' probe runs are placed at the screening's posterior (its mode, and a
//! standard deviation along each parameter), not one per baseline sample.

pub mod absorbed;
mod converge;
pub mod record;
pub mod sites;
pub mod stage;

use nalgebra::DVector;

use super::runs::{self, Executed, RunContext, RunOutcomes, Source};
use super::{Event, Reporter, curves};
use crate::emulate::sequential::{self as seq, Posterior};
use crate::error::Error;
use crate::execute::RunStore;
use crate::execute::sweep::{self, Prepared};
use crate::plan::{Plan, PlannedRun, RunRole};
use crate::study::{SolverSimulation, Study};
pub use converge::{Decide, Decided, Fitted, Provisional};
pub use record::{Batch, BatchState, Placed, Sequence, Stop};
use sites::{RunData, Tests};
use stage::{
    Assessed, Limits, Next, PROBE_RETRIES, Stage, StageId, fnv, latest_batches, probe_points, probe_replacement,
    run_at, usable_counts,
};
pub use stage::{ScreeningRuns, StopReason};

/// The screening of a sequential study: the plan it made (samples, the latest batch per design as
/// checks, the probes), its runs, and the record of its batches.
pub struct Screened {
    pub plan: Plan,
    pub rendered: Prepared,
    pub executed: Executed,
    pub sequence: Sequence,
}

/// The pipeline's reporter without the per-sweep outcome tables: a batch is one line
/// ([`Event::Batch`]); the stage's table comes once at its end.
struct Quiet<'r>(&'r mut dyn Reporter);

impl Reporter for Quiet<'_> {
    fn report(&mut self, event: Event<'_>) {
        if !matches!(event, Event::RunsEnded(_)) {
            self.0.report(event);
        }
    }

    fn progress(&mut self, runs: u64) -> indicatif::ProgressBar {
        self.0.progress(runs)
    }
}

/// What the loop reads and never changes: where and how its runs are made, the tests in the
/// planner's units, the curves' setting, and how it may spend runs.
struct Settings<'a> {
    cx: RunContext<'a>,
    tests: Tests,
    setting: Option<curves::Setting>,
    limits: Limits,
}

impl<'a> Settings<'a> {
    fn of(cx: RunContext<'a>) -> Settings<'a> {
        let (study, sim) = (cx.study, cx.sim);
        let q = sim.sampling.sequential.as_ref().expect("a sequential study");
        let setting = curves::Setting::of(study);
        let specimens = setting.map(|s| curves::specimens(study, &s));
        Settings {
            tests: Tests::of(study, specimens.as_deref().zip(setting.map(|s| s.spec))),
            setting,
            limits: Limits {
                batch: q.batch.unwrap_or(cx.options.jobs).max(1),
                budget: crate::plan::sweep::sequential_budget(study, sim).expect("a sequential study"),
                seed: sim.sampling.seed,
            },
            cx,
        }
    }

    fn study(&self) -> &'a Study {
        self.cx.study
    }

    fn sim(&self) -> &'a SolverSimulation {
        self.cx.sim
    }
}

/// The runs made so far, in order: the batch each came in, its response and its curve, their
/// rendering and how they ended.
struct Made {
    plan: Plan,
    batch_of: Vec<usize>,
    responses: Vec<Option<f64>>,
    curves: Vec<Option<DVector<f64>>>,
    /// Every run's rendering so far (the meshes are made once).
    rendered: Option<Prepared>,
    outcomes: RunOutcomes,
}

impl Made {
    fn new(rendered: Option<Prepared>) -> Made {
        Made {
            plan: Plan { runs: Vec::new() },
            batch_of: Vec::new(),
            responses: Vec::new(),
            curves: Vec::new(),
            rendered,
            outcomes: RunOutcomes::default(),
        }
    }

    /// The latest batch of a stage's own runs (0 before any).
    fn stage_batch(&self, stage: &Stage) -> usize {
        self.plan
            .runs
            .iter()
            .zip(&self.batch_of)
            .filter(|(run, _)| stage.mine(run))
            .map(|(_, b)| *b)
            .max()
            .unwrap_or(0)
    }

    /// The next batch's number: after every stage's (so that stages may take turns).
    fn next_batch(&self) -> usize {
        self.batch_of.last().map_or(0, |b| b + 1)
    }

    /// Each stage's own runs so far.
    fn counts(&self, stages: &converge::Stages) -> Vec<usize> {
        stages
            .iter()
            .map(|(_, stage, _)| self.plan.runs.iter().filter(|r| stage.mine(r)).count())
            .collect()
    }
}

/// The driver: runs a stage's batches, records them, reports them.
struct Runner<'a> {
    set: Settings<'a>,
    made: Made,
    sequence: Sequence,
    /// Wall time of the planner (assessing the runs in hand and choosing the next batch), seconds.
    planning: f64,
    /// The emulators' error allowed at the posterior, as a fraction of the tests' noise of the mean:
    /// the study's, halved by the loop while the decision could still change within it.
    tolerance: f64,
    /// The loop's stages stopped because nothing their runs could show would change the decision
    /// ([`converge`]); reopened when that no longer holds.
    parked: Vec<StageId>,
}

/// The screening's runs, sampled sequentially, then the probes (see the module notes).
pub fn screening(cx: RunContext, reporter: &mut dyn Reporter) -> Result<Screened, Error> {
    let (study, sim) = (cx.study, cx.sim);
    let mut store = crate::execute::open_store(&cx.options.out)?;
    let mut r = Runner::new(Settings::of(cx), Sequence::default(), None);
    let reserve = crate::plan::sweep::SequenceFloor::of(study, sim).map_or(0, |f| f.reserve());
    let stage = Stage::screening(study, reserve);
    r.batch(&stage, Plan::initial(study, sim).runs, 0, &mut store, reporter)?;
    let posterior = r.iterate(&stage, &mut store, reporter)?;
    r.mark_checks(&stage, RunRole::Check);
    r.probes(&posterior, &mut store, reporter)?;
    let (plan, rendered, swept, outcomes) = r.finish(&store, reporter)?;
    let replay = match cx.source {
        Source::Replay(dir) => Some(dir.clone()),
        _ => None,
    };
    Ok(Screened {
        plan,
        rendered,
        executed: Executed {
            store,
            swept,
            outcomes,
            replay,
        },
        sequence: r.sequence,
    })
}

impl<'a> Runner<'a> {
    fn new(set: Settings<'a>, mut sequence: Sequence, rendered: Option<Prepared>) -> Runner<'a> {
        let tolerance = set
            .sim()
            .sampling
            .sequential
            .as_ref()
            .expect("a sequential study")
            .tolerance;
        sequence.method = "sequential".into();
        sequence.tolerance = tolerance;
        Runner {
            set,
            made: Made::new(rendered),
            sequence,
            planning: 0.0,
            tolerance,
            parked: Vec::new(),
        }
    }

    /// Renders and runs `new` as batch `b` of the stage, records it, and reads its responses and
    /// curves; the batch's runs that failed.
    fn batch(
        &mut self,
        stage: &Stage,
        new: Vec<PlannedRun>,
        b: usize,
        store: &mut RunStore,
        reporter: &mut dyn Reporter,
    ) -> Result<Vec<PlannedRun>, Error> {
        let cx = self.set.cx;
        let batch = Plan { runs: new };
        self.sequence.planned.extend(batch.runs.iter().map(record::Planned::of));
        self.sequence.runs += batch.runs.len();
        let in_flight = Batch::in_flight(&stage.name, &batch, b, self.sequence.runs, self.planning);
        self.sequence.sequence.push(in_flight);
        self.planning = 0.0;
        self.sequence.write(&cx.options.out)?;
        let solver = crate::extract::adapters::solver(cx.sim)?;
        let rendered = sweep::prepare_after(cx.study, &solver, &batch, self.made.rendered.as_ref())?;
        let (swept, outcomes) = runs::sweep_plan(cx, &batch, &rendered, store, &mut Quiet(reporter))?;
        if let Some(last) = self.sequence.sequence.last_mut() {
            last.count.failed = record::Failed::of(&outcomes);
            last.count.attempts = record::retried(store, &rendered.keys);
        }
        self.sequence.write(&cx.options.out)?;
        if let Source::Replay(dir) = cx.source
            && !outcomes.damaged.is_empty()
        {
            return Err(runs::damaged_error(&solver, store, dir, &outcomes.damaged, None));
        }
        let usable = swept.usable(&cx.sim.quality);
        let curves = match &self.set.setting {
            Some(s) => curves::on_grid(cx.study, cx.sim, s, &rendered.keys, &usable, &self.dirs(store)),
            None => vec![None; usable.len()],
        };
        let failed: Vec<PlannedRun> = (batch.runs.iter().zip(&rendered.keys))
            .filter(|(_, key)| outcomes.failed.iter().any(|f| f.key == **key))
            .map(|(run, _)| run.clone())
            .collect();
        let made = &mut self.made;
        made.outcomes = std::mem::take(&mut made.outcomes).merge(outcomes);
        made.batch_of.extend(std::iter::repeat_n(b, batch.runs.len()));
        made.responses.extend(usable);
        made.curves.extend(curves);
        made.plan.runs.extend(batch.runs);
        made.rendered = Some(merge(made.rendered.take(), rendered));
        Ok(failed)
    }

    /// Where finished runs' outputs are (as [`Executed::output_dirs`]).
    fn dirs(&self, store: &RunStore) -> Vec<std::path::PathBuf> {
        let mut dirs = vec![store.out().join(crate::execute::store::RUNS_DIR)];
        if let Source::Replay(d) = self.set.cx.source {
            dirs.push(d.clone());
        }
        if let Some(d) = &self.set.sim().replay
            && !dirs.contains(d)
        {
            dirs.push(d.clone());
        }
        dirs
    }

    /// The stage's runs (and the earlier stage's it learns from) as the sites are built from them.
    fn run_data<'s>(&'s self, stage: &'s Stage) -> Vec<RunData<'s>> {
        let prior = stage.prior.iter().map(|(design, point, y, c)| RunData {
            design,
            point: point.clone(),
            batch: 0,
            response: *y,
            curve: c.as_ref(),
        });
        let made = &self.made;
        let own = made
            .plan
            .runs
            .iter()
            .enumerate()
            .filter(|(_, run)| stage.mine(run))
            .map(|(i, run)| RunData {
                design: &run.design,
                point: stage.point(run),
                batch: made.batch_of[i],
                response: made.responses[i],
                curve: made.curves[i].as_ref(),
            });
        prior.chain(own).collect()
    }

    /// Batches until every tested design's emulators are good enough at the posterior, or the
    /// budget is spent; the stage's last posterior.
    fn iterate(
        &mut self,
        stage: &Stage,
        store: &mut RunStore,
        reporter: &mut dyn Reporter,
    ) -> Result<Posterior, Error> {
        loop {
            if let Some(posterior) = self.step(stage, false, store, reporter)? {
                return Ok(posterior);
            }
        }
    }

    /// One step of a stage: the runs in hand assessed, and either the stage stopped (its last
    /// posterior) or its next batch run (`None`). `settled`: the decision does not depend on what
    /// the stage's runs may still show ([`converge`]); it stops.
    fn step(
        &mut self,
        stage: &Stage,
        settled: bool,
        store: &mut RunStore,
        reporter: &mut dyn Reporter,
    ) -> Result<Option<Posterior>, Error> {
        // The candidates' seed follows the latest batch of any stage (as when stages ran one after
        // another); the record completed is this stage's own latest batch.
        let latest = self.made.batch_of.last().copied().unwrap_or(0);
        let seed = self.set.limits.seed ^ fnv(&stage.name) ^ (latest as u64).wrapping_mul(0x9e37_79b9);
        let started = std::time::Instant::now();
        let failing = self.sequence.failing(&stage.name);
        if failing && self.run_data(stage).iter().all(|r| r.response.is_none()) {
            return Err(self.nothing_to_fit(stage));
        }
        let assessed = self.assess(stage, self.made.stage_batch(stage), seed);
        if let Some(last) = self.sequence.sequence.iter().rev().find(|l| l.stage == stage.name) {
            reporter.report(Event::Batch(last));
        }
        let room = self
            .set
            .limits
            .budget
            .saturating_sub(self.sequence.runs + stage.reserve);
        let picks = match assessed.open.iter().any(|&o| o) && room > 0 && !settled {
            true => self.picks(stage, &assessed, room, seed),
            false => Vec::new(),
        };
        self.planning = started.elapsed().as_secs_f64();
        match stage.next(&assessed, (room, failing), settled, picks) {
            Next::Batch(new) => {
                self.batch(stage, new, latest + 1, store, reporter)?;
                Ok(None)
            }
            Next::Stop(reason) => {
                if !matches!(reason, StopReason::Converged | StopReason::Settled) {
                    self.unconverged(stage, reason, reporter);
                }
                let own = self.made.plan.runs.iter().filter(|run| stage.mine(run)).count();
                self.sequence.stop(&stage.name, reason, own);
                self.sequence.write(&self.set.cx.options.out)?;
                Ok(Some(assessed.posterior))
            }
        }
    }

    /// The planner's next batch of the stage: its points where the runs most reduce what the
    /// posterior depends on, as runs at their tested designs; never a run that failed already (its
    /// retries, where the study allows them, were made when it ran).
    fn picks(&self, stage: &Stage, a: &Assessed, room: usize, seed: u64) -> Vec<PlannedRun> {
        let q = self.set.limits.batch.min(room);
        let made = &self.made;
        let failed: Vec<&PlannedRun> = (made.plan.runs.iter().zip(&made.responses))
            .filter(|(run, y)| y.is_none() && stage.mine(run))
            .map(|(run, _)| run)
            .collect();
        seq::choose(&stage.bounds, &a.sites, &a.emulators, &a.posterior, &a.open, q, seed)
            .iter()
            .map(|(s, x)| {
                let t = &self.set.tests.designs[*s];
                stage.run_at(self.set.sim(), &t.name, &t.values, x)
            })
            .filter(|run| !failed.iter().any(|f| same_run(f, run)))
            .collect()
    }

    /// Why a stage whose runs all failed stops the study: nothing to fit.
    fn nothing_to_fit(&self, stage: &Stage) -> Error {
        let failed: Vec<&record::Failed> = (self.sequence.sequence.iter())
            .filter(|b| b.stage == stage.name)
            .flat_map(|b| &b.count.failed)
            .collect();
        let shown: Vec<String> = failed
            .iter()
            .take(5)
            .map(|f| format!("- design `{}`, key {}: {}", f.design, f.key, f.detail))
            .collect();
        Error::Failed(format!(
            "{}: every one of its {} run(s) failed, so there is nothing to fit an emulator to (each is in {}):\n{}",
            stage.name,
            failed.len(),
            self.set.cx.options.out.join(record::FILE).display(),
            shown.join("\n")
        ))
    }

    /// Says that a stage stopped before its emulators were within the tolerance: the decision then
    /// counts their larger error as noise, and a larger budget would narrow it.
    fn unconverged(&self, stage: &Stage, reason: StopReason, reporter: &mut dyn Reporter) {
        let Some((design, measured, predicted)) = self
            .sequence
            .sequence
            .iter()
            .rev()
            .find(|l| l.stage == stage.name)
            .and_then(|l| l.worst())
        else {
            return;
        };
        let predicted = match predicted {
            Some(p) => format!("{p:.3} of the tests' noise predicted"),
            None => "none predicted (no run there finished)".to_string(),
        };
        let error = match measured {
            Some(m) => format!("{m:.3} of the tests' noise on runs they were not fitted to, {predicted}"),
            None => format!("not measured (nothing held out yet, or the runs held out failed), {predicted}"),
        };
        reporter.report(Event::Note(format!(
            "{}: stopped ({}) before its emulators were within {} of the tests' noise at every tested design — \
             at {design} their error is {error}; the decision counts that error as noise, so its intervals are wider \
             and a cause harder to tell apart than a larger `sampling.budget` would give",
            stage.name,
            reason.key(),
            self.tolerance
        )));
    }

    /// The sites, their emulators and the posterior now; which designs are still open; the latest
    /// batch's record completed with what it bought.
    fn assess(&mut self, stage: &Stage, b: usize, seed: u64) -> Assessed {
        let data = self.run_data(stage);
        let tests = &self.set.tests;
        let sites = sites::sites(tests, &data);
        let kinds = sites::kinds(self.set.study(), self.set.sim());
        let bounds = &stage.bounds;
        // The study's surrogates' held-out errors do not depend on the planner's emulators: both at once.
        let across = self.set.sim().across_designs();
        let values: Vec<Vec<f64>> = tests.designs.iter().map(|t| t.values.clone()).collect();
        let ((emulators, posterior), measured) = rayon::join(
            || {
                let emus = match across {
                    true => seq::shared::emulators(&values, bounds, &sites),
                    false => seq::emulators(bounds, &sites),
                };
                let posterior = seq::posterior(bounds, &sites, &emus, seed);
                (emus, posterior)
            },
            || match across {
                true => sites::measured_errors_across(tests, &data, bounds),
                false => sites::measured_errors(tests, &data, kinds, bounds),
            },
        );
        let predicted: Vec<f64> = sites
            .iter()
            .zip(&emulators)
            .map(|(s, e)| seq::predicted_error(s, e, &posterior))
            .collect();
        // The screening's own emulators per design: the error that still matters is the part the
        // parameters do not absorb where the misfit stands with it ([`absorbed`]).
        let screening = absorbed::Screening {
            tests,
            sites: &sites,
            emulators: &emulators,
            posterior: &posterior,
            bounds,
        };
        let alpha = crate::diagnose::Settings::default().alpha;
        let matters = (stage.id == StageId::Screening && !across)
            .then(|| absorbed::unabsorbed_errors(&screening, &measured, alpha))
            .flatten();
        // An error that could not be measured (the held-out runs failed, or the emulators could not
        // be fitted without them) is not measured: the design stays open, and no "inf" is shown.
        let measured: Vec<Option<f64>> = measured
            .iter()
            .map(|m| m.map(|h| h.rms).filter(|v| v.is_finite()))
            .collect();
        let f = self.tolerance;
        let open = (0..measured.len())
            .map(|i| {
                let m = matters.as_ref().map_or(measured[i], |u| u[i]);
                !(m.is_some_and(|m| m <= f) && predicted[i] <= f)
            })
            .collect();
        let names: Vec<String> = tests.designs.iter().map(|t| t.name.clone()).collect();
        if let Some(last) = self
            .sequence
            .sequence
            .iter_mut()
            .rev()
            .find(|l| l.batch == b && l.stage == stage.name)
        {
            last.done(
                &names,
                (&measured, &predicted),
                matters.as_deref(),
                &stage.names,
                &posterior,
            );
        }
        Assessed {
            open,
            posterior,
            sites,
            emulators,
        }
    }

    /// The fewest runs a design's emulator needs besides its latest batch for that batch to be held
    /// out: a linear one over the stage's variables (d + 1); none with one emulator across the
    /// designs, which the other designs' runs fit (it is then fitted to the check runs as well, and
    /// checked by a refit without them: [`super::stages::fit_surrogates`]).
    fn least(&self, stage: &Stage) -> usize {
        if self.set.sim().across_designs() {
            0
        } else {
            crate::study::SurrogateKind::Linear.min_samples(stage.bounds.dim())
        }
    }

    /// Each design's latest batch of the stage's own runs becomes its check runs.
    fn mark_checks(&mut self, stage: &Stage, check: RunRole) {
        let names: Vec<String> = self.set.tests.designs.iter().map(|t| t.name.clone()).collect();
        let prior = usable_counts(&stage.prior);
        let least = self.least(stage);
        let made = &mut self.made;
        for i in latest_batches(&made.plan, &made.batch_of, &|r| stage.mine(r), &names, &prior, least) {
            made.plan.runs[i].role = check;
        }
    }

    /// The extension hypotheses' screening runs at their probe values, placed at the posterior: its
    /// mode, and the mode moved by one standard deviation along each parameter (p + 1 per design:
    /// what a linear surrogate of the extension's effect over θ needs there).
    fn probes(
        &mut self,
        posterior: &Posterior,
        store: &mut RunStore,
        reporter: &mut dyn Reporter,
    ) -> Result<(), Error> {
        let (study, sim) = (self.set.study(), self.set.sim());
        let points = probe_points(posterior, &study.parameter_bounds());
        // With one emulator across the designs, the designs take the points in turn, one each: the
        // emulator learns how the effect changes with θ across them ([`crate::plan::sweep::probes_across`]).
        let across = crate::plan::sweep::probes_across(study, sim);
        let mut new = Vec::new();
        for (k, h) in study.extension_hypotheses() {
            let variables = h.extension().unwrap_or_default().to_vec();
            for (i, t) in self.set.tests.designs.iter().enumerate() {
                let mine: Vec<&Vec<f64>> = match across {
                    true => vec![&points[i % points.len()]],
                    false => points.iter().collect(),
                };
                for x in mine {
                    let theta = crate::plan::sweep::as_written(sim, x);
                    new.push(run_at(
                        &t.name,
                        &t.values,
                        theta,
                        RunRole::Extension(k),
                        variables.clone(),
                    ));
                }
            }
        }
        if new.is_empty() {
            return Ok(());
        }
        let stage = Stage::probes(study);
        let mut n = new.len();
        let failed = self.probe_batch(&stage, new, store, reporter)?;
        // A failed probe is tried again elsewhere: without it the hypothesis would be screened on
        // fewer points than its surrogate needs. Each retry is placed from the probe's first point.
        let bounds = study.parameter_bounds();
        let mut open: Vec<(Vec<f64>, PlannedRun)> = failed.into_iter().map(|r| (r.theta.clone(), r)).collect();
        for f in PROBE_RETRIES {
            if open.is_empty() {
                break;
            }
            if let Some(last) = self.sequence.sequence.last() {
                reporter.report(Event::Batch(last));
            }
            let again: Vec<(Vec<f64>, PlannedRun)> = (open.into_iter())
                .map(|(first, run)| {
                    let theta = crate::plan::sweep::as_written(sim, &probe_replacement(&first, posterior, &bounds, f));
                    (first, PlannedRun { theta, ..run })
                })
                .collect();
            n += again.len();
            let runs: Vec<PlannedRun> = again.iter().map(|(_, r)| r.clone()).collect();
            let failed = self.probe_batch(&stage, runs, store, reporter)?;
            open = again
                .into_iter()
                .filter(|(_, r)| failed.iter().any(|f| same_run(f, r)))
                .collect();
        }
        self.sequence.stop(&stage.name, StopReason::Planned, n);
        if let Some(last) = self.sequence.sequence.last_mut() {
            reporter.report(Event::Batch(last));
        }
        self.sequence.write(&self.set.cx.options.out)
    }

    /// One batch of probes, done as planned; its failed runs.
    fn probe_batch(
        &mut self,
        stage: &Stage,
        new: Vec<PlannedRun>,
        store: &mut RunStore,
        reporter: &mut dyn Reporter,
    ) -> Result<Vec<PlannedRun>, Error> {
        let b = self.made.next_batch();
        let failed = self.batch(stage, new, b, store, reporter)?;
        if let Some(last) = self.sequence.sequence.last_mut() {
            last.state = BatchState::Done;
        }
        Ok(failed)
    }

    /// The stage's plan as made, its rendering, and every run's record as the store holds it (read
    /// back, so that the results are what is on disk, as for a fixed plan); the stage's outcome
    /// table.
    fn finish(
        &mut self,
        store: &RunStore,
        reporter: &mut dyn Reporter,
    ) -> Result<(Plan, Prepared, sweep::SweepResult, RunOutcomes), Error> {
        let plan = std::mem::replace(&mut self.made.plan, Plan { runs: Vec::new() });
        let rendered = self
            .made
            .rendered
            .take()
            .unwrap_or_else(|| merge(None, empty_prepared()));
        let swept = sweep::SweepResult::recorded(store, &rendered);
        let outcomes = std::mem::take(&mut self.made.outcomes);
        reporter.report(Event::RunsEnded(&outcomes));
        self.sequence.write(&self.set.cx.options.out)?;
        Ok((plan, rendered, swept, outcomes))
    }
}

/// Whether two planned runs are the same run (design, parameters and extension values).
fn same_run(a: &PlannedRun, b: &PlannedRun) -> bool {
    a.design == b.design && a.theta == b.theta && a.extension == b.extension
}

/// A rendering of nothing.
fn empty_prepared() -> Prepared {
    Prepared {
        keys: Vec::new(),
        inputs: Default::default(),
        meshes: Default::default(),
        run_mesh: Vec::new(),
        design_mesh: Default::default(),
    }
}

/// Two renderings as one (the later's keys after the earlier's; meshes shared).
fn merge(earlier: Option<Prepared>, later: Prepared) -> Prepared {
    let Some(mut e) = earlier else { return later };
    e.keys.extend(later.keys);
    e.inputs.extend(later.inputs);
    e.meshes.extend(later.meshes);
    e.run_mesh.extend(later.run_mesh);
    e.design_mesh.extend(later.design_mesh);
    e
}

/// The solver-in-the-loop's runs of `hypotheses`, sampled sequentially in each one's joint space
/// (θ × its ranged variables) from what the screening already ran there: its probes, and its
/// baseline runs where the baseline is the space's edge. One stage per hypothesis; the sequence's
/// record goes on in `sequence`. The loop's policy over the stages is [`converge`].
pub fn looped(
    cx: RunContext,
    hypotheses: &[usize],
    screening: &ScreeningRuns,
    (store, sequence): (&mut RunStore, Sequence),
    reporter: &mut dyn Reporter,
    decide: &mut Decide,
) -> Result<(super::extend::JointRuns, Sequence), Error> {
    let meshes = Prepared {
        meshes: screening.rendered.meshes.clone(),
        design_mesh: screening.rendered.design_mesh.clone(),
        ..empty_prepared()
    };
    let mut r = Runner::new(Settings::of(cx), sequence, Some(meshes));
    let mut stages = Vec::new();
    let mut edges = Vec::new();
    for &k in hypotheses {
        let Some((stage, edge)) = stage::loop_stage(cx.study, k, screening) else {
            continue;
        };
        if edge.is_none() {
            reporter.report(Event::Note(format!(
                "'{}': a baseline run rendered with the extension at its lower bounds is not the same deck as the \
                 baseline's (write the template's default for the extension's variables as that bound, e.g. 0.0 for a \
                 range from 0.0), so the loop cannot reuse the baseline's runs and starts from the probes",
                cx.study.diagnosis.hypotheses[k].name
            )));
        }
        if let Some(e) = &edge {
            edges.push((k, e.clone()));
        }
        let seed = r.set.limits.seed ^ fnv(&stage.name) ^ r.made.plan.runs.len() as u64;
        let initial = stage.initial_loop_runs((cx.study, cx.sim), &r.set.tests, seed);
        let b = r.made.next_batch();
        if !initial.is_empty() {
            r.batch(&stage, initial, b, store, reporter)?;
        }
        stages.push((k, stage, edge));
    }
    // Room for a check of every stage at the decision's fitted point, and for the confirmation
    // runs after the loop, kept from the batches.
    let confirmation = crate::plan::sweep::SequenceFloor::of(cx.study, cx.sim).map_or(0, |f| f.confirmation);
    let checks = r.set.tests.designs.len() * stages.len() + confirmation;
    for (_, stage, _) in &mut stages {
        stage.reserve = checks;
    }
    let unchecked = r.converge_and_check(&stages, &edges, decide, store, reporter)?;
    for (k, stage, _) in &stages {
        r.mark_checks(stage, RunRole::JointCheck(*k));
    }
    let (plan, rendered, swept, outcomes) = r.finish(store, reporter)?;
    let usable = swept.usable(&cx.sim.quality);
    let flags = swept.flags(&cx.sim.quality.gates);
    let joint = super::extend::JointRuns {
        plan,
        rendered,
        swept,
        outcomes,
        flags,
        usable,
        edges,
        unchecked,
        running: Vec::new(),
    };
    Ok((joint, r.sequence))
}
