//! Each LS-DYNA reader on its hand-written format sample (fixtures/format-samples), numbers checked exactly.

use lab::extract::lsdyna::rcforc::Side;
use lab::extract::lsdyna::termination::Termination;
use lab::extract::lsdyna::{bndout, glstat, nodout, rcforc, secforc, spcforc, termination};
use std::path::{Path, PathBuf};

fn sample(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/format-samples")
        .join(name)
}

#[test]
fn rcforc_master_slave() {
    let r = rcforc::read(&sample("rcforc_master_slave")).unwrap();
    assert_eq!(r.interfaces.len(), 4);
    let m1 = &r.interfaces[&(Side::SurfB, 1)];
    assert_eq!(m1.time, vec![0.0, 1.0e-3, 2.0e-3]);
    assert_eq!(m1.x, vec![0.0, 1.5, 3.0]);
    assert_eq!(m1.y, vec![0.0, -2.25e-2, -4.5e-2]);
    assert_eq!(m1.z, vec![0.0, -1.23456e2, -2.46912e2]);
    assert_eq!(m1.mass, vec![0.0, 6.0e2, 6.0e2]);
    assert!(m1.moments.is_none());
    let s2 = &r.interfaces[&(Side::SurfA, 2)];
    assert_eq!(s2.z, vec![0.0, 6.1728e1, 1.23456e2]);
    assert!(r.single_surface.is_empty());
}

#[test]
fn rcforc_surfa_surfb_with_moments() {
    let r = rcforc::read(&sample("rcforc_surfa_surfb_moments")).unwrap();
    assert_eq!(r.interfaces.len(), 2);
    let a = &r.interfaces[&(Side::SurfA, 3)];
    let b = &r.interfaces[&(Side::SurfB, 3)];
    assert_eq!(a.z, vec![0.0, 1.23456e2, 2.46912e2]);
    assert_eq!(b.z, vec![0.0, -1.23456e2, -2.46912e2]);
    let m = b.moments.as_ref().unwrap();
    assert_eq!(m[0], vec![0.0, 10.0, 20.0]);
    assert_eq!(m[1], vec![-0.2, -0.2, -0.2]);
    assert_eq!(m[2], vec![0.0, 3.0e-100, 3.0e-100]);
    assert_eq!(r.single_surface, vec![4]);
}

/// Reading one interface side gives that side's series exactly as the whole parse does, and no
/// other side: on both format samples and on a recording of the main job (three interfaces).
#[test]
fn rcforc_one_interface_side_is_the_whole_parse_restricted() {
    let recording = std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/honeycomb"))
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path().join("rcforc")))
        .find(|p| p.is_file())
        .unwrap();
    let mut compared = 0;
    for file in [
        sample("rcforc_master_slave"),
        sample("rcforc_surfa_surfb_moments"),
        recording,
    ] {
        let text = std::fs::read_to_string(&file).unwrap();
        let whole = rcforc::parse(&file, &text).unwrap();
        assert!(whole.interfaces.len() >= 2, "{}", file.display());
        for (&(side, id), series) in &whole.interfaces {
            let one = rcforc::parse_interface(&file, &text, side, id).unwrap();
            assert_eq!(one.interfaces.len(), 1);
            assert_eq!(&one.interfaces[&(side, id)], series, "{} {side:?} {id}", file.display());
            assert_eq!(one.single_surface, whole.single_surface);
            compared += 1;
        }
    }
    assert!(compared >= 12, "{compared} interface sides compared");
}

#[test]
fn glstat_with_legend() {
    let g = glstat::read(&sample("glstat")).unwrap();
    assert_eq!(g.time(), vec![0.0, 1.0e-3]);
    assert_eq!(g.kinetic_energy().unwrap(), vec![3.0e2, 2.9e2]);
    assert_eq!(g.internal_energy().unwrap(), vec![0.0, 9.87654]);
    assert_eq!(g.steps[1].cycle, Some(1021));
    assert_eq!(g.series("energy ratio w/o eroded energy").unwrap(), vec![1.0, 1.0]);
    assert_eq!(g.series("time per zone cycle.(nanosec)").unwrap(), vec![57.0, 57.0]);
    assert_eq!(g.series("stonewall energy wall# 1").unwrap(), vec![0.0, 0.0]);
    assert_eq!(g.series("hourglass energy").unwrap(), vec![1.5e-2, 1.5e-2]);
    assert_eq!(g.series("reached the minimum time step").unwrap(), vec![0.0, 0.0]);
    assert!(g.series("no such label").is_none());
}

#[test]
fn nodout_two_time_formats_glued_and_letterless_exponent() {
    let n = nodout::read(&sample("nodout")).unwrap();
    let s = &n.nodes[&1001];
    assert_eq!(s.time, vec![0.0, 1.0e-3, 2.0e-3]);
    assert_eq!(s.disp[2], vec![0.0, -1.0, -2.0]);
    assert_eq!(s.vel[2], vec![-1.0e3; 3]);
    assert_eq!(s.coor[2], vec![150.0, 149.0, 148.0]);
    let t = &n.nodes[&1002];
    assert_eq!(t.disp[1], vec![-2.5e-4; 3]);
    assert_eq!(t.disp[2], vec![0.0, -0.5, -1.0]);
    assert_eq!(t.accl[0], vec![1.2345e4, 1.2345e4, 1.2345e104]);
    assert_eq!(n.rotations[&1001].rot[0], vec![1.0e-3]);
    assert_eq!(n.rotations[&1001].time, vec![1.0e-3]);
}

