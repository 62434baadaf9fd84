//! `report.html`: one self-contained page (inline SVG and CSS, no script, no external asset),
//! printable, rendered from [`Results`] and, when recorded, [`ReportData`] — so `lab report`
//! rebuilds it from what `lab run` wrote.
//!
//! Sections (element ids): `study`, `force-displacement`, `surrogates`, `calibration`,
//! `identifiability`, `diagnosis`, `runs`. A section whose data are absent says why instead of
//! drawing. Figures are `<figure class=plot id=…>` holding one `<svg>` each. The force–displacement
//! section is in `html_curves.rs`, the paper's Fig. 13 over every train/validate split in
//! `html_splits.rs`.

use std::fmt::Write;

use indexmap::IndexMap;

use super::data::{ReportData, RunRow, StudyInfo, SurrogateData, Variable};
use super::plots::{self, Band, BarPlot, Series, Style, VLine, XyPlot, short};
use super::results::{MethodResult, Results, Role, SurrogateResult};
use super::summary::significant;

#[path = "html_curves.rs"]
mod curves;
#[path = "html_sequence.rs"]
mod sequence;
#[path = "html_loop.rs"]
mod solver_loop;
#[path = "html_solvers.rs"]
mod solvers;
#[path = "html_splits.rs"]
mod splits;
#[path = "html_stroke.rs"]
mod stroke;

/// Section ids, in page order (the browser test checks them). The page opens with the verdict.
pub const SECTIONS: [&str; 8] = [
    "answer",
    "study",
    "force-displacement",
    "surrogates",
    "calibration",
    "identifiability",
    "diagnosis",
    "runs",
];

pub fn render(results: &Results, data: Option<&ReportData>) -> String {
    let page = Page { r: results, d: data };
    let mut body = String::new();
    let _ = write!(body, "<header><h1>Calibration report — {}</h1>", escape(&results.study));
    if data.is_none() {
        body.push_str(
            "<p class=warn>No report-data.json was recorded beside results.json (written by an older lab?): \
             the plots that need it are left out. Run <code>lab run</code> again to get them.</p>",
        );
    }
    body.push_str("<nav><ol>");
    for (id, title) in SECTIONS.iter().zip(TITLES) {
        let _ = write!(body, "<li><a href=#{id}>{title}</a></li>");
    }
    body.push_str("</ol></nav></header>");
    let sections = [
        page.answer(),
        page.study(),
        page.force_displacement(),
        page.surrogates(),
        page.calibration(),
        page.identifiability(),
        page.diagnosis(),
        page.runs(),
    ];
    for ((id, title), content) in SECTIONS.iter().zip(TITLES).zip(sections) {
        let _ = write!(body, "<section id={id}><h2>{title}</h2>{content}</section>");
    }
    format!(
        "<!DOCTYPE html><html lang=en><head><meta charset=utf-8>\
         <meta name=viewport content=\"width=device-width, initial-scale=1\">\
         <title>lab — {}</title><style>{STYLE}</style></head><body>{body}</body></html>\n",
        escape(&results.study)
    )
}

const TITLES: [&str; 8] = [
    "Verdict",
    "Study",
    "Force–displacement curves",
    "Response surfaces",
    "Calibration",
    "Identifiability",
    "Diagnosis",
    "Runs",
];

const STYLE: &str = "body{font-family:system-ui,sans-serif;max-width:76em;margin:1.5em auto;padding:0 1em;color:#222;\
line-height:1.4}h1{font-size:1.6em}h2{border-bottom:2px solid #ddd;padding-bottom:.2em;margin-top:1.6em}\
h3{font-size:1.05em;margin:1.2em 0 .4em}\
nav ol{display:flex;flex-wrap:wrap;gap:.3em 1.4em;padding-left:1.2em}\
table{border-collapse:collapse;margin:.6em 0}td,th{border:1px solid #ccc;padding:.25em .6em;text-align:right;\
vertical-align:top}th{background:#f3f3f3}td.l,th.l{text-align:left}\
.grid{display:grid;grid-template-columns:repeat(auto-fill,minmax(30em,1fr));gap:1em}\
figure.plot{margin:0;border:1px solid #eee;padding:.3em}figure.plot svg{width:100%;height:auto;display:block}\
figcaption{font-size:.85em;color:#555;padding:.2em .4em}.warn{color:#a40;font-weight:600}.ok{color:#264}\
.note{color:#555;font-style:italic}p.summary{border-left:4px solid #264;padding:.2em .8em;background:#f6faf7}\
p.summary.flag{border-color:#a40;background:#fdf6f0}\
div.verdict{border-left:5px solid #264;padding:.3em .9em;background:#f6faf7;margin:.6em 0}\
div.verdict.flag{border-color:#a40;background:#fdf6f0}div.verdict.open{border-color:#886;background:#fafaf2}\
div.verdict.found{border-color:#246;background:#f4f7fb}\
div.verdict p{margin:.3em 0}tr.failed td{background:#fff3f0}code{font-size:.95em}\
@media print{body{max-width:none;margin:0}nav{display:none}figure,table,tr{break-inside:avoid}\
.grid{grid-template-columns:1fr 1fr}h2{break-after:avoid}}";

struct Page<'a> {
    r: &'a Results,
    d: Option<&'a ReportData>,
}

fn method_name(key: &str) -> String {
    match key {
        "least_squares" => "least squares".into(),
        "sensitivity" => "sensitivity".into(),
        "bayesian" => "Bayesian".into(),
        other => other.replace('_', " "),
    }
}

/// Colour of a method in every plot.
fn method_color(key: &str) -> usize {
    match key {
        "least_squares" => 0,
        "sensitivity" => 1,
        "bayesian" => 2,
        _ => 3,
    }
}

fn figure(id: &str, svg: String, caption: &str) -> String {
    format!(
        "<figure class=plot id={id}>{svg}<figcaption>{}</figcaption></figure>",
        escape(caption)
    )
}

fn note(text: &str) -> String {
    format!("<p class=note>{}</p>", escape(text))
}

/// A value with its unit, `sig` significant figures.
fn with_unit(v: f64, unit: Option<&str>, sig: usize) -> String {
    match unit {
        Some(u) => format!("{} {}", significant(v, sig), escape(u)),
        None => significant(v, sig),
    }
}

/// A relative error as a percentage with three significant figures (trailing zeros kept: 1.40 %
/// beside 0.739 % reads as the same precision).
fn pct(x: Option<f64>) -> String {
    x.map_or("–".to_string(), |v| {
        if v.abs() < 1e-9 {
            "0 %".into()
        } else {
            format!("{} %", significant(100.0 * v, 3))
        }
    })
}

