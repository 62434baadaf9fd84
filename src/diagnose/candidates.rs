//! Step 2: the uncorrected model and every candidate, each fitted jointly with θ on the training
//! designs, with the numbers the ranking needs.
//!
//! A candidate is `y(d, θ) + γ g(d, θ, y)` for a shape g (study hypotheses first, then the built-ins
//! of [`Shape::built_ins`]). A built-in numerically equal in shape to a study hypothesis is dropped:
//! the hypothesis carries the user's name. Nothing else is dropped for its shape: whether the data
//! can tell a shape from a change of θ is for [`super::evidence`] to measure.
//!
//! Scores (smaller is better) estimate the out-of-sample deviance:
//! - with spare designs, `½ (AICc + D_loo)`, D_loo the leave-one-design-out predictive deviance.
//!   Both estimate the same quantity (Stone 1977: LOO and AIC are asymptotically equivalent); with
//!   few designs each is noisy, so the two are averaged;
//! - with replicates but few designs, `AIC + D_val`: the fit against the replicate noise plus the
//!   validation designs' predictive deviance (Gelman, Hwang & Vehtari 2014: held-out data score
//!   a model directly).

use rayon::prelude::*;

use super::fit::Fit;
use super::shapes::{Origin, Shape};
use super::{Context, Mode, stats};
use crate::base::CalibrationError;

/// A fitted model: the uncorrected one (no shape) or a candidate.
pub(crate) struct Model {
    pub shape: Option<Shape>,
    /// Shapes fitted together with `shape` (a model found by the library search: its further term
    /// and the cause it extends; see [`super::discover`]); empty for a candidate.
    pub more: Vec<Shape>,
    /// The built-in this study hypothesis stands in for.
    pub replaces: Option<String>,
    pub fit: Fit,
    /// Leave-one-design-out predictions at the training designs (ranked mode only).
    pub loo: Option<Vec<f64>>,
}

impl Model {
    pub fn shapes(&self) -> Vec<&Shape> {
        self.shape.iter().chain(&self.more).collect()
    }

    /// Fitted numbers: parameters and amplitudes.
    pub fn k(&self) -> usize {
        self.fit.theta.len() + usize::from(self.shape.is_some()) + self.more.len()
    }

    pub fn name(&self) -> &str {
        self.shape.as_ref().map_or("uncorrected", |s| s.name.as_str())
    }

    pub fn predict(&self, cx: &Context, design: &[f64]) -> f64 {
        cx.data
            .predict(&self.shapes(), self.fit.theta.as_slice(), &self.fit.gamma, design)
    }
}

fn fit_model(cx: &Context, shape: Option<Shape>, replaces: Option<String>) -> Result<Model, CalibrationError> {
    let shapes: Vec<&Shape> = shape.iter().collect();
    let fit = cx.data.fit(&shapes, &cx.train)?;
    let loo = match cx.mode {
        Mode::Ranked => Some(cx.data.leave_one_out(&shapes, &cx.train, &fit.theta)?),
        _ => None,
    };
    drop(shapes);
    Ok(Model {
        shape,
        more: Vec::new(),
        replaces,
        fit,
        loo,
    })
}

/// The uncorrected model: θ alone by weighted least squares.
pub(crate) fn uncorrected(cx: &Context) -> Result<Model, CalibrationError> {
    fit_model(cx, None, None)
}

