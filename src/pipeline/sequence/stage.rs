//! A stage of the sequence as a value: its space (a box and how a point becomes a run), the runs
//! of earlier stages it learns from, and what it does with what its last batch showed — the next
//! batch, or a typed reason to stop ([`Stage::next`]).

use nalgebra::DVector;

use super::sites::Tests;
use crate::base::{Bounds, latin_hypercube};
use crate::emulate::sequential::{self as seq, Posterior};
use crate::plan::sweep::{as_written, initial_samples, joint_bounds};
use crate::plan::{Plan, PlannedRun, RunRole};
use crate::study::{SolverSimulation, Study};

/// Which stage: the screening over θ, the extension hypotheses' probes, or hypothesis `k`'s loop
/// over θ and its ranged variables.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StageId {
    Screening,
    Probes,
    Loop(usize),
}

impl StageId {
    /// Its name in `sequence.json` and on the terminal: `screening`, `probes`, `loop: <hypothesis>`.
    pub fn name(self, study: &Study) -> String {
        match self {
            StageId::Screening => "screening".into(),
            StageId::Probes => "probes".into(),
            StageId::Loop(k) => format!("loop: {}", study.diagnosis.hypotheses[k].name),
        }
    }
}

/// Why a stage stopped (`sequence.json` and `results.json` `sampling.stopped[].reason`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum StopReason {
    /// The emulators' error within the tolerance at every tested design.
    #[serde(rename = "converged")]
    Converged,
    /// Nothing the stage's runs could show would change the decision.
    #[serde(rename = "settled")]
    Settled,
    /// The runs allowed are spent.
    #[serde(rename = "budget")]
    Budget,
    /// The planner found no point to run that was not run already.
    #[serde(rename = "nowhere to run")]
    NowhereToRun,
    /// A stage of fixed size.
    #[serde(rename = "planned")]
    Planned,
    /// Every run of the stage's latest two batches failed (of its first, when it has one): more
    /// runs would spend the budget on a solver that does not finish there.
    #[serde(rename = "failures")]
    Failures,
}

impl StopReason {
    /// The word `sequence.json` and the terminal use.
    pub fn key(self) -> &'static str {
        match self {
            StopReason::Converged => "converged",
            StopReason::Settled => "settled",
            StopReason::Budget => "budget",
            StopReason::NowhereToRun => "nowhere to run",
            StopReason::Planned => "planned",
            StopReason::Failures => "failures",
        }
    }
}

/// How the sequence may spend runs.
#[derive(Debug, Clone, Copy)]
pub struct Limits {
    pub batch: usize,
    pub budget: usize,
    pub seed: u64,
}

/// An earlier stage's run as a later stage sees it: its design, its point in the later stage's box,
/// its response and its curve (None where the run failed).
pub type PriorRun = (String, Vec<f64>, Option<f64>, Option<DVector<f64>>);

/// A loop stage's edge at the baseline: its extension's values there (see [`loop_stage`]).
pub type Edge = Vec<(String, f64)>;

/// How a stage makes the run at a tested design (name, values) and a point of its box.
type MakeRun<'s> = Box<dyn Fn(&str, &[f64], &[f64]) -> PlannedRun + 's>;

/// A run's point in a stage's box.
type RunPoint<'s> = Box<dyn Fn(&PlannedRun) -> Vec<f64> + 's>;

/// One stage: its box and names, how a point becomes a run, which runs are its own, the runs of an
/// earlier stage it learns from, and the runs of the budget it leaves for the stages after it.
pub struct Stage<'s> {
    pub id: StageId,
    pub name: String,
    pub bounds: Bounds,
    pub names: Vec<String>,
    make: MakeRun<'s>,
    point: RunPoint<'s>,
    mine: Box<dyn Fn(&PlannedRun) -> bool + 's>,
    /// The screening's runs that are points of this stage's space (a loop's probes, and the
    /// baseline's runs at its edge).
    pub prior: Vec<PriorRun>,
    pub reserve: usize,
}

