//! The paper's Fig. 13: each method's calibration (training) and validation error for every
//! train/validate split — the study's own, then those of `results.json` `splits` (calibrated from
//! the same simulations) — as one bar plot with a heading row per split, and a table with each
//! split's estimates (and their error against the study's `truth`, when it states one).

use std::fmt::Write;

use indexmap::IndexMap;

use super::{Page, escape, figure, list, method_name, pct};
use crate::report::plots::BarPlot;
use crate::report::results::Role;
use crate::report::summary::significant;

/// One split as shown.
struct SplitView {
    training: Vec<String>,
    validation: Vec<String>,
    methods: Vec<MethodView>,
}

struct MethodView {
    method: String,
    training_error: Option<f64>,
    validation_error: Option<f64>,
    parameters: IndexMap<String, f64>,
    parameter_error: Option<IndexMap<String, f64>>,
    error: Option<String>,
}

impl SplitView {
    fn same_designs(&self, training: &[String], validation: &[String]) -> bool {
        let sorted = |v: &[String]| {
            let mut v = v.to_vec();
            v.sort();
            v
        };
        sorted(&self.training) == sorted(training) && sorted(&self.validation) == sorted(validation)
    }

    fn title(&self) -> String {
        format!("train {} → validate {}", list(&self.training), list(&self.validation))
    }
}

