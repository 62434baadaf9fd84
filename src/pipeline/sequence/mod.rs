//! The plan → execute → fit loop of a study sampled sequentially (`sampling.method: sequential`),
//! written once for its two uses: the screening's runs over θ, and the solver-in-the-loop's runs of
//! an extension over θ and its ranged variables.
//!
//! ```text
//! initial design ─► sweep ─► sites (runs, tests) ─► emulators, posterior ─► enough? ─┬─► stop
//!        ▲                                                                            │
//!        └──────────────── sweep ◄── the next batch (plan::sequential::choose) ◄──────┘
//! ```
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

pub mod record;
pub mod sites;

use nalgebra::DVector;

use super::runs::{self, Executed, RunOutcomes, Source};
use super::{Engine, Event, Reporter, RunOptions, curves};
use crate::base::Bounds;
use crate::emulate::sequential::{self as seq, Posterior};
use crate::error::Error;
use crate::execute::RunStore;
use crate::execute::sweep::{self, Prepared};
use crate::plan::sweep::{as_written, initial_samples, joint_bounds};
use crate::plan::{Plan, PlannedRun, RunRole, latin_hypercube};
use crate::study::{SolverSimulation, Study};
pub use record::{Batch, Sequence, Stop};
use sites::{RunData, Tests};

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

/// How the sequence may spend runs.
#[derive(Debug, Clone, Copy)]
struct Limits {
    batch: usize,
    budget: usize,
    tolerance: f64,
    seed: u64,
}

impl Limits {
    fn of(study: &Study, sim: &SolverSimulation, options: &RunOptions) -> Limits {
        let q = sim.sampling.sequential.as_ref().expect("a sequential study");
        Limits {
            batch: q.batch.unwrap_or(options.jobs).max(1),
            budget: crate::plan::sweep::sequential_budget(study, sim).expect("a sequential study"),
            tolerance: q.tolerance,
            seed: sim.sampling.seed,
        }
    }
}

/// Everything the loop carries from batch to batch.
struct Runner<'a> {
    study: &'a Study,
    sim: &'a SolverSimulation,
    source: &'a Source,
    options: &'a RunOptions,
    engine: &'a Engine<'a>,
    tests: Tests,
    setting: Option<curves::Setting>,
    limits: Limits,
    /// This stage's own runs, in order, with the batch each came in, its response and its curve.
    plan: Plan,
    batch_of: Vec<usize>,
    responses: Vec<Option<f64>>,
    curves: Vec<Option<DVector<f64>>>,
    /// Runs of an earlier stage this stage's emulators also learn from, at their point in its space.
    prior: Vec<PriorRun>,
    /// Every run's rendering so far (the meshes are made once).
    rendered: Option<Prepared>,
    outcomes: RunOutcomes,
    sequence: Sequence,
    /// Wall time of the planner (assessing the runs in hand and choosing the next batch), seconds.
    planning: f64,
    /// The loop's stages stopped because nothing their runs could show would change the decision
    /// ([`Runner::settled`]); reopened when that no longer holds.
    parked: Vec<String>,
}

/// What the loop's stages read: the stages, their edges at the baseline, the screening's runs.
#[derive(Clone, Copy)]
struct Looping<'a, 's> {
    stages: &'a Stages<'s>,
    edges: &'a [(usize, Vec<(String, f64)>)],
    screening: &'a ScreeningRuns<'a>,
}

/// An earlier stage's run as a later stage sees it: its design, its point in the later stage's box,
/// its response and its curve (None where the run failed).
type PriorRun = (String, Vec<f64>, Option<f64>, Option<DVector<f64>>);

/// How a stage makes the run at a tested design (name, values) and a point of its box.
type MakeRun<'s> = Box<dyn Fn(&str, &[f64], &[f64]) -> PlannedRun + 's>;

/// A run's point in a stage's box.
type RunPoint<'s> = Box<dyn Fn(&PlannedRun) -> Vec<f64> + 's>;

/// The loop's stages: each hypothesis, its joint space, and its edge at the baseline.
type Stages<'s> = [(usize, Space<'s>, Option<Vec<(String, f64)>>)];

/// One stage's space: its box and names, and how a point becomes a run at a design.
struct Space<'s> {
    name: String,
    bounds: Bounds,
    names: Vec<String>,
    /// The run at a tested design (name, values) and a point of the box.
    make: MakeRun<'s>,
    /// A run's point in the box.
    point: RunPoint<'s>,
    /// Whether a run of the plan is one of this stage's own.
    mine: Box<dyn Fn(&PlannedRun) -> bool + 's>,
    /// Runs of the budget this stage leaves for the stages after it.
    reserve: usize,
}