/// A duration: whole seconds from 100 s, milliseconds below 1 s.
fn seconds(s: f64) -> String {
    if s >= 100.0 {
        format!("{s:.0} s")
    } else if s >= 1.0 {
        format!("{} s", significant(s, 3))
    } else {
        format!("{} ms", short(1000.0 * s, 3))
    }
}

fn id_part(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect()
}

impl Page<'_> {
    fn study_info(&self) -> Option<&StudyInfo> {
        self.d.map(|d| &d.study)
    }

    /// The response axis label: name and unit when known.
    fn response_label(&self) -> String {
        match self.study_info() {
            Some(s) => match &s.response_unit {
                Some(u) => format!("{} ({u})", s.response),
                None => s.response.clone(),
            },
            None => "response".into(),
        }
    }

    fn response_unit(&self) -> Option<&str> {
        self.study_info().and_then(|s| s.response_unit.as_deref())
    }

    fn parameter(&self, name: &str) -> Option<&Variable> {
        self.study_info()?.parameters.iter().find(|p| p.name == name)
    }

    fn parameter_label(&self, name: &str) -> String {
        self.parameter(name).map_or(name.to_string(), Variable::label)
    }

    fn study(&self) -> String {
        let Some(info) = self.study_info() else {
            let mut s = String::new();
            let _ = write!(
                s,
                "{}",
                note("the study description is recorded in report-data.json, which is missing")
            );
            return s + &self.runs_summary();
        };
        self.study_table(info) + &self.tests_table(info)
    }

    /// The study as run: simulation, response, constants, variables and bounds, runs, wall time.
    fn study_table(&self, info: &StudyInfo) -> String {
        let mut s = String::new();
        s.push_str("<table><tr><th class=l>item</th><th class=l>value</th></tr>");
        let sim = match &info.solver {
            None => format!("closed form: <code>{}</code>", escape(&info.simulation)),
            Some(solver) => format!(
                "solver (adapter <code>{}</code>): <code>{}</code><br>{} surrogate per design; {}",
                escape(&solver.adapter),
                escape(&info.simulation),
                escape(&solver.surrogate),
                escape(&solver.sampling)
            ),
        };
        let _ = write!(s, "<tr><td class=l>simulation</td><td class=l>{sim}</td></tr>");
        let _ = write!(
            s,
            "<tr><td class=l>response</td><td class=l>{}</td></tr>",
            escape(&self.response_label())
        );
        if !info.constants.is_empty() {
            let c: Vec<String> = info
                .constants
                .iter()
                .map(|(k, v)| format!("{} = {}", escape(k), short(*v, 6)))
                .collect();
            let _ = write!(
                s,
                "<tr><td class=l>constants</td><td class=l>{}</td></tr>",
                c.join(", ")
            );
        }
        let _ = write!(
            s,
            "<tr><td class=l>design variables</td><td class=l>{}</td></tr>",
            variables_with_bounds(&info.design)
        );
        let _ = write!(
            s,
            "<tr><td class=l>parameters (bounds)</td><td class=l>{}</td></tr>",
            variables_with_bounds(&info.parameters)
        );
        if let Some(runs) = &self.r.solver.runs {
            let _ = write!(
                s,
                "<tr><td class=l>solver runs</td><td class=l>{} planned: {} done, {} failed</td></tr>",
                runs.planned, runs.succeeded, runs.failed
            );
        } else {
            s.push_str("<tr><td class=l>solver runs</td><td class=l>none (closed form)</td></tr>");
        }
        if let Some(t) = self.d.and_then(|d| d.wall_time_s) {
            let _ = write!(s, "<tr><td class=l>wall time</td><td class=l>{}</td></tr>", seconds(t));
        }
        s.push_str("</table>");
        s
    }

    /// The tested designs: role, design-variable values, replicate count, mean and scatter.
    fn tests_table(&self, info: &StudyInfo) -> String {
        let mut s = String::new();
        s.push_str("<h3>Tests</h3><table><tr><th class=l>design</th><th class=l>role</th>");
        for v in &info.design {
            let _ = write!(s, "<th>{}</th>", escape(&v.label()));
        }
        let sd = match self.response_unit() {
            Some(u) => format!("std dev ({u})"),
            None => "std dev".into(),
        };
        let _ = write!(
            s,
            "<th>tests</th><th>mean {}</th><th>{}</th></tr>",
            escape(&self.response_label()),
            escape(&sd)
        );
        for t in &info.tests {
            let _ = write!(
                s,
                "<tr><td class=l>{}</td><td class=l>{}</td>",
                escape(&t.name),
                escape(&t.role)
            );
            for v in &t.values {
                let _ = write!(s, "<td>{}</td>", short(*v, 5));
            }
            let n = t.replicates.len();
            let mean = t.replicates.iter().sum::<f64>() / n.max(1) as f64;
            let sd =
                (n > 1).then(|| (t.replicates.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt());
            let _ = write!(
                s,
                "<td>{n}</td><td>{}</td><td>{}</td></tr>",
                significant(mean, 5),
                sd.map_or("–".into(), |v| significant(v, 3))
            );
        }
        s.push_str("</table>");
        s
    }

    fn runs_summary(&self) -> String {
        match &self.r.solver.runs {
            Some(r) => match r.failed_words() {
                Some(words) => format!("<p class=warn>{}.</p>", escape(&words)),
                None => format!(
                    "<p>{} planned solver runs: {} done, none failed.</p>",
                    r.planned, r.succeeded
                ),
            },
            None => String::new(),
        }
    }

    fn surrogates(&self) -> String {
        let Some(table) = &self.r.solver.surrogates else {
            return note("closed-form simulation: evaluated directly, no response surfaces were fitted");
        };
        let mut s = surrogate_table(table);
        let Some(d) = self.d.filter(|d| !d.solver.surrogates.is_empty()) else {
            return s + &note("the surrogates' samples were not recorded (report-data.json missing)");
        };
        let params: Vec<String> = d.study.parameters.iter().map(|p| p.name.clone()).collect();
        let y_label = self.response_label();
        s.push_str("<div class=grid>");
        for sd in &d.solver.surrogates {
            let err = table.get(&sd.design).and_then(|t| t.check_max_relative_error);
            let title = format!("Response surface, design {} (max check error {})", sd.design, pct(err));
            let plot = self.surrogate_plot(sd, title, &params[0], &y_label);
            let caption = format!(
                "Design {}: {} surrogate fitted to {} sample run(s) (filled), checked at {} run(s) it was not fitted to (hollow).",
                sd.design,
                sd.kind,
                sd.samples.len(),
                sd.checks.len()
            );
            s.push_str(&figure(
                &format!("surrogate-{}", id_part(&sd.design)),
                plot.render(),
                &caption,
            ));
        }
        s + "</div>"
    }

    /// One design's response surface: the surrogate over the one parameter with its sample and
    /// check runs, or (several parameters) surrogate against run at the check points.
    fn surrogate_plot(&self, sd: &SurrogateData, title: String, parameter: &str, y_label: &str) -> XyPlot {
        if let Some((x, y)) = &sd.curve {
            XyPlot {
                title,
                x_label: self.parameter_label(parameter),
                y_label: y_label.to_string(),
                series: vec![
                    Series::new(
                        format!("{} surrogate", sd.kind),
                        0,
                        Style::Line,
                        x.iter().copied().zip(y.iter().copied()).collect(),
                    ),
                    Series::new(
                        "sample runs",
                        plots::BLACK_,
                        Style::Markers,
                        sd.samples.iter().map(|(t, y)| (t[0], *y)).collect(),
                    ),
                    Series::new(
                        "check runs",
                        1,
                        Style::Hollow,
                        sd.checks.iter().map(|(t, y, _)| (t[0], *y)).collect(),
                    ),
                ],
                ..Default::default()
            }
        } else {
            // Several parameters: surrogate against run at the check points (parity).
            let pts: Vec<(f64, f64)> = sd.checks.iter().map(|(_, y, p)| (*y, *p)).collect();
            let (lo, hi) = pts.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.0.min(p.1)), b.max(p.0.max(p.1)))
            });
            let diag = if lo.is_finite() {
                vec![(lo, lo), (hi, hi)]
            } else {
                vec![]
            };
            XyPlot {
                title,
                x_label: format!("{y_label}, solver run"),
                y_label: format!("{y_label}, surrogate"),
                series: vec![
                    Series::new("surrogate = run", plots::GREY, Style::Dashed, diag),
                    Series::new("check runs", 1, Style::Hollow, pts),
                ],
                ..Default::default()
            }
        }
    }

    fn calibration(&self) -> String {
        let mut s = self.parameter_table();
        s.push_str("<div class=grid>");
        s.push_str(&self.posterior_plots());
        s.push_str(&self.prediction_plot());
        s.push_str(&self.split_plot());
        s.push_str("</div>");
        s.push_str(&self.split_table());
        s
    }

    fn parameter_table(&self) -> String {
        let r = self.r;
        let mut s = String::from("<table><tr><th class=l></th>");
        for method in r.calibration.keys() {
            let _ = write!(
                s,
                "<th data-method=\"{}\">{}</th>",
                escape(method),
                escape(&method_name(method))
            );
        }
        s.push_str("</tr>");
        let names: Vec<String> = r
            .calibration
            .values()
            .find(|m| m.error.is_none())
            .map(|m| m.parameters.keys().cloned().collect())
            .unwrap_or_default();
        let row = |label: String, cell: &dyn Fn(&super::results::MethodResult) -> String| {
            let mut line = format!("<tr><td class=l>{label}</td>");
            for m in r.calibration.values() {
                let c = if m.error.is_some() {
                    "failed".to_string()
                } else {
                    cell(m)
                };
                let _ = write!(line, "<td>{c}</td>");
            }
            line + "</tr>"
        };
        for name in &names {
            s.push_str(&row(escape(&self.parameter_label(name)), &|m| {
                m.parameters.get(name).map_or("–".into(), |v| significant(*v, 5))
            }));
            s.push_str(&row(format!("{} 95 % interval", escape(name)), &|m| {
                m.posterior
                    .interval95
                    .as_ref()
                    .and_then(|iv| iv.get(name))
                    .map_or("–".into(), |[lo, hi]| {
                        format!("[{}, {}]", significant(*lo, 4), significant(*hi, 4))
                    })
            }));
            s.push_str(&row(format!("{} posterior median", escape(name)), &|m| {
                m.posterior
                    .median
                    .as_ref()
                    .and_then(|md| md.get(name))
                    .map_or("–".into(), |v| significant(*v, 5))
            }));
        }
        let unit = self.response_unit().map(str::to_string);
        s.push_str(&row("discrepancy".into(), &|m| discrepancy_cell(m, unit.as_deref())));
        s.push_str(&row("calibration (training) error".into(), &|m| pct(m.training_error)));
        s.push_str(&row("validation error".into(), &|m| pct(m.validation_error)));
        s.push_str("</table>");
        s + &method_failures(r)
    }

    /// Paper Fig. 12: the posterior of each parameter with its 95 % interval and every method's estimate.
    fn posterior_plots(&self) -> String {
        let Some(post) = self.d.and_then(|d| d.posterior.as_ref()) else {
            return if self.r.calibration.contains_key("bayesian") {
                note("the Bayesian posterior samples were not recorded")
            } else {
                String::new()
            };
        };
        let bayes = self.r.calibration.get("bayesian");
        let mut s = String::new();
        for (k, name) in post.parameters.iter().enumerate() {
            let band = bayes
                .and_then(|b| b.posterior.interval95.as_ref())
                .and_then(|iv| iv.get(name))
                .map(|[lo, hi]| Band {
                    label: format!("95 % interval [{}, {}]", significant(*lo, 4), significant(*hi, 4)),
                    x0: *lo,
                    x1: *hi,
                });
            let marks: Vec<VLine> = self
                .r
                .calibration
                .iter()
                .filter_map(|(m, res)| {
                    let v = *res.parameters.get(name)?;
                    Some(VLine {
                        label: format!("{} {}", method_name(m), significant(v, 5)),
                        x: v,
                        color: method_color(m),
                    })
                })
                .collect();
            let samples = post.samples.get(k).map(Vec::as_slice).unwrap_or_default();
            let density = match self.parameter(name).and_then(|p| p.unit.as_deref()) {
                Some(u) => format!("posterior density (per {u})"),
                None => "posterior density".into(),
            };
            let title = format!("Posterior of {name}");
            let x_label = self.parameter_label(name);
            let svg = match post.density.get(k) {
                Some((x, y)) => plots::density_curve(&title, &x_label, &density, (x, y), band, &marks),
                None => plots::histogram(&title, &x_label, &density, samples, 30, band, &marks),
            };
            let how = match (post.density.get(k), bayes.and_then(|b| b.posterior.quadrature.as_ref())) {
                (Some(_), Some(q)) => format!(
                    "by quadrature, no sampling ({}; estimated relative error {:.1e} over θ, {:.1e} in the hyperparameters)",
                    escape(&q.rule),
                    q.relative_error,
                    q.inner_relative_error
                ),
                _ => format!("{} thinned samples", samples.len()),
            };
            let convergence = bayes
                .and_then(|b| b.posterior.convergence.as_ref())
                .and_then(|c| c.get(name))
                .map_or(String::new(), |c| {
                    format!(
                        " Chain: split R-hat {}, effective sample size {:.0}: {}.",
                        significant(c.split_rhat, 4),
                        c.ess,
                        if c.converged {
                            "converged (R-hat ≤ 1.01, ESS ≥ 1000)"
                        } else {
                            "NOT converged (limits R-hat ≤ 1.01, ESS ≥ 1000), so the histogram and interval are rough"
                        }
                    )
                });
            let caption = format!(
                "Bayesian posterior of {name} ({how}) with its 95 % interval (shaded) and each method's estimate (dashed) — the paper's Fig. 12.{convergence}"
            );
            s.push_str(&figure(&format!("posterior-{}", id_part(name)), svg, &caption));
        }
        s
    }

    /// Paper Figs 4–6: each method's prediction over the design range against the measurements.
    fn prediction_plot(&self) -> String {
        let first = self.r.calibration.values().find(|m| m.error.is_none());
        let Some(first) = first else {
            return note("no method produced an estimate: nothing to predict");
        };
        let response = self.response_label();
        let design = self.study_info().filter(|s| s.design.len() == 1).map(|s| &s.design[0]);
        if let (Some(var), Some(d)) = (design, self.d.filter(|d| !d.prediction_curves.is_empty())) {
            return self.predictions_over_design(first, var, d);
        }
        self.predictions_against_measured(&response)
    }

    /// Each method's prediction over the one design variable, with the measurements and their
    /// replicate scatter (the paper's Figs 4–6).
    fn predictions_over_design(&self, first: &MethodResult, var: &Variable, d: &ReportData) -> String {
        let response = self.response_label();
        let mut series = Vec::new();
        let measured = |role: Role| -> (Vec<(f64, f64)>, Vec<f64>) {
            first
                .predictions
                .iter()
                .filter(|p| p.role == role)
                .filter_map(|p| {
                    let x = self.design_value(&p.design)?;
                    Some(((x, p.measured), p.measured_std.unwrap_or(0.0)))
                })
                .unzip()
        };
        for c in &d.prediction_curves {
            let style = if c.x.len() < 6 { Style::LineMarkers } else { Style::Line };
            series.push(Series::new(
                method_name(&c.method),
                method_color(&c.method),
                style,
                c.x.iter().copied().zip(c.y.iter().copied()).collect(),
            ));
        }
        for (role, label, style) in [
            (Role::Training, "measured, training", Style::Markers),
            (Role::Validation, "measured, validation", Style::Hollow),
        ] {
            let (pts, err) = measured(role);
            if !pts.is_empty() {
                series.push(Series {
                    label: label.into(),
                    color: plots::BLACK_,
                    style,
                    points: pts,
                    y_err: Some(err),
                });
            }
        }
        let plot = XyPlot {
            title: format!("Calibrated predictions over {}", var.name),
            x_label: var.label(),
            y_label: response.clone(),
            series,
            ..Default::default()
        };
        let caption = "Each method's calibrated prediction over the design range (a solver study's point methods exist only at the \
                       tested designs) against the measurements (filled: training, hollow: validation; bars: ± one replicate std dev) — the paper's Figs 4–6.";
        figure("predictions", plot.render(), caption)
    }

    /// No design curve: predicted against measured at every tested design.
    fn predictions_against_measured(&self, response: &str) -> String {
        let mut series = Vec::new();
        let mut all = Vec::new();
        for (m, res) in &self.r.calibration {
            let pts: Vec<(f64, f64)> = res.predictions.iter().map(|p| (p.measured, p.predicted)).collect();
            all.extend(pts.iter().flat_map(|p| [p.0, p.1]));
            series.push(Series::new(method_name(m), method_color(m), Style::Markers, pts));
        }
        let (lo, hi) = all
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(*v), b.max(*v)));
        if lo.is_finite() {
            series.insert(
                0,
                Series::new(
                    "prediction = measurement",
                    plots::GREY,
                    Style::Dashed,
                    vec![(lo, lo), (hi, hi)],
                ),
            );
        }
        // The noise of each measured mean, as bars about the 1:1 line: a prediction outside its bar
        // misses beyond the noise.
        let noise: Vec<(f64, f64)> = self
            .r
            .diagnosed
            .diagnosis
            .iter()
            .flat_map(|d| d.record.residuals.iter())
            .filter(|r| r.sigma.is_finite() && r.sigma > 0.0 && r.test.count > 1)
            .map(|r| (r.test.measured, r.sigma))
            .collect();
        if !noise.is_empty() {
            series.insert(
                1,
                Series {
                    label: "measured mean ± σ of the mean".into(),
                    color: plots::BLACK_,
                    style: Style::Hollow,
                    points: noise.iter().map(|(m, _)| (*m, *m)).collect(),
                    y_err: Some(noise.iter().map(|(_, s)| *s).collect()),
                },
            );
        }
        let plot = XyPlot {
            title: "Calibrated predictions against measurements".into(),
            x_label: format!("measured {response}"),
            y_label: format!("predicted {response}"),
            series,
            ..Default::default()
        };
        let caption = if noise.is_empty() {
            "Each method's calibrated prediction at every tested design against the measured mean; dashed: 1:1 (no \
             replicates, so no noise bars)."
        } else {
            "Each method's calibrated prediction at every tested design against the measured mean; dashed: 1:1; \
             hollow circles with bars: each measured mean ± σ of the mean (replicate noise), so a prediction outside \
             its bar misses beyond the noise."
        };
        figure("predictions", plot.render(), caption)
    }

    fn design_value(&self, design: &str) -> Option<f64> {
        self.study_info()?
            .tests
            .iter()
            .find(|t| t.name == design)?
            .values
            .first()
            .copied()
    }

    fn identifiability(&self) -> String {
        let id = &self.r.identifiability;
        let weak = id.note.contains("weakly");
        let class = if id.identifiable && !weak { "ok" } else { "warn" };
        let mut s = format!(
            "<p class={class}>{}{}</p>",
            if class == "warn" { "⚠ " } else { "✓ " },
            escape(&id.note)
        );
        if !id.combinations.is_empty() {
            let _ = write!(
                s,
                "<p>Determined combinations: {}</p>",
                id.combinations
                    .iter()
                    .map(|c| format!("<code>{}</code>", escape(c)))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        if !id.singular_values.is_empty() {
            let sv: Vec<String> = id.singular_values.iter().map(|v| significant(*v, 3)).collect();
            let _ = write!(
                s,
                "<p>Singular values of the scaled sensitivity matrix ∂ln y/∂ln θ: {}</p>",
                sv.join(", ")
            );
        }
        s
    }

    /// The Diagnosis section: the verdict block, the residual plots, the candidates, what the
    /// extended model gains and leaves, the candidate table, the next test.
    /// The page's first section: the verdict, the action and the figure that decided it, then the
    /// parameters to use and what limits them (the details are in the diagnosis section).
    fn answer(&self) -> String {
        let Some(dg) = &self.r.diagnosed.diagnosis else {
            return note(&format!(
                "no diagnosis: {}",
                self.r.diagnosed.diagnosis_error.as_deref().unwrap_or("it did not run")
            ));
        };
        use crate::diagnose::verdict::Verdict;
        let class = match dg.finding.verdict {
            Verdict::NoModelError => "clear",
            Verdict::TooFewTests | Verdict::CannotTellApart => "open",
            _ => "flag",
        };
        // Results written before the answer had its key: built from the same values.
        let answer = self.r.answer.clone().or_else(|| crate::report::answer::of(self.r));
        let Some(a) = answer else {
            return String::new();
        };
        let mut s = format!(
            "<div id=answer-verdict class=\"verdict {class}\"><p class=headline><strong>{}</strong></p>\
             <p class=action>{}</p><p id=decided-by>{}</p></div>",
            escape(&a.verdict),
            escape(&a.action),
            escape(&a.decided_by)
        );
        for l in dg
            .finding
            .limits
            .iter()
            .filter(|l| l.starts_with("The calibrated parameters are only as good"))
        {
            let _ = write!(s, "<p class=warn id=parameter-limits>{}</p>", escape(l));
        }
        s
    }

    fn diagnosis(&self) -> String {
        let Some(dg) = &self.r.diagnosed.diagnosis else {
            return note(&format!(
                "no diagnosis: {}",
                self.r.diagnosed.diagnosis_error.as_deref().unwrap_or("it did not run")
            ));
        };
        let mut s = verdict_block(dg);
        if let Some(f) = &dg.checked.discovered {
            s.push_str(&discovered_block(f));
        }
        s.push_str("<div class=grid>");
        s.push_str(&self.residual_plots(dg));
        if dg.explained.candidates.is_empty() {
            s.push_str("</div>");
            s.push_str(&note("no candidate causes were ranked (see the notes below)"));
            s.push_str("<div class=grid>");
        } else {
            s.push_str(&self.candidate_plot(dg));
        }
        if let Some(ext) = dg.extended_model() {
            s.push_str(&before_after(ext));
        }
        s.push_str("</div>");
        match dg.extended_model() {
            Some(ext) => s.push_str(&remaining_block(ext)),
            None => s.push_str(&note(
                "no cause was named, so there is no extended model to compare before/after",
            )),
        }
        s.push_str(&self.stroke(dg));
        s.push_str(&solver_loop::section(dg, self.d));
        if !dg.explained.candidates.is_empty() {
            s.push_str(&candidate_table(dg));
        }
        s.push_str(&self.next_test(dg));
        for n in &dg.record.notes {
            s.push_str(&note(n));
        }
        s
    }

    /// Residuals of the uncorrected model against each design variable, with the trend test's words.
    fn residual_plots(&self, dg: &crate::diagnose::Diagnosis) -> String {
        let response = self.response_label();
        let names: Vec<String> = dg
            .record
            .residuals
            .first()
            .map(|r| r.values.keys().cloned().collect())
            .unwrap_or_default();
        let mut s = String::new();
        for name in &names {
            let label = self
                .study_info()
                .and_then(|i| i.design.iter().find(|v| &v.name == name))
                .map_or(name.clone(), Variable::label);
            let mut series = Vec::new();
            for (role, lab, style) in [
                (crate::diagnose::Role::Training, "training", Style::Markers),
                (crate::diagnose::Role::Validation, "validation", Style::Hollow),
            ] {
                let rs: Vec<_> = dg.record.residuals.iter().filter(|r| r.role == role).collect();
                if rs.is_empty() {
                    continue;
                }
                series.push(Series {
                    label: lab.into(),
                    color: if role == crate::diagnose::Role::Training { 0 } else { 1 },
                    style,
                    points: rs.iter().map(|r| (r.values[name], r.residual)).collect(),
                    y_err: Some(rs.iter().map(|r| r.sigma).collect()),
                });
            }
            let plot = XyPlot {
                title: format!("Residuals against {name}"),
                x_label: label,
                y_label: format!("measured − predicted {response}"),
                series,
                hline: Some(0.0),
                ..Default::default()
            };
            let trend = dg
                .record
                .structure
                .iter()
                .find(|t| &t.against == name)
                .map_or(String::new(), trend_words);
            let caption = format!(
                "Residuals of the uncorrected model (calibrated by weighted least squares on the training designs); bars: ± σ of the mean measurement ({} noise).{trend}",
                noise_kind(&dg.record.noise.kind)
            );
            s.push_str(&figure(
                &format!("residuals-{}", id_part(name)),
                plot.render(),
                &caption,
            ));
        }
        s
    }

    /// The recommended next test, with the design's units.
    fn next_test(&self, dg: &crate::diagnose::Diagnosis) -> String {
        let mut s = String::from("<h3>Recommended next test</h3>");
        let Some(nt) = &dg.explained.next_test else {
            return s + &note("no next test recommended");
        };
        let at: Vec<String> = nt
            .choice
            .design
            .iter()
            .map(|(k, v)| {
                let unit = self
                    .study_info()
                    .and_then(|i| i.design.iter().find(|d| &d.name == k))
                    .and_then(|d| d.unit.clone());
                format!("{} = {}", escape(k), with_unit(*v, unit.as_deref(), 3))
            })
            .collect();
        let _ = write!(
            s,
            "<p id=next-test><strong>Test at {}.</strong> {}</p>",
            at.join(", "),
            escape(&nt.choice.why)
        );
        s
    }

    fn candidate_plot(&self, dg: &crate::diagnose::Diagnosis) -> String {
        let mut s = String::new();
        let mut categories: Vec<String> = dg.explained.candidates.iter().map(|c| c.shape.name.clone()).collect();
        let mut weights: Vec<Option<f64>> = dg.explained.candidates.iter().map(|c| Some(c.scores.weight)).collect();
        if let Some(w) = dg.record.uncorrected.weight {
            categories.push("uncorrected model".into());
            weights.push(Some(w));
        }
        let plot = BarPlot {
            title: "Candidate causes, ranked".into(),
            value_label: "weight (probability-like, sums to 1)".into(),
            categories,
            groups: vec![(String::new(), 0, weights)],
            percent: false,
            headings: vec![],
        };
        s.push_str(&figure(
            "candidates",
            plot.render(),
            "Weights exp(−Δscore/2) of each candidate and of the uncorrected model, score = (AICc + leave-one-design-out deviance)/2; best first.",
        ));
        s
    }

    fn runs(&self) -> String {
        sequence::section(self.r) + &self.run_table()
    }

    fn run_table(&self) -> String {
        let rows = self.d.map(|d| d.solver.runs.as_slice()).unwrap_or_default();
        if rows.is_empty() {
            return if self.r.solver.runs.is_some() {
                self.runs_summary() + &note("the run table was not recorded (report-data.json missing)")
            } else {
                note("closed-form simulation: no solver runs")
            };
        }
        let params: Vec<String> = self
            .study_info()
            .map(|i| i.parameters.iter().map(|p| p.label()).collect())
            .unwrap_or_default();
        let order = run_order(rows);
        let mut s = self.runs_sentence(rows);
        s.push_str("<table><tr><th class=l>key</th><th class=l>design</th><th class=l>role</th>");
        for p in &params {
            let _ = write!(s, "<th>{}</th>", escape(p));
        }
        let _ = write!(
            s,
            "<th class=l>status</th><th>attempts</th><th>time</th><th>{}</th><th class=l>outcome</th></tr>",
            escape(&self.response_label())
        );
        for &i in &order {
            write_run_row(&mut s, &rows[i]);
        }
        s + "</table>"
    }

    /// The paragraph above the run table: how many runs, how many failed and how many are
    /// suspect (and whether the surrogates used them), and the solver time in all or where the
    /// runs were replayed from.
    fn runs_sentence(&self, rows: &[RunRow]) -> String {
        let failed = rows
            .iter()
            .filter(|r| r.ended.class.as_deref().is_some_and(|c| c != "success"))
            .count();
        let suspect = rows.iter().filter(|r| !r.flags.is_empty()).count();
        let total: f64 = rows.iter().filter_map(|r| r.ended.seconds).sum();
        let time = match self.r.solver.runs.as_ref().and_then(|r| r.replayed_from.as_deref()) {
            Some(dir) => format!(
                "replayed from the recordings in {} (times are the replay's, not the solver's)",
                escape(dir)
            ),
            None => format!("{} of solver time in all", seconds(total)),
        };
        let suspects = match (
            suspect,
            self.r.solver.runs.as_ref().and_then(|r| r.suspect_runs.first()),
        ) {
            (0, _) => String::new(),
            (n, Some(first)) if first.used => {
                format!(", {n} suspect (breaking a quality gate; used by the surrogates)")
            }
            (n, _) => format!(", {n} suspect (breaking a quality gate; left out of the surrogates)"),
        };
        format!("<p>{} runs, {failed} failed{suspects}; {time}.</p>", rows.len())
    }
}

/// The order the run table lists `rows` in, as indices: failures first, then runs without a
/// record, then suspect runs, then sound ones, each group in plan order.
fn run_order(rows: &[RunRow]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..rows.len()).collect();
    order.sort_by_key(|&i| match rows[i].ended.class.as_deref() {
        Some("success") if rows[i].flags.is_empty() => 3,
        Some("success") => 2,
        Some(_) => 0,
        None => 1,
    });
    order
}

