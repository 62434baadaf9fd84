//! Confirmation runs: the solver at the fitted parameters of each model a verdict rests on, one
//! run per tested design, all in one batch, fixed and sequential designs, live, on Slurm or
//! replayed alike ([`crate::diagnose::confirm`] judges them).
//!
//! The models: the uncorrected simulation at its fitted parameters (the tests' noise alone), and
//! each cause a decision names — a looped extension at its extended model's fitted point (θ and
//! its ranged variables, run with the extension's template variables there), a screening candidate
//! at its fitted θ with its own term added to the solver's value.

use indexmap::IndexMap;
use nalgebra::DVector;

use super::diagnosis::{Finished, Reading};
use super::runs::{self, RunContext, RunOutcomes};
use super::sequence::record::Failed;
use super::{Event, Reporter, curves, extend};
use crate::diagnose::confirm::{Claim, Confirmation, Confirming, UNCORRECTED, claims, confirm_held, confirm_seeds};
use crate::diagnose::verdict::Verdict;
use crate::diagnose::{Diagnosis, Inputs, NoiseModel};
use crate::error::Error;
use crate::execute::quality::Flag;
use crate::execute::sweep::{self, Prepared, SweepResult};
use crate::plan::{Plan, PlannedRun, RunRole};
use crate::study::{SolverSimulation, Study};

/// The confirmation runs of a solver study.
pub struct ConfirmRuns {
    pub plan: Plan,
    pub rendered: Prepared,
    pub swept: SweepResult,
    pub outcomes: RunOutcomes,
    pub flags: Vec<Vec<Flag>>,
}

/// Where the confirmation runs go: the screening's rendering (its meshes), its store and, for a
/// sequential study, its record.
pub(super) type Made<'r> = (
    &'r Prepared,
    &'r mut super::Executed,
    &'r mut Option<super::sequence::Sequence>,
);

/// One model to confirm: what the solver runs, and how its values are judged.
pub(super) struct Subject<'a> {
    pub confirming: Confirming<'a>,
    /// The runs' parameters (θ) and template variables (an extension's).
    pub theta: Vec<f64>,
    pub extension: Vec<(String, f64)>,
    /// The level its lack of fit is judged at (the decision's for the claim it checks).
    pub level: f64,
    /// The loop's runs of this model already at `theta` (one per tested design, indices into the
    /// joint runs' plan): the solver is not run again ([`already_ran`]).
    pub ran: Option<Vec<usize>>,
    /// Its runs' role: a confirmation's, or a run over an open extension's amplitude.
    pub role: RunRole,
    /// Judged under the decision's noise alone ([`confirm_held`]): the uncorrected model where the
    /// verdict claims it misses.
    pub noise_held: bool,
}

/// A looped hypothesis's model as a confirmation reads it: its inputs (over θ and its ranged
/// variables) and its fitted point in each decision (with the emulators' error counted, with the
/// tests' noise alone), from its own diagnosis.
pub(super) struct LoopReading<'m> {
    pub hypothesis: usize,
    pub model: LoopModel<'m>,
    pub fitted: [IndexMap<String, f64>; 2],
    /// The fitted point's standard errors in each decision (empty without a covariance).
    pub se: [IndexMap<String, f64>; 2],
}

/// A looped model's inputs: the response's, or the curves' with their feature problem.
pub(super) enum LoopModel<'m> {
    Response(Box<Inputs<'m>>),
    Curves(
        Box<(
            crate::diagnose::features::CurveInputs<'m>,
            crate::diagnose::features::FeatureProblem,
        )>,
    ),
}

impl ConfirmRuns {
    /// These runs and `more` after them, as one set.
    pub(super) fn merge(mut self, more: ConfirmRuns) -> ConfirmRuns {
        self.plan.runs.extend(more.plan.runs);
        self.rendered.append(more.rendered);
        self.swept.append(more.swept);
        self.outcomes = self.outcomes.merge(more.outcomes);
        self.flags.extend(more.flags);
        self
    }
}

