//! Generates the "measured" tests of studies/honeycomb-openradioss.yaml with OpenRadioss itself,
//! from a documented truth the study's baseline lacks (see fixtures/README.md):
//!
//! - truth: the study's own deck (`templates/honeycomb-openradioss/main.k.tera`, the study's mesh,
//!   speed, mass scaling and output interval) with sigma_y = 185 MPa and linear strain hardening
//!   ETAN = 200 MPa (the baseline renders ETAN = 0);
//! - each specimen its own geometric imperfection: the starter's random nodal noise of the study's
//!   amplitude with the specimen's own seed (`-rxalea A -rseed S`, S = 0.1, 0.2, ... in order;
//!   the study's runs use another seed), so the specimens fold differently, as real ones do;
//! - specimen scatter, the whole force curve times (1 + 0.02 z), plus measurement noise of 0.5 %
//!   of the specimen's mean force per sample (z standard normal; ChaCha8 seeded with 2018, drawn
//!   in design then specimen order);
//! - each specimen a test-machine CSV `displacement [mm],force [kN]` (the striker's stroke and its
//!   contact force, from the T01 through lab's own reader); the experiments CSV (design, c, t,
//!   force) holds each specimen's mean crush force over the study's window, computed by lab's
//!   extractor on that CSV.
//!
//! `cargo run --release --example make_honeycomb_openradioss_tests -- OUT_DIR WORK_DIR`
//!
//! `... -- check WORK_DIR [TESTS_CSV]` instead runs the reduced model's mesh/speed check once, on
//! design C6T5 at the baseline (sigma_y = 185 MPa, no hardening, the study's nominal imperfection):
//! the study's model, the mesh refined (elements × 0.72, the mass-scaling step with them), the
//! speed halved (ramp, termination time and output interval doubled) and no mass scaling; it
//! prints each run's mean force over the window, initial peak, figures and time, and the change
//! against the specimens' scatter of that design in TESTS_CSV (the experiments CSV).
//!
//! Runs OpenRadioss (`starter_linux64_gf`, `engine_linux64_gf` on PATH; one thread each, argv, no
//! shell) in `WORK_DIR/<design>-<k>/`, one specimen at a time. Resumable: a specimen whose
//! directory holds the same deck and mesh and a finished run is not run again.

use std::fmt::Write as _;
use std::path::Path;
use std::process::{Command, Stdio};

use lab::execute::Adapter;
use lab::extract::adapters::openradioss::OpenRadiossAdapter;
use lab::extract::crush::{self, CsvOptions, SimSource, Window};
use lab::render::Renderer;
use lab::render::mesh::{self, TubeSpec};
use lab::study::{OpenRadiossSettings, Template};
use rand::{Rng, SeedableRng};

const SEED: u64 = 2018;
const SIGMA_Y: f64 = 185.0;
const ETAN: f64 = 200.0;
const SCATTER: f64 = 0.02;
const NOISE: f64 = 0.005;
const SPECIMENS: usize = 4;
/// Must match studies/honeycomb-openradioss.yaml (`tests/openradioss_study.rs` checks it).
pub const MODEL: Model = Model {
    element: 0.25,
    diameter: 10.0,
    length: 8.0,
    edge_set: 2,
    constants: &[
        ("ribbon_factor", 2.0),
        ("tube_length", 8.0),
        ("velocity", 5000.0),
        ("ramp_time", 0.0001),
        ("term_time", 0.00105),
        ("dt_out", 0.00001),
        ("dt_mass", 0.00000004),
        ("hold_edges", 1.0),
    ],
    noise: 0.005,
    window: Window { s0: 1.0, s1: 4.5 },
};
/// The study's nominal imperfection seed (`openradioss.noise.seed`).
const MODEL_SEED: f64 = 0.5;
const DESIGNS: [(&str, f64, f64); 3] = [("C6T5", 6.0, 0.05), ("C6T65", 6.0, 0.065), ("C6T8", 6.0, 0.08)];

/// The study's model settings the tests share.
pub struct Model {
    element: f64,
    diameter: f64,
    length: f64,
    edge_set: u32,
    constants: &'static [(&'static str, f64)],
    noise: f64,
    window: Window,
}

