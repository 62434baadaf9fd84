//! Deterministic adaptive cubature over a box, and the marginals of the integrated density.
//!
//! Tensor Gauss–Kronrod rules on boxes (Kronrod 1965; QUADPACK's QAG strategy, Piessens et al.
//! 1983): each box is integrated by the Kronrod rule, and the difference from the embedded Gauss
//! rule along each axis estimates the error there. The box with the largest error is bisected along
//! its worst axis until the summed error is below the tolerance or a box budget is spent. The
//! integrand is evaluated in parallel over a box's nodes.
//!
//! A marginal density of one coordinate is, on each box, the integral over the other axes at the
//! rule's nodes, interpolated by the polynomial through them (barycentric Lagrange, Berrut &
//! Trefethen 2004); its distribution function integrates that polynomial exactly by Gauss–Legendre.

use rayon::prelude::*;

/// A Kronrod rule on [−1, 1] with its embedded Gauss rule (weight 0 at the Kronrod-only nodes).
#[derive(Debug, Clone)]
pub struct Rule {
    pub nodes: Vec<f64>,
    pub kronrod: Vec<f64>,
    pub gauss: Vec<f64>,
    /// Barycentric interpolation weights of the nodes.
    bary: Vec<f64>,
}

/// Half of a symmetric rule: nodes from the left end to the centre, weights alike.
fn symmetric(half_nodes: &[f64], half_k: &[f64], half_g: &[f64]) -> Rule {
    let n = half_nodes.len();
    let mirror = |v: &[f64], sign: f64| -> Vec<f64> {
        v.iter()
            .copied()
            .chain(v[..n - 1].iter().rev().map(|x| sign * x))
            .collect()
    };
    let nodes = mirror(half_nodes, -1.0);
    let bary = (0..nodes.len())
        .map(|j| {
            1.0 / (0..nodes.len())
                .filter(|&i| i != j)
                .map(|i| nodes[j] - nodes[i])
                .product::<f64>()
        })
        .collect();
    Rule {
        kronrod: mirror(half_k, 1.0),
        gauss: mirror(half_g, 1.0),
        nodes,
        bary,
    }
}

impl Rule {
    /// Gauss 7 / Kronrod 15 (QUADPACK's qk15 constants): exact to degree 13 / 22.
    pub fn k15() -> Rule {
        symmetric(
            &[
                -0.991_455_371_120_812_6,
                -0.949_107_912_342_758_5,
                -0.864_864_423_359_769_1,
                -0.741_531_185_599_394_4,
                -0.586_087_235_467_691_1,
                -0.405_845_151_377_397_2,
                -0.207_784_955_007_898_5,
                0.0,
            ],
            &[
                0.022_935_322_010_529_225,
                0.063_092_092_629_978_55,
                0.104_790_010_322_250_18,
                0.140_653_259_715_525_92,
                0.169_004_726_639_267_9,
                0.190_350_578_064_785_4,
                0.204_432_940_075_298_9,
                0.209_482_141_084_727_83,
            ],
            &[
                0.0,
                0.129_484_966_168_869_7,
                0.0,
                0.279_705_391_489_276_7,
                0.0,
                0.381_830_050_505_118_9,
                0.0,
                0.417_959_183_673_469_4,
            ],
        )
    }

    /// Gauss 3 / Kronrod 7: exact to degree 5 / 10; the cheaper rule for tensor boxes in 2-D.
    pub fn k7() -> Rule {
        symmetric(
            &[
                -0.960_491_268_708_020_3,
                -0.774_596_669_241_483_4,
                -0.434_243_749_346_802_56,
                0.0,
            ],
            &[
                0.104_656_226_026_467_27,
                0.268_488_089_868_333_44,
                0.401_397_414_775_962_2,
                0.450_916_538_658_474_14,
            ],
            &[0.0, 5.0 / 9.0, 0.0, 8.0 / 9.0],
        )
    }

    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The polynomial through `values` at the nodes, at t ∈ [−1, 1] (barycentric formula).
    pub fn interpolate(&self, values: &[f64], t: f64) -> f64 {
        let (mut num, mut den) = (0.0, 0.0);
        for ((&x, &w), &v) in self.nodes.iter().zip(&self.bary).zip(values) {
            let d = t - x;
            if d == 0.0 {
                return v;
            }
            num += w / d * v;
            den += w / d;
        }
        num / den
    }
}