#[test]
fn bndout_sample() {
    let b = bndout::read(&sample("bndout")).unwrap();
    assert_eq!(b.steps.len(), 2);
    let s = &b.steps[1];
    assert_eq!(s.time, 1.0e-3);
    assert_eq!(s.entries.len(), 3);
    assert_eq!(s.entries[0].force, [0.0, 0.0, -12.345]);
    assert_eq!(s.entries[0].energy, 6.1725);
    assert_eq!(
        s.entries[0].source,
        "velocity boundary condition forces/rigid body moments"
    );
    assert_eq!(s.entries[2].kind, "mat");
    assert_eq!(s.entries[2].moment, Some([0.0, 1.0, -1.0]));
    assert_eq!(s.totals[0].force, [1.0e-2, 0.0, -49.38]);
    assert_eq!(b.node_force(12).1[1], [1.0e-2, 0.0, -12.345]);
}

#[test]
fn secforc_sample() {
    let s = secforc::read(&sample("secforc")).unwrap();
    assert_eq!(s.sections.len(), 2);
    let a = &s.sections[&1];
    assert_eq!(a.time, vec![0.0, 1.0e-3]);
    assert_eq!(a.force[2], vec![0.0, -40.0]);
    assert_eq!(a.force[0], vec![0.0, 3.0]);
    assert_eq!(a.moment[1], vec![-1.5, -1.5]);
    assert_eq!(a.centroid[2], vec![75.0, 75.0]);
    assert_eq!(a.area, vec![120.0, 120.0]);
    assert_eq!(a.system, "global system");
    assert_eq!(s.sections[&2].system, "rb ID = 7");
}

#[test]
fn spcforc_sample() {
    let s = spcforc::read(&sample("spcforc")).unwrap();
    assert_eq!(s.steps.len(), 2);
    let st = &s.steps[1];
    assert_eq!(st.time, 1.0e-3);
    assert_eq!(st.forces.len(), 2);
    assert_eq!(st.forces[0].value, [0.0, 0.0, 25.0]);
    assert_eq!(st.forces[0].setid, Some(1));
    assert_eq!(st.forces[1].setid, None);
    assert_eq!(st.moments[0].value, [0.0, 0.5, 0.0]);
    assert_eq!(st.resultant, Some([-1.0e-3, 0.0, 50.0]));
}

#[test]
fn termination_lines() {
    assert_eq!(
        termination::read(&sample("d3hsp_normal")).unwrap(),
        Termination::Normal("01/15/26 10:02:11".into())
    );
    assert_eq!(
        termination::read(&sample("messag_error")).unwrap(),
        Termination::Error("01/15/26 10:01:02".into())
    );
    assert_eq!(
        termination::read(&sample("stdout_missing")).unwrap(),
        Termination::Missing
    );
    let missing = sample("no-such-file");
    let s = termination::scan(&[&missing, &sample("stdout_missing"), &sample("d3hsp_normal")]).unwrap();
    assert!(matches!(s, Termination::Normal(_)));
}

#[test]
fn errors_name_file_and_line() {
    let f = Path::new("run/rcforc");
    let text = " t\n ls-dyna (version x) date y\n  master          1 time 1.0E+00  x 1.0 y 2.0\n";
    let e = rcforc::parse(f, text).unwrap_err().to_string();
    assert!(e.starts_with("run/rcforc:3:"), "{e}");
    assert!(e.contains("expected"), "{e}");

    let text = " t\n not the version line\n";
    let e = glstat::parse(Path::new("glstat"), text).unwrap_err().to_string();
    assert!(e.starts_with("glstat:2:") && e.contains("ls-dyna"), "{e}");

    let text = " t\n ls-dyna\n{BEGIN LEGEND}\n 1 a\n";
    let e = nodout::parse(Path::new("nodout"), text).unwrap_err().to_string();
    assert!(e.starts_with("nodout:3:") && e.contains("END LEGEND"), "{e}");

    let text = " t\n ls-dyna\n n o d a l   p r i n t   o u t   f o r   t i m e  s t e p 1 ( at time 1.0E+00 )\n nodal point x-disp\n 7 1.0 2.0\n";
    let e = nodout::parse(Path::new("nodout"), text).unwrap_err().to_string();
    assert!(e.starts_with("nodout:5:") && e.contains("12 numbers"), "{e}");

    let text = " t\n ls-dyna\n output at time = 1.0\n node= 5 local x,y,z forces = 1.0 2.0\n";
    let e = spcforc::parse(Path::new("spcforc"), text).unwrap_err().to_string();
    assert!(e.starts_with("spcforc:4:"), "{e}");

    let text = " t\n ls-dyna\n        1  0.0  1.0 2.0 3.0 4.0\n global system 1 2 3\n";
    let e = secforc::parse(Path::new("secforc"), text).unwrap_err().to_string();
    assert!(e.starts_with("secforc:4:"), "{e}");

    let text = " t\n ls-dyna\n nd#  1 xforce= 1.0\n";
    let e = bndout::parse(Path::new("bndout"), text).unwrap_err().to_string();
    assert!(e.starts_with("bndout:3:"), "{e}");

    let e = rcforc::parse(Path::new("empty"), "").unwrap_err().to_string();
    assert!(e.starts_with("empty:") && e.contains("empty file"), "{e}");
}