/// Appends the run table's row for `r`: key, design, role, parameters, status, attempts, time,
/// response and outcome (a successful run's quality flags and warnings, a failure's details).
fn write_run_row(s: &mut String, r: &RunRow) {
    let ok = r.ended.class.as_deref() == Some("success");
    let _ = write!(
        s,
        "<tr{}><td class=l><code title=\"{}\">{}</code></td><td class=l>{}</td><td class=l>{}</td>",
        if ok { "" } else { " class=failed" },
        escape(&r.key),
        escape(&r.key[..r.key.len().min(12)]),
        escape(&r.design),
        escape(&r.role)
    );
    for v in &r.theta {
        let _ = write!(s, "<td>{}</td>", significant(*v, 5));
    }
    let _ = write!(
        s,
        "<td class=l>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=l>{}</td></tr>",
        escape(match r.ended.class.as_deref() {
            Some("success") if !r.flags.is_empty() => "suspect",
            other => other.unwrap_or("no record"),
        }),
        r.ended.attempts,
        r.ended.seconds.map_or("–".into(), seconds),
        r.ended.response.map_or("–".into(), |v| significant(v, 5)),
        if ok {
            escape(
                &r.flags
                    .iter()
                    .chain(&r.warnings)
                    .cloned()
                    .collect::<Vec<_>>()
                    .join("; "),
            )
        } else {
            escape(&r.ended.outcome)
        }
    );
}

