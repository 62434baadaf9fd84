//! The `force-displacement` section: one plot per design of its simulated runs (grey, the run
//! nearest the calibrated parameters in black) and its test specimens (colour), with the stroke
//! window shaded — what the mean crush force of each curve is taken over.

use super::{Page, figure, id_part, method_name, note};
use crate::report::data::DesignCurves;
use crate::report::plots::{self, Band, Series, Style, XyPlot, short};

/// Specimens labelled one by one in a legend; more share one entry.
const MAX_TEST_LABELS: usize = 4;
/// A nearest run further than this fraction of a parameter's range from the estimate is said to be far.
const FAR: f64 = 0.05;

impl Page<'_> {
    pub(super) fn force_displacement(&self) -> String {
        let curves = self
            .d
            .map(|d| d.solver.force_displacement.as_slice())
            .unwrap_or_default();
        if curves.is_empty() {
            return note(
                "no force–displacement curves were recorded for this study: its response is not a crush force \
                 and it names no test curves (experiments.curves)",
            );
        }
        let mut s = String::from("<div class=grid>");
        for dc in curves {
            let series = self.curve_series(dc);
            let legend_room = legend_room(&series);
            let plot = XyPlot {
                title: format!("Force–displacement, {}", self.design_title(&dc.design)),
                x_label: "displacement (mm)".into(),
                y_label: "force (kN)".into(),
                series,
                bands: dc
                    .window
                    .map(|[a, b]| Band {
                        label: format!("stroke window {}–{} mm", short(a, 3), short(b, 3)),
                        x0: a,
                        x1: b,
                    })
                    .into_iter()
                    .collect(),
                y_floor: Some(0.0),
                legend_room,
                ..Default::default()
            };
            let id = format!("fd-{}", id_part(&dc.design));
            s.push_str(&figure(&id, plot.render(), &self.curve_caption(dc)));
        }
        s + "</div>" + &self.solver_comparison()
    }

    /// `design C6T5 (c = 6 mm, t = 0.05 mm)`.
    fn design_title(&self, design: &str) -> String {
        let Some(info) = self.study_info() else {
            return format!("design {design}");
        };
        let Some(test) = info.tests.iter().find(|t| t.name == design) else {
            return format!("design {design}");
        };
        let values: Vec<String> = info
            .design
            .iter()
            .zip(&test.values)
            .map(|(v, x)| match &v.unit {
                Some(u) => format!("{} = {} {u}", v.name, short(*x, 4)),
                None => format!("{} = {}", v.name, short(*x, 4)),
            })
            .collect();
        format!("design {design} ({})", values.join(", "))
    }

    /// Grey runs first, then the highlighted run, then the tests on top: the tests are what the
    /// reader compares against.
    fn curve_series(&self, dc: &DesignCurves) -> Vec<Series> {
        let points = |c: &crate::report::data::Curve| -> Vec<(f64, f64)> {
            c.displacement.iter().copied().zip(c.force.iter().copied()).collect()
        };
        let mut series = Vec::new();
        let others = dc.simulations.len() - usize::from(dc.nearest.is_some());
        let mut labelled = false;
        for (i, c) in dc.simulations.iter().enumerate() {
            if Some(i) == dc.nearest {
                continue;
            }
            let label = if labelled {
                String::new()
            } else {
                labelled = true;
                format!("{others} other simulated runs")
            };
            series.push(Series::new(label, plots::GREY, Style::Thin, points(c)));
        }
        // With a recommended model drawn, the uncorrected estimate's run is the one it replaces.
        let uncorrected = dc.recommended.as_ref().is_some_and(|r| r.model != "uncorrected");
        if let Some(c) = dc.nearest.and_then(|i| dc.simulations.get(i)) {
            let (label, style) = match uncorrected {
                true => (
                    format!("uncorrected, run nearest the estimate: {}", c.label),
                    Style::Dashed,
                ),
                false => (format!("run nearest the estimate: {}", c.label), Style::Line),
            };
            series.push(Series::new(label, plots::BLACK_, style, points(c)));
        }
        if let Some(r) = &dc.recommended {
            series.push(Series::new(recommended_label(r), 0, Style::Line, points(&r.curve)));
        }
        // Beyond a few specimens one legend entry stands for all: a legend line each would cover the plot.
        let many = dc.tests.len() > MAX_TEST_LABELS;
        for (i, c) in dc.tests.iter().enumerate() {
            // Colours 1.. of the palette: 0 (blue) stays the methods' first colour elsewhere.
            let colour = [1, 2, 3, 4, 5][i % 5];
            let label = match (many, i) {
                (false, _) => format!("test {}", c.label),
                (true, 0) => format!("{} test specimens", dc.tests.len()),
                (true, _) => String::new(),
            };
            series.push(Series::new(label, colour, Style::Line, points(c)));
        }
        series
    }

    fn curve_caption(&self, dc: &DesignCurves) -> String {
        let mut parts = Vec::new();
        if !dc.simulations.is_empty() {
            let shown = if dc.simulations.len() < dc.runs {
                format!(
                    "{} of its {} simulated runs (grey: the lowest and the highest mean crush force and runs spread \
                     between)",
                    dc.simulations.len(),
                    dc.runs
                )
            } else {
                format!("its {} simulated runs (grey)", dc.simulations.len())
            };
            parts.push(shown);
            if let (Some(c), Some(r)) = (dc.nearest.and_then(|i| dc.simulations.get(i)), &dc.reference) {
                let black = match dc.recommended.as_ref().is_some_and(|r| r.model != "uncorrected") {
                    true => "dashed black, the uncorrected model: the run",
                    false => "in black the run",
                };
                parts.push(format!(
                    "{black} nearest the {} estimate ({}): {}, mean crush force {}",
                    method_name(&r.method),
                    self.parameters_text(&r.parameters),
                    c.label,
                    kn(c.mean_force)
                ));
                if let Some(far) = self.offset(&c.parameters, &r.parameters).filter(|f| *f > FAR) {
                    parts.push(format!(
                        "no run lies near the estimate: the nearest is {} % of the parameter range away, so the \
                         black curve shows the trend, not the calibrated model",
                        short(100.0 * far, 2)
                    ));
                }
            }
        }
        if let Some(r) = &dc.recommended {
            parts.push(format!(
                "in blue the recommended model ({}): {}, mean crush force {}",
                model_name(&r.model),
                recommended_where(r),
                kn(r.curve.mean_force)
            ));
        }
        if !dc.tests.is_empty() {
            let means: Vec<f64> = dc.tests.iter().filter_map(|c| c.mean_force).collect();
            let mean = (!means.is_empty()).then(|| means.iter().sum::<f64>() / means.len() as f64);
            let shown = if dc.tests.len() < dc.tests_total {
                format!("{} of its {} test specimens", dc.tests.len(), dc.tests_total)
            } else if dc.tests.len() == 1 {
                "its test specimen".to_string()
            } else {
                format!("its {} test specimens", dc.tests.len())
            };
            parts.push(match mean {
                Some(_) => format!("{shown} in colour (mean crush force {})", kn(mean)),
                None => format!("{shown} in colour"),
            });
        }
        let mut text = format!("Design {}: {}.", dc.design, parts.join("; "));
        if dc.window.is_some() {
            text.push_str(" Shaded: the stroke window the mean crush force (absorbed energy / stroke) is taken over.");
        }
        text.push_str(" Curves are thinned to at most 300 points, keeping each bin's lowest and highest force.");
        text
    }

    /// The largest difference between two parameter vectors, each as a fraction of its range.
    fn offset(&self, a: &[f64], b: &[f64]) -> Option<f64> {
        let params = self.study_info()?.parameters.as_slice();
        let fractions = params.iter().zip(a.iter().zip(b)).filter_map(|(p, (x, y))| {
            let range = p.max? - p.min?;
            (range > 0.0).then(|| (x - y).abs() / range)
        });
        fractions.reduce(f64::max)
    }

    /// `sigma_y = 199.2 MPa`: calibrated parameters with their units.
    fn parameters_text(&self, values: &[f64]) -> String {
        let names = self.study_info().map(|i| i.parameters.as_slice()).unwrap_or_default();
        values
            .iter()
            .enumerate()
            .map(|(k, v)| match names.get(k) {
                Some(p) => match &p.unit {
                    Some(u) => format!("{} = {} {u}", p.name, short(*v, 4)),
                    None => format!("{} = {}", p.name, short(*v, 4)),
                },
                None => short(*v, 4),
            })
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// `with 'strain hardening': sigma_y = 184.6 MPa, etan = 195.4 MPa` and where the run lies.
fn recommended_label(r: &crate::report::data::RecommendedCurve) -> String {
    let at = if r.offset <= FAR { "" } else { " (nearest run)" };
    format!("recommended, {}: {}{at}", model_name(&r.model), r.curve.label)
}

fn model_name(model: &str) -> String {
    match model {
        "uncorrected" => "the simulation as calibrated".to_string(),
        cause => format!("with '{cause}'"),
    }
}

/// Whether the drawn run is at the model's fitted point or only the nearest to it.
fn recommended_where(r: &crate::report::data::RecommendedCurve) -> String {
    if r.offset < 1e-9 {
        format!("the solver's run at its fitted parameters, {}", r.curve.label)
    } else if r.offset <= FAR {
        format!(
            "the solver's run nearest its fitted parameters ({} % of a range away), {}",
            short(100.0 * r.offset, 2),
            r.curve.label
        )
    } else {
        format!(
            "no run lies near its fitted parameters: the nearest, {} % of a range away, {}",
            short(100.0 * r.offset, 2),
            r.curve.label
        )
    }
}

/// Room above the curves for the legend, as a fraction of the force span: about one legend line
/// (plus the stroke window's) per 6 % of it.
fn legend_room(series: &[Series]) -> f64 {
    let lines = 1 + series.iter().filter(|s| !s.label.is_empty()).count();
    0.06 * lines as f64 + 0.08
}

fn kn(v: Option<f64>) -> String {
    v.map_or("–".into(), |v| format!("{} kN", short(v, 3)))
}

#[cfg(test)]
mod tests {
    use super::super::Page;
    use crate::report::Results;
    use crate::report::data::{Curve, DesignCurves, Reference, ReportData, SolverData, StudyInfo, TestInfo, Variable};

    fn curve(label: &str, parameters: Vec<f64>, mean: f64) -> Curve {
        Curve {
            label: label.into(),
            displacement: vec![0.0, 10.0, 60.0],
            force: vec![0.0, mean, mean],
            parameters,
            mean_force: Some(mean),
            points: 123,
        }
    }

    fn data() -> ReportData {
        let study = StudyInfo {
            parameters: vec![Variable {
                name: "sigma_y".into(),
                unit: Some("MPa".into()),
                min: None,
                max: None,
            }],
            design: ["c", "t"]
                .map(|n| Variable {
                    name: n.into(),
                    unit: Some("mm".into()),
                    min: None,
                    max: None,
                })
                .to_vec(),
            tests: vec![TestInfo {
                name: "C6T5".into(),
                role: "training".into(),
                values: vec![6.0, 0.05],
                replicates: vec![2.8],
            }],
            ..Default::default()
        };
        ReportData {
            study,
            solver: SolverData {
                force_displacement: vec![DesignCurves {
                    design: "C6T5".into(),
                    window: Some([5.0, 60.0]),
                    simulations: vec![
                        curve("sigma_y = 100.5 MPa", vec![100.5], 1.5),
                        curve("sigma_y = 198.9 MPa", vec![198.9], 2.86),
                        curve("sigma_y = 249 MPa", vec![249.0], 3.6),
                    ],
                    tests: vec![curve("C6T5-1", vec![], 2.7), curve("C6T5-2", vec![], 2.9)],
                    runs: 17,
                    nearest: Some(1),
                    reference: Some(Reference {
                        method: "least_squares".into(),
                        parameters: vec![199.23],
                    }),
                    tests_total: 3,
                    recommended: None,
                }],
                ..Default::default()
            },
            ..Default::default()
        }
    }

    fn results() -> Results {
        serde_json::from_value(serde_json::json!({
            "study": "honeycomb", "calibration": {}, "diagnosis": null,
            "identifiability": {"identifiable": true, "note": "", "combinations": [], "singular_values": []}
        }))
        .unwrap()
    }

    #[test]
    fn a_design_plot_names_its_runs_tests_and_window() {
        let (r, d) = (results(), data());
        let html = Page { r: &r, d: Some(&d) }.force_displacement();
        assert!(html.contains("<figure class=plot id=fd-C6T5><svg"), "{html}");
        for text in [
            "Force–displacement, design C6T5 (c = 6 mm, t = 0.05 mm)",
            "force (kN)",
            "displacement (mm)",
            "stroke window 5–60 mm",
            "2 other simulated runs",
            "run nearest the estimate: sigma_y = 198.9 MPa",
            "test C6T5-2",
            "3 of its 17 simulated runs",
            "least squares estimate (sigma_y = 199.2 MPa): sigma_y = 198.9 MPa, mean crush force 2.86 kN",
            // The drawn specimens' mean: (2.7 + 2.9) / 2.
            "2 of its 3 test specimens in colour (mean crush force 2.8 kN)",
        ] {
            assert!(html.contains(text), "`{text}` missing:\n{html}");
        }
        // One legend entry for all the grey runs.
        assert_eq!(html.matches("other simulated runs").count(), 1);
    }

    #[test]
    fn many_specimens_share_a_legend_entry_and_a_far_nearest_run_is_said_to_be_far() {
        let r = results();
        let mut d = data();
        d.study.parameters[0].min = Some(100.0);
        d.study.parameters[0].max = Some(250.0);
        let dc = &mut d.solver.force_displacement[0];
        dc.tests = (1..=5).map(|i| curve(&format!("C6T5-{i}"), vec![], 2.8)).collect();
        dc.simulations[1].parameters = vec![249.0];
        let html = Page { r: &r, d: Some(&d) }.force_displacement();
        assert!(
            html.contains("5 test specimens") && !html.contains("test C6T5-1"),
            "{html}"
        );
        // (249 − 199.23) / (250 − 100) = 33 %.
        assert!(
            html.contains("the nearest is 33 % of the parameter range away"),
            "{html}"
        );
        // Near enough (within 5 % of the range): nothing said.
        d.solver.force_displacement[0].simulations[1].parameters = vec![198.9];
        let html = Page { r: &r, d: Some(&d) }.force_displacement();
        assert!(!html.contains("no run lies near"), "{html}");
    }

    #[test]
    fn no_curves_says_why() {
        let r = results();
        let d = ReportData::default();
        let html = Page { r: &r, d: Some(&d) }.force_displacement();
        assert!(html.contains("no force–displacement curves were recorded"), "{html}");
    }
}
