//! Outputs you can trust (issue 16): a run is a success only when its histories are complete, and
//! a run that breaks a quality gate is flagged `suspect`.
//!
//! - live: crushsim's test switches (gap, early, unpaired, missnode; hourglass, energy,
//!   addedmass) each break exactly their check, and the gate switches leave the response as it was;
//! - recorded: a fixture recording with each defect cut into it by hand is incomplete at the
//!   right file and line; recordings with raised hourglass, energy drift or added mass are flagged
//!   in results.json and the report, left out of the surrogates unless the study says `use`;
//! - the study keys of `simulation.quality` are checked with file:line errors.

use crate::crushsim_bin;
use crate::fixed_design;

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;

use lab::execute::{Adapter, Outcome};
use lab::extract::adapters::LsDynaAdapter;
use lab::extract::crush::{SimSource, Window};
use lab::extract::lsdyna::quality::Gates;
use lab::render::lsdyna;
use lab::render::mesh::{self, TubeSpec};
use tera::{Context, Tera};

const TEMPLATE: &str = include_str!("../templates/honeycomb/main.k.tera");
const LAB: &str = env!("CARGO_BIN_EXE_lab");

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn adapter() -> LsDynaAdapter {
    LsDynaAdapter {
        window: Window { s0: 5.0, s1: 60.0 },
        source: SimSource::honeycomb_striker(),
        deck: "main.k".into(),
    }
}

/// Renders the honeycomb deck (C6T5, 185 MPa, the study's times) with a crushsim test switch and
/// runs crushsim in a fresh directory.
fn live(switch: Option<(&str, f64)>) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let mut tera = Tera::new();
    lsdyna::register(&mut tera);
    tera.add_raw_template("main.k.tera", TEMPLATE).unwrap();
    let mut ctx = Context::new();
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

/// The incomplete-output outcome's (file, line, detail), or a panic naming what came instead.
#[track_caller]
fn incomplete(r: Result<lab::execute::Judged, Outcome>) -> (String, usize, String) {
    match r {
        Err(Outcome::IncompleteOutput { file, line, detail }) => (file, line, detail),
        other => panic!("expected an incomplete output, got {other:?}"),
    }
}

/// Line `line` (from 1) of file `name` in `dir`.
fn line_of(dir: &Path, name: &str, line: usize) -> String {
    std::fs::read_to_string(dir.join(name))
        .unwrap()
        .lines()
        .nth(line - 1)
        .unwrap()
        .to_string()
}

#[test]
fn live_history_defects_are_incomplete_at_their_file_and_line() {
    let a = adapter();
    // The middle output (number 61 of 0..=122 at 0.5 ms) is left out: the gap ends at 31 ms.
    let gap = live(Some(("gap", 0.0)));
    let (file, line, detail) = incomplete(a.judge(gap.path()));
    assert_eq!(file, "rcforc");
    assert!(
        detail.contains("gap") && detail.contains("about 1 output(s) missing"),
        "{detail}"
    );
    assert!(
        line_of(gap.path(), "rcforc", line).contains("time 3.10000E-02"),
        "line {line}"
    );

    // Histories stop at half the termination time, though the run ends "normally".
    let early = live(Some(("early", 0.5)));
    let (file, line, detail) = incomplete(a.judge(early.path()));
    assert_eq!(file, "rcforc");
    assert!(detail.contains("short of the termination time 6.1e-2"), "{detail}");
    assert!(
        line_of(early.path(), "rcforc", line).contains("time 3.05000E-02"),
        "line {line}"
    );

    // The last interface's master row is missing at the middle output.
    let unpaired = live(Some(("unpaired", 0.0)));
    let (file, line, detail) = incomplete(a.judge(unpaired.path()));
    assert_eq!(file, "rcforc");
    assert!(
        detail.contains("interface 3 has a slave (SURFA) row but no master (SURFB) row"),
        "{detail}"
    );
    assert!(
        line_of(unpaired.path(), "rcforc", line).contains("time 3.05000E-02"),
        "line {line}"
    );

    // nodout's middle block lacks the striker node the deck requests.
    let missing = live(Some(("missnode", 0.0)));
    let (file, line, detail) = incomplete(a.judge(missing.path()));
    assert_eq!(file, "nodout");
    assert!(detail.contains("no row for requested node 9000005"), "{detail}");
    assert!(
        line_of(missing.path(), "nodout", line).contains("at time 3.0500000E-02"),
        "line {line}"
    );
}