fn noise_kind(kind: &crate::diagnose::NoiseKind) -> &'static str {
    match kind {
        crate::diagnose::NoiseKind::Absolute => "absolute",
        crate::diagnose::NoiseKind::Relative => "relative",
        crate::diagnose::NoiseKind::Combined => "absolute and relative",
        crate::diagnose::NoiseKind::FromResiduals => "estimated from the residuals",
        crate::diagnose::NoiseKind::Stated => "stated by the study",
    }
}

/// A method's discrepancy as a table cell: none, a constant, or a GP's mean and std dev.
fn discrepancy_cell(m: &MethodResult, unit: Option<&str>) -> String {
    match &m.discrepancy {
        None => "none".into(),
        Some(d) => {
            if let Some(c) = d.get("constant").and_then(|c| c.as_f64()) {
                format!("constant {}", with_unit(c, unit, 4))
            } else if let Some(gp) = d.get("gaussian_process") {
                let f = |k: &str| {
                    gp.get(k)
                        .and_then(|v| v.as_f64())
                        .map_or("–".into(), |v| with_unit(v, unit, 3))
                };
                format!("GP: mean {}, std dev {}", f("mean"), f("std_dev"))
            } else {
                escape(&d.to_string())
            }
        }
    }
}

/// A warning per method that failed, with why.
fn method_failures(r: &Results) -> String {
    let mut s = String::new();
    for (method, m) in &r.calibration {
        if let Some(e) = &m.error {
            let _ = write!(
                s,
                "<p class=warn>{} failed: {}</p>",
                escape(&method_name(method)),
                escape(e)
            );
        }
    }
    s
}

