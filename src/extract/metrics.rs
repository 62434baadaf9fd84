//! Curve metrics: how far a computed force–displacement curve is from a target (test) curve.
//!
//! Curves are `&[[f64; 2]]` of `[x, y]` = `[displacement, force]` points in their recorded order;
//! `exp` is the target (the test), `num` the computed curve. Every function is pure and returns
//! NaN where its definition gives no number (empty curves, a target with no range for [`pcm`],
//! grids of different lengths for [`mse`]).
//!
//! - [`mse`], [`weighted_mse`]: LS-OPT's Mean Squared Error on a common grid (see [`super::grid`]).
//! - [`pcm`], [`frechet`], [`dtw`], [`area`]: as `similaritymeasures` 1.5.0 (Jekel; PyPI) computes
//!   them — `pcm`, `frechet_dist(p=2)`, `dtw(...)[0]`, `area_between_two_curves` — reproduced from
//!   its source, including where its algorithm is unusual (said at each function), so that a value
//!   from `lab` and one from that package agree to rounding. Sums are numpy's pairwise sums and
//!   interpolation is `np.interp`'s, so that the package's discrete choices (which curve is longer,
//!   which segment is longest) fall the same way. `tests/curve_metrics_reference.rs` checks this
//!   against the package itself.
//!
//! The distance metrics work in the curves' own units, where one mm and one kN count the same:
//! [`frechet`] is a length in "mm-or-kN", [`dtw`] a sum of such lengths, [`area`] is in mm·kN = J;
//! [`pcm`] normalises both axes by the target's ranges and is dimensionless.

use super::crush::ForceDisplacement;

/// A curve's points `[displacement, force]`, in order.
pub fn curve_points(curve: &ForceDisplacement) -> Vec<[f64; 2]> {
    curve
        .displacement
        .iter()
        .zip(&curve.force)
        .map(|(&x, &y)| [x, y])
        .collect()
}

/// LS-OPT's Mean Squared Error of a computed curve against its target on a common grid: the mean
/// over the grid points of `((computed − target) / s)²` with `s = max |target|`, LS-OPT's default
/// scale factor (LS-OPT User's Manual, "Mean Squared Error" curve-matching composite:
/// `ε = (1/P) Σ W_p ((f_p − G_p) / s_p)²`, here with `W_p = 1`). Dimensionless. `s = 1` when the
/// target is identically zero (no scale to take). NaN for empty or unequal grids.
pub fn mse(target_on_grid: &[f64], computed_on_grid: &[f64]) -> f64 {
    weighted_mse(target_on_grid, computed_on_grid, &vec![1.0; target_on_grid.len()])
}

/// [`mse`] with a weight `W_p` per grid point (e.g. `1/σ_p²` from replicate scatter):
/// `(1/P) Σ W_p ((computed_p − target_p) / s)²`, `s = max |target|` as in [`mse`]. So with
/// `W_p = 1/σ_p²` it is χ² / (P s²). NaN for empty or unequal lengths.
pub fn weighted_mse(target: &[f64], computed: &[f64], weights: &[f64]) -> f64 {
    if target.is_empty() || target.len() != computed.len() || target.len() != weights.len() {
        return f64::NAN;
    }
    let s = target.iter().fold(0.0_f64, |m, t| m.max(t.abs()));
    let s = if s > 0.0 { s } else { 1.0 };
    let sum: f64 = target
        .iter()
        .zip(computed)
        .zip(weights)
        .map(|((t, c), w)| w * ((c - t) / s).powi(2))
        .sum();
    sum / target.len() as f64
}

