//! Step 7: the test that would settle what the verdict leaves open — one design, or a programme of
//! a few designs, or an independent measurement of a parameter.
//!
//! Model discrimination by T-optimal design (Atkinson & Fedorov 1975): take one explanation A as
//! true, with its fitted numbers, and ask how badly a rival B — refitted to the training tests plus
//! the new specimens — would then miss. That misfit, in units of the noise, is the noncentrality λ
//! of the likelihood-ratio test that would follow. With B linearised around its fit (weighted
//! Jacobian A_B over the training tests, r = W(μ_A − μ_B)) and new rows (one per specimen and
//! observed output, e = (μ_A − μ_B)/σ, j = ∂μ_B/∂β/σ, m specimens counting m times):
//!
//! `λ = rᵀr + Σ m eᵀe − bᵀ M⁺ b`,  `M = A_BᵀA_B + Σ m jᵀj`,  `b = A_Bᵀr + Σ m jᵀe`,
//!
//! the residual sum of squares of the least-squares refit of B (the recursive form of the
//! single-design update λ₀ + m e²/(1 + m h)). A pair of candidates counts the weaker direction
//! (min over A→B and B→A); a candidate against the uncorrected model counts only the candidate as
//! true (the larger model nests the smaller). The test at α has power ≥ `power` when
//! λ ≥ (z_{1−α/2} + z_power)² (normal approximation of the noncentral χ²₁; Cohen 1988, ch. 2).
//!
//! The search, cheapest first (fewest specimens in all):
//! 1. one design in the design box (every tested design included) with m specimens;
//! 2. programmes of two designs (m₁, m₂), and, when no pair decides, three (the best pairs and a
//!    third design); the candidate designs are a coarser grid for these;
//! 3. the chosen programme's power is then taken over the uncertainty of A's fitted numbers
//!    (expected power, or assurance: the mean power over draws of A from its Gauss–Newton
//!    covariance, B refitted each time; O'Hagan, Stevens & Campbell 2005), and its specimens are
//!    raised until that reaches `power`;
//! 4. when nothing inside the design bounds decides, the same search over a box widened by half
//!    its width on each side (closed forms only: a solver study's surrogates exist at its tested
//!    designs alone), reported as a test outside the tested range;
//! 5. for each parameter both explanations share, the standard uncertainty an independent
//!    measurement of it (a coupon test of E, say) would need, with the existing tests, to tell them
//!    apart at the same power: a prior row (β_j − β_A,j)/σ added to B's refit;
//! 6. where the tests' noise is not measured (no replicates, none stated), σ is only guessed from
//!    the residuals of the models being judged, and the new specimens must measure it: they are
//!    replicates, and the difference is judged on their own scatter, a t test on
//!    ν = Σ(specimens at a design − 1) degrees of freedom, whose power is the noncentral t's with
//!    noncentrality √λ ([`stats::t_power`]): each design of the programme gets a specimen more
//!    until ν ≥ 2 and that power reaches `power`.

use indexmap::IndexMap;
use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use super::{Context, Mode, NextTest, NoiseKind, NoiseModel, TestAmount, TestChoice, stats};
use crate::base::format::{num, params};

/// A prediction at an observation point for fitted numbers β.
type Eval<'e> = dyn Fn(&[f64], &[f64]) -> f64 + Sync + 'e;
/// ∂y/∂β at β̂, at an observation point.
type Gradient<'e> = dyn Fn(&[f64]) -> DVector<f64> + Sync + 'e;

/// One explanation as the discrimination sees it: its prediction at an observation point for any
/// fitted numbers β (θ first), its fit β̂ with covariance, and ∂y/∂β at β̂.
pub(crate) struct Explanation<'e> {
    pub name: String,
    eval: Box<Eval<'e>>,
    gradient: Box<Gradient<'e>>,
    beta: DVector<f64>,
    /// Names of β's entries (θ by the study's names, then γ or the extension's variables).
    names: Vec<String>,
    cov: Option<DMatrix<f64>>,
    /// θ's bounds (the first entries of β), which parameter draws are kept inside.
    bounds: &'e crate::base::Bounds,
    /// What the model is made of: its simulation (empty for the study's own) and its shapes, by
    /// name and term. A model whose parts all lie in another's is nested in it (the uncorrected
    /// model in every other; the model a found term extends in the found one): only the larger as
    /// true counts when the two are compared.
    parts: Vec<String>,
    /// The relative variance of its simulation's own error at each observation point (its
    /// emulator's, measured on runs it was not fitted to; empty for a closed form).
    code: Vec<(Vec<f64>, f64)>,
}

impl<'e> Explanation<'e> {
    /// A model fitted in context `cx` (the screening's, or a loop model's own): `entry`'s shape (if
    /// any) with its amplitude, θ its parameters. `uncorrected`: it is the study's simulation
    /// alone, nested in every other explanation.
    pub fn from_entry(cx: &'e Context<'e>, entry: &'e super::ranking::Entry, name: String, uncorrected: bool) -> Self {
        let model = &entry.model;
        let p = cx.p();
        let beta: DVector<f64> = DVector::from_iterator(
            p + model.fit.gamma.len(),
            model.fit.theta.iter().chain(&model.fit.gamma).copied(),
        );
        let mut names = cx.inputs.space.parameter_names.clone();
        names.extend((0..model.fit.gamma.len()).map(|k| format!("γ{k}")));
        let code = (0..cx.data.designs.len())
            .map(|i| {
                // Relative to the response's level; whitened curve features have none (their
                // emulator's error is in their noise).
                let v = match cx.inputs.features {
                    None => cx.emulator_variance(i),
                    Some(_) => 0.0,
                };
                let y = cx.data.means[i];
                let rel = if y != 0.0 && v > 0.0 { v / (y * y) } else { 0.0 };
                (cx.data.designs[i].clone(), rel)
            })
            .collect();
        Explanation {
            name,
            code,
            eval: Box::new(move |pt, b| cx.data.predict(&model.shapes(), &b[..p], &b[p..], pt)),
            gradient: Box::new(move |pt| cx.data.gradient(&model.shapes(), &model.fit, pt)),
            beta,
            names,
            cov: entry.assessed.cov.as_ref().map(|c| c.matrix.clone()),
            bounds: &cx.inputs.space.parameter_bounds,
            parts: if uncorrected {
                Vec::new()
            } else {
                model
                    .shapes()
                    .iter()
                    .map(|s| format!("{}: {}", s.name, s.term))
                    .collect()
            },
        }
    }

    /// The same explanation, its simulation a model the loop extended with `hypothesis` (so that
    /// it is nested in no screening candidate, nor they in it).
    pub fn simulated_by(mut self, hypothesis: &str) -> Self {
        self.parts.insert(0, format!("simulation: {hypothesis}"));
        self
    }

    /// The same explanation at `values` (by name) where given: the point handed over when the
    /// solver's confirmation refitted its parameters ([`super::refit`]); its predictions there are
    /// its emulators' across that small step, its slope and covariance the fit's.
    pub fn at(mut self, values: Option<&IndexMap<String, f64>>) -> Self {
        for (name, v) in values.into_iter().flatten() {
            if let Some(j) = self.names.iter().position(|n| n == name) {
                self.beta[j] = *v;
            }
        }
        self
    }

    /// The simulation it runs: `None` for the study's own (the screening's), else the hypothesis
    /// the loop extended it with.
    fn simulation(&self) -> Option<&str> {
        self.parts.first().and_then(|p| p.strip_prefix("simulation: "))
    }

