//! What "no model error" leaves open: for each listed hypothesis, the range of its amplitude the
//! tests do not exclude, the calibrated parameters over that range, and the smallest effect they
//! could have detected.
//!
//! From each candidate's joint fit of θ and its amplitude γ (the screening's, [`super::evidence`]):
//!
//! - **not excluded**: γ̂ ± t(1 − α_K/2, ν)·SE(γ), the amplitudes the candidates' amplitude test (at
//!   its level α_K, one of the K candidates' Bonferroni shares) would not reject. The ranges are
//!   read at the level the verdict tests each hypothesis at, so that they say the same as the
//!   verdict: "no model error" holds exactly where every listed hypothesis's range takes in its
//!   absence, and the ranges hold together at α (Bonferroni). At α, a hypothesis whose test the
//!   search's size had left short of α_K would be "excluded from its absence" beside a verdict that
//!   found no model error;
//! - **the parameters over it**: the joint fit's regression of θ on γ, θ(γ) = θ̂ + Cov(θ, γ)/Var(γ)·(γ
//!   − γ̂), at the range's ends: where the parameters would be were the effect there;
//! - **detectable**: (t(1 − α_K/2, ν) + t(power, ν))·SE(γ), the smallest |γ| the candidates'
//!   amplitude test (at its level α_K) finds with the settings' power.
//!
//! An extension's amplitude is read as its variable (γ × the value the study set it to, the
//! baseline at 0, as the screening linearises it: exact where the response is linear in it); a
//! term's is its coefficient.
//!
//! **From solver runs** ([`Profile`]): an extension's range is read again from the solver run over
//! its amplitude, where the pipeline runs it (a small loop, [`next_amplitudes`]): the profile
//! χ²(v) — the tests' misfit with the parameters refitted at each value v of the extension's
//! variable — from the runs' values interpolated linearly in v between the values run at, and the
//! range is {v : χ²(v) − min χ² ≤ t²(1 − α_K/2, ν)}, the likelihood-ratio interval (Cox & Hinkley
//! 1974, §7.2; for a response linear in v it is the one above, read without its linearisation).

use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

use super::confirm::{Confirmation, Confirming};
use super::shapes::Origin;
use super::shapes::Shape;
use super::{Candidate, Inputs, Levels, NoiseModel, stats};

/// One listed hypothesis the tests do not exclude (`diagnosis.not_excluded[]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NotExcluded {
    pub hypothesis: String,
    /// The amplitude's range the tests do not exclude at α_K (module notes): an extension's variable, or the
    /// term's `amplitude`.
    pub amplitude: IndexMap<String, [f64; 2]>,
    /// Each calibrated parameter over that range.
    pub parameters: IndexMap<String, [f64; 2]>,
    /// The smallest effect the tests would have detected (same names as `amplitude`).
    pub detectable: IndexMap<String, f64>,
    /// The solver's runs over the amplitude the range was read from ([`Profile`]); empty: read from
    /// the screening's probes, linearised.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub runs: Vec<OpenRun>,
    /// Where those runs reject the hypothesis's absence at the level its amplitude is tested at
    /// in the screening: what the emulators read as no model error, the solver does not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub favoured: Option<Favoured>,
}

/// The solver's runs over an extension's amplitude against its absence: the likelihood-ratio
/// test of the baseline value within the extended model (`not_excluded[].favoured`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Favoured {
    /// χ² at the baseline less the profile's least, and its critical value t²(1 − α_K/2, ν).
    pub drop: f64,
    pub critical: f64,
    /// α_K: one of the screening's candidates' amplitude tests.
    pub level: f64,
    /// The profile's best point: the variable, then the parameters refitted there.
    pub at: IndexMap<String, f64>,
}

/// One value of an extension's variable the solver ran at, at every tested design
/// (`diagnosis.not_excluded[].runs[]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OpenRun {
    /// The extension's variable.
    pub amplitude: IndexMap<String, f64>,
    /// The parameters the solver ran at.
    pub at: IndexMap<String, f64>,
    /// The profile there: the tests' χ² with the parameters refitted at this amplitude, and where
    /// they are refitted to.
    pub chi2: f64,
    pub refitted: IndexMap<String, f64>,
    /// The solver's seeds per design (1 without `simulation.seeds`).
    pub seeds: usize,
}

