//! Step 7: the test that would settle what the verdict leaves open.
//!
//! Model discrimination by T-optimal design (Atkinson & Fedorov 1975): take one explanation A as
//! true, with its fitted parameters, and ask how badly a rival B — refitted to the training tests
//! plus m new specimens at design d — would then miss. That misfit, in units of the noise, is the
//! noncentrality λ of the likelihood-ratio test that would follow. With B linearised around its
//! fit (Jacobian J, weights W over the training designs), the existing designs give
//! `λ₀ = ‖r − A δ₀‖²`, `r = W(μ_A − μ_B)`, `A = WJ`, `δ₀ = (AᵀA)⁻¹Aᵀr`, and m specimens at d
//! add, by the recursive least-squares update,
//! `λ(d, m) = λ₀ + m e² / (1 + m h)`, `e = (μ_A(d) − μ_B(d) − j_dᵀδ₀)/σ(d)`,
//! `h = j_dᵀ(AᵀA)⁻¹j_d/σ(d)²`.
//! A pair of candidates counts the weaker direction (min over A→B and B→A); a candidate against
//! the uncorrected model counts only the candidate as true (the larger model nests the smaller and
//! can always mimic it). The test at α has power ≥ `power` when λ ≥ (z_{1−α/2} + z_power)²
//! (normal approximation of the noncentral χ²₁; Cohen 1988, ch. 2). The recommended design is the
//! one that needs the fewest specimens for that, over every compared pair; as m grows, λ is
//! bounded by λ₀ + e²/h: when even that falls short, no number of specimens at one design settles
//! it, and the text says so.

use indexmap::IndexMap;

use super::ranking::{Entry, Ranked};
use super::verdict::Decision;
use nalgebra::{DMatrix, DVector};

use super::{Context, Mode, NextTest, NoiseKind, NoiseModel, stats, text};

/// One explanation: its name and its fitted model.
struct Explanation<'e> {
    name: String,
    entry: &'e Entry,
}

impl Explanation<'_> {
    fn predict(&self, cx: &Context, d: &[f64]) -> f64 {
        self.entry.model.predict(cx, d)
    }
}

/// `found`: a model the library search found and the model it extends ([`super::discover`]);
/// when given, they are the explanations compared, in place of the decision's.
pub(crate) fn recommend(
    cx: &Context,
    ranked: &Ranked,
    decision: &Decision,
    noise: &NoiseModel,
    found: &[(String, &Entry)],
) -> Option<NextTest> {
    let mut explanations: Vec<Explanation> = found
        .iter()
        .map(|(name, entry)| Explanation {
            name: name.clone(),
            entry,
        })
        .collect();
    for k in decision.compare.iter().filter(|_| found.is_empty()) {
        let entry = k.map_or(&ranked.base, |k| &ranked.entries[k]);
        let name = entry.model.name().to_string();
        if !explanations.iter().any(|e| e.name == name) {
            explanations.push(Explanation { name, entry });
        }
    }
    if cx.inputs.design_bounds.dim() == 0 {
        return None;
    }
    if explanations.len() < 2 {
        return farthest_from_tested(cx, &explanations);
    }
    let sigma = one_test_sigma(cx, noise);
    let alpha = cx.alpha();
    let z = stats::normal_quantile(1.0 - alpha / 2.0) + stats::normal_quantile(cx.inputs.settings.power);
    let pick = match &sigma {
        Some(s) => fewest_specimens(cx, &explanations, s, z * z),
        None => widest_gap(cx, &explanations),
    }?;
    let d = pick.design;
    let (ea, eb) = (&explanations[pick.pair.0], &explanations[pick.pair.1]);
    let (ya, yb) = (ea.predict(cx, &d), eb.predict(cx, &d));
    let already_tested = tested_at(cx, &d);
    let separation = sigma
        .as_ref()
        .map_or(pick.gap, |s| (ya - yb).abs() / s(0.5 * (ya + yb)));
    let power = pick
        .specimens
        .map(|_| stats::normal_cdf(pick.lambda.max(0.0).sqrt() - stats::normal_quantile(1.0 - alpha / 2.0)));
    let additional = pick
        .specimens
        .map(|m| m.saturating_sub(already_tested.as_ref().map_or(0, |t| t.1)));
    let compared: IndexMap<String, f64> = explanations
        .iter()
        .map(|e| (e.name.clone(), e.predict(cx, &d)))
        .collect();
    let design: IndexMap<String, f64> = cx.inputs.design_names.iter().cloned().zip(d.iter().copied()).collect();
    let advice = advice(cx, sigma.is_some(), pick.specimens, additional, already_tested.as_ref());
    let why = why(
        &design,
        &compared,
        (ya, yb),
        sigma.is_some(),
        already_tested.as_ref(),
        &advice,
    );
    Some(NextTest {
        design,
        why,
        advice,
        between: [ea.name.clone(), eb.name.clone()],
        predictions: [ya, yb],
        separation,
        compared,
        already_tested,
        specimens: pick.specimens,
        additional_specimens: additional,
        power,
    })
}

