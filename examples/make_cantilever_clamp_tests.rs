//! Generates the "tests" of studies/cantilever-ccx-clamp.yaml with the real solver (CalculiX) at a
//! documented truth:
//!
//! - truth: the study's own template (templates/cantilever-ccx/beam-clamp.inp.tera) and constants,
//!   E = 68,000 MPa (the paper's E0) and a compliant clamp layer `clamp_E` = 210,000 MPa (a steel
//!   support under an aluminium beam); the clamp layer's depth is the template's default, h / 2;
//! - on a FINER mesh than the study's (40 x 16 x 4 elements against 20 x 8 x 2), so the study does
//!   not calibrate against its own discretisation (about 0.15 % apart in the tip deflection);
//! - 3 specimens per design, h = 7..13 mm (h7..h13): the model's tip deflection times
//!   (1 + 0.005 z), z standard normal from ChaCha8 seeded with SEED (the replicate scatter the
//!   diagnosis takes as its noise model).
//!
//! `cargo run --release --example make_cantilever_clamp_tests [-- OUT.csv]` from the repository
//! root (ccx on PATH; about 40 s); OUT defaults to studies/cantilever-ccx-clamp-tests.csv.
//! scripts/make_cantilever_clamp_tests.sh runs it.

use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

use lab::execute::{Adapter, STDOUT_FILE};
use lab::render::{self, Renderer};
use lab::study::{Response, Simulation};
use rand::{Rng, SeedableRng};

const STUDY: &str = "studies/cantilever-ccx-clamp.yaml";
const SEED: u64 = 12;
const E0: f64 = 68_000.0;
const CLAMP_E: f64 = 210_000.0;
const NOISE: f64 = 0.0025;
const SPECIMENS: usize = 5;
const MESH: (f64, f64, f64) = (40.0, 16.0, 4.0);

fn normal(rng: &mut impl Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

fn fail(message: String) -> ! {
    eprintln!("make_cantilever_clamp_tests: {message}");
    std::process::exit(1)
}

fn main() {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "studies/cantilever-ccx-clamp-tests.csv".into());
    let study = lab::study::load(Path::new(STUDY)).unwrap_or_else(|e| fail(e.to_string()));
    let Simulation::Solver(sim) = &study.simulation else {
        fail(format!("{STUDY}: not a solver study"))
    };
    let Response::Dat(adapter) = &sim.response else {
        fail(format!("{STUDY}: not a CalculiX study"))
    };
    let renderer = Renderer::new(&sim.inputs.templates).unwrap_or_else(|e| fail(e.to_string()));
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(SEED);
    // The CSV holds no comment (the experiments reader takes a header and rows): the truth is
    // documented here and in the study.
    let mut csv = String::from("design,h,deflection\n");
    for h in 7..=13 {
        let name = format!("h{h}");
        let mut ctx = render::context(&study, &name, &[h as f64], &[E0]);
        ctx.insert("nx", &MESH.0);
        ctx.insert("ny", &MESH.1);
        ctx.insert("nz", &MESH.2);
        render::extend(&mut ctx, &[("clamp_E".to_string(), CLAMP_E)]);
        let dir = tempfile::tempdir().unwrap_or_else(|e| fail(e.to_string()));
        for (rel, bytes) in renderer.render(&ctx).unwrap_or_else(|e| fail(e.to_string())) {
            std::fs::write(dir.path().join(rel), bytes).unwrap_or_else(|e| fail(e.to_string()));
        }
        let argv = adapter.argv();
        let run = Command::new(&argv[0])
            .args(&argv[1..])
            .current_dir(dir.path())
            .output()
            .unwrap_or_else(|e| fail(format!("cannot run {}: {e}", argv[0])));
        std::fs::write(dir.path().join(STDOUT_FILE), &run.stdout).unwrap_or_else(|e| fail(e.to_string()));
        if !run.status.success() {
            fail(format!("{name}: ccx exited with {}", run.status));
        }
        if let Some(o) = adapter.find_failure(dir.path()) {
            fail(format!("{name}: {o:?}"));
        }
        let model = adapter
            .extract(dir.path())
            .unwrap_or_else(|o| fail(format!("{name}: {o:?}")));
        eprintln!("{name}: model tip deflection {model:.6} mm");
        for _ in 0..SPECIMENS {
            let measured = model * (1.0 + NOISE * normal(&mut rng));
            let _ = writeln!(csv, "{name},{h},{measured:.6}");
        }
    }
    std::fs::write(&out, csv).unwrap_or_else(|e| fail(format!("{out}: {e}")));
    eprintln!("wrote {out}");
}
