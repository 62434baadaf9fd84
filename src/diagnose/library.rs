//! The library of additive shapes that the discovery search tries ([`super::discover`]), built
//! from what the study declares: its design variables (names, units, scales), the simulation's
//! response `y`, and the exponents written in its closed form.
//!
//! Every entry is a plain [`Shape`] `g(d, θ, y)` with a free coefficient, like a listed hypothesis,
//! and its `term` is written so that it can be pasted into a study (`1/h`, `y*h^2`,
//! `y*(t/c)^(2/3)`, `exp(-h/10)`). In this order (simplest first: when two entries are the same
//! shape over the tested designs, the search keeps the first and lists the other beside it):
//! 1. the constant `1` and `y` (an offset and a scale error);
//! 2. per design variable x, the power laws x^a, a in [`exponents`]: −3, −2, −1, −1/2, 1/2, 1, 2, 3
//!    and, for a closed-form simulation, the fractional exponents it is written with (±a and the
//!    distances of a to its neighbouring integers: `t^(5/3)` adds ±5/3, ±2/3, ±1/3);
//! 3. y·x^a for the same exponents;
//! 4. per pair of design variables, the product x_i·x_j and the ratios x_i/x_j, x_j/x_i; and when
//!    both declare the same unit (a dimensionless group), (x_i/x_j)^a and y·(x_i/x_j)^a for every a;
//! 5. per design variable with a declared `scale` L, `exp(-x/L)` and `ln(x/L)`.
//!
//! **Units.** The coefficient of each shape may carry units, so any power law (times y or not) can
//! add to the response whatever the units: units exclude nothing there. What they exclude is a
//! transcendental function of a dimensional argument: `exp` and `ln` need x/L dimensionless, so
//! they are searched only where the study declares the scale L (`design: {h: {unit: mm, scale:
//! 10}}`, L in h's unit); without it they are listed as dropped, with the reason. The study's
//! constants add no shape of their own: a constant factor is absorbed by the free coefficient.

use serde::{Deserialize, Serialize};

use super::shapes::{Origin, Shape};

/// What the study declares that the library is built from, per design variable in the order of
/// [`super::Space::design_names`] (a shorter list means "not declared" for the rest).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LibrarySpec {
    pub units: Vec<Option<String>>,
    pub scales: Vec<Option<f64>>,
    /// The exponents written in the simulation's closed form (none for a solver).
    pub exponents: Vec<f64>,
}

/// A shape the library leaves out, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Dropped {
    pub term: String,
    pub reason: String,
}

/// The library's shapes, in search order, and what it left out.
pub struct Library {
    pub shapes: Vec<Shape>,
    pub dropped: Vec<Dropped>,
    /// The exponents of the power laws.
    pub exponents: Vec<f64>,
}

/// The exponents every library tries, simplest first.
pub const POWERS: [f64; 8] = [1.0, -1.0, 2.0, -2.0, 3.0, -3.0, 0.5, -0.5];

/// [`POWERS`] and, for each fractional exponent written in the simulation, ±a and the distances of
/// a to its neighbouring integers (within |a| ≤ 3): the scaling laws the simulation is made of.
pub fn exponents(written: &[f64]) -> Vec<f64> {
    let mut out = POWERS.to_vec();
    for &w in written {
        if !w.is_finite() || (w - w.round()).abs() < 1e-9 {
            continue;
        }
        for a in [w, w - w.floor(), w.ceil() - w] {
            for s in [a, -a] {
                if s.abs() <= 3.0 + 1e-9 && !out.iter().any(|o| (o - s).abs() < 1e-9) {
                    out.push(s);
                }
            }
        }
    }
    out
}

/// `a` as `p/q` with a small denominator, else as a decimal.
pub fn exponent_text(a: f64) -> String {
    for q in 1..=12i64 {
        let p = a * q as f64;
        if (p - p.round()).abs() < 1e-9 {
            let p = p.round() as i64;
            return if q == 1 { p.to_string() } else { format!("{p}/{q}") };
        }
    }
    format!("{a:.4}")
}

/// `x`, `x^2`, `x^(1/2)` for |a| (the sign is the caller's).
fn factor(name: &str, a: f64) -> String {
    let a = a.abs();
    if (a - 1.0).abs() < 1e-12 {
        name.to_string()
    } else if (a - a.round()).abs() < 1e-12 {
        format!("{name}^{}", exponent_text(a))
    } else {
        format!("{name}^({})", exponent_text(a))
    }
}

