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
use super::{Event, Reporter, curves, extend};
use crate::diagnose::confirm::{Confirmation, Confirming, UNCORRECTED, confirm};
use crate::diagnose::verdict::Verdict;
use crate::diagnose::{Diagnosis, Inputs, NoiseModel};
use crate::error::Error;
use crate::execute::quality::Flag;
use crate::execute::sweep::{self, Prepared, SweepResult};
use crate::plan::{Plan, PlannedRun, RunRole};
use crate::study::Study;

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
}

/// A looped hypothesis's model as a confirmation reads it: its inputs (over θ and its ranged
/// variables) and its fitted point in each decision (with the emulators' error counted, with the
/// tests' noise alone), from its own diagnosis.
pub(super) struct LoopReading<'m> {
    pub hypothesis: usize,
    pub model: LoopModel<'m>,
    pub fitted: [IndexMap<String, f64>; 2],
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

impl LoopReading<'_> {
    pub(super) fn inputs(&self) -> Inputs<'_> {
        match &self.model {
            LoopModel::Response(i) => (**i).clone(),
            LoopModel::Curves(c) => c.1.inputs(&c.0),
        }
    }
}

/// Each looped hypothesis's model and fitted points (`own`: each decision's loop diagnoses, in
/// the order of `models`).
pub(super) fn loop_readings<'m>(
    stage: Option<&curves::CurveStage>,
    models: &'m [extend::ExtendedModel],
    loop_curves: &[(usize, crate::emulate::functional::CurveModel)],
    own: [&[Diagnosis]; 2],
) -> Result<Vec<LoopReading<'m>>, Error> {
    models
        .iter()
        .enumerate()
        .map(|(j, m)| {
            let model = match stage {
                None => LoopModel::Response(Box::new(crate::diagnose::inputs_from_study(&m.study, &m.surrogates))),
                Some(s) => {
                    let curve = loop_curves.iter().find(|(k, _)| *k == m.hypothesis).map(|(_, c)| c);
                    let curve = curve.ok_or_else(|| Error::Failed("internal: a loop model without curves".into()))?;
                    let mut ci = curves::inputs(&m.study, &s.setting, s.designs.clone(), curve, Vec::new());
                    ci.settings.emulator_counted = false;
                    let problem = crate::diagnose::features::FeatureProblem::new(&ci).map_err(Error::Failed)?;
                    LoopModel::Curves(Box::new((ci, problem)))
                }
            };
            let fitted = own.map(|o| o.get(j).map(|d| d.uncorrected.parameters.clone()).unwrap_or_default());
            Ok(LoopReading {
                hypothesis: m.hypothesis,
                model,
                fitted,
            })
        })
        .collect()
}

/// The models the two decisions rest on: the uncorrected simulation at its fitted parameters
/// (noise alone), then each named cause's model in each decision (`decided`: counted, then noise
/// alone).
pub(super) fn subjects<'a>(
    study: &Study,
    decided: &[Finished; 2],
    screening: &'a Inputs<'a>,
    (readings, inputs): (&[LoopReading], &'a [Inputs<'a>]),
) -> Vec<Subject<'a>> {
    let noise_alone = &decided[1].diagnosis;
    let mut out = vec![uncorrected(screening, noise_alone)];
    for (which, f) in decided.iter().enumerate() {
        let d = &f.diagnosis;
        let (Verdict::CauseNamed, Some(cause)) = (d.verdict, &d.cause) else {
            continue;
        };
        if out.iter().any(|s| &s.confirming.name == cause) {
            continue;
        }
        let looped = readings
            .iter()
            .zip(inputs)
            .find(|(l, _)| &study.diagnosis.hypotheses[l.hypothesis].name == cause);
        let subject = match looped {
            Some((l, inputs)) => looped_cause(study, l, inputs, which, d),
            None => candidate_cause(screening, d, cause),
        };
        out.extend(subject);
    }
    out
}

