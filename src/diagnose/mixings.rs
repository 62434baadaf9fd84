//! The loop models judged over the noise's form the replicates allow.
//!
//! The replicates fix the noise's form σ² = a² + (b·y)² only to a set of mixings λ ([`super::noise`]);
//! the chosen one is an estimate. Judging the loop models under it alone can reject the model that
//! made the tests where the form is least certain (few replicates, the designs' levels far apart).
//! So, where the chosen mixing names no cause, the decision after the loop ([`super::after_loop`])
//! is made again under each mixing of the set (the screening kept as it is), and a cause is named
//! when, at some mixing, its model fits and the decision names it, and **at every mixing of the
//! set** every other open explanation is out: its model misses the tests, or the cause's shape
//! added to it is significant while its own added to the cause's is not. Each rival is thus
//! rejected with the p-value maximised over the nuisance's confidence set (Berger & Boos 1994),
//! the same rule the detection uses; the cause's own fit needs one form the replicates allow, as
//! the uncorrected model's does. The noise's note says which mixing the loop models were judged under.

use super::after_loop::{self, AfterLoop};
use super::verdict::{Verdict, Who};
use super::{Evidence, noise};
use crate::calibrate::CalibrationError;

/// The loop models' evidence the conclusion reads: under the chosen mixing (`chosen`), or under the
/// mixing of the set that names a cause every mixing of the set leaves alone (a note says which).
/// `gather`: the loop models' evidence under a mixing.
pub(super) fn judged<'a>(
    screening: &mut Evidence,
    chosen: Vec<Evidence<'a>>,
    names: &[String],
    gather: &dyn Fn(Option<f64>) -> Result<Vec<Evidence<'a>>, CalibrationError>,
) -> Result<Vec<Evidence<'a>>, CalibrationError> {
    let inputs = screening.cx.inputs;
    let scatter = match (&inputs.features, chosen.is_empty()) {
        (None, false) => noise::Scatter::of(&inputs.observations),
        _ => None,
    };
    let Some(scatter) = scatter else { return Ok(chosen) };
    if after_loop::decide(screening, &chosen, names).0.verdict == Verdict::CauseNamed {
        return Ok(chosen);
    }
    let alpha = inputs.settings.alpha;
    let mut under: Vec<(f64, Vec<Evidence<'a>>, Option<String>, AfterLoop)> = Vec::new();
    let points = scatter.set_points(alpha);
    for &lambda in &points {
        let looped = gather(Some(lambda))?;
        let (d, after) = after_loop::decide(screening, &looped, names);
        let named = (d.verdict == Verdict::CauseNamed)
            .then_some(d.cause)
            .flatten()
            .map(|who| name(screening, names, who));
        under.push((lambda, looped, named, after));
    }
    let level = screening.cx.alpha();
    let lambda_hat = scatter.chosen_mixing(alpha);
    let robust = |cause: &str| under.iter().all(|(_, _, _, after)| rivals_out(after, cause, level));
    let best = (under.iter().enumerate())
        .filter(|(_, (_, _, named, _))| named.as_deref().is_some_and(robust))
        .min_by(|(_, a), (_, b)| (a.0 - lambda_hat).abs().total_cmp(&(b.0 - lambda_hat).abs()))
        .map(|(i, _)| i);
    let Some(i) = best else { return Ok(chosen) };
    let (lambda, looped, named, _) = under.swap_remove(i);
    let (lo, hi) = (points[0], points[points.len() - 1]);
    screening.noise.note.push_str(&format!(
        "; the loop models are judged under the noise's mixing λ = {lambda:.2}, which the replicates allow: under \
         λ = {lambda_hat:.2} no cause is named, but under {lambda:.2} the model with '{}' fits the tests, and under \
         every mixing from {lo:.2} to {hi:.2} each other open explanation misses them or is beaten by it",
        named.unwrap_or_default()
    ));
    Ok(looped)
}

/// Every open explanation other than `cause` is out in this decision: rejected on its lack of
/// fit, or beaten by `cause` (its shape significant at `alpha` added to the other's model, the
/// other's not added to its own).
fn rivals_out(after: &AfterLoop, cause: &str, alpha: f64) -> bool {
    let p = |e: &str, f: &str| {
        after
            .pairwise
            .iter()
            .find(|x| x.shape_of == e && x.added_to == f)
            .and_then(|x| x.p_value)
    };
    after.explanations.iter().filter(|x| x.name != cause).all(|x| {
        x.rejected || (p(cause, &x.name).is_some_and(|v| v < alpha) && p(&x.name, cause).is_some_and(|v| v >= alpha))
    })
}

/// The name of an explanation of the decision after the loop.
fn name(screening: &Evidence, names: &[String], who: Who) -> String {
    match who {
        Who::Extended(j) => names[j].clone(),
        Who::Candidate(k) => screening.ranked.entries[k].model.name().to_string(),
        Who::Uncorrected => "uncorrected".to_string(),
    }
}
