//! A solver study's diagnosis: the screening (the extension hypotheses judged from their runs at
//! their probe values), then the solver in the loop ([`super::extend`]) for the hypotheses it
//! leaves open, then one decision from all of it ([`crate::diagnose::conclude`]).

use std::path::PathBuf;

use indexmap::IndexMap;

use super::runs::RunContext;
use super::{Event, Reporter, SolverRuns, curves, extend, extension_surrogates, sequence, values};
use crate::calibrate::{CalibrationError, Model};
use crate::diagnose::Diagnosis;
use crate::emulate::SurrogateModel;
use crate::error::Error;
use crate::execute::sweep::Prepared;
use crate::plan::Plan;
use crate::study::{SolverSimulation, Study};

/// The extension hypotheses' screening models (the surrogates of their probe runs). A hypothesis
/// whose probe runs failed at a tested design cannot be screened there and is left out of the
/// candidates: said, with the runs, never silently.
fn screened_extensions(
    study: &Study,
    (runs, stage): (&SolverRuns, Option<&curves::CurveStage>),
    reporter: &mut dyn Reporter,
) -> Vec<(usize, std::sync::Arc<dyn Model + Send>)> {
    for why in stage.iter().flat_map(|s| &s.unscreened) {
        reporter.report(Event::Note(format!(
            "{why}; the diagnosis leaves it out of the candidates; `lab run` again retries the failed runs"
        )));
    }
    let fitted = extension_surrogates(study, runs.sim, &runs.plan, &runs.usable);
    for (k, m) in &fitted {
        let missing: Vec<String> = crate::plan::sweep::tested_designs(study)
            .map(|(d, _)| d)
            .filter(|d| !m.designs.iter().any(|s| &s.design == *d))
            .map(|d| {
                let probes = (runs.plan.runs.iter().zip(&runs.usable))
                    .filter(|(r, _)| r.role == crate::plan::RunRole::Extension(*k) && &r.design == d);
                let (n, ok) = probes.fold((0, 0), |(n, ok), (_, y)| (n + 1, ok + usize::from(y.is_some())));
                format!("{d} ({ok} of {n} finished)")
            })
            .collect();
        if !missing.is_empty() {
            reporter.report(Event::Note(format!(
                "'{}' cannot be screened: its probe runs failed at {}, too few for its surrogate there, so the \
                 diagnosis leaves it out of the candidates; `lab run` again retries the failed runs",
                study.diagnosis.hypotheses[*k].name,
                missing.join(", ")
            )));
        }
    }
    (fitted.into_iter())
        .map(|(k, m)| (k, std::sync::Arc::new(m) as std::sync::Arc<dyn Model + Send>))
        .collect()
}