/// With nothing to compare (no candidate could be fitted): the design in the box farthest from
/// every tested one (in units of the box), where the calibrated model is least checked.
fn farthest_from_tested(cx: &Context, explanations: &[Explanation]) -> Option<NextTest> {
    let width = cx.inputs.design_bounds.width();
    let gap = |d: &[f64]| {
        cx.inputs
            .observations
            .iter()
            .map(|o| {
                o.design
                    .iter()
                    .zip(d)
                    .enumerate()
                    .map(|(j, (a, b))| ((a - b) / width[j].abs().max(1e-12)).powi(2))
                    .sum::<f64>()
            })
            .fold(f64::INFINITY, f64::min)
    };
    let d = candidate_points(cx)
        .into_iter()
        .max_by(|a, b| gap(a).total_cmp(&gap(b)))?;
    let y = explanations.first().map_or(f64::NAN, |e| e.predict(cx, &d));
    let design: IndexMap<String, f64> = cx.inputs.design_names.iter().cloned().zip(d.iter().copied()).collect();
    let at = design
        .iter()
        .map(|(n, v)| format!("{n} = {}", text::num(*v)))
        .collect::<Vec<_>>()
        .join(", ");
    let advice = "at least 3 specimens there, so that the scatter is measured and the calibrated model is checked \
                  where it was not fitted"
        .to_string();
    Some(NextTest {
        why: format!(
            "Test at {at} (not tested yet): no candidate cause can be fitted to so few tests, so the most useful \
             next test is the design farthest from those tested, where the calibrated simulation predicts {}. In \
             numbers: {advice}.",
            text::num(y)
        ),
        advice,
        between: ["uncorrected".into(), "uncorrected".into()],
        predictions: [y, y],
        separation: 0.0,
        compared: [("uncorrected".to_string(), y)].into_iter().collect(),
        already_tested: None,
        specimens: None,
        additional_specimens: None,
        power: None,
        design,
    })
}

/// The chosen design, the pair that limits it, and what it takes there.
struct Pick {
    design: Vec<f64>,
    pair: (usize, usize),
    /// Specimens for power at α (`None`: no number suffices).
    specimens: Option<usize>,
    /// λ with those specimens (or the bound when none suffices).
    lambda: f64,
    /// The relative gap of the pair (used without a noise).
    gap: f64,
}

/// More specimens than this at one design are no practical recommendation.
const MAX_SPECIMENS: usize = 1000;

/// B linearised around its fit, refitted to A's predictions at the training designs.
struct Discriminant<'e> {
    a: &'e Explanation<'e>,
    b: &'e Explanation<'e>,
    m_inv: DMatrix<f64>,
    delta0: DVector<f64>,
    lambda0: f64,
}