/// The uncorrected simulation at the noise-alone decision's fitted parameters.
fn uncorrected<'a>(screening: &'a Inputs<'a>, d: &Diagnosis) -> Subject<'a> {
    let point = values(&screening.parameter_names, &d.uncorrected.parameters);
    Subject {
        confirming: Confirming {
            name: UNCORRECTED.into(),
            inputs: screening,
            point: point.clone(),
            correction: vec![0.0; screening.observations.len()],
        },
        theta: point,
        extension: Vec::new(),
        level: d.levels.uncorrected_fit,
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
    let point = values(&inputs.parameter_names, &l.fitted[which]);
    let p = study.parameters.len();
    Some(Subject {
        confirming: Confirming {
            name: h.name.clone(),
            inputs,
            point: point.clone(),
            correction: vec![0.0; inputs.observations.len()],
        },
        theta: point[..p].to_vec(),
        extension: spec.at(&point[p..]),
        level: d.levels.cause_fit,
    })
}

/// A screening candidate's model: the simulation at its fitted θ, its term added to the solver's
/// value (its prediction less the emulator's at the same θ).
fn candidate_cause<'a>(screening: &'a Inputs<'a>, d: &Diagnosis, cause: &str) -> Option<Subject<'a>> {
    let c = d.candidates.iter().find(|c| c.name == cause)?;
    let point = values(&screening.parameter_names, &c.parameters);
    let correction = screening
        .observations
        .iter()
        .map(|o| {
            c.predictions.get(&o.name).copied().unwrap_or(f64::NAN)
                - screening.model.predict(&screening.point(o), &point)
        })
        .collect();
    Some(Subject {
        confirming: Confirming {
            name: cause.to_string(),
            inputs: screening,
            point: point.clone(),
            correction,
        },
        theta: point,
        extension: Vec::new(),
        level: d.levels.cause_fit,
    })
}

/// `named` in the order of `names` (NaN for a name it lacks).
fn values(names: &[String], named: &IndexMap<String, f64>) -> Vec<f64> {
    names
        .iter()
        .map(|n| named.get(n).copied().unwrap_or(f64::NAN))
        .collect()
}

/// Runs every subject at every tested design in one batch (recorded in a sequential study's
/// record as the stage `confirmation`) and judges each against the tests' `noise` alone.
pub(super) fn run(
    cx: RunContext,
    (rendered_before, executed, sequence): Made,
    subjects: &[Subject],
    (read, noise): (&Reading, &NoiseModel),
    reporter: &mut dyn Reporter,
) -> Result<(Vec<Confirmation>, Option<ConfirmRuns>), Error> {
    if subjects.is_empty() {
        return Ok((Vec::new(), None));
    }
    let (study, sim) = (cx.study, cx.sim);
    let designs: Vec<(&String, &Vec<f64>)> = crate::plan::sweep::tested_designs(study).collect();
    let subjects = within_budget(cx, sequence.as_ref(), subjects, designs.len());
    let plan = Plan {
        runs: subjects
            .iter()
            .flat_map(|s| {
                designs.iter().map(move |(name, values)| PlannedRun {
                    design: (*name).clone(),
                    design_values: (*values).clone(),
                    theta: crate::plan::sweep::as_written(sim, &s.theta),
                    role: RunRole::Confirm,
                    extension: s
                        .extension
                        .iter()
                        .map(|(n, v)| (n.clone(), crate::plan::sweep::as_written(sim, &[*v])[0]))
                        .collect(),
                })
            })
            .collect(),
    };
    let solver = crate::extract::adapters::solver(sim)?;
    let rendered = sweep::prepare_after(study, &solver, &plan, Some(rendered_before))?;
    match sequence.as_mut() {
        Some(sequence) => sequence.planned_batch("confirmation", &plan, &cx.options.out)?,
        None => write_plan(&cx.options.out, &plan)?,
    }
    let (swept, outcomes) = runs::sweep_plan(cx, &plan, &rendered, &mut executed.store, reporter)?;
    if let Some(b) = match sequence.as_mut() {
        Some(sequence) => sequence.finish_planned("confirmation", plan.runs.len(), &cx.options.out)?,
        None => None,
    } {
        reporter.report(Event::Batch(b));
    }
    let usable = swept.usable(&sim.quality);
    let whitened = whitened_features(cx, executed, read, (&plan, &rendered, &usable));
    let nd = designs.len();
    let confirmations = subjects
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let obs = &s.confirming.inputs.observations;
            let solver: Vec<Option<f64>> = obs
                .iter()
                .map(|o| {
                    let d = designs.iter().position(|(n, _)| **n == o.group)?;
                    let at = i * nd + d;
                    match &whitened {
                        Some(w) => w[at].as_ref().map(|z| z[o.output]),
                        None => usable[at],
                    }
                })
                .collect();
            confirm(&s.confirming, &solver, noise, s.level)
        })
        .collect();
    let flags = swept.flags(&sim.quality.gates);
    let made = ConfirmRuns {
        plan,
        rendered,
        swept,
        outcomes,
        flags,
    };
    Ok((confirmations, Some(made)))
}

/// `OUT/confirmation-plan.json`: a fixed design's confirmation runs, written before they start so
/// that `lab status` counts them (a sequential study's are in its `sequence.json`).
pub const PLAN_FILE: &str = "confirmation-plan.json";

fn write_plan(out: &std::path::Path, plan: &Plan) -> Result<(), Error> {
    let planned: Vec<_> = plan.runs.iter().map(super::sequence::record::Planned::of).collect();
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
/// simulation first); a fixed design runs them all.
fn within_budget<'s, 'a>(
    cx: RunContext,
    sequence: Option<&super::sequence::Sequence>,
    subjects: &'s [Subject<'a>],
    designs: usize,
) -> &'s [Subject<'a>] {
    let (Some(sequence), Some(budget)) = (sequence, crate::plan::sweep::sequential_budget(cx.study, cx.sim)) else {
        return subjects;
    };
    let room = budget.saturating_sub(sequence.runs) / designs.max(1);
    &subjects[..subjects.len().min(room)]
}

/// With curves: each confirmation run's curve features, whitened by the tests' scatter alone (as
/// the noise-alone decision read the specimens); `None` for a study of the response.
fn whitened_features(
    cx: RunContext,
    executed: &super::Executed,
    read: &Reading,
    (plan, rendered, usable): (&Plan, &Prepared, &[Option<f64>]),
) -> Option<Vec<Option<DVector<f64>>>> {
    let problem = read.problem(false)?;
    let setting = curves::Setting::of(cx.study)?;
    let dirs = executed.output_dirs(cx.sim);
    let grid = curves::on_grid(cx.study, cx.sim, &setting, &rendered.keys, usable, &dirs);
    Some(
        plan.runs
            .iter()
            .zip(grid)
            .map(|(r, c)| problem.model.whiten_curve(&r.design_values, c?.as_slice()))
            .collect(),
    )
}
