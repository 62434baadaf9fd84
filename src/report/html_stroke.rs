//! The diagnosis on curves (`calibration.against: [response, curves]`): where along the stroke the
//! model errs. The curve features the diagnosis read (initial peak, plateau level and slope, fold
//! period) with the specimens' mean, its standard error and the uncorrected and final models'
//! values in units of it; then per tested design the specimens' band (mean ± 2 s.d. at each
//! stroke), the simulated curve before (uncorrected, at its calibrated parameters) and after (the
//! named cause's model), and the residual curves (test mean − model) against the band's half-width.

use std::fmt::Write;

use super::{Page, figure, id_part, note};
use crate::diagnose::features::FeaturesReport;
use crate::report::data::ResidualCurves;
use crate::report::markup::escape;
use crate::report::plots::{self, Series, Style, XyPlot, short};

/// Colours: the tests' band and mean, the uncorrected model, the named cause's model.
const TEST: usize = 1;
const BEFORE: usize = 3;
const AFTER: usize = 2;

impl Page<'_> {
    /// The features table and, per design, the curves and their residuals; empty without curves.
    pub(super) fn stroke(&self, dg: &crate::diagnose::Diagnosis) -> String {
        let curves = self.d.map(|d| d.residual_curves.as_slice()).unwrap_or_default();
        if dg.checked.features.is_none() && curves.is_empty() {
            return String::new();
        }
        let mut s = String::from("<h3 id=stroke>Where along the stroke the model errs</h3>");
        if let Some(f) = &dg.checked.features {
            s.push_str(&features_table(f));
        }
        if curves.is_empty() {
            s.push_str(&note(
                "the curves on the stroke grid were not recorded (report-data.json from an older lab)",
            ));
            return s;
        }
        s.push_str("<div class=grid>");
        for rc in curves {
            s.push_str(&curve_figure(rc));
            s.push_str(&residual_figure(rc));
        }
        s + "</div>"
    }
}

/// What the curves' features say: one row per design and feature, each model's value and its
/// residual in units of the specimens' standard error.
fn features_table(f: &FeaturesReport) -> String {
    let z = |v: Option<f64>| v.map_or("–".to_string(), |z| format!("{z:+.1}"));
    let value = |v: Option<f64>| v.map_or("–".to_string(), |v| short(v, 4));
    let mut s = String::from(
        "<table class=features><thead><tr><th>design</th><th>feature</th><th>tests: mean ± s.e.</th>\
         <th>specimens</th><th>uncorrected</th><th>z</th><th>final model</th><th>z</th></tr></thead><tbody>",
    );
    for r in &f.rows {
        let _ = write!(
            s,
            "<tr><td>{}</td><td>{}</td><td>{} ± {} {}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            escape(&r.design),
            escape(&r.feature),
            short(r.measured, 4),
            short(r.sigma, 2),
            escape(&r.unit),
            r.specimens,
            value(r.uncorrected),
            z(r.z_uncorrected),
            value(r.extended),
            z(r.z_extended),
        );
    }
    s.push_str("</tbody></table>");
    let read = f.read.join("; ");
    let mut text = format!(
        "The diagnosis reads these features of every specimen's curve, whitened in this order: {read}. \
         z = (tests − model) / standard error of the tests' mean."
    );
    if let (Some(by), Some(share)) = (&f.decided_by, f.decided_share) {
        let _ = write!(
            text,
            " Decided by the {by}: {:.0} % of the misfit the named cause's model removes.",
            100.0 * share
        );
    }
    s + &note(&text)
}

fn points(x: &[f64], y: &[f64]) -> Vec<(f64, f64)> {
    x.iter().copied().zip(y.iter().copied()).collect()
}

/// The band's edges, mean ± 2 s.d. at each stroke.
fn band(rc: &ResidualCurves, centre: &[f64], sign: f64) -> Vec<(f64, f64)> {
    let y: Vec<f64> = centre
        .iter()
        .zip(&rc.test_sd)
        .map(|(m, sd)| m + sign * 2.0 * sd)
        .collect();
    points(&rc.stroke, &y)
}

fn role(rc: &ResidualCurves) -> &'static str {
    if rc.validation { "validation" } else { "training" }
}

