//! Step 6: the model extended with the cause, and what it gains.
//!
//! - Gain on the validation designs (the contract's `gain`) and, beside it, leave-one-design-out
//!   over the training designs (`gain_loo`): one validation design can sit where the uncorrected
//!   model happens to cross the truth, and then its "before" error is no measure of anything. Such
//!   designs (|z| < 2 for the uncorrected prediction, noise and calibration uncertainty included)
//!   are listed in `before_within_noise` — only when the noise is known from replicates.
//! - The extended model's lack of fit against the replicate noise ([`super::evidence`]): when it
//!   rejects, the cause is only part of the story, and `remaining` says where (designs whose
//!   standardised residual still exceeds 2).

use indexmap::IndexMap;

use super::ranking::{Entry, Ranked};
use super::{Context, Evidence, Extended, ExtendedCheck, ExtendedFit, ExtendedGain, ExtensionEffect};
use crate::base::format::num;

/// The screening's extended model of candidate `k`: θ and its amplitude fitted jointly.
pub(crate) fn extend(cx: &Context, ranked: &Ranked, k: usize) -> Option<Extended> {
    let e = &ranked.entries[k];
    let base = &ranked.base;
    let shape = e.model.shape.as_ref()?;
    let (before, after, measured_on) = errors(cx, base, e);
    let loo = |x: &Entry| x.score.as_ref().and_then(|s| s.loo_error);
    let (loo_before, loo_after) = (loo(base), loo(e));
    let lof = e.assessed.lack_of_fit.as_ref();
    let names = &cx.inputs.space.parameter_names;
    let theta0 = &base.model.fit.theta;
    let theta = &e.model.fit.theta;
    let gamma = e.model.fit.amplitude();
    Some(Extended {
        model: ExtendedFit {
            cause: shape.name.clone(),
            term: shape.term.clone(),
            amplitude: gamma,
            amplitude_ci95: e.assessed.separability.amplitude_ci95,
            parameters: cx.param_map(theta),
            parameter_se: e.assessed.cov.as_ref().map(|c| cx.standard_errors(c)),
            parameter_change: names
                .iter()
                .enumerate()
                .map(|(j, n)| (n.clone(), theta[j] / theta0[j] - 1.0))
                .collect(),
        },
        gains: ExtendedGain {
            validation_error_before: before,
            validation_error_after: after,
            gain: (before > 0.0).then(|| 1.0 - after / before),
            measured_on: measured_on.to_string(),
            loo_error_before: loo_before,
            loo_error_after: loo_after,
            gain_loo: loo_before
                .zip(loo_after)
                .filter(|(b, _)| *b > 0.0)
                .map(|(b, a)| 1.0 - a / b),
            before_within_noise: within_noise(cx, base),
        },
        check: ExtendedCheck {
            lack_of_fit_chi2: lof.map(|l| l.chi2),
            lack_of_fit_dof: lof.map(|l| l.dof),
            lack_of_fit_p: lof.map(|l| l.p_value),
            lack_of_fit: lof.cloned(),
            remaining: standardised(cx, e).into_iter().filter(|(_, z)| z.abs() > 2.0).collect(),
            residual_z: standardised(cx, e),
            extension: shape.amplitude_meaning(gamma).map(|meaning| ExtensionEffect {
                variables: shape.extension.iter().flatten().cloned().collect(),
                amplitude: gamma,
                meaning,
            }),
            solver_in_the_loop: false,
        },
    })
}

/// Mean |relative error| before and after, on the validation designs, else leave-one-design-out,
/// else in sample.
fn errors(cx: &Context, base: &Entry, e: &Entry) -> (f64, f64, &'static str) {
    let val = |x: &Entry| x.assessed.validation.as_ref().map(|v| v.error);
    let loo = |x: &Entry| x.score.as_ref().and_then(|s| s.loo_error);
    if let (Some(b), Some(a)) = (val(base), val(e)) {
        return (b, a, "validation");
    }
    if let (Some(b), Some(a)) = (loo(base), loo(e)) {
        return (b, a, "leave-one-out");
    }
    let fitted = |x: &Entry| cx.mean_abs_rel(cx.train.iter().map(|&i| (i, x.model.predict(cx, &cx.data.designs[i]))));
    (fitted(base), fitted(e), "training (in sample)")
}

