//! The terminal summary: one table of parameters and errors per method, one of predictions.

use std::fmt::Write;

use super::results::{Results, Role, SplitResult, Units};

/// Renders the summary as plain text (no colour: it is also what a log file gets): the answer in
/// plain words first, then the tables; the diagnosis's evidence lines only when `verbose`.
pub fn render(results: &Results, verbose: bool) -> String {
    let mut out = answer_lines(results);
    out.push_str(&sampling_line(results));
    out.push_str(&methods_table(results));
    out.push_str(&diagnosis_models(results));
    out.push_str(&model_caution(results));
    out.push_str(&convergence_warnings(results));
    out.push_str(&predictions_table(results));
    let id = &results.identifiability;
    let _ = writeln!(out, "\nidentifiability: {}", id.note);
    if let Some(c) = &results.curve_calibration {
        out.push_str(&curves_table(c));
    }
    out.push_str(&failed_runs(results));
    write_diagnosis(&mut out, results, verbose);
    out
}

/// The answer's three lines: the verdict in plain words, the action, the statistics that decided.
fn answer_lines(results: &Results) -> String {
    match &results.answer {
        Some(a) => format!("{}\n{}\n{}\n\n", a.verdict, a.action, a.decided_by),
        None => String::new(),
    }
}

/// The models the diagnosis calibrated, beside the methods' table: its own calibration (least
/// squares weighted by the tests' noise, on what it read) of the uncorrected simulation, the
/// cause's model and, when the tests cannot tell them apart, the leading explanations', so that
/// each figure the answer quotes has its row.
fn diagnosis_models(results: &Results) -> String {
    let Some(d) = &results.diagnosed.diagnosis else {
        return String::new();
    };
    let rows = super::answer::quoted_models(results, d);
    let mut columns: Vec<(&String, Option<&String>)> = Vec::new();
    for q in rows.iter().flat_map(|(m, _)| m.parameters.iter().chain(&m.variables)) {
        if !columns.iter().any(|(n, _)| *n == &q.name) {
            columns.push((&q.name, q.unit.as_ref()));
        }
    }
    let read = match &d.checked.features {
        Some(f) => format!("the curve features: {}", f.read.join(", ")),
        None => "the response".to_string(),
    };
    let extended = d.extended_model();
    let on = extended.map_or("validation", |e| e.gains.measured_on.as_str());
    let mut t = format!("\nthe diagnosis's models (least squares weighted by the tests' noise, on {read})\n");
    let _ = write!(t, "{:<36}", "model");
    for (n, unit) in &columns {
        let _ = write!(t, " {:>14}", Units::label(*unit, n));
    }
    let _ = writeln!(t, "  {} err", if on == "validation" { "valid" } else { "LOO" });
    for (model, error) in &rows {
        let _ = write!(t, "{:<36}", model.model);
        for (n, _) in &columns {
            let value = model.parameters.iter().chain(&model.variables).find(|q| q.name == **n);
            let _ = write!(t, " {:>14}", value.map_or("-".to_string(), |q| significant(q.value, 6)));
        }
        let _ = writeln!(t, "  {:>9}", percent(*error));
    }
    t
}

/// When runs failed: how many, in which stages, and that the fits and the verdict rest on the
/// runs that finished.
fn failed_runs(results: &Results) -> String {
    let Some(words) = results.solver.runs.as_ref().and_then(|r| r.failed_words()) else {
        return String::new();
    };
    let listed = match results.sampling {
        Some(_) => "listed above and in results.json `sampling.sequence[].failed`",
        None => "listed above",
    };
    format!("\ncaution: {words} (the failed runs are {listed})\n")
}