/// A monomial `[y] · Π x_j^a_j` as a study term: positive powers over negative ones
/// (`1/h`, `y/h^2`, `y*h^(1/2)`, `t*c`, `c/t`).
pub fn monomial(factors: &[(&str, f64)], with_y: bool) -> String {
    let up: Vec<String> = factors.iter().filter(|f| f.1 > 0.0).map(|f| factor(f.0, f.1)).collect();
    let down: Vec<String> = factors.iter().filter(|f| f.1 < 0.0).map(|f| factor(f.0, f.1)).collect();
    let mut top: Vec<String> = Vec::new();
    if with_y {
        top.push("y".into());
    }
    top.extend(up);
    let top = if top.is_empty() { "1".to_string() } else { top.join("*") };
    match down.len() {
        0 => top,
        1 => format!("{top}/{}", down[0]),
        _ => format!("{top}/({})", down.join("*")),
    }
}

/// `(t/c)^a` as a study term, the ratio turned over for a negative a; `[y*]` in front.
fn ratio_term(num: &str, den: &str, a: f64, with_y: bool) -> String {
    let (n, d) = if a > 0.0 { (num, den) } else { (den, num) };
    let base = if (a.abs() - 1.0).abs() < 1e-12 {
        format!("{n}/{d}")
    } else if (a - a.round()).abs() < 1e-12 {
        format!("({n}/{d})^{}", exponent_text(a.abs()))
    } else {
        format!("({n}/{d})^({})", exponent_text(a.abs()))
    };
    if with_y { format!("y*{base}") } else { base }
}

/// x^a, with integer powers exact.
fn pow(x: f64, a: f64) -> f64 {
    if (a - a.round()).abs() < 1e-12 && a.abs() <= 16.0 {
        x.powi(a.round() as i32)
    } else {
        x.powf(a)
    }
}

fn search_shape(term: String, f: impl Fn(&[f64], &[f64], f64) -> f64 + Send + Sync + 'static) -> Shape {
    Shape::new(term.clone(), term, Origin::Search, f)
}

/// The library for `design_names` as `spec` declares them (see the module notes for the order).
pub fn build(design_names: &[String], spec: &LibrarySpec) -> Library {
    let exps = exponents(&spec.exponents);
    let mut shapes = vec![
        search_shape("1".into(), |_, _, _| 1.0),
        search_shape("y".into(), |_, _, y| y),
    ];
    let mut dropped = Vec::new();
    let names: Vec<&str> = design_names.iter().map(String::as_str).collect();
    for with_y in [false, true] {
        for (j, name) in names.iter().enumerate() {
            for &a in &exps {
                let term = monomial(&[(name, a)], with_y);
                shapes.push(search_shape(term, move |d, _, y| {
                    let g = pow(d[j], a);
                    if with_y { y * g } else { g }
                }));
            }
        }
    }
    for i in 0..names.len() {
        for j in i + 1..names.len() {
            pair_shapes((&names, i, j), spec, &exps, (&mut shapes, &mut dropped));
        }
    }
    for (j, name) in names.iter().enumerate() {
        scale_shapes((name, j), spec, (&mut shapes, &mut dropped));
    }
    Library {
        shapes,
        dropped,
        exponents: exps,
    }
}

/// Design variable `j`'s declared unit (none when blank).
fn unit_of(spec: &LibrarySpec, j: usize) -> Option<String> {
    spec.units.get(j).cloned().flatten().filter(|u| !u.trim().is_empty())
}

/// The shapes of the pair of design variables `i`, `j`: their product and ratios, and where both
/// declare the same unit the powers of their ratio (else those are dropped, with why).
fn pair_shapes(
    (names, i, j): (&[&str], usize, usize),
    spec: &LibrarySpec,
    exps: &[f64],
    (shapes, dropped): (&mut Vec<Shape>, &mut Vec<Dropped>),
) {
    let (a, b) = (names[i], names[j]);
    shapes.push(search_shape(monomial(&[(a, 1.0), (b, 1.0)], false), move |d, _, _| {
        d[i] * d[j]
    }));
    shapes.push(search_shape(monomial(&[(a, 1.0), (b, -1.0)], false), move |d, _, _| {
        d[i] / d[j]
    }));
    shapes.push(search_shape(monomial(&[(a, -1.0), (b, 1.0)], false), move |d, _, _| {
        d[j] / d[i]
    }));
    match (unit_of(spec, i), unit_of(spec, j)) {
        (Some(u), Some(v)) if u == v => {
            for with_y in [false, true] {
                for &e in exps {
                    if !with_y && (e.abs() - 1.0).abs() < 1e-12 {
                        continue; // the ratios above
                    }
                    shapes.push(search_shape(ratio_term(a, b, e, with_y), move |d, _, y| {
                        let g = pow(d[i] / d[j], e);
                        if with_y { y * g } else { g }
                    }));
                }
            }
        }
        (u, v) => dropped.push(Dropped {
            term: format!("({a}/{b})^a, y*({a}/{b})^a"),
            reason: format!(
                "{a} and {b} do not declare the same unit ({} and {}): their ratio is no dimensionless group, \
                 so only {a}*{b}, {a}/{b} and {b}/{a} are searched",
                u.as_deref().unwrap_or("none"),
                v.as_deref().unwrap_or("none")
            ),
        }),
    }
}