/// The surrogates' table: kind, sample and check runs, check errors per design.
fn surrogate_table(table: &IndexMap<String, SurrogateResult>) -> String {
    let mut s = String::from(
        "<table><tr><th class=l>design</th><th class=l>surrogate</th><th>sample runs</th><th>check runs</th>\
         <th>max check error</th><th>mean check error</th></tr>",
    );
    for (design, sr) in table {
        let _ = write!(
            s,
            "<tr><td class=l>{}</td><td class=l>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            escape(design),
            escape(&sr.kind),
            sr.samples,
            sr.check_runs,
            pct(sr.check_max_relative_error),
            pct(sr.check_mean_relative_error)
        );
    }
    s.push_str("</table>");
    s
}

/// Variables as `name ∈ [min, max] unit`, one per line.
fn variables_with_bounds(vars: &[Variable]) -> String {
    vars.iter()
        .map(|v| {
            let range = match (v.min, v.max) {
                (Some(lo), Some(hi)) => format!(" ∈ [{}, {}]", short(lo, 6), short(hi, 6)),
                _ => String::new(),
            };
            format!(
                "{}{range}{}",
                escape(&v.name),
                v.unit.as_ref().map_or(String::new(), |u| format!(" {}", escape(u)))
            )
        })
        .collect::<Vec<_>>()
        .join("<br>")
}