/// A solver study's diagnosis: the screening (the extension hypotheses judged from their runs at
/// their probe values), then the solver in the loop ([`extend`]) for the hypotheses it leaves
/// open, then one decision from all of it ([`crate::diagnose::conclude`]) — made twice, with the
/// emulators' error counted in the noise and with the tests' noise alone — then confirmed by the
/// solver at the fitted parameters of the models it rests on ([`super::confirm`]).
pub(super) fn diagnose_with_solver(
    cx: RunContext,
    runs: &mut SolverRuns,
    stage: Option<&curves::CurveStage>,
    reporter: &mut dyn Reporter,
) -> Result<Result<Diagnosis, CalibrationError>, Error> {
    let study = cx.study;
    let extensions = screened_extensions(study, (runs, stage), reporter);
    let read = match Reading::of(study, stage) {
        Ok(r) => r,
        Err(e) => return Ok(Err(e)),
    };
    let inputs = [true, false].map(|counted| read.inputs(counted, study, &runs.surrogates, &extensions));
    let screening = match crate::diagnose::diagnose(&inputs[0]) {
        Ok(d) => d,
        Err(e) => return Ok(Err(e)),
    };
    if cx.engine.signals.interrupted() {
        reporter.report(Event::Interrupted { out: &cx.options.out });
        return Err(Error::Interrupted);
    }
    // Where the emulators found no model error but the solver's runs over an extension's amplitude
    // favour it, the solver in the loop over it decides (the runs made so far are kept).
    let (chosen, earlier) = match extend::chosen(study, &screening) {
        chosen if !chosen.is_empty() => (chosen, None),
        _ => {
            let made = (&runs.rendered, &mut runs.executed, &mut runs.sequence);
            let confirmed = match without_the_loop(cx, made, stage, (&read, &inputs, screening), reporter)? {
                Ok(c) => c,
                Err(e) => return Ok(Err(e)),
            };
            match loop_from_favoured(cx, &confirmed.0, runs.sequence.as_ref(), reporter) {
                Some((chosen, favoured)) => (chosen, Some((confirmed, favoured))),
                None => return Ok(Ok(runs.diagnosed.keep(confirmed))),
            }
        }
    };
    let favoured = earlier.as_ref().map_or_else(Vec::new, |(_, n)| n.clone());
    let dirs = runs.executed.output_dirs(runs.sim);
    let after = AfterLoop {
        study,
        sim: runs.sim,
        plan: &runs.plan,
        usable: &runs.usable,
        dirs: &dirs,
        surrogates: &runs.surrogates,
        stage,
        extensions: &extensions,
        favoured: &favoured,
    };
    let screened = Screened {
        plan: &runs.plan,
        usable: &runs.usable,
        rendered: &runs.rendered,
    };
    let store = (&mut runs.executed.store, &mut runs.sequence);
    let looped = match in_the_loop(cx, &after, &inputs, &chosen, (screened, store), reporter)? {
        Ok(l) => l,
        Err(e) => return Ok(Err(e)),
    };
    let made = (&runs.rendered, &mut runs.executed, &mut runs.sequence);
    after_the_loop(
        cx,
        (made, &mut runs.diagnosed),
        (&after, &read, &inputs),
        (looped, earlier),
        reporter,
    )
    .map(Ok)
}

/// The decision from the loop's runs (made twice, the emulators' error counted and not), confirmed
/// by the solver at the fitted parameters of the models it rests on, kept with the loop's runs and
/// with those made before it (`earlier`: where the loop was started by the solver's runs over the
/// amplitudes, that diagnosis, its runs and the favoured extensions).
fn after_the_loop(
    cx: RunContext,
    (made, diagnosed): (super::confirm::Made, &mut super::Diagnosed),
    (after, read, inputs): (&AfterLoop, &Reading, &[crate::diagnose::Inputs; 2]),
    (looped, earlier): (Looped, Option<(Confirmed, Vec<String>)>),
    reporter: &mut dyn Reporter,
) -> Result<Diagnosis, Error> {
    let (study, stage) = (cx.study, after.stage);
    let (joint, models, [counted, noise_alone], [own, own_alone], loop_curves) = looped;
    let records = models
        .iter()
        .zip(&own)
        .map(|(m, own)| extend::assess(study, m, &counted, own))
        .collect::<Result<Vec<_>, _>>()?;
    let extended: Vec<(usize, Vec<f64>)> = models
        .iter()
        .zip(&records)
        .map(|(m, x)| (m.hypothesis, x.fitted.parameters.values().copied().collect()))
        .collect();
    let decided = [(counted, true), (noise_alone, false)].map(|(d, c)| {
        Finished::of(
            study,
            stage,
            read.problem(c),
            d.with_extensions(records.clone()),
            &loop_curves,
        )
    });
    let baseline: std::sync::Arc<dyn Model + Send> = std::sync::Arc::new(after.surrogates.clone());
    let shapes = (study, &baseline, after.extensions);
    let readings = super::confirm::loop_readings(stage, (&models, shapes), &loop_curves, [&own, &own_alone])?;
    let loop_inputs: Vec<crate::diagnose::Inputs> = readings.iter().map(|l| l.inputs()).collect();
    let subjects = super::confirm::subjects(study, &decided, &inputs[1], (&readings, &loop_inputs, Some(&joint)));
    let before = earlier.as_ref().and_then(|((_, runs, _), _)| runs.as_ref());
    let reuse = super::confirm::Earlier {
        joint: Some(&joint),
        confirmed: before,
    };
    // Where the solver refits the named cause, the next test is read again there: the kept
    // decision (the emulators' error counted or not) made again with that model at the refit.
    let refitted = |d: &Diagnosis| {
        let counted = d
            .checked
            .emulator
            .as_ref()
            .is_none_or(|e| e.confirmed.as_deref().or(e.unjudged.as_deref()) != Some("noise_alone"));
        let reading = Counting {
            floor: 0.0,
            emulator: counted,
            refit: d.checked.solver_refit.as_ref(),
        };
        let again = after.conclude(&inputs[usize::from(!counted)], &models, &joint, reading);
        again.ok()?.ok().map(|(d, _, _)| d.explained.next_test)
    };
    let (d, confirmation, residuals) = confirmed(cx, made, decided, (subjects, reuse), read, &refitted, reporter)?;
    // The runs made before the loop (the confirmation, the runs over the amplitudes) stay counted.
    let (d, confirmation) = match earlier {
        Some(((before, runs_before, _), _)) => (
            d.after_favoured(&before.checked.not_excluded),
            match (runs_before, confirmation) {
                (Some(a), Some(b)) => Some(a.merge(b)),
                (a, b) => a.or(b),
            },
        ),
        None => (d, confirmation),
    };
    let d = diagnosed.keep((d, confirmation, residuals));
    for (m, (_, at)) in models.into_iter().zip(extended) {
        diagnosed.extended.push((m, at));
    }
    diagnosed.joint = Some(joint);
    Ok(d)
}