/// Gauss–Legendre nodes and weights on [−1, 1] (Newton on P_n from Chebyshev guesses).
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let (mut x, mut w) = (vec![0.0; n], vec![0.0; n]);
    for i in 0..n {
        let mut t = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, t);
            for k in 2..=n {
                (p0, p1) = (p1, ((2 * k - 1) as f64 * t * p1 - (k - 1) as f64 * p0) / k as f64);
            }
            let p = if n == 0 {
                1.0
            } else if n == 1 {
                t
            } else {
                p1
            };
            let pm = if n == 1 { 1.0 } else { p0 };
            dp = n as f64 * (t * p - pm) / (t * t - 1.0);
            let step = p / dp;
            t -= step;
            if step.abs() < 1e-16 {
                break;
            }
        }
        x[n - 1 - i] = t;
        w[n - 1 - i] = 2.0 / ((1.0 - t * t) * dp * dp);
    }
    (x, w)
}

/// One box of the cubature, with the integrand at its tensor nodes (axis 0 varies slowest).
#[derive(Debug, Clone)]
pub struct Panel {
    pub lo: Vec<f64>,
    pub hi: Vec<f64>,
    pub values: Vec<f64>,
    pub integral: f64,
    pub error: f64,
    worst_axis: usize,
}

/// The finished cubature: its boxes, integral, error estimate and cost.
#[derive(Debug, Clone)]
pub struct Cubature {
    pub rule: Rule,
    pub panels: Vec<Panel>,
    pub integral: f64,
    pub error: f64,
    pub evaluations: usize,
}

/// Digits of tensor index `i` in base `n`, axis 0 first (slowest).
fn digits(mut i: usize, n: usize, dim: usize) -> Vec<usize> {
    let mut d = vec![0; dim];
    for k in (0..dim).rev() {
        d[k] = i % n;
        i /= n;
    }
    d
}

fn panel(f: &(dyn Fn(&[f64]) -> f64 + Sync), rule: &Rule, lo: Vec<f64>, hi: Vec<f64>) -> Panel {
    let (dim, n) = (lo.len(), rule.len());
    let half: Vec<f64> = lo.iter().zip(&hi).map(|(a, b)| (b - a) / 2.0).collect();
    let values: Vec<f64> = (0..n.pow(dim as u32))
        .into_par_iter()
        .map(|i| {
            let x: Vec<f64> = digits(i, n, dim)
                .iter()
                .enumerate()
                .map(|(k, &d)| lo[k] + half[k] * (1.0 + rule.nodes[d]))
                .collect();
            let v = f(&x);
            if v.is_finite() { v.max(0.0) } else { 0.0 }
        })
        .collect();
    let volume: f64 = half.iter().product();
    let (mut integral, mut axis_err) = (0.0, vec![0.0; dim]);
    for (i, v) in values.iter().enumerate() {
        let d = digits(i, n, dim);
        let wk: f64 = d.iter().map(|&j| rule.kronrod[j]).product();
        integral += wk * v;
        for k in 0..dim {
            let others: f64 = wk / rule.kronrod[d[k]];
            axis_err[k] += others * (rule.kronrod[d[k]] - rule.gauss[d[k]]) * v;
        }
    }
    let axis_err: Vec<f64> = axis_err.iter().map(|e| (e * volume).abs()).collect();
    let worst_axis = (0..dim)
        .max_by(|&a, &b| axis_err[a].total_cmp(&axis_err[b]))
        .unwrap_or(0);
    Panel {
        lo,
        hi,
        values,
        integral: integral * volume,
        error: axis_err.iter().sum(),
        worst_axis,
    }
}

/// Integrates `f` (a non-negative density, unnormalised) over the union of `boxes` to relative
/// error `rel_tol`, bisecting the worst box until then or until `max_panels` boxes exist.
pub fn integrate(
    f: &(dyn Fn(&[f64]) -> f64 + Sync),
    boxes: Vec<(Vec<f64>, Vec<f64>)>,
    rule: Rule,
    rel_tol: f64,
    max_panels: usize,
) -> Cubature {
    let mut panels: Vec<Panel> = boxes.into_iter().map(|(lo, hi)| panel(f, &rule, lo, hi)).collect();
    let total = |ps: &[Panel]| ps.iter().fold((0.0, 0.0), |(i, e), p| (i + p.integral, e + p.error));
    while panels.len() < max_panels {
        let (integral, error) = total(&panels);
        if error <= rel_tol * integral {
            break;
        }
        let worst = (0..panels.len())
            .max_by(|&a, &b| panels[a].error.total_cmp(&panels[b].error))
            .expect("at least one box");
        let p = panels.swap_remove(worst);
        let k = p.worst_axis;
        let mid = (p.lo[k] + p.hi[k]) / 2.0;
        let (mut hi_left, mut lo_right) = (p.hi.clone(), p.lo.clone());
        hi_left[k] = mid;
        lo_right[k] = mid;
        let (a, b) = rayon::join(
            || panel(f, &rule, p.lo.clone(), hi_left),
            || panel(f, &rule, lo_right, p.hi.clone()),
        );
        panels.push(a);
        panels.push(b);
    }
    let (integral, error) = total(&panels);
    let dim = panels.first().map_or(0, |p| p.lo.len());
    let evaluations = panels.len() * rule.len().pow(dim as u32);
    Cubature {
        rule,
        panels,
        integral,
        error,
        evaluations,
    }
}