impl<'e> Discriminant<'e> {
    /// `unit`: 1/σ where the weights do not carry the noise (no replicates), else 1.
    fn new(cx: &Context, a: &'e Explanation<'e>, b: &'e Explanation<'e>, unit: f64) -> Option<Self> {
        let mb = &b.entry.model;
        let jac = cx.data.jacobian(&mb.shapes(), &mb.fit, &cx.train) * unit;
        let r = DVector::from_iterator(
            cx.train.len(),
            cx.train.iter().map(|&i| {
                let d = &cx.data.designs[i];
                unit * cx.data.weights[i] * (a.predict(cx, d) - b.predict(cx, d))
            }),
        );
        let m = jac.transpose() * &jac;
        let eps = 1e-12 * m.norm().max(f64::MIN_POSITIVE);
        let m_inv = m.pseudo_inverse(eps).ok()?;
        let delta0 = &m_inv * (jac.transpose() * &r);
        let lambda0 = (&r - &jac * &delta0).norm_squared();
        Some(Discriminant {
            a,
            b,
            m_inv,
            delta0,
            lambda0,
        })
    }

    /// (e², h) of one specimen at d, for the weight 1/σ(d).
    fn row(&self, cx: &Context, d: &[f64], sigma: &Sigma) -> (f64, f64) {
        let mb = &self.b.entry.model;
        let (ya, yb) = (self.a.predict(cx, d), self.b.predict(cx, d));
        let w = 1.0 / sigma(ya);
        let j = cx.data.gradient(&mb.shapes(), &mb.fit, d) * w;
        let e = w * (ya - yb) - j.dot(&self.delta0);
        let h = (j.transpose() * &self.m_inv * &j)[(0, 0)].max(0.0);
        (e * e, h)
    }
}

/// λ(m) = λ₀ + m e²/(1 + m h); the least m with λ ≥ target, or `None`.
fn specimens_for(lambda0: f64, e2: f64, h: f64, target: f64) -> Option<usize> {
    if lambda0 >= target {
        return Some(1);
    }
    let need = target - lambda0;
    let slope = e2 - need * h;
    (slope > 0.0)
        .then(|| (need / slope).ceil())
        .filter(|m| *m <= MAX_SPECIMENS as f64)
        .map(|m| (m as usize).max(1))
}

fn lambda_at(lambda0: f64, e2: f64, h: f64, m: f64) -> f64 {
    lambda0 + m * e2 / (1.0 + m * h)
}

/// The hardest direction at one design: specimens needed, the bound on λ as they grow, the pair,
/// and λ with those specimens.
type Limit = (Option<usize>, f64, (usize, usize), f64);