impl LoopReading<'_> {
    pub(super) fn inputs(&self) -> Inputs<'_> {
        match &self.model {
            LoopModel::Response(i) => (**i).clone(),
            LoopModel::Curves(c) => c.1.inputs(&c.0),
        }
    }
}

/// What the loop models' inputs carry besides their own: the study's simulation (its surrogates)
/// and the extensions' screening models, whose shapes are the other explanations' candidates in a
/// loop model's diagnosis (and its confirmation's rivals).
pub(super) type Shapes<'s> = (
    &'s Study,
    &'s std::sync::Arc<dyn crate::emulate::Model + Send>,
    &'s [(usize, std::sync::Arc<dyn crate::emulate::Model + Send>)],
);

/// Each looped hypothesis's model and fitted points (`own`: each decision's loop diagnoses, in
/// the order of `models`), with the other explanations' shapes as its diagnosis had them.
pub(super) fn loop_readings<'m>(
    stage: Option<&curves::CurveStage>,
    (models, shapes): (&'m [extend::ExtendedModel], Shapes),
    loop_curves: &[(usize, crate::emulate::functional::CurveModel)],
    own: [&[Diagnosis]; 2],
) -> Result<Vec<LoopReading<'m>>, Error> {
    let (study, baseline, extensions) = shapes;
    models
        .iter()
        .enumerate()
        .map(|(j, m)| {
            let model = match stage {
                None => LoopModel::Response(Box::new(extend::loop_model(study, m, baseline, extensions).inputs)),
                Some(s) => {
                    let curve = loop_curves.iter().find(|(k, _)| *k == m.hypothesis).map(|(_, c)| c);
                    let curve = curve.ok_or_else(|| Error::Failed("internal: a loop model without curves".into()))?;
                    let base = Some((curves::curve_fn(s.baseline.clone()), study.parameters.len()));
                    let others = curves::extension_hypotheses(study, &s.extension_fns(), base, Some(m.hypothesis));
                    let mut ci = curves::inputs(&m.study, &s.setting, s.designs.clone(), curve, others);
                    ci.settings.emulator_counted = false;
                    let problem = crate::diagnose::features::FeatureProblem::new(&ci).map_err(Error::Failed)?;
                    LoopModel::Curves(Box::new((ci, problem)))
                }
            };
            let fitted = own.map(|o| {
                o.get(j)
                    .map(|d| d.record.uncorrected.parameters.clone())
                    .unwrap_or_default()
            });
            let se = own.map(|o| {
                o.get(j)
                    .and_then(|d| d.record.uncorrected.precision.as_ref())
                    .map(|p| p.se.clone())
                    .unwrap_or_default()
            });
            Ok(LoopReading {
                hypothesis: m.hypothesis,
                model,
                fitted,
                se,
            })
        })
        .collect()
}

