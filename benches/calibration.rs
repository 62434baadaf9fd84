//! The three calibration methods on the paper's cantilever (training h = 8, 10; E in [50k, 80k]).
//! Run: `cargo bench --bench calibration`; figures go in docs/benchmarks.md.

use criterion::{Criterion, criterion_group, criterion_main};
use lab::calibrate::{Bounds, Problem, bayesian, least_squares, sensitivity};
use nalgebra::{DMatrix, DVector};

const F: f64 = 600.0;
const B: f64 = 2.0;
const L: f64 = 20.0;
const NU: f64 = 0.36;
const E0: f64 = 68_000.0;

fn euler(d: &[f64], theta: &[f64]) -> f64 {
    4.0 * F * L.powi(3) / (theta[0] * B * d[0].powi(3))
}

fn timoshenko(h: f64) -> f64 {
    euler(&[h], &[E0]) + F * L * (4.0 + 5.0 * NU) / (2.0 * E0 * B * h)
}

fn problem() -> Problem<'static> {
    let hs = [8.0, 10.0];
    Problem {
        designs: DMatrix::from_column_slice(2, 1, &hs),
        measured: DVector::from_iterator(2, hs.iter().map(|&h| timoshenko(h))),
        bounds: Bounds::new(vec![50_000.0], vec![80_000.0]),
        model: &euler,
    }
}

fn methods(c: &mut Criterion) {
    let problem = problem();
    let design_bounds = Bounds::new(vec![7.0], vec![13.0]);
    let settings = bayesian::Settings::default();
    let samples = bayesian::emulator_samples(&problem, &design_bounds, &settings);
    c.bench_function("least_squares", |b| {
        b.iter(|| least_squares::calibrate(&problem).unwrap())
    });
    c.bench_function("sensitivity", |b| b.iter(|| sensitivity::calibrate(&problem).unwrap()));
    let mut group = c.benchmark_group("bayesian");
    group.sample_size(10);
    group.bench_function("emulator + ML + MCMC", |b| {
        b.iter(|| bayesian::calibrate(&problem, &design_bounds, &samples, &settings).unwrap())
    });
    group.finish();
}

criterion_group!(benches, methods);
criterion_main!(benches);
