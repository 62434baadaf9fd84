//! The few distribution functions the diagnosis needs: tail probabilities on top of statrs's
//! regularised incomplete gamma and beta functions, plus ranks and correlations.

use statrs::distribution::{ChiSquared, ContinuousCDF, Normal, StudentsT};
use statrs::function::beta::checked_beta_reg;
use statrs::function::gamma::checked_gamma_ur;

/// Regularised upper incomplete gamma Q(a, x) = Γ(a, x) / Γ(a); NaN for invalid arguments.
fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    checked_gamma_ur(a, x).unwrap_or(f64::NAN)
}

/// Regularised incomplete beta I_x(a, b); NaN for invalid arguments.
fn beta_i(a: f64, b: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    checked_beta_reg(a, b, x).unwrap_or(f64::NAN)
}

/// P(χ²_k > x).
pub fn chi2_sf(x: f64, k: f64) -> f64 {
    gamma_q(k / 2.0, x / 2.0)
}

/// P(F_{d1,d2} > f); a known noise (d2 ≥ [`super::noise::KNOWN_DOF`]) gives χ²_{d1}/d1.
pub fn f_sf(f: f64, d1: f64, d2: f64) -> f64 {
    if f.is_nan() || f <= 0.0 {
        return 1.0;
    }
    if f.is_infinite() {
        return 0.0;
    }
    if d2 >= super::noise::KNOWN_DOF as f64 {
        return chi2_sf(f * d1, d1);
    }
    beta_i(d2 / 2.0, d1 / 2.0, d2 / (d2 + d1 * f))
}

/// Two-sided P(|Z| > |z|) for a standard normal Z.
pub fn normal_two_sided(z: f64) -> f64 {
    gamma_q(0.5, z * z / 2.0)
}

/// Two-sided P(|T_ν| > |t|) for Student's t with ν degrees of freedom.
pub fn t_two_sided(t: f64, nu: f64) -> f64 {
    if !t.is_finite() {
        return 0.0;
    }
    beta_i(nu / 2.0, 0.5, nu / (nu + t * t))
}

/// The `q` quantile of Student's t with ν degrees of freedom (the normal one for ν = ∞ or 0).
pub fn t_quantile(q: f64, nu: f64) -> f64 {
    match StudentsT::new(0.0, 1.0, nu) {
        Ok(t) if nu.is_finite() && nu > 0.0 => t.inverse_cdf(q),
        _ => normal_quantile(q),
    }
}

/// The power of the two-sided t test at level α on ν degrees of freedom against a shift of δ
/// standard errors: P(|T′| > t(1 − α/2, ν)) for T′ noncentral t(ν, δ). T′ = (Z + δ)/√(V/ν) with
/// V ~ χ²_ν, so the power is E_V[Φ(δ − c√(V/ν)) + Φ(−δ − c√(V/ν))], taken here by the midpoint
/// rule over 1,000 equal steps of V's probability. (The shortcut T_ν(δ − c) overstates it at few
/// degrees of freedom: 0.90 where it is 0.75 at ν = 2.)
pub fn t_power(delta: f64, nu: f64, alpha: f64) -> f64 {
    const STEPS: usize = 1000;
    let c = t_quantile(1.0 - alpha / 2.0, nu);
    let Ok(v) = ChiSquared::new(nu) else {
        return normal_cdf(delta - c) + normal_cdf(-delta - c);
    };
    let total: f64 = (0..STEPS)
        .map(|i| {
            let s = (v.inverse_cdf((i as f64 + 0.5) / STEPS as f64) / nu).sqrt();
            normal_cdf(delta - c * s) + normal_cdf(-delta - c * s)
        })
        .sum();
    total / STEPS as f64
}

/// The `q` quantile of χ² with `k` degrees of freedom.
pub fn chi2_quantile(q: f64, k: f64) -> f64 {
    ChiSquared::new(k).map_or(f64::NAN, |c| c.inverse_cdf(q))
}

/// The `q` quantile of the standard normal.
pub fn normal_quantile(q: f64) -> f64 {
    Normal::standard().inverse_cdf(q)
}

/// P(Z ≤ z) for the standard normal.
pub fn normal_cdf(z: f64) -> f64 {
    Normal::standard().cdf(z)
}

/// Ranks (1-based), ties given their average rank.
pub fn ranks(x: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..x.len()).collect();
    order.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
    let mut r = vec![0.0; x.len()];
    let mut i = 0;
    while i < order.len() {
        let mut j = i;
        while j + 1 < order.len() && x[order[j + 1]] == x[order[i]] {
            j += 1;
        }
        let avg = (i + j) as f64 / 2.0 + 1.0;
        for &k in &order[i..=j] {
            r[k] = avg;
        }
        i = j + 1;
    }
    r
}

