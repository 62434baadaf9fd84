//! `lab run`'s outcome written: `results.json`, `report-data.json` and `report.html` built from the
//! pipeline's domain values ([`crate::pipeline::Outcome`]), and the contract's exit code.

use std::path::Path;
use std::time::Instant;

use indexmap::IndexMap;

use super::Results;
use super::data::{ExtensionSurface, ReportData};
use super::results::{RunsResult, SplitResult, SuspectRun};
use crate::calibrate::{Calibration, CalibrationError};
use crate::diagnose::Diagnosis;
use crate::error::Error;
use crate::execute::quality::Flag;
use crate::pipeline::{Outcome, RunOutcomes, Simulated, SplitCalibration, extend, sequence};
use crate::plan::Plan;
use crate::plan::RunRole;
use crate::study::Study;

/// What `lab run` wrote: `results.json` and `report-data.json`, and how a solver study's runs ended
/// (`None` for a closed-form study).
pub struct Written {
    pub results: Results,
    pub report: ReportData,
    pub runs: Option<RunOutcomes>,
}

impl Written {
    /// The contract's exit code of a finished `lab run`: 1 when a run or a method failed, else 0.
    pub fn exit_code(&self) -> i32 {
        let failed_runs = self.runs.as_ref().is_some_and(|r| !r.failed.is_empty());
        if failed_runs || self.results.any_failed() { 1 } else { 0 }
    }
}

/// Builds `results.json` and `report-data.json` from `lab run`'s outcome and writes them with the
/// HTML report into `out`.
pub fn write_run(study: &Study, outcome: Outcome, out: &Path) -> Result<Written, Error> {
    let Outcome {
        simulated,
        calibration,
        curve_calibration,
        diagnosis,
        splits,
        started,
    } = outcome;
    let splits = splits.map(|s| split_results(&simulated, &s));
    let mut results = results(study, &simulated, &calibration, diagnosis, splits);
    results.curve_calibration = curve_calibration;
    results.answer = super::answer::of(&results);
    let recommended = results.answer.as_ref().and_then(|a| a.recommended.as_ref());
    let report = report_data(study, &simulated, &calibration, started, recommended);
    write(out, &results, &report)?;
    Ok(Written {
        results,
        report,
        runs: simulated.into_outcomes(),
    })
}

/// Each split's results, from its calibration with the study's emulators.
fn split_results(simulated: &Simulated, splits: &[SplitCalibration]) -> Vec<SplitResult> {
    splits
        .iter()
        .map(|split| {
            let not_diagnosed = Err(CalibrationError::Numerics("not diagnosed per split".into()));
            let results = Results::build(&split.study, simulated.model(), &split.calibration, not_diagnosed);
            SplitResult::from_results(&split.study, &results)
        })
        .collect()
}