/// The tests' band and mean with the models' curves.
fn curve_figure(rc: &ResidualCurves) -> String {
    let mut series = vec![
        Series::new(
            format!("tests: mean ± 2 s.d. ({} specimens)", rc.specimens),
            TEST,
            Style::Dashed,
            band(rc, &rc.test_mean, 1.0),
        ),
        Series::new("", TEST, Style::Dashed, band(rc, &rc.test_mean, -1.0)),
        Series::new("tests: mean", TEST, Style::Line, points(&rc.stroke, &rc.test_mean)),
    ];
    if let Some(b) = &rc.before {
        series.push(Series::new(
            "uncorrected simulation",
            BEFORE,
            Style::Line,
            points(&rc.stroke, b),
        ));
    }
    if let (Some(a), Some(label)) = (&rc.after, &rc.after_label) {
        series.push(Series::new(
            format!("with '{label}'"),
            AFTER,
            Style::Line,
            points(&rc.stroke, a),
        ));
    }
    let plot = XyPlot {
        title: format!("Curves on the stroke grid, {} ({})", rc.design, role(rc)),
        x_label: "displacement (mm)".into(),
        y_label: "force (kN)".into(),
        legend_room: 0.06 * series.iter().filter(|s| !s.label.is_empty()).count() as f64 + 0.08,
        series,
        y_floor: Some(0.0),
        ..Default::default()
    };
    let caption = format!(
        "Design {} ({} design): the specimens' mean force at each stroke with the band mean ± 2 s.d. of the \
         specimens, the uncorrected simulation at its calibrated parameters{}.",
        rc.design,
        role(rc),
        rc.after_label
            .as_ref()
            .map(|l| format!(" and the model extended with '{l}'"))
            .unwrap_or_default()
    );
    figure(&format!("stroke-{}", id_part(&rc.design)), plot.render(), &caption)
}

/// Tests' mean − model along the stroke, against ± 2 s.d. of the specimens.
fn residual_figure(rc: &ResidualCurves) -> String {
    let zero = vec![0.0; rc.stroke.len()];
    let residual = |m: &[f64]| -> Vec<(f64, f64)> {
        let r: Vec<f64> = rc.test_mean.iter().zip(m).map(|(t, m)| t - m).collect();
        points(&rc.stroke, &r)
    };
    let mut series = vec![
        Series::new(
            "± 2 s.d. of the specimens",
            plots::GREY,
            Style::Dashed,
            band(rc, &zero, 1.0),
        ),
        Series::new("", plots::GREY, Style::Dashed, band(rc, &zero, -1.0)),
    ];
    if let Some(b) = &rc.before {
        series.push(Series::new("tests − uncorrected", BEFORE, Style::Line, residual(b)));
    }
    if let (Some(a), Some(label)) = (&rc.after, &rc.after_label) {
        series.push(Series::new(
            format!("tests − with '{label}'"),
            AFTER,
            Style::Line,
            residual(a),
        ));
    }
    let plot = XyPlot {
        title: format!("Residual curve, {}", rc.design),
        x_label: "displacement (mm)".into(),
        y_label: "force residual (kN)".into(),
        legend_room: 0.08 * series.iter().filter(|s| !s.label.is_empty()).count() as f64 + 0.08,
        series,
        hline: Some(0.0),
        ..Default::default()
    };
    let caption = format!(
        "Design {}: the tests' mean minus each model along the stroke; where a residual leaves the dashed band the \
         model misses beyond the specimens' scatter.",
        rc.design
    );
    figure(
        &format!("stroke-residual-{}", id_part(&rc.design)),
        plot.render(),
        &caption,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rc() -> ResidualCurves {
        let stroke = vec![0.0, 1.0, 2.0];
        let mut r = ResidualCurves::band(
            "C6T5",
            false,
            stroke,
            &[vec![0.0, 3.0, 2.0], vec![0.0, 3.2, 2.2], vec![0.0, 2.8, 2.4]],
        );
        r.before = Some(vec![0.0, 2.9, 1.9]);
        r.after = Some(vec![0.0, 3.0, 2.2]);
        r.after_label = Some("strain hardening".into());
        r
    }

    #[test]
    fn the_band_is_the_specimens_mean_and_sample_sd() {
        let r = rc();
        assert!((r.test_mean[1] - 3.0).abs() < 1e-12);
        assert!((r.test_sd[1] - 0.2).abs() < 1e-12, "{:?}", r.test_sd);
        assert!((r.test_sd[2] - 0.2).abs() < 1e-12);
        assert_eq!(r.specimens, 3);
    }

    #[test]
    fn both_figures_name_the_models_and_the_band() {
        let r = rc();
        let curve = curve_figure(&r);
        assert!(curve.contains("tests: mean ± 2 s.d. (3 specimens)"), "{curve}");
        assert!(curve.contains("uncorrected simulation"));
        assert!(curve.contains("with 'strain hardening'"), "{curve}");
        let residual = residual_figure(&r);
        assert!(residual.contains("id=stroke-residual-C6T5"));
        assert!(residual.contains("tests − uncorrected"));
    }
}