/// Partial Curve Mapping (Witowski & Stander 2012; Jekel, Venter, Venter, Stander & Haftka 2019,
/// "Similarity measures for identifying material parameters from hysteresis loops using inverse
/// analysis", Int. J. Mater. Form.), exactly as `similaritymeasures.pcm(exp, num)` 1.5.0
/// (`norm_seg_length=False`):
///
/// 1. both curves are normalised by the target's ranges: `ξ = (x − min x_exp) / (max x_exp − min x_exp)`,
///    likewise `η` for y (the computed curve may fall outside [0, 1]);
/// 2. each curve's cumulative arc length in (ξ, η) is divided by its own total, so runs 0 → 1;
/// 3. the curve with the longer total length becomes curve 1, the other curve 2;
/// 4. for 200 offsets from 0 to `L1 − L2` (one offset, 0, when the lengths are equal), curve 2 is
///    read (linear interpolation in its fractional arc length, clamped at its ends) at curve 1's
///    fractional arc lengths plus the offset, and the score is `Σ_i ½ (d_i + d_{i+1}) · s_{i+1}`
///    where `d` are the point distances and `s_{i+1}` curve 1's fractional arc length at point i+1;
/// 5. the result is the smallest score.
///
/// Reproduced on purpose although odd: the offset is an absolute length while the arc lengths it is
/// added to are fractions of 1 (so most offsets read curve 2 clamped at its end); the trapezoids are
/// weighted by the cumulative arc length `s_{i+1}`, not the segment length, so late points count
/// more; and which curve is "1" depends on lengths, not on which is the target.
pub fn pcm(exp: &[[f64; 2]], num: &[[f64; 2]]) -> f64 {
    if exp.is_empty() || num.is_empty() {
        return f64::NAN;
    }
    let (mut c1, mut c2) = normalise_by_target(exp, num);
    let (mut len1, mut len2) = (arc_length(&c1), arc_length(&c2));
    if len2.total > len1.total {
        std::mem::swap(&mut c1, &mut c2);
        std::mem::swap(&mut len1, &mut len2);
    }
    let s1: Vec<f64> = len1.cumulative.iter().map(|s| s / len1.total).collect();
    let s2: Vec<f64> = len2.cumulative.iter().map(|s| s / len2.total).collect();
    let (x2, y2): (Vec<f64>, Vec<f64>) = c2.iter().map(|p| (p[0], p[1])).unzip();
    let max_offset = len1.total - len2.total;
    let offsets = if max_offset == 0.0 {
        vec![0.0]
    } else {
        linspace(0.0, max_offset, 200)
    };
    let score = |offset: f64| {
        let d: Vec<f64> = c1
            .iter()
            .zip(&s1)
            .map(|(p, s)| {
                let (x, y) = (np_interp(s + offset, &s2, &x2), np_interp(s + offset, &s2, &y2));
                let (dy, dx) = (p[1] - y, p[0] - x);
                (dy * dy + dx * dx).sqrt()
            })
            .collect();
        let v: Vec<f64> = (1..d.len()).map(|i| 0.5 * (d[i - 1] + d[i]) * s1[i]).collect();
        pairwise_sum(&v)
    };
    offsets.into_iter().map(score).fold(f64::INFINITY, nan_min)
}

/// Discrete Fréchet distance (Eiter & Mannila 1994, "Computing discrete Fréchet distance"), with
/// Euclidean point distances: the smallest, over monotone couplings of the two point sequences,
/// of the largest coupled distance. As `similaritymeasures.frechet_dist(exp, num, p=2)`.
/// O(n·m) time, O(m) memory (one row of the coupling table).
pub fn frechet(exp: &[[f64; 2]], num: &[[f64; 2]]) -> f64 {
    coupling(exp, num, py_max)
}

/// Dynamic time warping distance (Senin 2008, "Dynamic time warping algorithm review"), with
/// Euclidean point distances: the smallest sum of coupled distances over monotone couplings that
/// start at both first points and end at both last points. As the first value of
/// `similaritymeasures.dtw(exp, num)`. O(n·m) time, O(m) memory (one row of the cumulative table).
pub fn dtw(exp: &[[f64; 2]], num: &[[f64; 2]]) -> f64 {
    coupling(exp, num, |best, d| best + d)
}

/// The last cell of the coupling table of [`frechet`] and [`dtw`], kept one row at a time: a cell
/// is `extend(best, d)` of the best of its three predecessors (the one before it in its row or
/// column at the table's edges) and the distance of its two points. NaN for an empty curve.
fn coupling(exp: &[[f64; 2]], num: &[[f64; 2]], extend: impl Fn(f64, f64) -> f64) -> f64 {
    if exp.is_empty() || num.is_empty() {
        return f64::NAN;
    }
    let mut row: Vec<f64> = Vec::with_capacity(num.len());
    for (j, q) in num.iter().enumerate() {
        let c = dist(&exp[0], q);
        row.push(if j == 0 { c } else { extend(row[j - 1], c) });
    }
    for p in &exp[1..] {
        let mut diag = row[0];
        row[0] = extend(row[0], dist(p, &num[0]));
        for (j, q) in num.iter().enumerate().skip(1) {
            let up = row[j];
            row[j] = extend(py_min3(up, row[j - 1], diag), dist(p, q));
            diag = up;
        }
    }
    row[num.len() - 1]
}