/// A piece of a marginal: the density (unnormalised) at the rule's nodes over [lo, hi].
#[derive(Debug, Clone)]
struct Piece {
    lo: f64,
    hi: f64,
    values: Vec<f64>,
}

/// The marginal density of one coordinate of a [`Cubature`], normalised.
#[derive(Debug, Clone)]
pub struct Marginal {
    rule: Rule,
    pieces: Vec<Piece>,
    total: f64,
    /// Gauss–Legendre 8 on [−1, 1]: exact for the rule's interpolating polynomials (degree ≤ 14).
    gl: (Vec<f64>, Vec<f64>),
}

impl Cubature {
    /// The marginal of coordinate `axis`: the other axes integrated out box by box.
    pub fn marginal(&self, axis: usize) -> Marginal {
        let n = self.rule.len();
        let pieces = self
            .panels
            .iter()
            .map(|p| {
                let dim = p.lo.len();
                let others: f64 = (0..dim)
                    .filter(|&k| k != axis)
                    .map(|k| (p.hi[k] - p.lo[k]) / 2.0)
                    .product();
                let mut values = vec![0.0; n];
                for (i, v) in p.values.iter().enumerate() {
                    let d = digits(i, n, dim);
                    let w: f64 = (0..dim)
                        .filter(|&k| k != axis)
                        .map(|k| self.rule.kronrod[d[k]])
                        .product();
                    values[d[axis]] += w * v * others;
                }
                Piece {
                    lo: p.lo[axis],
                    hi: p.hi[axis],
                    values,
                }
            })
            .collect();
        Marginal {
            rule: self.rule.clone(),
            pieces,
            total: self.integral,
            gl: gauss_legendre(8),
        }
    }
}

impl Marginal {
    /// Normalised density at x (clamped at 0: the interpolant may dip below in a steep box). Each
    /// box holds [lo, hi) of its axis, the last one its upper end too.
    pub fn density(&self, x: f64) -> f64 {
        let top = self.pieces.iter().map(|p| p.hi).fold(f64::NEG_INFINITY, f64::max);
        let sum: f64 = self
            .pieces
            .iter()
            .filter(|p| p.lo <= x && (x < p.hi || (x == top && p.hi == top)))
            .map(|p| {
                let t = 2.0 * (x - p.lo) / (p.hi - p.lo) - 1.0;
                self.rule.interpolate(&p.values, t)
            })
            .sum();
        (sum / self.total).max(0.0)
    }

    /// Normalised distribution function at x.
    pub fn cdf(&self, x: f64) -> f64 {
        let mut sum = 0.0;
        for p in self.pieces.iter().filter(|p| p.lo < x) {
            let top = x.min(p.hi);
            let half = (top - p.lo) / 2.0;
            for (&g, &w) in self.gl.0.iter().zip(&self.gl.1) {
                let s = p.lo + half * (1.0 + g);
                let t = 2.0 * (s - p.lo) / (p.hi - p.lo) - 1.0;
                sum += w * half * self.rule.interpolate(&p.values, t);
            }
        }
        sum / self.total
    }

    /// The q-quantile, by bisection on the distribution function within [lo, hi].
    pub fn quantile(&self, q: f64, lo: f64, hi: f64) -> f64 {
        let (mut a, mut b) = (lo, hi);
        for _ in 0..60 {
            let m = (a + b) / 2.0;
            if self.cdf(m) < q { a = m } else { b = m }
        }
        (a + b) / 2.0
    }