#[test]
fn live_gate_breaks_keep_the_response_and_report_their_figures() {
    let a = adapter();
    let clean = a.judge(live(None).path()).unwrap();
    let q = clean.quality.expect("glstat figures");
    assert_eq!(q.hourglass_ratio, Some(0.0));
    assert!(q.energy_error.unwrap().abs() < 1e-4, "{q:?}");
    assert_eq!(q.added_mass_ratio, None, "no mass scaling: not reported");
    assert!(Gates::default().flags(&q).is_empty());
    // Each switch: (mode, value, gate, the figure it sets). glstat's %12.5E values hold 6 digits.
    for (mode, value, gate) in [
        ("hourglass", 0.2, "hourglass"),
        ("energy", 0.1, "energy"),
        ("addedmass", 0.02, "added_mass"),
    ] {
        let j = a.judge(live(Some((mode, value))).path()).unwrap();
        assert_eq!(j.response, clean.response, "{mode}: the force history is untouched");
        let q = j.quality.unwrap();
        let figure = match gate {
            "hourglass" => q.hourglass_ratio,
            "energy" => q.energy_error,
            _ => q.added_mass_ratio,
        }
        .unwrap();
        assert!((figure - value).abs() < 1e-4, "{mode}: {figure}");
        let flags = Gates::default().flags(&q);
        let gates: Vec<&str> = flags.iter().map(|f| f.gate.as_str()).collect();
        assert_eq!(gates, [gate], "{mode}: {flags:?}");
    }
}

/// A copy of one fixture recording, with its rendered deck from the manifest, to cut defects into.
struct Recording {
    dir: tempfile::TempDir,
}

impl Recording {
    fn of(key: &str) -> Recording {
        let from = root().join("fixtures/honeycomb").join(key);
        let dir = tempfile::tempdir().unwrap();
        for f in ["messag", "rcforc", "nodout", "glstat"] {
            std::fs::copy(from.join(f), dir.path().join(f)).unwrap();
        }
        let m = manifest(&from);
        let deck = m["inputs"]["main.k"]["text"].as_str().unwrap();
        std::fs::write(dir.path().join("main.k"), deck).unwrap();
        Recording { dir }
    }

    fn text(&self, name: &str) -> String {
        std::fs::read_to_string(self.dir.path().join(name)).unwrap()
    }

    /// Rewrites `name` keeping the lines (numbered from 1) for which `keep` is true.
    fn keep_lines(&self, name: &str, keep: impl Fn(usize, &str) -> bool) {
        let text: String = self
            .text(name)
            .lines()
            .enumerate()
            .filter(|(i, l)| keep(i + 1, l))
            .map(|(_, l)| format!("{l}\n"))
            .collect();
        std::fs::write(self.dir.path().join(name), text).unwrap();
    }

    /// The 1-based number of the first line of `name` containing `needle` (white space runs
    /// compared as one space).
    fn find(&self, name: &str, needle: &str) -> usize {
        let squash = |s: &str| s.split_whitespace().collect::<Vec<_>>().join(" ");
        let needle = squash(needle);
        let at = self.text(name).lines().position(|l| squash(l).contains(&needle));
        at.unwrap_or_else(|| panic!("`{needle}` not in {name}")) + 1
    }
}

fn manifest(dir: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(dir.join("manifest.json")).unwrap()).unwrap()
}

/// Recording keys of fixtures/honeycomb by (design, role), in key order.
fn recordings(design: &str, role: &str) -> Vec<String> {
    recordings_in(&root().join("fixtures/honeycomb"), design, role)
}