/// The open extensions the solver's runs favour against their absence, the largest fall of χ²
/// first: the order the loop takes them in and the words name them in.
pub fn favoured_first(open: &[NotExcluded]) -> Vec<(&NotExcluded, &Favoured)> {
    let mut favoured: Vec<_> = (open.iter()).filter_map(|n| Some((n, n.favoured.as_ref()?))).collect();
    favoured.sort_by(|a, b| b.1.drop.total_cmp(&a.1.drop));
    favoured
}

/// The listed hypotheses' open ranges (`shapes`: the hypotheses, for an extension's declared
/// ranges; `nu`: the noise's degrees of freedom; `power`: the settings'); empty where no candidate
/// has an amplitude's standard error.
pub fn not_excluded(
    candidates: &[Candidate],
    shapes: &[Shape],
    nu: usize,
    (levels, power): (Levels, f64),
) -> Vec<NotExcluded> {
    let k = candidates.len();
    candidates
        .iter()
        .filter(|c| c.shape.origin == Origin::Study)
        .filter_map(|c| {
            let declared = shapes
                .iter()
                .find(|s| s.name == c.shape.name)
                .map_or(&[][..], |s| &s.ranges[..]);
            one(c, declared, nu, levels.amplitude(k), power)
        })
        .collect()
}

fn one(c: &Candidate, declared: &[(String, f64, f64)], nu: usize, alpha_k: f64, power: f64) -> Option<NotExcluded> {
    let se = c
        .checks
        .separability
        .amplitude_se
        .filter(|s| s.is_finite() && *s > 0.0)?;
    let nu = nu.max(1) as f64;
    let half = stats::t_quantile(1.0 - alpha_k / 2.0, nu) * se;
    let mut range = [c.fit.amplitude - half, c.fit.amplitude + half];
    // An extension's variable cannot leave the range the study declares for it (a hardening
    // modulus below 0): the open range is clipped to it, in γ (the variable over its probe value).
    if let (Some(e), [(name, lo, hi)]) = (c.checks.extension.as_ref().filter(|e| e.len() == 1), declared) {
        let probe = e.get(name).copied().filter(|v| *v != 0.0);
        if let Some(v) = probe {
            let (a, b) = ((lo / v).min(hi / v), (lo / v).max(hi / v));
            range = [range[0].clamp(a, b), range[1].clamp(a, b)];
        }
    }
    let detect = (stats::t_quantile(1.0 - alpha_k / 2.0, nu) + stats::t_quantile(power, nu)) * se;
    let parameters = c
        .fit
        .parameters
        .keys()
        .map(|n| {
            let ends = range.map(|g| theta_at(c, g)[n]);
            (n.clone(), [ends[0].min(ends[1]), ends[0].max(ends[1])])
        })
        .collect();
    let (names, scale) = variable(c);
    let ends = range.map(|g| g * scale);
    Some(NotExcluded {
        hypothesis: c.shape.name.clone(),
        amplitude: [(names.clone(), [ends[0].min(ends[1]), ends[0].max(ends[1])])]
            .into_iter()
            .collect(),
        parameters,
        detectable: [(names, (detect * scale).abs())].into_iter().collect(),
        runs: Vec::new(),
        favoured: None,
    })
}

/// An extension candidate's one variable and the value its amplitude γ = 1 stands for (its probe
/// value); a term's `amplitude`, 1.
fn variable(c: &Candidate) -> (String, f64) {
    match c.checks.extension.as_ref().filter(|e| e.len() == 1) {
        Some(e) => {
            let (n, v) = e.iter().next().expect("one");
            (n.clone(), *v)
        }
        None => ("amplitude".to_string(), 1.0),
    }
}