impl Page<'_> {
    /// The study's own split first, then every other recorded split, each once.
    fn splits(&self) -> Vec<SplitView> {
        let r = self.r;
        let own = SplitView {
            training: self.split_names(Role::Training),
            validation: self.split_names(Role::Validation),
            methods: r
                .calibration
                .iter()
                .map(|(k, m)| MethodView {
                    method: k.clone(),
                    training_error: m.training_error,
                    validation_error: m.validation_error,
                    parameters: m.parameters.clone(),
                    parameter_error: None,
                    error: m.error.clone(),
                })
                .collect(),
        };
        let mut out = vec![own];
        let recorded: Vec<SplitView> = match &r.stated.splits {
            Some(splits) => splits
                .iter()
                .map(|sp| SplitView {
                    training: sp.training.clone(),
                    validation: sp.validation.clone(),
                    methods: sp
                        .methods
                        .iter()
                        .map(|(k, m)| MethodView {
                            method: k.clone(),
                            training_error: m.training_error,
                            validation_error: m.validation_error,
                            parameters: m.parameters.clone(),
                            parameter_error: m.parameter_error.clone(),
                            error: m.error.clone(),
                        })
                        .collect(),
                })
                .collect(),
            // An older report-data.json may hold extra splits' errors.
            None => self
                .d
                .map(|d| d.splits.as_slice())
                .unwrap_or_default()
                .iter()
                .map(|sp| SplitView {
                    training: sp.training.clone(),
                    validation: sp.validation.clone(),
                    methods: sp
                        .methods
                        .iter()
                        .map(|(k, [c, v])| MethodView {
                            method: k.clone(),
                            training_error: *c,
                            validation_error: *v,
                            parameters: IndexMap::new(),
                            parameter_error: None,
                            error: None,
                        })
                        .collect(),
                })
                .collect(),
        };
        for sp in recorded {
            match out.iter_mut().find(|o| o.same_designs(&sp.training, &sp.validation)) {
                // The study's own split again: keep its numbers, take the error against the truth.
                Some(o) => {
                    for m in &mut o.methods {
                        if let Some(e) = sp.methods.iter().find(|x| x.method == m.method) {
                            m.parameter_error = m.parameter_error.take().or(e.parameter_error.clone());
                        }
                    }
                }
                None => out.push(sp),
            }
        }
        out
    }

    fn split_names(&self, role: Role) -> Vec<String> {
        self.r
            .calibration
            .values()
            .find(|m| m.error.is_none())
            .map(|m| {
                m.predictions
                    .iter()
                    .filter(|p| p.role == role)
                    .map(|p| p.design.clone())
                    .collect()
            })
            .unwrap_or_default()
    }

    /// Paper Fig. 13: one heading row per split, one row per method under it.
    pub(super) fn split_plot(&self) -> String {
        let splits = self.splits();
        let many = splits.len() > 1;
        let mut categories = Vec::new();
        let mut headings = Vec::new();
        let (mut cal, mut val) = (Vec::new(), Vec::new());
        for (i, sp) in splits.iter().enumerate() {
            if many {
                headings.push(categories.len());
                categories.push(format!("{}. {}", i + 1, sp.title()));
                cal.push(None);
                val.push(None);
            }
            for m in sp.methods.iter().filter(|m| m.error.is_none()) {
                categories.push(method_name(&m.method));
                cal.push(m.training_error);
                val.push(m.validation_error);
            }
        }
        let plot = BarPlot {
            title: if many {
                "Calibration and validation errors per split".into()
            } else {
                "Calibration and validation errors".into()
            },
            value_label: "mean |relative error| (%)".into(),
            categories,
            groups: vec![("calibration (training)".into(), 0, cal), ("validation".into(), 1, val)],
            percent: true,
            headings,
        };
        let caption = if many {
            format!(
                "Mean |relative error| of each method on the designs it was calibrated to and on the held-out designs, \
                 for each of the {} train/validate splits (each calibrated from the same simulations) — the paper's Fig. 13.",
                splits.len()
            )
        } else {
            format!(
                "Mean |relative error| of each method on the designs it was calibrated to and on the held-out designs — \
                 the paper's Fig. 13; {}. The study names no further splits (`splits:`).",
                splits[0].title()
            )
        };
        figure("splits", plot.render(), &caption)
    }

    /// Each split's estimates and errors; only when there are several splits (the parameter table
    /// above already holds the study's own).
    pub(super) fn split_table(&self) -> String {
        let splits = self.splits();
        if splits.len() < 2 {
            return String::new();
        }
        let names: Vec<String> = splits
            .iter()
            .flat_map(|s| s.methods.iter().flat_map(|m| m.parameters.keys().cloned()))
            .fold(Vec::new(), |mut v, n| {
                if !v.contains(&n) {
                    v.push(n);
                }
                v
            });
        let truth = splits
            .iter()
            .any(|s| s.methods.iter().any(|m| m.parameter_error.is_some()));
        let mut s = String::from(
            "<h3>Train/validate splits</h3><table id=split-table><tr><th class=l>split</th><th class=l>method</th>",
        );
        for n in &names {
            let _ = write!(s, "<th>{}</th>", escape(&self.parameter_label(n)));
            if truth {
                let _ = write!(s, "<th>{} vs truth</th>", escape(n));
            }
        }
        s.push_str("<th>calibration error</th><th>validation error</th></tr>");
        for (i, sp) in splits.iter().enumerate() {
            for (j, m) in sp.methods.iter().enumerate() {
                let split = if j == 0 {
                    format!(
                        "<td class=l rowspan={}>{}. {}</td>",
                        sp.methods.len(),
                        i + 1,
                        escape(&sp.title())
                    )
                } else {
                    String::new()
                };
                let _ = write!(s, "<tr>{split}<td class=l>{}</td>", escape(&method_name(&m.method)));
                if let Some(e) = &m.error {
                    let span = names.len() * (1 + usize::from(truth)) + 2;
                    let _ = write!(s, "<td class=l colspan={span}>failed: {}</td></tr>", escape(e));
                    continue;
                }
                for n in &names {
                    let v = m.parameters.get(n).map_or("–".into(), |v| significant(*v, 4));
                    let _ = write!(s, "<td>{v}</td>");
                    if truth {
                        let e = m.parameter_error.as_ref().and_then(|e| e.get(n)).copied();
                        let _ = write!(s, "<td>{}</td>", signed_pct(e));
                    }
                }
                let _ = write!(
                    s,
                    "<td>{}</td><td>{}</td></tr>",
                    pct(m.training_error),
                    pct(m.validation_error)
                );
            }
        }
        s + "</table>"
    }
}