fn list(names: &[String]) -> String {
    if names.is_empty() {
        "none".into()
    } else {
        names.join(", ")
    }
}

/// The trend test's words for a residual plot: the same test and α as the decision.
fn trend_words(t: &crate::diagnose::Trend) -> String {
    format!(
        " Rank correlation {} (p = {}; linear trend p = {}): {} at α = {}.",
        significant(t.rank_correlation, 2),
        significant(t.rank_p_value, 2),
        significant(t.slope_p_value, 2),
        if t.significant {
            "a significant trend"
        } else {
            "no significant trend"
        },
        DIAGNOSIS_ALPHA
    )
}

/// Validation error before and after the extension.
fn before_after(ext: &crate::diagnose::Extended) -> String {
    let plot = BarPlot {
        title: format!("Validation error before and after adding {}", ext.model.cause),
        value_label: format!("mean |relative error| (%), {}", ext.gains.measured_on),
        categories: vec!["uncorrected".into(), format!("with {}", ext.model.cause)],
        groups: vec![(
            String::new(),
            0,
            vec![
                Some(ext.gains.validation_error_before),
                Some(ext.gains.validation_error_after),
            ],
        )],
        percent: true,
        headings: vec![],
    };
    let loo = ext.gains.gain_loo.map_or(String::new(), |g| {
        format!("; leave-one-design-out gain {:.0} %", 100.0 * g)
    });
    let caption = format!(
        "Validation error of the uncorrected model and of the model extended with {} (term {}), measured on {}; gain {}{loo}.",
        ext.model.cause,
        ext.model.term,
        ext.gains.measured_on,
        pct(ext.gains.gain)
    );
    figure("before-after", plot.render(), &caption)
}

