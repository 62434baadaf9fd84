//! The plain-language summary, generated from the numbers alone: the only words it knows are the
//! design variables', parameters' and candidates' names.

use super::{Candidate, Extended, Inputs, LackOfFit, NoiseModel, Residual, Role, Trend};

/// A number with four significant digits, without trailing noise.
pub fn num(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let mag = v.abs().log10().floor() as i32;
    if !(-3..6).contains(&mag) {
        return format!("{v:.3e}");
    }
    let decimals = (3 - mag).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// |v| as a percentage with sensible digits.
pub fn pct_pub(v: f64) -> String {
    pct(v)
}

fn pct(v: f64) -> String {
    let a = 100.0 * v.abs();
    if a >= 10.0 {
        format!("{a:.0} %")
    } else if a >= 1.0 {
        format!("{a:.1} %")
    } else {
        format!("{a:.2} %")
    }
}

fn p_text(p: f64) -> String {
    if p < 1e-6 {
        "p < 1e-6".to_string()
    } else {
        format!("p = {}", num(p))
    }
}

pub struct Facts<'a> {
    pub inputs: &'a Inputs<'a>,
    pub residuals: &'a [Residual],
    pub structure: &'a [Trend],
    pub noise: &'a NoiseModel,
    pub lack_of_fit: Option<&'a LackOfFit>,
    pub candidates: &'a [Candidate],
    pub leader: Option<usize>,
    pub cause: Option<&'a str>,
    pub detected: bool,
    pub extended: Option<&'a Extended>,
    pub confounded: &'a [String],
}

fn direction(mean_rel: f64) -> &'static str {
    if mean_rel < 0.0 {
        "under-predicts"
    } else {
        "over-predicts"
    }
}