/// Area between two curves by quadrilaterals (Jekel et al. 2019, as above), exactly as
/// `similaritymeasures.area_between_two_curves(exp, num)` 1.5.0:
///
/// 1. the curve with more points is taken as the first (equal counts: `exp` first);
/// 2. the other gets points added until the counts match: each time, its longest segment (Euclidean
///    length in the curves' own units; the first of equal ones) is split at the midpoint of its x
///    range, y interpolated linearly in x;
/// 3. point i of one curve is paired with point i of the other, and the area is the sum over i of
///    the quadrilateral `first[i−1], first[i], second[i], second[i−1]` (shoelace formula) after
///    reordering its corners to make it simple when they cross.
///
/// Reproduced on purpose although odd: a vertical segment (equal x) "splits" into a zero-length
/// copy of its first point and itself, so it stays the longest and takes every added point; the
/// corner reordering tries two swaps and, when neither gives a simple quadrilateral, keeps the
/// last (still crossing) one; pairing by index, not by stroke, means the value depends on how
/// the points are spread along each curve. Units: mm·kN = J. Time O(n·k) for k added points.
pub fn area(exp: &[[f64; 2]], num: &[[f64; 2]]) -> f64 {
    let (first, second) = if exp.len() < num.len() { (num, exp) } else { (exp, num) };
    // No points, or one point that cannot be split into more (the package raises there).
    if second.is_empty() || (second.len() == 1 && first.len() > 1) {
        return f64::NAN;
    }
    let second = add_points(second, first.len());
    let quads: Vec<f64> = (1..first.len())
        .map(|i| quad_area([first[i - 1], first[i], second[i], second[i - 1]]))
        .collect();
    pairwise_sum(&quads)
}

/// `curve` with points added (step 2 of [`area`]) until it has `n`.
fn add_points(curve: &[[f64; 2]], n: usize) -> Vec<[f64; 2]> {
    let mut c = curve.to_vec();
    let mut seg: Vec<f64> = c.windows(2).map(|w| dist(&w[0], &w[1])).collect();
    while c.len() < n && !seg.is_empty() {
        let k = np_argmax(&seg);
        let (p, q) = (c[k], c[k + 1]);
        let x = (q[0] + p[0]) / 2.0;
        let y = if p[0] < q[0] {
            np_interp(x, &[p[0], q[0]], &[p[1], q[1]])
        } else {
            np_interp(x, &[q[0], p[0]], &[q[1], p[1]])
        };
        let mid = [x, y];
        c.insert(k + 1, mid);
        seg[k] = dist(&p, &mid);
        seg.insert(k + 1, dist(&mid, &q));
    }
    c
}

/// The shoelace area of a quadrilateral after `makeQuad`'s reordering: as given if simple, else
/// with the first two corners swapped, else with the second and third swapped (kept either way).
fn quad_area(q: [[f64; 2]; 4]) -> f64 {
    let orders = [[0, 1, 2, 3], [1, 0, 2, 3], [0, 2, 1, 3]];
    let mut corners = q;
    for order in orders {
        corners = order.map(|i| q[i]);
        if is_simple_quad(&corners) {
            break;
        }
    }
    shoelace(&corners)
}

/// `is_simple_quad`: of the four corner cross products (AB×BC, BC×CD, CD×DA, DA×AB), at least three
/// share the majority sign (zeros count with either sign).
fn is_simple_quad(q: &[[f64; 2]; 4]) -> bool {
    let edge = |i: usize| {
        let (a, b) = (q[i], q[(i + 1) % 4]);
        [b[0] - a[0], b[1] - a[1]]
    };
    let e = [edge(0), edge(1), edge(2), edge(3)];
    let cross: Vec<f64> = (0..4)
        .map(|i| {
            let (a, b) = (e[i], e[(i + 1) % 4]);
            a[0] * b[1] - a[1] * b[0]
        })
        .collect();
    let positive = cross.iter().filter(|&&c| c > 0.0).count();
    let negative = cross.iter().filter(|&&c| c < 0.0).count();
    let same = if positive < negative {
        cross.iter().filter(|&&c| c <= 0.0).count()
    } else {
        cross.iter().filter(|&&c| c >= 0.0).count()
    };
    same > 2
}

/// `poly_area`: ½ |Σ x_i y_{i−1} − Σ y_i x_{i−1}|, each sum in index order as numpy's 4-element dot.
fn shoelace(q: &[[f64; 2]; 4]) -> f64 {
    let (mut xy, mut yx) = (0.0, 0.0);
    for i in 0..4 {
        let prev = q[(i + 3) % 4];
        xy += q[i][0] * prev[1];
        yx += q[i][1] * prev[0];
    }
    0.5 * (xy - yx).abs()
}