/// The keys of the recordings in `dir` of `design`'s runs with `role`, sorted.
fn recordings_in(dir: &Path, design: &str, role: &str) -> Vec<String> {
    let mut keys: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.path().join("manifest.json").is_file())
        .filter(|e| {
            let m = manifest(&e.path());
            m["design"] == design && m["role"] == role
        })
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    keys.sort();
    keys
}

#[test]
fn recorded_histories_with_each_defect_are_incomplete() {
    let a = adapter();
    let key = &recordings("C3T8", "sample")[0];
    let clean = a.judge(Recording::of(key).dir.path()).unwrap();
    assert!(clean.response > 10.0, "{}", clean.response);

    // One master row deleted: interface 1 at 20 ms is no longer paired.
    let r = Recording::of(key);
    let at = r.find("rcforc", "  master           1 time 2.00000E-02");
    r.keep_lines("rcforc", |i, _| i != at);
    let (file, line, detail) = incomplete(a.judge(r.dir.path()));
    assert_eq!((file.as_str(), line), ("rcforc", at - 1), "{detail}");
    assert!(
        detail.contains("interface 1 has a slave (SURFA) row but no master (SURFB) row"),
        "{detail}"
    );

    // One whole output time (its 6 rows) deleted: a gap, named at the next time's first row.
    let r = Recording::of(key);
    let at = r.find("rcforc", "time 2.00000E-02");
    r.keep_lines("rcforc", |i, _| !(at..at + 6).contains(&i));
    let (file, line, detail) = incomplete(a.judge(r.dir.path()));
    assert_eq!((file.as_str(), line), ("rcforc", at), "{detail}");
    assert!(detail.contains("between times 1.95e-2 and 2.05e-2"), "{detail}");

    // The tail after 50 ms lost: the history ends short of the termination time (61 ms).
    let r = Recording::of(key);
    let at = r.find("rcforc", "time 5.05000E-02");
    r.keep_lines("rcforc", |i, _| i < at);
    let (file, _, detail) = incomplete(a.judge(r.dir.path()));
    assert_eq!(file, "rcforc");
    assert!(
        detail.contains("ends at time 5e-2, short of the termination time 6.1e-2"),
        "{detail}"
    );

    // The last line cut in its last number (it still parses): the missing line break tells.
    let r = Recording::of(key);
    let text = r.text("rcforc");
    std::fs::write(r.dir.path().join("rcforc"), &text[..text.len() - 5]).unwrap(); // `mass  0.0000`
    let (file, line, detail) = incomplete(a.judge(r.dir.path()));
    assert_eq!((file.as_str(), line), ("rcforc", text.lines().count()), "{detail}");

    // A nodout row deleted: its block lacks the requested striker node.
    let r = Recording::of(key);
    let heading = r.find("nodout", "( at time 2.0000000E-02 )");
    r.keep_lines("nodout", |i, _| i != heading + 3);
    let (file, line, detail) = incomplete(a.judge(r.dir.path()));
    assert_eq!((file.as_str(), line), ("nodout", heading), "{detail}");
    assert!(detail.contains("no row for requested node 9000005"), "{detail}");

    // A nodout heading deleted: the next block's rows run into the previous block.
    let r = Recording::of(key);
    let heading = r.find("nodout", "( at time 2.0000000E-02 )");
    r.keep_lines("nodout", |i, _| i != heading);
    let (file, _, detail) = incomplete(a.judge(r.dir.path()));
    assert_eq!(file, "nodout");
    assert!(detail.contains("node 9000005 appears twice"), "{detail}");

    // A glstat line deleted: that step lacks the label.
    let r = Recording::of(key);
    let time = r.find("glstat", "time........................... 3.00000E-02");
    let internal = time
        + r.text("glstat")
            .lines()
            .skip(time)
            .position(|l| l.contains("internal energy"))
            .unwrap()
        + 1;
    r.keep_lines("glstat", |i, _| i != internal);
    let (file, line, detail) = incomplete(a.judge(r.dir.path()));
    assert_eq!((file.as_str(), line), ("glstat", time), "{detail}");
    assert!(detail.contains("no `internal energy` line"), "{detail}");
}