    /// The variance of its simulation's own error at `pt` where it predicts `y`: measured at a
    /// tested point, elsewhere the largest measured (relative).
    fn code_variance(&self, pt: &[f64], y: f64) -> f64 {
        let rel = self
            .code
            .iter()
            .find(|(at, _)| at.as_slice() == pt)
            .map(|c| c.1)
            .unwrap_or_else(|| self.code.iter().map(|c| c.1).fold(0.0, f64::max));
        rel * y * y
    }

    /// Whether every part of this model is one of `other`'s.
    fn nested_in(&self, other: &Explanation) -> bool {
        self.parts.iter().all(|p| other.parts.contains(p))
    }

    pub fn predict(&self, pt: &[f64]) -> f64 {
        (self.eval)(pt, self.beta.as_slice())
    }

    /// The value of a named parameter of β.
    fn value(&self, name: &str) -> Option<f64> {
        self.names.iter().position(|n| n == name).map(|j| self.beta[j])
    }
}

/// A programme of specimens at designs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProgrammeRun {
    pub design: IndexMap<String, f64>,
    /// Specimens to test there (all of them, the tested ones included).
    pub specimens: usize,
    /// The tested design at this point, if any, and how many more specimens it needs.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub tested_as: Option<String>,
    pub additional: usize,
}

/// An independent measurement of one parameter that would tell the explanations apart.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Measurement {
    pub parameter: String,
    /// The largest standard uncertainty that still decides, relative to the parameter's value.
    pub relative_uncertainty: f64,
    /// The values the two explanations give it.
    pub values: [f64; 2],
}

/// More specimens than this at one design are no practical recommendation.
const MAX_SPECIMENS: usize = 1000;
/// The largest programme of several designs searched (specimens in all).
const MAX_PROGRAMME: usize = 120;
/// Draws of the true explanation's fitted numbers for the expected power.
const DRAWS: usize = 64;

/// The next test: what it compares, where, with how many specimens; `None` without a design
/// space. `ex`: the explanations to tell apart (the uncorrected model may be one). `fresh`: the
/// tests in hand left them open, so the new specimens must decide on their own evidence — the
/// increase of λ over what the tests in hand give reaches the target (when the tests in hand have
/// decided, a confirming test may count them).
pub(crate) fn recommend(
    cx: &Context,
    ex: &[Explanation],
    noise: &NoiseModel,
    fresh: bool,
    level: f64,
) -> Option<NextTest> {
    if cx.inputs.space.design_bounds.dim() == 0 {
        return None;
    }
    let mut ex: Vec<&Explanation> = ex.iter().collect();
    ex.dedup_by(|a, b| a.name == b.name);
    if ex.len() < 2 {
        return farthest_from_tested(cx, &ex);
    }
    let Some(sigma) = one_test_sigma(cx, noise) else {
        return widest_gap(cx, &ex);
    };
    let z_alpha = stats::normal_quantile(1.0 - level / 2.0);
    let target = (z_alpha + stats::normal_quantile(cx.inputs.settings.power)).powi(2);
    let mut search = Search::new(cx, &ex, &sigma, target, true);
    search.fresh = fresh;
    let (found, outside) = search.inside_then_outside();
    let mut pick = found?;
    // Where nothing decides, say whether exact simulations would: then it is the emulators' error,
    // not the specimens, that stands between the explanations.
    let limited_by_emulators = !pick.decides && ex.iter().any(|e| e.code.iter().any(|c| c.1 > 0.0)) && {
        let mut exact = Search::new(cx, &ex, &sigma, target, false);
        exact.fresh = fresh;
        exact.inside_then_outside().0.is_some_and(|p| p.decides)
    };
    if pick.decides {
        search.raise_for_uncertainty(&mut pick, z_alpha);
        if noise.kind == NoiseKind::FromResiduals {
            search.replicate(&mut pick, level);
        }
    }
    let measurements = search.measurements(target);
    pick.limited_by_emulators = limited_by_emulators;
    Some(describe(cx, &ex, &sigma, pick, outside, measurements, level))
}

/// The designs and specimens chosen, and what they achieve.
#[derive(Debug, Clone)]
struct Pick {
    runs: Vec<(Vec<f64>, usize)>,
    /// The pair that limits it, as indices into the explanations.
    pair: (usize, usize),
    /// λ of that pair's weaker direction at the fitted numbers.
    lambda: f64,
    /// Power reaches the target.
    decides: bool,
    /// Mean power over the uncertainty of the true explanation's fitted numbers.
    expected_power: Option<f64>,
    /// It does not decide, where exact simulations would: the emulators' error stands between.
    limited_by_emulators: bool,
    /// Where the noise is not measured: the degrees of freedom of the scatter the programme's
    /// replicates measure, on which it decides (module notes, 6).
    scatter_dof: Option<usize>,
}

impl Pick {
    /// Specimens `runs` reaching λ = `lambda` for `pair`, before any expected power.
    fn new(runs: Vec<(Vec<f64>, usize)>, pair: (usize, usize), lambda: f64, decides: bool) -> Pick {
        Pick {
            runs,
            pair,
            lambda,
            decides,
            expected_power: None,
            limited_by_emulators: false,
            scatter_dof: None,
        }
    }

    fn total(&self) -> usize {
        self.runs.iter().map(|r| r.1).sum()
    }
}

type Sigma = Box<dyn Fn(f64) -> f64 + Send + Sync>;

/// One specimen's rows at a design: Σeᵀe, Σjᵀe, Σjᵀj over its observed outputs; with the
/// variance of the two simulations' own error there in units of one test's (`code`, mean over the
/// outputs) and the training specimens tested there (`tested`), which [`Rows::count`] needs.
#[derive(Clone)]
struct Rows {
    ete: f64,
    jte: DVector<f64>,
    jtj: DMatrix<f64>,
    code: f64,
    tested: f64,
}

impl Rows {
    fn zero(q: usize) -> Self {
        Rows {
            ete: 0.0,
            jte: DVector::zeros(q),
            jtj: DMatrix::zeros(q, q),
            code: 0.0,
            tested: 0.0,
        }
    }

    /// What `m` new specimens at this design count for, in specimens of exact simulations. The
    /// simulations' error there is one draw shared by every specimen of the design (Kennedy &
    /// O'Hagan 2001, the code's uncertainty in the likelihood), so the mean of n specimens has
    /// variance σ²(1/n + k) and counts n/(1 + n·k): the new ones add what the tested ones lack of
    /// that, and no number of specimens tells apart what differs by less than the simulations' error.
    fn count(&self, m: f64) -> f64 {
        let counts = |n: f64| n / (1.0 + n * self.code);
        counts(self.tested + m) - counts(self.tested)
    }
}

/// The variance of the difference of two explanations' simulation errors at `pt`: none when they
/// run the same simulation (its error cancels), else the sum of both.
fn pair_code(a: &Explanation, b: &Explanation, pt: &[f64], ya: f64, yb: f64) -> f64 {
    if a.simulation() == b.simulation() {
        0.0
    } else {
        a.code_variance(pt, ya) + b.code_variance(pt, yb)
    }
}

/// A true explanation `truth` and a refitted rival `rival`, over the training tests.
struct Direction {
    truth: usize,
    rival: usize,
    ata: DMatrix<f64>,
    atr: DVector<f64>,
    rtr: f64,
}

