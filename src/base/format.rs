//! How numbers are written in the words `lab` prints: one place, so that the terminal, the report
//! and the diagnosis's evidence lines agree, and so that no module that decides anything needs the
//! module that words the decisions.

use indexmap::IndexMap;

/// A number with four significant digits, without trailing noise.
pub fn num(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let mag = v.abs().log10().floor() as i32;
    if !(-3..6).contains(&mag) {
        return format!("{v:.3e}");
    }
    let decimals = (3 - mag).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// |v| as a percentage with sensible digits.
pub fn pct(v: f64) -> String {
    let a = 100.0 * v.abs();
    if a >= 10.0 {
        format!("{a:.0} %")
    } else if a >= 1.0 {
        format!("{a:.1} %")
    } else {
        format!("{a:.2} %")
    }
}

/// `p = …`, or `p < 1e-6`.
pub fn p_text(p: f64) -> String {
    if p < 1e-6 {
        "p < 1e-6".to_string()
    } else {
        format!("p = {}", num(p))
    }
}

/// `name = value, …`.
pub fn params(p: &IndexMap<String, f64>) -> String {
    p.iter()
        .map(|(k, v)| format!("{k} = {}", num(*v)))
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_keep_four_significant_digits() {
        assert_eq!(num(184.8123), "184.8");
        assert_eq!(num(0.076543), "0.07654");
        assert_eq!(num(1.0e-7), "1.000e-7");
        assert_eq!(num(0.0), "0");
        assert_eq!(pct(-0.0123), "1.2 %");
        assert_eq!(p_text(3e-7), "p < 1e-6");
    }
}