fn normal(rng: &mut impl Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

fn fail(message: String) -> ! {
    eprintln!("make_honeycomb_openradioss_tests: {message}");
    std::process::exit(1)
}

/// A deck to run: the design, the material, and what differs from the study's model.
struct Case<'a> {
    name: &'a str,
    c: f64,
    t: f64,
    sigma_y: f64,
    etan: f64,
    /// Element size, mm.
    element: f64,
    /// Template variables replacing the study's constants of the same name.
    overrides: &'a [(&'a str, f64)],
}

/// The case's deck and mesh, rendered as the study renders its runs (mesh beside the deck).
fn render(renderer: &Renderer, case: &Case) -> (String, String) {
    let spec = TubeSpec {
        cell: case.c,
        diameter: MODEL.diameter,
        length: MODEL.length,
        element: case.element,
    };
    let (mesh_text, _) = mesh::include_with_edge_set(&spec, MODEL.edge_set).unwrap_or_else(|e| fail(e.to_string()));
    let mut ctx = tera::Context::new();
    let base = [
        ("c", case.c),
        ("t", case.t),
        ("sigma_y", case.sigma_y),
        ("etan", case.etan),
    ];
    for (k, v) in base.into_iter().chain(MODEL.constants.iter().copied()) {
        let v = case.overrides.iter().find(|(o, _)| *o == k).map_or(v, |(_, o)| *o);
        ctx.insert(k, &v);
    }
    let name = case.name;
    ctx.insert("design_name", name);
    ctx.insert("mesh_file", "mesh.k");
    let deck = renderer.render(&ctx).unwrap_or_else(|e| fail(e.to_string()));
    let deck = String::from_utf8(deck[0].1.clone()).unwrap_or_else(|e| fail(e.to_string()));
    (deck, mesh_text)
}

/// The adapter as the study builds it, with the nodal noise's `seed`.
fn adapter(seed: f64) -> OpenRadiossAdapter {
    OpenRadiossAdapter {
        window: MODEL.window,
        source: SimSource::honeycomb_striker(),
        deck: "main.k".into(),
        settings: OpenRadiossSettings {
            starter: "starter_linux64_gf".into(),
            engine: "engine_linux64_gf".into(),
            threads: 1,
            noise: Some((MODEL.noise, seed)),
            environment: Vec::new(),
            standin: None,
        },
    }
}

/// Runs the specimen in `dir` unless a finished run of the same deck and mesh is there.
fn run(adapter: &OpenRadiossAdapter, dir: &Path, deck: &str, mesh_text: &str) {
    let same = |name: &str, text: &str| std::fs::read_to_string(dir.join(name)).is_ok_and(|t| t == text);
    if same("main.k", deck) && same("mesh.k", mesh_text) && adapter.judge(dir).is_ok() {
        eprintln!("{}: finished earlier, reused", dir.display());
        return;
    }
    let _ = std::fs::remove_dir_all(dir);
    std::fs::create_dir_all(dir).unwrap_or_else(|e| fail(format!("{}: {e}", dir.display())));
    std::fs::write(dir.join("mesh.k"), mesh_text).unwrap();
    std::fs::write(dir.join("main.k"), deck).unwrap();
    let chain = adapter.chain();
    let argvs = std::iter::once(OpenRadiossAdapter::starter_argv(&adapter.settings, &adapter.deck)).chain(chain.then);
    for argv in argvs {
        let log = std::fs::File::create(dir.join(format!("{}.log", argv[0]))).unwrap();
        let status = Command::new(&argv[0])
            .args(&argv[1..])
            .envs(chain.env.iter().map(|(k, v)| (k, v)))
            .current_dir(dir)
            .stdout(log)
            .stderr(Stdio::null())
            .status()
            .unwrap_or_else(|e| fail(format!("cannot start {}: {e}", argv[0])));
        if !status.success() {
            fail(format!("{} failed in {}", argv[0], dir.display()));
        }
    }
    for rel in chain.scratch {
        let _ = std::fs::remove_file(dir.join(rel));
    }
    if let Err(o) = adapter.judge(dir) {
        fail(format!("{}: {o}", dir.display()));
    }
}

