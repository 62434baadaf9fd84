//! What `lab run`, `lab status` and `lab extract` print: the pipeline's events and the run
//! engine's progress on stderr, the status counts, a curve's or a binout's figures.

use std::path::Path;

use crate::error::{Error, InputError};
use crate::execute::progress;
use crate::extract::crush;
use crate::pipeline::{Event, Reporter, verbs};
use crate::study::Study;

/// The pipeline's events, and the run engine's progress bar, on stderr.
pub(super) struct Stderr;

impl Reporter for Stderr {
    fn report(&mut self, event: Event<'_>) {
        match event {
            Event::Note(note) => eprintln!("note: {note}"),
            Event::Recorded { runs, dir } => eprintln!("recorded {runs} run(s) into {}", dir.display()),
            Event::Failed(runs) => {
                for run in runs {
                    eprintln!("failed: {}", run.words());
                }
            }
            Event::RunsEnded(outcomes) => {
                eprint!(
                    "{}",
                    progress::summary_table(&outcomes.classes, outcomes.reused, outcomes.missing)
                );
            }
            Event::Batch(b) => eprintln!("{}", b.line()),
            Event::Interrupted { out } => eprintln!(
                "interrupted: finished runs are kept in {}; `lab run` again resumes",
                out.display()
            ),
        }
    }

    /// A progress bar on stderr when it is a terminal.
    fn progress(&mut self, runs: u64) -> indicatif::ProgressBar {
        progress::bar(runs)
    }
}

/// `lab status`: counts of the planned runs, and who holds the output directory.
pub(super) fn status(study: &Study, out: &Path) -> Result<i32, Error> {
    let Some(s) = verbs::status(study, out)? else {
        println!(
            "study `{}`: closed-form simulation, no solver runs (done 0, failed 0, running 0, pending 0)",
            study.name
        );
        return Ok(0);
    };
    println!(
        "study `{}`: {} planned run(s): done {}, failed {}, running {}, pending {}",
        study.name, s.planned, s.done, s.failed, s.running, s.pending
    );
    if !s.failed_by_stage.is_empty() {
        let stages: Vec<String> = s
            .failed_by_stage
            .iter()
            .map(|(stage, n)| format!("{stage} {n}"))
            .collect();
        println!("failed by stage: {}", stages.join(", "));
    }
    if let Some(b) = &s.batches {
        let done: Vec<String> = b.done.iter().map(|(stage, n)| format!("{stage} {n}")).collect();
        println!(
            "batches done: {}",
            if done.is_empty() {
                "none".into()
            } else {
                done.join(", ")
            }
        );
        if let Some((stage, batch, runs)) = &b.in_flight {
            println!("in flight: {stage} batch {batch} ({runs} run(s))");
        }
        for (stage, reason) in &b.stopped {
            println!("{stage}: stopped ({reason})");
        }
    }
    if let Some(holder) = s.holder {
        let who = holder.map_or("holder not yet written".to_string(), |h| {
            format!("pid {} on host {}", h.pid, h.host)
        });
        println!("a lab is running on {} ({who})", out.display());
    }
    Ok(0)
}

/// `lab extract CURVE --window S0:S1`, or a binout with `--list` / `--series PATH [--json]`.
pub(super) fn extract(
    curve: &Path,
    window: &str,
    list: bool,
    series: Option<String>,
    json: bool,
) -> Result<i32, Error> {
    let bad = || InputError::file(curve, format!("--window `{window}`: give S0:S1 in mm, e.g. 5:60"));
    let (a, b) = window.split_once(':').ok_or_else(bad)?;
    let (s0, s1) = (
        a.trim().parse::<f64>().map_err(|_| bad())?,
        b.trim().parse::<f64>().map_err(|_| bad())?,
    );
    if verbs::is_binout(curve) {
        let query = match (list, series) {
            (true, _) => verbs::BinoutQuery::List,
            (false, Some(path)) => verbs::BinoutQuery::Series { path, json },
            (false, None) => verbs::BinoutQuery::MeanForce(crush::Window { s0, s1 }),
        };
        let answer = verbs::extract_binout(curve, &query)?;
        answer.notes.iter().for_each(|n| eprintln!("note: {n}"));
        print!("{}", answer.text);
        return Ok(0);
    }
    if list || series.is_some() {
        return Err(InputError::file(
            curve,
            "--list and --series read a binout (an LSDA file or a run directory), not a CSV",
        )
        .into());
    }
    let r = verbs::extract(curve, crush::Window { s0, s1 })?;
    println!(
        "mean crush force {} kN over {s0}-{s1} mm (energy {} J, peak {} kN at {} mm)",
        r.mean_force, r.energy, r.peak_force, r.peak_at
    );
    Ok(0)
}