/// The design needing the fewest specimens over every compared pair (T-optimal discrimination).
fn fewest_specimens(cx: &Context, ex: &[Explanation], sigma: &Sigma, target: f64) -> Option<Pick> {
    let unit = if cx.known() { 1.0 } else { 1.0 / sigma(1.0) };
    // Each pair, with the directions that count: both for two candidates, the candidate as true
    // against the uncorrected model.
    let mut pairs: Vec<((usize, usize), Vec<Discriminant>)> = Vec::new();
    for a in 0..ex.len() {
        for b in a + 1..ex.len() {
            // A model whose shapes are all in the other's (the uncorrected one; the model a found
            // term extends) is nested in it: only the larger as true counts.
            let nested = |k: usize, m: usize| {
                let outer = ex[m].entry.model.shapes();
                let within = |s: &&super::Shape| outer.iter().any(|o| o.name == s.name && o.term == s.term);
                ex[k].entry.model.shapes().iter().all(within)
            };
            let dirs: Vec<(usize, usize)> = match (nested(a, b), nested(b, a)) {
                (false, true) => vec![(a, b)],
                (true, false) => vec![(b, a)],
                _ => vec![(a, b), (b, a)],
            };
            let ds: Vec<Discriminant> = dirs
                .iter()
                .filter_map(|&(t, r)| Discriminant::new(cx, &ex[t], &ex[r], unit))
                .collect();
            if !ds.is_empty() {
                pairs.push(((a, b), ds));
            }
        }
    }
    let mut best: Option<(Option<usize>, f64, Pick)> = None;
    for d in candidate_points(cx) {
        // For each pair, its weakest direction: specimens needed and the bound as m grows.
        let mut worst: Option<Limit> = None;
        for (pair, ds) in &pairs {
            for disc in ds {
                let (e2, h) = disc.row(cx, &d, sigma);
                if !(e2.is_finite() && h.is_finite()) {
                    continue;
                }
                let m = specimens_for(disc.lambda0, e2, h, target);
                let bound = if h > 0.0 { disc.lambda0 + e2 / h } else { f64::INFINITY };
                let harder = |w: &Limit| match (m, w.0) {
                    (None, Some(_)) => true,
                    (Some(a), Some(b)) => a > b,
                    (None, None) => bound < w.1,
                    (Some(_), None) => false,
                };
                if worst.as_ref().is_none_or(harder) {
                    let lam = m.map_or(bound, |m| lambda_at(disc.lambda0, e2, h, m as f64));
                    worst = Some((m, bound, *pair, lam));
                }
            }
        }
        let Some((m, bound, pair, lam)) = worst else { continue };
        let better = |b: &(Option<usize>, f64, Pick)| match (m, b.0) {
            (Some(x), Some(y)) => x < y,
            (Some(_), None) => true,
            (None, Some(_)) => false,
            (None, None) => bound > b.1,
        };
        if best.as_ref().is_none_or(better) {
            let (ya, yb) = (ex[pair.0].predict(cx, &d), ex[pair.1].predict(cx, &d));
            let gap = (ya - yb).abs() / (0.5 * (ya.abs() + yb.abs())).max(f64::MIN_POSITIVE);
            best = Some((
                m,
                bound,
                Pick {
                    design: d,
                    pair,
                    specimens: m,
                    lambda: lam,
                    gap,
                },
            ));
        }
    }
    best.map(|b| b.2)
}

/// Without a noise: the design where the closest pair differs most, relatively.
fn widest_gap(cx: &Context, ex: &[Explanation]) -> Option<Pick> {
    let mut best: Option<Pick> = None;
    for d in candidate_points(cx) {
        let y: Vec<f64> = ex.iter().map(|e| e.predict(cx, &d)).collect();
        let mut closest: Option<(f64, (usize, usize))> = None;
        for a in 0..ex.len() {
            for b in a + 1..ex.len() {
                let gap = (y[a] - y[b]).abs() / (0.5 * (y[a].abs() + y[b].abs())).max(f64::MIN_POSITIVE);
                if closest.is_none_or(|c| gap < c.0) {
                    closest = Some((gap, (a, b)));
                }
            }
        }
        if let Some((gap, pair)) = closest.filter(|c| c.0.is_finite())
            && best.as_ref().is_none_or(|b| gap > b.gap)
        {
            best = Some(Pick {
                design: d,
                pair,
                specimens: None,
                lambda: 0.0,
                gap,
            });
        }
    }
    best
}

type Sigma = Box<dyn Fn(f64) -> f64>;

/// σ of one test at a response level: from the replicates, or from the residuals of a ranked
/// diagnosis; `None` when the data give no noise.
fn one_test_sigma(cx: &Context, noise: &NoiseModel) -> Option<Sigma> {
    let from_residuals = noise.kind == NoiseKind::FromResiduals;
    let usable = noise.scale > 0.0 && noise.scale.is_finite() && (!from_residuals || cx.mode == Mode::Ranked);
    usable.then(|| {
        let nm = noise.clone();
        Box::new(move |level: f64| nm.sigma_at(level).max(f64::MIN_POSITIVE)) as Sigma
    })
}