/// The extensions the solver in the loop judges where the emulators found no model error but the
/// solver's runs over extensions' amplitudes favour them ([`extend::open_beside`]), and the names of
/// the favoured; said. `None`: none favoured, or no room left for the loop.
fn loop_from_favoured(
    cx: RunContext,
    d: &Diagnosis,
    sequence: Option<&sequence::Sequence>,
    reporter: &mut dyn Reporter,
) -> Option<(Vec<usize>, Vec<String>)> {
    let study = cx.study;
    let favoured = extend::favoured(study, d);
    if favoured.is_empty() || !room_for_the_loop(cx, sequence) {
        return None;
    }
    let chosen = extend::open_beside(study, d, &favoured);
    let name = |k: &usize| study.diagnosis.hypotheses[*k].name.clone();
    let names: Vec<String> = favoured.iter().map(name).collect();
    reporter.report(Event::Note(format!(
        "the emulators found no model error, but the solver's runs over the amplitude of '{}' favour {} against its \
         absence: the solver in the loop over '{}' decides",
        names.join("' and '"),
        if names.len() == 1 { "it" } else { "each" },
        chosen.iter().map(name).collect::<Vec<_>>().join("' and '")
    )));
    Some((chosen, names))
}

/// Whether the solver in the loop can still decide: always with a fixed design; in a sequential
/// study, when its budget has room for a batch at every tested design and the check of its
/// emulators at the fitted point there (a run at each again): a loop with less cannot check its
/// model, and an unchecked model is neither named nor rejected.
fn room_for_the_loop(cx: RunContext, sequence: Option<&sequence::Sequence>) -> bool {
    let Some(s) = sequence else { return true };
    let budget = crate::plan::sweep::sequential_budget(cx.study, cx.sim).unwrap_or(0);
    budget.saturating_sub(s.runs) >= 2 * crate::plan::sweep::tested_designs(cx.study).count()
}

/// The decision when no extension is run with the solver in the loop: the screening's, made
/// again with the tests' noise alone, then confirmed.
fn without_the_loop(
    cx: RunContext,
    made: super::confirm::Made,
    stage: Option<&curves::CurveStage>,
    (read, inputs, screening): (&Reading, &[crate::diagnose::Inputs; 2], Diagnosis),
    reporter: &mut dyn Reporter,
) -> Result<Result<Confirmed, CalibrationError>, Error> {
    let study = cx.study;
    let noise_alone = match crate::diagnose::diagnose(&inputs[1]) {
        Ok(d) => d,
        Err(e) => return Ok(Err(e)),
    };
    let decided =
        [(screening, true), (noise_alone, false)].map(|(d, c)| Finished::of(study, stage, read.problem(c), d, &[]));
    let subjects = super::confirm::subjects(study, &decided, &inputs[1], (&[], &[], None));
    confirmed(
        cx,
        made,
        decided,
        (subjects, Default::default()),
        read,
        &|_| None,
        reporter,
    )
    .map(Ok)
}

