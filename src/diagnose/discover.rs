//! Discovery: when no listed cause explains the misfit, a search over a library of physically
//! sensible shapes for the missing term, held to the same evidence as a listed cause.
//!
//! Sparse model discovery (Brunton, Proctor & Kutz 2016, "Discovering governing equations from
//! data by sparse identification of nonlinear dynamical systems", PNAS 113(15), 3932–3937: SINDy)
//! finds the missing term of a physical law from few data when the library of candidate terms is
//! sensible and the selection is honest about having searched. With a library of tens of shapes
//! and at most two terms, best-subset selection is the small-library equivalent of its sequential
//! thresholding, and it is what this module does, with the diagnosis's own fits and tests:
//!
//! 1. **When.** Model error is detected, `discover` is on, and either the study lists no
//!    hypothesis, or the verdict is "partly explained" or "no listed cause explains it". The
//!    verdict stays the listed hypotheses' verdict; what the search finds is reported beside it,
//!    as found by search, not listed.
//! 2. **Base.** The uncorrected model; or, when a listed cause partly explains the misfit, that
//!    cause's model, its shape kept in: the search then looks for the term to add to it.
//! 3. **Library** ([`super::library`]): shapes evaluated at the base fit; one not finite at every
//!    training design, or vanishing there, is dropped with the reason; one numerically identical to
//!    an earlier one (or to the base's shape) is the same model (equality to 1e-9, not a judgement)
//!    and is listed beside it (`1/h` and `y*h^2` on a cantilever whose y ∝ h⁻³). L distinct shapes
//!    remain; with pairs, the search covers M = L + L(L−1)/2 models.
//! 4. **Selection by leave-one-design-out prediction error, θ refitted each time.** Every single
//!    term and every pair is first scored by the leave-one-out residuals of its model linearised at
//!    the base fit (one Gauss–Newton step: the columns ∂ŷ/∂θ, the base's shapes and the terms; exact
//!    leave-one-out residuals e_i/(1 − h_ii) of that linear fit). The best [`SHORTLIST_SINGLES`]
//!    singles and [`SHORTLIST_PAIRS`] pairs are then fitted for real ([`super::fit::Data::fit`]: θ and
//!    the amplitudes) with a refit of θ and γ for each design left out
//!    ([`super::fit::Data::leave_one_out`]). The linearisation only orders the search; every number
//!    that decides or is reported comes from the nonlinear fits. The winner is the eligible model
//!    with the smallest weighted leave-one-out error; *eligible*: significant against the base after
//!    the correction below, and, for a pair, each term still significant with the other in, at
//!    α/(L − 1) (the rule of step 6 applied to the pair's own terms).
//! 5. **Correction for searching: Bonferroni over the M models searched, α/M.** The winner's
//!    extra-sum-of-squares F test against the base (the diagnosis's [`super::Context::drop_test`],
//!    on the 1 or 2 numbers it adds) must have p < α/M. Under no model error beyond the base, the
//!    probability that *any* of the M models passes is at most α, whatever the dependence between
//!    them and however the winner was picked: the family-wise rate of false discovery is ≤ α = 1 %
//!    by construction (the union bound), and it does not rest on the linear screening having looked
//!    at every model. Chosen over a permutation or parametric-bootstrap calibration of the maximum
//!    statistic because that would need B × M refits (B ≥ 100 to resolve α = 0.01; the designs are
//!    few and replicated, so permuting designs is also coarse) against a budget of one second, and
//!    because it holds without replicates, where the noise comes from each fit's own residuals.
//!    Its price is power when the shapes are strongly correlated (they are: the library's shapes are
//!    smooth), and that price is paid only in the size of effect needed, not in false discoveries.
//! 6. **The diagnosis's rules, after the correction.** The winner must leave nothing another library
//!    shape still explains: no rival r, added to it, reduces the misfit at α/(L − |W|) (Bonferroni
//!    over the rivals, as the verdict's "partly explained" rule). When one does and the winner is a
//!    single term, the pair with that rival is judged instead (same rules). And, with replicates,
//!    its model's lack of fit against the replicate noise (training residuals and the validation
//!    designs' predictive residuals, [`super::evidence`]) must not reject at α. Otherwise nothing
//!    in the library explains the misfit, and the closest models are listed with why they fall short.
//! 7. **Shapes the data cannot separate.** Over a narrow design range many library shapes are
//!    nearly collinear (1/h, 1/h², h^(−1/2) over h = 7…13). A rival r is *alike* a found term s when
//!    s, added to the model with r in its place, does not reduce the misfit at α: the encompassing
//!    test the ranking uses to say "cannot tell apart" (Davidson & MacKinnon 1981), decided by the
//!    data, never by an angle. The term is reported as the best of its group ("a 1/h-like term:
//!    1/h; 1/h^2, 1/h^(1/2) fit equally").
//! 8. **Reading.** Where the found shape matches a known physical form relative to the simulation
//!    (local power-law exponents of g/y against those of y), it is named: ∝ y·h² beside y ∝ h⁻³
//!    (1/h on a cantilever's tip) is shear-like, ∝ y·h a clamp's root rotation, ∝ y·(t/c)^(2/3) on
//!    a honeycomb's crush force hardening-like, a constant an offset, y itself a scale error.

use indexmap::IndexMap;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::candidates::{self, Model};
use super::fit::Fit;
use super::library::{self, Dropped, LibrarySpec};
use super::next_test::Explanation;
use super::ranking::Entry;
use super::shapes::{Origin, Shape};
use super::verdict::{Decision, Verdict, Who};
use super::{Context, Evidence, LackOfFit, Mode, evidence, stats};
use crate::base::format::{num, p_text, pct};

/// Singles fitted for real after the linear screening.
pub const SHORTLIST_SINGLES: usize = 10;
/// Pairs fitted for real after the linear screening.
pub const SHORTLIST_PAIRS: usize = 20;

/// What the search concluded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    /// A term (or two) passed the corrected test and the diagnosis's rules.
    Found,
    /// No shape (or pair) of the library explains the misfit.
    NothingExplains,
}

/// One found term.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FoundTerm {
    pub term: String,
    pub coefficient: f64,
    /// 95 % interval of the coefficient (absent without a covariance).
    pub interval: Option<[f64; 2]>,
    /// Library terms that are the same shape over the tested designs.
    pub same_shape: Vec<String>,
    /// Library terms the data cannot tell from it (the encompassing test at α), best first.
    pub alike: Vec<String>,
}