/// Rewrites every glstat value of `label` with `f(step values) -> new value`.
fn edit_glstat(path: &Path, edit: impl Fn(&str, f64, &std::collections::HashMap<String, f64>) -> Option<String>) {
    use std::collections::HashMap;
    let text = std::fs::read_to_string(path).unwrap();
    // First pass: the values of each step, by label.
    let mut steps: Vec<HashMap<String, f64>> = Vec::new();
    for l in text.lines() {
        if let Some((label, value)) = label_value(l) {
            if label == "time" {
                steps.push(HashMap::new());
            }
            if let Some(s) = steps.last_mut() {
                s.insert(label, value);
            }
        }
    }
    let mut out = String::new();
    let mut k = 0usize;
    for l in text.lines() {
        let mut line = l.to_string();
        if let Some((label, value)) = label_value(l) {
            if label == "time" {
                k += 1;
            }
            if let Some(new) = k.checked_sub(1).and_then(|k| edit(&label, value, &steps[k])) {
                line = new;
            }
        }
        out.push_str(&line);
        out.push('\n');
    }
    std::fs::write(path, out).unwrap();
}

fn label_value(line: &str) -> Option<(String, f64)> {
    let (label, value) = line.rsplit_once(' ')?;
    let label = label.trim().trim_end_matches('.').trim();
    Some((label.to_string(), value.trim().parse().ok()?))
}

fn glstat_line(label: &str, v: f64) -> String {
    format!(" {label:.<31} {v:>12.5E}")
}

/// A copy of fixtures/honeycomb in which one sample run of each design breaks one gate:
/// C6T5 hourglass (a fifth of the internal energy moved to hourglass energy, total unchanged:
/// ratio 0.2 / 0.8 = 25 %), C3T7 energy (total raised by 8 % of initial energy + external work
/// after the first step), C3T8 added mass (2 %). Returns (dir, keys).
fn gate_breaking_fixtures() -> (tempfile::TempDir, [String; 3]) {
    let copy = tempfile::tempdir().unwrap();
    let src = fixed_design::recordings();
    for e in std::fs::read_dir(src).unwrap().filter_map(|e| e.ok()) {
        if !e.path().join("manifest.json").is_file() {
            continue;
        }
        let to = copy.path().join(e.file_name());
        std::fs::create_dir(&to).unwrap();
        for f in std::fs::read_dir(e.path()).unwrap().filter_map(|e| e.ok()) {
            std::fs::copy(f.path(), to.join(f.file_name())).unwrap();
        }
    }
    let keys = [
        recordings_in(src, "C6T5", "sample")[0].clone(),
        recordings_in(src, "C3T7", "sample")[0].clone(),
        recordings_in(src, "C3T8", "sample")[0].clone(),
    ];
    edit_glstat(
        &copy.path().join(&keys[0]).join("glstat"),
        |label, v, step| match label {
            "internal energy" => Some(glstat_line(label, 0.8 * v)),
            "hourglass energy" => Some(glstat_line(label, 0.2 * step["internal energy"])),
            _ => None,
        },
    );
    let first_total = std::cell::OnceCell::new();
    edit_glstat(&copy.path().join(&keys[1]).join("glstat"), |label, v, step| {
        if label != "total energy" {
            return None;
        }
        let Some(&initial) = first_total.get() else {
            first_total.set(v).expect("unset"); // the first step's total, left as it is
            return None;
        };
        Some(glstat_line(label, v + 0.08 * (initial + step["external work"])))
    });
    edit_glstat(&copy.path().join(&keys[2]).join("glstat"), |label, v, _| {
        (label == "time per zone cycle.(nanosec)").then(|| {
            format!(
                "{}\n{}\n{}",
                glstat_line(label, v),
                glstat_line("added mass", 1.2e-2),
                glstat_line("percentage increase", 2.0)
            )
        })
    });
    (copy, keys)
}