/// A sequential study's solver runs in all, stage by stage, and why each stopped; first, when the
/// study names the fixed design it replaces, that design's runs beside them (`246 → 45`).
fn sampling_line(results: &Results) -> String {
    let Some(s) = &results.sampling else {
        return String::new();
    };
    let stages: Vec<String> = s
        .stopped
        .iter()
        .map(|x| match x.failed {
            0 => format!("{} {} ({})", x.stage, x.runs, x.reason.key()),
            n => format!("{} {} ({}, {n} failed)", x.stage, x.runs, x.reason.key()),
        })
        .collect();
    let starts = match s.attempts() {
        n if n > s.runs => format!(" ({n} solver starts with retries)"),
        _ => String::new(),
    };
    let failed = match s.failed() {
        0 => starts,
        n => format!("{starts}, {n} failed"),
    };
    let total = match &s.replaces {
        Some(r) => format!(
            "{} → {} solver runs{failed}: sampled sequentially in place of a {}",
            r.runs,
            s.runs,
            r.design()
        ),
        None => format!("solver runs: {} in all{failed}, sampled sequentially", s.runs),
    };
    format!("{total}: {}\n\n", stages.join(", "))
}

/// Beside the calibrated parameters: when the diagnosis finds model error that no listed cause
/// accounts for, the parameters are only as good as the model (how far each moves is in the
/// diagnosis's limits).
fn model_caution(results: &Results) -> String {
    use crate::diagnose::verdict::Verdict;
    let Some(d) = &results.diagnosed.diagnosis else {
        return String::new();
    };
    let moved = d.explained.parameter_limits.first().map_or(String::new(), |l| {
        format!(
            "; with the misfit absorbed {} moves {:+.1} %",
            l.parameter,
            100.0 * l.relative
        )
    });
    match d.finding.verdict {
        Verdict::PartlyExplained | Verdict::Unexplained => format!(
            "caution: the diagnosis finds model error that no listed cause accounts for; these parameters absorb it and \
             are only as good as the model{moved}\n"
        ),
        _ => String::new(),
    }
}

/// The methods on whole curves: parameters, the metric at the training and validation designs,
/// the emulator, and what the curves pin down that the mean force does not.
fn curves_table(c: &super::results::CurveCalibrationResult) -> String {
    let mut out = String::new();
    let components: Vec<String> = c.emulator.components.iter().map(|(d, k)| format!("{d} {k}")).collect();
    let _ = writeln!(
        out,
        "\ncurves: {} over {} strokes, {}..{} mm{}; emulator components {}, reconstruction error {}, check error {}",
        c.metric,
        c.points,
        c.window[0],
        c.window[1],
        c.filter
            .as_ref()
            .map_or(String::new(), |f| format!(", CFC {} at {} m/s", f.cfc, f.speed)),
        components.join(", "),
        percent(Some(c.emulator.reconstruction_error)),
        percent(c.emulator.check_error),
    );
    let _ = writeln!(
        out,
        "{:<15} {:<36} {:>12} {:>12}",
        "method", "parameters", "train", "validation"
    );
    let value = |v: Option<f64>| v.map_or("-".to_string(), |v| significant(v, 4));
    for (m, r) in &c.methods {
        let params: Vec<String> = match &r.error {
            Some(e) => vec![format!("failed: {e}")],
            None => r
                .parameters
                .iter()
                .map(|(n, v)| format!("{n} = {}", significant(*v, 5)))
                .collect(),
        };
        let _ = writeln!(
            out,
            "{m:<15} {:<36} {:>12} {:>12}",
            params.join(", "),
            value(r.train),
            value(r.validation)
        );
    }
    for p in &c.identifiability {
        let se = |v: Option<f64>| v.map_or("not determined".to_string(), |v| format!("±{}", significant(v, 3)));
        let _ = writeln!(
            out,
            "{}: standard error {} from the curves, {} from the mean forces",
            p.parameter,
            se(p.curves_se),
            se(p.mean_force_se)
        );
    }
    out
}