/// `exp(-x/L)` and `ln(x/L)` of design variable `j` where it declares its scale L; else dropped,
/// with why.
fn scale_shapes((name, j): (&str, usize), spec: &LibrarySpec, (shapes, dropped): (&mut Vec<Shape>, &mut Vec<Dropped>)) {
    let terms = |l: &str| [format!("exp(-{name}/{l})"), format!("ln({name}/{l})")];
    match spec.scales.get(j).copied().flatten() {
        Some(l) => {
            let [e, g] = terms(&l.to_string());
            shapes.push(search_shape(e, move |d, _, _| (-d[j] / l).exp()));
            shapes.push(search_shape(g, move |d, _, _| (d[j] / l).ln()));
        }
        None => {
            let why = match unit_of(spec, j) {
                Some(u) => format!(
                    "{name} is in {u} and no scale is declared: exp and ln need {name}/L dimensionless; declare \
                     `scale:` (a length in {u}) under design.{name} to search them"
                ),
                None => format!(
                    "no scale is declared for {name}: exp and ln need {name}/L dimensionless; declare `unit:` and \
                     `scale:` under design.{name} to search them"
                ),
            };
            for t in terms("L") {
                dropped.push(Dropped {
                    term: t,
                    reason: why.clone(),
                });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(n: &[&str]) -> Vec<String> {
        n.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn terms_read_as_written() {
        assert_eq!(monomial(&[("h", -1.0)], false), "1/h");
        assert_eq!(monomial(&[("h", 2.0)], true), "y*h^2");
        assert_eq!(monomial(&[("h", -2.0)], true), "y/h^2");
        assert_eq!(monomial(&[("h", -0.5)], false), "1/h^(1/2)");
        assert_eq!(monomial(&[("t", 1.0), ("c", -1.0)], false), "t/c");
        assert_eq!(ratio_term("t", "c", 2.0 / 3.0, true), "y*(t/c)^(2/3)");
        assert_eq!(ratio_term("t", "c", -2.0, false), "(c/t)^2");
        assert_eq!(exponent_text(-5.0 / 3.0), "-5/3");
    }

    #[test]
    fn fractional_exponents_of_the_simulation_join_the_powers() {
        let e = exponents(&[5.0 / 3.0, 3.0]);
        for want in [5.0 / 3.0, -5.0 / 3.0, 2.0 / 3.0, -2.0 / 3.0, 1.0 / 3.0, -1.0 / 3.0] {
            assert!(e.iter().any(|a| (a - want).abs() < 1e-12), "{want} missing from {e:?}");
        }
        assert_eq!(e.len(), POWERS.len() + 6);
        assert_eq!(exponents(&[3.0, 2.0]).len(), POWERS.len());
    }

    /// Every term, compiled as a study would compile it, is the shape the search fits.
    #[test]
    fn every_term_is_its_shape() {
        let spec = LibrarySpec {
            units: vec![Some("mm".into()), Some("mm".into())],
            scales: vec![Some(10.0), None],
            exponents: vec![5.0 / 3.0],
        };
        let design = names(&["t", "c"]);
        let lib = build(&design, &spec);
        let params = names(&["s"]);
        for s in &lib.shapes {
            let compiled =
                Shape::from_term("x", &s.term, &design, &params, &[]).unwrap_or_else(|e| panic!("{}: {e:?}", s.term));
            for d in [[0.7, 3.0], [1.3, 8.5]] {
                let (a, b) = (s.eval(&d, &[1.0], 2.5), compiled.eval(&d, &[1.0], 2.5));
                assert!((a - b).abs() <= 1e-12 * a.abs().max(1.0), "{}: {a} vs {b}", s.term);
            }
        }
        assert!(lib.shapes.iter().any(|s| s.term == "y*(t/c)^(2/3)"));
        assert!(lib.shapes.iter().any(|s| s.term == "exp(-t/10)"));
        assert!(
            lib.dropped
                .iter()
                .any(|d| d.term == "ln(c/L)" && d.reason.contains("scale"))
        );
    }

    #[test]
    fn ratio_powers_only_for_a_shared_unit() {
        let mixed = LibrarySpec {
            units: vec![Some("mm".into()), Some("s".into())],
            ..Default::default()
        };
        let lib = build(&names(&["h", "v"]), &mixed);
        assert!(lib.shapes.iter().any(|s| s.term == "h/v"));
        assert!(!lib.shapes.iter().any(|s| s.term.contains("(h/v)")));
        assert!(lib.dropped.iter().any(|d| d.term.starts_with("(h/v)")));
    }
}
