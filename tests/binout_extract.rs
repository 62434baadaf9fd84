//! binout beside the ASCII files: the d3hsp facts of the real logs, crushsim's binout judged as
//! its ASCII files are (same curve, same figures, same completeness checks, now naming the step
//! and offset), and `lab extract` on a binout or a run directory.

use crate::crushsim_bin;

use std::path::PathBuf;
use std::process::Command;

use lab::execute::{Adapter, Outcome};
use lab::extract::adapters::LsDynaAdapter;
use lab::extract::crush::{SimSource, Window};
use lab::extract::lsdyna::binout::{self, histories};
use lab::extract::lsdyna::d3hsp;
use lab::extract::lsdyna::termination::Termination;
use lab::extract::lsdyna::{glstat, nodout, rcforc};
use lab::render::lsdyna;
use lab::render::mesh::{self, TubeSpec};

const LAB: &str = env!("CARGO_BIN_EXE_lab");

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn the_real_d3hsp_logs_give_their_termination_and_timing() {
    // (version, termination date, problem time, cycle, CPU s, clock total s, elapsed s, cycles)
    let cases = [
        ("R7_1_2", "08/31/25 16:53:38", 3.5024e-2, 576, 1.0, 1.273, 0.0, 576),
        ("R9_3_1", "08/31/25 16:54:00", 3.5024e-2, 576, 1.0, 1.251, 0.0, 576),
        ("R12_2_1", "08/31/25 16:54:33", 3.5031e-2, 640, 1.0, 1.298, 0.0, 640),
    ];
    for (v, date, time, cycle, cpu, clock, elapsed, cycles) in cases {
        let s = d3hsp::read(&root().join(format!("fixtures/lsdyna-real/{v}/d3hsp"))).unwrap();
        assert_eq!(s.termination, Termination::Normal(date.into()), "{v}");
        assert_eq!(s.problem_time, Some(time), "{v}");
        assert_eq!(s.problem_cycle, Some(cycle), "{v}");
        assert_eq!(s.cpu_seconds, Some(cpu), "{v}");
        assert_eq!(s.clock_seconds, Some(clock), "{v}");
        assert_eq!(
            (s.elapsed_seconds, s.elapsed_cycles),
            (Some(elapsed), Some(cycles)),
            "{v}"
        );
    }
    let cut = d3hsp::parse(" Problem time       =    1.0E-02\n Problem cycle      =        12\n");
    assert_eq!(
        (cut.termination, cut.problem_cycle, cut.elapsed_seconds),
        (Termination::Missing, Some(12), None)
    );
}

fn adapter() -> LsDynaAdapter {
    LsDynaAdapter {
        window: Window { s0: 5.0, s1: 60.0 },
        source: SimSource::honeycomb_striker(),
        deck: "main.k".into(),
    }
}

/// crushsim on the honeycomb deck (C6T5, 185 MPa) with BINARY = `binary` and a test switch.
fn live(binary: u8, switch: Option<(&str, f64)>) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let mut tera = tera::Tera::new();
    lsdyna::register(&mut tera);
    tera.add_raw_template("main.k.tera", include_str!("../templates/honeycomb/main.k.tera"))
        .unwrap();
    let mut ctx = tera::Context::new();
    for (k, v) in [
        ("c", 6.0),
        ("t", 0.05),
        ("sigma_y", 185.0),
        ("term_time", 0.061),
        ("dt_out", 0.0005),
    ] {
        ctx.insert(k, &v);
    }
    ctx.insert("design_name", "C6T5");
    ctx.insert("ribbon_factor", &2);
    ctx.insert("binary", &binary);
    if let Some((mode, value)) = switch {
        ctx.insert("crushsim_test", mode);
        ctx.insert("crushsim_test_value", &value);
    }
    std::fs::write(dir.path().join("main.k"), tera.render("main.k.tera", &ctx).unwrap()).unwrap();
    let (include, _) = mesh::include(&TubeSpec::paper(6.0, 2.0)).unwrap();
    std::fs::write(dir.path().join("mesh.k"), include).unwrap();
    let o = Command::new(crushsim_bin::crushsim())
        .args(["i=main.k", "ncpu=1"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    dir
}

/// Equal within what 6 significant ASCII digits keep of a float32.
fn same(a: &[f64], b: &[f64], what: &str) {
    assert_eq!(a.len(), b.len(), "{what}");
    let scale = a.iter().chain(b).fold(0.0f64, |m, v| m.max(v.abs()));
    for (k, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            (x - y).abs() <= 6e-6 * x.abs().max(y.abs()) + 1e-12 * scale,
            "{what}[{k}]: ASCII {x}, binout {y}"
        );
    }
}