/// The joint fit's parameters at amplitude γ: θ(γ) = θ̂ + Cov(θ, γ)/Var(γ)·(γ − γ̂), the slope read
/// as each parameter's shift over γ at the 95 % edge.
fn theta_at(c: &Candidate, gamma: f64) -> IndexMap<String, f64> {
    let edge = c
        .checks
        .separability
        .amplitude_ci95
        .map(|[lo, hi]| if lo.abs() > hi.abs() { lo } else { hi });
    (c.fit.parameters.iter())
        .map(|(n, v)| {
            let shift = c.checks.separability.parameter_shift.get(n).copied().unwrap_or(0.0);
            let slope = edge.filter(|e| *e != 0.0).map_or(0.0, |e| shift / e);
            (n.clone(), v + slope * (gamma - c.fit.amplitude))
        })
        .collect()
}

/// The linearised parameters where an extension candidate's variable is `value` (the screening's
/// joint fit, [`theta_at`]): where a first run over its amplitude goes.
pub fn linearised_at(c: &Candidate, value: f64) -> IndexMap<String, f64> {
    let (_, scale) = variable(c);
    theta_at(c, if scale != 0.0 { value / scale } else { 0.0 })
}

/// The profile χ²(v) of one extension from the solver's runs at values v_j of its variable
/// (module notes). Between two values run at, the runs' values and the parameters they ran at are
/// both interpolated linearly in v, and the confirmation's bridge refits the parameters from there
/// along the emulator's slope: at a value run at, the solver's own values at its own parameters,
/// the emulator bridging only the small step to the refit. Each observation's variance is the
/// tests' σ²/n plus the solver's scatter r·σ²·Σ |w_j|/K_j (w_j the interpolation's weights, K_j
/// the seeds): a mean's over K seeds at the values run at, held between them.
pub struct Profile<'a> {
    inputs: &'a Inputs<'a>,
    /// The values run at, ascending, and at each: the parameters, the solver's values per
    /// observation (means over the seeds), the seeds, and the confirmation read there.
    points: Vec<Point<'a>>,
    /// Per observation: the tests' variance of its mean, and the solver's between seeds of one run.
    tests: Vec<f64>,
    solver: Vec<f64>,
    /// The degrees of freedom of the variance the χ² is read against.
    dof: usize,
}

/// One value of the variable the solver ran at ([`Profile`]).
struct Point<'a> {
    value: f64,
    theta: Vec<f64>,
    values: Vec<f64>,
    seeds: usize,
    confirmation: &'a Confirmation,
}

