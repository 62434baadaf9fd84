//! Hidden-effect tests: a generator draws, from a seed, a hidden model error out of a family and a
//! magnitude, makes "measured" data with replicate noise from a base model, and hands the diagnosis
//! only what an engineer would have: the data, the base model, and a list of candidate terms with
//! neutral names in shuffled order (the true shape among them). Only this file knows what was hidden.
//!
//! Base model (honeycomb crush force, one Y junction, Wierzbicki): F = k σ t^(5/3) / c^(1/3) with
//! k = 8.61 fixed and σ calibrated (true 185, bounds [100, 300]). Design box t ∈ [0.5, 2], c ∈ [3, 12];
//! a 4 × 3 training grid over t ∈ [0.5, 1.4], c ∈ [3, 8], and 4 validation designs beyond it (t = 2 or
//! c = 12), 3 replicates each. Noise: absolute
//! or relative (drawn), 1–2 % of the level (of the mean training level when absolute).
//! Effect magnitude: drawn in [8 %, 20 %] of the mean training level at the designs where the shape
//! is largest; the sign is drawn where the family allows.
//!
//! Assertions (the issue's): the right cause in ≥ 9 of 10 seeds per family; no discrepancy
//! detected on effect-free data in ≥ 9 of 10 seeds; gain ≥ 50 % in ≥ 9 of 10 seeds where an effect
//! was hidden. A scale error on this base is, by construction, a change of σ (F ∝ σ): there the right
//! answer is "no discrepancy, and the scale term is confounded with σ", and a second base with the
//! exponent of t calibrated instead of σ checks that a scale error is named when it is identifiable.

use lab::calibrate::Bounds;
use lab::diagnose::{self, Diagnosis, Inputs, NoiseKind, Observation, Role, Settings, Shape};
use rand::seq::{IndexedRandom, SliceRandom};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const K: f64 = 8.61;
const SIGMA: f64 = 185.0;
const SEEDS: u64 = 10;

/// The candidate terms the engineer suspects; every hidden shape below is one of them.
const POOL: [&str; 13] = [
    "1", "y", "y^2", "t^0.5", "t^2", "t^3", "1/t", "c^0.5", "c^2", "1/c", "t*c", "t/c", "c/t",
];

