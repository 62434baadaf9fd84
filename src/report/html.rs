//! `report.html`: one self-contained page (no external assets) rendered from [`Results`] alone, so
//! `lab report` can rewrite it from what is recorded. Tables only for now; plots come later.

use std::fmt::Write;

use super::results::{Results, Role};
use super::summary::significant;

pub fn render(results: &Results) -> String {
    let mut body = String::new();
    let _ = write!(body, "<h1>Calibration report — {}</h1>", escape(&results.study));
    let _ = write!(body, "<h2>Calibrated parameters</h2><table><tr><th>method</th><th>parameters</th>\
        <th>95 % interval</th><th>discrepancy</th><th>training error</th><th>validation error</th></tr>");
    for (method, r) in &results.calibration {
        if let Some(e) = &r.error {
            let _ = write!(body, "<tr><td>{}</td><td colspan=5>failed: {}</td></tr>", escape(method), escape(e));
            continue;
        }
        let params: Vec<String> =
            r.parameters.iter().map(|(n, v)| format!("{} = {}", escape(n), significant(*v, 6))).collect();
        let interval = r.interval95.as_ref().map_or(String::new(), |iv| {
            iv.iter()
                .map(|(n, [lo, hi])| format!("{}: [{}, {}]", escape(n), significant(*lo, 5), significant(*hi, 5)))
                .collect::<Vec<_>>()
                .join("<br>")
        });
        let discrepancy = r.discrepancy.as_ref().map_or("none".to_string(), |d| escape(&d.to_string()));
        let _ = write!(
            body,
            "<tr><td>{}</td><td>{}</td><td>{interval}</td><td>{discrepancy}</td><td>{}</td><td>{}</td></tr>",
            escape(method),
            params.join("<br>"),
            percent(r.training_error),
            percent(r.validation_error)
        );
    }
    body.push_str("</table><h2>Predictions</h2><table><tr><th>design</th><th>role</th><th>measured</th>");
    for method in results.calibration.keys() {
        let _ = write!(body, "<th>{}</th>", escape(method));
    }
    body.push_str("</tr>");
    if let Some(first) = results.calibration.values().find(|m| m.error.is_none()) {
        for (i, p) in first.predictions.iter().enumerate() {
            let role = if p.role == Role::Training { "training" } else { "validation" };
            let _ = write!(body, "<tr><td>{}</td><td>{role}</td><td>{}</td>", escape(&p.design), significant(p.measured, 6));
            for r in results.calibration.values() {
                let cell = r.predictions.get(i).map_or("–".into(), |q| {
                    format!("{} ({:+.2} %)", significant(q.predicted, 6), 100.0 * q.relative_error)
                });
                let _ = write!(body, "<td>{cell}</td>");
            }
            body.push_str("</tr>");
        }
    }
    body.push_str("</table>");
    let id = &results.identifiability;
    let class = if id.identifiable { "ok" } else { "warn" };
    let _ = write!(body, "<h2>Identifiability</h2><p class={class}>{}</p>", escape(&id.note));
    format!(
        "<!DOCTYPE html><html lang=en><head><meta charset=utf-8><title>lab — {}</title><style>{STYLE}</style></head>\
         <body>{body}</body></html>\n",
        escape(&results.study)
    )
}

const STYLE: &str = "body{font-family:system-ui,sans-serif;max-width:70em;margin:2em auto;color:#222}\
table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:.3em .6em;text-align:right}\
th{background:#f3f3f3}.warn{color:#a40}.ok{color:#264}";

fn percent(x: Option<f64>) -> String {
    x.map_or("–".to_string(), |v| format!("{:.2} %", 100.0 * v))
}

pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}
