//! The crush-force extractor: analytic mean forces, windows, time synchronisation, test-machine CSVs.

use lab::extract::crush::{
    CrushError, CsvOptions, ForceDisplacement, ForceUnit, Sign, SimSource, Window, crush_force, from_histories,
    from_lsdyna, parse_test_csv, read_test_csv,
};
use lab::extract::lsdyna::{nodout, rcforc, rcforc::Side};
use std::f64::consts::PI;
use std::path::Path;

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

#[test]
fn constant_plus_sinusoid_over_whole_periods_gives_the_constant() {
    let (c, a, lambda, periods, per) = (12.5, 4.0, 3.7, 5, 64);
    let n = periods * per;
    let d: Vec<f64> = (0..=n).map(|i| lambda * i as f64 / per as f64).collect();
    let f: Vec<f64> = d.iter().map(|x| c + a * (2.0 * PI * x / lambda).sin()).collect();
    let curve = ForceDisplacement {
        displacement: d,
        force: f,
    };
    let r = crush_force(
        &curve,
        Window {
            s0: 0.0,
            s1: lambda * periods as f64,
        },
    )
    .unwrap();
    assert!(rel(r.mean_force, c) < 1e-9, "{}", r.mean_force);
    assert!(rel(r.energy, c * lambda * periods as f64) < 1e-9);
    assert!(rel(r.peak_force, c + a) < 1e-12);
}

#[test]
fn triangle_is_exact_and_window_ends_are_interpolated() {
    // 0 -> 20 kN at 10 mm -> 0 at 20 mm.
    let curve = ForceDisplacement {
        displacement: vec![0.0, 10.0, 20.0],
        force: vec![0.0, 20.0, 0.0],
    };
    let full = crush_force(&curve, Window { s0: 0.0, s1: 20.0 }).unwrap();
    assert_eq!(full.energy, 200.0);
    assert_eq!(full.mean_force, 10.0);
    assert_eq!(full.peak_force, 20.0);
    assert_eq!(full.peak_at, 10.0);
    // Window [5, 15]: F(5) = 10, F(15) = 10; energy = 2 * (10+20)/2 * 5 = 150; mean 15.
    let w = crush_force(&curve, Window { s0: 5.0, s1: 15.0 }).unwrap();
    assert!(rel(w.energy, 150.0) < 1e-12 && rel(w.mean_force, 15.0) < 1e-12);
    // Window inside one segment: [2, 4]: F = 2x -> mean 6.
    let w = crush_force(&curve, Window { s0: 2.0, s1: 4.0 }).unwrap();
    assert!(rel(w.mean_force, 6.0) < 1e-12);
    assert_eq!(w.stroke, 2.0);
    assert!(rel(w.peak_force, 8.0) < 1e-12 && w.peak_at == 4.0);
}

#[test]
fn window_errors() {
    let curve = ForceDisplacement {
        displacement: vec![0.0, 10.0],
        force: vec![1.0, 1.0],
    };
    for (s0, s1) in [(0.0, 11.0), (-1.0, 5.0), (5.0, 5.0), (6.0, 2.0), (f64::NAN, 1.0)] {
        assert!(
            matches!(crush_force(&curve, Window { s0, s1 }), Err(CrushError::Data { .. })),
            "{s0} {s1}"
        );
    }
    let bad = ForceDisplacement {
        displacement: vec![0.0, 1.0, 2.0],
        force: vec![1.0, f64::NAN, 1.0],
    };
    assert!(crush_force(&bad, Window { s0: 0.0, s1: 2.0 }).is_err());
}

#[test]
fn rebound_counts_with_its_sign_and_the_first_crossing_ends_the_window() {
    // Goes to 10, back to 6, then to 14; window [0, 12] with F = 1 everywhere: the path integral is 12.
    let curve = ForceDisplacement {
        displacement: vec![0.0, 10.0, 6.0, 14.0],
        force: vec![1.0; 4],
    };
    let r = crush_force(&curve, Window { s0: 0.0, s1: 12.0 }).unwrap();
    assert!(rel(r.energy, 12.0) < 1e-12);
}

