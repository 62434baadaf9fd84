//! A stand-in solver for lab's tests of the verdict after the loop: a cantilever with a compliant
//! clamp, as a closed form run as a program (so that lab renders, runs, records and judges it like
//! any solver). Not a finite-element code.
//!
//! `clamped_beam INPUT` in a run directory reads `name = number` lines (h, F, L, b, E, nu, and
//! optionally s and kr, 0 by default) and writes `output.txt` with `y = <tip deflection>`:
//!
//! ```text
//! y = 4 F L³ / (E b h³)               Euler–Bernoulli bending
//!   + s  F L (4 + 5 ν) / (2 E b h)     s times the Timoshenko shear term (Qiu et al. 2018, Eq. 11)
//!   + kr 4 F L² / (E b h²)             a clamp of compliance kr (root rotation)
//! ```
//!
//! With `imperfection = cv` (and `seed = k`, 1 by default) the deflection is multiplied by
//! 1 + cv·z, z a standard normal drawn from (k, h) alone: a random imperfection, the same for the
//! same seed and depth, whatever E, kr or s (for `simulation.seeds`).
//!
//! The three terms part with the depth h as h⁻³, h⁻¹ and h⁻². Built by `cargo test` (examples are
//! compiled with the tests); the tests run `target/release/examples/clamped_beam`.

use std::collections::HashMap;

fn main() {
    let path = std::env::args().nth(1).unwrap_or_else(|| "beam.txt".into());
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| fail(&format!("{path}: {e}")));
    let mut v = HashMap::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let Some((name, value)) = line.split_once('=') else {
            fail(&format!("{path}:{}: expected `name = number`", n + 1))
        };
        let value: f64 = value
            .trim()
            .parse()
            .unwrap_or_else(|_| fail(&format!("{path}:{}: `{}` is not a number", n + 1, value.trim())));
        v.insert(name.trim().to_string(), value);
    }
    let get = |k: &str| *v.get(k).unwrap_or_else(|| fail(&format!("{path}: `{k}` is missing")));
    let opt = |k: &str| v.get(k).copied().unwrap_or(0.0);
    let (f, l, b, h, e, nu) = (get("F"), get("L"), get("b"), get("h"), get("E"), get("nu"));
    let y = 4.0 * f * l.powi(3) / (e * b * h.powi(3))
        + opt("s") * f * l * (4.0 + 5.0 * nu) / (2.0 * e * b * h)
        + opt("kr") * 4.0 * f * l * l / (e * b * h * h);
    let seed = v.get("seed").copied().unwrap_or(1.0);
    let y = y * (1.0 + opt("imperfection") * normal(seed, h));
    std::fs::write(
        "output.txt",
        format!("tip deflection (clamped beam stand-in)\ny = {y:e}\n"),
    )
    .unwrap_or_else(|e| fail(&format!("output.txt: {e}")));
}

fn fail(message: &str) -> ! {
    eprintln!("clamped_beam: {message}");
    std::process::exit(2)
}

/// A standard normal from (seed, h) alone: splitmix64 of their bits, two uniforms, Box–Muller.
fn normal(seed: f64, h: f64) -> f64 {
    let mix = |mut z: u64| {
        z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    };
    let a = mix(seed.to_bits() ^ mix(h.to_bits()));
    let b = mix(a);
    let uniform = |x: u64| ((x >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
    (-2.0 * uniform(a).ln()).sqrt() * (std::f64::consts::TAU * uniform(b)).cos()
}