#[derive(Debug, Clone, Copy, PartialEq)]
enum Family {
    None,
    Offset,
    /// Scale error on the σ-calibrated base (confounded with σ).
    Scale,
    /// Scale error on the base with the exponent of t calibrated (identifiable).
    ScaleIdentifiable,
    Power,
    Saturation,
    Interaction,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Base {
    /// θ = [σ].
    Sigma,
    /// θ = [a], the exponent of t; σ = 185 known.
    Exponent,
}

impl Base {
    fn predict(self, d: &[f64], th: &[f64]) -> f64 {
        match self {
            Base::Sigma => K * th[0] * d[0].powf(5.0 / 3.0) / d[1].powf(1.0 / 3.0),
            Base::Exponent => K * SIGMA * d[0].powf(th[0]) / d[1].powf(1.0 / 3.0),
        }
    }
    fn truth(self) -> Vec<f64> {
        match self {
            Base::Sigma => vec![SIGMA],
            Base::Exponent => vec![5.0 / 3.0],
        }
    }
    fn parameter(self) -> (&'static str, f64, f64) {
        match self {
            Base::Sigma => ("sigma", 100.0, 300.0),
            Base::Exponent => ("a", 1.0, 2.5),
        }
    }
}

struct Case {
    inputs_obs: Vec<Observation>,
    hypotheses: Vec<Shape>,
    /// The neutral name given to the hidden shape's term (None for no effect).
    hidden_name: Option<String>,
    noise_relative: bool,
    magnitude: f64,
}

fn training_designs() -> Vec<[f64; 2]> {
    let mut v = Vec::new();
    for t in [0.5, 0.75, 1.1, 1.6] {
        for c in [3.0, 5.5, 10.0] {
            v.push([t, c]);
        }
    }
    v
}

/// Validation designs beyond the training grid, as in the paper (train h = 8, 10; validate h = 13):
/// a model that has found the missing physics extrapolates.
const VALIDATION: [[f64; 2]; 4] = [[2.0, 3.0], [2.0, 8.0], [0.5, 12.0], [1.3, 12.0]];

fn eval_term(term: &str, d: &[f64], y: f64) -> f64 {
    let (t, c) = (d[0], d[1]);
    match term {
        "1" => 1.0,
        "y" => y,
        "y^2" => y * y,
        "t^0.5" => t.sqrt(),
        "t^2" => t * t,
        "t^3" => t.powi(3),
        "1/t" => 1.0 / t,
        "c^0.5" => c.sqrt(),
        "c^2" => c * c,
        "1/c" => 1.0 / c,
        "t*c" => t * c,
        "t/c" => t / c,
        "c/t" => c / t,
        _ => unreachable!("{term}"),
    }
}

/// Draws the hidden effect and the data. Returns the case and the true base.
fn generate(family: Family, seed: u64) -> (Case, Base) {
    generate_with(family, seed, 3)
}

/// As [`generate`], with `replicates` tests per design.
fn generate_with(family: Family, seed: u64, replicates: usize) -> (Case, Base) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed * 1000 + family as u64);
    let base = if family == Family::ScaleIdentifiable {
        Base::Exponent
    } else {
        Base::Sigma
    };
    let theta = base.truth();
    let train = training_designs();
    let level = train.iter().map(|d| base.predict(d, &theta)).sum::<f64>() / train.len() as f64;
    let m: f64 = rng.random_range(0.08..0.20);
    let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
    // The hidden term (from POOL) and how it changes the response.
    let hidden: Option<&str> = match family {
        Family::None => None,
        Family::Offset => Some("1"),
        Family::Scale | Family::ScaleIdentifiable => Some("y"),
        Family::Power => Some(
            *["t^0.5", "t^2", "t^3", "1/t", "c^0.5", "c^2", "1/c"]
                .choose(&mut rng)
                .unwrap(),
        ),
        Family::Saturation => Some("y^2"),
        Family::Interaction => Some("t*c"),
    };
    let ymax = train.iter().map(|d| base.predict(d, &theta)).fold(0.0, f64::max);
    let truth = |d: &[f64]| -> f64 {
        let y = base.predict(d, &theta);
        match family {
            Family::None => y,
            Family::Scale | Family::ScaleIdentifiable => y * (1.0 + sign * m),
            // A saturating response y / (1 + y/Y), reduced by the fraction m at the largest level.
            Family::Saturation => {
                let cap = ymax * (1.0 - m) / m;
                y / (1.0 + y / cap)
            }
            _ => {
                let term = hidden.unwrap();
                let smax = train.iter().map(|e| eval_term(term, e, 0.0).abs()).fold(0.0, f64::max);
                y + sign * m * level * eval_term(term, d, y) / smax
            }
        }
    };
    let noise_relative = rng.random_bool(0.5);
    let cv: f64 = rng.random_range(0.005..0.015);
    let mut obs = Vec::new();
    let designs = train
        .iter()
        .map(|d| (d, Role::Training))
        .chain(VALIDATION.iter().map(|d| (d, Role::Validation)));
    for (k, (d, role)) in designs.enumerate() {
        let mu = truth(d);
        let sd = if noise_relative { cv * mu.abs() } else { cv * level };
        let reps: Vec<f64> = (0..replicates).map(|_| mu + sd * gauss(&mut rng)).collect();
        obs.push(Observation::from_replicates(format!("d{k}"), d.to_vec(), role, &reps));
    }
    // Neutral names, shuffled order.
    let mut terms: Vec<&str> = POOL.to_vec();
    terms.shuffle(&mut rng);
    let names: Vec<String> = (1..=terms.len()).map(|i| format!("H{i}")).collect();
    let (pname, _, _) = base.parameter();
    let design_names = vec!["t".to_string(), "c".to_string()];
    let hypotheses: Vec<Shape> = terms
        .iter()
        .zip(&names)
        .map(|(term, name)| Shape::from_term(name.clone(), term, &design_names, &[pname.to_string()], &[]).unwrap())
        .collect();
    let hidden_name = hidden.map(|h| names[terms.iter().position(|t| *t == h).unwrap()].clone());
    (
        Case {
            inputs_obs: obs,
            hypotheses,
            hidden_name,
            noise_relative,
            magnitude: m,
        },
        base,
    )
}