/// `studies/honeycomb.yaml` with absolute paths and `quality` settings, in `dir`.
/// The fixed-design main job (`fixed_design`) with `quality` lines.
fn study_with(dir: &Path, quality: &str) -> PathBuf {
    fixed_design::study(dir, quality)
}

fn lab_replay(study: &Path, replay: &Path, out: &Path) -> (serde_json::Value, String) {
    let o = Command::new(LAB)
        .args([
            "run",
            study.to_str().unwrap(),
            "--replay",
            replay.to_str().unwrap(),
            "--out",
        ])
        .arg(out)
        .env("PATH", "/usr/bin:/bin")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(0), "{stderr}");
    let r = serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap();
    (r, stderr)
}

fn samples(r: &serde_json::Value, design: &str) -> u64 {
    r["surrogates"][design]["samples"]
        .as_u64()
        .unwrap_or_else(|| panic!("{}", r["surrogates"]))
}

#[test]
fn recorded_gate_breaks_are_flagged_shown_and_left_out_unless_the_study_says_use() {
    let (fixtures, keys) = gate_breaking_fixtures();
    let tmp = tempfile::tempdir().unwrap();
    let study = study_with(tmp.path(), "");
    let out = tmp.path().join("out");
    let (r, stderr) = lab_replay(&study, fixtures.path(), &out);
    let runs = &r["runs"];
    // Every recorded sampled run replays; the three gate-breaking samples are screening runs. Left
    // out, they move the fitted parameters, so the confirmation runs are asked for where nothing
    // was recorded: they fail, named, and the verdict says it is not confirmed there.
    let recorded = fixed_design::keys(fixtures.path()).len() as u64;
    let confirmation = runs["confirmation"].as_u64().unwrap();
    assert_eq!(confirmation, 6, "{runs}");
    assert_eq!(
        (
            runs["succeeded"].as_u64(),
            runs["failed"].as_u64(),
            runs["suspect"].as_u64()
        ),
        (Some(recorded - confirmation), Some(confirmation), Some(3)),
        "{runs}"
    );
    assert!(stderr.contains("6 confirmation run(s) have no recording"), "{stderr}");
    assert!(
        r["diagnosis"]["limits"]
            .to_string()
            .contains("Not confirmed by the solver"),
        "{}",
        r["diagnosis"]["limits"]
    );
    assert_eq!(runs["gates"]["hourglass"], 0.1);
    let suspect = runs["suspect_runs"].as_array().unwrap();
    let by_key = |k: &str| {
        suspect
            .iter()
            .find(|s| s["key"] == k)
            .unwrap_or_else(|| panic!("{k}: {runs}"))
    };
    for (key, gate, figure) in [
        (&keys[0], "hourglass", 0.25),
        (&keys[1], "energy", 0.08),
        (&keys[2], "added_mass", 0.02),
    ] {
        let s = by_key(key);
        assert_eq!(s["used"], false);
        let flags = s["flags"].as_array().unwrap();
        assert_eq!(flags.len(), 1, "{s}");
        assert_eq!(flags[0]["gate"], gate);
        let v = flags[0]["value"].as_f64().unwrap();
        assert!((v - figure).abs() < 1e-4, "{gate}: {v} vs {figure}");
    }
    assert!(
        stderr.contains("3 suspect run(s) left out of the surrogates"),
        "{stderr}"
    );
    for design in ["C6T5", "C3T7", "C3T8"] {
        assert_eq!(
            samples(&r, design),
            fixed_design::SAMPLES - 1,
            "{design}: one sample left out"
        );
    }
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("3 suspect (breaking a quality gate; left out of the surrogates)"));
    assert!(html.contains("<td class=l>suspect</td>") && html.contains("hourglass energy 25.0 % of internal energy"));

    // Lenient gates: nothing is suspect, every sample is used.
    let tmp2 = tempfile::tempdir().unwrap();
    let lenient = "  quality: {hourglass: 0.5, energy: 0.1, added_mass: 0.05}\n";
    let (r, _) = lab_replay(
        &study_with(tmp2.path(), lenient),
        fixtures.path(),
        &tmp2.path().join("out"),
    );
    assert_eq!(r["runs"]["suspect"], 0);
    assert_eq!(samples(&r, "C6T5"), fixed_design::SAMPLES);

    // `suspect: use`: flagged, but fitted.
    let tmp3 = tempfile::tempdir().unwrap();
    let (r, _) = lab_replay(
        &study_with(tmp3.path(), "  quality: {suspect: use}\n"),
        fixtures.path(),
        &tmp3.path().join("out"),
    );
    assert_eq!(r["runs"]["suspect"], 3);
    assert_eq!(r["runs"]["suspect_runs"][0]["used"], true);
    assert_eq!(samples(&r, "C6T5"), fixed_design::SAMPLES);
}