/// The screening's runs, sampled sequentially, then the probes (see the module notes).
pub fn screening(
    study: &Study,
    sim: &SolverSimulation,
    source: &Source,
    options: &RunOptions,
    engine: &Engine,
    reporter: &mut dyn Reporter,
) -> Result<Screened, Error> {
    let mut store = crate::execute::open_store(&options.out)?;
    let limits = Limits::of(study, sim, options);
    let mut r = Runner::new(study, sim, source, options, engine, limits, Sequence::default());
    let space = Space {
        name: "screening".into(),
        bounds: study.parameter_bounds(),
        names: study.parameters.iter().map(|p| p.name.clone()).collect(),
        make: Box::new(|name, values, x| run_at(name, values, x.to_vec(), RunRole::Sample, Vec::new())),
        point: Box::new(|run| run.theta.clone()),
        mine: Box::new(|run| matches!(run.role, RunRole::Sample | RunRole::Check)),
        // The probes and the loop's first batches come after the screening, within the budget.
        reserve: crate::plan::sweep::SequenceFloor::of(study, sim).map_or(0, |f| f.reserve()),
    };
    r.batch(&space, Plan::initial(study, sim).runs, 0, &mut store, reporter)?;
    let posterior = r.iterate(&space, &mut store, reporter)?;
    r.mark_checks(&space, RunRole::Check);
    r.probes(&posterior, &mut store, reporter)?;
    let (plan, rendered, swept, outcomes) = r.finish(&mut store, reporter)?;
    let replay = match source {
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

fn run_at(name: &str, values: &[f64], theta: Vec<f64>, role: RunRole, extension: Vec<(String, f64)>) -> PlannedRun {
    PlannedRun {
        design: name.to_string(),
        design_values: values.to_vec(),
        theta,
        role,
        extension,
    }
}

impl<'a> Runner<'a> {
    fn new(
        study: &'a Study,
        sim: &'a SolverSimulation,
        source: &'a Source,
        options: &'a RunOptions,
        engine: &'a Engine<'a>,
        limits: Limits,
        mut sequence: Sequence,
    ) -> Runner<'a> {
        let setting = curves::Setting::of(study);
        let specimens = setting.map(|s| curves::specimens(study, &s));
        let tests = Tests::of(study, specimens.as_deref().zip(setting.map(|s| s.spec)));
        sequence.method = "sequential".into();
        sequence.tolerance = limits.tolerance;
        Runner {
            study,
            sim,
            source,
            options,
            engine,
            tests,
            setting,
            limits,
            plan: Plan { runs: Vec::new() },
            batch_of: Vec::new(),
            responses: Vec::new(),
            curves: Vec::new(),
            prior: Vec::new(),
            rendered: None,
            outcomes: RunOutcomes::default(),
            sequence,
            planning: 0.0,
            parked: Vec::new(),
        }
    }

    /// Renders and runs `new` as batch `b` of the stage, records it, and reads its responses and
    /// curves.
    fn batch(
        &mut self,
        space: &Space,
        new: Vec<PlannedRun>,
        b: usize,
        store: &mut RunStore,
        reporter: &mut dyn Reporter,
    ) -> Result<(), Error> {
        let batch = Plan { runs: new };
        self.sequence.planned.extend(batch.runs.iter().map(record::Planned::of));
        self.sequence.runs += batch.runs.len();
        self.sequence.sequence.push(self.in_flight(space, &batch, b));
        self.planning = 0.0;
        self.sequence.write(&self.options.out)?;
        let rendered = sweep::prepare_after(
            self.study,
            &crate::extract::adapters::solver(self.sim)?,
            &batch,
            self.rendered.as_ref(),
        )?;
        let (swept, outcomes) = runs::sweep_plan(
            self.study,
            self.sim,
            &batch,
            &rendered,
            self.source,
            self.options,
            self.engine,
            store,
            &mut Quiet(reporter),
        )?;
        let usable = swept.usable(&self.sim.quality);
        let curves = match &self.setting {
            Some(s) => curves::on_grid(self.study, self.sim, s, &rendered.keys, &usable, &self.dirs(store)),
            None => vec![None; usable.len()],
        };
        self.outcomes = std::mem::take(&mut self.outcomes).merge(outcomes);
        self.batch_of.extend(std::iter::repeat_n(b, batch.runs.len()));
        self.responses.extend(usable);
        self.curves.extend(curves);
        self.plan.runs.extend(batch.runs);
        self.rendered = Some(merge(self.rendered.take(), rendered));
        Ok(())
    }

    /// Where finished runs' outputs are (as [`Executed::output_dirs`]).
    fn dirs(&self, store: &RunStore) -> Vec<std::path::PathBuf> {
        let mut dirs = vec![store.out().join(crate::execute::store::RUNS_DIR)];
        if let Source::Replay(d) = self.source {
            dirs.push(d.clone());
        }
        if let Some(d) = &self.sim.replay
            && !dirs.contains(d)
        {
            dirs.push(d.clone());
        }
        dirs
    }

    /// The record of batch `b` before its runs start.
    fn in_flight(&self, space: &Space, batch: &Plan, b: usize) -> Batch {
        let mut designs = indexmap::IndexMap::new();
        for r in &batch.runs {
            *designs.entry(r.design.clone()).or_insert(0) += 1;
        }
        Batch {
            stage: space.name.clone(),
            batch: b,
            state: "in flight".into(),
            runs: batch.runs.len(),
            total: self.sequence.runs,
            designs,
            emulator_error: Default::default(),
            predicted_error: Default::default(),
            estimates: Default::default(),
            interval95: Default::default(),
            stopped: None,
            planning_seconds: self.planning,
            placed: None,
        }
    }

    /// The stage's runs (and the earlier stage's it learns from) as the sites are built from them.
    fn run_data(&self, space: &Space) -> Vec<RunData<'_>> {
        let prior = self.prior.iter().map(|(design, point, y, c)| RunData {
            design,
            point: point.clone(),
            batch: 0,
            response: *y,
            curve: c.as_ref(),
        });
        let own = self
            .plan
            .runs
            .iter()
            .enumerate()
            .filter(|(_, run)| (space.mine)(run))
            .map(|(i, run)| RunData {
                design: &run.design,
                point: (space.point)(run),
                batch: self.batch_of[i],
                response: self.responses[i],
                curve: self.curves[i].as_ref(),
            });
        prior.chain(own).collect()
    }

    /// Batches until every tested design's emulators are good enough at the posterior, or the
    /// budget is spent; the stage's last posterior.
    fn iterate(
        &mut self,
        space: &Space,
        store: &mut RunStore,
        reporter: &mut dyn Reporter,
    ) -> Result<Posterior, Error> {
        loop {
            if let Some(posterior) = self.step(space, false, store, reporter)? {
                return Ok(posterior);
            }
        }
    }

    /// The latest batch of a stage's own runs (0 before any).
    fn stage_batch(&self, space: &Space) -> usize {
        self.plan
            .runs
            .iter()
            .zip(&self.batch_of)
            .filter(|(run, _)| (space.mine)(run))
            .map(|(_, b)| *b)
            .max()
            .unwrap_or(0)
    }

    /// One step of a stage: the runs in hand assessed, and either the stage stopped (its last
    /// posterior) or its next batch run (`None`). New batches are numbered after every stage's, so
    /// that stages may take turns. `settled`: the decision does not depend on what the stage's runs
    /// may still show ([`Runner::settled`]); it stops.
    fn step(
        &mut self,
        space: &Space,
        settled: bool,
        store: &mut RunStore,
        reporter: &mut dyn Reporter,
    ) -> Result<Option<Posterior>, Error> {
        // The candidates' seed follows the latest batch of any stage (as when stages ran one after
        // another); the record completed is this stage's own latest batch.
        let latest = self.batch_of.last().copied().unwrap_or(0);
        let seed = self.limits.seed ^ fnv(&space.name) ^ (latest as u64).wrapping_mul(0x9e37_79b9);
        let started = std::time::Instant::now();
        let (open, posterior, sites, emus) = self.assess(space, self.stage_batch(space), seed);
        if let Some(last) = self.sequence.sequence.iter().rev().find(|l| l.stage == space.name) {
            reporter.report(Event::Batch(last));
        }
        let room = self.limits.budget.saturating_sub(self.sequence.runs + space.reserve);
        let picks = if open.iter().any(|&o| o) && room > 0 && !settled {
            seq::choose(
                &space.bounds,
                &sites,
                &emus,
                &posterior,
                &open,
                self.limits.batch.min(room),
                seed,
            )
        } else {
            Vec::new()
        };
        self.planning = started.elapsed().as_secs_f64();
        let stop = if !open.iter().any(|&o| o) {
            Some("converged")
        } else if settled {
            Some("settled")
        } else if room == 0 {
            Some("budget")
        } else if picks.is_empty() {
            Some("nowhere to run")
        } else {
            None
        };
        if let Some(reason) = stop {
            if reason != "converged" && reason != "settled" {
                self.unconverged(space, reason, reporter);
            }
            let own = self.plan.runs.iter().filter(|run| (space.mine)(run)).count();
            self.sequence.stop(&space.name, reason, own);
            self.sequence.write(&self.options.out)?;
            return Ok(Some(posterior));
        }
        let new: Vec<PlannedRun> = picks
            .iter()
            .map(|(s, x)| {
                let t = &self.tests.designs[*s];
                (space.make)(&t.name, &t.values, &as_written(self.sim, x))
            })
            .collect();
        self.batch(space, new, latest + 1, store, reporter)?;
        Ok(None)
    }

    /// Says that a stage stopped before its emulators were within the tolerance: the decision then
    /// counts their larger error as noise, and a larger budget would narrow it.
    fn unconverged(&self, space: &Space, reason: &str, reporter: &mut dyn Reporter) {
        let Some((design, measured, predicted)) = self
            .sequence
            .sequence
            .iter()
            .rev()
            .find(|l| l.stage == space.name)
            .and_then(|l| l.worst())
        else {
            return;
        };
        let error = match measured {
            Some(m) => format!("{m:.3} of the tests' noise on runs they were not fitted to, {predicted:.3} predicted"),
            None => format!("not yet measured (nothing held out), {predicted:.3} of the tests' noise predicted"),
        };
        reporter.report(Event::Note(format!(
            "{}: stopped ({reason}) before its emulators were within {} of the tests' noise at every tested design — \
             at {design} their error is {error}; the decision counts that error as noise, so its intervals are wider \
             and a cause harder to tell apart than a larger `sampling.budget` would give",
            space.name, self.limits.tolerance
        )));
    }

    /// A loop stage's first runs: where the screening's runs in its space (`prior`) are fewer at a
    /// design than a space-filling start needs there, seeded Latin-hypercube points of the joint box.
    fn initial_loop_runs(&self, space: &Space, start: usize) -> Vec<PlannedRun> {
        if self.sim.across_designs() {
            return self.initial_loop_runs_across(space, start);
        }
        let d = space.bounds.dim();
        let needed = initial_samples(self.study, self.sim, d);
        let have = self
            .tests
            .designs
            .iter()
            .map(|t| {
                self.prior
                    .iter()
                    .filter(|(n, _, y, _)| *n == t.name && y.is_some())
                    .count()
            })
            .min()
            .unwrap_or(0);
        if have >= needed {
            return Vec::new();
        }
        let seed = self.limits.seed ^ fnv(&space.name) ^ start as u64;
        let points = initial_points(&space.bounds, needed - have, seed);
        self.tests
            .designs
            .iter()
            .flat_map(|t| {
                points
                    .iter()
                    .map(|x| (space.make)(&t.name, &t.values, &as_written(self.sim, x)))
            })
            .collect()
    }

    /// A loop stage's first runs with one emulator across the designs: where the screening's runs in
    /// its space are fewer than its linear trend over the designs' values and the space needs with a
    /// run to spare, seeded Latin-hypercube points of the joint box, round the designs.
    fn initial_loop_runs_across(&self, space: &Space, start: usize) -> Vec<PlannedRun> {
        let designs = &self.tests.designs;
        let d = designs.first().map_or(0, |t| t.values.len());
        let needed = d + space.bounds.dim() + 2;
        let have = self.prior.iter().filter(|(_, _, y, _)| y.is_some()).count();
        if have >= needed || designs.is_empty() {
            return Vec::new();
        }
        let seed = self.limits.seed ^ fnv(&space.name) ^ start as u64;
        initial_points(&space.bounds, needed - have, seed)
            .iter()
            .enumerate()
            .map(|(i, x)| {
                let t = &designs[i % designs.len()];
                (space.make)(&t.name, &t.values, &as_written(self.sim, x))
            })
            .collect()
    }

    /// The sites, their emulators and the posterior now; which designs are still open; the latest
    /// batch's record completed with what it bought.
    fn assess(
        &mut self,
        space: &Space,
        b: usize,
        seed: u64,
    ) -> (Vec<bool>, Posterior, Vec<seq::Site>, Vec<seq::SiteEmulators>) {
        let data = self.run_data(space);
        let sites = sites::sites(&self.tests, &data);
        let kinds = sites::kinds(self.study, self.sim);
        let bounds = &space.bounds;
        // The study's surrogates' held-out errors do not depend on the planner's emulators: both at once.
        let across = self.sim.across_designs();
        let values: Vec<Vec<f64>> = self.tests.designs.iter().map(|t| t.values.clone()).collect();
        let ((emus, posterior), measured) = rayon::join(
            || {
                let emus = if across {
                    seq::shared::emulators(&values, bounds, &sites)
                } else {
                    seq::emulators(bounds, &sites)
                };
                let posterior = seq::posterior(bounds, &sites, &emus, seed);
                (emus, posterior)
            },
            || {
                if across {
                    sites::measured_errors_across(&self.tests, &data, bounds)
                } else {
                    sites::measured_errors(&self.tests, &data, kinds, bounds)
                }
            },
        );
        let predicted: Vec<f64> = sites
            .iter()
            .zip(&emus)
            .map(|(s, e)| seq::predicted_error(s, e, &posterior))
            .collect();
        let f = self.limits.tolerance;
        let open: Vec<bool> = measured
            .iter()
            .zip(&predicted)
            .map(|(m, p)| !(m.is_some_and(|m| m <= f) && *p <= f))
            .collect();
        if let Some(last) = self
            .sequence
            .sequence
            .iter_mut()
            .rev()
            .find(|l| l.batch == b && l.stage == space.name)
        {
            last.state = "done".into();
            for (t, (m, p)) in self.tests.designs.iter().zip(measured.iter().zip(&predicted)) {
                last.emulator_error.insert(t.name.clone(), *m);
                last.predicted_error.insert(t.name.clone(), *p);
            }
            for (j, n) in space.names.iter().enumerate() {
                last.estimates.insert(n.clone(), posterior.mean[j]);
                last.interval95.insert(n.clone(), posterior.interval[j]);
            }
        }
        (open, posterior, sites, emus)
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
        let Looping {
            stages,
            edges,
            screening,
        } = l;
        let mut round = 0;
        loop {
            let mut open: Vec<bool> = stages
                .iter()
                .map(|(_, space, _)| !self.parked.contains(&space.name))
                .collect();
            while open.iter().any(|&o| o) {
                let mut settled = self.settled(l, &mut open, decide, reporter);
                for (i, (k, space, edge)) in stages.iter().enumerate() {
                    if !open[i] {
                        continue;
                    }
                    self.prior = prior_runs(self.study, *k, edge.as_deref(), screening);
                    open[i] = self.step(space, settled, store, reporter)?.is_none();
                    if settled && !self.sequence.converged(&space.name) {
                        self.parked.push(space.name.clone());
                    }
                    // A stage that stopped leaves fewer running: where only stages yet to take their
                    // turn in this round are open, they ask again before they run another batch.
                    let later = open[i + 1..].iter().any(|&o| o) && !open[..=i].iter().any(|&o| o);
                    if !settled && !open[i] && later {
                        settled = self.settled(l, &mut open, decide, reporter);
                    }
                }
            }
            if stages.is_empty() {
                return Ok(None);
            }
            let provisional = self.provisional(stages, edges.to_vec(), screening);
            let measured = decide(&provisional, 0.0);
            if round == TIGHTENINGS || self.sequence.runs >= self.limits.budget {
                return Ok(measured);
            }
            let f = self.limits.tolerance;
            let worst = decide(&provisional, f * f);
            let key = |d: &Option<Provisional>| d.as_ref().map(|d| d.key.clone());
            if key(&measured) == key(&worst) {
                return Ok(measured);
            }
            self.limits.tolerance = f / 2.0;
            round += 1;
            reporter.report(Event::Note(format!(
                "the decision after the loop could still change within the emulators' remaining error ({} with it as \
                 measured, {} at the tolerance's worst case): the loop goes on at a tolerance of {}",
                key(&measured).as_deref().unwrap_or("none"),
                key(&worst).as_deref().unwrap_or("none"),
                self.limits.tolerance
            )));
        }
    }

    /// Whether nothing the still running stages' runs may show could change the decision: the
    /// provisional decision from the runs in hand, with the open and the parked stages' loop models
    /// running ([`crate::diagnose::after_loop`], step 6). When it holds, the open stages stop
    /// (`settled`) and join the parked; when it does not, the parked reopen, unless the decision is
    /// settled whatever the parked alone show (the others taken as they are).
    fn settled(&mut self, l: Looping, open: &mut [bool], decide: &mut Decide, reporter: &mut dyn Reporter) -> bool {
        let Looping {
            stages,
            edges,
            screening,
        } = l;
        let ask = |this: &Self, running: &dyn Fn(usize, &Space) -> bool, decide: &mut Decide| {
            let mut joint = this.provisional(stages, edges.to_vec(), screening);
            joint.running = stages
                .iter()
                .enumerate()
                .filter(|(i, (_, space, _))| running(*i, space))
                .map(|(_, (k, _, _))| *k)
                .collect();
            decide(&joint, 0.0).is_some_and(|d| d.settled)
        };
        let parked = |_: usize, space: &Space| self.parked.contains(&space.name);
        // Before the loop's own first runs the question waits a round: a stage stopped with none of
        // its own would leave its model fitted to the probes alone, unchecked by any run of its own.
        if !open.iter().any(|&o| o) || self.plan.runs.is_empty() {
            return false;
        }
        let all = |i: usize, space: &Space| open[i] || self.parked.contains(&space.name);
        if ask(self, &all, decide) {
            let names: Vec<&str> = stages
                .iter()
                .zip(open.iter())
                .filter(|(_, o)| **o)
                .map(|((k, _, _), _)| self.study.diagnosis.hypotheses[*k].name.as_str())
                .collect();
            reporter.report(Event::Note(format!(
                "{}: whatever the loop's further runs would show of {}, the verdict and the cause after the loop \
                 are the same: those runs are not made (its fit stays unchecked, and beside another explanation the \
                 decision neither rejects it nor names it over that one)",
                names.iter().map(|n| format!("'{n}'")).collect::<Vec<_>>().join(", "),
                if names.len() == 1 { "its model" } else { "their models" }
            )));
            return true;
        }
        if !self.parked.is_empty() && !ask(self, &parked, decide) {
            for ((_, space, _), o) in stages.iter().zip(open.iter_mut()) {
                if self.parked.contains(&space.name) {
                    *o = true;
                }
            }
            self.parked.clear();
        }
        false
    }

    /// The stages converged ([`Runner::converge`]), then checked at the decision's fitted point
    /// ([`Runner::verify`]) until the check passes ([`VERIFICATIONS`] times at most): the looped
    /// hypotheses whose latest fit no run checked.
    fn converge_and_check(
        &mut self,
        l: Looping,
        decide: &mut Decide,
        store: &mut RunStore,
        reporter: &mut dyn Reporter,
    ) -> Result<Vec<usize>, Error> {
        let stages = l.stages;
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
            let before = self.counts(stages);
            decision = self.converge(l, decide, store, reporter)?;
            let after = self.counts(stages);
            // Passed: no run since, because the stage converged with the check held out (not because
            // the budget stopped it).
            checked = stages
                .iter()
                .zip(at.iter().zip(before.iter().zip(&after)))
                .map(|((_, space, _), (a, (b, c)))| *a && b == c && self.sequence.converged(&space.name))
                .collect();
            if before == after {
                break;
            }
        }
        let unchecked: Vec<usize> = stages
            .iter()
            .zip(&checked)
            .filter(|(_, c)| !**c)
            .map(|((k, _, _), _)| *k)
            .collect();
        let parked: Vec<usize> = stages
            .iter()
            .filter(|(_, space, _)| self.parked.contains(&space.name))
            .map(|(k, _, _)| *k)
            .collect();
        for k in unchecked.iter().filter(|k| !parked.contains(k)) {
            reporter.report(Event::Note(format!(
                "'{}': no solver run checked the loop's emulators at the decision's fitted point (or the last check \
                 missed and the budget left no room for another), so its fit there may be theirs: beside another \
                 explanation, the decision neither rejects it nor names it over that one",
                self.study.diagnosis.hypotheses[*k].name
            )));
        }
        Ok(unchecked)
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
        let mut at = checked.to_vec();
        let mut placed: Vec<(&Space, Vec<PlannedRun>)> = Vec::new();
        // A parked stage is not checked: nothing its fit shows could change the decision.
        let unchecked =
            |(i, (_, space, _)): &(usize, &(usize, Space, _))| !checked[*i] && !self.parked.contains(&space.name);
        for (i, (k, space, _)) in stages.iter().enumerate().filter(unchecked) {
            let Some(x) = d
                .points
                .iter()
                .find(|(j, _)| j == k)
                .and_then(|(_, f)| f.point(&space.names))
            else {
                continue;
            };
            let x = as_written(self.sim, &x);
            let runs: Vec<PlannedRun> = self
                .tests
                .designs
                .iter()
                .map(|t| (space.make)(&t.name, &t.values, &x))
                .collect();
            at[i] = true;
            placed.push((space, runs));
        }
        let n: usize = placed.iter().map(|(_, runs)| runs.len()).sum();
        if n == 0 {
            return Ok(Check::Had(at));
        }
        if self.sequence.runs + n > self.limits.budget {
            reporter.report(Event::Note(format!(
                "the loop's emulators were not checked by solver runs at the decision's fitted point: the {n} run(s) \
                 it takes do not fit in the budget ({} of {} spent)",
                self.sequence.runs, self.limits.budget
            )));
            return Ok(Check::NoRoom);
        }
        for (space, runs) in placed {
            let b = self.batch_of.last().map_or(0, |b| b + 1);
            self.batch(space, runs, b, store, reporter)?;
            if let Some(last) = self.sequence.sequence.last_mut() {
                last.placed = Some("the decision's fitted point".into());
            }
        }
        self.sequence.write(&self.options.out)?;
        Ok(Check::Placed(at))
    }

    /// Each stage's own runs so far.
    fn counts(&self, stages: &Stages) -> Vec<usize> {
        stages
            .iter()
            .map(|(_, space, _)| self.plan.runs.iter().filter(|r| (space.mine)(r)).count())
            .collect()
    }

    /// The fewest runs a design's emulator needs besides its latest batch for that batch to be held
    /// out: a linear one over the stage's variables (d + 1); none with one emulator across the
    /// designs, which the other designs' runs fit (it is then fitted to the check runs as well, and
    /// checked by a refit without them: [`super::stages::fit_across`]).
    fn least(&self, space: &Space) -> usize {
        if self.sim.across_designs() {
            0
        } else {
            crate::study::SurrogateKind::Linear.min_samples(space.bounds.dim())
        }
    }

    /// Each design's latest batch of the stage's own runs becomes its check runs.
    fn mark_checks(&mut self, space: &Space, check: RunRole) {
        let names: Vec<String> = self.tests.designs.iter().map(|t| t.name.clone()).collect();
        let prior = usable_counts(&self.prior);
        for i in latest_batches(
            &self.plan,
            &self.batch_of,
            &*space.mine,
            &names,
            &prior,
            self.least(space),
        ) {
            self.plan.runs[i].role = check;
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
        let points = probe_points(posterior, &self.study.parameter_bounds());
        // With one emulator across the designs, the designs take the points in turn, one each: the
        // emulator learns how the effect changes with θ across them ([`crate::plan::sweep::probes_across`]).
        let across = crate::plan::sweep::probes_across(self.study, self.sim);
        let mut new = Vec::new();
        for (k, h) in self.study.extension_hypotheses() {
            let variables = h.extension().unwrap_or_default().to_vec();
            for (i, t) in self.tests.designs.iter().enumerate() {
                let mine: Vec<&Vec<f64>> = if across {
                    vec![&points[i % points.len()]]
                } else {
                    points.iter().collect()
                };
                for x in mine {
                    new.push(run_at(
                        &t.name,
                        &t.values,
                        as_written(self.sim, x),
                        RunRole::Extension(k),
                        variables.clone(),
                    ));
                }
            }
        }
        if new.is_empty() {
            return Ok(());
        }
        let space = Space {
            name: "probes".into(),
            bounds: self.study.parameter_bounds(),
            names: Vec::new(),
            make: Box::new(|_, _, _| unreachable!("probes are planned whole")),
            point: Box::new(|run| run.theta.clone()),
            mine: Box::new(|run| matches!(run.role, RunRole::Extension(_))),
            reserve: 0,
        };
        let n = new.len();
        self.batch(
            &space,
            new,
            1 + self.batch_of.last().copied().unwrap_or(0),
            store,
            reporter,
        )?;
        self.sequence.stop("probes", "planned", n);
        if let Some(last) = self.sequence.sequence.last_mut() {
            last.state = "done".into();
            reporter.report(Event::Batch(last));
        }
        self.sequence.write(&self.options.out)
    }

    /// The loop's runs so far as joint runs, each stage's latest batch per design as its checks,
    /// for a provisional decision (read from what the batches left, nothing swept again).
    #[allow(clippy::type_complexity)]
    fn provisional(
        &self,
        stages: &[(usize, Space, Option<Vec<(String, f64)>>)],
        edges: Vec<(usize, Vec<(String, f64)>)>,
        screening: &ScreeningRuns,
    ) -> super::extend::JointRuns {
        let mut plan = self.plan.clone();
        let names: Vec<String> = self.tests.designs.iter().map(|t| t.name.clone()).collect();
        for (k, space, edge) in stages {
            let prior = usable_counts(&prior_runs(self.study, *k, edge.as_deref(), screening));
            for i in latest_batches(&plan, &self.batch_of, &*space.mine, &names, &prior, self.least(space)) {
                plan.runs[i].role = RunRole::JointCheck(*k);
            }
        }
        let n = plan.runs.len();
        let keys = self.rendered.as_ref().map_or_else(Vec::new, |r| r.keys.clone());
        super::extend::JointRuns {
            plan,
            rendered: Prepared {
                keys,
                inputs: Default::default(),
                meshes: Default::default(),
                run_mesh: Vec::new(),
                design_mesh: Default::default(),
            },
            swept: sweep::SweepResult {
                responses: self.responses.clone(),
                classes: vec![None; n],
                quality: vec![None; n],
                reused: 0,
                errors: Vec::new(),
            },
            outcomes: RunOutcomes::default(),
            flags: vec![Vec::new(); n],
            usable: self.responses.clone(),
            edges,
            unchecked: Vec::new(),
            running: Vec::new(),
        }
    }

    /// The stage's whole plan rendered and swept once more (every run finished: nothing runs), so
    /// that its results are read back from the store like a fixed plan's; the stage's outcome table.
    fn finish(
        &mut self,
        store: &mut RunStore,
        reporter: &mut dyn Reporter,
    ) -> Result<(Plan, Prepared, sweep::SweepResult, RunOutcomes), Error> {
        let plan = std::mem::replace(&mut self.plan, Plan { runs: Vec::new() });
        let rendered = sweep::prepare_after(
            self.study,
            &crate::extract::adapters::solver(self.sim)?,
            &plan,
            self.rendered.as_ref(),
        )?;
        let (swept, _) = runs::sweep_plan(
            self.study,
            self.sim,
            &plan,
            &rendered,
            self.source,
            self.options,
            self.engine,
            store,
            &mut Quiet(reporter),
        )?;
        let outcomes = std::mem::take(&mut self.outcomes);
        reporter.report(Event::RunsEnded(&outcomes));
        self.sequence.write(&self.options.out)?;
        Ok((plan, rendered, swept, outcomes))
    }
}