/// What the runs in hand showed a stage: per tested design whether it is still open (its
/// emulators not yet within the tolerance), the posterior, the planner's sites and emulators.
pub struct Assessed {
    pub open: Vec<bool>,
    pub posterior: Posterior,
    pub sites: Vec<seq::Site>,
    pub emulators: Vec<seq::SiteEmulators>,
}

/// What a stage does next.
pub enum Next {
    Batch(Vec<PlannedRun>),
    Stop(StopReason),
}

impl<'s> Stage<'s> {
    /// The screening over θ: its runs are the samples (and checks), the probes and the loop's first
    /// batches come after it within the budget (`reserve`).
    pub fn screening(study: &Study, reserve: usize) -> Stage<'s> {
        Stage {
            id: StageId::Screening,
            name: StageId::Screening.name(study),
            bounds: study.parameter_bounds(),
            names: study.parameters.iter().map(|p| p.name.clone()).collect(),
            make: Box::new(|name, values, x| run_at(name, values, x.to_vec(), RunRole::Sample, Vec::new())),
            point: Box::new(|run| run.theta.clone()),
            mine: Box::new(|run| matches!(run.role, RunRole::Sample | RunRole::Check)),
            prior: Vec::new(),
            reserve,
        }
    }

    /// The probes: planned whole from the screening's posterior, never by the planner.
    pub fn probes(study: &Study) -> Stage<'s> {
        Stage {
            id: StageId::Probes,
            name: StageId::Probes.name(study),
            bounds: study.parameter_bounds(),
            names: Vec::new(),
            make: Box::new(|_, _, _| unreachable!("probes are planned whole")),
            point: Box::new(|run| run.theta.clone()),
            mine: Box::new(|run| matches!(run.role, RunRole::Extension(_))),
            prior: Vec::new(),
            reserve: 0,
        }
    }

    /// Whether `run` is one of this stage's own.
    pub fn mine(&self, run: &PlannedRun) -> bool {
        (self.mine)(run)
    }

    /// A run's point in this stage's box.
    pub fn point(&self, run: &PlannedRun) -> Vec<f64> {
        (self.point)(run)
    }

    /// The run at a tested design and a point of the box, as the solver's fields will write it.
    pub fn run_at(&self, sim: &SolverSimulation, name: &str, values: &[f64], x: &[f64]) -> PlannedRun {
        (self.make)(name, values, &as_written(sim, x))
    }

    /// Given what the runs in hand showed, `room` runs left in the budget for this stage, and
    /// whether the decision is settled whatever its runs show: the next batch (`picks`: the
    /// planner's points per tested design), or why the stage stops.
    /// `failing`: the latest batches' runs all failed.
    pub fn next(
        &self,
        assessed: &Assessed,
        (room, failing): (usize, bool),
        settled: bool,
        picks: Vec<PlannedRun>,
    ) -> Next {
        if failing {
            Next::Stop(StopReason::Failures)
        } else if !assessed.open.iter().any(|&o| o) {
            Next::Stop(StopReason::Converged)
        } else if settled {
            Next::Stop(StopReason::Settled)
        } else if room == 0 {
            Next::Stop(StopReason::Budget)
        } else if picks.is_empty() {
            Next::Stop(StopReason::NowhereToRun)
        } else {
            Next::Batch(picks)
        }
    }

    /// A loop stage's first runs: where the screening's runs in its space are fewer at a design than
    /// a space-filling start needs there, seeded Latin-hypercube points of the joint box.
    pub fn initial_loop_runs(&self, cx: (&Study, &SolverSimulation), tests: &Tests, seed: u64) -> Vec<PlannedRun> {
        let (study, sim) = cx;
        if sim.across_designs() {
            return self.initial_loop_runs_across(sim, tests, seed);
        }
        let needed = initial_samples(study, sim, self.bounds.dim());
        let have = tests
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
        let points = initial_points(&self.bounds, needed - have, seed);
        tests
            .designs
            .iter()
            .flat_map(|t| points.iter().map(|x| self.run_at(sim, &t.name, &t.values, x)))
            .collect()
    }

    /// With one emulator across the designs: where the screening's runs in its space are fewer than
    /// its linear trend over the designs' values and the space needs with a run to spare, seeded
    /// Latin-hypercube points of the joint box, round the designs.
    fn initial_loop_runs_across(&self, sim: &SolverSimulation, tests: &Tests, seed: u64) -> Vec<PlannedRun> {
        let designs = &tests.designs;
        let d = designs.first().map_or(0, |t| t.values.len());
        let needed = d + self.bounds.dim() + 2;
        let have = self.prior.iter().filter(|(_, _, y, _)| y.is_some()).count();
        if have >= needed || designs.is_empty() {
            return Vec::new();
        }
        initial_points(&self.bounds, needed - have, seed)
            .iter()
            .enumerate()
            .map(|(i, x)| {
                let t = &designs[i % designs.len()];
                self.run_at(sim, &t.name, &t.values, x)
            })
            .collect()
    }
}