/// The models the two decisions rest on: the uncorrected simulation at its fitted parameters
/// (noise alone), then each named cause's model in each decision (`decided`: counted, then noise
/// alone), then the loop models each put out beside its cause on their lack of fit (their misses
/// are claimed too, [`crate::diagnose::confirm::rejected_beside`]; last, so that a sequential
/// budget keeps its room for the causes first).
pub(super) fn subjects<'a>(
    study: &Study,
    decided: &[Finished; 2],
    screening: &'a Inputs<'a>,
    (readings, inputs, joint): (&[LoopReading], &'a [Inputs<'a>], Option<&extend::JointRuns>),
) -> Vec<Subject<'a>> {
    // The loop's runs are at one seed of the solver's imperfection: where `simulation.seeds` asks
    // for several, a confirmation needs each seed's run, so the loop's do not serve.
    let seeded = matches!(&study.simulation, crate::study::Simulation::Solver(s) if s.inputs.seeds.is_some());
    let joint = joint.filter(|_| !seeded);
    let noise_alone = &decided[1].diagnosis;
    let mut out = vec![uncorrected(screening, noise_alone)];
    let named = |d: &Diagnosis| match (d.finding.verdict, &d.finding.cause) {
        (Verdict::CauseNamed, Some(cause)) => Some(cause.clone()),
        _ => None,
    };
    let causes = (decided.iter().enumerate()).filter_map(|(which, f)| Some((which, named(&f.diagnosis)?, None)));
    let rejected = decided.iter().enumerate().flat_map(|(which, f)| {
        let beside = named(&f.diagnosis).map(|c| crate::diagnose::confirm::rejected_beside(&f.diagnosis, &c));
        beside
            .into_iter()
            .flatten()
            .map(move |(name, level)| (which, name, Some(level)))
    });
    let wanted: Vec<(usize, String, Option<f64>)> = causes.chain(rejected).collect();
    for (which, name, out_at) in wanted {
        if out.iter().any(|s| s.confirming.name == name) {
            continue;
        }
        let d = &decided[which].diagnosis;
        let looped = readings
            .iter()
            .zip(inputs)
            .find(|(l, _)| study.diagnosis.hypotheses[l.hypothesis].name == name);
        let subject = match looped {
            Some((l, inputs)) => {
                looped_cause(study, l, inputs, which, d).map(|s| s.already_ran(study, l, which, joint))
            }
            None => candidate_cause(screening, d, &name),
        };
        out.extend(subject.map(|s| s.judged_as_out(out_at)));
    }
    out
}

/// The other explanations the after-loop step judged against the named `cause` (its survivors,
/// not out by their lack of fit), each with the level of its pair: the rivals whose shapes the
/// cause's confirmation adds to its model on the solver's runs.
fn survivors(d: &Diagnosis, cause: &str) -> Vec<(String, f64)> {
    let Some(a) = &d.checked.after_loop else {
        return Vec::new();
    };
    let others: Vec<String> = (a.explanations.iter())
        .filter(|e| !e.rejected && e.name != cause)
        .map(|e| e.name.clone())
        .collect();
    // Every pair is judged at one level, α over the other survivors (as the after-loop step).
    let level = crate::diagnose::levels::Levels::new(d.record.levels.alpha, false).rival(others.len());
    others.into_iter().map(|name| (name, level)).collect()
}

/// The uncorrected simulation at the noise-alone decision's fitted parameters.
fn uncorrected<'a>(screening: &'a Inputs<'a>, d: &Diagnosis) -> Subject<'a> {
    let point = values(&screening.space.parameter_names, &d.record.uncorrected.parameters);
    Subject {
        confirming: Confirming {
            name: UNCORRECTED.into(),
            inputs: screening,
            point: point.clone(),
            correction: vec![0.0; screening.observations.len()],
            rivals: Vec::new(),
        },
        theta: point,
        extension: Vec::new(),
        level: d.record.levels.uncorrected_fit,
        ran: None,
        role: RunRole::Confirm,
        noise_held: claims(d).contains(&(UNCORRECTED.to_string(), Claim::Misses)),
    }
}

/// A looped extension's model at its fitted point in decision `which`.
fn looped_cause<'a>(
    study: &Study,
    l: &LoopReading,
    inputs: &'a Inputs<'a>,
    which: usize,
    d: &Diagnosis,
) -> Option<Subject<'a>> {
    let h = &study.diagnosis.hypotheses[l.hypothesis];
    let spec = h.extension_spec()?;
    let point = values(&inputs.space.parameter_names, &l.fitted[which]);
    let p = study.parameters.len();
    Some(Subject {
        confirming: Confirming {
            name: h.name.clone(),
            inputs,
            point: point.clone(),
            correction: vec![0.0; inputs.observations.len()],
            rivals: survivors(d, &h.name),
        },
        theta: point[..p].to_vec(),
        extension: spec.at(&point[p..]),
        level: d.record.levels.cause_fit,
        ran: None,
        role: RunRole::Confirm,
        noise_held: false,
    })
}

