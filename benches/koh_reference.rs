//! lab's Bayesian calibration side by side with a numpy/scipy reference of the same modular KOH
//! (benches/koh_reference.py) on the paper's cantilever, two tests (h = 8, 10), E in [50k, 80k]:
//! the same 24-run emulator design, the same likelihood and priors, timed in one run.
//!
//! Run: `cargo bench --bench koh_reference` (the Python environment comes from
//! scripts/bench-venv.sh, or set LAB_BENCH_PYTHON). The reference runs with single-threaded BLAS;
//! lab with its default thread pool (set RAYON_NUM_THREADS=1 for one thread). Figures: docs/benchmarks.md.

use std::process::Command;
use std::time::Instant;

use lab::calibrate::{Bounds, Problem, bayesian};
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

fn python() -> String {
    if let Ok(p) = std::env::var("LAB_BENCH_PYTHON") {
        return p;
    }
    let out = Command::new("scripts/bench-venv.sh")
        .output()
        .expect("scripts/bench-venv.sh runs");
    String::from_utf8_lossy(&out.stdout)
        .trim()
        .lines()
        .last()
        .unwrap_or("python3")
        .to_string()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let hs = [8.0, 10.0];
    let problem = Problem {
        designs: DMatrix::from_column_slice(2, 1, &hs),
        measured: DVector::from_iterator(2, hs.iter().map(|&h| timoshenko(h))),
        bounds: Bounds::new(vec![50_000.0], vec![80_000.0]),
        model: &euler,
    };
    let design_bounds = Bounds::new(vec![7.0], vec![13.0]);
    let settings = bayesian::Settings::default();
    let sim = bayesian::emulator_samples(&problem, &design_bounds, &settings);
    // lab: emulator fit, ML and posterior, from fresh runs each time (no shared emulator).
    let mut times = Vec::new();
    let mut fit = None;
    for _ in 0..21 {
        let fresh = bayesian::SimulationData::new(sim.inputs.clone(), sim.outputs.clone());
        let t0 = Instant::now();
        fit = Some(bayesian::calibrate(&problem, &design_bounds, &fresh, &settings).expect("calibrates"));
        times.push(t0.elapsed().as_secs_f64());
    }
    let fit = fit.expect("ran");
    let lab_s = median(times);
    let input = serde_json::json!({
        "inputs": (0..sim.inputs.nrows()).map(|i| sim.inputs.row(i).iter().copied().collect::<Vec<_>>()).collect::<Vec<_>>(),
        "outputs": sim.outputs.as_slice(),
        "lower": [7.0, 50_000.0], "upper": [13.0, 80_000.0],
        "design_lower": [7.0], "design_upper": [13.0],
        "designs": [[8.0], [10.0]],
        "measured": problem.measured.as_slice(),
        "lab_roughness": fit.emulator.roughness(),
    });
    let path = std::env::temp_dir().join("lab-koh-reference-input.json");
    std::fs::write(&path, input.to_string()).expect("writes the input");
    let out = Command::new(python())
        .arg("benches/koh_reference.py")
        .arg(&path)
        .arg("3")
        .env("OPENBLAS_NUM_THREADS", "1")
        .env("OMP_NUM_THREADS", "1")
        .env("MKL_NUM_THREADS", "1")
        .output()
        .expect("the reference runs");
    let text = String::from_utf8_lossy(&out.stdout);
    let reference: serde_json::Value = serde_json::from_str(text.trim())
        .unwrap_or_else(|_| panic!("reference output: {text}\n{}", String::from_utf8_lossy(&out.stderr)));
    let ref_s = reference["seconds"].as_f64().unwrap_or(f64::NAN);
    let ref_iv = [
        reference["interval95"][0].as_f64().unwrap_or(f64::NAN),
        reference["interval95"][1].as_f64().unwrap_or(f64::NAN),
    ];
    let (lo, hi) = fit.interval95[0];
    println!("| | lab | numpy/scipy reference |");
    println!("|---|---|---|");
    println!("| time (median) | {:.1} ms | {:.0} ms |", 1e3 * lab_s, 1e3 * ref_s);
    println!(
        "| E (ML) | {:.1} | {:.1} |",
        fit.theta[0],
        reference["theta"][0].as_f64().unwrap_or(f64::NAN)
    );
    println!(
        "| posterior median | {:.1} | {:.1} |",
        fit.median[0],
        reference["median"].as_f64().unwrap_or(f64::NAN)
    );
    println!(
        "| 95 % interval | [{lo:.0}, {hi:.0}] | [{:.0}, {:.0}] |",
        ref_iv[0], ref_iv[1]
    );
    println!(
        "| emulator roughness | {:?} | {} |",
        fit.emulator.roughness(),
        reference["roughness"]
    );
    println!(
        "\nratio reference / lab: {:.0}; E vs 64,911: {:+.3} %; interval ends vs reference: {:+.3} %, {:+.3} %",
        ref_s / lab_s,
        100.0 * (fit.theta[0] / 64_911.0 - 1.0),
        100.0 * (lo / ref_iv[0] - 1.0),
        100.0 * (hi / ref_iv[1] - 1.0)
    );
    println!(
        "reference time: emulator, ML, posterior grid: {} s",
        reference["seconds_emulator_ml_posterior"]
    );
    println!(
        "emulator ℓ: scipy's optimum {} , scipy's ℓ at lab's roughness {}",
        reference["emulator_nll"], reference["emulator_nll_at_lab_roughness"]
    );
}