fn candidate_points(cx: &Context) -> Vec<Vec<f64>> {
    let bounds = &cx.inputs.design_bounds;
    let dim = bounds.dim();
    if dim <= 3 {
        let m = cx.inputs.settings.grid_per_axis.max(2);
        (0..m.pow(dim as u32))
            .map(|mut k| {
                (0..dim)
                    .map(|j| {
                        let t = (k % m) as f64 / (m - 1) as f64;
                        k /= m;
                        bounds.lower[j] + t * (bounds.upper[j] - bounds.lower[j])
                    })
                    .collect()
            })
            .collect()
    } else {
        crate::plan::latin_hypercube(cx.inputs.settings.search_points, dim, 0)
            .row_iter()
            .map(|r| bounds.from_unit(&r.transpose()).iter().copied().collect())
            .collect()
    }
}

/// The tested design at `d` (within 1e-6 of the box on every variable), with its specimens.
fn tested_at(cx: &Context, d: &[f64]) -> Option<(String, usize)> {
    let width = cx.inputs.design_bounds.width();
    cx.inputs
        .observations
        .iter()
        .find(|o| {
            o.design
                .iter()
                .zip(d)
                .enumerate()
                .all(|(j, (a, b))| (a - b).abs() <= 1e-6 * width[j].abs().max(1e-12))
        })
        .map(|o| (o.name.clone(), o.count))
}

/// What it takes at the design, in one sentence.
fn advice(
    cx: &Context,
    noise_known: bool,
    specimens: Option<usize>,
    additional: Option<usize>,
    tested: Option<&(String, usize)>,
) -> String {
    let power = 100.0 * cx.inputs.settings.power;
    let alpha = cx.alpha();
    match (noise_known, specimens, additional, tested) {
        (false, ..) => {
            "the noise is unknown (no replicate tests): test at least 3 specimens there, so that the scatter \
                        is measured as well"
                .to_string()
        }
        (true, Some(_), Some(0), Some((name, n))) => format!(
            "the {n} specimen(s) already tested at {name} should tell them apart (power {power:.0} % at α = {alpha}): \
             the data in hand carry the answer"
        ),
        (true, Some(m), Some(add), Some((name, n))) => format!(
            "{add} more specimen(s) at {name} ({m} with the {n} tested) give power {power:.0} % at α = {alpha} to tell \
             them apart"
        ),
        (true, Some(m), _, None) => {
            format!("{m} specimen(s) there give power {power:.0} % at α = {alpha} to tell them apart")
        }
        _ => format!(
            "no number of specimens at one design makes the difference decisive (power {power:.0} % at α = {alpha}): the \
             existing tests pin the explanations' parameters too loosely, so each can bend to a new point; tests at \
             further designs, wider design bounds, or an independent measurement of the parameters are needed"
        ),
    }
}

fn why(
    design: &IndexMap<String, f64>,
    compared: &IndexMap<String, f64>,
    (ya, yb): (f64, f64),
    noise_known: bool,
    tested: Option<&(String, usize)>,
    advice: &str,
) -> String {
    let at = design
        .iter()
        .map(|(n, v)| format!("{n} = {}", text::num(*v)))
        .collect::<Vec<_>>()
        .join(", ");
    let preds = compared
        .iter()
        .map(|(n, y)| format!("'{n}' {}", text::num(*y)))
        .collect::<Vec<_>>()
        .join(", ");
    let rel = (ya - yb).abs() / (0.5 * (ya.abs() + yb.abs())).max(f64::MIN_POSITIVE);
    let place = match tested {
        Some((name, n)) => format!("{at} (already tested as {name}, {n} specimen(s))"),
        None => format!("{at} (not tested yet)"),
    };
    let chosen = if noise_known {
        "the design inside the bounds where the fewest specimens would tell them apart"
    } else {
        "the widest such gap inside the design bounds"
    };
    format!(
        "Test at {place}: there {preds}; the closest two are {} apart, {chosen}. In numbers: {advice}.",
        text::pct_pub(rel)
    )
}