/// A model of the search that came close, and why it falls short.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Closest {
    pub term: String,
    /// p of its F test against the base (to be compared with `threshold`).
    pub p_value: Option<f64>,
    /// Mean |relative error| of its leave-one-design-out predictions at the training designs.
    pub loo_error: f64,
    pub why: String,
}

/// The library as searched.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LibrarySummary {
    /// The exponents of the power laws, as written in terms.
    pub exponents: Vec<String>,
    /// Distinct shapes searched (L).
    pub size: usize,
    /// Models searched: L singles and, when the designs allow two terms, L(L−1)/2 pairs (M).
    pub models: usize,
    /// Shapes left out, with the reason (units, not finite, vanishing, the base's own shape).
    pub dropped: Vec<Dropped>,
    /// Library terms that are the same shape over the tested designs as a searched one.
    pub same_shape: IndexMap<String, Vec<String>>,
}

/// `diagnosis.discovered`: the library search and what it found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Discovered {
    /// What the search found: its outcome, the term, its coefficient and the parameters with it.
    #[serde(flatten)]
    pub found: FoundFit,
    /// The found term in words: its reading, name, terms and shape.
    #[serde(flatten)]
    pub named: FoundName,
    /// The search's test: against which base, its p-value and the threshold its size pays for.
    #[serde(flatten)]
    pub test: SearchTest,
    /// How the model with the found term predicts and fits.
    #[serde(flatten)]
    pub checks: FoundChecks,
    /// The nearest library terms, the library searched, and the evidence in words.
    #[serde(flatten)]
    pub search: SearchRecord,
}

/// What the search found: its outcome, the term, its coefficient and the parameters with it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FoundFit {
    pub outcome: Outcome,
    /// The found term as a study term (two terms: `a + c*(b)`, c the ratio of their coefficients);
    /// `null` when nothing was found.
    pub term: Option<String>,
    /// The (first) term's coefficient and its 95 % interval.
    pub coefficient: Option<f64>,
    pub interval: Option<[f64; 2]>,
    /// The parameters calibrated with the term (empty when nothing was found).
    pub parameters: IndexMap<String, f64>,
    /// 1 − after / before of the mean |relative error| on `measured_on` (the validation designs,
    /// else leave-one-design-out), against the base.
    pub gain: Option<f64>,
}

/// The found term in words: its reading, name, terms and shape.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FoundName {
    /// The physical form the shape matches, in words (absent when none is known).
    pub reading: Option<String>,
    /// The name the hypothesis line gives it (`found 1/h`).
    pub name: Option<String>,
    /// The found terms with their coefficients and the shapes the data cannot tell them from.
    pub terms: Vec<FoundTerm>,
    /// The shape in words: "a 1/h-like term: ...".
    pub shape: Option<String>,
    /// The lines to paste under `diagnosis.hypotheses` to test it as a listed cause.
    pub hypothesis_line: Option<String>,
}

/// The search's test: against which base, its p-value and the threshold its size pays for.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SearchTest {
    /// What the search started from: `uncorrected`, or the listed cause it extends.
    pub base: String,
    /// p of the found model's F test against the base.
    pub p_value: Option<f64>,
    /// α/M: the level the winner's test had to beat.
    pub threshold: f64,
    /// The correction for the size of the search, in words.
    pub correction: String,
}

/// How the model with the found term predicts and fits.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FoundChecks {
    pub validation_error_before: Option<f64>,
    pub validation_error_after: Option<f64>,
    pub measured_on: Option<String>,
    pub loo_error_before: Option<f64>,
    pub loo_error_after: Option<f64>,
    pub gain_loo: Option<f64>,
    /// The found model's lack of fit against the replicate noise (absent without replicates).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub lack_of_fit: Option<LackOfFit>,
}

/// The nearest library terms, the library searched, and the evidence in words.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SearchRecord {
    /// The models that came closest, best first (when nothing was found: why each falls short).
    pub closest: Vec<Closest>,
    pub library: LibrarySummary,
    /// The search in words, one fact per line (the first also leads the diagnosis's evidence).
    pub evidence: Vec<String>,
}

/// The search's result and the found model as an explanation for the next test.
pub(crate) struct Search<'a> {
    pub discovered: Discovered,
    /// The found model (its name, and the fitted model with its evidence).
    pub found: Option<(String, Entry)>,
    base: Base<'a>,
}

impl Search<'_> {
    /// The found model and its base, for the next test to tell apart (empty when nothing was
    /// found): the found model nests its base.
    pub fn compared(&self) -> Vec<Explanation<'_>> {
        let Some((name, entry)) = &self.found else {
            return Vec::new();
        };
        let b = &self.base;
        let found = Explanation::from_entry(b.cx, entry, name.clone(), false);
        let base = Explanation::from_entry(b.cx, b.entry, b.name.clone(), b.uncorrected);
        match &b.simulated_by {
            Some(h) => vec![found.simulated_by(h), base.simulated_by(h)],
            None => vec![found, base],
        }
    }
}

/// One model of the search: library terms (indices into the kept shapes) added to the base.
#[derive(Clone)]
struct Tried {
    terms: Vec<usize>,
    fit: Fit,
    /// Leave-one-design-out predictions at the training designs (when computed).
    loo: Option<Vec<f64>>,
    /// p of the F test against the base.
    p: Option<f64>,
}

impl Tried {
    fn press(&self, cx: &Context) -> f64 {
        self.loo.as_ref().map_or(f64::INFINITY, |loo| cx.press(loo))
    }

    fn loo_error(&self, cx: &Context) -> f64 {
        self.loo.as_ref().map_or(f64::NAN, |loo| cx.loo_error(loo))
    }
}

/// The search's working set: the base, the distinct shapes and the fits shared between steps.
struct Searcher<'a> {
    cx: &'a Context<'a>,
    base: &'a Model,
    base_shapes: Vec<Shape>,
    shapes: Vec<Shape>,
    /// Exact single fits (base + one term), by shape.
    singles: Vec<Option<Fit>>,
}