fn renderer() -> Renderer {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let file = root.join("templates/honeycomb-openradioss/main.k.tera");
    let source = std::fs::read_to_string(&file).unwrap_or_else(|e| fail(format!("{}: {e}", file.display())));
    Renderer::new(&[Template {
        file,
        output: "main.k".into(),
        source,
    }])
    .unwrap_or_else(|e| fail(e.to_string()))
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match &args[..] {
        [mode, work] if mode == "check" => check(Path::new(work), None),
        [mode, work, tests] if mode == "check" => check(Path::new(work), Some(Path::new(tests))),
        [out, work] => tests(Path::new(out), Path::new(work)),
        _ => fail("usage: make_honeycomb_openradioss_tests OUT_DIR WORK_DIR | check WORK_DIR [TESTS_CSV]".into()),
    }
}

/// The tests: every design's specimens, their CSVs and the experiments CSV.
fn tests(out: &Path, work: &Path) {
    std::fs::create_dir_all(out).unwrap_or_else(|e| fail(format!("{}: {e}", out.display())));
    let renderer = renderer();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(SEED);
    let mut experiments = String::from("design,c,t,force\n");
    for (name, c, t) in DESIGNS {
        let case = Case {
            name,
            c,
            t,
            sigma_y: SIGMA_Y,
            etan: ETAN,
            element: MODEL.element,
            overrides: &[],
        };
        let (deck, mesh_text) = render(&renderer, &case);
        for k in 1..=SPECIMENS {
            let seed = 0.1 * k as f64;
            let adapter = adapter(seed);
            let dir = work.join(format!("{name}-{k}"));
            run(&adapter, &dir, &deck, &mesh_text);
            let curve = lab::extract::adapters::openradioss::read_curve(&dir, &adapter)
                .unwrap_or_else(|| fail(format!("{}: no curve", dir.display())));
            let plain = crush::crush_force(&curve, MODEL.window).unwrap_or_else(|e| fail(e.to_string()));
            let factor = 1.0 + SCATTER * normal(&mut rng);
            let mut csv = format!(
                "# honeycomb specimen {name}-{k}: a SYNTHETIC test made with OpenRadioss\n\
                 # truth sigma_y = {SIGMA_Y} MPa, ETAN = {ETAN} MPa; imperfection seed {seed:.1}; scatter x{factor:.5}; \
                 noise {NOISE} x mean; seed {SEED}\ndisplacement [mm],force [kN]\n"
            );
            for (d, f) in curve.displacement.iter().zip(&curve.force) {
                let noisy = f * factor + NOISE * plain.mean_force * normal(&mut rng);
                writeln!(csv, "{d:.5},{noisy:.6}").unwrap();
            }
            let path = out.join(format!("{name}-{k}.csv"));
            std::fs::write(&path, &csv).unwrap_or_else(|e| fail(format!("{}: {e}", path.display())));
            let read = crush::read_test_csv(&path, CsvOptions::default()).unwrap_or_else(|e| fail(e.to_string()));
            let measured = crush::crush_force(&read, MODEL.window).unwrap_or_else(|e| fail(e.to_string()));
            writeln!(experiments, "{name},{c},{t},{}", measured.mean_force).unwrap();
            eprintln!(
                "{name}-{k}: imperfection seed {seed:.1}, mean force {:.4} kN",
                measured.mean_force
            );
        }
    }
    std::fs::write(out.join("experiments.csv"), experiments).unwrap_or_else(|e| fail(e.to_string()));
}

