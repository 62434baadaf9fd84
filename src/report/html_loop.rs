//! The solver in the loop, as the Diagnosis section shows it: per extended hypothesis, its
//! calibrated parameters with their intervals and what it gains (a table from `results.json`
//! `diagnosis.extensions`), the extended model's response over its extension variable against
//! every design's tests (`report-data.json` `extension_surfaces`), and each design's residual in
//! units of σ before and after.

use std::fmt::Write;

use super::{escape, figure, id_part, pct};
use crate::diagnose::Diagnosis;
use crate::diagnose::joint::SolverExtension;
use crate::report::data::{ExtensionSurface, ReportData};
use crate::report::plots::{Band, BarPlot, Series, Style, VLine, XyPlot};
use crate::report::summary::significant;

/// The loop's subsection; empty when no hypothesis was extended with the solver.
pub(super) fn section(dg: &Diagnosis, data: Option<&ReportData>) -> String {
    if dg.explained.extensions.is_empty() {
        return String::new();
    }
    let mut s = String::from("<h3>Simulation in the loop</h3>");
    s.push_str(&table(&dg.explained.extensions));
    s.push_str("<div class=grid>");
    for x in &dg.explained.extensions {
        let surface = data.and_then(|d| d.extension_surfaces.iter().find(|c| c.hypothesis == x.setup.hypothesis));
        if let Some(surface) = surface {
            s.push_str(&surface_plot(x, surface));
        }
        s.push_str(&before_after_z(dg, x));
    }
    s.push_str("</div>");
    s
}

/// One row per extended hypothesis.
fn table(extensions: &[SolverExtension]) -> String {
    let mut s = String::from(
        "<table id=loop-table><tr><th class=l>hypothesis</th><th>runs</th><th class=l>parameters (95 % interval)</th>\
         <th>lack of fit p</th><th>validation error before → after</th><th>leave-one-out before → after</th>\
         <th class=l>what remains</th></tr>",
    );
    for x in extensions {
        let params: Vec<String> = x
            .fitted
            .parameters
            .iter()
            .map(|(n, v)| match x.fitted.interval95.as_ref().and_then(|i| i.get(n)) {
                Some([lo, hi]) => format!(
                    "{n} = {} ({} to {})",
                    significant(*v, 5),
                    significant(*lo, 4),
                    significant(*hi, 4)
                ),
                None => format!("{n} = {}", significant(*v, 5)),
            })
            .collect();
        let arrow = |b: Option<f64>, a: Option<f64>| format!("{} → {}", pct(b), pct(a));
        let _ = write!(
            s,
            "<tr><td class=l>{}</td><td>{} / {}</td><td class=l>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=l>{}</td></tr>",
            escape(&x.setup.hypothesis),
            x.setup.runs.succeeded,
            x.setup.runs.planned,
            escape(&params.join("; ")),
            x.judged.lack_of_fit_p.map_or("–".into(), |p| significant(p, 2)),
            arrow(x.judged.validation_error_before, x.judged.validation_error_after),
            arrow(x.judged.loo_error_before, x.judged.loo_error_after),
            escape(&x.left.what_remains_headline)
        );
    }
    s.push_str("</table>");
    s
}

/// Predicted / measured over the extension variable, one line per design: where a line crosses 1
/// the extended model meets that design's tests; the shaded band is the calibrated value's 95 %
/// interval.
fn surface_plot(x: &SolverExtension, surface: &ExtensionSurface) -> String {
    let series = surface
        .designs
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let points = c.points.iter().map(|(v, y)| (*v, y / c.measured)).collect();
            let mut s = Series::new(c.design.clone(), i, Style::Line, points);
            s.y_err = None;
            s
        })
        .collect();
    let value = x.fitted.parameters.get(&surface.variable).copied();
    let interval = x.fitted.interval95.as_ref().and_then(|i| i.get(&surface.variable));
    let unit = surface.unit.as_deref().map_or(String::new(), |u| format!(" [{u}]"));
    let plot = XyPlot {
        title: format!("The extended model over {} ({})", surface.variable, x.setup.hypothesis),
        x_label: format!("{}{unit}", surface.variable),
        y_label: "predicted / measured".into(),
        series,
        bands: interval
            .map(|[lo, hi]| Band {
                label: "95 % interval".into(),
                x0: *lo,
                x1: *hi,
            })
            .into_iter()
            .collect(),
        vlines: value
            .map(|v| VLine {
                label: format!("calibrated {}", significant(v, 4)),
                x: v,
                color: 0,
            })
            .into_iter()
            .collect(),
        hline: Some(1.0),
        y_floor: None,
        legend_room: 0.25,
    };
    let noise = surface
        .designs
        .iter()
        .filter_map(|c| c.sigma_of_mean.map(|s| s / c.measured))
        .fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))));
    let caption = format!(
        "Each design's prediction of the model extended with {} divided by its tests' mean, over {} (the other \
         parameters at their calibrated values), from the surrogates fitted to the {} runs over the joint space. \
         Where a line crosses 1 the model meets that design's tests{}; the vertical line is the calibrated value, \
         the band its 95 % interval.",
        x.setup.hypothesis,
        surface.variable,
        x.setup.runs.succeeded,
        noise.map_or(String::new(), |n| format!(
            " (the tests' means are uncertain by up to ±{:.2} % at one σ)",
            100.0 * n
        ))
    );
    figure(
        &format!("loop-surface-{}", id_part(&x.setup.hypothesis)),
        plot.render(),
        &caption,
    )
}

/// Each design's residual in units of σ, before (the uncorrected simulation) and after (the
/// extended model): within ±2 is within the noise.
fn before_after_z(dg: &Diagnosis, x: &SolverExtension) -> String {
    let designs: Vec<String> = x.left.residual_z.keys().cloned().collect();
    // Magnitudes: the bars grow from 0 (the table of residuals gives the signs).
    let before: Vec<Option<f64>> = designs
        .iter()
        .map(|d| dg.record.residuals.iter().find(|r| &r.design == d).map(|r| r.z.abs()))
        .collect();
    let plot = BarPlot {
        title: format!("Residual / σ before and after extending with {}", x.setup.hypothesis),
        value_label: "|measured − predicted| / σ".into(),
        categories: designs,
        groups: vec![
            ("uncorrected".into(), 1, before),
            (
                format!("extended with {}", x.setup.hypothesis),
                2,
                x.left.residual_z.values().map(|z| Some(z.abs())).collect(),
            ),
        ],
        percent: false,
        headings: vec![],
    };
    let caption = format!(
        "Each tested design's |residual| in units of σ (training: σ of the mean; validation: with the prediction's \
         uncertainty, after) for the uncorrected simulation and the model extended with {} calibrated in the loop. \
         Within ±2 is within the noise; {} design(s) remain beyond it.",
        x.setup.hypothesis,
        x.left.remaining.len()
    );
    figure(
        &format!("loop-residuals-{}", id_part(&x.setup.hypothesis)),
        plot.render(),
        &caption,
    )
}