impl Searcher<'_> {
    /// The shapes of a model: its terms first, then the base's.
    fn shapes_of(&self, terms: &[usize]) -> Vec<&Shape> {
        terms
            .iter()
            .map(|&t| &self.shapes[t])
            .chain(&self.base_shapes)
            .collect()
    }

    fn k(&self, terms: &[usize]) -> usize {
        self.cx.p() + self.base_shapes.len() + terms.len()
    }

    fn dof(&self, terms: &[usize]) -> usize {
        self.cx.train.len().saturating_sub(self.k(terms))
    }

    /// Fitted from a warm start (the base's θ, or a smaller model's).
    fn fit(&self, terms: &[usize], from: &DVector<f64>) -> Option<Fit> {
        self.cx.data.fit_from(&self.shapes_of(terms), &self.cx.train, from).ok()
    }

    /// p of the drop from `smaller` to `larger` (its extra numbers).
    fn drop_p(&self, smaller: f64, larger: &Fit, larger_terms: &[usize], extra: usize) -> Option<f64> {
        self.cx
            .drop_test(smaller - larger.wrss, extra, larger.wrss, self.dof(larger_terms))
    }

    fn tried(&self, terms: Vec<usize>, fit: Fit, with_loo: bool) -> Tried {
        let p = self.drop_p(self.base.fit.wrss, &fit, &terms, terms.len());
        let loo = with_loo
            .then(|| {
                self.cx
                    .data
                    .leave_one_out(&self.shapes_of(&terms), &self.cx.train, &fit.theta)
                    .ok()
            })
            .flatten();
        Tried { terms, fit, loo, p }
    }

    fn term_of(&self, t: &Tried) -> String {
        t.terms
            .iter()
            .map(|&k| self.shapes[k].term.clone())
            .collect::<Vec<_>>()
            .join(" + ")
    }
}

/// Runs the search once the decision is final (the screening's, or the decision after the loop:
/// see the module notes), when it calls for one; `None` otherwise.
pub(crate) fn run<'a>(
    screening: &'a Evidence<'a>,
    looped: &'a [Evidence<'a>],
    loop_names: &[String],
    decision: &Decision,
    notes: &mut Vec<String>,
) -> Option<Search<'a>> {
    let inputs = screening.cx.inputs;
    let Some(spec) = &inputs.library else {
        return None;
    };
    if !(decision.detected || inputs.settings.search_without_detection) {
        return None;
    }
    let listed = !inputs.hypotheses.is_empty();
    if listed && decision.detected && !matches!(decision.verdict, Verdict::PartlyExplained | Verdict::Unexplained) {
        return None;
    }
    // The base: the listed cause that partly explains the misfit (the loop's extended model where
    // the loop calibrated it), else the uncorrected model. A built-in cause (offset, scale, a
    // linear trend) is itself a library shape: the search starts without it and may pair it.
    let cause = decision
        .cause
        .filter(|_| listed && decision.verdict == Verdict::PartlyExplained);
    let is_listed = |k: usize| {
        let shape = screening.ranked.entries[k].model.shape.as_ref();
        shape.is_some_and(|s| s.origin == Origin::Study)
    };
    let fitted = |cx, entry: &'a Entry| Base {
        cx,
        entry,
        name: entry.model.name().to_string(),
        uncorrected: false,
        simulated_by: None,
    };
    let base = match cause {
        Some(Who::Candidate(k)) if is_listed(k) => fitted(&screening.cx, &screening.ranked.entries[k]),
        Some(Who::Extended(j)) => Base {
            name: loop_names[j].clone(),
            simulated_by: Some(loop_names[j].clone()),
            ..fitted(&looped[j].cx, &looped[j].ranked.base)
        },
        // The uncorrected model's name is `uncorrected`.
        _ => Base {
            uncorrected: true,
            ..fitted(&screening.cx, &screening.ranked.base)
        },
    };
    search(base, spec, notes)
}

/// What the search starts from: a fitted model in its own context.
pub(crate) struct Base<'a> {
    cx: &'a Context<'a>,
    entry: &'a Entry,
    name: String,
    /// The study's simulation alone.
    uncorrected: bool,
    /// The loop's extended model is the simulation (the hypothesis it extends).
    simulated_by: Option<String>,
}

/// The library as the search sees it at the base fit: the distinct shapes kept (with their
/// weighted vectors at the training designs), and what was dropped or merged as the same shape.
struct Kept {
    shapes: Vec<Shape>,
    vectors: Vec<Vec<f64>>,
    dropped: Vec<Dropped>,
    same_shape: IndexMap<String, Vec<String>>,
    exponents: Vec<String>,
}

/// How many models the search may try, and the corrected threshold that pays for them.
struct Size {
    /// Distinct single terms.
    l: usize,
    singles: bool,
    pairs: bool,
    /// M: the singles, and the pairs when the designs allow them.
    models: usize,
    /// α / M.
    threshold: f64,
}

/// What the judging of the shortlist produced: the first model that passed, and those that fell
/// short (with why), in the order judged.
struct Judged {
    winner: Option<Passed>,
    failed: Vec<(Tried, String)>,
}

/// The search from `base` over the library `spec` describes, step by step: the library at the
/// base fit ([`kept`]), its size and correction ([`size`]), the shortlist by leave-one-design-out
/// error ([`shortlist`]), the rules in that order ([`judge_shortlist`]), and the record.
fn search<'a>(b: Base<'a>, spec: &LibrarySpec, notes: &mut Vec<String>) -> Option<Search<'a>> {
    let cx = b.cx;
    if cx.mode != Mode::Ranked {
        notes.push(format!(
            "no library search: {} training design(s) for {} parameter(s) leave no design to spare for \
             leave-one-design-out selection",
            cx.train.len(),
            cx.p()
        ));
        return None;
    }
    let base = &b.entry.model;
    let base_shapes: Vec<Shape> = base.shapes().into_iter().cloned().collect();
    let kept = kept(cx, base, &base_shapes, &b.name, spec);
    let size = size(cx, base_shapes.len(), kept.shapes.len());
    if !size.singles {
        notes.push(format!(
            "no library search: {} training design(s) cannot fit a term beside {} parameter(s) and leave one out",
            cx.train.len(),
            cx.p()
        ));
        return None;
    }
    let mut s = Searcher {
        cx,
        base,
        base_shapes,
        shapes: kept.shapes,
        singles: Vec::new(),
    };
    let theta0 = base.fit.theta.clone();
    s.singles = (0..size.l).into_par_iter().map(|t| s.fit(&[t], &theta0)).collect();
    let tried = shortlist(&s, &kept.vectors, size.pairs);
    let judged = judge_shortlist(&s, &tried, &size, &kept.vectors);
    let summary = LibrarySummary {
        exponents: kept.exponents,
        size: size.l,
        models: size.models,
        dropped: kept.dropped,
        same_shape: kept.same_shape,
    };
    let mut discovered = empty_record(&b, &size, summary);
    let mut found = None;
    let mut found_terms: Vec<usize> = Vec::new();
    if let Some(Passed {
        tried: w,
        model,
        assessed,
        adds,
    }) = judged.winner
    {
        discovered.checks.lack_of_fit = assessed.lack_of_fit.clone();
        discovered.test.p_value = w.p;
        found = Some(finish(&s, &w, model, assessed, &adds, &mut discovered));
        found_terms = w.terms.clone();
    }
    discovered.search.closest = closest(&s, &tried, &judged.failed, &found_terms, &size);
    discovered.search.evidence = words(&discovered, size.l, size.pairs);
    Some(Search {
        discovered,
        found,
        base: b,
    })
}