impl Subject<'_> {
    /// A loop model put out on its lack of fit (`level`: the one it was judged at), whose miss
    /// the solver's runs judge: its lack of fit at that level, under the noise the decision put it
    /// out under (as the uncorrected model's claimed miss, [`confirm_held`]), no rival's shape
    /// added to it.
    fn judged_as_out(mut self, level: Option<f64>) -> Self {
        if let Some(level) = level {
            self.level = level;
            self.noise_held = true;
            self.confirming.rivals.clear();
        }
        self
    }

    /// A looped model confirmed by runs the loop already made ([`already_ran`]), where there are
    /// such runs: the subject then sits at their point.
    fn already_ran(mut self, study: &Study, l: &LoopReading, which: usize, joint: Option<&extend::JointRuns>) -> Self {
        let names = &self.confirming.inputs.space.parameter_names;
        let se = values(names, &l.se[which]);
        let Some((ran, at)) = joint.and_then(|j| already_ran(study, j, l.hypothesis, &self.confirming.point, &se))
        else {
            return self;
        };
        let p = study.parameters.len();
        let spec = study.diagnosis.hypotheses[l.hypothesis].extension_spec();
        self.extension = spec.map_or_else(Vec::new, |s| s.at(&at[p..]));
        self.theta = at[..p].to_vec();
        self.confirming.point = at;
        self.ran = Some(ran);
        self
    }
}

/// The loop's runs of hypothesis `k` at one point at every tested design, all finished, where that
/// point is within one standard error of the `fitted` one in every variable (`se`, the fit's own
/// Gauss–Newton errors): a point the tests cannot tell from the fitted one, so the solver's values
/// there confirm the model as well as new runs at the fit would (the bridge then moves them the
/// small step, [`crate::diagnose::confirm`]). The loop's check at the decision's fitted point is
/// such a batch. The nearest such point: its runs (one per tested design) and the point.
fn already_ran(
    study: &Study,
    joint: &extend::JointRuns,
    k: usize,
    fitted: &[f64],
    se: &[f64],
) -> Option<(Vec<usize>, Vec<f64>)> {
    let ranges = study.diagnosis.hypotheses[k].ranges();
    let designs: Vec<&String> = crate::plan::sweep::tested_designs(study).map(|(n, _)| n).collect();
    let runs = &joint.plan.runs;
    let mine = |i: usize| {
        matches!(runs[i].role, RunRole::Joint(j) | RunRole::JointCheck(j) if j == k) && joint.usable[i].is_some()
    };
    let distance = |x: &[f64]| {
        x.iter()
            .zip(fitted)
            .zip(se)
            .map(|((a, b), s)| (a - b).abs() / s)
            .fold(0.0, f64::max)
    };
    let mut best: Option<(f64, Vec<usize>, Vec<f64>)> = None;
    let first = *designs.first()?;
    for i in (0..runs.len()).filter(|&i| mine(i) && &runs[i].design == first) {
        let x = runs[i].joint_point(ranges);
        let d = distance(&x);
        if d.is_nan() || d > 1.0 || best.as_ref().is_some_and(|b| b.0 <= d) {
            continue;
        }
        let at: Option<Vec<usize>> = designs
            .iter()
            .map(|name| {
                (0..runs.len()).find(|&j| mine(j) && &runs[j].design == *name && runs[j].joint_point(ranges) == x)
            })
            .collect();
        if let Some(at) = at {
            best = Some((d, at, x));
        }
    }
    best.map(|(_, at, x)| (at, x))
}

/// A screening candidate's model: the simulation at its fitted θ, its term added to the solver's
/// value (its prediction less the emulator's at the same θ).
fn candidate_cause<'a>(screening: &'a Inputs<'a>, d: &Diagnosis, cause: &str) -> Option<Subject<'a>> {
    let c = d.explained.candidates.iter().find(|c| c.shape.name == cause)?;
    let point = values(&screening.space.parameter_names, &c.fit.parameters);
    let correction = screening
        .observations
        .iter()
        .map(|o| {
            c.checks.predictions.get(&o.name).copied().unwrap_or(f64::NAN)
                - screening.model.predict(&screening.point(o), &point)
        })
        .collect();
    Some(Subject {
        confirming: Confirming {
            name: cause.to_string(),
            inputs: screening,
            point: point.clone(),
            correction,
            rivals: Vec::new(),
        },
        theta: point,
        extension: Vec::new(),
        level: d.record.levels.cause_fit,
        ran: None,
        role: RunRole::Confirm,
        noise_held: false,
    })
}