/// The runs of a stage (`mine`) that are their design's latest batch: what each design's emulator
/// is checked on. A design's latest batch is held out only where the runs left to fit its emulator
/// — its earlier batches and the earlier stages' runs it also learns from (`prior`: usable runs
/// per design) — are at least `least` (the least emulator over the stage's variables, a linear
/// one: d + 1): otherwise nothing is held out there, and its error stays unmeasured. (A loop
/// stage left only its first batch by the budget, which an earlier stage spent, held all of it out
/// and then could not fit its emulator from the two probes left: `lab run` stopped with an error.)
fn latest_batches(
    plan: &Plan,
    batch_of: &[usize],
    mine: &dyn Fn(&PlannedRun) -> bool,
    designs: &[String],
    prior: &[(String, usize)],
    least: usize,
) -> Vec<usize> {
    let mut out = Vec::new();
    for name in designs {
        let runs: Vec<usize> = (0..plan.runs.len())
            .filter(|&i| &plan.runs[i].design == name && mine(&plan.runs[i]))
            .collect();
        let Some(last) = runs.iter().map(|&i| batch_of[i]).max() else {
            continue;
        };
        let earlier = runs.iter().filter(|&&i| batch_of[i] < last).count();
        let before = prior.iter().find(|(n, _)| n == name).map_or(0, |p| p.1);
        if earlier + before < least {
            continue;
        }
        out.extend(runs.into_iter().filter(|&i| batch_of[i] == last));
    }
    out
}