/// `results.json`: the calibration and diagnosis, plus a solver study's surrogates, splits and run counts.
fn results(
    study: &Study,
    simulated: &Simulated,
    calibration: &Calibration,
    diagnosis: Result<Diagnosis, CalibrationError>,
    splits: Option<Vec<SplitResult>>,
) -> Results {
    // A fixed design has no loop check to reuse: it runs every confirmed model.
    let reused = diagnosis
        .as_ref()
        .map_or(0, |d| d.checked.confirmation.iter().filter(|c| c.reused).count());
    let results = Results::build(study, simulated.model(), calibration, diagnosis);
    let Simulated::Solver(runs) = simulated else {
        return results;
    };
    let mut results = results.with_surrogates(&runs.surrogates);
    results.stated.splits = splits;
    results.sampling = runs.sequence.as_ref().map(|s| sequence::Sequence {
        replaces: sequence::record::Replaced::of(
            study,
            runs.sim,
            runs.diagnosed.joint.as_ref().map(|j| &j.plan),
            confirmation_runs(runs, |_| true) + reused * crate::plan::sweep::tested_designs(study).count(),
        ),
        ..s.for_results()
    });
    let gates = runs.sim.quality.gates;
    let use_suspect = runs.sim.quality.use_suspect;
    // The screening's runs, then the loop's.
    let mut sweeps = vec![(&runs.plan, &runs.rendered.keys, &runs.executed.swept, &runs.flags)];
    if let Some(j) = &runs.diagnosed.joint {
        sweeps.push((&j.plan, &j.rendered.keys, &j.swept, &j.flags));
    }
    if let Some(c) = &runs.diagnosed.confirmation {
        sweeps.push((&c.plan, &c.rendered.keys, &c.swept, &c.flags));
    }
    let mut all = RunsResult {
        planned: 0,
        succeeded: 0,
        failed: 0,
        in_the_loop: runs.diagnosed.joint.as_ref().map_or(0, |j| j.plan.runs.len()),
        confirmation: confirmation_runs(runs, |r| r == RunRole::Confirm),
        not_excluded: confirmation_runs(runs, |r| matches!(r, RunRole::NotExcluded(_))),
        replayed_from: runs.executed.replay.as_ref().map(|d| d.display().to_string()),
        suspect: 0,
        gates: sweeps
            .iter()
            .any(|(_, _, swept, _)| swept.quality.iter().any(Option::is_some))
            .then_some(gates),
        suspect_runs: Vec::new(),
        outcomes: IndexMap::new(),
    };
    for (plan, keys, swept, flags) in sweeps {
        for (run, class) in plan.runs.iter().zip(&swept.classes) {
            let class = class.map_or("not_run".to_string(), |c| c.key());
            *all.outcomes
                .entry(run.role.stage(study))
                .or_default()
                .entry(class)
                .or_insert(0) += 1;
        }
        let succeeded = swept.responses.iter().filter(|r| r.is_some()).count();
        all.planned += plan.runs.len();
        all.succeeded += succeeded;
        all.failed += plan.runs.len() - succeeded;
        all.suspect += flags.iter().filter(|f| !f.is_empty()).count();
        all.suspect_runs
            .extend(suspect_runs(study, plan, keys, &swept.responses, flags, use_suspect));
    }
    results.solver.runs = Some(all);
    results
}

/// `report-data.json`: what the page draws beyond `results.json` (posterior samples, prediction
/// curves, the runs and their surrogates, force–displacement curves, the wall time).
fn report_data(
    study: &Study,
    simulated: &Simulated,
    calibration: &Calibration,
    started: Instant,
    recommended: Option<&super::answer::Model>,
) -> ReportData {
    let mut data = ReportData::build(study, simulated.model(), calibration);
    data.solver.force_displacement = match simulated {
        Simulated::ClosedForm(_) => super::curves::design_curves(study, None, None),
        Simulated::Solver(r) => {
            let responses = &r.executed.swept.responses;
            data = data.with_runs(
                study,
                &r.plan,
                &r.rendered.keys,
                responses,
                &r.surrogates,
                &r.executed.store,
            );
            for (row, f) in data.solver.runs.iter_mut().zip(&r.flags) {
                row.flags = f.iter().map(|f| f.text.clone()).collect();
            }
            let outputs = super::curves::RunOutputs {
                plan: &r.plan,
                keys: &r.rendered.keys,
                responses,
                dirs: r.executed.output_dirs(r.sim),
            };
            let reference = super::data::reference(calibration);
            data.extension_surfaces = r
                .diagnosed
                .extended
                .iter()
                .map(|(m, at)| surface(study, m, at))
                .collect();
            data.residual_curves = r.diagnosed.residual_curves.clone();
            data.solver_comparison = super::solvers::compare(r.sim, &outputs);
            let mut curves = super::curves::design_curves(study, Some(&outputs), reference.as_ref());
            if let Some(model) = recommended {
                with_recommended(study, r, outputs, model, &mut curves);
            }
            curves
        }
    };
    data.wall_time_s = Some(started.elapsed().as_secs_f64());
    data
}