/// The library at the base fit: a shape not finite or vanishing at the training designs, or the
/// same over them as one of the base's shapes, is dropped; shapes the same as one already kept are
/// merged into it.
fn kept(cx: &Context, base: &Model, base_shapes: &[Shape], base_name: &str, spec: &LibrarySpec) -> Kept {
    let built = library::build(&cx.inputs.space.design_names, spec);
    let same_cosine = cx.inputs.settings.same_shape_cosine;
    let mut dropped = built.dropped.clone();
    let mut same_shape: IndexMap<String, Vec<String>> = IndexMap::new();
    let base_vectors: Vec<Vec<f64>> = base_shapes
        .iter()
        .map(|s| candidates::shape_vector(cx, s, base))
        .collect();
    let mut kept: Vec<(Shape, Vec<f64>)> = Vec::new();
    for shape in built.shapes {
        let v = candidates::shape_vector(cx, &shape, base);
        let same = |w: &Vec<f64>| stats::cosine(w, &v).abs() > same_cosine;
        let reason = if v.iter().any(|x| !x.is_finite()) {
            Some("not finite at every training design".to_string())
        } else if v.iter().all(|&x| x == 0.0) {
            Some("vanishes at every training design".to_string())
        } else if base_vectors.iter().any(same) {
            Some(format!(
                "the same shape over the training designs as the base '{base_name}'"
            ))
        } else {
            None
        };
        if let Some(reason) = reason {
            dropped.push(Dropped {
                term: shape.term.clone(),
                reason,
            });
        } else if let Some((first, _)) = kept.iter().find(|(_, w)| same(w)) {
            same_shape
                .entry(first.term.clone())
                .or_default()
                .push(shape.term.clone());
        } else {
            kept.push((shape, v));
        }
    }
    let (shapes, vectors) = kept.into_iter().unzip();
    Kept {
        shapes,
        vectors,
        dropped,
        same_shape,
        exponents: built.exponents.iter().map(|&a| library::exponent_text(a)).collect(),
    }
}

/// Singles need a design to spare beside θ and the base's shapes (two without replicates), pairs
/// one more; M counts what can be tried, and α/M pays for it (Bonferroni).
fn size(cx: &Context, base_shapes: usize, l: usize) -> Size {
    let n = cx.train.len();
    let fits_with = |extra: usize| {
        let k = cx.p() + base_shapes + extra;
        n > k && (cx.known() || n > k + 1)
    };
    let (singles, pairs) = (fits_with(1) && l > 0, fits_with(2) && l > 1);
    let models = if pairs { l + l * (l - 1) / 2 } else { l };
    Size {
        l,
        singles,
        pairs,
        models,
        threshold: cx.levels().searched(models),
    }
}

/// The correction in words.
fn correction_text(size: &Size, alpha: f64) -> String {
    format!(
        "Bonferroni over the M = {} models searched ({} single terms{}): the winner's F test against the base \
         must have p < α/M = {} (α = {alpha}), so that on data without model error beyond the base the chance of any \
         discovery is at most α",
        size.models,
        size.l,
        if size.pairs {
            format!(" and {} pairs", size.l * (size.l - 1) / 2)
        } else {
            String::new()
        },
        num(size.threshold)
    )
}

/// The shortlist: the singles and pairs best by their linearised leave-one-out error, fitted
/// exactly with their leave-one-out predictions, best first.
fn shortlist(s: &Searcher, vectors: &[Vec<f64>], pairs_ok: bool) -> Vec<Tried> {
    let screened = screen(s, vectors, pairs_ok);
    let take = |len: usize, count: usize| {
        screened
            .iter()
            .filter(move |(t, _)| t.len() == len)
            .take(count)
            .map(|(t, _)| t.clone())
    };
    let theta0 = &s.base.fit.theta;
    let mut tried: Vec<Tried> = take(1, SHORTLIST_SINGLES)
        .chain(take(2, SHORTLIST_PAIRS))
        .collect::<Vec<_>>()
        .into_par_iter()
        .filter_map(|terms| {
            let fit = match terms.as_slice() {
                [t] => s.singles[*t].clone()?,
                _ => s.fit(&terms, theta0)?,
            };
            Some(s.tried(terms, fit, true))
        })
        .collect();
    tried.sort_by(|a, b| a.press(s.cx).total_cmp(&b.press(s.cx)));
    tried
}

/// α over the rivals of a model with `w` terms.
fn rivals_alpha(s: &Searcher, w: usize) -> f64 {
    s.cx.levels().rival(s.shapes.len().saturating_sub(w))
}

/// A model may be judged: its F test against the base passes α/M, and a pair's terms each still
/// reduce the misfit with the other in.
fn eligible(s: &Searcher, t: &Tried, threshold: f64) -> bool {
    t.p.is_some_and(|p| p < threshold)
        && match t.terms.as_slice() {
            [a, b] => [b, a].iter().all(|&&other| {
                s.singles[other]
                    .as_ref()
                    .and_then(|o| s.drop_p(o.wrss, &t.fit, &t.terms, 1))
                    .is_some_and(|p| p < rivals_alpha(s, 1))
            }),
            _ => true,
        }
}