#[test]
fn binout_and_ascii_of_one_run_give_the_same_histories_curve_and_figures() {
    let run = live(3, None);
    let dir = run.path();
    let b = binout::open_dir(dir).unwrap().unwrap();
    let rc_a = rcforc::read(&dir.join("rcforc")).unwrap();
    let rc_b = histories::rcforc(&b).unwrap().unwrap();
    assert_eq!(
        rc_a.interfaces.keys().collect::<Vec<_>>(),
        rc_b.interfaces.keys().collect::<Vec<_>>()
    );
    for (k, s) in &rc_a.interfaces {
        let t = &rc_b.interfaces[k];
        for (name, x, y) in [
            ("time", &s.time, &t.time),
            ("x", &s.x, &t.x),
            ("y", &s.y, &t.y),
            ("z", &s.z, &t.z),
            ("mass", &s.mass, &t.mass),
        ] {
            same(x, y, &format!("rcforc {k:?} {name}"));
        }
    }
    let nod_a = nodout::read(&dir.join("nodout")).unwrap();
    let nod_b = histories::nodout(&b).unwrap().unwrap();
    for (id, s) in &nod_a.nodes {
        let t = &nod_b.nodes[id];
        for a in 0..3 {
            same(&s.disp[a], &t.disp[a], &format!("nodout {id} disp {a}"));
            same(&s.coor[a], &t.coor[a], &format!("nodout {id} coor {a}"));
        }
    }
    let gl_a = glstat::read(&dir.join("glstat")).unwrap();
    let gl_b = histories::glstat(&b).unwrap().unwrap();
    for label in [
        "kinetic energy",
        "internal energy",
        "total energy",
        "external work",
        "hourglass energy",
    ] {
        same(&gl_a.series(label).unwrap(), &gl_b.series(label).unwrap(), label);
    }
    // The adapter, from binout (BINARY 3: the deck sends the histories there) and from the ASCII
    // files alone (the same run with its binout removed).
    let from_binout = adapter().judge(dir).unwrap();
    let ascii = tempfile::tempdir().unwrap();
    for f in ["main.k", "messag", "d3hsp", "rcforc", "nodout", "glstat"] {
        std::fs::copy(dir.join(f), ascii.path().join(f)).unwrap();
    }
    let from_ascii = adapter().judge(ascii.path()).unwrap();
    let (fa, fb) = (from_ascii.response, from_binout.response);
    assert!(
        (fa - fb).abs() <= 1e-5 * fa,
        "mean crush force {fa} (ASCII) vs {fb} (binout)"
    );
    let (qa, qb) = (from_ascii.quality.unwrap(), from_binout.quality.unwrap());
    assert!(
        (qa.energy_error.unwrap() - qb.energy_error.unwrap()).abs() < 1e-5,
        "{qa:?} {qb:?}"
    );
    assert_eq!(qa.hourglass_ratio, qb.hourglass_ratio);
    // And with the ASCII files removed, the binout is read (the files are absent).
    for f in ["rcforc", "nodout", "glstat"] {
        std::fs::remove_file(dir.join(f)).unwrap();
    }
    assert_eq!(adapter().judge(dir).unwrap(), from_binout);
}

#[track_caller]
fn incomplete(r: Result<lab::execute::Judged, Outcome>) -> String {
    match r {
        Err(o @ Outcome::IncompleteOutput { .. }) => o.to_string(),
        other => panic!("expected an incomplete output, got {other:?}"),
    }
}

