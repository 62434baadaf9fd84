//! The honeycomb-tube mesher against the geometry.
//!
//! Formulas: hexagon of size c across flats has area A_cell = (√3/2) c²; a hexagonal lattice has
//! wall length 2/c per unit area, a third of it in the ribbon direction. The tube's cross-section
//! is A = π D²/4 (D = 57.35 mm), so cells ≈ A / A_cell and wall length ≈ 2A/c.

use std::collections::HashSet;

use lab::render::mesh::{self, PART_RIBBON, PART_SINGLE, TubeSpec};

const COARSE: f64 = 2.0;

fn area() -> f64 {
    std::f64::consts::PI / 4.0 * 57.35f64.powi(2)
}

#[test]
fn cell_count_and_wall_length_follow_the_geometry() {
    for cell in [3.0, 6.0] {
        let s = mesh::mesh(&TubeSpec::paper(cell, COARSE)).unwrap().summary();
        let cells = area() / (3f64.sqrt() / 2.0 * cell * cell);
        let walls = 2.0 * area() / cell;
        let total = s.wall_length_single + s.wall_length_ribbon;
        assert!(
            (s.cells as f64 / cells - 1.0).abs() < 0.03,
            "c={cell}: {} cells, expected ≈ {cells:.1}",
            s.cells
        );
        assert!(
            (total / walls - 1.0).abs() < 0.02,
            "c={cell}: wall length {total:.1}, expected ≈ {walls:.1}"
        );
        let ribbon_share = s.wall_length_ribbon / total;
        assert!(
            (ribbon_share - 1.0 / 3.0).abs() < 0.02,
            "c={cell}: ribbon share {ribbon_share:.3}"
        );
        assert!(
            s.dropped_length < 0.01 * total,
            "c={cell}: dropped {}",
            s.dropped_length
        );
    }
}

#[test]
fn no_duplicate_nodes_and_every_node_used() {
    let m = mesh::mesh(&TubeSpec::paper(3.0, COARSE)).unwrap();
    let mut seen = HashSet::new();
    for (_, [x, y, z]) in m.nodes() {
        let key = (
            (x * 1e4).round() as i64,
            (y * 1e4).round() as i64,
            (z * 1e4).round() as i64,
        );
        assert!(seen.insert(key), "two nodes at ({x}, {y}, {z})");
    }
    let used: HashSet<usize> = m.elements().flat_map(|(_, _, n)| n).collect();
    assert_eq!(used.len(), m.node_count(), "unused nodes");
}

#[test]
fn junctions_are_shared_between_three_walls() {
    let m = mesh::mesh(&TubeSpec::paper(3.0, COARSE)).unwrap();
    let mut degree = vec![0usize; m.points.len()];
    for w in &m.walls {
        degree[w.points[0]] += 1;
        degree[*w.points.last().unwrap()] += 1;
    }
    let y_junctions = degree.iter().filter(|&&d| d == 3).count();
    // Two Y junctions per cell in the interior.
    assert!(
        y_junctions as f64 > 1.8 * m.cells as f64,
        "{y_junctions} junctions for {} cells",
        m.cells
    );
}

#[test]
fn element_quality_is_bounded() {
    for (cell, h) in [(3.0, COARSE), (6.0, COARSE), (3.0, 1.0)] {
        let s = mesh::mesh(&TubeSpec::paper(cell, h)).unwrap().summary();
        assert!(
            s.min_aspect >= 1.0 && s.max_aspect <= 4.0 + 1e-9,
            "c={cell} h={h}: {s:?}"
        );
    }
    let m = mesh::mesh(&TubeSpec::paper(3.0, COARSE)).unwrap();
    let xyz: Vec<[f64; 3]> = m.nodes().map(|(_, p)| p).collect();
    for (_, _, n) in m.elements() {
        let p = |i: usize| xyz[n[i] - 1];
        let (a, b, d) = (p(0), p(1), p(3));
        let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let v = [d[0] - a[0], d[1] - a[1], d[2] - a[2]];
        let cross = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        let area = (cross[0].powi(2) + cross[1].powi(2) + cross[2].powi(2)).sqrt();
        assert!(area > 0.25 * 0.25 * COARSE * COARSE, "degenerate shell {n:?}");
    }
}

#[test]
fn ribbon_part_present_in_the_include() {
    let (text, s) = mesh::include(&TubeSpec::paper(6.0, COARSE)).unwrap();
    assert!(s.elements_ribbon > 0 && s.elements_single > 2 * s.elements_ribbon - s.elements_ribbon / 5);
    let parts: HashSet<u32> = text
        .lines()
        .skip_while(|l| !l.starts_with("*ELEMENT_SHELL"))
        .filter(|l| !l.starts_with(['*', '$']))
        .map(|l| l[8..16].trim().parse().unwrap())
        .collect();
    assert_eq!(parts, HashSet::from([PART_SINGLE, PART_RIBBON]));
    assert!(text.lines().all(|l| l.len() <= 80), "a line over 80 columns");
    assert_eq!(text.lines().last(), Some("*END"));
    let problems = lab::render::lsdyna::lint::lint_named("mesh.k", &text, &|_| None);
    assert!(problems.is_empty(), "{problems:?}");
}

/// Sizes and timings of the paper's meshes (0.5 mm): `cargo test --release --test suite -- --ignored --nocapture deck_mesh::`.
#[test]
#[ignore]
fn paper_mesh_sizes() {
    for (cell, h) in [(6.0, 0.5), (3.0, 0.5), (6.0, COARSE), (3.0, COARSE)] {
        let t0 = std::time::Instant::now();
        let (text, s) = mesh::include(&TubeSpec::paper(cell, h)).unwrap();
        println!(
            "c={cell} h={h}: {s:?}, {} MB, {:.2} s",
            text.len() / 1_000_000,
            t0.elapsed().as_secs_f64()
        );
    }
}