pub fn run_at(name: &str, values: &[f64], theta: Vec<f64>, role: RunRole, extension: Vec<(String, f64)>) -> PlannedRun {
    PlannedRun {
        design: name.to_string(),
        design_values: values.to_vec(),
        theta,
        role,
        extension,
        seed: 0,
    }
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
    pub rendered: &'a crate::execute::sweep::Prepared,
}

/// Hypothesis `k`'s loop stage (`None`: no ranged variables), with its edge at the baseline and the
/// screening's runs in its space.
pub fn loop_stage<'s>(study: &'s Study, k: usize, screening: &ScreeningRuns) -> Option<(Stage<'s>, Option<Edge>)> {
    let h = &study.diagnosis.hypotheses[k];
    let spec = h.extension_spec().filter(|e| !e.ranges.is_empty())?;
    let edge = edge(study, k);
    let ranges = spec.ranges.clone();
    let p = study.parameters.len();
    let id = StageId::Loop(k);
    let stage = Stage {
        id,
        name: id.name(study),
        bounds: joint_bounds(study, &ranges),
        names: study.parameters.iter().chain(&ranges).map(|q| q.name.clone()).collect(),
        make: Box::new(move |name, values, x| {
            run_at(name, values, x[..p].to_vec(), RunRole::Joint(k), spec.at(&x[p..]))
        }),
        point: Box::new(move |run| run.joint_point(&ranges)),
        mine: Box::new(move |run| matches!(run.role, RunRole::Joint(j) | RunRole::JointCheck(j) if j == k)),
        prior: prior_runs(study, k, edge.as_deref(), screening),
        reserve: 0,
    };
    Some((stage, edge))
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

/// Usable runs per design among an earlier stage's runs.
pub fn usable_counts(prior: &[PriorRun]) -> Vec<(String, usize)> {
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
pub fn probe_points(posterior: &Posterior, bounds: &Bounds) -> Vec<Vec<f64>> {
    let sd = posterior_sd(posterior, bounds);
    let mut out = vec![posterior.mode.clone()];
    for j in 0..bounds.dim() {
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

/// The posterior's standard deviation along each coordinate (at least 0.1 % of the box's width).
fn posterior_sd(posterior: &Posterior, bounds: &Bounds) -> Vec<f64> {
    (0..bounds.dim())
        .map(|j| {
            let m = posterior.mean[j];
            let v: f64 = (posterior.points.column(j).iter().zip(&posterior.weights))
                .map(|(x, w)| w * (x - m).powi(2))
                .sum();
            v.sqrt().max(1e-3 * bounds.width()[j])
        })
        .collect()
}

/// The places a failed probe is tried again, in turn, as multiples of its offset from the mode:
/// mirrored through the mode first (a probe one standard deviation above it goes one below), then
/// half way out on its own side, then half way out on the other. Three tries: with a solver that
/// fails one run in ten at random, a design is then left short with probability about 1e-4.
pub const PROBE_RETRIES: [f64; 3] = [-1.0, 0.5, -0.5];

/// Where a probe placed first at `x` is tried again with the factor `f` of [`PROBE_RETRIES`]: at
/// mode + f·(x − mode), or, for the mode itself, f standard deviations along the first coordinate
/// (the other way where that leaves the box); inside the box. A linear surrogate of the extension's
/// effect over θ then still has its p + 1 points, none of them where the solver failed.
pub fn probe_replacement(x: &[f64], posterior: &Posterior, bounds: &Bounds, f: f64) -> Vec<f64> {
    let mode = &posterior.mode;
    let inside = |v: Vec<f64>| {
        let v: Vec<f64> = (0..v.len())
            .map(|j| v[j].clamp(bounds.lower[j], bounds.upper[j]))
            .collect();
        seq::snap(bounds, &v)
    };
    if inside(x.to_vec()) != inside(mode.clone()) {
        return inside(x.iter().zip(mode.iter()).map(|(x, m)| m + f * (x - m)).collect());
    }
    let step = f * posterior_sd(posterior, bounds)[0];
    let mut y = mode.clone();
    y[0] = if (bounds.lower[0]..=bounds.upper[0]).contains(&(mode[0] + step)) {
        mode[0] + step
    } else {
        mode[0] - step
    };
    inside(y)
}

/// The runs of a stage (`mine`) that are their design's latest batch: what each design's emulator
/// is checked on. A design's latest batch is held out only where the runs left to fit its emulator
/// — its earlier batches and the earlier stages' runs it also learns from (`prior`: usable runs
/// per design) — are at least `least` (the least emulator over the stage's variables, a linear
/// one: d + 1): otherwise nothing is held out there, and its error stays unmeasured. (A loop
/// stage left only its first batch by the budget, which an earlier stage spent, held all of it out
/// and then could not fit its emulator from the two probes left: `lab run` stopped with an error.)
pub fn latest_batches(
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

/// A stable hash of a stage's name (FNV-1a), so that each stage draws its own candidates.
pub fn fnv(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
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

    #[test]
    fn a_stage_stops_for_the_first_reason_that_holds() {
        let posterior = Posterior {
            points: nalgebra::DMatrix::zeros(1, 1),
            weights: vec![1.0],
            mode: vec![0.0],
            mean: vec![0.0],
            interval: vec![[0.0, 0.0]],
        };
        let assessed = |open: bool| Assessed {
            open: vec![open],
            posterior: posterior.clone(),
            sites: Vec::new(),
            emulators: Vec::new(),
        };
        let study_run = || vec![run_at("d", &[1.0], vec![0.5], RunRole::Sample, Vec::new())];
        let stage = Stage {
            id: StageId::Screening,
            name: "screening".into(),
            bounds: Bounds::new(vec![0.0], vec![1.0]),
            names: vec!["t".into()],
            make: Box::new(|n, v, x| run_at(n, v, x.to_vec(), RunRole::Sample, Vec::new())),
            point: Box::new(|r| r.theta.clone()),
            mine: Box::new(|_| true),
            prior: Vec::new(),
            reserve: 0,
        };
        let reason = |n: Next| match n {
            Next::Stop(r) => Some(r),
            Next::Batch(_) => None,
        };
        assert_eq!(
            reason(stage.next(&assessed(false), (5, false), true, study_run())),
            Some(StopReason::Converged)
        );
        assert_eq!(
            reason(stage.next(&assessed(true), (5, false), true, study_run())),
            Some(StopReason::Settled)
        );
        assert_eq!(
            reason(stage.next(&assessed(true), (0, false), false, study_run())),
            Some(StopReason::Budget)
        );
        assert_eq!(
            reason(stage.next(&assessed(true), (5, false), false, Vec::new())),
            Some(StopReason::NowhereToRun)
        );
        assert_eq!(
            reason(stage.next(&assessed(true), (5, false), false, study_run())),
            None
        );
        assert_eq!(
            reason(stage.next(&assessed(true), (5, true), false, study_run())),
            Some(StopReason::Failures)
        );
    }
}