#[test]
fn binout_histories_with_defects_are_incomplete_at_their_step_and_offset() {
    // A gap (the middle output, number 61 from 0, left out of every history: the step after it,
    // d000062, is where the jump shows) and an early end.
    let gap = incomplete(adapter().judge(live(2, Some(("gap", 0.0))).path()));
    assert!(
        gap.starts_with("incomplete output: binout: rcforc /rcforc/d000062 (offset "),
        "{gap}"
    );
    assert!(gap.contains("gap in the history"), "{gap}");
    let early = incomplete(adapter().judge(live(2, Some(("early", 0.5))).path()));
    assert!(
        early.contains("short of the termination time") && early.contains("offset "),
        "{early}"
    );
    // An unpaired rcforc entry: the middle step's arrays one entry short.
    let unpaired = live(2, Some(("unpaired", 0.0)));
    match adapter().judge(unpaired.path()) {
        Err(Outcome::BadResponse { detail, .. }) => {
            assert!(detail.contains("offset ") && detail.contains("expected 6"), "{detail}")
        }
        other => panic!("{other:?}"),
    }
    // No binout though the deck sends the histories there.
    let run = live(2, None);
    std::fs::remove_file(run.path().join("binout")).unwrap();
    match adapter().judge(run.path()) {
        Err(Outcome::BadResponse { detail, .. }) => assert!(detail.contains("binout was not written"), "{detail}"),
        other => panic!("{other:?}"),
    }
}

fn lab(args: &[&str]) -> (Option<i32>, String, String) {
    let o = Command::new(LAB).args(args).output().unwrap();
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stdout).into(),
        String::from_utf8_lossy(&o.stderr).into(),
    )
}