/// Standard normal by Box–Muller.
fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random_range(f64::EPSILON..1.0);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

fn diagnose_case(case: &Case, base: Base) -> Diagnosis {
    let (pname, lo, hi) = base.parameter();
    let model = move |d: &[f64], th: &[f64]| base.predict(d, th);
    let inputs = Inputs {
        observations: case.inputs_obs.clone(),
        model: &model,
        parameter_names: vec![pname.to_string()],
        parameter_bounds: Bounds::new(vec![lo], vec![hi]),
        design_names: vec!["t".to_string(), "c".to_string()],
        design_bounds: Bounds::new(vec![0.5, 3.0], vec![2.0, 12.0]),
        hypotheses: case.hypotheses.clone(),
        settings: Settings::default(),
    };
    diagnose::diagnose(&inputs).expect("diagnosis runs")
}

struct Tally {
    right: usize,
    gain: usize,
    noise_right: usize,
    lines: Vec<String>,
}

fn tally(family: Family, right: impl Fn(&Case, &Diagnosis) -> bool) -> Tally {
    let mut t = Tally {
        right: 0,
        gain: 0,
        noise_right: 0,
        lines: Vec::new(),
    };
    for seed in 0..SEEDS {
        let (case, base) = generate(family, seed);
        let d = diagnose_case(&case, base);
        let ok = right(&case, &d);
        let gain = d.extended.as_ref().and_then(|e| e.gain);
        let expected_noise = if case.noise_relative {
            NoiseKind::Relative
        } else {
            NoiseKind::Absolute
        };
        t.right += usize::from(ok);
        t.gain += usize::from(gain.is_some_and(|g| g >= 0.5));
        t.noise_right += usize::from(d.noise.kind == expected_noise);
        let term_of = |name: &str| {
            d.candidates
                .iter()
                .find(|c| c.name == name)
                .map(|c| c.term.clone())
                .unwrap_or_default()
        };
        t.lines.push(format!(
            "{family:?} seed {seed}: hidden {:?} ({}) m {:.3} | detected {} cause {:?} ({}) | top3 {:?} | gain {:?} ({:?}) | noise {:?} | {}",
            case.hidden_name,
            case.hidden_name.as_deref().map(term_of).unwrap_or_default(),
            case.magnitude,
            d.discrepancy_detected,
            d.cause,
            d.cause.as_deref().map(term_of).unwrap_or_default(),
            d.candidates.iter().take(3).map(|c| format!("{} {:.2}", c.term, c.weight)).collect::<Vec<_>>(),
            gain.map(|g| (g * 100.0).round() / 100.0),
            d.extended.as_ref().map(|e| (e.validation_error_before, e.validation_error_after)),
            d.noise.kind,
            if ok { "ok" } else { "WRONG" }
        ));
    }
    for l in &t.lines {
        eprintln!("{l}");
    }
    eprintln!(
        "{family:?}: right {}/{SEEDS}, gain ≥ 50 % {}/{SEEDS}, noise model right {}/{SEEDS}",
        t.right, t.gain, t.noise_right
    );
    t
}

fn named_correctly(case: &Case, d: &Diagnosis) -> bool {
    d.discrepancy_detected && d.cause.is_some() && d.cause == case.hidden_name
}

fn check_named(family: Family) {
    let t = tally(family, named_correctly);
    assert!(t.right >= 9, "{family:?}: right cause in {}/{SEEDS} seeds", t.right);
    assert!(t.gain >= 9, "{family:?}: gain ≥ 50 % in {}/{SEEDS} seeds", t.gain);
    // 16 designs × 2 degrees of freedom and levels spanning a factor of ~10: the replicate
    // likelihoods separate absolute from relative noise almost always.
    assert!(
        t.noise_right >= 9,
        "{family:?}: noise model right in {}/{SEEDS} seeds",
        t.noise_right
    );
}

#[test]
fn no_effect_is_not_a_discrepancy() {
    let t = tally(Family::None, |_, d| {
        !d.discrepancy_detected && d.cause.is_none() && d.extended.is_none()
    });
    assert!(
        t.right >= 9,
        "false alarms in {} of {SEEDS} seeds",
        SEEDS as usize - t.right
    );
    assert!(t.noise_right >= 9);
}