/// Judged in order of leave-one-design-out error: the eligible singles first; a pair only when no
/// single suffices (each single with the rival that still reduces the misfit with it in, and the
/// shortlisted pairs). The first model that passes the diagnosis's rules is found. Which eligible
/// model is judged first changes nothing in the correction: a discovery needs its own p < α/M, so
/// the union bound over the M models holds however the order is made.
fn judge_shortlist(s: &Searcher, tried: &[Tried], size: &Size, vectors: &[Vec<f64>]) -> Judged {
    let ok = |t: &Tried| eligible(s, t, size.threshold);
    let mut pool: Vec<Tried> = tried.iter().filter(|t| t.terms.len() == 2 && ok(t)).cloned().collect();
    let mut failed: Vec<(Tried, String)> = Vec::new();
    for w in tried.iter().filter(|t| t.terms.len() == 1 && ok(t)) {
        match judge(s, w, rivals_alpha(s, 1), vectors) {
            Judgement::Pass(p) => {
                return Judged {
                    winner: Some(*p),
                    failed,
                };
            }
            Judgement::Fail { why, adder } => {
                if let Some((r, fit)) = adder.filter(|_| size.pairs) {
                    let pair = s.tried(vec![w.terms[0], r], fit, true);
                    let same = |t: &Tried| t.terms.contains(&w.terms[0]) && t.terms.contains(&r);
                    if ok(&pair) && !pool.iter().any(same) {
                        pool.push(pair);
                    }
                }
                failed.push((w.clone(), why));
            }
        }
    }
    if size.pairs {
        pool.sort_by(|a, b| a.press(s.cx).total_cmp(&b.press(s.cx)));
        for w in &pool {
            match judge(s, w, rivals_alpha(s, 2), vectors) {
                Judgement::Pass(p) => {
                    return Judged {
                        winner: Some(*p),
                        failed,
                    };
                }
                Judgement::Fail { why, .. } => failed.push((w.clone(), why)),
            }
        }
    }
    Judged { winner: None, failed }
}

/// The record before anything is found: the base's errors, the library, the correction.
fn empty_record(b: &Base, size: &Size, library: LibrarySummary) -> Discovered {
    let e = b.entry;
    Discovered {
        found: FoundFit {
            outcome: Outcome::NothingExplains,
            term: None,
            coefficient: None,
            interval: None,
            parameters: IndexMap::new(),
            gain: None,
        },
        named: FoundName {
            reading: None,
            name: None,
            terms: Vec::new(),
            shape: None,
            hypothesis_line: None,
        },
        test: SearchTest {
            base: b.name.clone(),
            p_value: None,
            threshold: size.threshold,
            correction: correction_text(size, b.cx.alpha()),
        },
        checks: FoundChecks {
            validation_error_before: e.assessed.validation.as_ref().map(|v| v.error),
            validation_error_after: None,
            measured_on: None,
            loo_error_before: e.score.as_ref().and_then(|x| x.loo_error),
            loo_error_after: None,
            gain_loo: None,
            lack_of_fit: None,
        },
        search: SearchRecord {
            closest: Vec::new(),
            library,
            evidence: Vec::new(),
        },
    }
}

/// The models that came closest, best first: those judged and short of the rules, then the
/// closest others (beside a found model, those that do without its terms).
fn closest(s: &Searcher, tried: &[Tried], failed: &[(Tried, String)], found: &[usize], size: &Size) -> Vec<Closest> {
    let cx = s.cx;
    let mut out: Vec<Closest> = failed
        .iter()
        .take(3)
        .map(|(t, why)| Closest {
            term: s.term_of(t),
            p_value: t.p,
            loo_error: t.loo_error(cx),
            why: format!("passes the corrected test, but {why}"),
        })
        .collect();
    let contains = |a: &[usize], b: &[usize]| !b.is_empty() && b.iter().all(|t| a.contains(t));
    for t in tried.iter().filter(|t| !contains(&t.terms, found)) {
        if out.len() >= 3 {
            break;
        }
        let term = s.term_of(t);
        if out.iter().any(|c| c.term == term) {
            continue;
        }
        let threshold = size.threshold;
        let why = match t.p {
            Some(p) if p >= threshold => format!("{} ≥ α/M = {}", p_text(p), num(threshold)),
            None => "no test (no noise estimate)".to_string(),
            Some(_) if !eligible(s, t, threshold) => "one of its two terms adds nothing beyond the other".to_string(),
            Some(_) => "a model with a smaller leave-one-design-out error was preferred".to_string(),
        };
        out.push(Closest {
            term,
            p_value: t.p,
            loo_error: t.loo_error(cx),
            why,
        });
    }
    out
}

/// A model that passed the diagnosis's rules: its fit from every start, its evidence, and every
/// other library shape added to it.
struct Passed {
    tried: Tried,
    model: Model,
    assessed: evidence::Assessed,
    adds: Vec<(usize, Fit, Option<f64>)>,
}

enum Judgement {
    Pass(Box<Passed>),
    /// Why it falls short, and the rival that still adds to it (with the fit of both).
    Fail {
        why: String,
        adder: Option<(usize, Fit)>,
    },
}

/// Rivals whose exact fit a cheap judgement refits: the best by the linearised drop.
const ADDERS_REFITTED: usize = 4;

