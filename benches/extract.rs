//! Reading one recorded honeycomb run (fixtures/honeycomb, the main job's recordings: `rcforc`
//! 76 kB, `nodout` 53 kB, read for every run's response and curve) and writing the finest tube's
//! mesh (the main job's C3 designs: 7.6 MB of keyword text, generated once per distinct tube).
//! These are the main job's largest costs outside the numerics.
//!
//! Run: `cargo bench --bench extract`; the figures go in the README (Benchmarks).

use criterion::{Criterion, criterion_group, criterion_main};
use lab::extract::lsdyna::{nodout, rcforc};
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

criterion_group!(benches, bench);
criterion_main!(benches);
