//! Fixed-width number fields of the mesh's keyword text, written without `core::fmt`.
//!
//! A fine tube's `*NODE` block is hundreds of thousands of `{:16.9}` fields, and Rust's exact
//! float formatting (Grisu with a Dragon fallback) was most of the time of meshing it. Here a
//! double's exact binary value m·2^e is scaled by 10⁹ in 128-bit integers and rounded half to
//! even, which is what the formatter does, so the text, hence every run key, is byte for byte the
//! same (checked against `format!` in the tests of [`super`]).

use std::fmt::Write;

/// Appends `format!("{x:width$.9}")`.
pub fn push_fixed9(out: &mut String, x: f64, width: usize) {
    let Some(q) = scaled_by_1e9(x) else {
        let _ = write!(out, "{x:width$.9}");
        return;
    };
    let mut int = itoa::Buffer::new();
    let mut frac = itoa::Buffer::new();
    let int = int.format(q / 1_000_000_000);
    let frac = frac.format((q % 1_000_000_000) as u32);
    let sign = usize::from(x.is_sign_negative());
    pad(out, sign + int.len() + 10, width);
    if sign == 1 {
        out.push('-');
    }
    out.push_str(int);
    out.push('.');
    for _ in frac.len()..9 {
        out.push('0');
    }
    out.push_str(frac);
}

/// Appends `format!("{v:width$}")` of an integer.
pub fn push_int(out: &mut String, v: impl itoa::Integer, width: usize) {
    let mut buf = itoa::Buffer::new();
    let s = buf.format(v);
    pad(out, s.len(), width);
    out.push_str(s);
}

fn pad(out: &mut String, len: usize, width: usize) {
    for _ in len..width {
        out.push(' ');
    }
}

/// |x|·10⁹ rounded half to even, from x's exact value; `None` when not finite or too large for
/// 128 bits (|x| ≥ 2^93, far beyond any mesh).
fn scaled_by_1e9(x: f64) -> Option<u128> {
    if !x.is_finite() {
        return None;
    }
    let bits = x.to_bits();
    let biased = ((bits >> 52) & 0x7ff) as i32;
    let fraction = bits & ((1u64 << 52) - 1);
    let (m, e) = if biased == 0 {
        (fraction, -1074)
    } else {
        (fraction | (1u64 << 52), biased - 1075)
    };
    let n = u128::from(m) * 1_000_000_000; // < 2^83
    if e >= 0 {
        return (e <= 40).then(|| n << e);
    }
    let s = e.unsigned_abs();
    if s >= 128 {
        return Some(0); // n < 2^83, far below half of 2^s
    }
    let (q, r, half) = (n >> s, n & ((1u128 << s) - 1), 1u128 << (s - 1));
    Some(if r > half || (r == half && q & 1 == 1) {
        q + 1
    } else {
        q
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn agrees(x: f64) {
        let mut fast = String::new();
        push_fixed9(&mut fast, x, 16);
        assert_eq!(fast, format!("{x:16.9}"), "x = {x:e} ({:#x})", x.to_bits());
    }

    #[test]
    fn fixed_fields_are_what_format_writes() {
        // Ties at the ninth decimal are exact dyadic values (k·2⁻¹⁰ has ten decimals).
        for k in -4096..4096 {
            agrees(k as f64 / 1024.0);
            agrees(k as f64 / 2048.0 * 1e-6);
        }
        for x in [
            0.0,
            -0.0,
            1e-300,
            -1e-300,
            5e-324,
            -5e-10,
            5e-10,
            4.9999999999e-10,
            1e12,
            -1e15,
            2f64.powi(92),
        ] {
            agrees(x);
        }
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        for _ in 0..300_000 {
            let magnitude = 10f64.powf(rng.random_range(-12.0..16.0));
            let x = if rng.random_bool(0.5) { magnitude } else { -magnitude };
            agrees(x);
            // Coordinates as the mesher makes them: multiples of an irrational step.
            agrees(rng.random_range(-200i32..200) as f64 * 3f64.sqrt() / 2.0 * rng.random_range(0.5..5.0));
        }
        let mut s = String::new();
        for v in [0usize, 7, 12345678, 123456789] {
            s.clear();
            push_int(&mut s, v, 8);
            assert_eq!(s, format!("{v:8}"));
        }
    }
}