/// `named` in the order of `names` (NaN for a name it lacks).
fn values(names: &[String], named: &IndexMap<String, f64>) -> Vec<f64> {
    names
        .iter()
        .map(|n| named.get(n).copied().unwrap_or(f64::NAN))
        .collect()
}

/// Runs already made that a confirmation reads again instead of running the solver: the loop's
/// (a looped model's [`Subject::ran`]) and the confirmation made before a loop the solver's runs
/// over an amplitude started (the same model at the same point: planned again, it would be counted
/// twice).
#[derive(Clone, Copy, Default)]
pub(super) struct Earlier<'r> {
    pub joint: Option<&'r extend::JointRuns>,
    pub confirmed: Option<&'r ConfirmRuns>,
}

/// Some runs already made, as [`solver_values`] reads them.
struct MadeRuns {
    plan: Plan,
    keys: Vec<String>,
    usable: Vec<Option<f64>>,
}

impl Earlier<'_> {
    /// The runs already made that confirm `s` (`planned`: the runs it would need), if any.
    fn runs_of(&self, cx: RunContext, s: &Subject, planned: &[PlannedRun]) -> Option<MadeRuns> {
        let (idx, plan, keys, usable) = match (&s.ran, self.joint, self.confirmed) {
            (Some(ran), Some(j), _) => (
                ran.clone(),
                &j.plan,
                &j.rendered.keys,
                ran.iter().map(|&i| j.usable[i]).collect(),
            ),
            (None, _, Some(c)) => {
                let idx: Vec<usize> = (planned.iter())
                    .map(|p| c.plan.runs.iter().position(|r| r == p))
                    .collect::<Option<_>>()?;
                let all = c.swept.usable(&cx.sim.quality);
                let usable = idx.iter().map(|&i| all[i]).collect();
                (idx, &c.plan, &c.rendered.keys, usable)
            }
            _ => return None,
        };
        Some(MadeRuns {
            plan: Plan {
                runs: idx.iter().map(|&i| plan.runs[i].clone()).collect(),
            },
            keys: idx.iter().map(|&i| keys[i].clone()).collect(),
            usable,
        })
    }
}

/// Runs every subject at every tested design in one batch (recorded in a sequential study's
/// record as the stage of the subjects' role: confirmation, or not_excluded), but for those whose
/// runs were already made ([`Earlier`]), and judges each against the tests' `noise` alone.
pub(super) fn run(
    cx: RunContext,
    (rendered_before, executed, sequence): Made,
    subjects: &[Subject],
    (read, noise, earlier): (&Reading, &NoiseModel, Earlier),
    reporter: &mut dyn Reporter,
) -> Result<(Vec<Confirmation>, Option<ConfirmRuns>), Error> {
    if subjects.is_empty() {
        return Ok((Vec::new(), None));
    }
    let (study, sim) = (cx.study, cx.sim);
    let designs: Vec<(&String, &Vec<f64>)> = crate::plan::sweep::tested_designs(study).collect();
    let seeds = sim.inputs.seeds.as_ref().map_or(1, |s| s.count);
    let wanted: Vec<Vec<PlannedRun>> = subjects.iter().map(|s| planned(sim, s, &designs, seeds)).collect();
    let before: Vec<Option<MadeRuns>> = (subjects.iter().zip(&wanted))
        .map(|(s, w)| earlier.runs_of(cx, s, w))
        .collect();
    let fit = within_budget(
        cx,
        sequence.as_ref(),
        before.iter().map(Option::is_none),
        designs.len() * seeds,
    );
    let plan = Plan {
        runs: (wanted.into_iter().zip(&before).take(fit))
            .filter(|(_, b)| b.is_none())
            .flat_map(|(w, _)| w)
            .collect(),
    };
    let made = match plan.runs.is_empty() {
        true => None,
        false => {
            // A confirmation after the runs this `lab run` made before a loop adds to their plan.
            let append = earlier.confirmed.is_some();
            Some(sweep_batch(
                cx,
                (rendered_before, executed, sequence),
                (plan, append),
                reporter,
            )?)
        }
    };
    let fresh_values = made.as_ref().map_or_else(Vec::new, |m| {
        solver_values(
            cx,
            executed,
            read,
            (&m.plan, &m.rendered.keys, &m.swept.usable(&sim.quality)),
        )
    });
    let nd = designs.len() * seeds;
    let mut next_fresh = 0;
    let confirmations = (subjects.iter().zip(&before).take(fit))
        .map(|(s, b)| {
            let runs: Vec<Option<DVector<f64>>> = match b {
                Some(b) => solver_values(cx, executed, read, (&b.plan, &b.keys, &b.usable)),
                None => {
                    next_fresh += 1;
                    fresh_values[(next_fresh - 1) * nd..next_fresh * nd].to_vec()
                }
            };
            let mut c = judged(s, &designs, &runs, noise);
            c.reused = s.ran.is_some() && b.is_some();
            c
        })
        .collect();
    Ok((confirmations, made))
}