#[test]
fn time_synchronisation_interpolates_onto_common_times() {
    // Force F(t) = 100 t on t = 0, 0.01, ..., 1; striker at v = 2 on another grid, from t = 0.05.
    let tf: Vec<f64> = (0..=100).map(|i| i as f64 * 0.01).collect();
    let f: Vec<f64> = tf.iter().map(|t| -100.0 * t).collect(); // compressive force negative in the solver
    let td: Vec<f64> = (0..=70).map(|i| 0.05 + i as f64 * 0.013).collect();
    let d: Vec<f64> = td.iter().map(|t| -2.0 * t).collect(); // striker moves along -z
    let c = from_histories(&tf, &f, &td, &d, Sign::Auto, Sign::Auto).unwrap();
    // Overlap [0.05, 0.96]; union of grids; F = 50 d exactly (both linear).
    assert!(c.displacement.windows(2).all(|w| w[1] > w[0]));
    assert!(rel(c.displacement[0], 0.1) < 1e-12);
    assert!(rel(*c.displacement.last().unwrap(), 1.92) < 1e-12);
    for (x, y) in c.displacement.iter().zip(&c.force) {
        assert!((y - 50.0 * x).abs() < 1e-9, "{x} {y}");
    }
    // Mean of F = 50 d over [0.5, 1.5] = 50.
    let r = crush_force(&c, Window { s0: 0.5, s1: 1.5 }).unwrap();
    assert!(rel(r.mean_force, 50.0) < 1e-9);
    // Explicit signs give the negative curve.
    let c2 = from_histories(&tf, &f, &td, &d, Sign::Plus, Sign::Plus).unwrap();
    assert!(c2.displacement[1] < 0.0 && c2.force[1] < 0.0);
    // No overlap, non-increasing times.
    assert!(
        from_histories(
            &[0.0, 1.0],
            &[1.0, 1.0],
            &[2.0, 3.0],
            &[0.0, 1.0],
            Sign::Auto,
            Sign::Auto
        )
        .is_err()
    );
    assert!(
        from_histories(
            &[0.0, 0.0],
            &[1.0, 1.0],
            &[0.0, 1.0],
            &[0.0, 1.0],
            Sign::Auto,
            Sign::Auto
        )
        .is_err()
    );
}

#[test]
fn from_the_lsdyna_samples() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/format-samples");
    let r = rcforc::read(&dir.join("rcforc_master_slave")).unwrap();
    let n = nodout::read(&dir.join("nodout")).unwrap();
    let src = SimSource {
        interface: 1,
        side: Side::SurfB,
        force_axis: 2,
        force_sign: Sign::Minus,
        force_to_kn: 1.0,
        node: 1001,
        disp_axis: 2,
        disp_sign: Sign::Minus,
        disp_to_mm: 1.0,
        rigid_wall: None,
    };
    let c = from_lsdyna(&r, &n, &src).unwrap();
    assert_eq!(c.displacement, vec![0.0, 1.0, 2.0]);
    assert_eq!(c.force, vec![0.0, 123.456, 246.912]);
    let res = crush_force(&c, Window { s0: 0.0, s1: 2.0 }).unwrap();
    assert!(rel(res.energy, 246.912) < 1e-12);
    let missing = SimSource {
        interface: 9,
        ..src.clone()
    };
    assert!(
        from_lsdyna(&r, &n, &missing)
            .unwrap_err()
            .to_string()
            .contains("interface 9")
    );
}

#[test]
fn test_machine_csv_in_kn_and_in_n_give_the_same_curve() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/format-samples");
    let kn = read_test_csv(&dir.join("test_machine_kN.csv"), CsvOptions::default()).unwrap();
    let n = read_test_csv(&dir.join("test_machine_N.csv"), CsvOptions::default()).unwrap();
    assert_eq!(kn, n);
    assert_eq!(kn.force, vec![0.0, 10.0, 20.0, 10.0, 0.0]);
    let r = crush_force(&kn, Window { s0: 0.0, s1: 4.0 }).unwrap();
    assert_eq!(r.mean_force, 10.0);
}

#[test]
fn csv_without_header_needs_a_unit_setting() {
    let f = Path::new("machine.csv");
    let text = "0 0\n1 1000\n2 2000\n";
    let e = parse_test_csv(f, text, CsvOptions::default()).unwrap_err().to_string();
    assert!(e.contains("force unit"), "{e}");
    let c = parse_test_csv(
        f,
        text,
        CsvOptions {
            force_unit: Some(ForceUnit::Newton),
        },
    )
    .unwrap();
    assert_eq!(c.force, vec![0.0, 1.0, 2.0]);
    // Header and setting disagree.
    let e = parse_test_csv(
        f,
        "disp [mm],force [kN]\n0,1\n1,2\n",
        CsvOptions {
            force_unit: Some(ForceUnit::Newton),
        },
    );
    assert!(e.is_err());
    // Displacement in metres is converted to mm.
    let c = parse_test_csv(f, "disp [m],force [kN]\n0,1\n0.001,2\n", CsvOptions::default()).unwrap();
    assert_eq!(c.displacement, vec![0.0, 1.0]);
}

#[test]
fn csv_errors_name_the_line() {
    let f = Path::new("machine.csv");
    let e = parse_test_csv(f, "displacement,force [kN]\n0,1\n1,x\n", CsvOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("machine.csv:3:"), "{e}");
    let e = parse_test_csv(f, "displacement,force [kN]\n0,1\n1\n", CsvOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("machine.csv:3:"), "{e}");
    let e = parse_test_csv(f, "time,temperature\n0,1\n", CsvOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("machine.csv:1:"), "{e}");
    let e = parse_test_csv(f, "disp,force [lbf]\n0,1\n1,2\n", CsvOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("lbf"), "{e}");
}