#[test]
fn lab_extract_lists_prints_series_and_the_mean_force_of_a_binout() {
    let real = root().join("fixtures/lsdyna-real/R12_2_1/binout");
    let real = real.to_str().unwrap();
    let (code, list, _) = lab(&["extract", real, "--list"]);
    assert_eq!(code, Some(0));
    for line in [
        "rwforc/forces: 88 output steps",
        "  rwforc/forces/normal_force",
        "  glstat/version ",
        "\"smp s R12\"",
    ] {
        assert!(list.contains(line), "{line} not in:\n{list}");
    }
    let (code, json, _) = lab(&["extract", real, "--series", "rwforc/forces/normal_force", "--json"]);
    assert_eq!(code, Some(0));
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let values: Vec<f64> = v["values"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert_eq!(v["time"].as_array().unwrap().len(), 88);
    // lasso-python-reads.txt: sum 173.0030379295349 (float32 values summed in float64, in order).
    assert_eq!(values.iter().sum::<f64>(), 173.0030379295349);
    let (_, summary, _) = lab(&["extract", real]);
    assert!(
        summary.starts_with("rwforc rigid wall 1 normal force: peak 137.57"),
        "{summary}"
    );

    let run = live(2, None);
    let dir = run.path().to_str().unwrap();
    let (code, text, _) = lab(&["extract", dir]);
    assert_eq!(code, Some(0), "{text}");
    let mean: f64 = text
        .strip_prefix("mean crush force ")
        .unwrap()
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    let judged = adapter().judge(run.path()).unwrap().response;
    assert!(
        (mean * 1e-3 - judged).abs() <= 1e-12 * judged,
        "{mean} N vs {judged} kN"
    );
    let (_, json, _) = lab(&[
        "extract",
        &format!("{dir}/binout"),
        "--series",
        "rcforc/z_force",
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["values"].as_array().unwrap().len(), 6, "one list per entry");
    assert_eq!(v["ids"], serde_json::json!([1.0, 1.0, 2.0, 2.0, 3.0, 3.0]));

    // Bad requests: exit 2 with the file named.
    let (code, _, err) = lab(&["extract", real, "--series", "rwforc/forces/nothing"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("binout") && err.contains("nothing"), "{err}");
    let csv = root().join("fixtures/honeycomb/tests/C6T5-1.csv");
    let (code, _, err) = lab(&["extract", csv.to_str().unwrap(), "--list"]);
    assert_eq!(code, Some(2), "{err}");
    // A cut binout: read up to its last whole record, with a note naming the offset.
    let cut = tempfile::tempdir().unwrap();
    let bytes = std::fs::read(run.path().join("binout")).unwrap();
    std::fs::write(cut.path().join("binout"), &bytes[..bytes.len() / 2]).unwrap();
    let (code, text, err) = lab(&[
        "extract",
        cut.path().join("binout").to_str().unwrap(),
        "--series",
        "rcforc/time",
    ]);
    assert_eq!(code, Some(0), "{err}");
    assert!(err.starts_with("note: ") && err.contains("offset "), "{err}");
    assert!(text.lines().count() > 10, "{text}");
}

/// A run directory whose deck sends rwforc and nodout to binout, with rigid wall 3's normal force
/// F = 1000 + 10 d (N) against the striker node 7's stroke d = 0, 10, …, 100 mm (z, downwards).
fn rigid_wall_run(steps: usize) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let deck = "*KEYWORD\n*CONTROL_TERMINATION\n      0.01\n*DATABASE_RWFORC\n     0.001         2\n\
                *DATABASE_NODOUT\n     0.001         2\n*DATABASE_HISTORY_NODE\n         7\n*END\n";
    std::fs::write(dir.path().join("main.k"), deck).unwrap();
    std::fs::write(
        dir.path().join("messag"),
        " N o r m a l    t e r m i n a t i o n   01/01/26\n",
    )
    .unwrap();
    let mut w = lsda::Writer::new(lsda::Header::default());
    w.cd("/rwforc/forces/metadata");
    w.write("ids", &lsda::Values::I4(vec![3])).unwrap();
    w.cd("/nodout/metadata");
    w.write("ids", &lsda::Values::I4(vec![7])).unwrap();
    for k in 0..steps {
        let (t, d) = (k as f32 * 0.001, k as f32 * 10.0);
        w.cd(&format!("/rwforc/forces/d{:06}", k + 1));
        w.write("time", &lsda::Values::R4(vec![t])).unwrap();
        w.write("normal_force", &lsda::Values::R4(vec![1000.0 + 10.0 * d]))
            .unwrap();
        for axis in ["x", "y", "z"] {
            w.write(&format!("{axis}_force"), &lsda::Values::R4(vec![0.0])).unwrap();
        }
        w.cd(&format!("/nodout/d{:06}", k + 1));
        w.write("time", &lsda::Values::R4(vec![t])).unwrap();
        for name in ["displacement", "velocity", "acceleration", "coordinate"] {
            for axis in ["x", "y", "z"] {
                let v = if name == "displacement" && axis == "z" { -d } else { 0.0 };
                w.write(&format!("{axis}_{name}"), &lsda::Values::R4(vec![v])).unwrap();
            }
        }
        w.flush().unwrap();
    }
    w.save(&dir.path().join("binout")).unwrap();
    dir
}

#[test]
fn a_rigid_wall_is_a_response_source() {
    let mut a = adapter();
    a.source = SimSource {
        rigid_wall: Some(3),
        node: 7,
        ..SimSource::honeycomb_striker()
    };
    // Energy / stroke of F = 1000 + 10 d over 5..60 mm: 1000 + 10 × 32.5 = 1325 N (trapezoids are
    // exact on a straight line).
    let judged = a.judge(rigid_wall_run(11).path()).unwrap();
    assert!((judged.response - 1.325).abs() < 1e-12, "{}", judged.response);
    assert_eq!(judged.quality, None);
    assert!(a.identity().ends_with(" rigid_wall 3") && !adapter().identity().contains("rigid_wall"));
    // Short of the termination time: incomplete, at rwforc's last step.
    let short = incomplete(a.judge(rigid_wall_run(7).path()));
    assert!(
        short.contains("rwforc/forces /rwforc/forces/d000007 (offset ")
            && short.contains("short of the termination time"),
        "{short}"
    );
    // A wall the binout does not have.
    a.source.rigid_wall = Some(4);
    match a.judge(rigid_wall_run(11).path()) {
        Err(Outcome::BadResponse { detail, .. }) => assert!(detail.contains("no rigid wall 4 (walls: 3)"), "{detail}"),
        other => panic!("{other:?}"),
    }
}