/// Both curves normalised by the target's x and y ranges (`normalizeTwoCurves`).
fn normalise_by_target(exp: &[[f64; 2]], num: &[[f64; 2]]) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
    let range = |k: usize| {
        exp.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (nan_min(lo, p[k]), nan_max(hi, p[k]))
        })
    };
    let ((x0, x1), (y0, y1)) = (range(0), range(1));
    let norm = |c: &[[f64; 2]]| -> Vec<[f64; 2]> {
        c.iter()
            .map(|p| [(p[0] - x0) / (x1 - x0), (p[1] - y0) / (y1 - y0)])
            .collect()
    };
    (norm(exp), norm(num))
}

/// Arc length along a curve (`get_length` without segment normalisation).
struct ArcLength {
    /// 0, then the running sum of segment lengths (in order).
    cumulative: Vec<f64>,
    /// numpy's sum of the segment lengths (with a leading 0).
    total: f64,
}

fn arc_length(c: &[[f64; 2]]) -> ArcLength {
    let mut segments = vec![0.0];
    let mut cumulative = vec![0.0];
    for w in c.windows(2) {
        let l = dist(&w[0], &w[1]);
        segments.push(l);
        cumulative.push(cumulative[cumulative.len() - 1] + l);
    }
    ArcLength {
        cumulative,
        total: pairwise_sum(&segments),
    }
}

/// Euclidean distance, as scipy's `cdist` computes it: `sqrt(dx² + dy²)`.
fn dist(p: &[f64; 2], q: &[f64; 2]) -> f64 {
    let (dx, dy) = (p[0] - q[0], p[1] - q[1]);
    (dx * dx + dy * dy).sqrt()
}

/// numpy's `np.sum` of a float64 array: pairwise summation in blocks of 128 with 8 accumulators
/// (numpy `pairwise_sum`), so that sums round as they do there.
fn pairwise_sum(a: &[f64]) -> f64 {
    let n = a.len();
    if n < 8 {
        return a.iter().fold(0.0, |s, v| s + v);
    }
    if n <= 128 {
        let mut r: [f64; 8] = std::array::from_fn(|k| a[k]);
        let whole = n - n % 8;
        for block in a[8..whole].chunks_exact(8) {
            for k in 0..8 {
                r[k] += block[k];
            }
        }
        let res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        return a[whole..].iter().fold(res, |s, v| s + v);
    }
    let half = n / 2 - (n / 2) % 8;
    pairwise_sum(&a[..half]) + pairwise_sum(&a[half..])
}

/// `np.interp(x, xp, fp)` for non-decreasing `xp`: ends held, else the bracket `xp[j] <= x < xp[j+1]`
/// with the last such `j` (so at a repeated `xp` value the last of them wins).
fn np_interp(x: f64, xp: &[f64], fp: &[f64]) -> f64 {
    let n = xp.len();
    if x.is_nan() {
        return x;
    }
    if x > xp[n - 1] {
        return fp[n - 1];
    }
    if x < xp[0] {
        return fp[0];
    }
    // Only NaNs in `xp` (garbage in, as in numpy) can leave no bracket below `x`.
    let Some(j) = xp.partition_point(|&v| v <= x).checked_sub(1) else {
        return fp[0];
    };
    if j == n - 1 || xp[j] == x {
        return fp[j];
    }
    let slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j]);
    let y = slope * (x - xp[j]) + fp[j];
    if !y.is_nan() {
        return y;
    }
    let y = slope * (x - xp[j + 1]) + fp[j + 1];
    if y.is_nan() && fp[j] == fp[j + 1] { fp[j] } else { y }
}

/// `np.linspace(start, stop, num)`: `i · step + start`, the last exactly `stop`.
fn linspace(start: f64, stop: f64, num: usize) -> Vec<f64> {
    let div = (num - 1) as f64;
    let delta = stop - start;
    let step = delta / div;
    let mut y: Vec<f64> = (0..num)
        .map(|i| {
            let t = if step == 0.0 {
                i as f64 / div * delta
            } else {
                i as f64 * step
            };
            t + start
        })
        .collect();
    y[num - 1] = stop;
    y
}

/// `np.argmax`: the first largest, or the first NaN.
fn np_argmax(v: &[f64]) -> usize {
    let mut best = 0;
    for (i, &x) in v.iter().enumerate() {
        if x.is_nan() {
            return i;
        }
        if x > v[best] {
            best = i;
        }
    }
    best
}