impl Direction {
    fn lambda(&self, adds: &[(&Rows, f64)]) -> f64 {
        let mut m = self.ata.clone();
        let mut b = self.atr.clone();
        let mut rr = self.rtr;
        for (rows, k) in adds {
            m += &rows.jtj * *k;
            b += &rows.jte * *k;
            rr += rows.ete * k;
        }
        // A rival whose numbers the rows do not all determine (singular M) refits along the
        // undetermined directions freely: the pseudo-inverse.
        if let Some(ch) = m.clone().cholesky() {
            let d = ch.l_dirty().diagonal();
            let (lo, hi) = d.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
                (lo.min(v.abs()), hi.max(v.abs()))
            });
            if lo > 1e-6 * hi {
                return (rr - b.dot(&ch.solve(&b))).max(0.0);
            }
        }
        let eps = 1e-12 * m.norm().max(f64::MIN_POSITIVE);
        match m.pseudo_inverse(eps) {
            Ok(inv) => (rr - b.dot(&(&inv * &b))).max(0.0),
            Err(_) => 0.0,
        }
    }
}

/// Everything the search reuses: the explanations, the noise, and each direction's training part.
struct Search<'a, 'e> {
    cx: &'a Context<'a>,
    ex: &'a [&'a Explanation<'e>],
    sigma: &'a Sigma,
    target: f64,
    /// 1/σ where the weights do not carry the noise (no replicates), else 1.
    unit: f64,
    /// Each compared pair with the directions that count.
    pairs: Vec<((usize, usize), Vec<Direction>)>,
    /// Count only what new specimens add to λ (see [`recommend`]).
    fresh: bool,
    /// Count the simulations' own error (see [`Search::new`]).
    code: bool,
}

impl<'a, 'e> Search<'a, 'e> {
    /// `code`: count the simulations' own error ([`Rows::count`]); without it, the search says what
    /// exact simulations would decide.
    fn new(cx: &'a Context<'a>, ex: &'a [&'a Explanation<'e>], sigma: &'a Sigma, target: f64, code: bool) -> Self {
        let unit = if cx.known() { 1.0 } else { 1.0 / sigma(1.0) };
        let mut pairs = Vec::new();
        for a in 0..ex.len() {
            for b in a + 1..ex.len() {
                let dirs: Vec<(usize, usize)> = match (ex[a].nested_in(ex[b]), ex[b].nested_in(ex[a])) {
                    (false, true) => vec![(a, b)],
                    (true, false) => vec![(b, a)],
                    _ => vec![(a, b), (b, a)],
                };
                let ds: Vec<Direction> = dirs
                    .into_iter()
                    .filter_map(|(t, r)| direction(cx, ex, (t, r), unit, code, None))
                    .collect();
                if !ds.is_empty() {
                    pairs.push(((a, b), ds));
                }
            }
        }
        Search {
            cx,
            ex,
            sigma,
            target,
            unit: 1.0,
            pairs,
            fresh: false,
            code,
        }
        .with_unit(unit)
    }

    fn with_unit(mut self, unit: f64) -> Self {
        self.unit = unit;
        self
    }

    /// One specimen's rows at design `d` for a direction, with the truth's numbers `beta` (β̂ when
    /// `None`); `None` where either explanation is not finite (a solver study's untested design).
    fn rows(&self, d: &[f64], truth: usize, rival: usize, beta: Option<&DVector<f64>>) -> Option<Rows> {
        let (a, b) = (self.ex[truth], self.ex[rival]);
        let mut rows = Rows::zero(b.beta.len());
        let points = observation_points(self.cx, d);
        for pt in &points {
            let ya = match beta {
                Some(bb) => (a.eval)(pt, bb.as_slice()),
                None => a.predict(pt),
            };
            let yb = b.predict(pt);
            let w = 1.0 / (self.sigma)(ya);
            let j = (b.gradient)(pt) * w;
            let e = w * (ya - yb);
            if !(e.is_finite() && j.iter().all(|v| v.is_finite())) {
                return None;
            }
            rows.ete += e * e;
            rows.jte += &j * e;
            rows.jtj += &j * j.transpose();
            if self.code {
                rows.code += pair_code(a, b, pt, ya, yb) * w * w / points.len() as f64;
            }
        }
        rows.tested = trained_at(self.cx, d) as f64;
        Some(rows)
    }

    /// The directions, flattened, with their pair.
    fn directions(&self) -> Vec<((usize, usize), &Direction)> {
        self.pairs
            .iter()
            .flat_map(|(pair, dirs)| dirs.iter().map(move |d| (*pair, d)))
            .collect()
    }

    /// One specimen's rows at each of `points` for every direction; points where an explanation
    /// cannot be evaluated are dropped.
    fn table(&self, points: &[Vec<f64>]) -> Table {
        use rayon::prelude::*;
        let dirs = self.directions();
        let rows: Vec<Option<Vec<Rows>>> = points
            .par_iter()
            .map(|d| {
                dirs.iter()
                    .map(|(_, dir)| self.rows(d, dir.truth, dir.rival, None))
                    .collect()
            })
            .collect();
        let (points, rows) = points
            .iter()
            .zip(rows)
            .filter_map(|(d, r)| r.map(|r| (d.clone(), r)))
            .unzip();
        Table { points, rows }
    }

    /// The weakest λ over every direction for specimens `runs` (point index, count) of `table`.
    fn weakest_in(&self, table: &Table, runs: &[(usize, usize)]) -> (f64, (usize, usize)) {
        let mut worst = (f64::INFINITY, (0, 1));
        for (k, (pair, dir)) in self.directions().into_iter().enumerate() {
            let adds: Vec<(&Rows, f64)> = runs
                .iter()
                .map(|&(i, m)| (&table.rows[i][k], table.rows[i][k].count(m as f64)))
                .collect();
            let lam = dir.lambda(&adds) - if self.fresh { dir.lambda(&[]) } else { 0.0 };
            if lam < worst.0 {
                worst = (lam, pair);
            }
        }
        worst
    }

    /// The weakest λ for a programme of designs (`None`: an explanation cannot be evaluated there).
    fn weakest(&self, runs: &[(Vec<f64>, usize)]) -> Option<(f64, (usize, usize))> {
        let points: Vec<Vec<f64>> = runs.iter().map(|r| r.0.clone()).collect();
        let table = self.table(&points);
        (table.points.len() == runs.len()).then(|| {
            self.weakest_in(
                &table,
                &runs.iter().enumerate().map(|(i, r)| (i, r.1)).collect::<Vec<_>>(),
            )
        })
    }

    /// The cheapest programme inside the design bounds; else outside them (closed forms only),
    /// and whether it lies there; else the design where the explanations differ most.
    fn inside_then_outside(&self) -> (Option<Pick>, bool) {
        let cx = self.cx;
        let per_axis = cx.inputs.settings.grid_per_axis;
        if let Some(p) = self.cheapest(&candidate_points(cx, &cx.inputs.space.design_bounds, per_axis)) {
            return (Some(p), false);
        }
        match widened(cx) {
            Some(wide) => {
                let outside = self.cheapest(&candidate_points(cx, &wide, per_axis));
                let found = outside.is_some();
                (outside.or_else(|| self.closest(cx)), found)
            }
            None => (self.closest(cx), false),
        }
    }

