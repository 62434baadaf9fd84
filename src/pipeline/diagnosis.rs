//! A solver study's diagnosis: the screening (the extension hypotheses judged from their runs at
//! their probe values), then the solver in the loop ([`super::extend`]) for the hypotheses it
//! leaves open, then one decision from all of it ([`crate::diagnose::conclude`]).

use std::path::PathBuf;

use super::runs::RunContext;
use super::{Event, Reporter, SolverRuns, curves, extend, extension_models, sequence, values};
use crate::calibrate::{CalibrationError, Model};
use crate::diagnose::Diagnosis;
use crate::emulate::SurrogateModel;
use crate::error::Error;
use crate::execute::sweep::Prepared;
use crate::plan::Plan;
use crate::study::{SolverSimulation, Study};

/// A solver study's diagnosis: the screening (the extension hypotheses judged from their runs at
/// their probe values), then the solver in the loop ([`extend`]) for the hypotheses it leaves
/// open, then one decision from all of it ([`crate::diagnose::conclude`]).
pub(super) fn diagnose_with_solver(
    cx: RunContext,
    runs: &mut SolverRuns,
    stage: Option<&curves::CurveStage>,
    reporter: &mut dyn Reporter,
) -> Result<Result<Diagnosis, CalibrationError>, Error> {
    let study = cx.study;
    let extensions = extension_models(study, runs.sim, &runs.plan, &runs.usable);
    // With curves, the diagnosis reads their features; else the response.
    let curve_inputs = stage.map(|s| {
        let hypotheses = curves::extension_hypotheses(study, &s.extension_fns(), None, None);
        curves::inputs(study, &s.setting, s.designs.clone(), &s.baseline, hypotheses)
    });
    let problem = match feature_problem(curve_inputs.as_ref()) {
        Ok(p) => p,
        Err(e) => return Ok(Err(e)),
    };
    let inputs = match (&problem, &curve_inputs) {
        (Some(p), Some(ci)) => p.inputs(ci),
        _ => {
            let mut inputs = crate::diagnose::inputs_with_extensions(study, &runs.surrogates, &extensions);
            inputs.emulator_variance = crate::diagnose::emulator_variance(&runs.surrogates, &inputs.observations);
            inputs
        }
    };
    let screening = match crate::diagnose::diagnose(&inputs) {
        Ok(d) => d,
        Err(e) => return Ok(Err(e)),
    };
    if cx.engine.signals.interrupted() {
        reporter.report(Event::Interrupted { out: &cx.options.out });
        return Err(Error::Interrupted);
    }
    let chosen = extend::chosen(study, &screening);
    if chosen.is_empty() {
        let (d, residuals) = with_features(study, stage, problem.as_ref(), screening, &[]);
        runs.residual_curves = residuals;
        return Ok(Ok(d.worded()));
    }
    let dirs = runs.executed.output_dirs(runs.sim);
    let after = AfterLoop {
        study,
        sim: runs.sim,
        plan: &runs.plan,
        usable: &runs.usable,
        dirs: &dirs,
        surrogates: &runs.surrogates,
        stage,
        inputs: &inputs,
        extensions: &extensions,
    };
    let screened = Screened {
        plan: &runs.plan,
        usable: &runs.usable,
        rendered: &runs.rendered,
    };
    let store = (&mut runs.executed.store, &mut runs.sequence);
    let looped = match in_the_loop(cx, &after, &chosen, (screened, store), reporter)? {
        Ok(l) => l,
        Err(e) => return Ok(Err(e)),
    };
    let (joint, models, diagnosis, own, loop_curves) = looped;
    let records = models
        .iter()
        .zip(&own)
        .map(|(m, own)| extend::assess(study, m, &diagnosis, own))
        .collect::<Result<Vec<_>, _>>()?;
    for (m, x) in models.into_iter().zip(&records) {
        runs.extended.push((m, x.parameters.values().copied().collect()));
    }
    runs.joint = Some(joint);
    let (diagnosis, residuals) = with_features(study, stage, problem.as_ref(), diagnosis, &loop_curves);
    runs.residual_curves = residuals;
    Ok(Ok(diagnosis.with_extensions(records).worded()))
}

/// What the loop made and decided: its runs, the extended models, the decision after it, each loop
/// model's own diagnosis, and their curve models.
type Looped = (
    extend::JointRuns,
    Vec<extend::ExtendedModel>,
    Diagnosis,
    Vec<Diagnosis>,
    Vec<(usize, crate::emulate::functional::CurveModel)>,
);