/// The diagnosis's rules for an eligible model `w`: no other library shape still reduces the misfit
/// with it in (at `bound`: α over the rivals), and, with replicates, its model's lack of fit does
/// not reject at α.
///
/// In two stages, the second only for a model that passes the first: (1) its lack of fit at its
/// own fit, and the [`ADDERS_REFITTED`] rivals that would reduce its misfit most linearised at that
/// fit ([`linear_adders`]), refitted exactly; (2) every rival refitted exactly, the model refitted
/// from every start, its lack of fit again. Every rule that decides a discovery is thus applied
/// exactly; the first stage only spares the full set of refits for the models that fall short.
fn judge(s: &Searcher, w: &Tried, bound: f64, vectors: &[Vec<f64>]) -> Judgement {
    let cx = s.cx;
    let adder_fails = |adds: &[(usize, Fit, Option<f64>)]| {
        best_adder(adds)
            .filter(|(_, _, p)| *p < bound)
            .map(|(r, fit, p)| Judgement::Fail {
                why: format!(
                    "'{}' still reduces the misfit with it in ({} < α/{} = {})",
                    s.shapes[r].term,
                    p_text(p),
                    s.shapes.len().saturating_sub(w.terms.len()),
                    num(bound)
                ),
                adder: Some((r, fit)),
            })
    };
    let model_of = |fit: Fit| {
        let mut terms_shapes: Vec<Shape> = w.terms.iter().map(|&t| s.shapes[t].clone()).collect();
        let first = terms_shapes.remove(0);
        Model {
            shape: Some(first),
            more: terms_shapes.into_iter().chain(s.base_shapes.iter().cloned()).collect(),
            replaces: None,
            fit,
            loo: w.loo.clone(),
        }
    };
    let misses = |assessed: &evidence::Assessed| {
        let l = assessed.lack_of_fit.as_ref().filter(|l| l.rejects())?;
        Some(format!(
            "its model still misses the tests beyond the noise ({})",
            crate::diagnose::text::lack_of_fit(l)
        ))
    };
    // (1) Cheap.
    let first = linear_adders(s, w, vectors);
    let some: Vec<usize> = first.into_iter().take(ADDERS_REFITTED).collect();
    if let Some(fail) = adder_fails(&rivals_added(s, w, &some)) {
        return fail;
    }
    let warm = model_of(w.fit.clone());
    if let Some(why) = misses(&evidence::assess_one(cx, &warm, Some(s.base))) {
        return Judgement::Fail { why, adder: None };
    }
    // (2) Exact.
    let all: Vec<usize> = (0..s.shapes.len()).filter(|r| !w.terms.contains(r)).collect();
    let adds = rivals_added(s, w, &all);
    if let Some(fail) = adder_fails(&adds) {
        return fail;
    }
    let shapes = s.shapes_of(&w.terms);
    let fit = match cx.data.fit(&shapes, &cx.train) {
        Ok(f) if f.wrss < w.fit.wrss => f,
        _ => w.fit.clone(),
    };
    let model = model_of(fit);
    let assessed = evidence::assess_one(cx, &model, Some(s.base));
    if let Some(why) = misses(&assessed) {
        return Judgement::Fail { why, adder: None };
    }
    Judgement::Pass(Box::new(Passed {
        tried: w.clone(),
        model,
        assessed,
        adds,
    }))
}

/// The library shapes not in `w`, best first by the drop in weighted RSS each would give added to
/// `w`, linearised at `w`'s fit: ((I − P_A) v · r)² / ‖(I − P_A) v‖², A the Jacobian of `w`'s
/// model (θ and its amplitudes), r its weighted residuals, v the shape (exact for a model linear
/// in its numbers: one Gauss–Newton step otherwise; v as weighted at the base fit, an ordering only).
fn linear_adders(s: &Searcher, w: &Tried, vectors: &[Vec<f64>]) -> Vec<usize> {
    let cx = s.cx;
    let shapes = s.shapes_of(&w.terms);
    let a = cx.data.jacobian(&shapes, &w.fit, &cx.train);
    let (th, gamma) = (w.fit.theta.as_slice(), w.fit.gamma.as_slice());
    let r = DVector::from_iterator(
        cx.train.len(),
        cx.train.iter().map(|&i| {
            let d = &cx.data.designs[i];
            cx.data.weights[i] * (cx.data.means[i] - cx.data.predict(&shapes, th, gamma, d))
        }),
    );
    let norms: Vec<f64> = a.column_iter().map(|c| c.norm().max(f64::MIN_POSITIVE)).collect();
    let scaled = DMatrix::from_fn(a.nrows(), a.ncols(), |i, j| a[(i, j)] / norms[j]);
    let q = scaled.qr().q();
    let mut scored: Vec<(usize, f64)> = (0..s.shapes.len())
        .filter(|k| !w.terms.contains(k))
        .map(|k| {
            let v = DVector::from_column_slice(&vectors[k]);
            let perp = &v - &q * (q.transpose() * &v);
            let nn = perp.norm_squared();
            let drop = if nn > 1e-20 * v.norm_squared() {
                perp.dot(&r).powi(2) / nn
            } else {
                0.0
            };
            (k, drop)
        })
        .collect();
    scored.sort_by(|a, b| b.1.total_cmp(&a.1));
    scored.into_iter().map(|(k, _)| k).collect()
}

/// The shapes `rivals` (none of `w`'s), each added to `w`: (shape, fit, p of its drop).
fn rivals_added(s: &Searcher, w: &Tried, rivals: &[usize]) -> Vec<(usize, Fit, Option<f64>)> {
    rivals
        .par_iter()
        .copied()
        .filter_map(|r| {
            let mut terms = w.terms.clone();
            terms.push(r);
            let fit = s.fit(&terms, &w.fit.theta)?;
            let p = s.drop_p(w.fit.wrss, &fit, &terms, 1);
            Some((r, fit, p))
        })
        .collect()
}

/// The rival that adds most (smallest p).
fn best_adder(adds: &[(usize, Fit, Option<f64>)]) -> Option<(usize, Fit, f64)> {
    adds.iter()
        .filter_map(|(r, f, p)| p.map(|p| (*r, f.clone(), p)))
        .min_by(|a, b| a.2.total_cmp(&b.2))
}

/// The linearised leave-one-out error of every single and (when allowed) every pair, best first.
fn screen(s: &Searcher, vectors: &[Vec<f64>], pairs: bool) -> Vec<(Vec<usize>, f64)> {
    let cx = s.cx;
    let base_shapes: Vec<&Shape> = s.base_shapes.iter().collect();
    let a = cx.data.jacobian(&base_shapes, &s.base.fit, &cx.train);
    let r = DVector::from_iterator(
        cx.train.len(),
        cx.train
            .iter()
            .map(|&i| cx.data.weights[i] * (cx.data.means[i] - s.base.predict(cx, &cx.data.designs[i]))),
    );
    let l = vectors.len();
    let mut sets: Vec<Vec<usize>> = (0..l).map(|t| vec![t]).collect();
    if pairs {
        for i in 0..l {
            for j in i + 1..l {
                sets.push(vec![i, j]);
            }
        }
    }
    let mut scored: Vec<(Vec<usize>, f64)> = sets
        .into_par_iter()
        .filter_map(|terms| {
            let cols = a.ncols() + terms.len();
            let x = DMatrix::from_fn(r.len(), cols, |i, j| {
                if j < a.ncols() {
                    a[(i, j)]
                } else {
                    vectors[terms[j - a.ncols()]][i]
                }
            });
            linear_press(&x, &r).map(|press| (terms, press))
        })
        .collect();
    scored.sort_by(|a, b| a.1.total_cmp(&b.1));
    scored
}