/// Validation designs where the uncorrected prediction is within the noise (|z| < 2), among the
/// observations the errors are measured on.
fn within_noise(cx: &Context, base: &Entry) -> Vec<String> {
    // Without replicates the z scale is the uncorrected model's own residual variance, model error
    // included: "within the noise" would then only say "no worse than the model's misfit elsewhere".
    if !cx.known() {
        return Vec::new();
    }
    let counts = |name: &str| {
        cx.val
            .iter()
            .any(|&i| cx.inputs.observations[i].name == name && cx.relative_error(i, cx.data.means[i]).is_some())
    };
    base.assessed
        .validation
        .iter()
        .flat_map(|v| v.z.iter())
        .filter(|(n, z)| z.abs() < 2.0 && counts(n))
        .map(|(n, _)| n.clone())
        .collect()
}

/// The extended model's residuals in units of their standard error ([`super::evidence::standardised`]);
/// empty without a noise.
fn standardised(cx: &Context, e: &Entry) -> IndexMap<String, f64> {
    match e.assessed.s2 {
        Some(s2) => super::evidence::standardised(cx, &e.model, s2, e.assessed.validation.as_ref()),
        None => IndexMap::new(),
    }
}

/// The screening's extended model of a cause (`screening`) carried over to the loop's model of it
/// (`looped`, the extended model taken as the simulation): the parameters gain the extension's
/// variables, and the fit, lack of fit, gains and what remains are the loop model's, no longer the
/// linearisation's.
pub(crate) fn from_loop(screening: Extended, looped: &Evidence) -> Extended {
    let cx = &looped.cx;
    let base = &looped.ranked.base;
    let mut e = screening;
    let before = e.model.parameters.clone();
    e.model.parameters = cx.param_map(&base.model.fit.theta);
    e.model.parameter_se = base.assessed.cov.as_ref().map(|c| cx.standard_errors(c));
    e.model.parameter_change = before
        .iter()
        .filter_map(|(n, v0)| Some((n.clone(), e.model.parameters.get(n)? / v0 - 1.0)))
        .collect();
    if let Some(v) = &base.assessed.validation
        && e.gains.measured_on == "validation"
    {
        e.gains.validation_error_after = v.error;
        e.gains.gain = (e.gains.validation_error_before > 0.0).then(|| 1.0 - v.error / e.gains.validation_error_before);
    }
    e.gains.loo_error_after = base.score.as_ref().and_then(|s| s.loo_error);
    e.gains.gain_loo = e
        .gains
        .loo_error_before
        .zip(e.gains.loo_error_after)
        .filter(|(b, _)| *b > 0.0)
        .map(|(b, a)| 1.0 - a / b);
    if e.gains.measured_on == "leave-one-out"
        && let Some(a) = e.gains.loo_error_after
    {
        e.gains.validation_error_after = a;
        e.gains.gain = e.gains.gain_loo;
    }
    let lof = base.assessed.lack_of_fit.as_ref();
    e.check.lack_of_fit_chi2 = lof.map(|l| l.chi2);
    e.check.lack_of_fit_dof = lof.map(|l| l.dof);
    e.check.lack_of_fit_p = lof.map(|l| l.p_value);
    e.check.lack_of_fit = lof.cloned();
    e.check.residual_z = standardised(cx, base);
    e.check.remaining = e
        .check
        .residual_z
        .iter()
        .filter(|(_, z)| z.abs() > 2.0)
        .map(|(n, z)| (n.clone(), *z))
        .collect();
    let intervals = looped.ranked.uncorrected(cx).precision;
    let variables: Vec<String> = cx
        .inputs
        .space
        .parameter_names
        .iter()
        .filter(|n| !before.contains_key(*n))
        .map(|n| {
            let v = e.model.parameters[n];
            match intervals.as_ref().and_then(|p| p.interval95.get(n)) {
                Some([lo, hi]) => format!("{n} = {} (95 % {} to {})", num(v), num(*lo), num(*hi)),
                None => format!("{n} = {}", num(v)),
            }
        })
        .collect();
    if let Some(x) = &mut e.check.extension {
        x.meaning = format!(
            "calibrated with the solver in the loop: {} (the screening's linearised amplitude was γ = {})",
            variables.join(", "),
            num(x.amplitude)
        );
    }
    e.check.solver_in_the_loop = true;
    e
}
