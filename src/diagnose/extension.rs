//! Step 6: the model extended with the cause, and what it gains.
//!
//! - Gain on the validation designs (the contract's `gain`) and, beside it, leave-one-design-out
//!   over the training designs (`gain_loo`): one validation design can sit where the uncorrected
//!   model happens to cross the truth, and then its "before" error is no measure of anything. Such
//!   designs (|z| < 2 for the uncorrected prediction, noise and calibration uncertainty included)
//!   are listed in `before_within_noise`.
//! - The extended model's lack of fit against the replicate noise ([`super::evidence`]): when it
//!   rejects, the cause is only part of the story, and `remaining` says where (designs whose
//!   standardised residual still exceeds 2).

use indexmap::IndexMap;

use super::candidates::mean_abs_rel;
use super::ranking::{Entry, Ranked};
use super::verdict::Decision;
use super::{Context, Extended, ExtensionEffect};

pub(crate) fn extend(cx: &Context, ranked: &Ranked, decision: &Decision) -> Option<Extended> {
    let e = &ranked.entries[decision.cause?];
    let base = &ranked.base;
    let shape = e.model.shape.as_ref()?;
    let (before, after, measured_on) = errors(cx, base, e);
    let loo = |x: &Entry| x.score.as_ref().and_then(|s| s.loo_error);
    let (loo_before, loo_after) = (loo(base), loo(e));
    let lof = e.assessed.lack_of_fit.as_ref();
    let names = &cx.inputs.parameter_names;
    let theta0 = &base.model.fit.theta;
    let theta = &e.model.fit.theta;
    let gamma = e.model.fit.amplitude();
    Some(Extended {
        cause: shape.name.clone(),
        term: shape.term.clone(),
        amplitude: gamma,
        amplitude_ci95: e.assessed.separability.amplitude_ci95,
        parameters: cx.param_map(theta),
        parameter_se: e.assessed.cov.as_ref().map(|c| {
            names
                .iter()
                .enumerate()
                .map(|(j, n)| (n.clone(), c.matrix[(j, j)].sqrt()))
                .collect()
        }),
        parameter_change: names
            .iter()
            .enumerate()
            .map(|(j, n)| (n.clone(), theta[j] / theta0[j] - 1.0))
            .collect(),
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
        before_within_noise: within_noise(base),
        lack_of_fit_chi2: lof.map(|l| l.chi2),
        lack_of_fit_dof: lof.map(|l| l.dof),
        lack_of_fit_p: lof.map(|l| l.p_value),
        remaining: standardised(cx, e).into_iter().filter(|(_, z)| z.abs() > 2.0).collect(),
        residual_z: standardised(cx, e),
        extension: shape.amplitude_meaning(gamma).map(|meaning| ExtensionEffect {
            variables: shape.extension.iter().flatten().cloned().collect(),
            amplitude: gamma,
            meaning,
        }),
        solver_in_the_loop: false,
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
    let fitted = |x: &Entry| {
        mean_abs_rel(
            cx.train
                .iter()
                .map(|&i| (x.model.predict(cx, &cx.data.designs[i]), cx.data.means[i])),
        )
    };
    (fitted(base), fitted(e), "training (in sample)")
}

/// Validation designs where the uncorrected prediction is within the noise (|z| < 2).
fn within_noise(base: &Entry) -> Vec<String> {
    base.assessed
        .validation
        .iter()
        .flat_map(|v| v.z.iter())
        .filter(|(_, z)| z.abs() < 2.0)
        .map(|(n, _)| n.clone())
        .collect()
}

/// The extended model's residuals in units of σ: training residuals in units of the noise of the
/// mean, validation designs by their predictive z.
fn standardised(cx: &Context, e: &Entry) -> IndexMap<String, f64> {
    let Some(s2) = e.assessed.s2 else {
        return IndexMap::new();
    };
    let mut z: IndexMap<String, f64> = cx
        .train
        .iter()
        .map(|&i| {
            let r = cx.data.means[i] - e.model.predict(cx, &cx.data.designs[i]);
            (
                cx.inputs.observations[i].name.clone(),
                cx.data.weights[i] * r / s2.sqrt(),
            )
        })
        .collect();
    if let Some(v) = &e.assessed.validation {
        z.extend(v.z.iter().map(|(n, z)| (n.clone(), *z)));
    }
    z
}