/// A warning per sampled method whose chain ended before converging (split R-hat ≤ 1.01 and ESS ≥
/// 1000 per parameter), and per integrated one whose quadrature ran out of boxes before its
/// tolerance: its interval is then rough.
pub fn convergence_warnings(results: &Results) -> String {
    let mut out = String::new();
    for (method, r) in &results.calibration {
        if let Some(q) = r.posterior.quadrature.as_ref().filter(|q| !q.converged) {
            let _ = writeln!(
                out,
                "warning: the {method} posterior's quadrature stopped at its budget of {} boxes before its                  tolerance (estimated relative error {:.1e}): its interval is rough",
                q.boxes, q.relative_error
            );
        }
        let Some(conv) = &r.posterior.convergence else { continue };
        let short: Vec<String> = conv
            .iter()
            .filter(|(_, c)| !c.converged)
            .map(|(n, c)| format!("{n}: split R-hat {:.3}, ESS {:.0}", c.split_rhat, c.ess))
            .collect();
        if !short.is_empty() {
            let _ = writeln!(
                out,
                "warning: the {method} chain ended before converging ({}; the limits are R-hat ≤ 1.01 and \
                 ESS ≥ 1000): its interval is rough",
                short.join("; ")
            );
        }
    }
    out
}

/// Per method: the parameters, the 95 % interval or the constant discrepancy, and the errors.
fn methods_table(results: &Results) -> String {
    let mut out = String::new();
    let names: Vec<&String> = results
        .calibration
        .values()
        .find(|m| m.error.is_none())
        .map(|m| m.parameters.keys().collect())
        .unwrap_or_default();

    let _ = writeln!(out, "study {}\n", results.study);
    let mut header = format!("{:<15}", "method");
    for n in &names {
        let _ = write!(
            header,
            " {:>14}",
            Units::label(results.stated.units.parameters.get(*n), n)
        );
    }
    let _ = writeln!(
        out,
        "{header} {:>30} {:>10} {:>10}",
        "95 % interval / discrepancy", "train err", "valid err"
    );
    for (method, r) in &results.calibration {
        let mut line = format!("{method:<15}");
        if let Some(e) = &r.error {
            let _ = writeln!(out, "{line} failed: {e}");
            continue;
        }
        for n in &names {
            let _ = write!(line, " {:>14}", significant(r.parameters[*n], 6));
        }
        let extra = match (&r.posterior.interval95, &r.discrepancy) {
            (Some(iv), _) => iv
                .values()
                .map(|[lo, hi]| format!("[{}, {}]", significant(*lo, 5), significant(*hi, 5)))
                .collect::<Vec<_>>()
                .join(" "),
            (None, Some(d)) => d
                .get("constant")
                .and_then(|c| c.as_f64())
                .map(|c| {
                    let unit = results
                        .stated
                        .units
                        .response
                        .as_ref()
                        .map_or(String::new(), |u| format!(" {u}"));
                    format!("d = {}{unit}", significant(c, 5))
                })
                .unwrap_or_default(),
            _ => String::new(),
        };
        let _ = writeln!(
            out,
            "{line} {extra:>30} {:>10} {:>10}",
            percent(r.training_error),
            percent(r.validation_error)
        );
    }
    out
}

/// Per tested design: the measurement and each method's prediction with its relative error.
fn predictions_table(results: &Results) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "\npredictions (relative error)");
    let measured = Units::label(results.stated.units.response.as_ref(), "measured");
    let mut header = format!("{:<12} {:<10} {:>14}", "design", "role", measured);
    for method in results.calibration.keys() {
        let _ = write!(header, " {:>24}", method);
    }
    let _ = writeln!(out, "{header}");
    if let Some(first) = results.calibration.values().find(|m| m.error.is_none()) {
        for (i, p) in first.predictions.iter().enumerate() {
            let role = match p.role {
                Role::Training => "training",
                Role::Validation => "validation",
            };
            let mut line = format!("{:<12} {:<10} {:>14}", p.design, role, significant(p.measured, 6));
            for r in results.calibration.values() {
                let cell = r.predictions.get(i).map_or("-".to_string(), |q| {
                    // Rounded first, and + 0.0 turns a rounded −0 into 0: no "(-0.00 %)".
                    let pct = (1e4 * q.relative_error).round() / 100.0 + 0.0;
                    format!("{} ({pct:+.2} %)", significant(q.predicted, 6))
                });
                let _ = write!(line, " {cell:>24}");
            }
            let _ = writeln!(out, "{line}");
        }
    }
    out
}