/// The solver in the loop for the `chosen` hypotheses, a sequential loop asking for the decision
/// from its runs so far ([`sequence::looped`]), then the decision from all its runs.
fn in_the_loop(
    cx: RunContext,
    after: &AfterLoop,
    chosen: &[usize],
    (screened, store): (
        Screened,
        (&mut crate::execute::RunStore, &mut Option<sequence::Sequence>),
    ),
    reporter: &mut dyn Reporter,
) -> Result<Result<Looped, CalibrationError>, Error> {
    let mut decide = |joint: &extend::JointRuns, floor: f64| -> Option<sequence::Provisional> {
        let models = after.models(chosen, joint).ok()?;
        let (d, own, _) = after.conclude(&models, joint, floor).ok()?.ok()?;
        Some(provisional(chosen, &d, &own))
    };
    let joint = loop_runs(cx, screened, store, after.stage, chosen, reporter, &mut decide)?;
    let models = after.models(chosen, &joint)?;
    Ok(after
        .conclude(&models, &joint, 0.0)?
        .map(|(diagnosis, own, curves)| (joint, models, diagnosis, own, curves)))
}

/// The curves' feature problem, where the study reads curves.
fn feature_problem(
    curve_inputs: Option<&crate::diagnose::features::CurveInputs>,
) -> Result<Option<crate::diagnose::features::FeatureProblem>, CalibrationError> {
    curve_inputs
        .map(crate::diagnose::features::FeatureProblem::new)
        .transpose()
        .map_err(|e| CalibrationError::Numerics(format!("the curves cannot be diagnosed: {e}")))
}

/// What the decision after the loop reads besides the loop's runs: the screening's runs, its
/// surrogates or curve stage, and the screening diagnosis's inputs.
struct AfterLoop<'a> {
    study: &'a Study,
    sim: &'a SolverSimulation,
    plan: &'a Plan,
    usable: &'a [Option<f64>],
    dirs: &'a [PathBuf],
    surrogates: &'a SurrogateModel,
    stage: Option<&'a curves::CurveStage>,
    inputs: &'a crate::diagnose::Inputs<'a>,
    extensions: &'a [(usize, std::sync::Arc<dyn Model + Send>)],
}

impl AfterLoop<'_> {
    /// The `chosen` hypotheses' extended models over the joint runs.
    fn models(&self, chosen: &[usize], joint: &extend::JointRuns) -> Result<Vec<extend::ExtendedModel>, Error> {
        chosen
            .iter()
            .map(|&k| extend::extended_model(self.study, self.sim, k, (self.plan, self.usable), joint))
            .collect()
    }

    /// The decision with the extended models, on the mean force or on the curves; `floor` is the
    /// emulators' error a provisional decision allows for (0 for the final one).
    fn conclude(
        &self,
        models: &[extend::ExtendedModel],
        joint: &extend::JointRuns,
        floor: f64,
    ) -> Result<Result<Concluded, CalibrationError>, Error> {
        let (study, inputs) = (self.study, self.inputs);
        match self.stage {
            None => Ok(conclude_on_response(
                study,
                self.surrogates,
                inputs,
                models,
                self.extensions,
                floor,
            )),
            Some(st) => conclude_on_curves(
                study,
                (self.sim, self.plan, self.dirs),
                st,
                inputs,
                models,
                joint,
                floor,
            ),
        }
    }
}

/// The loop's decision so far as the sequence compares it from batch to batch.
fn provisional(chosen: &[usize], d: &Diagnosis, own: &[Diagnosis]) -> sequence::Provisional {
    sequence::Provisional {
        decided: sequence::Decided {
            verdict: d.verdict,
            cause: d.cause.clone(),
            partial: d.partial.as_ref().map(|p| p.name.clone()),
        },
        points: fitted_points(chosen, own),
        settled: d.after_loop.as_ref().is_some_and(|a| a.settled),
    }
}

/// Each looped hypothesis's fitted values, from its model's own diagnosis.
fn fitted_points(chosen: &[usize], own: &[Diagnosis]) -> Vec<(usize, sequence::Fitted)> {
    chosen
        .iter()
        .zip(own)
        .map(|(&k, o)| {
            (
                k,
                sequence::Fitted {
                    values: o.uncorrected.parameters.clone(),
                },
            )
        })
        .collect()
}

/// The screening's runs as the loop reads them.
struct Screened<'a> {
    plan: &'a Plan,
    usable: &'a [Option<f64>],
    rendered: &'a Prepared,
}