/// Σ (e_i / (1 − h_ii))² of the least-squares fit of `r` on the columns of `x`: the exact
/// leave-one-out residuals of a linear fit. `None` when the columns are numerically dependent or
/// a row has leverage 1.
fn linear_press(x: &DMatrix<f64>, r: &DVector<f64>) -> Option<f64> {
    let (n, m) = x.shape();
    if n <= m {
        return None;
    }
    let norms: Vec<f64> = x.column_iter().map(|c| c.norm()).collect();
    if norms.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
        return None;
    }
    let scaled = DMatrix::from_fn(n, m, |i, j| x[(i, j)] / norms[j]);
    let qr = scaled.qr();
    let rr = qr.r();
    let diag = rr.diagonal().map(f64::abs);
    if diag.min() < 1e-10 * diag.max() {
        return None;
    }
    let q = qr.q();
    let fitted = &q * (q.transpose() * r);
    let mut press = 0.0;
    for i in 0..n {
        let h = q.row(i).norm_squared();
        if h >= 1.0 - 1e-10 {
            return None;
        }
        press += ((r[i] - fitted[i]) / (1.0 - h)).powi(2);
    }
    Some(press)
}

/// Fills `d` for the found model `w` and returns it as a named entry for the next test.
fn finish(
    s: &Searcher,
    w: &Tried,
    model: Model,
    assessed: evidence::Assessed,
    adds: &[(usize, Fit, Option<f64>)],
    d: &mut Discovered,
) -> (String, Entry) {
    let cx = s.cx;
    let p = cx.p();
    let dof = s.dof(&w.terms);
    let q = stats::t_quantile(0.975, if cx.known() { cx.nu } else { dof } as f64);
    let fit = &model.fit;
    let alike = alike(s, w, adds);
    let terms: Vec<FoundTerm> = w
        .terms
        .iter()
        .enumerate()
        .map(|(k, &t)| {
            let term = s.shapes[t].term.clone();
            let coefficient = fit.gamma[k];
            let interval = assessed.cov.as_ref().map(|c| {
                let se = c.matrix[(p + k, p + k)].max(0.0).sqrt();
                [coefficient - q * se, coefficient + q * se]
            });
            FoundTerm {
                same_shape: d.search.library.same_shape.get(&term).cloned().unwrap_or_default(),
                alike: alike[k].iter().map(|&r| s.shapes[r].term.clone()).collect(),
                term,
                coefficient,
                interval,
            }
        })
        .collect();
    let term = match terms.as_slice() {
        [a] => a.term.clone(),
        [a, b] => format!("{} + {}*({})", a.term, num(b.coefficient / a.coefficient), b.term),
        _ => unreachable!("one or two terms"),
    };
    let name = format!(
        "found {}",
        terms.iter().map(|t| t.term.as_str()).collect::<Vec<_>>().join(" + ")
    );
    let val_after = assessed.validation.as_ref().map(|v| v.error);
    let loo_after = w.loo_error(cx);
    d.found.outcome = Outcome::Found;
    d.found.term = Some(term.clone());
    d.found.coefficient = terms.first().map(|t| t.coefficient);
    d.found.interval = terms.first().and_then(|t| t.interval);
    d.found.parameters = cx.param_map(&fit.theta);
    d.checks.validation_error_after = val_after;
    let (before, after, on) = match (d.checks.validation_error_before, val_after) {
        (Some(b), Some(a)) => (Some(b), Some(a), "validation"),
        _ => (d.checks.loo_error_before, Some(loo_after), "leave-one-out"),
    };
    d.checks.measured_on = Some(on.to_string());
    d.found.gain = before.zip(after).filter(|(b, _)| *b > 0.0).map(|(b, a)| 1.0 - a / b);
    d.checks.loo_error_after = Some(loo_after);
    d.checks.gain_loo = d
        .checks
        .loo_error_before
        .filter(|b| *b > 0.0)
        .map(|b| 1.0 - loo_after / b);
    d.named.reading = terms.iter().find_map(|t| reading_of(s, t));
    d.named.shape = Some(shape_words(&terms));
    d.named.hypothesis_line = Some(format!("- name: {name}\n  term: \"{term}\""));
    d.named.name = Some(name.clone());
    d.named.terms = terms;
    let score = candidates::score(cx, &model, assessed.validation.as_ref().map(|v| v.deviance));
    (
        name,
        Entry {
            model,
            assessed,
            score: Some(score),
            explains: true,
            weight: 0.0,
        },
    )
}

/// For each term of `w`, the rivals the data cannot tell it from, best fitting first.
fn alike(s: &Searcher, w: &Tried, adds: &[(usize, Fit, Option<f64>)]) -> Vec<Vec<usize>> {
    let alpha = s.cx.alpha();
    w.terms
        .iter()
        .map(|&term| {
            let others: Vec<usize> = w.terms.iter().copied().filter(|&t| t != term).collect();
            let mut group: Vec<(usize, f64)> = adds
                .par_iter()
                .filter_map(|(r, both, _)| {
                    // The model with r in the term's place, and the term added back to it.
                    let mut swapped = others.clone();
                    swapped.push(*r);
                    let fit = if others.is_empty() {
                        s.singles[*r].clone()?
                    } else {
                        s.fit(&swapped, &w.fit.theta)?
                    };
                    let mut all = swapped.clone();
                    all.push(term);
                    let p = s.drop_p(fit.wrss, both, &all, 1)?;
                    (p >= alpha).then_some((*r, fit.wrss))
                })
                .collect();
            group.sort_by(|a, b| a.1.total_cmp(&b.1));
            group.into_iter().map(|(r, _)| r).collect()
        })
        .collect()
}

/// "'1/h', a 1/h-like term (y*h^2 is the same shape over these designs; 1/h^2, 1/h^(1/2) fit
/// equally: the data cannot tell them apart)".
fn shape_words(terms: &[FoundTerm]) -> String {
    let one = |t: &FoundTerm| {
        let mut notes = Vec::new();
        if !t.same_shape.is_empty() {
            notes.push(format!(
                "{} {} the same shape over these designs",
                t.same_shape.join(", "),
                if t.same_shape.len() == 1 { "is" } else { "are" }
            ));
        }
        if !t.alike.is_empty() {
            let shown: Vec<&str> = t.alike.iter().take(4).map(String::as_str).collect();
            let more = t.alike.len().saturating_sub(shown.len());
            notes.push(format!(
                "{}{} fit equally: the data cannot tell them apart",
                shown.join(", "),
                if more > 0 {
                    format!(" and {more} more")
                } else {
                    String::new()
                }
            ));
        }
        let notes = if notes.is_empty() {
            String::new()
        } else {
            format!(" ({})", notes.join("; "))
        };
        format!("'{}', a {}-like term{notes}", t.term, t.term)
    };
    terms.iter().map(one).collect::<Vec<_>>().join(", and ")
}