/// Usable runs per design among an earlier stage's runs.
fn usable_counts(prior: &[PriorRun]) -> Vec<(String, usize)> {
    let mut out: Vec<(String, usize)> = Vec::new();
    for (design, ..) in prior.iter().filter(|p| p.2.is_some()) {
        match out.iter_mut().find(|(n, _)| n == design) {
            Some(e) => e.1 += 1,
            None => out.push((design.clone(), 1)),
        }
    }
    out
}

/// The mode, and the mode plus one standard deviation along each coordinate (minus, where that
/// leaves the box).
fn probe_points(posterior: &Posterior, bounds: &Bounds) -> Vec<Vec<f64>> {
    let p = bounds.dim();
    let sd: Vec<f64> = (0..p)
        .map(|j| {
            let m = posterior.mean[j];
            let v: f64 = posterior
                .points
                .column(j)
                .iter()
                .zip(&posterior.weights)
                .map(|(x, w)| w * (x - m).powi(2))
                .sum();
            v.sqrt().max(1e-3 * bounds.width()[j])
        })
        .collect();
    let mut out = vec![posterior.mode.clone()];
    for j in 0..p {
        let mut x = posterior.mode.clone();
        x[j] = if x[j] + sd[j] <= bounds.upper[j] {
            x[j] + sd[j]
        } else {
            (x[j] - sd[j]).max(bounds.lower[j])
        };
        out.push(x);
    }
    out.iter().map(|x| seq::snap(bounds, x)).collect()
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

/// A stable hash of a stage's name (FNV-1a), so that each stage draws its own candidates.
fn fnv(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// A space-filling start in a box: `n` seeded Latin-hypercube points.
fn initial_points(bounds: &Bounds, n: usize, seed: u64) -> Vec<Vec<f64>> {
    bounds.spread_rows(&latin_hypercube(n, bounds.dim(), seed))
}

/// What the loop learns from the screening: its runs, their responses and curves, their rendering.
pub struct ScreeningRuns<'a> {
    pub plan: &'a Plan,
    pub usable: &'a [Option<f64>],
    pub curves: &'a [Option<DVector<f64>>],
    pub rendered: &'a Prepared,
}

/// The decision after the loop from provisional joint runs, with the emulators' error counted at
/// least at a floor (a share of the tests' noise variance) (`None`: no decision could be made).
pub type Decide<'d> = dyn FnMut(&super::extend::JointRuns, f64) -> Option<Provisional> + 'd;

/// A provisional decision after the loop: what may not change, and where it reads the emulators.
#[derive(Debug, Clone)]
pub struct Provisional {
    /// Changes when the verdict, the cause or the partial explanation does.
    pub key: String,
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

/// The most times the loop's tolerance is halved for a decision that its emulators' remaining error
/// could still change.
const TIGHTENINGS: usize = 3;

/// The most times the loop's emulators are checked by solver runs at the decision's fitted point.
const VERIFICATIONS: usize = 3;

/// The solver-in-the-loop's runs of `hypotheses`, sampled sequentially in each one's joint space
/// (θ × its ranged variables) from what the screening already ran there: its probes, and its
/// baseline runs where the baseline is the space's edge ([`edge`]). One stage per hypothesis; the
/// sequence's record goes on in `sequence`.
///
/// Once every stage's emulators are within the tolerance, the decision after the loop is made
/// twice ([`Decide`]): with the emulators' error as measured, and with it at the tolerance's worst
/// case (f² of the tests' noise variance). Where the two differ, the remaining error could change
/// the decision: the tolerance is halved and the stages go on.
#[allow(clippy::too_many_arguments)] // the stage's inputs, each used once
pub fn looped(
    study: &Study,
    sim: &SolverSimulation,
    hypotheses: &[usize],
    screening: &ScreeningRuns,
    source: &Source,
    options: &RunOptions,
    engine: &Engine,
    store: &mut RunStore,
    reporter: &mut dyn Reporter,
    sequence: Sequence,
    decide: &mut Decide,
) -> Result<(super::extend::JointRuns, Sequence), Error> {
    let limits = Limits::of(study, sim, options);
    let mut r = Runner::new(study, sim, source, options, engine, limits, sequence);
    r.rendered = Some(merge(None, clone_prepared(screening.rendered)));
    let mut stages = Vec::new();
    let mut edges = Vec::new();
    for &k in hypotheses {
        let Some((space, edge)) = loop_space(study, k) else {
            continue;
        };
        if edge.is_none() {
            reporter.report(Event::Note(format!(
                "'{}': a baseline run rendered with the extension at its lower bounds is not the same deck as the \
                 baseline's (write the template's default for the extension's variables as that bound, e.g. 0.0 for a \
                 range from 0.0), so the loop cannot reuse the baseline's runs and starts from the probes",
                study.diagnosis.hypotheses[k].name
            )));
        }
        if let Some(e) = &edge {
            edges.push((k, e.clone()));
        }
        r.prior = prior_runs(study, k, edge.as_deref(), screening);
        let start = r.plan.runs.len();
        let initial = r.initial_loop_runs(&space, start);
        let b = r.batch_of.last().map_or(0, |b| b + 1);
        if !initial.is_empty() {
            r.batch(&space, initial, b, store, reporter)?;
        }
        stages.push((k, space, edge));
    }
    // Room for a check of every stage at the decision's fitted point, kept from the batches.
    let checks = r.tests.designs.len() * stages.len();
    for (_, space, _) in &mut stages {
        space.reserve = checks;
    }
    let l = Looping {
        stages: &stages,
        edges: &edges,
        screening,
    };
    let unchecked = r.converge_and_check(l, decide, store, reporter)?;
    for (k, space, edge) in &stages {
        r.prior = prior_runs(study, *k, edge.as_deref(), screening);
        r.mark_checks(space, RunRole::JointCheck(*k));
    }
    let (plan, rendered, swept, outcomes) = r.finish(store, reporter)?;
    let usable = swept.usable(&sim.quality);
    let flags = swept.flags(&sim.quality.gates);
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

/// Hypothesis `k`'s joint space (`None`: no ranged variables), and its edge at the baseline.
#[allow(clippy::type_complexity)]
fn loop_space(study: &Study, k: usize) -> Option<(Space<'_>, Option<Vec<(String, f64)>>)> {
    let h = &study.diagnosis.hypotheses[k];
    let spec = h.extension_spec().filter(|e| !e.ranges.is_empty())?;
    let edge = edge(study, k);
    let ranges = spec.ranges.clone();
    let p = study.parameters.len();
    let space = Space {
        name: format!("loop: {}", h.name),
        bounds: joint_bounds(study, &ranges),
        names: study.parameters.iter().chain(&ranges).map(|q| q.name.clone()).collect(),
        make: Box::new(move |name, values, x| {
            run_at(name, values, x[..p].to_vec(), RunRole::Joint(k), spec.at(&x[p..]))
        }),
        point: Box::new(move |run| run.joint_point(&ranges)),
        mine: Box::new(move |run| matches!(run.role, RunRole::Joint(j) | RunRole::JointCheck(j) if j == k)),
        reserve: 0,
    };
    Some((space, edge))
}

fn clone_prepared(p: &Prepared) -> Prepared {
    Prepared {
        keys: Vec::new(),
        inputs: Default::default(),
        meshes: p.meshes.clone(),
        run_mesh: Vec::new(),
        design_mesh: p.design_mesh.clone(),
    }
}

/// The extension's values at the edge of hypothesis `k`'s joint space, where the baseline is that
/// edge ([`crate::study::Extension::baseline_at_edge`]): its ranged variables at their lower
/// bounds, its fixed ones at their values. There the baseline's runs are runs of the extended model.
fn edge(study: &Study, k: usize) -> Option<Vec<(String, f64)>> {
    let spec = study.diagnosis.hypotheses[k].extension_spec().expect("an extension");
    spec.baseline_at_edge.then(|| spec.at_lower_bounds())
}

/// The screening's runs that are points of hypothesis `k`'s joint space: its probes, and the
/// baseline's runs at the edge.
fn prior_runs(study: &Study, k: usize, edge: Option<&[(String, f64)]>, s: &ScreeningRuns) -> Vec<PriorRun> {
    let ranges = study.diagnosis.hypotheses[k].ranges();
    s.plan
        .runs
        .iter()
        .enumerate()
        .filter_map(|(i, run)| {
            let point = match run.role {
                RunRole::Extension(j) if j == k => run.joint_point(ranges),
                RunRole::Sample | RunRole::Check => {
                    let edge = edge?;
                    let value = |n: &str| edge.iter().find(|(m, _)| m == n).map(|v| v.1);
                    let tail: Option<Vec<f64>> = ranges.iter().map(|r| value(&r.name)).collect();
                    run.theta.iter().copied().chain(tail?).collect()
                }
                _ => return None,
            };
            Some((run.design.clone(), point, s.usable[i], s.curves[i].clone()))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `per_design[i]`: the batches design `d{i}`'s runs came in.
    fn plan_of(per_design: &[&[usize]]) -> (Plan, Vec<usize>, Vec<String>) {
        let mut runs = Vec::new();
        let mut batch_of = Vec::new();
        for (i, batches) in per_design.iter().enumerate() {
            for &b in *batches {
                runs.push(run_at(
                    &format!("d{i}"),
                    &[i as f64],
                    vec![0.5, 0.5],
                    RunRole::Joint(0),
                    Vec::new(),
                ));
                batch_of.push(b);
            }
        }
        let names = (0..per_design.len()).map(|i| format!("d{i}")).collect();
        (Plan { runs }, batch_of, names)
    }

    #[test]
    fn a_latest_batch_is_held_out_only_where_the_rest_can_fit_a_linear_emulator() {
        // Over two variables a linear emulator needs three runs.
        let (plan, batch_of, names) = plan_of(&[&[0, 0, 0], &[0, 0, 0], &[0, 0, 1, 1, 2], &[0, 0, 0]]);
        let mine = |_: &PlannedRun| true;
        let prior = vec![("d0".to_string(), 2), ("d1".to_string(), 3)];
        let held = latest_batches(&plan, &batch_of, &mine, &names, &prior, 3);
        let designs: Vec<&str> = held.iter().map(|&i| plan.runs[i].design.as_str()).collect();
        // d0: one batch and two probes (2 < 3), kept to fit; d1: three earlier runs, its batch held
        // out; d2: four runs before its last batch, that batch (one run) held out; d3: nothing before.
        assert_eq!(designs, ["d1", "d1", "d1", "d2"]);
        assert_eq!(batch_of[held[3]], 2);
    }

    #[test]
    fn usable_runs_are_counted_per_design() {
        let run = |d: &str, y: Option<f64>| (d.to_string(), vec![0.0], y, None);
        let counts = usable_counts(&[
            run("a", Some(1.0)),
            run("b", None),
            run("a", Some(2.0)),
            run("b", Some(3.0)),
        ]);
        assert_eq!(counts, [("a".to_string(), 2), ("b".to_string(), 1)]);
    }
}