/// The candidate shapes: the study's hypotheses, then the built-ins that no hypothesis duplicates.
/// A shape that is not finite, or vanishes, at every training design is skipped with a note.
pub(crate) fn shapes(cx: &Context, base: &Model, notes: &mut Vec<String>) -> Vec<(Shape, Option<String>)> {
    let inputs = cx.inputs;
    let mut kept: Vec<(Shape, Option<String>, Vec<f64>)> = Vec::new();
    for shape in inputs.candidate_shapes() {
        let v = shape_vector(cx, &shape, base);
        if v.iter().any(|x| !x.is_finite()) {
            notes.push(format!(
                "candidate '{}' ({}) is not finite at every training design: skipped",
                shape.name, shape.term
            ));
            continue;
        }
        if v.iter().all(|&x| x == 0.0) {
            notes.push(format!(
                "candidate '{}' ({}) vanishes at every training design: skipped",
                shape.name, shape.term
            ));
            continue;
        }
        let same = |hv: &Vec<f64>| stats::cosine(hv, &v).abs() > inputs.settings.same_shape_cosine;
        if shape.origin == Origin::BuiltIn
            && let Some(k) = kept.iter().position(|(h, _, hv)| h.origin == Origin::Study && same(hv))
        {
            kept[k].1.get_or_insert_with(|| shape.name.clone());
            continue;
        }
        kept.push((shape, None, v));
    }
    kept.into_iter().map(|(s, r, _)| (s, r)).collect()
}

/// The weighted shape w_i g(d_i, θ, y_i) over the training designs at the uncorrected θ.
pub(crate) fn shape_vector(cx: &Context, shape: &Shape, base: &Model) -> Vec<f64> {
    let th = base.fit.theta.as_slice();
    cx.train
        .iter()
        .map(|&i| {
            let d = &cx.data.designs[i];
            cx.data.weights[i] * shape.eval(d, th, cx.inputs.model.predict(d, th))
        })
        .collect()
}

/// Every candidate fitted jointly with θ (in parallel); a failed fit is a note, not an error.
pub(crate) fn fit_all(cx: &Context, shapes: Vec<(Shape, Option<String>)>, notes: &mut Vec<String>) -> Vec<Model> {
    if cx.train.len() <= cx.p() {
        notes.push(format!(
            "{} training design(s) cannot fit a candidate with {} parameter(s): candidates are not fitted",
            cx.train.len(),
            cx.p()
        ));
        return Vec::new();
    }
    let results: Vec<(String, Result<Model, CalibrationError>)> = shapes
        .into_par_iter()
        .map(|(shape, replaces)| (shape.name.clone(), fit_model(cx, Some(shape), replaces)))
        .collect();
    let mut out = Vec::new();
    for (name, r) in results {
        match r {
            Ok(m) => out.push(m),
            Err(e) => notes.push(format!("candidate '{name}' could not be fitted: {e}")),
        }
    }
    out
}

/// The ranking numbers of one model.
#[derive(Debug, Clone)]
pub(crate) struct Score {
    pub aicc: Option<f64>,
    pub bic: f64,
    pub loo_deviance: Option<f64>,
    pub loo_error: Option<f64>,
    pub score: f64,
}

/// `−2 log L` of a fit up to a constant: the weighted RSS with known noise, the profile deviance
/// `n ln(2π RSS/n) + n` without.
fn deviance(cx: &Context, rss: f64, n: usize) -> f64 {
    if cx.known() {
        rss
    } else {
        let nf = n as f64;
        nf * (2.0 * std::f64::consts::PI * rss.max(cx.rss_floor) / nf).ln() + nf
    }
}

/// The scores of `model`; `validation_deviance` is its predictive deviance at the validation
/// designs (the few-designs score uses it).
pub(crate) fn score(cx: &Context, model: &Model, validation_deviance: Option<f64>) -> Score {
    let n = cx.train.len();
    let nf = n as f64;
    let k = (model.k() + usize::from(!cx.known())) as f64;
    let m2ll = deviance(cx, model.fit.wrss, n);
    let bic = m2ll + k * nf.ln();
    let aicc = (nf - k - 1.0 > 0.0).then(|| m2ll + 2.0 * k + 2.0 * k * (k + 1.0) / (nf - k - 1.0));
    let loo = model.loo.as_ref();
    let loo_deviance = loo.map(|loo| deviance(cx, cx.press(loo), n));
    let loo_error = loo.map(|loo| cx.loo_error(loo));
    let score = match (cx.mode, aicc, loo_deviance) {
        (Mode::Ranked, Some(a), Some(d)) => 0.5 * (a + d),
        _ => m2ll + 2.0 * k + validation_deviance.unwrap_or(0.0),
    };
    Score {
        aicc,
        bic,
        loo_deviance,
        loo_error,
        score,
    }
}
