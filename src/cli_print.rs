//! What `lab run` and `lab status` print while they work: the pipeline's events and the run
//! engine's progress on stderr, and the status counts.

use std::path::Path;

use crate::error::Error;
use crate::execute::progress;
use crate::pipeline::{Event, Reporter, verbs};
use crate::study::Study;

/// The pipeline's events, and the run engine's progress bar, on stderr.
pub(super) struct Stderr;

impl Reporter for Stderr {
    fn report(&mut self, event: Event<'_>) {
        match event {
            Event::Note(note) => eprintln!("note: {note}"),
            Event::Recorded { runs, dir } => eprintln!("recorded {runs} run(s) into {}", dir.display()),
            Event::RunsEnded(outcomes) => {
                eprint!(
                    "{}",
                    progress::summary_table(&outcomes.classes, outcomes.reused, outcomes.missing)
                );
                for run in outcomes.failed.iter().take(5) {
                    eprintln!(
                        "failed: design `{}`, parameters {:?}: {} (see {})",
                        run.design,
                        run.theta,
                        run.why,
                        run.dir.display()
                    );
                }
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
    if let Some(b) = &s.batches {
        let done: Vec<String> = b.done.iter().map(|(stage, n)| format!("{stage} {n}")).collect();
        println!("batches done: {}", if done.is_empty() { "none".into() } else { done.join(", ") });
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