/// The known physical form the term, or a shape the data cannot tell from it, matches (a shape the
/// same as the term over the designs reads the same).
fn reading_of(s: &Searcher, t: &FoundTerm) -> Option<String> {
    std::iter::once(&t.term).chain(&t.alike).find_map(|term| {
        let shape = s.shapes.iter().find(|x| &x.term == term)?;
        reading(s.cx, &s.base.fit.theta, shape)
    })
}

/// Local power-law exponents ∂ln|f|/∂ln x_j at every training design, when f is a pure power law
/// over them (the same exponents everywhere, to 1e-4); `None` otherwise.
fn power_law(cx: &Context, f: &dyn Fn(&[f64]) -> f64) -> Option<Vec<f64>> {
    let dims = cx.inputs.space.design_names.len();
    let mut out: Option<Vec<f64>> = None;
    for &i in &cx.train {
        let d = &cx.data.designs[i];
        let mut e = Vec::with_capacity(dims);
        for j in 0..dims {
            if d[j] <= 0.0 {
                return None;
            }
            let step = 1e-4;
            let (mut up, mut dn) = (d.clone(), d.clone());
            up[j] *= 1.0 + step;
            dn[j] *= 1.0 - step;
            let (fu, fd) = (f(&up).abs(), f(&dn).abs());
            if !(fu > 0.0 && fd > 0.0 && fu.is_finite() && fd.is_finite()) {
                return None;
            }
            e.push((fu.ln() - fd.ln()) / ((1.0 + step).ln() - (1.0 - step).ln()));
        }
        match &out {
            None => out = Some(e),
            Some(first) if first.iter().zip(&e).all(|(a, b)| (a - b).abs() < 1e-4) => {}
            Some(_) => return None,
        }
    }
    out
}

/// The reading of `shape` against the simulation at θ: by the exponents of g/y and of y.
fn reading(cx: &Context, theta: &DVector<f64>, shape: &Shape) -> Option<String> {
    let th = theta.as_slice();
    let model = cx.inputs.model;
    let names = &cx.inputs.space.design_names;
    let g = |d: &[f64]| shape.eval(d, th, model.predict(d, th));
    let y = |d: &[f64]| model.predict(d, th);
    let ratio = |d: &[f64]| g(d) / y(d);
    let near = |a: f64, b: f64| (a - b).abs() < 1e-3;
    let eg = power_law(cx, &g)?;
    if eg.iter().all(|&e| near(e, 0.0)) {
        return Some(
            "offset-like: the same amount at every design (a zero error of the measurement, a slack, a preload)".into(),
        );
    }
    let er = power_law(cx, &ratio)?;
    let ey = power_law(cx, &y)?;
    if er.iter().all(|&e| near(e, 0.0)) {
        return Some(
            "scale-like: proportional to the simulation's response (a calibration error of the measurement, or a \
             parameter that multiplies the response)"
                .into(),
        );
    }
    // The study's field's known forms: data of the library ([`super::readings::FORMS`]).
    super::readings::FORMS
        .iter()
        .find_map(|form| form.read(names, &ey, &er))
}

/// The search in words: the first line leads the diagnosis's evidence.
fn words(d: &Discovered, l: usize, pairs: bool) -> Vec<String> {
    let searched = format!(
        "{} models ({l} shapes{}) at α/M = {}",
        d.search.library.models,
        if pairs { " and their pairs" } else { "" },
        num(d.test.threshold)
    );
    let base = match d.test.base.as_str() {
        "uncorrected" => "uncorrected".to_string(),
        name => format!("'{name}'"),
    };
    let mut out = Vec::new();
    match d.found.outcome {
        Outcome::Found => {
            let t = &d.named.terms[0];
            let ci = t
                .interval
                .map_or(String::new(), |[a, b]| format!(" (95 % {} to {})", num(a), num(b)));
            let fit = d.checks.lack_of_fit.as_ref().map_or(String::new(), |l| {
                format!(
                    ", and it leaves nothing beyond the noise (χ² = {} on {} degrees of freedom, {})",
                    num(l.chi2),
                    l.dof,
                    p_text(l.p_value)
                )
            });
            let gains = match (d.checks.validation_error_before, d.checks.validation_error_after) {
                (Some(b), Some(a)) => format!("; validation error {} → {}", pct(b), pct(a)),
                _ => String::new(),
            };
            let loo = match (d.checks.loo_error_before, d.checks.loo_error_after) {
                (Some(b), Some(a)) => format!("; leave-one-design-out {} → {}", pct(b), pct(a)),
                _ => String::new(),
            };
            out.push(format!(
                "Found by search, not listed: {} added to the {} model, coefficient {}{ci}, with {}; it reduces the \
                 misfit beyond what a search of {searched} allows ({}), no other library shape still reduces it with \
                 it in{fit}{gains}{loo}.",
                d.named.shape.as_deref().unwrap_or_default(),
                base,
                num(t.coefficient),
                crate::base::format::params(&d.found.parameters),
                d.test.p_value.map_or("-".into(), p_text),
            ));
            if let Some(r) = &d.named.reading {
                out.push(format!("Reading of the found term: {r}."));
            }
            if let Some(line) = &d.named.hypothesis_line {
                out.push(format!(
                    "To test it as a listed cause, add under diagnosis.hypotheses: {}.",
                    line.replace('\n', " ")
                ));
            }
        }
        Outcome::NothingExplains => {
            let closest = d
                .search
                .closest
                .iter()
                .map(|c| format!("'{}' ({})", c.term, c.why))
                .collect::<Vec<_>>()
                .join("; ");
            out.push(format!(
                "Searched by library, not listed: no shape in the library explains the misfit (searched {searched}, \
                 base {}){}.",
                base,
                if closest.is_empty() {
                    String::new()
                } else {
                    format!("; closest: {closest}")
                }
            ));
        }
    }
    out
}