/// A decision with its words and, with curves, its features and residual curves.
pub(super) struct Finished {
    pub diagnosis: Diagnosis,
    pub residuals: Vec<values::ResidualCurves>,
}

impl Finished {
    fn of(
        study: &Study,
        stage: Option<&curves::CurveStage>,
        problem: Option<&crate::diagnose::features::FeatureProblem>,
        d: Diagnosis,
        loops: &[(usize, crate::emulate::functional::CurveModel)],
    ) -> Finished {
        let (diagnosis, residuals) = with_features(study, stage, problem, d, loops);
        Finished {
            diagnosis: diagnosis.worded(),
            residuals,
        }
    }
}

/// The decisions confirmed by the solver at the fitted parameters of `subjects` ([`super::confirm`],
/// on the screening's store and record `made`): the diagnosis kept, the confirmation runs, and the
/// kept decision's residual curves.
fn confirmed(
    cx: RunContext,
    made: super::confirm::Made,
    [counted, noise_alone]: [Finished; 2],
    (subjects, earlier): (Vec<super::confirm::Subject>, super::confirm::Earlier),
    read: &Reading,
    refitted: &Refitted,
    reporter: &mut dyn Reporter,
) -> Result<Confirmed, Error> {
    let noise = noise_alone.diagnosis.record.noise.clone();
    let (rendered, executed, sequence) = made;
    let (confirmations, runs) = super::confirm::run(
        cx,
        (rendered, &mut *executed, &mut *sequence),
        &subjects,
        (read, &noise, earlier),
        reporter,
    )?;
    let designs: Vec<String> = crate::plan::sweep::tested_designs(cx.study)
        .map(|(n, _)| n.clone())
        .collect();
    let decided = (noise_alone.diagnosis, counted.diagnosis);
    let d = crate::diagnose::confirm::settle(decided, confirmations, &designs, refitted);
    // What "no model error" leaves open, read again from the solver over each open extension.
    let (d, open_runs) = match subjects.first() {
        Some(s) => super::open::over_amplitudes(
            cx,
            (rendered, executed, sequence),
            d,
            (s.confirming.inputs, read, &noise),
            earlier.confirmed,
            reporter,
        )?,
        None => (d, None),
    };
    let runs = match (runs, open_runs) {
        (Some(a), Some(b)) => Some(a.merge(b)),
        (a, b) => a.or(b),
    };
    let kept = d.checked.emulator.as_ref().and_then(|e| e.confirmed.as_deref());
    let residuals = match kept {
        Some("counted") => counted.residuals,
        _ => noise_alone.residuals,
    };
    Ok((d, runs, residuals))
}

impl super::Diagnosed {
    /// Keeps a confirmed diagnosis's runs and residual curves; returns the diagnosis.
    fn keep(&mut self, (d, confirmation, residuals): Confirmed) -> Diagnosis {
        self.confirmation = confirmation;
        self.residual_curves = residuals;
        d
    }
}

/// The kept decision's next test read again where the solver refitted its named cause
/// ([`crate::diagnose::confirm::settle`]).
type Refitted<'r> = dyn Fn(&Diagnosis) -> Option<Option<crate::diagnose::NextTest>> + 'r;

/// A confirmed diagnosis, its confirmation runs, and its residual curves.
type Confirmed = (
    Diagnosis,
    Option<super::confirm::ConfirmRuns>,
    Vec<values::ResidualCurves>,
);

/// What the diagnosis reads: with curves, their inputs and feature problems with the emulators'
/// error counted and with the tests' noise alone; else the response.
pub(super) struct Reading<'s> {
    curves: Option<
        [(
            crate::diagnose::features::CurveInputs<'s>,
            crate::diagnose::features::FeatureProblem,
        ); 2],
    >,
}