/// A subject judged on its runs' values (`runs`: a design's consecutive, one per seed it ran at).
fn judged(
    s: &Subject,
    designs: &[(&String, &Vec<f64>)],
    runs: &[Option<DVector<f64>>],
    noise: &NoiseModel,
) -> Confirmation {
    let per_design = runs.len() / designs.len().max(1);
    let solver: Vec<Vec<f64>> = s
        .confirming
        .inputs
        .observations
        .iter()
        .map(|o| match designs.iter().position(|(n, _)| **n == o.group) {
            Some(d) => runs[d * per_design..(d + 1) * per_design]
                .iter()
                .filter_map(|v| v.as_ref()?.get(o.output).copied())
                .collect(),
            None => Vec::new(),
        })
        .collect();
    match s.noise_held {
        true => confirm_held(&s.confirming, &solver, noise, s.level),
        false => confirm_seeds(&s.confirming, &solver, noise, s.level),
    }
}

/// A subject's confirmation runs: at every tested design, at each of the `seeds` of the solver's
/// imperfection (consecutive).
fn planned(sim: &SolverSimulation, s: &Subject, designs: &[(&String, &Vec<f64>)], seeds: usize) -> Vec<PlannedRun> {
    let theta = crate::plan::sweep::as_written(sim, &s.theta);
    let extension: Vec<(String, f64)> = (s.extension.iter())
        .map(|(n, v)| (n.clone(), crate::plan::sweep::as_written(sim, &[*v])[0]))
        .collect();
    let at = |(name, values): &(&String, &Vec<f64>), seed| PlannedRun {
        design: (*name).clone(),
        design_values: (*values).clone(),
        theta: theta.clone(),
        role: s.role,
        extension: extension.clone(),
        seed,
    };
    designs
        .iter()
        .flat_map(|d| (0..seeds).map(|k| at(d, k)).collect::<Vec<_>>())
        .collect()
}

/// The new runs swept as one batch, recorded as their role's stage (every run of a batch has one
/// role); confirmation-plan.json written anew for the confirmation, appended to after it (and by a
/// confirmation that follows earlier ones of the same `lab run`: `append`).
fn sweep_batch(
    cx: RunContext,
    (rendered_before, executed, sequence): Made,
    (plan, append): (Plan, bool),
    reporter: &mut dyn Reporter,
) -> Result<ConfirmRuns, Error> {
    let (study, sim) = (cx.study, cx.sim);
    let role = plan.runs[0].role;
    let stage = role.stage(study);
    let solver = crate::extract::adapters::solver(sim)?;
    let rendered = sweep::prepare_after(study, &solver, &plan, Some(rendered_before))?;
    match sequence.as_mut() {
        Some(sequence) => sequence.planned_batch(&stage, &plan, &cx.options.out)?,
        None => write_plan(&cx.options.out, &plan, append || role != RunRole::Confirm)?,
    }
    let (swept, outcomes) = runs::sweep_plan(cx, &plan, &rendered, &mut executed.store, reporter)?;
    if let Some(b) = match sequence.as_mut() {
        Some(sequence) => {
            let failed = Failed::of(&outcomes);
            sequence.finish_planned(&stage, (plan.runs.len(), failed), &cx.options.out)?
        }
        None => None,
    } {
        reporter.report(Event::Batch(b));
    }
    let flags = swept.flags(&sim.quality.gates);
    Ok(ConfirmRuns {
        plan,
        rendered,
        swept,
        outcomes,
        flags,
    })
}