#[test]
fn constant_offset_is_named() {
    check_named(Family::Offset);
}

#[test]
fn power_law_in_a_design_variable_is_named() {
    check_named(Family::Power);
}

#[test]
fn saturation_is_named() {
    check_named(Family::Saturation);
}

#[test]
fn interaction_is_named() {
    check_named(Family::Interaction);
}

#[test]
fn identifiable_scale_error_is_named() {
    check_named(Family::ScaleIdentifiable);
}

/// F ∝ σ: a scale error is exactly a different σ. The right answer is no discrepancy, the scale
/// term flagged as confounded with σ, and σ absorbing the error.
#[test]
fn scale_error_on_a_multiplicative_parameter_is_confounded_not_named() {
    let t = tally(Family::Scale, |case, d| {
        let name = case.hidden_name.as_deref().unwrap();
        let flagged = d
            .candidates
            .iter()
            .any(|c| c.name == name && c.confounded_with == vec!["sigma".to_string()]);
        !d.discrepancy_detected && d.cause.is_none() && flagged
    });
    assert!(
        t.right >= 9,
        "scale error handled as confounded in {}/{SEEDS} seeds",
        t.right
    );
}

/// The false-alarm rate over more seeds than the ten: the rule's two tests at α = 0.01 give
/// at most ~2 % in theory; allow 5 of 60 (8 %) so that only a real excess fails.
#[test]
fn false_alarm_rate_over_sixty_seeds() {
    let alarms = (100..160)
        .filter(|&seed| {
            let (case, base) = generate(Family::None, seed);
            diagnose_case(&case, base).discrepancy_detected
        })
        .count();
    eprintln!("false alarms: {alarms}/60");
    assert!(alarms <= 5, "false alarms in {alarms} of 60 seeds");
}

/// Without replicates the noise comes from the residuals of the best model and the detection test
/// is the classical extra-sum-of-squares F test (1, n − p − 1). Same generator, one test per design.
/// Beyond the issue: it checks the no-replicate path on noisy data (the paper cases are noise-free).
#[test]
fn without_replicates_no_effect_is_rarely_flagged_and_effects_are_named() {
    let mut alarms = 0;
    let mut named = [0usize; 3];
    for seed in 0..SEEDS {
        let (case, base) = generate_with(Family::None, seed, 1);
        let d = diagnose_case(&case, base);
        assert_eq!(d.noise.kind, NoiseKind::FromResiduals);
        alarms += usize::from(d.discrepancy_detected);
        for (k, family) in [Family::Offset, Family::Interaction, Family::Power]
            .into_iter()
            .enumerate()
        {
            let (case, base) = generate_with(family, seed, 1);
            let d = diagnose_case(&case, base);
            if !named_correctly(&case, &d) {
                let term = |n: &str| d.candidates.iter().find(|c| c.name == n).map(|c| c.term.clone());
                eprintln!(
                    "no replicates, {family:?} seed {seed}: hidden {:?}, cause {:?}, relative noise {}, top {:?}",
                    case.hidden_name.as_deref().and_then(term),
                    d.cause.as_deref().and_then(term),
                    case.noise_relative,
                    d.candidates
                        .iter()
                        .take(3)
                        .map(|c| format!("{} {:.2} p={:.1e}", c.term, c.weight, c.p_value))
                        .collect::<Vec<_>>()
                );
            }
            named[k] += usize::from(named_correctly(&case, &d));
        }
    }
    eprintln!("no replicates: false alarms {alarms}/{SEEDS}, named (offset, interaction, power) {named:?}/{SEEDS}");
    assert!(alarms <= 1, "false alarms in {alarms} of {SEEDS} seeds");
    // Offset and interaction: the 9 of 10. Power laws: 8 of 10 (measured 8): one test per
    // design carries √3 times the noise of a mean of three, the weights are those of absolute noise
    // whatever the truth, and neighbouring power laws (t^0.5 against c^0.5, t^2 against t/c) then
    // come out close; the weights show it (0.8 against 0.15 in the misses).
    assert!(named[0] >= 9 && named[1] >= 9 && named[2] >= 8, "{named:?}");
}