    /// The cheapest programme over `points` that reaches the target: one design, else two, else three
    /// (specimens are new ones). When the tests in hand already reach it (a confirmation), no new
    /// specimen: the tested design where one more would add most is named with none.
    fn cheapest(&self, points: &[Vec<f64>]) -> Option<Pick> {
        let table = self.table(points);
        let in_hand = self
            .directions()
            .iter()
            .map(|(_, d)| d.lambda(&[]))
            .fold(f64::INFINITY, f64::min);
        if !self.fresh && in_hand >= self.target {
            let tested = (0..table.points.len()).filter(|&i| tested_at(self.cx, &table.points[i]).is_some());
            let best = tested.max_by(|&a, &b| {
                self.weakest_in(&table, &[(a, 1)])
                    .0
                    .total_cmp(&self.weakest_in(&table, &[(b, 1)]).0)
            })?;
            let pair = self.weakest_in(&table, &[]).1;
            return Some(Pick::new(vec![(table.points[best].clone(), 0)], pair, in_hand, true));
        }
        let single = (0..table.points.len())
            .filter_map(|i| self.fewest(&table, &[i], MAX_SPECIMENS))
            .min_by_key(|p| p.total());
        let coarse = coarse(self.cx, &table);
        let budget = single.as_ref().map_or(MAX_PROGRAMME, |s| s.total().min(MAX_PROGRAMME));
        let pairs = self.best_pairs(&table, &coarse, budget);
        let mut best = [single, pairs.first().cloned()]
            .into_iter()
            .flatten()
            .min_by_key(|p| p.total());
        if best.is_none() {
            best = self.best_triple(&table, &coarse);
        }
        best
    }

    /// The fewest specimens in all at the designs `at` (indices into `table`), each at least one,
    /// reaching the target, up to `max`; every split of a total is tried.
    fn fewest(&self, table: &Table, at: &[usize], max: usize) -> Option<Pick> {
        let n = at.len();
        let best_split = |total: usize| -> Option<(f64, (usize, usize), Vec<usize>)> {
            splits(total, n)
                .into_iter()
                .map(|ms| {
                    let runs: Vec<(usize, usize)> = at.iter().copied().zip(ms.iter().copied()).collect();
                    let (l, pair) = self.weakest_in(table, &runs);
                    (l, pair, ms)
                })
                .max_by(|a, b| a.0.total_cmp(&b.0))
        };
        let reaches = |total: usize| best_split(total).is_some_and(|b| b.0 >= self.target);
        // λ grows with the specimens (any split of T extends to one of T + 1): double, then bisect.
        let mut hi = n;
        while !reaches(hi) {
            if hi >= max {
                return None;
            }
            hi = (hi * 2).min(max);
        }
        let mut lo = n - 1;
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if mid >= n && reaches(mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        let (lambda, pair, ms) = best_split(hi)?;
        let runs = at.iter().map(|&i| table.points[i].clone()).zip(ms).collect();
        Some(Pick::new(runs, pair, lambda, true))
    }

    /// The cheapest pairs of designs, best first (at most a few), each no dearer than `budget`.
    fn best_pairs(&self, table: &Table, points: &[usize], budget: usize) -> Vec<Pick> {
        use rayon::prelude::*;
        let pairs: Vec<(usize, usize)> = (0..points.len())
            .flat_map(|a| (a + 1..points.len()).map(move |b| (a, b)))
            .collect();
        let mut found: Vec<Pick> = pairs
            .par_iter()
            .filter_map(|&(a, b)| self.fewest(table, &[points[a], points[b]], budget))
            .collect();
        found.sort_by(|x, y| x.total().cmp(&y.total()).then(y.lambda.total_cmp(&x.lambda)));
        found.truncate(8);
        found
    }

    /// When no pair decides: the pairs that do most at a fixed budget, each with a third design.
    fn best_triple(&self, table: &Table, points: &[usize]) -> Option<Pick> {
        use rayon::prelude::*;
        if points.len() < 3 {
            return None;
        }
        let budget = MAX_PROGRAMME / 3;
        let mut scored: Vec<(f64, usize, usize)> = (0..points.len())
            .flat_map(|a| (a + 1..points.len()).map(move |b| (a, b)))
            .map(|(a, b)| {
                (
                    self.weakest_in(table, &[(points[a], budget), (points[b], budget)]).0,
                    a,
                    b,
                )
            })
            .collect();
        scored.sort_by(|x, y| y.0.total_cmp(&x.0));
        scored.truncate(6);
        let triples: Vec<[usize; 3]> = scored
            .iter()
            .flat_map(|&(_, a, b)| {
                (0..points.len())
                    .filter(move |&c| c != a && c != b)
                    .map(move |c| [points[a], points[b], points[c]])
            })
            .collect();
        triples
            .par_iter()
            .filter_map(|t| self.fewest(table, t, MAX_PROGRAMME))
            .min_by_key(|p| p.total())
    }

    /// Nothing decides: the single design where the explanations differ most (bound of λ at the
    /// largest number of specimens).
    fn closest(&self, cx: &Context) -> Option<Pick> {
        candidate_points(cx, &cx.inputs.space.design_bounds, cx.inputs.settings.grid_per_axis)
            .into_iter()
            .filter_map(|d| {
                let runs = vec![(d, MAX_SPECIMENS)];
                self.weakest(&runs)
                    .map(|(lambda, pair)| Pick::new(runs, pair, lambda, false))
            })
            .max_by(|a, b| a.lambda.total_cmp(&b.lambda))
    }

    /// The expected power of `pick` over the uncertainty of the true explanation's fitted numbers,
    /// with the specimens raised (by a quarter at a time, to at most four times the programme at
    /// the fitted numbers) until it reaches the target power. When even that falls short — the
    /// fitted numbers are too uncertain for any size of test to be sure — the programme at the
    /// fitted numbers is kept and its (lower) expected power reported.
    fn raise_for_uncertainty(&self, pick: &mut Pick, z_alpha: f64) {
        let want = self.cx.inputs.settings.power;
        let start = pick.clone();
        let mut trial = pick.clone();
        loop {
            let power = self.expected_power(&trial.runs, z_alpha);
            trial.expected_power = power;
            if power.is_none_or(|p| p >= want) {
                *pick = trial;
                return;
            }
            if trial.total() >= 4 * start.total() || trial.total() >= MAX_SPECIMENS {
                pick.expected_power = self.expected_power(&start.runs, z_alpha);
                return;
            }
            for run in trial.runs.iter_mut() {
                run.1 = (run.1 as f64 * 1.25).ceil() as usize;
            }
            if let Some((l, pair)) = self.weakest(&trial.runs) {
                trial.lambda = l;
                trial.pair = pair;
            }
        }
    }

    /// Where the noise is not measured, the programme's specimens are replicates that measure it
    /// (module notes, 6): one more at each of its designs until their scatter's degrees of freedom
    /// ν reach 2 and the t test's power on them reaches `power` (short of it at the most specimens
    /// sensible, no programme decides). The expected power, a normal one with the noise known, does
    /// not apply to that t test and is dropped.
    fn replicate(&self, pick: &mut Pick, level: f64) {
        let power = self.cx.inputs.settings.power;
        let tested: Vec<usize> = pick
            .runs
            .iter()
            .map(|(d, _)| tested_at(self.cx, d).map_or(0, |t| t.1))
            .collect();
        loop {
            let nu: usize = (pick.runs.iter().zip(&tested))
                .map(|((_, m), t)| (m + t).saturating_sub(1))
                .sum();
            let reaches = nu >= 2 && stats::t_power(pick.lambda.max(0.0).sqrt(), nu as f64, level) >= power;
            if reaches || pick.total() >= MAX_SPECIMENS {
                // Short of the power at the most specimens sensible: no programme decides.
                (pick.scatter_dof, pick.expected_power, pick.decides) = (Some(nu), None, reaches);
                return;
            }
            for run in pick.runs.iter_mut() {
                run.1 += 1;
            }
            if let Some((l, pair)) = self.weakest(&pick.runs) {
                pick.lambda = l;
                pick.pair = pair;
            }
        }
    }

    /// Mean power over draws of the truth's numbers, the weakest direction per draw; `None` when a
    /// truth has no covariance.
    fn expected_power(&self, runs: &[(Vec<f64>, usize)], z_alpha: f64) -> Option<f64> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut total = 0.0;
        for _ in 0..DRAWS {
            let mut worst = f64::INFINITY;
            for (_, dirs) in &self.pairs {
                for dir in dirs {
                    let truth = self.ex[dir.truth];
                    let beta = draw(truth, &mut rng)?;
                    let moved = direction(
                        self.cx,
                        self.ex,
                        (dir.truth, dir.rival),
                        self.unit,
                        self.code,
                        Some(&beta),
                    )?;
                    let rows: Vec<(Rows, f64)> = runs
                        .iter()
                        .map(|(d, m)| {
                            self.rows(d, dir.truth, dir.rival, Some(&beta)).map(|r| {
                                let k = r.count(*m as f64);
                                (r, k)
                            })
                        })
                        .collect::<Option<_>>()?;
                    let adds: Vec<(&Rows, f64)> = rows.iter().map(|(r, m)| (r, *m)).collect();
                    let fresh = if self.fresh { moved.lambda(&[]) } else { 0.0 };
                    worst = worst.min(moved.lambda(&adds) - fresh);
                }
            }
            total += stats::normal_cdf(worst.max(0.0).sqrt() - z_alpha);
        }
        Some(total / DRAWS as f64)
    }

