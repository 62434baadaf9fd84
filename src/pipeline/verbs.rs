//! The other commands, each a short sequence of the same stages as [`super::run`], returning what
//! the command line prints: `lab check`, `lab status`, `lab report`, `lab extract` and the
//! internal `lab slurm-worker`.

use std::path::Path;

use crate::error::{Error, InputError};
use crate::execute::store::Snapshot;
use crate::execute::{lock, sweep};
use crate::extract::crush;
use crate::plan::Plan;
use crate::report::Results;
use crate::report::data::ReportData;
use crate::study::{Simulation, Study};

/// `lab check`: what was validated beyond loading the study.
pub struct Checked {
    /// A solver study's planned runs, every one rendered in memory.
    pub rendered_runs: Option<usize>,
    /// The runs the solver in the loop would add if every ranged extension were chosen, rendered too.
    pub loop_runs: usize,
    /// Force–displacement curves read: (specimens, designs).
    pub curves: (usize, usize),
}

/// `lab check`: renders every planned run in memory (undefined template variables show up here),
/// and the solver-in-the-loop runs of every extension with ranges (which a `lab run` plans only for
/// the hypotheses its screening chooses); loading the study has already read everything else it
/// references.
pub fn check(study: &Study) -> Result<Checked, Error> {
    let (rendered_runs, loop_runs) = match &study.simulation {
        Simulation::Solver(sim) => {
            let plan = Plan::new(study, sim);
            sweep::prepare(study, sim, &plan)?;
            let ranged: Vec<usize> = study.extension_hypotheses().map(|(k, _)| k).collect();
            let joint = Plan::joint(study, sim, &ranged);
            sweep::prepare(study, sim, &joint)?;
            (Some(plan.runs.len()), joint.runs.len())
        }
        Simulation::Expression(_) => (None, 0),
    };
    let curves = &study.experiments.curves;
    Ok(Checked {
        rendered_runs,
        loop_runs,
        curves: (curves.iter().map(|c| c.specimens.len()).sum(), curves.len()),
    })
}

/// `lab status`: counts of the planned runs.
pub struct Status {
    pub planned: usize,
    pub done: usize,
    pub failed: usize,
    pub running: usize,
    pub pending: usize,
    /// Whether a lab holds the output directory: `Some(None)` while the holder is being written.
    pub holder: Option<Option<crate::execute::Holder>>,
}

/// `lab status`: the planned runs counted from the store, read without taking its lock; `None`
/// for a closed-form study (no runs). The solver-in-the-loop runs count once a `lab run` has
/// chosen them (`OUT/extension-plan.json`).
pub fn status(study: &Study, out: &Path) -> Result<Option<Status>, Error> {
    let Simulation::Solver(sim) = &study.simulation else {
        return Ok(None);
    };
    let mut plan = Plan::new(study, sim);
    plan.runs.extend(super::extend::recorded_plan(study, sim, out).runs);
    let prepared = sweep::prepare(study, sim, &plan)?;
    let snapshot = Snapshot::read(out)?;
    let holder = lock::probe(out).map_err(|e| Error::Failed(e.to_string()))?;
    let mut status = Status {
        planned: plan.runs.len(),
        done: 0,
        failed: 0,
        running: 0,
        pending: 0,
        holder,
    };
    for key in &prepared.keys {
        match snapshot.records.get(key) {
            Some(r) if r.outcome.is_success() => status.done += 1,
            Some(_) => status.failed += 1,
            None if status.holder.is_some() && snapshot.run_dirs.contains(key) => status.running += 1,
            None => status.pending += 1,
        }
    }
    Ok(Some(status))
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
    super::write_report(dir, &results, data.as_ref())?;
    Ok(warning)
}

/// `lab extract`: the mean crush force of a test machine's force–displacement CSV over a window.
pub fn extract(curve: &Path, window: crush::Window) -> Result<crush::CrushResult, Error> {
    let data = crush::read_test_csv(curve, crush::CsvOptions::default())?;
    Ok(crush::crush_force(&data, window).map_err(|e| InputError::file(curve, e.to_string()))?)
}

/// `lab slurm-worker` (inside a Slurm job): runs `keys` of the study and commits their records.
pub fn slurm_worker(study: &Study, out: &Path, jobs: usize, keys: &[String]) -> Result<i32, Error> {
    let Simulation::Solver(sim) = &study.simulation else {
        return Err(Error::Failed("slurm-worker: not a solver study".into()));
    };
    sweep::worker(study, sim, out, jobs, keys)
}