impl<'a> Profile<'a> {
    /// From `points`: the anchor first (the uncorrected model's confirmation, the baseline's value
    /// of the variable), then each value's runs; `None` with fewer than two usable values (a value
    /// with a failed run is left out).
    pub fn new(inputs: &'a Inputs<'a>, noise: &NoiseModel, points: &[(f64, &'a Confirmation)]) -> Option<Profile<'a>> {
        let names = &inputs.space.parameter_names;
        let obs = &inputs.observations;
        let mut usable: Vec<Point> = Vec::new();
        for (value, c) in points {
            let theta = names.iter().map(|n| c.at.get(n).copied()).collect::<Option<Vec<f64>>>();
            let values = c.runs.iter().map(|r| r.solver).collect::<Option<Vec<f64>>>();
            let (Some(theta), Some(values)) = (theta, values) else {
                continue;
            };
            if values.len() != obs.len() {
                continue;
            }
            // A value run at again (at the profile's newer parameters) replaces its older runs.
            usable.retain(|u| u.value != *value);
            let seeds = c.scatter.as_ref().map_or(1, |s| s.seeds.max(1));
            usable.push(Point {
                value: *value,
                theta,
                values,
                seeds,
                confirmation: c,
            });
        }
        if usable.len() < 2 {
            return None;
        }
        usable.sort_by(|a, b| a.value.total_cmp(&b.value));
        let ratio = pooled_scatter(usable.iter().map(|u| u.confirmation));
        let sigma2 = |o: &super::Observation| noise.sigma_at(o.mean).powi(2);
        let dof = points[0].1.lack_of_fit.as_ref().map_or(noise.dof, |l| l.noise_dof);
        Some(Profile {
            inputs,
            tests: obs.iter().map(|o| sigma2(o) / o.count.max(1) as f64).collect(),
            solver: obs
                .iter()
                .map(|o| sigma2(o) * ratio.get(o.output).copied().unwrap_or(0.0))
                .collect(),
            points: usable,
            dof,
        })
    }

    /// χ²(v) and the parameters refitted there (`None`: the bridge has no fit). Beyond the values
    /// run at, extrapolated along the secant of the outermost two: a segment between two close
    /// values carries their runs' scatter over its short length, and extrapolated it would turn that
    /// scatter into a slope.
    pub fn at(&self, v: f64) -> Option<(f64, Vec<f64>)> {
        let n = self.points.len();
        let (first, last) = (&self.points[0], &self.points[n - 1]);
        let (a, b) = if v < first.value || v > last.value {
            (first, last)
        } else {
            let s = self.points.partition_point(|p| p.value <= v).clamp(1, n - 1) - 1;
            (&self.points[s], &self.points[s + 1])
        };
        let wa = (b.value - v) / (b.value - a.value);
        let wb = 1.0 - wa;
        let mix = |x: &[f64], y: &[f64]| -> Vec<f64> { x.iter().zip(y).map(|(x, y)| wa * x + wb * y).collect() };
        // The solver's scatter of the values run at, held over the segment between them (and grown
        // with the extrapolation's weights beyond): the interpolation's smaller variance between two
        // values would weigh χ² differently at each v, and the profile compares them.
        let shrink = wa.abs() / a.seeds as f64 + wb.abs() / b.seeds as f64;
        let sd: Vec<f64> = (self.tests.iter().zip(&self.solver))
            .map(|(t, r)| (t + r * shrink).sqrt())
            .collect();
        let from = Confirming {
            name: String::new(),
            inputs: self.inputs,
            point: mix(&a.theta, &b.theta),
            correction: vec![0.0; self.tests.len()],
            rivals: Vec::new(),
        };
        let bridged = super::confirm::bridge(&from, &mix(&a.values, &b.values), &sd)?;
        let chi2: f64 = bridged.chi2.iter().filter(|c| c.is_finite()).sum();
        let theta: Vec<f64> = (from.point.iter().zip(&bridged.step)).map(|(t, d)| t + d).collect();
        theta.iter().all(|t| t.is_finite()).then_some((chi2, theta))
    }

    /// The values run at.
    pub fn ran(&self) -> Vec<f64> {
        self.points.iter().map(|p| p.value).collect()
    }

    /// Each value run at, and whether its runs are at the parameters the profile refits there
    /// (within a tenth of each parameter's range over `open`): a run made at parameters the profile
    /// has since moved from reads its neighbourhood through the emulator's slope over the move, so
    /// it settles no end of the range ([`next_amplitudes`]). The anchor (the uncorrected model's
    /// confirmation) is taken as it is.
    pub fn fresh(&self, open: &NotExcluded) -> Vec<(f64, bool)> {
        let width: Vec<f64> = (self.inputs.space.parameter_names.iter())
            .map(|n| open.parameters.get(n).map_or(0.0, |[a, b]| b - a))
            .collect();
        (self.points.iter().enumerate())
            .map(|(j, p)| {
                let refit = self.at(p.value).map(|a| a.1);
                let near = |t: &Vec<f64>| {
                    (t.iter().zip(&p.theta).zip(&width)).all(|((r, x), w)| (r - x).abs() <= 0.1 * w + 1e-9 * x.abs())
                };
                (p.value, j == 0 || refit.as_ref().is_some_and(near))
            })
            .collect()
    }

    /// The open range over the declared `[lo, hi]` of variable `name`: the likelihood-ratio interval
    /// at `alpha_k` (the candidates' amplitude test's level, module notes) on a grid of 600 steps
    /// and the values run at; the parameters over it; the smallest effect detectable from the
    /// anchor at that level with `power` (the profile's
    /// curvature between the anchor and the next value run at, t(1 − α_K/2, ν) + t(power, ν)
    /// standard errors).
    pub fn read(
        &self,
        hypothesis: &str,
        (name, lo, hi): (&str, f64, f64),
        (alpha_k, power): (f64, f64),
    ) -> Option<NotExcluded> {
        let names = &self.inputs.space.parameter_names;
        let grid = (0..=600).map(|i| lo + (hi - lo) * i as f64 / 600.0);
        let inside_declared = self.ran().into_iter().filter(|v| (lo..=hi).contains(v));
        let profile: Vec<(f64, f64, Vec<f64>)> = grid
            .chain(inside_declared)
            .filter_map(|v| self.at(v).map(|(q, t)| (v, q, t)))
            .collect();
        let least = profile.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
        let nu = self.dof.max(1) as f64;
        let crit = stats::t_quantile(1.0 - alpha_k / 2.0, nu).powi(2);
        let open: Vec<&(f64, f64, Vec<f64>)> = profile.iter().filter(|p| p.1 - least <= crit).collect();
        let values: Vec<f64> = open.iter().map(|p| p.0).collect();
        let mut amplitude = hull(&values)?;
        // Each end inside the declared range refined between the grid's last value inside and its
        // first outside, by bisection.
        let outside = |v: f64| self.at(v).is_none_or(|a| a.0 - least > crit);
        let step = (hi - lo) / 600.0;
        for (end, toward) in [(0, -step), (1, step)] {
            let (mut inside, mut out) = (amplitude[end], amplitude[end] + toward);
            if !(lo..=hi).contains(&out) || !outside(out) {
                continue;
            }
            for _ in 0..40 {
                let mid = 0.5 * (inside + out);
                if outside(mid) { out = mid } else { inside = mid }
            }
            amplitude[end] = inside;
        }
        let parameters = (names.iter().enumerate())
            .filter_map(|(k, n)| Some((n.clone(), hull(&open.iter().map(|p| p.2[k]).collect::<Vec<_>>())?)))
            .collect();
        let detect = self.standard_error().map(|se| {
            let t = stats::t_quantile(1.0 - alpha_k / 2.0, nu) + stats::t_quantile(power, nu);
            self.points[0].value + t * se
        });
        // The baseline judged against the best of the profile at the same level: favoured exactly
        // where the range leaves the baseline out.
        let best = profile.iter().min_by(|a, b| a.1.total_cmp(&b.1))?;
        let drop = self.at(self.points[0].value)?.0 - least;
        let favoured = (drop > crit).then(|| Favoured {
            drop,
            critical: crit,
            level: alpha_k,
            at: std::iter::once((name.to_string(), best.0))
                .chain(names.iter().cloned().zip(best.2.iter().copied()))
                .collect(),
        });
        Some(NotExcluded {
            hypothesis: hypothesis.to_string(),
            amplitude: [(name.to_string(), amplitude)].into_iter().collect(),
            parameters,
            detectable: detect.into_iter().map(|d| (name.to_string(), d)).collect(),
            runs: self.runs(name),
            favoured,
        })
    }

    /// The amplitude's standard error at the anchor: χ² = (v − v̂)²/SE² has second difference
    /// 2h²/SE² over steps h (a quarter of the way to the next value run at).
    fn standard_error(&self) -> Option<f64> {
        let v0 = self.points[0].value;
        let h = (self.points[1].value - v0) / 4.0;
        let q = |v: f64| self.at(v).map(|a| a.0);
        let curvature = (q(v0 + 2.0 * h)? - 2.0 * q(v0 + h)? + q(v0)?) / (2.0 * h * h);
        (curvature > 0.0).then(|| 1.0 / curvature.sqrt())
    }

    /// The values run at, as recorded.
    fn runs(&self, name: &str) -> Vec<OpenRun> {
        let names = &self.inputs.space.parameter_names;
        self.points
            .iter()
            .filter_map(|p| {
                let (chi2, theta) = self.at(p.value)?;
                Some(OpenRun {
                    amplitude: [(name.to_string(), p.value)].into_iter().collect(),
                    at: p.confirmation.at.clone(),
                    chi2,
                    refitted: names.iter().cloned().zip(theta).collect(),
                    seeds: p.seeds,
                })
            })
            .collect()
    }
}

/// The least and the greatest of `values` (`None`: none, or not finite).
fn hull(values: &[f64]) -> Option<[f64; 2]> {
    let least = values.iter().copied().fold(f64::INFINITY, f64::min);
    let most = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    (least.is_finite() && most.is_finite()).then_some([least, most])
}

/// Per output: the solver's variance between seeds over one specimen's, pooled over the
/// confirmations that measured it (weighted by their degrees of freedom); 0 where none did.
fn pooled_scatter<'c>(confirmations: impl Iterator<Item = &'c Confirmation>) -> Vec<f64> {
    let (mut sums, mut dofs) = (Vec::new(), Vec::new());
    for s in confirmations.filter_map(|c| c.scatter.as_ref()) {
        sums.resize(sums.len().max(s.relative_sd.len()), 0.0);
        dofs.resize(sums.len(), 0.0);
        for (k, r) in s.relative_sd.iter().enumerate().filter(|(_, r)| r.is_finite()) {
            sums[k] += s.dof as f64 * r * r;
            dofs[k] += s.dof as f64;
        }
    }
    sums.iter()
        .zip(&dofs)
        .map(|(s, d)| if *d > 0.0 { s / d } else { 0.0 })
        .collect()
}

/// The rounds of runs over one extension's amplitude at most: a first at the screening's ends, a
/// second where the runs moved them, a third to settle.
pub const ROUNDS: usize = 3;

/// The ends of `open`'s range no run over the amplitude is near yet (`ran`: the values run at,
/// each with whether its runs are at the profile's parameters there, [`Profile::fresh`]): within a
/// tenth of the range's width (a millionth of the declared range's at least). Where the next runs
/// go; empty: the range rests on runs at its ends.
pub fn next_amplitudes(open: &NotExcluded, ran: &[(f64, bool)], (lo, hi): (f64, f64)) -> Vec<f64> {
    let Some([a, b]) = open.amplitude.values().next().copied() else {
        return Vec::new();
    };
    let tolerance = (0.1 * (b - a)).max(1e-6 * (hi - lo));
    let mut ends: Vec<f64> = [a, b]
        .into_iter()
        .filter(|e| !ran.iter().any(|(r, fresh)| *fresh && (r - e).abs() <= tolerance))
        .collect();
    ends.dedup_by(|x, y| (*x - *y).abs() <= tolerance);
    ends
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    use super::*;
    use crate::diagnose::confirm::confirm;
    use crate::diagnose::{Observation, Role};

    /// The solver: a clamped beam's tip y = a/h³ (1 + 3 kr/h), kr the extension's variable.
    fn solver(a: f64, kr: f64, h: f64) -> f64 {
        a / h.powi(3) * (1.0 + 3.0 * kr / h)
    }

    /// Three specimens at each of five depths, 0.3 % noise, all training, at the truth `kr`.
    fn tests(kr: f64, rng: &mut rand_chacha::ChaCha8Rng) -> (Vec<Observation>, NoiseModel) {
        let obs: Vec<Observation> = [7.0, 8.0, 9.0, 11.0, 13.0]
            .iter()
            .map(|&h| {
                let y = solver(600.0, kr, h);
                let reps: Vec<f64> = (0..3)
                    .map(|_| y * (1.0 + 0.003 * Distribution::<f64>::sample(&StandardNormal, rng)))
                    .collect();
                Observation::from_replicates(format!("h{h}"), vec![h], Role::Training, &reps)
            })
            .collect();
        let noise = crate::diagnose::noise::from_replicates(&obs, 0.05).expect("replicates");
        (obs, noise)
    }

    /// The reference: χ²(kr) minimised over a in closed form (the response is linear in a), the
    /// tests' variance σ²/n; the likelihood-ratio interval over kr ∈ [0, 1] on a fine grid.
    fn reference(obs: &[Observation], noise: &NoiseModel, alpha: f64) -> [f64; 2] {
        let chi2 = |kr: f64| {
            let w: Vec<f64> = (obs.iter())
                .map(|o| o.count as f64 / noise.sigma_at(o.mean).powi(2))
                .collect();
            let g: Vec<f64> = obs.iter().map(|o| solver(1.0, kr, o.design[0])).collect();
            let a = (0..obs.len()).map(|i| w[i] * g[i] * obs[i].mean).sum::<f64>()
                / (0..obs.len()).map(|i| w[i] * g[i] * g[i]).sum::<f64>();
            (0..obs.len())
                .map(|i| w[i] * (obs[i].mean - a * g[i]).powi(2))
                .sum::<f64>()
        };
        let grid: Vec<(f64, f64)> = (0..=20_000)
            .map(|i| i as f64 / 20_000.0)
            .map(|k| (k, chi2(k)))
            .collect();
        let least = grid.iter().map(|g| g.1).fold(f64::INFINITY, f64::min);
        let crit = stats::t_quantile(1.0 - alpha / 2.0, noise.dof as f64).powi(2);
        let open: Vec<f64> = grid.iter().filter(|g| g.1 - least <= crit).map(|g| g.0).collect();
        [open[0], open[open.len() - 1]]
    }

    /// The screening's linearised range, as its joint fit of (a, kr) about kr = 0 at the
    /// baseline's fitted a0 gives it: kr̂ ± t(1 − α/2, ν)·SE, and a at each end.
    fn linearised(obs: &[Observation], noise: &NoiseModel, a0: f64) -> Vec<(f64, f64)> {
        let n = obs.len();
        let w = |o: &Observation| o.count as f64 / noise.sigma_at(o.mean).powi(2);
        let x = nalgebra::DMatrix::from_fn(n, 2, |i, k| {
            let h = obs[i].design[0];
            w(&obs[i]).sqrt()
                * if k == 0 {
                    solver(1.0, 0.0, h)
                } else {
                    a0 * 3.0 / h.powi(4)
                }
        });
        let r = nalgebra::DVector::from_fn(n, |i, _| {
            w(&obs[i]).sqrt() * (obs[i].mean - solver(a0, 0.0, obs[i].design[0]))
        });
        let cov = (x.transpose() * &x).try_inverse().expect("identifiable");
        let beta = &cov * x.transpose() * r;
        let half = stats::t_quantile(0.975, noise.dof as f64) * cov[(1, 1)].sqrt();
        let slope = cov[(0, 1)] / cov[(1, 1)];
        [beta[1] - half, beta[1] + half]
            .into_iter()
            .map(|k| k.clamp(0.0, 1.0))
            .filter(|k| *k > 0.0)
            .map(|k| (k, a0 + beta[0] + slope * (k - beta[1])))
            .collect()
    }

    /// The small loop as the pipeline runs it: the anchor (kr = 0 at its own fitted a), then
    /// rounds at the open range's ends — the first at the linearised range's, then each at the a
    /// the profile puts there; the range read.
    fn looped(inputs: &Inputs, noise: &NoiseModel) -> Option<NotExcluded> {
        looped_at(inputs, noise, 0.05)
    }

    /// [`looped`] with the amplitude test at `alpha_k`.
    fn looped_at(inputs: &Inputs, noise: &NoiseModel, alpha_k: f64) -> Option<NotExcluded> {
        let run = |kr: f64, a: f64| {
            let m = Confirming {
                name: "kr".into(),
                inputs,
                point: vec![a],
                correction: vec![0.0; inputs.observations.len()],
                rivals: Vec::new(),
            };
            let values: Vec<Option<f64>> = (inputs.observations.iter())
                .map(|o| Some(solver(a, kr, o.design[0])))
                .collect();
            confirm(&m, &values, noise, 0.05)
        };
        // The anchor's a: the baseline fitted (linear in a).
        let obs = &inputs.observations;
        let a0 = obs.iter().map(|o| o.mean * o.design[0].powi(3)).sum::<f64>() / obs.len() as f64;
        let mut at = vec![(0.0, run(0.0, a0))];
        let mut next = linearised(obs, noise, a0);
        let mut open = None;
        for _ in 0..ROUNDS {
            if next.is_empty() {
                break;
            }
            at.extend(next.iter().map(|&(kr, a)| (kr, run(kr, a))));
            let points: Vec<(f64, &Confirmation)> = at.iter().map(|(v, c)| (*v, c)).collect();
            let profile = Profile::new(inputs, noise, &points)?;
            let read = profile.read("compliance", ("kr", 0.0, 1.0), (alpha_k, 0.8))?;
            next = (next_amplitudes(&read, &profile.fresh(&read), (0.0, 1.0)).into_iter())
                .filter_map(|v| Some((v, profile.at(v)?.1[0])))
                .collect();
            open = Some(read);
        }
        open
    }

    fn beam_inputs(obs: Vec<Observation>, model: &dyn crate::emulate::Model) -> Inputs<'_> {
        let mut i = crate::diagnose::confirm::tests::inputs(obs, model);
        i.space.design_bounds = crate::base::Bounds::new(vec![7.0], vec![13.0]);
        i
    }

    /// The range read from the loop's runs is the likelihood-ratio interval of the exact profile:
    /// over 40 drawn beams with a hidden compliance kr ~ U(0, 0.3), its ends within 0.004 of the
    /// reference's (computed here in closed form on a grid of 20,000, independently of the bridge
    /// and the interpolation; the intervals are about 0.05 wide); the truth inside it in at least
    /// 34 of 40 (nominal 95 %: 38); the loop stops with a run near each end.
    #[test]
    fn the_range_read_from_runs_over_the_amplitude_is_the_likelihood_ratio_interval() {
        let model = |d: &[f64], t: &[f64]| t[0] / d[0].powi(3);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1_053);
        let (mut inside, mut worst, mut rounds) = (0, 0.0f64, Vec::new());
        for _ in 0..40 {
            let truth = 0.3 * rand::Rng::random::<f64>(&mut rng);
            let (obs, noise) = tests(truth, &mut rng);
            let inputs = beam_inputs(obs.clone(), &model);
            let open = looped(&inputs, &noise).expect("a range");
            let [lo, hi] = open.amplitude["kr"];
            let [a, b] = reference(&obs, &noise, 0.05);
            worst = worst.max((lo - a).abs()).max((hi - b).abs());
            let ran: Vec<(f64, f64)> = open.runs.iter().map(|r| (r.amplitude["kr"], r.at["a"])).collect();
            assert!(
                (lo - a).abs() <= 0.004 && (hi - b).abs() <= 0.004,
                "[{lo}, {hi}] against [{a}, {b}] {ran:?}"
            );
            let _ = &ran;
            inside += usize::from((lo..=hi).contains(&truth));
            rounds.push(open.runs.len() - 1);
            let [p, q] = open.parameters["a"];
            assert!(p < q && p > 400.0 && q < 700.0, "a over the range: [{p}, {q}]");
        }
        assert!(inside >= 34, "the truth inside in {inside} of 40");
        eprintln!("ends within {worst:.5} of the reference; truth inside {inside} of 40; values run at {rounds:?}");
    }

