//! Reading one recorded honeycomb run (fixtures/honeycomb, the main job's recordings: `rcforc`
//! 76 kB, `nodout` 53 kB, read for every run's response and curve) and writing the finest tube's
//! mesh (the main job's C3 designs: 7.6 MB of keyword text, generated once per distinct tube).
//! These are the main job's largest costs outside the numerics.
//!
//! And the same run's curve read from binout instead: the recording's histories
//! written into a binout as crushsim writes it (LS-DYNA's layout, float32, a symbol table per
//! output time), then read back from disk: the rcforc interface side and the nodout node, paired
//! into the force–displacement curve, against the same from the ASCII files.
//!
//! Run: `cargo bench --bench extract`; the figures go in docs/benchmarks.md and
//! docs/binout.md.

use criterion::{Criterion, criterion_group, criterion_main};
use lab::extract::crush::{self, SimSource};
use lab::extract::lsdyna::binout::{self, histories};
use lab::extract::lsdyna::{glstat, nodout, rcforc};
use lab::render::mesh::{self, TubeSpec};
use std::path::Path;

/// The first recording of the main job (by directory name).
fn recording() -> std::path::PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/honeycomb");
    let mut dirs: Vec<_> = std::fs::read_dir(&root)
        .expect("fixtures/honeycomb")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("rcforc").is_file())
        .collect();
    dirs.sort();
    dirs.remove(0)
}

fn bench(c: &mut Criterion) {
    let dir = recording();
    let rc = std::fs::read_to_string(dir.join("rcforc")).unwrap();
    let nod = std::fs::read_to_string(dir.join("nodout")).unwrap();
    c.bench_function("rcforc parse (76 kB)", |b| {
        b.iter(|| rcforc::parse(Path::new("rcforc"), &rc).unwrap())
    });
    c.bench_function("nodout parse (53 kB)", |b| {
        b.iter(|| nodout::parse(Path::new("nodout"), &nod).unwrap())
    });
    curve_from_binout_and_ascii(c, &dir);
    let tube = TubeSpec {
        cell: 3.0,
        diameter: 57.35,
        length: 150.0,
        element: 2.0,
    };
    let mut group = c.benchmark_group("mesh");
    group.sample_size(20);
    group.bench_function("C3 tube keyword text", |b| b.iter(|| mesh::include(&tube).unwrap()));
    group.finish();
}

/// The recording's rcforc, nodout and glstat as a binout in LS-DYNA's layout (what crushsim
/// writes for BINARY 2): per output time a step directory of each history, then a symbol table.
fn as_binout(dir: &Path) -> Vec<u8> {
    let rc = rcforc::read(&dir.join("rcforc")).unwrap();
    let nod = nodout::read(&dir.join("nodout")).unwrap();
    let gl = glstat::read(&dir.join("glstat")).unwrap();
    let r4 = |v: &[f64]| lsda::Values::R4(v.iter().map(|&x| x as f32).collect());
    let mut w = lsda::Writer::new(lsda::Header::default());
    let entries: Vec<_> = rc.interfaces.keys().copied().collect();
    w.cd("/rcforc/metadata");
    w.write("ids", &lsda::Values::I4(entries.iter().map(|e| e.1 as i32).collect()))
        .unwrap();
    w.write(
        "side",
        &lsda::Values::I4(entries.iter().map(|e| (e.0 == rcforc::Side::SurfB) as i32).collect()),
    )
    .unwrap();
    let ids: Vec<u64> = nod.nodes.keys().copied().collect();
    w.cd("/nodout/metadata");
    w.write("ids", &lsda::Values::I4(ids.iter().map(|&i| i as i32).collect()))
        .unwrap();
    let times = &rc.interfaces[&entries[0]].time;
    for (k, t) in times.iter().enumerate() {
        w.cd(&format!("/rcforc/d{:06}", k + 1));
        w.write("time", &r4(&[*t])).unwrap();
        let col = |f: &dyn Fn(&rcforc::ContactSeries) -> f64| -> Vec<f64> {
            entries.iter().map(|e| f(&rc.interfaces[e])).collect()
        };
        w.write("x_force", &r4(&col(&|s| s.x[k]))).unwrap();
        w.write("y_force", &r4(&col(&|s| s.y[k]))).unwrap();
        w.write("z_force", &r4(&col(&|s| s.z[k]))).unwrap();
        w.write("mass", &r4(&col(&|s| s.mass[k]))).unwrap();
        w.cd(&format!("/nodout/d{:06}", k + 1));
        w.write("time", &r4(&[*t])).unwrap();
        for (a, axis) in ["x", "y", "z"].iter().enumerate() {
            for (name, of) in [
                ("displacement", 0),
                ("velocity", 1),
                ("acceleration", 2),
                ("coordinate", 3),
            ] {
                let v: Vec<f64> = ids
                    .iter()
                    .map(|i| {
                        let s = &nod.nodes[i];
                        [&s.disp, &s.vel, &s.accl, &s.coor][of][a][k]
                    })
                    .collect();
                w.write(&format!("{axis}_{name}"), &r4(&v)).unwrap();
            }
        }
        if let Some(g) = gl.steps.iter().position(|s| s.time == *t) {
            w.cd(&format!("/glstat/d{:06}", g + 1));
            w.write("time", &r4(&[*t])).unwrap();
            for (label, v) in &gl.steps[g].values {
                w.write(&label.replace([' ', '/', '.'], "_"), &r4(&[*v])).unwrap();
            }
        }
        w.flush().unwrap();
    }
    w.finish().unwrap().remove(0)
}

fn curve_from_binout_and_ascii(c: &mut Criterion, recording: &Path) {
    let src = SimSource::honeycomb_striker();
    let bin_dir = tempfile::tempdir().unwrap();
    let bytes = as_binout(recording);
    std::fs::write(bin_dir.path().join("binout"), &bytes).unwrap();
    let ascii_curve = || {
        let rc_text = std::fs::read_to_string(recording.join("rcforc")).unwrap();
        let nod_text = std::fs::read_to_string(recording.join("nodout")).unwrap();
        let rc = rcforc::parse_interface(Path::new("rcforc"), &rc_text, src.side, src.interface).unwrap();
        let nod = nodout::parse(Path::new("nodout"), &nod_text).unwrap();
        crush::from_lsdyna(&rc, &nod, &src).unwrap()
    };
    let binout_curve = || {
        let b = binout::open_dir(bin_dir.path()).unwrap().unwrap();
        let rc = histories::rcforc(&b).unwrap().unwrap();
        let nod = histories::nodout(&b).unwrap().unwrap();
        crush::from_lsdyna(&rc, &nod, &src).unwrap()
    };
    let (a, b) = (ascii_curve(), binout_curve());
    assert_eq!(a.force.len(), b.force.len(), "the same curve both ways");
    let mut group = c.benchmark_group(format!("run curve (rcforc + nodout), binout {} kB", bytes.len() / 1000));
    group.bench_function("from the ASCII files", |b| b.iter(ascii_curve));
    group.bench_function("from binout", |b| b.iter(binout_curve));
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
