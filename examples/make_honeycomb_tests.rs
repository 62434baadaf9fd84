//! Generates the honeycomb study's "measured" tests from a documented truth, with the stand-in
//! solver `crushsim` (see fixtures/README.md):
//!
//! - truth: the deck template `templates/honeycomb/main.k.tera` with sigma_y = 185 MPa and ONE
//!   effect the study's baseline lacks: linear strain hardening ETAN = 200 MPa (design-dependent
//!   through the fold geometry in crushsim's physics); everything else as the study's runs
//!   (mesh element size, output interval, termination time);
//! - 3 specimens per design (C6T5, C3T7, C3T8): specimen scatter, the whole force curve times
//!   (1 + 0.02 z), plus measurement noise of 0.5 % of the specimen's mean force per sample
//!   (z standard normal; ChaCha8 seeded with SEED);
//! - each specimen a test-machine CSV `displacement [mm],force [kN]`; the experiments CSV
//!   (design, c, t, force) holds each specimen's mean crush force over 5–60 mm as computed by
//!   lab's own extractor on that CSV.
//!
//! `cargo run --release --example make_honeycomb_tests -- OUT_DIR PATH/TO/crushsim [DESIGNS [SPECIMENS]]`
//!
//! `HONEYCOMB_TESTS_TRUTH` (optional, for the seeded families of `tests/curves_family.rs`) replaces
//! the documented truth: comma-separated `key=value` among `sigma_y`, `etan`, `src`, `srp` (the
//! deck's Cowper–Symonds rate parameters, 0 = none), `scatter` and `noise`; keys not given keep the
//! fixtures' values. Unset, the output is the fixtures' byte for byte.
//!
//! DESIGNS (optional) is a comma-separated list `NAME:c:t` (e.g. `C6T5:6:0.05,C3T8:3:0.08`); the
//! default is the three designs of studies/honeycomb.yaml. The truth, noise and seed are the same
//! for any list (the random draws follow the list's order). SPECIMENS (optional, default 3) is the
//! number of specimens per design.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use lab::extract::crush::{self, CsvOptions, SimSource, Window};
use lab::extract::lsdyna::{nodout, rcforc};
use lab::render::Renderer;
use lab::render::mesh::{self, TubeSpec};
use lab::study::Template;
use rand::{Rng, SeedableRng};

const SEED: u64 = 2018;
const SIGMA_Y: f64 = 185.0;
const ETAN: f64 = 200.0;
const SCATTER: f64 = 0.02;
const NOISE: f64 = 0.005;
const SPECIMENS: usize = 3;
/// Must match studies/honeycomb.yaml.
const ELEMENT: f64 = 2.0;
const TERM_TIME: f64 = 0.061;
const DT_OUT: f64 = 0.0005;
const WINDOW: Window = Window { s0: 5.0, s1: 60.0 };
const DESIGNS: [(&str, f64, f64); 3] = [("C6T5", 6.0, 0.05), ("C3T7", 3.0, 0.07), ("C3T8", 3.0, 0.08)];