/// The significance level of the diagnosis's decisions (its `Settings::default().alpha`): captions
/// use the same α as the verdict.
const DIAGNOSIS_ALPHA: f64 = 0.01;

/// The verdict first, then the action, the evidence one fact per line, and the limits.
fn verdict_block(dg: &crate::diagnose::Diagnosis) -> String {
    use crate::diagnose::verdict::Verdict;
    let class = match dg.finding.verdict {
        Verdict::NoModelError => "clear",
        Verdict::TooFewTests => "open",
        _ => "flag",
    };
    let mut s = format!(
        "<div id=verdict class=\"verdict {class}\" data-verdict=\"{}\"><p class=headline><strong>{}</strong></p><p class=action>{}</p></div>",
        serde_json::to_value(dg.finding.verdict)
            .ok()
            .and_then(|v| v.as_str().map(str::to_string))
            .unwrap_or_default(),
        escape(&dg.finding.headline),
        escape(&dg.finding.action)
    );
    if !dg.finding.evidence.is_empty() {
        s.push_str("<h3>Evidence</h3><ul id=evidence>");
        for e in &dg.finding.evidence {
            let _ = write!(s, "<li>{}</li>", escape(e));
        }
        s.push_str("</ul>");
    }
    if !dg.finding.limits.is_empty() {
        s.push_str("<h3>Limits</h3><ul id=limits class=note>");
        for l in &dg.finding.limits {
            let _ = write!(s, "<li>{}</li>", escape(l));
        }
        s.push_str("</ul>");
    }
    s
}

/// The library search, after the verdict: what it found (or that nothing in the library explains
/// the misfit), marked as found by search, not listed, with the hypothesis line to paste.
fn discovered_block(f: &crate::diagnose::discover::Discovered) -> String {
    use crate::diagnose::discover::Outcome;
    let mut s = String::from("<div id=discovered class=\"verdict found\"><h3>Found by search, not listed</h3>");
    match (f.found.outcome, &f.found.term) {
        (Outcome::Found, Some(term)) => s.push_str(&found_table(f, term)),
        _ => {
            let _ = write!(
                s,
                "<p class=headline><strong>No shape in the library explains the misfit</strong> ({} models searched, \
                 α/M = {}).</p>",
                f.search.library.models,
                significant(f.test.threshold, 2)
            );
        }
    }
    s.push_str(&closest_table(f));
    let _ = write!(
        s,
        "<p class=note>Library: {} distinct shapes (exponents {}); {}.</p>",
        f.search.library.size,
        escape(&f.search.library.exponents.join(", ")),
        escape(&f.test.correction)
    );
    if !f.search.library.dropped.is_empty() {
        s.push_str("<ul id=discovered-dropped class=note>");
        for d in &f.search.library.dropped {
            let _ = write!(
                s,
                "<li><code>{}</code> left out: {}</li>",
                escape(&d.term),
                escape(&d.reason)
            );
        }
        s.push_str("</ul>");
    }
    s.push_str("</div>");
    s
}