/// The splits as a text table: per split and method, the parameters and the errors.
pub fn splits(splits: &[SplitResult]) -> String {
    let mut t = String::from("\ntrain/validate splits:\n");
    for split in splits {
        let _ = writeln!(
            t,
            "  train {} / validate {}",
            split.training.join(", "),
            split.validation.join(", ")
        );
        for (method, m) in &split.methods {
            if let Some(e) = &m.error {
                let _ = writeln!(t, "    {method:<14} failed: {e}");
                continue;
            }
            let params: Vec<String> = m.parameters.iter().map(|(k, v)| format!("{k} = {v:.1}")).collect();
            let truth: Vec<String> = m
                .parameter_error
                .iter()
                .flatten()
                .map(|(k, e)| format!("{k} {:+.1} % vs truth", 100.0 * e))
                .collect();
            let pct = |e: Option<f64>| e.map_or("-".to_string(), |e| format!("{:.2} %", 100.0 * e));
            let _ = writeln!(
                t,
                "    {method:<14} {}{}  training error {}  validation error {}",
                params.join(", "),
                if truth.is_empty() {
                    String::new()
                } else {
                    format!(" ({})", truth.join(", "))
                },
                pct(m.training_error),
                pct(m.validation_error)
            );
        }
    }
    t
}

fn write_diagnosis(out: &mut String, results: &Results, verbose: bool) {
    let Some(d) = &results.diagnosed.diagnosis else {
        if let Some(e) = &results.diagnosed.diagnosis_error {
            let _ = writeln!(out, "\ndiagnosis: could not run: {e}");
        }
        return;
    };
    if verbose {
        let _ = writeln!(out, "\ndiagnosis: {}", d.record.summary);
    } else {
        let _ = writeln!(
            out,
            "\ndiagnosis: {} ({} evidence lines: `lab run --verbose`, or the report)",
            d.finding.verdict.words(),
            d.finding.evidence.len() + d.finding.limits.len()
        );
    }
    if !d.explained.candidates.is_empty() {
        let _ = writeln!(
            out,
            "  {:<24} {:>8} {:>10} {:>10}",
            "candidate", "weight", "p-value", "LOO error"
        );
        for c in d.explained.candidates.iter().take(5) {
            let flag = if c.checks.confounded_with.is_empty() {
                String::new()
            } else {
                format!(
                    "  (cannot be told from a change of {})",
                    c.checks.confounded_with.join(", ")
                )
            };
            let _ = writeln!(
                out,
                "  {:<24} {:>8.3} {:>10} {:>10}{flag}",
                c.shape.name,
                c.scores.weight,
                c.fit.p_value.map_or("-".to_string(), |p| significant(p, 2)),
                percent(c.scores.loo_error)
            );
        }
    }
    if let Some(x) = d.extended_model() {
        let params: Vec<String> = x
            .model
            .parameters
            .iter()
            .map(|(n, v)| format!("{n} = {}", significant(*v, 6)))
            .collect();
        let refit = (d.checked.solver_refit.as_ref()).is_some_and(|r| r.model == x.model.cause);
        let _ = writeln!(
            out,
            "  extended with `{}`: {}; validation error {:.2} % -> {:.2} % (gain {}){}",
            x.model.cause,
            params.join(", "),
            100.0 * x.gains.validation_error_before,
            100.0 * x.gains.validation_error_after,
            x.gains.gain.map_or("-".to_string(), |g| format!("{:.0} %", 100.0 * g)),
            if refit {
                ", at the loop's point before the solver's refit"
            } else {
                ""
            }
        );
    }
    if let Some(f) = &d.checked.discovered {
        write_discovered(out, f);
    }
}