impl<'s> Reading<'s> {
    fn of(study: &'s Study, stage: Option<&curves::CurveStage>) -> Result<Reading<'s>, CalibrationError> {
        let Some(s) = stage else {
            return Ok(Reading { curves: None });
        };
        let hypotheses = curves::extension_hypotheses(study, &s.extension_fns(), None, None);
        let counted = curves::inputs(study, &s.setting, s.designs.clone(), &s.baseline, hypotheses);
        let mut alone = counted.clone();
        alone.settings.emulator_counted = false;
        let problem = |ci: &crate::diagnose::features::CurveInputs| {
            crate::diagnose::features::FeatureProblem::new(ci)
                .map_err(|e| CalibrationError::Numerics(format!("the curves cannot be diagnosed: {e}")))
        };
        let (p, q) = (problem(&counted)?, problem(&alone)?);
        Ok(Reading {
            curves: Some([(counted, p), (alone, q)]),
        })
    }

    /// The screening's inputs, the emulators' error `counted` or not.
    fn inputs<'r>(
        &'r self,
        counted: bool,
        study: &'r Study,
        surrogates: &'r SurrogateModel,
        extensions: &'r [(usize, std::sync::Arc<dyn Model + Send>)],
    ) -> crate::diagnose::Inputs<'r> {
        if let Some(c) = &self.curves {
            let (ci, problem) = &c[usize::from(!counted)];
            return problem.inputs(ci);
        }
        let mut inputs = crate::diagnose::inputs_with_extensions(study, surrogates, extensions);
        let at = inputs.observations.iter().map(|o| (o.design.as_slice(), o.mean));
        inputs.emulator = crate::emulate::Uncertainty::of_surrogates(surrogates, at);
        inputs.settings.emulator_counted = counted;
        inputs
    }

    /// The feature problem, the emulators' error `counted` or not (`None` without curves).
    pub(super) fn problem(&self, counted: bool) -> Option<&crate::diagnose::features::FeatureProblem> {
        self.curves.as_ref().map(|c| &c[usize::from(!counted)].1)
    }
}

/// What the loop made and decided: its runs, the extended models, the decision after it, each loop
/// model's own diagnosis, and their curve models.
type Looped = (
    extend::JointRuns,
    Vec<extend::ExtendedModel>,
    [Diagnosis; 2],
    [Vec<Diagnosis>; 2],
    Vec<(usize, crate::emulate::functional::CurveModel)>,
);

/// The solver in the loop for the `chosen` hypotheses, a sequential loop asking for the decision
/// from its runs so far ([`sequence::looped`]), then the decision from all its runs.
fn in_the_loop(
    cx: RunContext,
    after: &AfterLoop,
    inputs: &[crate::diagnose::Inputs; 2],
    chosen: &[usize],
    (screened, store): (
        Screened,
        (&mut crate::execute::RunStore, &mut Option<sequence::Sequence>),
    ),
    reporter: &mut dyn Reporter,
) -> Result<Result<Looped, CalibrationError>, Error> {
    let mut decide = |joint: &extend::JointRuns, floor: f64| -> Option<sequence::Provisional> {
        let models = after.models(chosen, joint).ok()?;
        let counting = Counting {
            floor,
            emulator: true,
            refit: None,
        };
        let (d, own, _) = after.conclude(&inputs[0], &models, joint, counting).ok()?.ok()?;
        Some(provisional(chosen, &d, &own))
    };
    let joint = loop_runs(cx, screened, store, after.stage, chosen, reporter, &mut decide)?;
    let models = after.models(chosen, &joint)?;
    let counted = Counting {
        floor: 0.0,
        emulator: true,
        refit: None,
    };
    let (d, own, curves) = match after.conclude(&inputs[0], &models, &joint, counted)? {
        Ok(c) => c,
        Err(e) => return Ok(Err(e)),
    };
    let alone = Counting {
        floor: 0.0,
        emulator: false,
        refit: None,
    };
    let (d_alone, own_alone, _) = match after.conclude(&inputs[1], &models, &joint, alone)? {
        Ok(c) => c,
        Err(e) => return Ok(Err(e)),
    };
    Ok(Ok((joint, models, [d, d_alone], [own, own_alone], curves)))
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
    extensions: &'a [(usize, std::sync::Arc<dyn Model + Send>)],
    /// The extensions the solver's runs over their amplitudes favoured where the emulators found no
    /// model error ([`extend::favoured`]).
    favoured: &'a [String],
}