/// The found term: its shape, coefficient, parameters, gains and test, and how to list it.
fn found_table(f: &crate::diagnose::discover::Discovered, term: &str) -> String {
    let mut s = format!(
        "<p class=headline><strong><code>{}</code></strong> added to the {} model</p>",
        escape(term),
        escape(&f.test.base)
    );
    let params: Vec<String> = f
        .found
        .parameters
        .iter()
        .map(|(n, v)| format!("{} = {}", escape(n), significant(*v, 6)))
        .collect();
    let interval = f.found.interval.map_or("-".to_string(), |[a, b]| {
        format!("{} to {}", significant(a, 4), significant(b, 4))
    });
    let coefficient = f.found.coefficient.map_or("-".into(), |c| significant(c, 4));
    let rows = [
        ("shape", escape(f.named.shape.as_deref().unwrap_or("-"))),
        ("coefficient (95 % interval)", format!("{coefficient} ({interval})")),
        ("parameters with the term", params.join(", ")),
        (
            "validation error before → after (gain)",
            format!(
                "{} → {} ({})",
                pct(f.checks.validation_error_before),
                pct(f.checks.validation_error_after),
                pct(f.found.gain)
            ),
        ),
        (
            "leave-one-design-out error before → after (gain)",
            format!(
                "{} → {} ({})",
                pct(f.checks.loo_error_before),
                pct(f.checks.loo_error_after),
                pct(f.checks.gain_loo)
            ),
        ),
        (
            "test against the search's size",
            format!(
                "p = {} &lt; α/M = {} ({} models)",
                f.test.p_value.map_or("-".into(), |p| significant(p, 2)),
                significant(f.test.threshold, 2),
                f.search.library.models
            ),
        ),
    ];
    s.push_str("<table id=discovered-table>");
    for (k, v) in rows
        .iter()
        .chain(f.named.reading.as_ref().map(|r| ("reading", escape(r))).iter())
    {
        let _ = write!(s, "<tr><th class=l>{k}</th><td class=l>{v}</td></tr>");
    }
    s.push_str("</table>");
    if let Some(line) = &f.named.hypothesis_line {
        let _ = write!(
            s,
            "<p>To test it as a listed cause, add under <code>diagnosis.hypotheses</code>:</p><pre id=hypothesis-line>{}</pre>",
            escape(line)
        );
    }
    s
}

/// The models that came closest, and why each falls short.
fn closest_table(f: &crate::diagnose::discover::Discovered) -> String {
    if f.search.closest.is_empty() {
        return String::new();
    }
    let mut s = String::from(
        "<table id=discovered-closest><tr><th class=l>closest</th><th>p</th><th>leave-one-out error</th><th class=l>why not</th></tr>",
    );
    for c in &f.search.closest {
        let _ = write!(
            s,
            "<tr><td class=l><code>{}</code></td><td>{}</td><td>{}</td><td class=l>{}</td></tr>",
            escape(&c.term),
            c.p_value.map_or("-".into(), |p| significant(p, 2)),
            pct(Some(c.loo_error)),
            escape(&c.why)
        );
    }
    s.push_str("</table>");
    s
}

/// The extended model's standardised residuals at every design: what the cause leaves unexplained.
fn remaining_block(ext: &crate::diagnose::Extended) -> String {
    if ext.check.residual_z.is_empty() {
        return String::new();
    }
    let plot = BarPlot {
        title: format!("What remains after adding {}", ext.model.cause),
        value_label: "residual of the extended model / σ".into(),
        categories: ext.check.residual_z.keys().cloned().collect(),
        groups: vec![(
            String::new(),
            0,
            ext.check.residual_z.values().map(|z| Some(*z)).collect(),
        )],
        percent: false,
        headings: vec![],
    };
    let verdict = match &ext.check.lack_of_fit {
        Some(l) if l.rejects() => format!("beyond the noise: {}", crate::diagnose::text::lack_of_fit(l)),
        Some(l) => format!("within the noise both ways: {}", crate::diagnose::text::lack_of_fit(l)),
        None => "no replicates, so no test against the noise".into(),
    };
    let caption = format!(
        "Residuals of the model extended with {} in units of σ (training: of the mean; validation: with the \
         prediction's uncertainty). Beyond ±2 the design is still missed. Lack of fit: {verdict}.",
        ext.model.cause
    );
    figure("remaining", plot.render(), &caption)
}

/// Every candidate with the figures the verdict used.
fn candidate_table(dg: &crate::diagnose::Diagnosis) -> String {
    let mut s = String::from(
        "<h3>Candidates</h3><table id=candidate-table><tr><th>rank</th><th class=l>candidate</th><th class=l>term</th>\
         <th>weight</th><th>amplitude γ</th><th>95 % interval of γ</th><th>p-value</th><th>variance inflation</th>\
         <th class=l>explains misfit (p &lt; α/K)</th><th class=l>cannot be told from</th></tr>",
    );
    let opt = |v: Option<f64>| v.map_or("-".to_string(), |v| significant(v, 3));
    for (i, c) in dg.explained.candidates.iter().enumerate() {
        let ci = c.checks.separability.amplitude_ci95.map_or("-".to_string(), |[a, b]| {
            format!("{} to {}", significant(a, 3), significant(b, 3))
        });
        let vif = match (
            c.checks.separability.variance_inflation,
            c.checks.separability.amplitude_se,
        ) {
            (Some(v), _) => significant(v, 3),
            (None, None) if !c.checks.confounded_with.is_empty() => "∞".into(),
            _ => "-".into(),
        };
        let _ = write!(
            s,
            "<tr><td>{}</td><td class=l>{}</td><td class=l><code>{}</code></td><td>{}</td><td>{}</td><td>{ci}</td>\
             <td>{}</td><td>{vif}</td><td class=l>{}</td><td class=l>{}</td></tr>",
            i + 1,
            escape(&c.shape.name),
            escape(&c.shape.term),
            significant(c.scores.weight, 3),
            significant(c.fit.amplitude, 3),
            opt(c.fit.p_value),
            if c.fit.explains_misfit { "yes" } else { "no" },
            escape(&c.checks.confounded_with.join(", "))
        );
    }
    s.push_str("</table>");
    if !dg.explained.rivals.is_empty() {
        s.push_str(
            "<table id=rivals><tr><th class=l>rival of the leader</th><th>p (leader added to rival)</th>\
             <th>p (rival added to leader)</th><th class=l>rejected</th><th class=l>by</th></tr>",
        );
        for r in &dg.explained.rivals {
            let _ = write!(
                s,
                "<tr><td class=l>{}</td><td>{}</td><td>{}</td><td class=l>{}</td><td class=l>{}</td></tr>",
                escape(&r.rival),
                opt(r.p_leader_given_rival),
                opt(r.p_rival_given_leader),
                if r.beaten { "yes" } else { "no" },
                escape(&r.by)
            );
        }
        s.push_str("</table>");
    }
    s
}
/// Kept under its old name for the page's sections; the plots use it too (see [`super::markup`]).
pub use super::markup::escape;