/// The library search's result, after the verdict: found by search, not listed.
fn write_discovered(out: &mut String, f: &crate::diagnose::discover::Discovered) {
    use crate::diagnose::discover::Outcome;
    match (f.found.outcome, &f.found.term) {
        (Outcome::Found, Some(term)) => {
            let params: Vec<String> = f
                .found
                .parameters
                .iter()
                .map(|(n, v)| format!("{n} = {}", significant(*v, 6)))
                .collect();
            let interval = f.found.interval.map_or(String::new(), |[a, b]| {
                format!(" [{}, {}]", significant(a, 4), significant(b, 4))
            });
            let _ = writeln!(
                out,
                "  found by search, not listed: `{term}` added to the {} model: coefficient {}{interval}, {}; {} \
                 error {} -> {} (gain {}), leave-one-design-out {} -> {}",
                f.test.base,
                f.found.coefficient.map_or("-".into(), |c| significant(c, 4)),
                params.join(", "),
                f.checks.measured_on.as_deref().unwrap_or("validation"),
                percent(if f.checks.measured_on.as_deref() == Some("validation") {
                    f.checks.validation_error_before
                } else {
                    f.checks.loo_error_before
                }),
                percent(if f.checks.measured_on.as_deref() == Some("validation") {
                    f.checks.validation_error_after
                } else {
                    f.checks.loo_error_after
                }),
                f.found.gain.map_or("-".to_string(), |g| format!("{:.0} %", 100.0 * g)),
                percent(f.checks.loo_error_before),
                percent(f.checks.loo_error_after)
            );
            if let Some(shape) = &f.named.shape {
                let _ = writeln!(out, "    shape: {shape}");
            }
            if let Some(r) = &f.named.reading {
                let _ = writeln!(out, "    reading: {r}");
            }
            if let Some(line) = &f.named.hypothesis_line {
                let _ = writeln!(out, "    to test it as a listed cause, add under diagnosis.hypotheses:");
                for l in line.lines() {
                    let _ = writeln!(out, "      {l}");
                }
            }
        }
        _ => {
            let _ = writeln!(
                out,
                "  library search (not listed): no shape in the library explains the misfit ({} models, α/M = {})",
                f.search.library.models,
                significant(f.test.threshold, 2)
            );
            for c in &f.search.closest {
                let _ = writeln!(out, "    closest: `{}` — {}", c.term, c.why);
            }
        }
    }
}

/// `x` with `digits` significant figures, without exponent for ordinary magnitudes.
pub fn significant(x: f64, digits: usize) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let magnitude = x.abs().log10().floor() as i32;
    if !(-4..=9).contains(&magnitude) {
        return format!("{:.*e}", digits.saturating_sub(1), x);
    }
    let decimals = (digits as i32 - 1 - magnitude).max(0) as usize;
    format!("{x:.decimals$}")
}

fn percent(x: Option<f64>) -> String {
    x.map_or("-".to_string(), |v| format!("{:.2} %", 100.0 * v))
}

#[cfg(test)]
mod tests {
    use super::significant;

    #[test]
    fn quadrature_that_ran_out_of_boxes_is_warned_about() {
        let quadrature = |converged: bool| {
            serde_json::json!({
                "study": "s",
                "calibration": {"bayesian": {
                    "parameters": {"E": 1.0}, "discrepancy": null, "predictions": [],
                    "training_error": null, "validation_error": null,
                    "quadrature": {"rule": "GK", "relative_error": 0.02, "inner_relative_error": 0.0,
                                   "boxes": 400, "evaluations": 12000, "converged": converged}
                }},
                "identifiability": {"identifiable": true, "note": "", "combinations": [], "singular_values": []},
                "diagnosis": null
            })
        };
        let warn = |converged| {
            let r: super::Results = serde_json::from_value(quadrature(converged)).expect("a results.json");
            super::convergence_warnings(&r)
        };
        assert!(
            warn(false).contains("quadrature stopped at its budget of 400 boxes"),
            "{}",
            warn(false)
        );
        assert_eq!(warn(true), "");
    }

    #[test]
    fn significant_figures() {
        assert_eq!(significant(64913.87, 6), "64913.9");
        assert_eq!(significant(0.0188771, 5), "0.018877");
        assert_eq!(significant(1.5e-7, 3), "1.50e-7");
    }
}