    /// Posterior mean, by the Kronrod rule on every piece.
    pub fn mean(&self) -> f64 {
        let sum: f64 = self
            .pieces
            .iter()
            .map(|p| {
                let half = (p.hi - p.lo) / 2.0;
                (0..self.rule.len())
                    .map(|j| {
                        let x = p.lo + half * (1.0 + self.rule.nodes[j]);
                        self.rule.kronrod[j] * x * p.values[j]
                    })
                    .sum::<f64>()
                    * half
            })
            .sum();
        sum / self.total
    }

    /// Where the density is worth drawing: `n` even points on [lo, hi] and every rule node.
    pub fn curve(&self, lo: f64, hi: f64, n: usize) -> (Vec<f64>, Vec<f64>) {
        let mut xs: Vec<f64> = (0..n).map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64).collect();
        for p in &self.pieces {
            let half = (p.hi - p.lo) / 2.0;
            xs.extend(self.rule.nodes.iter().map(|t| p.lo + half * (1.0 + t)));
        }
        xs.sort_by(f64::total_cmp);
        xs.dedup();
        let ys = xs.iter().map(|&x| self.density(x)).collect();
        (xs, ys)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn exact_to_degree(rule: &[f64], weights: &[f64], degree: usize) -> bool {
        (0..=degree).all(|k| {
            let q: f64 = rule.iter().zip(weights).map(|(x, w)| w * x.powi(k as i32)).sum();
            let exact = if k % 2 == 1 { 0.0 } else { 2.0 / (k as f64 + 1.0) };
            (q - exact).abs() < 1e-14
        })
    }

    #[test]
    fn rules_are_exact_to_their_degree() {
        for (rule, dk, dg) in [(Rule::k15(), 22, 13), (Rule::k7(), 10, 5)] {
            assert!(exact_to_degree(&rule.nodes, &rule.kronrod, dk));
            assert!(exact_to_degree(&rule.nodes, &rule.gauss, dg));
            assert!(!exact_to_degree(&rule.nodes, &rule.gauss, dg + 1));
        }
        let (x, w) = gauss_legendre(8);
        assert!(exact_to_degree(&x, &w, 15) && !exact_to_degree(&x, &w, 16));
    }

    #[test]
    fn a_sharp_peak_is_integrated_to_tolerance() {
        // Cauchy peak of half-width 1e-4 at 0.3 on [0, 1]: ∫ = (atan(0.7/ε) + atan(0.3/ε))/π · πε/ε.
        let eps: f64 = 1e-4;
        let f = |x: &[f64]| 1.0 / (1.0 + ((x[0] - 0.3) / eps).powi(2));
        let exact = eps * ((0.7 / eps).atan() + (0.3 / eps).atan());
        let c = integrate(&f, vec![(vec![0.0], vec![1.0])], Rule::k15(), 1e-8, 500);
        assert!((c.integral / exact - 1.0).abs() < 1e-8, "{} vs {exact}", c.integral);
        assert!(c.error <= 1e-8 * c.integral);
        // The marginal of a 1-D cubature is the density itself; its median is the peak.
        let m = c.marginal(0);
        assert!((m.quantile(0.5, 0.0, 1.0) - 0.3).abs() < 1e-6);
        assert!((m.cdf(1.0) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn marginals_of_a_correlated_gaussian() {
        // N((0.4, 0.6), Σ) with sd 0.05, 0.08 and correlation 0.7, well inside the unit square:
        // the marginal of x has mean 0.4 and 97.5 % point 0.4 + 1.959964 · 0.05.
        let (s1, s2, rho) = (0.05, 0.08, 0.7);
        let f = |x: &[f64]| {
            let (a, b) = ((x[0] - 0.4) / s1, (x[1] - 0.6) / s2);
            (-(a * a - 2.0 * rho * a * b + b * b) / (2.0 * (1.0 - rho * rho))).exp()
        };
        let c = integrate(&f, vec![(vec![0.0, 0.0], vec![1.0, 1.0])], Rule::k7(), 1e-7, 400);
        let exact = 2.0 * std::f64::consts::PI * s1 * s2 * (1.0 - rho * rho).sqrt();
        assert!((c.integral / exact - 1.0).abs() < 1e-6, "{} vs {exact}", c.integral);
        let m = c.marginal(0);
        assert!((m.mean() - 0.4).abs() < 1e-6, "{}", m.mean());
        let q = m.quantile(0.975, 0.0, 1.0);
        assert!((q - (0.4 + 1.959_964 * s1)).abs() < 1e-5, "{q}");
        let peak = 1.0 / (s1 * (2.0 * std::f64::consts::PI).sqrt());
        assert!((m.density(0.4) / peak - 1.0).abs() < 1e-4, "{}", m.density(0.4));
    }
}