/// Python's `min((a, b, c))`: the first smallest by `<` (NaN-blind as Python is).
fn py_min3(a: f64, b: f64, c: f64) -> f64 {
    let mut m = a;
    if b < m {
        m = b;
    }
    if c < m {
        m = c;
    }
    m
}

/// Python's `max(a, b)`: `b` only when `b > a`.
fn py_max(a: f64, b: f64) -> f64 {
    if b > a { b } else { a }
}

/// numpy's `min`/`max` reductions propagate NaN.
fn nan_min(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() { f64::NAN } else { a.min(b) }
}

fn nan_max(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() { f64::NAN } else { a.max(b) }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(x0: f64, x1: f64, n: usize, f: impl Fn(f64) -> f64) -> Vec<[f64; 2]> {
        (0..n)
            .map(|i| {
                let x = x0 + (x1 - x0) * i as f64 / (n - 1) as f64;
                [x, f(x)]
            })
            .collect()
    }

    #[test]
    fn mse_is_scaled_by_the_largest_target() {
        // Target [2, -4], computed [3, -4]: ((1/4)² + 0) / 2 = 1/32.
        assert_eq!(mse(&[2.0, -4.0], &[3.0, -4.0]), 1.0 / 32.0);
        assert_eq!(mse(&[1.0, 2.0], &[1.0, 2.0]), 0.0);
        assert_eq!(weighted_mse(&[2.0, -4.0], &[3.0, -3.0], &[4.0, 0.0]), 4.0 / 16.0 / 2.0);
        assert_eq!(mse(&[0.0, 0.0], &[1.0, 1.0]), 1.0, "s = 1 for a zero target");
        assert!(mse(&[1.0], &[1.0, 2.0]).is_nan() && mse(&[], &[]).is_nan());
    }

    #[test]
    fn frechet_of_parallel_lines_is_their_distance() {
        // y = 0 and y = 3 over [0, 10], same x samples: every coupling pairs points 3 apart (1e-12).
        let (a, b) = (line(0.0, 10.0, 11, |_| 0.0), line(0.0, 10.0, 11, |_| 3.0));
        assert!((frechet(&a, &b) - 3.0).abs() < 1e-12);
        // Discrete: sampled at every half mm, y = 3 has points half a mm from any point of y = 0,
        // so the distance is sqrt(0.5² + 3²), not 3.
        let half = frechet(&a, &line(0.0, 10.0, 21, |_| 3.0));
        assert!((half - 9.25_f64.sqrt()).abs() < 1e-12, "{half}");
        // An outlier (5, 8) must be coupled with some point of y = 0; the nearest is (5, 0).
        let mut c = line(0.0, 10.0, 11, |_| 3.0);
        c[5][1] = 8.0;
        assert!((frechet(&a, &c) - 8.0).abs() < 1e-12, "{}", frechet(&a, &c));
        assert_eq!(frechet(&a, &a), 0.0);
    }

    #[test]
    fn dtw_of_identical_curves_is_zero_and_of_shifted_ones_the_sum() {
        let a = line(0.0, 10.0, 11, |x| x * x);
        assert_eq!(dtw(&a, &a), 0.0);
        // y = 0 vs y = 2 with the same 11 x: the diagonal coupling costs 11 × 2 = 22 (1e-12).
        let (b, c) = (line(0.0, 10.0, 11, |_| 0.0), line(0.0, 10.0, 11, |_| 2.0));
        assert!((dtw(&b, &c) - 22.0).abs() < 1e-12);
        // Repeating a point costs nothing more in DTW.
        let mut d = b.clone();
        d.insert(3, d[3]);
        assert!((dtw(&d, &b)).abs() < 1e-12);
    }

    #[test]
    fn area_between_y0_and_y1_over_unit_interval_is_one() {
        let (a, b) = (line(0.0, 1.0, 2, |_| 0.0), line(0.0, 1.0, 2, |_| 1.0));
        assert!((area(&a, &b) - 1.0).abs() < 1e-15);
        // Different point counts: the 2-point curve gets its midpoints added; still 1 (1e-12).
        let c = line(0.0, 1.0, 7, |_| 0.0);
        assert!((area(&c, &b) - 1.0).abs() < 1e-12, "{}", area(&c, &b));
        assert!((area(&b, &c) - 1.0).abs() < 1e-12);
        // Crossing lines y = x and y = 1 − x on [0, 1]: two triangles of 1/4 each.
        let (d, e) = (line(0.0, 1.0, 3, |x| x), line(0.0, 1.0, 3, |x| 1.0 - x));
        assert!((area(&d, &e) - 0.5).abs() < 1e-12, "{}", area(&d, &e));
        assert_eq!(area(&a, &a), 0.0);
    }

    #[test]
    fn area_adds_points_to_the_longest_segment_first() {
        // Segments of length 1 and 3: the 3 splits at 2.5, then the first 1.5 at 1.75, then the
        // other 1.5 at 3.25.
        let c = [[0.0, 0.0], [1.0, 0.0], [4.0, 0.0]];
        let x: Vec<f64> = add_points(&c, 6).iter().map(|p| p[0]).collect();
        assert_eq!(x, vec![0.0, 1.0, 1.75, 2.5, 3.25, 4.0]);
        // A vertical segment keeps taking the added points, each a copy of its first point.
        let v = add_points(&[[0.0, 0.0], [0.0, 5.0], [1.0, 5.0]], 5);
        assert_eq!(v, vec![[0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [0.0, 5.0], [1.0, 5.0]]);
    }

    #[test]
    fn pcm_of_identical_curves_is_zero_and_grows_with_the_gap() {
        let a = line(0.0, 10.0, 30, |x| (x * 0.7).sin() + x);
        assert_eq!(pcm(&a, &a), 0.0);
        let b: Vec<[f64; 2]> = a.iter().map(|p| [p[0], p[1] + 0.1]).collect();
        let c: Vec<[f64; 2]> = a.iter().map(|p| [p[0], p[1] + 0.5]).collect();
        let (pb, pc) = (pcm(&a, &b), pcm(&a, &c));
        assert!(pb > 0.0 && pc > 2.0 * pb, "{pb} {pc}");
        // A constant target has no y range to normalise by.
        assert!(pcm(&line(0.0, 1.0, 5, |_| 1.0), &a).is_nan());
    }

    #[test]
    fn pcm_of_a_shifted_straight_line_by_hand() {
        // Target (0,0)-(1,1) in 3 points, computed the same shifted up by 0.5 (normalised: 0.5).
        // Equal lengths → one offset 0; every distance is 0.5; fractional arc lengths 0, ½, 1:
        // score = ½(0.5+0.5)·½ + ½(0.5+0.5)·1 = 0.75 (1e-15).
        let a = [[0.0, 0.0], [0.5, 0.5], [1.0, 1.0]];
        let b = [[0.0, 0.5], [0.5, 1.0], [1.0, 1.5]];
        assert!((pcm(&a, &b) - 0.75).abs() < 1e-15, "{}", pcm(&a, &b));
    }

    #[test]
    fn numpy_helpers_behave_as_numpy() {
        // np.interp at a repeated xp value takes the last of them; ends are held.
        assert_eq!(np_interp(1.0, &[0.0, 1.0, 1.0, 2.0], &[0.0, 5.0, 7.0, 9.0]), 7.0);
        assert_eq!(np_interp(-1.0, &[0.0, 1.0], &[3.0, 4.0]), 3.0);
        assert_eq!(np_interp(2.0, &[0.0, 1.0], &[3.0, 4.0]), 4.0);
        assert_eq!(np_interp(0.25, &[0.0, 1.0], &[3.0, 4.0]), 3.25);
        assert_eq!(linspace(0.0, 1.0, 5), vec![0.0, 0.25, 0.5, 0.75, 1.0]);
        assert_eq!(np_argmax(&[1.0, 3.0, 3.0, 2.0]), 1);
        // Pairwise sum: exact on integers; on 1e16 and fifteen 1s (ulp 2 at 1e16) left to right
        // loses every 1, numpy's 8 accumulators lose only the one added to 1e16: 1e16 + 14 (numpy
        // 2.4 gives 1.0000000000000014e16).
        let v: Vec<f64> = (0..300).map(f64::from).collect();
        assert_eq!(pairwise_sum(&v), 44850.0);
        let mut w = vec![1.0; 16];
        w[0] = 1e16;
        assert_eq!(w.iter().fold(0.0, |s, x| s + x), 1e16);
        assert_eq!(pairwise_sum(&w), 1e16 + 14.0);
    }

    #[test]
    fn empty_curves_give_nan() {
        let a = line(0.0, 1.0, 3, |x| x);
        for f in [pcm, frechet, dtw, area] {
            assert!(f(&a, &[]).is_nan() && f(&[], &a).is_nan());
        }
    }
}
