//! The library search for a missing term on a 9-design, 2-variable study: a honeycomb Y
//! junction's crush force 8.61 σ t^(5/3) / c^(1/3) (σ calibrated) tested on a 3 × 3 grid of
//! t ∈ {0.6, 1.0, 1.4} mm × c ∈ {4, 6, 8} mm, three specimens each with 1 % seeded scatter. The
//! evidence the search starts from (every candidate fitted, tested and ranked) is timed with the
//! search and without it (`diagnose::discover`, `discover` on and off), so the difference is the
//! search's own cost; the whole diagnosis with the search (next test and words included) beside
//! them. Two hidden effects:
//! - `found`: a hardening-like y·(t/c)^(2/3) share of 15 % at the thickest foil in the smallest cells: inside
//!   the library, found;
//! - `nothing`: a 6 % spike at the centre design (outside the library): every eligible model is
//!   judged and none passes, the search's worst case.
//!
//! Run: `cargo bench --bench discover`; the figures go in docs/benchmarks.md.

use criterion::{Criterion, criterion_group, criterion_main};
use lab::calibrate::Bounds;
use lab::diagnose::library::LibrarySpec;
use lab::diagnose::{self, Inputs, Observation, Role, Settings, Space};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn junction(d: &[f64], th: &[f64]) -> f64 {
    8.61 * th[0] * d[0].powf(5.0 / 3.0) / d[1].powf(1.0 / 3.0)
}

fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random_range(f64::EPSILON..1.0);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// The tests, with `effect(t, c)` (a share of the response) hidden in them.
fn observations(effect: fn(f64, f64) -> f64) -> Vec<Observation> {
    let mut rng = ChaCha8Rng::seed_from_u64(26);
    let mut obs = Vec::new();
    for t in [0.6, 1.0, 1.4] {
        for c in [4.0, 6.0, 8.0] {
            let y = junction(&[t, c], &[185.0]) * (1.0 + effect(t, c));
            let reps: Vec<f64> = (0..3).map(|_| y * (1.0 + 0.01 * gauss(&mut rng))).collect();
            obs.push(Observation::from_replicates(
                format!("t{t}c{c}"),
                vec![t, c],
                Role::Training,
                &reps,
            ));
        }
    }
    obs
}

fn inputs(obs: Vec<Observation>, discover: bool) -> Inputs<'static> {
    Inputs {
        observations: obs,
        model: &junction,
        space: Space {
            parameter_names: vec!["sigma".into()],
            parameter_bounds: Bounds::new(vec![100.0], vec![300.0]),
            design_names: vec!["t".into(), "c".into()],
            design_bounds: Bounds::new(vec![0.6, 4.0], vec![1.4, 8.0]),
        },
        hypotheses: Vec::new(),
        settings: Settings::default(),
        library: discover.then(|| LibrarySpec {
            units: vec![Some("mm".into()), Some("mm".into())],
            scales: vec![None, None],
            exponents: vec![5.0 / 3.0, 1.0 / 3.0],
        }),
        built_ins: None,
        features: None,
        emulator: Default::default(),
    }
}

fn search(c: &mut Criterion) {
    let hardening: fn(f64, f64) -> f64 = |t, c| 0.15 * ((t / c) / (1.4 / 4.0)).powf(2.0 / 3.0);
    let spike: fn(f64, f64) -> f64 = |t, c| if t == 1.0 && c == 6.0 { 0.06 } else { 0.0 };
    let mut group = c.benchmark_group("discover (9 designs, t x c)");
    group.sample_size(20);
    for (name, effect) in [("found", hardening), ("nothing", spike)] {
        let obs = observations(effect);
        let f = diagnose::discover(&inputs(obs.clone(), true))
            .unwrap()
            .expect("the search ran");
        eprintln!(
            "{name}: {:?} {:?} ({} models searched)",
            f.found.outcome, f.found.term, f.search.library.models
        );
        if std::env::var("LAB_BENCH_VERBOSE").is_ok() {
            eprintln!("{}", f.search.evidence.join("\n"));
        }
        // The evidence (fits, tests, ranking) and the search; the evidence alone.
        group.bench_function(format!("{name}: evidence and search"), |b| {
            b.iter(|| diagnose::discover(&inputs(obs.clone(), true)).unwrap())
        });
        group.bench_function(format!("{name}: evidence alone"), |b| {
            b.iter(|| diagnose::discover(&inputs(obs.clone(), false)).unwrap())
        });
        group.bench_function(format!("{name}: whole diagnosis with the search"), |b| {
            b.iter(|| diagnose::diagnose(&inputs(obs.clone(), true)).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, search);
criterion_main!(benches);
