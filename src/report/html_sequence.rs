//! The report's account of a sequentially sampled study: what each batch of solver runs bought —
//! each variable's estimate and 95 % interval against the runs spent, and the batches in a table
//! with the emulators' error against the tests' noise and why each stage stopped.

use std::fmt::Write;

use super::plots::{Series, Style, XyPlot};
use super::{escape, figure};
use crate::pipeline::sequence::Sequence;
use crate::report::Results;

/// The section's content (empty for a study with a fixed plan).
pub(super) fn section(r: &Results) -> String {
    let Some(s) = &r.sampling else {
        return String::new();
    };
    let mut out = format!(
        "<h3>Sequential sampling</h3><p id=sequence-summary>{} solver runs in all{}; each batch was planned from the runs \
         before it, where the emulators' uncertainty most affects the posterior, until their error on runs they were not \
         fitted to was at most {} of the tests' noise at every tested design. {}</p><div class=grid>",
        s.runs,
        replaced(s),
        s.tolerance,
        escape(&stops(s))
    );
    for name in variables(s) {
        out.push_str(&interval_plot(
            s,
            &name,
            r.stated.truth.as_ref().and_then(|t| t.get(&name)).copied(),
        ));
    }
    out.push_str("</div>");
    out.push_str(&table(s));
    out
}

/// Beside the runs in all, the fixed design the study says the sequence replaces.
fn replaced(s: &Sequence) -> String {
    s.replaces.as_ref().map_or(String::new(), |r| {
        format!(" (the {} it replaces: {} runs)", r.design(), r.runs)
    })
}

fn stops(s: &Sequence) -> String {
    s.stopped
        .iter()
        .map(|x| format!("{}: {} after {} run(s)", x.stage, x.reason.key(), x.runs))
        .collect::<Vec<_>>()
        .join("; ")
}

/// Every variable any batch estimated, in first-seen order.
fn variables(s: &Sequence) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for b in &s.sequence {
        for n in b.posterior.estimates.keys() {
            if !out.contains(n) {
                out.push(n.clone());
            }
        }
    }
    out
}

/// A variable's estimate and 95 % interval after each batch, against the runs so far.
fn interval_plot(s: &Sequence, name: &str, truth: Option<f64>) -> String {
    // (runs so far, estimate, interval) after each batch.
    type Point = (f64, f64, [f64; 2]);
    let at: Vec<Point> = s
        .sequence
        .iter()
        .filter_map(|b| {
            Some((
                b.count.total as f64,
                *b.posterior.estimates.get(name)?,
                *b.posterior.interval95.get(name)?,
            ))
        })
        .collect();
    let line = |label: &str, color, style, f: &dyn Fn(&Point) -> f64| {
        Series::new(label, color, style, at.iter().map(|p| (p.0, f(p))).collect())
    };
    let mut series = vec![
        line("estimate (posterior mean)", 0, Style::LineMarkers, &|p| p.1),
        line("95 % interval", 1, Style::Dashed, &|p| p.2[0]),
        line("", 1, Style::Dashed, &|p| p.2[1]),
    ];
    if let Some(t) = truth {
        let xs = at.iter().map(|p| p.0);
        let (lo, hi) = xs.fold((f64::INFINITY, 0.0f64), |(a, b), x| (a.min(x), b.max(x)));
        series.push(Series::new("truth", 2, Style::Thin, vec![(lo, t), (hi, t)]));
    }
    let plot = XyPlot {
        title: format!("{name} as the runs come in"),
        x_label: "solver runs so far".into(),
        y_label: name.into(),
        series,
        bands: Vec::new(),
        vlines: Vec::new(),
        hline: None,
        y_floor: None,
        legend_room: 0.25,
    };
    figure(
        &format!("sequence-{name}"),
        plot.render(),
        &format!("The posterior of {name} after each batch (mean and 95 % interval), as the planner saw it."),
    )
}

/// One row per batch.
fn table(s: &Sequence) -> String {
    let mut out = String::from(
        "<table id=sequence-table><tr><th class=l>stage</th><th>batch</th><th>runs</th><th>in all</th>\
         <th class=l>emulator error / tests' noise (held out)</th><th class=l>estimates (95 %)</th></tr>",
    );
    for b in &s.sequence {
        let errors: Vec<String> = b
            .errors
            .emulator_error
            .iter()
            .map(|(d, e)| format!("{d} {}", e.map_or("–".into(), crate::base::format::num)))
            .collect();
        let estimates: Vec<String> = b
            .posterior
            .estimates
            .iter()
            .map(|(n, v)| {
                let [lo, hi] = b.posterior.interval95.get(n).copied().unwrap_or([f64::NAN; 2]);
                format!(
                    "{n} {} [{}, {}]",
                    crate::base::format::num(*v),
                    crate::base::format::num(lo),
                    crate::base::format::num(hi)
                )
            })
            .collect();
        let _ = write!(
            out,
            "<tr><td class=l>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=l>{}</td><td class=l>{}</td></tr>",
            escape(&b.stage),
            b.batch,
            b.count.runs,
            b.count.total,
            escape(&errors.join(", ")),
            escape(&estimates.join(", "))
        );
    }
    out.push_str("</table>");
    out
}
