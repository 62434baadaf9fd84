//! The reporter: consumes the executor's [`Event`]s, draws an indicatif bar (done / running /
//! failed, rate, ETA) on stderr when stderr is a terminal, and counts outcome classes for the final
//! summary table. The executor never prints; only this does.

use std::collections::{BTreeMap, BTreeSet};
use std::io::IsTerminal;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use tokio::sync::mpsc;

use super::{Event, OutcomeClass};

/// Counts kept while events arrive.
#[derive(Debug, Default)]
pub struct Tally {
    pub running: BTreeSet<String>,
    pub done: u64,
    pub failed: u64,
    pub retries: u64,
}

/// A progress bar over `total` runs; hidden unless stderr is a terminal.
pub fn bar(total: u64) -> ProgressBar {
    let target = if std::io::stderr().is_terminal() {
        ProgressDrawTarget::stderr()
    } else {
        ProgressDrawTarget::hidden()
    };
    let bar = ProgressBar::with_draw_target(Some(total), target);
    let style = ProgressStyle::with_template("{bar:30} {pos}/{len} runs  {msg}  {per_sec}  ETA {eta}")
        .unwrap_or_else(|_| ProgressStyle::default_bar());
    bar.set_style(style);
    bar.enable_steady_tick(Duration::from_millis(200));
    bar
}

/// Consumes events until the channel closes; returns the tally.
pub async fn report(mut events: mpsc::UnboundedReceiver<Event>, bar: ProgressBar) -> Tally {
    let mut tally = Tally::default();
    while let Some(event) = events.recv().await {
        match event {
            Event::Started { key, .. } => {
                tally.running.insert(key);
            }
            Event::Retrying { .. } => tally.retries += 1,
            Event::Finished { record } => {
                tally.running.remove(&record.key);
                if record.outcome.is_success() {
                    tally.done += 1;
                } else {
                    tally.failed += 1;
                }
                bar.inc(1);
            }
            Event::Cancelled { key } => {
                tally.running.remove(&key);
            }
        }
        bar.set_message(format!(
            "{} done, {} running, {} failed",
            tally.done,
            tally.running.len(),
            tally.failed
        ));
    }
    bar.finish_and_clear();
    tally
}

/// The final table: how many planned runs ended in each outcome class, plus those reused from
/// earlier passes and those with no result.
pub fn summary_table(classes: &BTreeMap<OutcomeClass, usize>, reused: usize, missing: usize) -> String {
    let mut rows: Vec<(String, usize)> = Vec::new();
    if reused > 0 {
        rows.push(("reused (finished earlier)".into(), reused));
    }
    for (class, n) in classes.iter().filter(|(_, n)| **n > 0) {
        rows.push((class.key(), *n));
    }
    if missing > 0 {
        rows.push(("not run".into(), missing));
    }
    let mut out = String::from("outcome                    runs\n");
    for (name, n) in rows {
        out.push_str(&format!("{name:<26} {n:>5}\n"));
    }
    out
}
