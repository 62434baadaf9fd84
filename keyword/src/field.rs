//! Fixed-width fields of LS-DYNA keyword cards (10 characters, 8 per 80-column line).
//!
//! A value is written in the shortest text that reads back to the same `f64` (Rust's shortest
//! round-trip digits, as plain decimal or as `1.85e+02`-style exponent form); if even that does not
//! fit the field, formatting fails with an error naming the value and the width. Nothing is ever
//! silently truncated or rounded. A caller that wants a rounded value asks for it with [`fit_real`].

use std::fmt;

/// A value that cannot be written into its field.
#[derive(Debug, Clone, PartialEq)]
pub struct FieldError {
    pub value: String,
    pub width: usize,
    pub reason: String,
}

impl fmt::Display for FieldError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "cannot write {} into a {}-character field: {}",
            self.value, self.width, self.reason
        )
    }
}

impl std::error::Error for FieldError {}

fn err(value: impl fmt::Display, width: usize, reason: impl Into<String>) -> FieldError {
    FieldError {
        value: value.to_string(),
        width,
        reason: reason.into(),
    }
}

/// The candidate texts for a real value, each of which parses back to exactly `value`.
fn real_candidates(value: f64) -> Vec<String> {
    let mut plain = format!("{value}");
    if !plain.contains(['.', 'e', 'E']) {
        plain.push_str(".0");
    }
    let exp = format!("{value:e}"); // shortest digits, e.g. "1.85e2", "2.7e-9"
    let (mantissa, power) = exp.split_once('e').unwrap_or((&exp, "0"));
    let power: i32 = power.parse().unwrap_or(0);
    let mantissa = if mantissa.contains('.') {
        mantissa.to_string()
    } else {
        format!("{mantissa}.0")
    };
    let sign = if power < 0 { '-' } else { '+' };
    let long = format!("{mantissa}e{sign}{:02}", power.abs());
    let short = format!("{mantissa}e{power}");
    let mut all = vec![plain, long, short];
    if let Some(stripped) = all[0].strip_prefix("0.") {
        all.push(format!(".{stripped}"));
    }
    if let Some(stripped) = all[0].strip_prefix("-0.") {
        all.push(format!("-.{stripped}"));
    }
    all.retain(|s| s.parse::<f64>().ok() == Some(value));
    all
}

/// The shortest text that reads back to exactly `value`, with no padding.
///
/// Plain decimal is preferred to exponent form at equal length; `1.85e+02` beats `1.85e2` only
/// when it fits, because a two-digit exponent is what Fortran-style readers expect.
pub fn real_text(value: f64, width: usize) -> Result<String, FieldError> {
    if !value.is_finite() {
        return Err(err(value, width, "not a finite number"));
    }
    let candidates = real_candidates(value);
    let fits = |s: &&String| s.len() <= width;
    let plain = candidates.first().filter(fits);
    let long_exp = candidates.get(1).filter(fits);
    let best = match (plain, long_exp) {
        (Some(p), Some(e)) if e.len() < p.len() => Some(e.clone()),
        (Some(p), _) => Some(p.clone()),
        (None, Some(e)) => Some(e.clone()),
        (None, None) => candidates.iter().filter(fits).min_by_key(|s| s.len()).cloned(),
    };
    best.ok_or_else(|| {
        let shortest = candidates.iter().map(String::len).min().unwrap_or(0);
        err(
            value,
            width,
            format!("its shortest exact form needs {shortest} characters; round it explicitly"),
        )
    })
}

/// A real value right-aligned in a field of `width` characters, exact or an error.
pub fn real(value: f64, width: usize) -> Result<String, FieldError> {
    real_text(value, width).map(|s| format!("{s:>width$}"))
}

/// An integer right-aligned in a field of `width` characters, or an error when it does not fit.
pub fn int(value: i64, width: usize) -> Result<String, FieldError> {
    let s = value.to_string();
    if s.len() > width {
        return Err(err(value, width, format!("needs {} characters", s.len())));
    }
    Ok(format!("{s:>width$}"))
}

/// Text (a name, a file, an `&name` reference) left-aligned in a field of `width` characters.
pub fn text(value: &str, width: usize) -> Result<String, FieldError> {
    if value.contains(['\n', '\r']) {
        return Err(err(format!("{value:?}"), width, "contains a line break"));
    }
    let n = value.chars().count();
    if n > width {
        return Err(err(format!("{value:?}"), width, format!("needs {n} characters")));
    }
    Ok(format!("{value:<width$}"))
}

/// A `*PARAMETER` name field: the type letter (`R`, `I` or `C`), a space, the name, in 10 columns.
pub fn param_name(kind: char, name: &str) -> Result<String, FieldError> {
    if !matches!(kind, 'R' | 'I' | 'C') {
        return Err(err(kind, 10, "the parameter type must be R, I or C"));
    }
    if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        return Err(err(
            format!("{name:?}"),
            10,
            "a parameter name is letters, digits and '_'",
        ));
    }
    // `&name` must fit a 10-character field where it is used: at most 9 characters.
    if name.len() > 8 {
        return Err(err(
            format!("{name:?}"),
            10,
            "a parameter name has at most 8 characters here",
        ));
    }
    text(&format!("{kind} {name}"), 10)
}

/// The value nearest to `value` with the most significant digits that still fits `width`
/// characters: an explicit, visible rounding for callers that choose it (never done implicitly).
pub fn fit_real(value: f64, width: usize) -> Result<f64, FieldError> {
    if !value.is_finite() {
        return Err(err(value, width, "not a finite number"));
    }
    for digits in (1..=17).rev() {
        let rounded: f64 = format!("{value:.*e}", digits - 1).parse().unwrap_or(value);
        if real_text(rounded, width).is_ok() {
            return Ok(rounded);
        }
    }
    Err(err(value, width, "no rounding of it fits"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shortest_forms() {
        assert_eq!(real_text(185.0, 10).unwrap(), "185.0");
        assert_eq!(real_text(2.7e-9, 10).unwrap(), "2.7e-09");
        assert_eq!(real_text(0.15, 10).unwrap(), "0.15");
        assert_eq!(real_text(68000.0, 10).unwrap(), "68000.0");
        assert_eq!(real_text(1.0e28, 10).unwrap(), "1.0e+28");
        assert_eq!(real(0.05, 10).unwrap(), "      0.05");
    }

    #[test]
    fn refuses_what_does_not_fit() {
        let e = real(137.2839102938401, 10).unwrap_err();
        assert!(e.to_string().contains("137.2839102938401"), "{e}");
        assert!(e.to_string().contains("10-character"), "{e}");
        assert!(int(12345678901, 10).is_err());
        assert!(text("&ABCDEFGHIJ", 10).is_err());
    }

    #[test]
    fn fit_rounds_explicitly() {
        let v = fit_real(137.2839102938401, 10).unwrap();
        assert_eq!(real_text(v, 10).unwrap(), "137.28391");
    }
}