    /// The solver's runs over the amplitude against the extension's absence, at the amplitude
    /// test's level 0.01: over 300 drawn beams without a clamp, `favoured` in at most 9 (expected
    /// 3; 9 or more has chance 0.004 at the level); over 100 with kr = 0.1 (about ten of the
    /// amplitude's standard errors), in at least 95; and favoured exactly where the range leaves
    /// kr = 0 out.
    #[test]
    fn the_runs_over_the_amplitude_reject_its_absence_at_the_amplitude_tests_level() {
        let model = |d: &[f64], t: &[f64]| t[0] / d[0].powi(3);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2_053);
        let mut favoured = |kr: f64, draws: usize| {
            (0..draws)
                .filter(|_| {
                    let (obs, noise) = tests(kr, &mut rng);
                    let inputs = beam_inputs(obs, &model);
                    // No range from runs (the linearised one is empty at the declared floor): none run.
                    let open = looped_at(&inputs, &noise, 0.01);
                    // Read at the same level, the range leaves the absence out exactly where the
                    // runs favour the clamp against it.
                    if let Some(o) = &open {
                        let [lo, _] = o.amplitude["kr"];
                        assert_eq!(o.favoured.is_some(), lo > 0.0, "{o:?}");
                    }
                    open.is_some_and(|o| o.favoured.is_some())
                })
                .count()
        };
        let null = favoured(0.0, 300);
        let clamp = favoured(0.1, 100);
        eprintln!("favoured: {null} of 300 without a clamp, {clamp} of 100 with kr = 0.1");
        assert!(null <= 9, "the absence rejected in {null} of 300 at 0.01");
        assert!(clamp >= 95, "kr = 0.1 favoured in only {clamp} of 100");
    }
}