pub fn summary(f: &Facts) -> String {
    let mut out: Vec<String> = Vec::new();
    let r = f.residuals;
    let n_train = r.iter().filter(|x| x.role == Role::Training).count();
    let mean_rel = r.iter().map(|x| x.relative_error).sum::<f64>() / r.len() as f64;
    let worst = r
        .iter()
        .max_by(|a, b| a.relative_error.abs().total_cmp(&b.relative_error.abs()));
    if let Some(w) = worst {
        let at = w
            .values
            .iter()
            .map(|(k, v)| format!("{k} = {}", num(*v)))
            .collect::<Vec<_>>()
            .join(", ");
        out.push(format!(
            "Calibrated on {n_train} training designs, the simulation {} the tests by {} on average; the largest error \
             is at {} ({at}): it {} by {}.",
            direction(mean_rel),
            pct(mean_rel),
            w.design,
            direction(w.relative_error),
            pct(w.relative_error)
        ));
    }

    // The strongest trend against a design variable: compare the low and the high third.
    let mut trends: Vec<&Trend> = f
        .structure
        .iter()
        .filter(|t| t.significant && t.against != "prediction")
        .collect();
    trends.sort_by(|a, b| {
        a.slope_p_value
            .min(a.rank_p_value)
            .total_cmp(&b.slope_p_value.min(b.rank_p_value))
    });
    if let Some(t) = trends.first() {
        let j = f
            .inputs
            .design_names
            .iter()
            .position(|n| *n == t.against)
            .expect("a design variable");
        let mut by: Vec<(f64, f64)> = f
            .inputs
            .observations
            .iter()
            .zip(r)
            .map(|(o, x)| (o.design[j], x.relative_error))
            .collect();
        by.sort_by(|a, b| a.0.total_cmp(&b.0));
        let third = (by.len() / 3).max(1);
        let low = &by[..third];
        let high = &by[by.len() - third..];
        let mean = |s: &[(f64, f64)]| s.iter().map(|x| x.1).sum::<f64>() / s.len() as f64;
        let (ml, mh) = (mean(low), mean(high));
        let grows = mh.abs() > ml.abs();
        out.push(format!(
            "It {} by {} where {v} is low ({v} ≤ {}) and {} by {} where {v} is high ({v} ≥ {}): the error {} as {v} grows \
             (rank correlation {:.2}).",
            direction(ml),
            pct(ml),
            num(low.last().unwrap().0),
            direction(mh),
            pct(mh),
            num(high[0].0),
            if grows { "grows" } else { "shrinks" },
            t.rank_correlation,
            v = t.against
        ));
        let others: Vec<&str> = trends[1..].iter().map(|t| t.against.as_str()).collect();
        if !others.is_empty() {
            out.push(format!("The residuals also trend with {}.", others.join(" and ")));
        }
    } else {
        out.push("The residuals show no trend against any design variable beyond the noise.".to_string());
    }
    if let Some(t) = f.structure.iter().find(|t| t.against == "prediction" && t.significant) {
        out.push(format!(
            "The standardised residuals {} with the predicted level (rank correlation {:.2}).",
            if t.rank_correlation > 0.0 { "grow" } else { "fall" },
            t.rank_correlation
        ));
    }

    out.push(format!("Noise: {}.", f.noise.note));
    if let Some(l) = f.lack_of_fit {
        out.push(format!(
            "The misfit is {} the replicate noise (χ² = {} on {} degrees of freedom, {}).",
            if l.p_value < f.inputs.settings.alpha {
                "beyond"
            } else {
                "within"
            },
            num(l.chi2),
            l.dof,
            p_text(l.p_value)
        ));
    }

    // Nothing detected, and the best-ranked candidate is a parameter change in disguise.
    let confounded_leader = (f.cause.is_none() && !f.detected)
        .then(|| f.candidates.first())
        .flatten()
        .filter(|c| !c.confounded_with.is_empty() && c.weight > 0.5);
    match (f.cause, f.leader) {
        (Some(cause), Some(k)) => {
            let c = &f.candidates[k];
            let mut s = format!(
                "Most likely cause: '{cause}' ({}; weight {:.2}, amplitude {}, {}).",
                c.term,
                c.weight,
                num(c.amplitude),
                p_text(c.p_value)
            );
            if let Some(e) = f.extended {
                let params = e
                    .parameters
                    .iter()
                    .map(|(k, v)| format!("{k} = {}", num(*v)))
                    .collect::<Vec<_>>()
                    .join(", ");
                s.push_str(&format!(
                    " With it, {params}, and the {} error drops from {} to {}.",
                    if e.measured_on == "validation" {
                        "validation"
                    } else {
                        "leave-one-out"
                    },
                    pct(e.validation_error_before),
                    pct(e.validation_error_after)
                ));
                if let Some(x) = &e.extension {
                    s.push_str(&format!(" {}", x.meaning));
                }
            }
            if let Some(second) = f.candidates.iter().skip(k + 1).find(|c| c.confounded_with.is_empty()) {
                s.push_str(&format!(" Runner-up: '{}' (weight {:.2}).", second.name, second.weight));
            }
            out.push(s);
        }
        (None, Some(k)) if f.detected => out.push(format!(
            "The simulation misses something, but no candidate explains it significantly better than no correction \
             (best: '{}', {}).",
            f.candidates[k].name,
            p_text(f.candidates[k].p_value)
        )),
        _ if f.detected => {
            out.push("The simulation misses something beyond the noise; no candidate was ranked.".to_string())
        }
        // Neither a pure-error test (needs replicates) nor a ranking (needs spare designs) was possible:
        // saying "no discrepancy" would report a test that was never made.
        _ if f.lack_of_fit.is_none() && f.candidates.is_empty() => out.push(
            "The data cannot tell whether the simulation misses something beyond the noise: without replicate \
             tests or spare training designs there is nothing to measure the misfit against. Replicate tests, or \
             more training designs, would settle it."
                .to_string(),
        ),
        // The best explanation is a change of a parameter in disguise: "no discrepancy" would hide that
        // the calibrated parameter may have absorbed a model error.
        _ if let Some(c) = confounded_leader => out.push(format!(
            "Best ranked: '{}' ({}; weight {:.2}), but over these designs it has the shape of a change of {}: \
                 the calibration absorbs it into {} and the data cannot separate the two. An independent measurement \
                 of {}, or tests at designs where the shapes differ more, would.",
            c.name,
            c.term,
            c.weight,
            c.confounded_with.join(" and "),
            c.confounded_with.join(" and "),
            c.confounded_with.join(" and ")
        )),
        _ => out.push(
            "No significant discrepancy: no candidate beats the uncorrected simulation beyond the noise.".to_string(),
        ),
    }
    // The best-ranked confounded candidate was already explained above.
    let explained = confounded_leader.map(|c| format!("'{}' ", c.name));
    for c in f
        .confounded
        .iter()
        .filter(|c| explained.as_ref().is_none_or(|e| !c.starts_with(e)))
    {
        out.push(format!("Note: {c}."));
    }
    out.join(" ")
}