/// Pearson correlation; 0 when either vector is constant.
pub fn pearson(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        sxy += (a - mx) * (b - my);
        sxx += (a - mx).powi(2);
        syy += (b - my).powi(2);
    }
    if sxx <= 0.0 || syy <= 0.0 {
        0.0
    } else {
        sxy / (sxx * syy).sqrt()
    }
}

/// Spearman's rank correlation and its two-sided p-value (t approximation with n − 2 degrees of
/// freedom; rough for n < 10 but only used to describe, never to decide the cause).
pub fn spearman(x: &[f64], y: &[f64]) -> (f64, f64) {
    let n = x.len();
    if n < 3 {
        return (0.0, 1.0);
    }
    let rho = pearson(&ranks(x), &ranks(y));
    if rho.abs() >= 1.0 {
        return (rho, 0.0);
    }
    let t = rho * ((n as f64 - 2.0) / (1.0 - rho * rho)).sqrt();
    (rho, t_two_sided(t, n as f64 - 2.0))
}

/// Cosine of the angle between two vectors; 0 when either is zero.
pub fn cosine(a: &[f64], b: &[f64]) -> f64 {
    let dot: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum();
    let na = a.iter().map(|x| x * x).sum::<f64>().sqrt();
    let nb = b.iter().map(|x| x * x).sum::<f64>().sqrt();
    if na == 0.0 || nb == 0.0 { 0.0 } else { dot / (na * nb) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against scipy's noncentral t, an independent implementation (scipy 1.17.1:
    /// `nct.sf(c, ν, δ) + nct.cdf(−c, ν, δ)`, c = `t.ppf(0.995, ν)`, the lower tail below 1e-16
    /// where scipy gave none), at the level 0.01.
    #[test]
    fn t_power_agrees_with_scipys_noncentral_t() {
        for (nu, delta, scipy) in [
            (1.0, 20.0, 0.24659010926994912),
            (2.0, 11.81, 0.7528692007390769),
            (3.0, 7.479, 0.8038857586502299),
            (4.0, 0.5, 0.01274186328141382 + 0.0016990840407932444),
            (5.0, 5.508, 0.8519571905568059),
            (10.0, 4.541, 0.8819882416023058),
            (30.0, 4.06, 0.895467251344536),
        ] {
            let p = t_power(delta, nu, 0.01);
            assert!(
                (p - scipy).abs() < 5e-4,
                "ν = {nu}, δ = {delta}: {p} against scipy's {scipy}"
            );
        }
    }

    // Reference values from scipy.stats (sf / cdf), to 1e-8 relative unless noted.
    #[test]
    fn tail_probabilities_match_reference_values() {
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-8 * b.abs().max(1e-300) + 1e-14;
        assert!(
            close(chi2_sf(3.841458820694124, 1.0), 0.05),
            "{}",
            chi2_sf(3.841458820694124, 1.0)
        );
        assert!(close(chi2_sf(18.307038053275146, 10.0), 0.05));
        assert!(
            close(f_sf(4.964602743730711, 1.0, 10.0), 0.05),
            "{}",
            f_sf(4.964602743730711, 1.0, 10.0)
        );
        // F with 2 numerator degrees of freedom has a closed form: P(F > f) = (1 + 2f/d2)^(−d2/2).
        for (f, d2) in [(0.3f64, 4.0f64), (4.1, 10.0), (25.0, 7.0)] {
            let exact = (1.0 + 2.0 * f / d2).powf(-d2 / 2.0);
            assert!(close(f_sf(f, 2.0, d2), exact), "{} vs {exact}", f_sf(f, 2.0, d2));
        }
        assert!(close(normal_two_sided(1.959963984540054), 0.05));
        assert!(close(t_two_sided(2.2281388519649385, 10.0), 0.05));
        // scipy.stats.t.ppf(0.975, 10), norm.ppf(0.99), norm.cdf(1.2815515655446004).
        assert!((t_quantile(0.975, 10.0) - 2.2281388519649385).abs() < 1e-8);
        assert!((normal_quantile(0.99) - 2.3263478740408408).abs() < 1e-8);
        assert!((normal_cdf(1.2815515655446004) - 0.9).abs() < 1e-10);
    }

    #[test]
    fn ranks_average_ties() {
        assert_eq!(ranks(&[3.0, 1.0, 3.0, 2.0]), vec![3.5, 1.0, 3.5, 2.0]);
        let (rho, p) = spearman(&[1.0, 2.0, 3.0, 4.0, 5.0], &[2.0, 4.0, 8.0, 16.0, 32.0]);
        assert_eq!(rho, 1.0);
        assert_eq!(p, 0.0);
    }
}