/// A variant of the check: its label, element size and template variables.
type Variant<'a> = (&'a str, f64, Vec<(&'a str, f64)>);

/// The mesh/speed check (see the module note).
fn check(work: &Path, tests: Option<&Path>) {
    let renderer = renderer();
    let constant = |k: &str| MODEL.constants.iter().find(|(n, _)| *n == k).map_or(0.0, |(_, v)| *v);
    let (v, ramp, term, out, dms) = (
        constant("velocity"),
        constant("ramp_time"),
        constant("term_time"),
        constant("dt_out"),
        constant("dt_mass"),
    );
    let fine = 0.72;
    let slow = [
        ("velocity", v / 2.0),
        ("ramp_time", 2.0 * ramp),
        ("term_time", 2.0 * term),
        ("dt_out", 2.0 * out),
    ];
    let variants: [Variant; 4] = [
        ("the study's model", MODEL.element, vec![]),
        (
            "mesh refined",
            round(MODEL.element * fine),
            vec![("dt_mass", round(dms * fine))],
        ),
        ("speed halved", MODEL.element, slow.to_vec()),
        ("no mass scaling", MODEL.element, vec![("dt_mass", 0.0)]),
    ];
    let scatter = tests.map(|p| specimen_scatter(p, "C6T5"));
    let mut base = None;
    println!(
        "| variant | element (mm) | speed (m/s) | mean force {}–{} mm (N) | change | initial peak (N) | kinetic/internal | added mass | energy error | solver time (s) |",
        MODEL.window.s0, MODEL.window.s1
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for (label, element, overrides) in variants {
        let case = Case {
            name: "C6T5",
            c: 6.0,
            t: 0.05,
            sigma_y: SIGMA_Y,
            etan: 0.0,
            element,
            overrides: &overrides,
        };
        let (deck, mesh_text) = render(&renderer, &case);
        let dir = work.join(label.replace(' ', "-").replace('\'', ""));
        let adapter = adapter(MODEL_SEED);
        let started = std::time::Instant::now();
        run(&adapter, &dir, &deck, &mesh_text);
        let seconds = started.elapsed().as_secs_f64();
        let judged = adapter.judge(&dir).unwrap_or_else(|o| fail(o.to_string()));
        let curve =
            lab::extract::adapters::openradioss::read_curve(&dir, &adapter).unwrap_or_else(|| fail("no curve".into()));
        let peak = curve
            .displacement
            .iter()
            .zip(&curve.force)
            .filter(|(d, _)| **d < MODEL.window.s0)
            .map(|(_, f)| *f)
            .fold(0.0, f64::max);
        let mean = judged.response;
        let change = base.map_or("–".to_string(), |b: f64| {
            format!("{:+.1} %", 100.0 * (mean / b - 1.0))
        });
        base.get_or_insert(mean);
        let q = judged.quality.unwrap_or_default();
        let pct = |v: Option<f64>| v.map_or("–".into(), |v| format!("{:.1} %", 100.0 * v));
        let speed = overrides.iter().find(|(k, _)| *k == "velocity").map_or(v, |(_, s)| *s) / 1000.0;
        println!(
            "| {label} | {element} | {speed} | {:.1} | {change} | {:.1} | {} | {} | {} | {seconds:.0} |",
            1000.0 * mean,
            1000.0 * peak,
            pct(q.kinetic_ratio),
            pct(q.added_mass_ratio),
            pct(q.energy_error)
        );
    }
    if let (Some((mean, sd, n)), Some(b)) = (scatter, base) {
        println!(
            "\nC6T5 specimens: mean {:.1} N, standard deviation {:.1} N ({:.1} % of the model's {:.1} N), {n} specimens",
            1000.0 * mean,
            1000.0 * sd,
            100.0 * sd / b,
            1000.0 * b
        );
    }
}

/// 4 significant digits: a template field takes it exactly.
fn round(v: f64) -> f64 {
    let scale = 10f64.powi(3 - v.abs().log10().floor() as i32);
    (v * scale).round() / scale
}

/// Mean and standard deviation of `design`'s specimens in the experiments CSV, and their count.
fn specimen_scatter(csv: &Path, design: &str) -> (f64, f64, usize) {
    let text = std::fs::read_to_string(csv).unwrap_or_else(|e| fail(format!("{}: {e}", csv.display())));
    let v: Vec<f64> = text
        .lines()
        .skip(1)
        .filter(|l| l.starts_with(&format!("{design},")))
        .filter_map(|l| l.rsplit(',').next()?.parse().ok())
        .collect();
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    (mean, sd, v.len())
}