/// How a decision reads the loop's models: the emulators' own error counted at least at `floor` (a
/// share of the tests' noise variance), or, without `emulator`, not at all (the tests' noise
/// alone); and, where the solver's confirmation refitted the named cause (`refit`), that model at
/// the point handed over for the next test.
#[derive(Debug, Clone, Copy)]
struct Counting<'r> {
    floor: f64,
    emulator: bool,
    refit: Option<&'r crate::diagnose::refit::SolverRefit>,
}

impl Counting<'_> {
    /// The loop model of `hypothesis` at the solver's refit where it is the refitted one.
    fn refit_of(&self, hypothesis: &str) -> Option<IndexMap<String, f64>> {
        self.refit.filter(|r| r.model == hypothesis).map(|r| r.to.clone())
    }
}

impl AfterLoop<'_> {
    /// The `chosen` hypotheses' extended models over the joint runs.
    fn models(&self, chosen: &[usize], joint: &extend::JointRuns) -> Result<Vec<extend::ExtendedModel>, Error> {
        chosen
            .iter()
            .map(|&k| extend::extended_model(self.study, self.sim, k, (self.plan, self.usable), joint))
            .collect()
    }

    /// The decision with the extended models from the screening's `inputs`, on the mean force or
    /// on the curves, the emulators' error counted as `counting` says.
    fn conclude(
        &self,
        inputs: &crate::diagnose::Inputs,
        models: &[extend::ExtendedModel],
        joint: &extend::JointRuns,
        floor: Counting,
    ) -> Result<Result<Concluded, CalibrationError>, Error> {
        let study = self.study;
        match self.stage {
            None => Ok(conclude_on_response(
                study,
                self.surrogates,
                (inputs, self.favoured),
                models,
                self.extensions,
                floor,
            )),
            Some(st) => conclude_on_curves(
                study,
                (self.sim, self.plan, self.dirs),
                st,
                (inputs, self.favoured),
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
            verdict: d.finding.verdict,
            cause: d.finding.cause.clone(),
            partial: d.finding.partial.as_ref().map(|p| p.name.clone()),
        },
        points: fitted_points(chosen, own),
        settled: d.checked.after_loop.as_ref().is_some_and(|a| a.settled),
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
                    values: o.record.uncorrected.parameters.clone(),
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
    (inputs, favoured): (&crate::diagnose::Inputs, &[String]),
    models: &[extend::ExtendedModel],
    extensions: &[(usize, std::sync::Arc<dyn Model + Send>)],
    floor: Counting,
) -> Result<Concluded, CalibrationError> {
    let baseline: std::sync::Arc<dyn Model + Send> = std::sync::Arc::new(surrogates.clone());
    let looped: Vec<_> = models
        .iter()
        .map(|m| {
            let mut l = extend::loop_model(study, m, &baseline, extensions);
            l.inputs.settings.emulator_floor = floor.floor;
            l.inputs.settings.emulator_counted = floor.emulator;
            l.refit = floor.refit_of(&l.hypothesis);
            l
        })
        .collect();
    let (d, own) = crate::diagnose::conclude(inputs, &looped, favoured)?;
    Ok((d, own, Vec::new()))
}

/// The decision after the loop on the curves: each extended model's curve emulator over the joint
/// runs, its features with the other hypotheses' shapes as candidates.
fn conclude_on_curves(
    study: &Study,
    (sim, plan, dirs): (&SolverSimulation, &Plan, &[PathBuf]),
    stage: &curves::CurveStage,
    (inputs, favoured): (&crate::diagnose::Inputs, &[String]),
    models: &[extend::ExtendedModel],
    joint: &extend::JointRuns,
    floor: Counting,
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
            ci.settings.emulator_floor = floor.floor;
            ci.settings.emulator_counted = floor.emulator;
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
        .map(|(m, (p, ci))| {
            let hypothesis = study.diagnosis.hypotheses[m.hypothesis].name.clone();
            crate::diagnose::LoopModel {
                refit: floor.refit_of(&hypothesis),
                hypothesis,
                inputs: p.inputs(ci),
                checked: m.checked,
                running: m.running,
            }
        })
        .collect();
    Ok(crate::diagnose::conclude(inputs, &looped, favoured).map(|(d, own)| (d, own, loop_curves)))
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