/// Adds to each design's curves the solver's run of the recommended model nearest its fitted point,
/// among the study's runs, the loop's and the confirmation's.
fn with_recommended(
    study: &Study,
    r: &crate::pipeline::SolverRuns,
    outputs: super::curves::RunOutputs,
    model: &super::answer::Model,
    curves: &mut [super::data::DesignCurves],
) {
    let dirs = outputs.dirs.clone();
    let joint = r
        .diagnosed
        .joint
        .as_ref()
        .map(|j| (&j.plan, &j.rendered.keys, &j.swept.responses));
    let confirm = r
        .diagnosed
        .confirmation
        .as_ref()
        .map(|c| (&c.plan, &c.rendered.keys, &c.swept.responses));
    let mut sets = vec![outputs];
    for (plan, keys, responses) in joint.into_iter().chain(confirm) {
        sets.push(super::curves::RunOutputs {
            plan,
            keys,
            responses,
            dirs: dirs.clone(),
        });
    }
    for (design, curve, offset) in super::curves::recommended_curves(study, &sets, model) {
        if let Some(dc) = curves.iter_mut().find(|c| c.design == design) {
            dc.recommended = Some(super::data::RecommendedCurve {
                model: model.model.clone(),
                curve,
                offset,
            });
        }
    }
}

/// Writes results.json, report-data.json and report.html into `out`.
fn write(out: &Path, results: &Results, data: &ReportData) -> Result<(), Error> {
    results.write(&out.join("results.json"))?;
    data.write(&out.join(ReportData::FILE_NAME))?;
    write_report(out, results, Some(data))
}

/// Writes `dir/report.html` (atomically) from the results and, when there, the report data.
pub fn write_report(dir: &Path, results: &Results, data: Option<&ReportData>) -> Result<(), Error> {
    super::write_atomic(&dir.join("report.html"), super::html::render(results, data).as_bytes())?;
    Ok(())
}

/// The suspect runs for `results.json`, in plan order (each key once).
pub fn suspect_runs(
    study: &Study,
    plan: &Plan,
    keys: &[String],
    responses: &[Option<f64>],
    flags: &[Vec<Flag>],
    used: bool,
) -> Vec<SuspectRun> {
    let mut seen = std::collections::BTreeSet::new();
    (0..plan.runs.len())
        .filter(|&i| !flags[i].is_empty() && seen.insert(&keys[i]))
        .filter_map(|i| {
            let run = &plan.runs[i];
            Some(SuspectRun {
                key: keys[i].clone(),
                design: run.design.clone(),
                role: run.role.key().to_string(),
                parameters: study.parameter_values(&run.theta),
                response: responses[i]?,
                flags: flags[i].clone(),
                used,
            })
        })
        .collect()
}

/// The extended model's response over its first ranged variable, the other parameters at `at`.
pub fn surface(study: &Study, m: &extend::ExtendedModel, at: &[f64]) -> ExtensionSurface {
    let hypothesis = &study.diagnosis.hypotheses[m.hypothesis];
    let variable = &hypothesis.ranges()[0];
    let j = study.parameters.len();
    ExtensionSurface::sweep(
        &m.study,
        &hypothesis.name,
        &m.surrogates,
        at,
        (j, variable.min, variable.max),
        variable,
    )
}

/// `lab report`: rewrites `dir/report.html` from `results.json` and, when readable,
/// `report-data.json`; returns a warning when the latter is there but unreadable.
pub fn rewrite_report(dir: &Path) -> Result<Option<String>, Error> {
    let results = Results::read(&dir.join("results.json")).map_err(|e| {
        Error::Failed(format!(
            "{}: {e} (run `lab run` first)",
            dir.join("results.json").display()
        ))
    })?;
    let data_file = dir.join(ReportData::FILE_NAME);
    let (data, warning) = match ReportData::read(&data_file) {
        Ok(d) => (Some(d), None),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => (None, None),
        Err(e) => (
            None,
            Some(format!(
                "{}: {e}; the report leaves out what it holds",
                data_file.display()
            )),
        ),
    };
    write_report(dir, &results, data.as_ref())?;
    Ok(warning)
}

/// The runs made after the screening and the loop whose role is `of`: the confirmation's, and
/// those over the open extensions' amplitudes.
fn confirmation_runs(runs: &crate::pipeline::SolverRuns, of: impl Fn(RunRole) -> bool) -> usize {
    let made = runs.diagnosed.confirmation.as_ref();
    made.map_or(0, |c| c.plan.runs.iter().filter(|r| of(r.role)).count())
}