/// `OUT/confirmation-plan.json`: a fixed design's confirmation runs (and its runs over the open
/// amplitudes after them), written before they start so that `lab status` counts them (a
/// sequential study's are in its `sequence.json`).
pub const PLAN_FILE: &str = "confirmation-plan.json";

/// Writes `plan` as the file's runs, or after the runs already in it (`after`: a later batch of
/// the same `lab run`).
fn write_plan(out: &std::path::Path, plan: &Plan, after: bool) -> Result<(), Error> {
    let before = if after { recorded_plan(out) } else { Vec::new() };
    let planned: Vec<_> = (before.iter().chain(&plan.runs))
        .map(super::sequence::record::Planned::of)
        .collect();
    let text = serde_json::to_vec_pretty(&planned).map_err(|e| Error::Failed(e.to_string()))?;
    let path = out.join(PLAN_FILE);
    crate::execute::store::write_atomic(&path, &text)
        .map_err(|e| Error::Failed(format!("cannot write {}: {e}", path.display())))
}

/// The confirmation runs the last `lab run` on `out` planned (empty when none).
pub fn recorded_plan(out: &std::path::Path) -> Vec<PlannedRun> {
    std::fs::read(out.join(PLAN_FILE))
        .ok()
        .and_then(|bytes| serde_json::from_slice::<Vec<super::sequence::record::Planned>>(&bytes).ok())
        .map(|p| p.iter().map(super::sequence::record::Planned::run).collect())
        .unwrap_or_default()
}

/// The subjects a sequential study's budget has room for, in their order (the uncorrected
/// simulation first; one already run needs no room); a fixed design runs them all.
fn within_budget(
    cx: RunContext,
    sequence: Option<&super::sequence::Sequence>,
    needs_runs: impl Iterator<Item = bool>,
    designs: usize,
) -> usize {
    let budget = sequence.and(crate::plan::sweep::sequential_budget(cx.study, cx.sim));
    let (Some(sequence), Some(budget)) = (sequence, budget) else {
        return usize::MAX;
    };
    let mut room = budget.saturating_sub(sequence.runs);
    needs_runs
        .take_while(|&needs| {
            let needs = if needs { designs } else { 0 };
            let fits = needs <= room;
            room = room.saturating_sub(needs);
            fits
        })
        .count()
}

/// Each run's values as the decisions read them: with curves, its curve features whitened by the
/// tests' scatter alone (as the noise-alone decision read the specimens); else its response.
fn solver_values(
    cx: RunContext,
    executed: &super::Executed,
    read: &Reading,
    (plan, keys, usable): (&Plan, &[String], &[Option<f64>]),
) -> Vec<Option<DVector<f64>>> {
    let (Some(problem), Some(setting)) = (read.problem(false), curves::Setting::of(cx.study)) else {
        return usable.iter().map(|u| u.map(|v| DVector::from_element(1, v))).collect();
    };
    let dirs = executed.output_dirs(cx.sim);
    let grid = curves::on_grid(cx.study, cx.sim, &setting, keys, usable, &dirs);
    plan.runs
        .iter()
        .zip(grid)
        .map(|(r, c)| problem.model.whiten_curve(&r.design_values, c?.as_slice()))
        .collect()
}
