//! The power of lab's F tests, for the seeded families' oracles: whether the data could decide what
//! a test asks of lab, computed from the hidden truth alone (never from lab's own fitting).

use statrs::distribution::{ChiSquared, ContinuousCDF, FisherSnedecor, Normal};

/// Power of the F(1, ν) test at level `alpha` with noncentrality λ, by quadrature over the
/// χ²_ν of the denominator (the numerator is (Z + √λ)², Z standard normal): accurate in the far
/// tail, where a simulation of a few thousand draws is not.
pub fn power_at(lambda: f64, nu: f64, alpha: f64) -> f64 {
    let crit = FisherSnedecor::new(1.0, nu).unwrap().inverse_cdf(1.0 - alpha).sqrt();
    let (chi, z) = (ChiSquared::new(nu).unwrap(), Normal::new(0.0, 1.0).unwrap());
    let root = lambda.max(0.0).sqrt();
    let nodes = 400;
    (0..nodes)
        .map(|i| {
            let q = chi.inverse_cdf((i as f64 + 0.5) / nodes as f64);
            let c = crit * (q / nu).sqrt();
            z.cdf(-c - root) + z.sf(c - root)
        })
        .sum::<f64>()
        / nodes as f64
}