#[test]
fn quality_keys_are_checked_with_file_and_line() {
    let tmp = tempfile::tempdir().unwrap();
    for (quality, phrase, needle) in [
        ("  quality: {hourglass: 1.5}\n", "`quality.hourglass` is 1.5", "1.5"),
        ("  quality: {energy: 0}\n", "`quality.energy` is 0", "0}"),
        (
            "  quality: {suspect: maybe}\n",
            "unknown `quality.suspect: maybe`",
            "maybe",
        ),
    ] {
        let study = study_with(tmp.path(), quality);
        let text = std::fs::read_to_string(&study).unwrap();
        let line = text.lines().position(|l| l.starts_with("  quality:")).unwrap() + 1;
        let err = lab::study::load(&study).unwrap_err();
        let column = common::column_of(&text, line, needle);
        common::assert_located(&err, &study, line, Some(column), phrase);
    }
    // An unknown key, through `lab check`: exit 2 with the file and line.
    let study = study_with(tmp.path(), "  quality: {hourglas: 0.1}\n");
    let o = Command::new(LAB)
        .args(["check", study.to_str().unwrap()])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    let text = std::fs::read_to_string(&study).unwrap();
    let line = text.lines().position(|l| l.starts_with("  quality:")).unwrap() + 1;
    assert!(
        stderr.contains(&format!("honeycomb.yaml:{line}:")) && stderr.contains("hourglas"),
        "{stderr}"
    );
}

/// The main job's `246 → N solver runs`: the fixed design its `sampling.replaces` names, counted
/// from that design's plan without running it, is the number of runs that design made when it ran
/// live (its recordings: samples, checks, the hardening's runs at every sample and the loop's);
/// N is the sequence's own tally. The report says the same.
#[test]
fn the_fixed_design_the_main_job_replaces_is_counted_as_the_runs_it_made() {
    let made = fixed_design::keys(fixed_design::recordings()).len() as u64;
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let o = Command::new(LAB)
        .arg("run")
        .arg(root().join("studies/honeycomb.yaml"))
        .arg("--replay")
        .arg(root().join("fixtures/honeycomb"))
        .arg("--out")
        .arg(&out)
        .env("PATH", "/usr/bin:/bin")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap();
    let replaces = &r["sampling"]["replaces"];
    assert_eq!(replaces["runs"].as_u64(), Some(made), "{replaces}");
    assert_eq!(
        (
            replaces["method"].as_str(),
            replaces["count"].as_u64(),
            replaces["check_runs"].as_u64()
        ),
        (Some("lhs"), Some(24), Some(5))
    );
    let runs = r["sampling"]["runs"].as_u64().unwrap();
    assert!(runs < made, "{runs} sequential runs against {made}");
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains(&format!("{made} → {runs} solver runs")), "{stdout}");
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(
        html.contains(&format!("24 + 5 check runs per design it replaces: {made} runs")),
        "report"
    );
}