/// `+7.7 %`: a signed relative difference.
fn signed_pct(v: Option<f64>) -> String {
    v.map_or("–".into(), |v| format!("{:+.1} %", 100.0 * v))
}

#[cfg(test)]
mod tests {
    use super::super::Page;
    use crate::report::Results;

    /// The study's own split (C6T5, C3T8 → C3T7) and, in `splits`, the same split again plus one more.
    fn results() -> Results {
        let method = |training: f64, validation: f64| {
            serde_json::json!({
                "parameters": {"sigma_y": 199.23}, "discrepancy": null, "predictions": [
                    {"design": "C6T5", "role": "training", "measured": 2.79, "predicted": 2.87,
                     "relative_error": 0.028, "replicates": 3, "measured_std": 0.07},
                    {"design": "C3T8", "role": "training", "measured": 20.3, "predicted": 20.29,
                     "relative_error": -0.0005, "replicates": 3, "measured_std": 0.27},
                    {"design": "C3T7", "role": "validation", "measured": 16.12, "predicted": 16.24,
                     "relative_error": 0.0074, "replicates": 3, "measured_std": 0.07}],
                "training_error": training, "validation_error": validation
            })
        };
        let split = |training: &[&str], validation: &[&str], sigma: f64, v: f64| {
            serde_json::json!({"training": training, "validation": validation, "methods": {
                "least_squares": {"parameters": {"sigma_y": sigma}, "parameter_error": {"sigma_y": (sigma - 185.0) / 185.0},
                                  "training_error": 0.01, "validation_error": v}}})
        };
        serde_json::from_value(serde_json::json!({
            "study": "honeycomb",
            "calibration": {"least_squares": method(0.014, 0.0074)},
            "identifiability": {"identifiable": true, "note": "", "combinations": [], "singular_values": []},
            "diagnosis": null,
            "splits": [split(&["C3T8", "C6T5"], &["C3T7"], 199.23, 0.0074),
                       split(&["C3T7", "C3T8"], &["C6T5"], 198.7, 0.0249)]
        }))
        .unwrap()
    }

    #[test]
    fn every_split_once_with_its_errors_and_its_estimate_against_the_truth() {
        let r = results();
        let page = Page { r: &r, d: None };
        let plot = page.split_plot();
        assert!(plot.starts_with("<figure class=plot id=splits><svg"), "{plot}");
        assert!(plot.contains("1. train C6T5, C3T8 → validate C3T7"));
        assert!(plot.contains("2. train C3T7, C3T8 → validate C6T5"));
        assert!(
            !plot.contains("3. train"),
            "the own split, listed again in a different order, is shown once"
        );
        // Bar labels: two significant figures.
        assert!(plot.contains("\n1.4 %\n") && plot.contains("\n2.5 %\n"), "{plot}");
        let table = page.split_table();
        assert_eq!(
            table.matches("<tr>").count(),
            3,
            "a header and a row per split: {table}"
        );
        // The own split takes its error against the truth from `splits`: (199.23 − 185) / 185.
        assert!(
            table.contains("<td>199.2</td><td>+7.7 %</td><td>1.40 %</td><td>0.740 %</td>"),
            "{table}"
        );
        assert!(
            table.contains("<td>198.7</td><td>+7.4 %</td><td>1.00 %</td><td>2.49 %</td>"),
            "{table}"
        );
    }

    #[test]
    fn one_split_is_said_to_be_the_only_one() {
        let mut r = results();
        r.stated.splits = None;
        let page = Page { r: &r, d: None };
        assert!(page.split_plot().contains("The study names no further splits"));
        assert_eq!(page.split_table(), "");
    }
}
