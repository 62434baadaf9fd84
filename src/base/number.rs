//! Numbers as solvers and test machines write them: Fortran exponents without `E` (`1.0-100`),
//! glued fields, `NaN`, and `***` for a field that overflowed.

use std::path::Path;

use crate::error::InputError;

/// `NaN`, `Infinity` and the like as a number.
pub(crate) fn special_word(w: &str) -> Option<f64> {
    let is = |words: &[&str]| words.iter().any(|k| w.eq_ignore_ascii_case(k));
    if is(&["nan", "+nan", "-nan"]) {
        Some(f64::NAN)
    } else if is(&["inf", "+inf", "infinity", "+infinity"]) {
        Some(f64::INFINITY)
    } else if is(&["-inf", "-infinity"]) {
        Some(f64::NEG_INFINITY)
    } else {
        None
    }
}

/// Length of a Fortran number at the start of `s` (0 if none). See the module doc for the rules.
pub fn number_len(s: &[u8]) -> usize {
    let mut i = 0;
    if i < s.len() && (s[i] == b'+' || s[i] == b'-') {
        i += 1;
    }
    let digits_start = i;
    while i < s.len() && s[i].is_ascii_digit() {
        i += 1;
    }
    let mut int_digits = i - digits_start;
    let mut has_dot = false;
    if i < s.len() && s[i] == b'.' {
        has_dot = true;
        i += 1;
        let f = i;
        while i < s.len() && s[i].is_ascii_digit() {
            i += 1;
        }
        int_digits += i - f;
    }
    if int_digits == 0 {
        return 0;
    }
    // Exponent with a letter.
    if i < s.len() && matches!(s[i], b'E' | b'e' | b'D' | b'd') {
        let mut j = i + 1;
        if j < s.len() && (s[j] == b'+' || s[j] == b'-') {
            j += 1;
        }
        let e = j;
        while j < s.len() && s[j].is_ascii_digit() {
            j += 1;
        }
        if j > e {
            return j;
        }
        return i;
    }
    // Fortran exponent without a letter: mantissa with '.', then sign + exactly three digits.
    if has_dot && i + 4 <= s.len() && (s[i] == b'+' || s[i] == b'-') && s[i + 1..i + 4].iter().all(u8::is_ascii_digit) {
        let after = s.get(i + 4);
        if !matches!(after, Some(c) if c.is_ascii_digit() || *c == b'.') {
            return i + 4;
        }
    }
    i
}

/// The value of a Fortran number token (as measured by [`number_len`]).
pub fn number_value(t: &str) -> Option<f64> {
    let b = t.as_bytes();
    if number_len(b) != b.len() || b.is_empty() {
        return None;
    }
    measured_value(t)
}

/// [`number_value`] of a token [`number_len`] has measured. The common forms (`1.5E+02`, `150`)
/// parse as they are; only `D` exponents and letterless ones (`1.5+102`) are rewritten first.
pub(crate) fn measured_value(t: &str) -> Option<f64> {
    let b = t.as_bytes();
    let letter = b.iter().position(|c| matches!(c, b'E' | b'e' | b'D' | b'd'));
    let sign = || b.iter().skip(1).rposition(|c| matches!(c, b'+' | b'-')).map(|i| i + 1);
    match letter {
        Some(i) if matches!(b[i], b'D' | b'd') => format!("{}E{}", &t[..i], &t[i + 1..]).parse().ok(),
        Some(_) => t.parse().ok(),
        None => match sign() {
            Some(i) => format!("{}E{}", &t[..i], &t[i..]).parse().ok(),
            None => t.parse().ok(),
        },
    }
}

/// Parse one whole token as a number (`1.0E+00`, `1.0-100`, `NaN`, `***`).
pub fn parse_number(t: &str) -> Option<f64> {
    if !t.is_empty() && t.bytes().all(|c| c == b'*') {
        return Some(f64::NAN);
    }
    number_value(t).or_else(|| special_word(t))
}

/// Read a file as text; invalid UTF-8 is replaced (the formats are ASCII; bad bytes then fail to parse).
pub fn read_text(file: &Path) -> Result<String, InputError> {
    let bytes = std::fs::read(file).map_err(|e| InputError::file(file, format!("cannot read: {e}")))?;
    Ok(String::from_utf8_lossy(&bytes).into_owned())
}