/// The solver-in-the-loop's runs of the `chosen` hypotheses: a fixed joint plan, or a sequential
/// study's batches ([`sequence::looped`], its record carried on in `sequence`), on the screening's
/// store.
fn loop_runs(
    cx: RunContext,
    s: Screened,
    (store, sequence): (&mut crate::execute::RunStore, &mut Option<sequence::Sequence>),
    stage: Option<&curves::CurveStage>,
    chosen: &[usize],
    reporter: &mut dyn Reporter,
    decide: &mut sequence::Decide,
) -> Result<extend::JointRuns, Error> {
    let Some(record) = sequence.take() else {
        return extend::execute(cx, chosen, s.rendered, store, reporter);
    };
    let none = vec![None; s.plan.runs.len()];
    let screening = sequence::ScreeningRuns {
        plan: s.plan,
        usable: s.usable,
        curves: stage.map_or(&none, |c| &c.runs),
        rendered: s.rendered,
    };
    let (joint, record) = sequence::looped(cx, chosen, &screening, (store, record), reporter, decide)?;
    *sequence = Some(record);
    Ok(joint)
}

/// What the loop's models concluded: the diagnosis, each loop model's own, and their curve models.
type Concluded = (
    Diagnosis,
    Vec<Diagnosis>,
    Vec<(usize, crate::emulate::functional::CurveModel)>,
);

/// The decision after the loop on the mean force: each extended model through its surrogate.
fn conclude_on_response(
    study: &Study,
    surrogates: &SurrogateModel,
    inputs: &crate::diagnose::Inputs,
    models: &[extend::ExtendedModel],
    extensions: &[(usize, std::sync::Arc<dyn Model + Send>)],
    floor: f64,
) -> Result<Concluded, CalibrationError> {
    let baseline: std::sync::Arc<dyn Model + Send> = std::sync::Arc::new(surrogates.clone());
    let looped: Vec<_> = models
        .iter()
        .map(|m| {
            let mut l = extend::loop_model(study, m, &baseline, extensions);
            l.inputs.settings.emulator_floor = floor;
            l
        })
        .collect();
    let (d, own) = crate::diagnose::conclude(inputs, &looped)?;
    Ok((d, own, Vec::new()))
}

/// The decision after the loop on the curves: each extended model's curve emulator over the joint
/// runs, its features with the other hypotheses' shapes as candidates.
fn conclude_on_curves(
    study: &Study,
    (sim, plan, dirs): (&SolverSimulation, &Plan, &[PathBuf]),
    stage: &curves::CurveStage,
    inputs: &crate::diagnose::Inputs,
    models: &[extend::ExtendedModel],
    joint: &extend::JointRuns,
    floor: f64,
) -> Result<Result<Concluded, CalibrationError>, Error> {
    let joint_curves = curves::on_grid(study, sim, &stage.setting, &joint.rendered.keys, &joint.usable, dirs);
    let baseline = curves::curve_fn(stage.baseline.clone());
    let p = study.parameters.len();
    let mut loop_curves = Vec::new();
    for m in models {
        let model = stage.loop_model(study, sim, plan, m.hypothesis, joint, &joint_curves)?;
        loop_curves.push((m.hypothesis, model));
    }
    let loop_inputs: Vec<_> = models
        .iter()
        .zip(&loop_curves)
        .map(|(m, (_, model))| {
            let others = curves::extension_hypotheses(
                study,
                &stage.extension_fns(),
                Some((baseline.clone(), p)),
                Some(m.hypothesis),
            );
            let mut ci = curves::inputs(&m.study, &stage.setting, stage.designs.clone(), model, others);
            ci.settings.emulator_floor = floor;
            ci
        })
        .collect();
    let problems = loop_inputs
        .iter()
        .map(crate::diagnose::features::FeatureProblem::new)
        .collect::<Result<Vec<_>, _>>()
        .map_err(Error::Failed)?;
    let looped: Vec<_> = models
        .iter()
        .zip(problems.iter().zip(&loop_inputs))
        .map(|(m, (p, ci))| crate::diagnose::LoopModel {
            hypothesis: study.diagnosis.hypotheses[m.hypothesis].name.clone(),
            inputs: p.inputs(ci),
            checked: m.checked,
            running: m.running,
        })
        .collect();
    Ok(crate::diagnose::conclude(inputs, &looped).map(|(d, own)| (d, own, loop_curves)))
}

/// With curves: the diagnosis with the features it read, and the residual curves the report draws.
fn with_features(
    study: &Study,
    stage: Option<&curves::CurveStage>,
    problem: Option<&crate::diagnose::features::FeatureProblem>,
    d: Diagnosis,
    loops: &[(usize, crate::emulate::functional::CurveModel)],
) -> (Diagnosis, Vec<values::ResidualCurves>) {
    match (stage, problem) {
        (Some(stage), Some(problem)) => {
            let residuals = curves::residual_curves(study, stage, loops, &d);
            let report = curves::features_report(study, stage, problem, loops, &d);
            (d.with_features(report), residuals)
        }
        _ => (d, Vec::new()),
    }
}