    /// For each parameter both of the closest pair share: the standard uncertainty of an
    /// independent measurement that decides with the existing tests (on its own evidence where
    /// they left it open, as a programme must).
    fn measurements(&self, target: f64) -> Vec<Measurement> {
        let Some(((a, b), dirs)) = self.pairs.first() else {
            return Vec::new();
        };
        // The tests in hand already decide: no measurement is needed.
        if dirs.iter().map(|d| d.lambda(&[])).fold(f64::INFINITY, f64::min) >= target {
            return Vec::new();
        }
        let (ea, eb) = (self.ex[*a], self.ex[*b]);
        let mut out = Vec::new();
        for name in &ea.names {
            if name.starts_with('γ') {
                continue;
            }
            let (Some(va), Some(vb)) = (ea.value(name), eb.value(name)) else {
                continue;
            };
            let lam = |sigma: f64| -> f64 {
                dirs.iter()
                    .map(|d| {
                        let (t, r) = (self.ex[d.truth], self.ex[d.rival]);
                        let Some(j) = r.names.iter().position(|n| n == name) else {
                            return 0.0;
                        };
                        let mut row = Rows::zero(r.beta.len());
                        let e = (t.value(name).unwrap_or(f64::NAN) - r.beta[j]) / sigma;
                        row.ete = e * e;
                        row.jte[j] = e / sigma;
                        row.jtj[(j, j)] = 1.0 / (sigma * sigma);
                        d.lambda(&[(&row, 1.0)]) - if self.fresh { d.lambda(&[]) } else { 0.0 }
                    })
                    .fold(f64::INFINITY, f64::min)
            };
            let scale = va.abs().max(vb.abs()).max(f64::MIN_POSITIVE);
            let (mut lo, mut hi) = (1e-9 * scale, 10.0 * scale);
            // Not reached (or not a number) even with the smallest uncertainty.
            if lam(lo).partial_cmp(&target).is_none_or(|o| o.is_lt()) {
                continue;
            }
            for _ in 0..60 {
                let mid = (lo * hi).sqrt();
                if lam(mid) >= target {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            out.push(Measurement {
                parameter: name.clone(),
                relative_uncertainty: lo / va.abs().max(f64::MIN_POSITIVE),
                values: [va, vb],
            });
        }
        out
    }
}

/// One specimen's rows at each candidate design, per direction (in [`Search::directions`] order).
struct Table {
    points: Vec<Vec<f64>>,
    rows: Vec<Vec<Rows>>,
}

/// Ways to put `total` specimens on `n` designs (n ≤ 3), each at least one: an even split, and
/// shares of 1/6 to 5/6 on each design, the rest spread over the others (a handful of splits keeps
/// the search of every pair cheap; the cheapest total moves by at most a specimen or two).
fn splits(total: usize, n: usize) -> Vec<Vec<usize>> {
    if n == 0 || total < n {
        return Vec::new();
    }
    let even = |t: usize, k: usize| -> Vec<usize> { (0..k).map(|i| t / k + usize::from(i < t % k)).collect() };
    let mut out = vec![even(total, n)];
    if n > 1 {
        for share in [1.0 / 6.0, 1.0 / 4.0, 1.0 / 3.0, 2.0 / 3.0, 3.0 / 4.0, 5.0 / 6.0] {
            let own = ((total as f64 * share).round() as usize).clamp(1, total - (n - 1));
            for at in 0..n {
                let mut rest = even(total - own, n - 1);
                rest.insert(at, own);
                out.push(rest);
            }
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// The training part of a direction (truth's numbers `beta`, β̂ when `None`).
/// With `code`, each test's variance carries the two simulations' error at its design
/// ([`pair_code`]).
fn direction(
    cx: &Context,
    ex: &[&Explanation],
    (truth, rival): (usize, usize),
    unit: f64,
    code: bool,
    beta: Option<&DVector<f64>>,
) -> Option<Direction> {
    let (a, b) = (ex[truth], ex[rival]);
    let n = cx.train.len();
    let q = b.beta.len();
    let mut jac = DMatrix::zeros(n, q);
    let mut r = DVector::zeros(n);
    for (row, &i) in cx.train.iter().enumerate() {
        let pt = &cx.data.designs[i];
        let ya = beta.map_or_else(|| a.predict(pt), |bb| (a.eval)(pt, bb.as_slice()));
        let yb = b.predict(pt);
        let tests = unit * cx.data.weights[i];
        let simulations = if code { pair_code(a, b, pt, ya, yb) } else { 0.0 };
        let w = 1.0 / (1.0 / (tests * tests) + simulations).sqrt();
        r[row] = w * (ya - yb);
        jac.set_row(row, &((b.gradient)(pt) * w).transpose());
    }
    if r.iter().chain(jac.iter()).any(|v| !v.is_finite()) {
        return None;
    }
    Some(Direction {
        truth,
        rival,
        atr: jac.transpose() * &r,
        ata: jac.transpose() * &jac,
        rtr: r.norm_squared(),
    })
}

/// One draw of an explanation's numbers from N(β̂, C), θ kept inside its bounds.
fn draw(e: &Explanation, rng: &mut rand_chacha::ChaCha8Rng) -> Option<DVector<f64>> {
    let cov = e.cov.as_ref()?;
    let l = cov.clone().cholesky()?.l();
    let z = DVector::from_fn(e.beta.len(), |_, _| StandardNormal.sample(rng));
    let mut b = &e.beta + l * z;
    for j in 0..e.bounds.dim().min(b.len()) {
        b[j] = b[j].clamp(e.bounds.lower[j], e.bounds.upper[j]);
    }
    Some(b)
}

/// The observation points of one specimen at design `d`: one per observed output.
fn observation_points(cx: &Context, d: &[f64]) -> Vec<Vec<f64>> {
    let outputs = cx.inputs.outputs();
    if outputs <= 1 {
        return vec![d.to_vec()];
    }
    (0..outputs)
        .map(|k| d.iter().copied().chain([k as f64]).collect())
        .collect()
}

/// σ of one test at a response level: from the replicates, or from the residuals of a ranked
/// diagnosis; `None` when the data give no noise.
fn one_test_sigma(cx: &Context, noise: &NoiseModel) -> Option<Sigma> {
    let from_residuals = noise.kind == NoiseKind::FromResiduals;
    // A stated uncertainty may be relative only (no scale of its own).
    let stated = noise.kind == NoiseKind::Stated && (noise.absolute > 0.0 || noise.relative > 0.0);
    let usable = stated || noise.scale > 0.0 && noise.scale.is_finite() && (!from_residuals || cx.mode == Mode::Ranked);
    usable.then(|| {
        let nm = noise.clone();
        Box::new(move |level: f64| nm.sigma_at(level).max(f64::MIN_POSITIVE)) as Sigma
    })
}

/// A grid of `per_axis` points per design variable (a Latin hypercube above three), plus every
/// tested design inside `bounds`.
fn candidate_points(cx: &Context, bounds: &crate::base::Bounds, per_axis: usize) -> Vec<Vec<f64>> {
    let dim = bounds.dim();
    let mut points: Vec<Vec<f64>> = if dim <= 3 {
        let m = per_axis.max(2);
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
        crate::base::latin_hypercube(cx.inputs.settings.search_points, dim, 0)
            .row_iter()
            .map(|r| bounds.from_unit(&r.transpose()).iter().copied().collect())
            .collect()
    };
    for o in &cx.inputs.observations {
        let inside = o
            .design
            .iter()
            .enumerate()
            .all(|(j, v)| *v >= bounds.lower[j] && *v <= bounds.upper[j]);
        if inside && !points.contains(&o.design) {
            points.push(o.design.clone());
        }
    }
    points
}

/// The designs for programmes of several (indices into `table`): every tested design, and an even
/// thinning of the others to about 40 in all.
fn coarse(cx: &Context, table: &Table) -> Vec<usize> {
    const MAX: usize = 40;
    let n = table.points.len();
    let step = n.div_ceil(MAX).max(1);
    let tested = |d: &Vec<f64>| cx.inputs.observations.iter().any(|o| &o.design == d);
    (0..n).filter(|&i| i % step == 0 || tested(&table.points[i])).collect()
}

/// The design box widened by half its width on each side (a positive lower bound stays above half
/// of itself); `None` for a solver study, whose surrogates exist at its tested designs only.
fn widened(cx: &Context) -> Option<crate::base::Bounds> {
    let b = &cx.inputs.space.design_bounds;
    let probe: Vec<f64> = (0..b.dim())
        .map(|j| b.lower[j] - 0.25 * (b.upper[j] - b.lower[j]))
        .collect();
    let p = cx.inputs.observations.first().map(|o| o.design.len()).unwrap_or(0);
    if p != b.dim() {
        return None;
    }
    let pt = observation_points(cx, &probe);
    let theta = cx.inputs.space.parameter_bounds.center();
    if !cx.inputs.model.predict(&pt[0], theta.as_slice()).is_finite() {
        return None;
    }
    let (lower, upper): (Vec<f64>, Vec<f64>) = (0..b.dim())
        .map(|j| {
            let w = b.upper[j] - b.lower[j];
            let lo = b.lower[j] - 0.5 * w;
            let lo = if b.lower[j] > 0.0 { lo.max(0.5 * b.lower[j]) } else { lo };
            (lo, b.upper[j] + 0.5 * w)
        })
        .unzip();
    Some(crate::base::Bounds::new(lower, upper))
}

/// With nothing to compare (no candidate could be fitted): the design in the box farthest from
/// every tested one (in units of the box), where the calibrated model is least checked.
fn farthest_from_tested(cx: &Context, ex: &[&Explanation]) -> Option<NextTest> {
    let width = cx.inputs.space.design_bounds.width();
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
    let d = candidate_points(cx, &cx.inputs.space.design_bounds, cx.inputs.settings.grid_per_axis)
        .into_iter()
        .max_by(|a, b| gap(a).total_cmp(&gap(b)))?;
    let y = ex
        .first()
        .map_or(f64::NAN, |e| e.predict(&observation_points(cx, &d)[0]));
    let design = cx.inputs.space.design_at(&d);
    let advice = "at least 3 specimens there, so that the scatter is measured and the calibrated model is checked \
                  where it was not fitted"
        .to_string();
    Some(NextTest {
        choice: TestChoice {
            why: format!(
                "Test at {} (not tested yet): no candidate cause can be fitted to so few tests, so the most useful \
             next test is the design farthest from those tested, where the calibrated simulation predicts {}. In \
             numbers: {advice}.",
                params(&design),
                num(y)
            ),
            advice,
            level: cx.alpha(),
            between: ["uncorrected".into(), "uncorrected".into()],
            predictions: [y, y],
            separation: 0.0,
            compared: [("uncorrected".to_string(), y)].into_iter().collect(),
            already_tested: None,
            output: None,
            design: design.clone(),
        },
        amount: TestAmount {
            specimens: None,
            additional_specimens: None,
            power: None,
            expected_power: None,
            programme: vec![ProgrammeRun {
                design: design.clone(),
                specimens: 3,
                tested_as: None,
                additional: 3,
            }],
            outside_range: false,
            measurements: Vec::new(),
            limited_by_emulators: false,
            scatter_dof: None,
        },
    })
}

/// Without a noise: the design where the closest pair differs most, relatively.
fn widest_gap(cx: &Context, ex: &[&Explanation]) -> Option<NextTest> {
    let mut best: Option<(f64, Vec<f64>, (usize, usize))> = None;
    for d in candidate_points(cx, &cx.inputs.space.design_bounds, cx.inputs.settings.grid_per_axis) {
        let pt = &observation_points(cx, &d)[0];
        let y: Vec<f64> = ex.iter().map(|e| e.predict(pt)).collect();
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
            && best.as_ref().is_none_or(|b| gap > b.0)
        {
            best = Some((gap, d, pair));
        }
    }
    let (gap, d, pair) = best?;
    let pick = Pick::new(vec![(d, 3)], pair, 0.0, false);
    let mut t = describe_common(cx, ex, &pick, false, Vec::new(), None);
    t.choice.separation = gap;
    t.amount.specimens = None;
    t.amount.additional_specimens = None;
    t.choice.advice =
        "the noise is unknown (no replicate tests): test at least 3 specimens there, so that the scatter is \
                measured as well"
            .to_string();
    t.choice.why = why(&t, false);
    Some(t)
}

/// The tested design at `d` (within 1e-6 of the box on every variable), with its specimens.
fn tested_at(cx: &Context, d: &[f64]) -> Option<(String, usize)> {
    observation_at(cx, d, 0..cx.inputs.observations.len()).map(|o| (o.group.clone(), o.count))
}

/// The specimens of the training tests at `d` (0 where none was trained on).
fn trained_at(cx: &Context, d: &[f64]) -> usize {
    observation_at(cx, d, cx.train.iter().copied()).map_or(0, |o| o.count)
}

/// The first of the observations `among` at `d` (within 1e-6 of the box on every variable).
fn observation_at<'c>(
    cx: &'c Context,
    d: &[f64],
    among: impl Iterator<Item = usize>,
) -> Option<&'c super::Observation> {
    let width = cx.inputs.space.design_bounds.width();
    among.map(|i| &cx.inputs.observations[i]).find(|o| {
        o.design
            .iter()
            .zip(d)
            .enumerate()
            .all(|(j, (a, b))| (a - b).abs() <= 1e-6 * width[j].abs().max(1e-12))
    })
}

/// The fields every recommendation shares, from the pick.
fn describe_common(
    cx: &Context,
    ex: &[&Explanation],
    pick: &Pick,
    outside: bool,
    measurements: Vec<Measurement>,
    power: Option<f64>,
) -> NextTest {
    let (d, m) = pick.runs[0].clone();
    let (ea, eb) = (ex[pick.pair.0], ex[pick.pair.1]);
    // With several outputs (whitened curve features, each in units of its noise), the one where
    // the pair differs most: the numbers shown are where the difference is.
    let points = observation_points(cx, &d);
    let gaps: Vec<f64> = points
        .iter()
        .map(|pt| (ea.predict(pt) - eb.predict(pt)).abs())
        .collect();
    let k = (0..points.len())
        .max_by(|&a, &b| gaps[a].total_cmp(&gaps[b]))
        .unwrap_or(0);
    let pt = &points[k];
    let (ya, yb) = (ea.predict(pt), eb.predict(pt));
    let output = (cx.inputs.features.as_ref())
        .filter(|f| f.outputs.len() > 1)
        .and_then(|f| f.outputs.get(k).cloned());
    let already_tested = tested_at(cx, &d);
    // The specimens of a programme are new ones: at a tested design they add to those tested.
    let programme: Vec<ProgrammeRun> = pick
        .runs
        .iter()
        .map(|(d, m)| {
            let tested = tested_at(cx, d);
            ProgrammeRun {
                design: cx.inputs.space.design_at(d),
                specimens: m + tested.as_ref().map_or(0, |t| t.1),
                additional: *m,
                tested_as: tested.map(|t| t.0),
            }
        })
        .collect();
    let single = pick.runs.len() == 1 && pick.decides;
    NextTest {
        choice: TestChoice {
            design: cx.inputs.space.design_at(&d),
            why: String::new(),
            advice: String::new(),
            level: cx.alpha(),
            between: [ea.name.clone(), eb.name.clone()],
            predictions: [ya, yb],
            separation: 0.0,
            compared: ex.iter().map(|e| (e.name.clone(), e.predict(pt))).collect(),
            already_tested: already_tested.clone(),
            output,
        },
        amount: TestAmount {
            specimens: single.then(|| m + already_tested.as_ref().map_or(0, |t| t.1)),
            additional_specimens: single.then_some(m),
            power,
            expected_power: pick.expected_power,
            programme: if pick.decides { programme } else { Vec::new() },
            outside_range: outside,
            measurements,
            limited_by_emulators: pick.limited_by_emulators,
            scatter_dof: pick.scatter_dof,
        },
    }
}

fn describe(
    cx: &Context,
    ex: &[&Explanation],
    sigma: &Sigma,
    pick: Pick,
    outside: bool,
    measurements: Vec<Measurement>,
    level: f64,
) -> NextTest {
    let root = pick.lambda.max(0.0).sqrt();
    let power = pick.decides.then(|| match pick.scatter_dof {
        Some(nu) => stats::t_power(root, nu as f64, level),
        None => stats::normal_cdf(root - stats::normal_quantile(1.0 - level / 2.0)),
    });
    let mut t = describe_common(cx, ex, &pick, outside, measurements, power);
    let (ya, yb) = (t.choice.predictions[0], t.choice.predictions[1]);
    t.choice.separation = (ya - yb).abs() / sigma(0.5 * (ya + yb));
    t.choice.level = level;
    t.choice.advice = advice(cx, &t, pick.decides);
    t.choice.why = why(&t, true);
    t
}

/// What it takes, in one sentence, read from the typed recommendation.
fn advice(cx: &Context, t: &NextTest, decides: bool) -> String {
    let power = 100.0 * cx.inputs.settings.power;
    let alpha = num(t.choice.level);
    // The power over the uncertainty of the fitted parameters: said beside, or as a caveat when
    // no programme could reach the target over it.
    let (expected, caveat) = match t.amount.expected_power {
        Some(p) if p + 0.005 >= cx.inputs.settings.power => (
            format!(" ({:.0} % over the uncertainty of the fitted parameters)", 100.0 * p),
            String::new(),
        ),
        Some(p) => (
            String::new(),
            format!(
                "; over the uncertainty of the fitted parameters the power is only {:.0} %: the tests in hand pin \
                 them too loosely for any programme to be sure",
                100.0 * p
            ),
        ),
        None => (String::new(), String::new()),
    };
    let measure = measurement_words(&t.amount.measurements);
    if !decides {
        return undecided_advice(t, power, &alpha, measure);
    }
    let place = if t.amount.outside_range {
        "only designs outside the tested range decide: "
    } else {
        ""
    };
    let mut s = match (t.amount.programme.as_slice(), &t.choice.already_tested) {
        ([one], Some((name, n))) if one.additional == 0 => format!(
            "{place}the {n} specimen(s) already tested at {name} should tell them apart (power {power:.0} % at α = \
             {alpha}{expected}): the data in hand carry the answer"
        ),
        ([one], Some((name, n))) => format!(
            "{place}{} more specimen(s) at {name} ({} with the {n} tested) give power {power:.0} % at α = {alpha}{expected} \
             to tell them apart",
            one.additional, one.specimens
        ),
        ([one], None) => format!(
            "{place}{} specimen(s) there give power {power:.0} % at α = {alpha}{expected} to tell them apart",
            one.specimens
        ),
        (many, _) => format!(
            "{place}no single design decides as cheaply; the programme {} ({} specimen(s) in all) gives power \
             {power:.0} % at α = {alpha}{expected} to tell them apart",
            programme_words(many),
            many.iter().map(|r| r.additional).sum::<usize>()
        ),
    };
    s.push_str(&caveat);
    if let Some(nu) = t.amount.scatter_dof {
        s.push_str(&format!(
            "; the tests in hand have no replicates, so these specimens are replicates that measure the scatter \
             ({nu} degrees of freedom, on which a t test decides); their number takes a scatter like the \
             best-ranked model's residuals"
        ));
    }
    if let Some(m) = measure {
        s.push_str(&format!("; alternatively, {m}"));
    }
    s
}

/// Where no programme decides: why (the emulators' error, or the parameters pinned too loosely),
/// and what else would tell.
fn undecided_advice(t: &NextTest, power: f64, alpha: &str, measure: Option<String>) -> String {
    if t.amount.limited_by_emulators {
        let mut s = format!(
            "no programme of specimens makes the difference decisive (power {power:.0} % at α = {alpha}): the \
             explanations differ by less than their emulators' own error, measured on solver runs they were not \
             fitted to; with exact simulations a programme would decide, so more solver runs for their models come \
             before more specimens"
        );
        if let Some(m) = measure {
            s.push_str(&format!("; {m}"));
        }
        return s;
    }
    let mut s = format!(
        "no programme of up to three designs inside the design bounds makes the difference decisive (power \
         {power:.0} % at α = {alpha}): the existing tests pin the explanations' parameters too loosely, so each \
         can bend to new points"
    );
    s.push_str(&match measure {
        Some(m) => format!("; {m}"),
        None => "; tests at wider designs or an independent measurement of the parameters are needed".into(),
    });
    s
}

/// `3 specimens at h = 7 (not tested) and 2 more at h13`.
pub(crate) fn programme_words(runs: &[ProgrammeRun]) -> String {
    runs.iter()
        .map(|r| match &r.tested_as {
            Some(name) => format!("{} more at {name} ({})", r.additional, params(&r.design)),
            None => format!("{} at {} (not tested yet)", r.specimens, params(&r.design)),
        })
        .collect::<Vec<_>>()
        .join(" and ")
}

fn measurement_words(ms: &[Measurement]) -> Option<String> {
    let m = ms
        .iter()
        .max_by(|a, b| a.relative_uncertainty.total_cmp(&b.relative_uncertainty))?;
    Some(format!(
        "an independent measurement of {} to ±{} (standard uncertainty; the explanations want {} and {}) would tell \
         them apart with the tests in hand",
        m.parameter,
        crate::base::format::pct(m.relative_uncertainty),
        num(m.values[0]),
        num(m.values[1])
    ))
}

fn why(t: &NextTest, noise_known: bool) -> String {
    let at = params(&t.choice.design);
    let preds = t
        .choice
        .compared
        .iter()
        .map(|(n, y)| format!("'{n}' {}", num(*y)))
        .collect::<Vec<_>>()
        .join(", ");
    let (ya, yb) = (t.choice.predictions[0], t.choice.predictions[1]);
    let rel = (ya - yb).abs() / (0.5 * (ya.abs() + yb.abs())).max(f64::MIN_POSITIVE);
    let place = match &t.choice.already_tested {
        Some((name, n)) => format!("{at} (already tested as {name}, {n} specimen(s))"),
        None => format!("{at} (not tested yet)"),
    };
    let chosen = if !noise_known {
        "the widest such gap inside the design bounds"
    } else if t.amount.programme.len() > 1 {
        "the first design of the cheapest programme that tells them apart"
    } else {
        "the design where the fewest specimens would tell them apart"
    };
    // A whitened curve feature has no unit of its own: its difference is said in the tests' scatter.
    let difference = match t.choice.output.as_ref().filter(|_| noise_known) {
        Some(feature) => format!(
            "the explanations differ most in the {feature}, by {} standard deviation(s) of one test ({preds}, in \
             units of its noise)",
            num(t.choice.separation)
        ),
        None => format!("{preds}; the closest two are {} apart", crate::base::format::pct(rel)),
    };
    format!(
        "Test at {place}: there {difference}, {chosen}. In numbers: {}.",
        t.choice.advice
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::base::Bounds;
    use crate::diagnose::{Inputs, Observation, Role, Settings, Space};

    /// n specimens of an exact simulation count n; with its error shared by a design's specimens
    /// (k = its variance in units of one test's) no number counts more than 1/k, and new specimens
    /// at a tested design add only what the tested ones lack of that.
    #[test]
    fn a_designs_specimens_count_up_to_the_simulations_error() {
        let mut rows = Rows::zero(1);
        assert_eq!(rows.count(7.0), 7.0);
        rows.code = 0.04;
        assert!((rows.count(1e9) - 25.0).abs() < 1e-3, "{}", rows.count(1e9));
        assert!((rows.count(5.0) - 5.0 / 1.2).abs() < 1e-12);
        rows.tested = 5.0;
        let both = 10.0 / 1.4 - 5.0 / 1.2;
        assert!((rows.count(5.0) - both).abs() < 1e-12);
        assert!(
            rows.count(5.0)
                < Rows {
                    tested: 0.0,
                    ..rows.clone()
                }
                .count(5.0)
        );
    }

    fn simulation(d: &[f64], theta: &[f64]) -> f64 {
        theta[0] * d[0].powi(-3)
    }

    /// Tests at x = 8..12 (5 specimens, σ = 0.002) of y = 1000 x⁻³ + 2 x⁻²; a design box 4..16.
    fn inputs() -> Inputs<'static> {
        let observations = (0..5)
            .map(|i| {
                let x = 8.0 + f64::from(i);
                let y = 1000.0 * x.powi(-3) + 2.0 * x.powi(-2);
                let reps: Vec<f64> = [-2.0, -1.0, 0.0, 1.0, 2.0]
                    .iter()
                    .map(|z| y + 0.002 * z / 1.58)
                    .collect();
                Observation::from_replicates(format!("x{i}"), vec![x], Role::Training, &reps)
            })
            .collect();
        Inputs {
            observations,
            model: &simulation,
            space: Space {
                parameter_names: vec!["theta".into()],
                parameter_bounds: Bounds::new(vec![100.0], vec![3000.0]),
                design_names: vec!["x".into()],
                design_bounds: Bounds::new(vec![4.0], vec![16.0]),
            },
            hypotheses: Vec::new(),
            settings: Settings::default(),
            library: None,
            built_ins: Some(Vec::new()),
            features: None,
            emulator: Default::default(),
        }
    }

    /// An explanation y = θ x⁻³ + γ xᵖ run by a simulation of its own (`simulation: name`), whose
    /// error has relative variance `rel` at every tested design; β fitted to the tests here.
    fn explanation<'e>(cx: &'e Context<'e>, name: &str, power: i32, rel: f64) -> Explanation<'e> {
        let cols = move |x: f64| [x.powi(-3), x.powi(power)];
        let a = DMatrix::from_fn(cx.train.len(), 2, |r, j| cols(cx.data.designs[cx.train[r]][0])[j]);
        let y = DVector::from_iterator(cx.train.len(), cx.train.iter().map(|&i| cx.data.means[i]));
        let beta = (a.transpose() * &a).lu().solve(&(a.transpose() * y)).unwrap();
        Explanation {
            name: name.into(),
            eval: Box::new(move |pt, b| b[0] * cols(pt[0])[0] + b[1] * cols(pt[0])[1]),
            gradient: Box::new(move |pt| DVector::from_row_slice(&cols(pt[0]))),
            beta,
            names: vec!["theta".into(), "γ0".into()],
            cov: None,
            bounds: &cx.inputs.space.parameter_bounds,
            parts: vec![format!("simulation: {name}")],
            code: cx.data.designs.iter().map(|d| (d.clone(), rel)).collect(),
        }
    }

    /// Two explanations that only a programme outside the tested band tells apart: with exact
    /// simulations a programme decides; with simulations whose error is ten times the tests' noise,
    /// none does, and the next test says that the emulators, not the specimens, stand between.
    #[test]
    fn no_programme_is_claimed_from_differences_within_the_simulations_error() {
        let inputs = inputs();
        let noise = NoiseModel::constant(0.002, 20, String::new());
        let cx = Context::new(&inputs, Some(&noise), false).unwrap();
        let level = cx.alpha();
        let next = |rel: f64| {
            let ex = [explanation(&cx, "a", -1, rel), explanation(&cx, "b", -2, rel)];
            recommend(&cx, &ex, &noise, true, level).unwrap()
        };
        let exact = next(0.0);
        assert!(
            !exact.amount.programme.is_empty() && !exact.amount.limited_by_emulators,
            "{exact:?}"
        );
        // The response is about 2 at x = 8 and 0.3 at x = 16: σ = 0.002 is 0.1 to 0.7 % of it,
        // and a relative simulation error of 5 % (variance 0.0025) is far beyond.
        let rough = next(0.0025);
        assert!(
            rough.amount.programme.is_empty() && rough.amount.limited_by_emulators,
            "{rough:?}"
        );
        assert!(
            rough.choice.advice.contains("emulators' own error"),
            "{}",
            rough.choice.advice
        );
        // An error far below the noise changes the programme by little.
        let fine = next(1e-12);
        let total = |t: &NextTest| t.amount.programme.iter().map(|r| r.additional).sum::<usize>() as f64;
        assert!(
            (total(&fine) - total(&exact)).abs() <= 0.05 * total(&exact) + 1.0,
            "{fine:?}"
        );
    }
}