fn normal(rng: &mut impl Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// `NAME:c:t,NAME:c:t,...`
fn parse_designs(list: &str) -> Vec<(String, f64, f64)> {
    list.split(',')
        .map(|item| {
            let parts: Vec<&str> = item.trim().split(':').collect();
            let [name, c, t] = parts[..] else {
                eprintln!("bad design `{item}`: expected NAME:c:t");
                std::process::exit(2);
            };
            let num = |v: &str| -> f64 {
                v.parse().unwrap_or_else(|_| {
                    eprintln!("bad number `{v}` in design `{item}`");
                    std::process::exit(2)
                })
            };
            (name.to_string(), num(c), num(t))
        })
        .collect()
}

/// What the tests are made from: the material, the specimen scatter and the measurement noise.
struct Truth {
    sigma_y: f64,
    etan: f64,
    src: f64,
    srp: f64,
    scatter: f64,
    noise: f64,
}

/// The fixtures' truth, or `HONEYCOMB_TESTS_TRUTH`'s.
fn truth() -> Truth {
    let mut t = Truth {
        sigma_y: SIGMA_Y,
        etan: ETAN,
        src: 0.0,
        srp: 0.0,
        scatter: SCATTER,
        noise: NOISE,
    };
    let Ok(list) = std::env::var("HONEYCOMB_TESTS_TRUTH") else {
        return t;
    };
    for item in list.split(',').filter(|i| !i.trim().is_empty()) {
        let (key, value) = item.split_once('=').unwrap_or((item, ""));
        let Ok(v) = value.trim().parse::<f64>() else {
            eprintln!("HONEYCOMB_TESTS_TRUTH: bad `{item}`: expected key=number");
            std::process::exit(2);
        };
        match key.trim() {
            "sigma_y" => t.sigma_y = v,
            "etan" => t.etan = v,
            "src" => t.src = v,
            "srp" => t.srp = v,
            "scatter" => t.scatter = v,
            "noise" => t.noise = v,
            other => {
                eprintln!("HONEYCOMB_TESTS_TRUTH: unknown key `{other}` (sigma_y, etan, src, srp, scatter, noise)");
                std::process::exit(2);
            }
        }
    }
    t
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (out, crushsim, designs, specimens) = match &args[..] {
        [out, crushsim] => (
            out,
            crushsim,
            DESIGNS.iter().map(|&(n, c, t)| (n.to_string(), c, t)).collect(),
            SPECIMENS,
        ),
        [out, crushsim, list] => (out, crushsim, parse_designs(list), SPECIMENS),
        [out, crushsim, list, n] => (
            out,
            crushsim,
            parse_designs(list),
            n.parse().ok().filter(|&n: &usize| n > 0).unwrap_or_else(|| {
                eprintln!("bad specimen count `{n}`");
                std::process::exit(2)
            }),
        ),
        _ => {
            eprintln!("usage: make_honeycomb_tests OUT_DIR CRUSHSIM [NAME:c:t,... [SPECIMENS]]");
            std::process::exit(2);
        }
    };
    let out = PathBuf::from(out);
    std::fs::create_dir_all(&out).unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let file = root.join("templates/honeycomb/main.k.tera");
    let source = std::fs::read_to_string(&file).unwrap();
    let renderer = Renderer::new(&[Template {
        file,
        output: "main.k".into(),
        source,
    }])
    .unwrap();
    // HONEYCOMB_TESTS_SEED: fresh draws of the same truth, for checks on cases the fixtures are not
    // (scripts/honeycomb-diagnosis-seeds.sh); the fixtures use SEED.
    let seed = std::env::var("HONEYCOMB_TESTS_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(SEED);
    let truth = truth();
    let rate = if truth.src > 0.0 {
        format!(", rate SRC = {} 1/s SRP = {}", truth.src, truth.srp)
    } else {
        String::new()
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut experiments = String::from("design,c,t,force\n");
    for (name, c, t) in designs {
        let name = name.as_str();
        let dir = tempfile::tempdir().unwrap();
        let (mesh_text, _) = mesh::include(&TubeSpec::paper(c, ELEMENT)).unwrap();
        std::fs::write(dir.path().join("mesh.k"), mesh_text).unwrap();
        let mut ctx = tera::Context::new();
        for (k, v) in [
            ("c", c),
            ("t", t),
            ("sigma_y", truth.sigma_y),
            ("etan", truth.etan),
            ("src", truth.src),
            ("srp", truth.srp),
            ("ribbon_factor", 2.0),
            ("term_time", TERM_TIME),
            ("dt_out", DT_OUT),
        ] {
            ctx.insert(k, &v);
        }
        ctx.insert("design_name", name);
        ctx.insert("mesh_file", "mesh.k");
        let deck = renderer.render(&ctx).unwrap();
        std::fs::write(dir.path().join("main.k"), &deck[0].1).unwrap();
        let status = std::process::Command::new(crushsim)
            .arg("i=main.k")
            .current_dir(dir.path())
            .stdout(std::process::Stdio::null())
            .status()
            .unwrap();
        assert!(status.success(), "crushsim failed for {name}");
        let rc = rcforc::read(&dir.path().join("rcforc")).unwrap();
        let nod = nodout::read(&dir.path().join("nodout")).unwrap();
        let source = SimSource::honeycomb_striker();
        let curve = crush::from_lsdyna(&rc, &nod, &source).unwrap();
        let level = crush::crush_force(&curve, WINDOW).unwrap().mean_force;
        for k in 1..=specimens {
            let factor = 1.0 + truth.scatter * normal(&mut rng);
            let (sy, et, noise) = (truth.sigma_y, truth.etan, truth.noise);
            let mut csv = format!(
                "# honeycomb tube {name} specimen {k}: SYNTHETIC test from the stand-in solver crushsim\n\
                 # truth sigma_y = {sy} MPa, ETAN = {et} MPa{rate}; scatter x{factor:.5}; noise {noise} x mean; seed {seed}\n\
                 displacement [mm],force [kN]\n"
            );
            for (d, f) in curve.displacement.iter().zip(&curve.force) {
                let measured = f * factor + noise * level * normal(&mut rng);
                let _ = writeln!(csv, "{d:.4},{measured:.5}");
            }
            let path = out.join(format!("{name}-{k}.csv"));
            std::fs::write(&path, csv).unwrap();
            let read = crush::read_test_csv(&path, CsvOptions::default()).unwrap();
            let mean = crush::crush_force(&read, WINDOW).unwrap().mean_force;
            let _ = writeln!(experiments, "{name},{c},{t},{mean}");
            println!("{name} specimen {k}: mean crush force {mean:.4} kN (model level {level:.4} kN)");
        }
    }
    std::fs::write(out.join("experiments.csv"), experiments).unwrap();
}
