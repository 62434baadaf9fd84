//! Record and replay of runs, so a solver study can be rerun where no solver is installed.
//!
//! ```text
//! DIR/<key>/manifest.json   what made the recording (below)
//! DIR/<key>/<output>...     the run's declared outputs (Adapter::outputs), as the solver wrote them
//! ```
//!
//! Other entries of DIR (a README, test data) are ignored. `--record DIR` copies every finished
//! run of the plan that DIR does not hold yet. `--replay DIR` judges each unfinished run's
//! recording with the study's adapter, exactly as after a live run (same code, same bytes, so the
//! same response to the bit), and commits the record to the run store; no solver is started.
//!
//! A planned run without a recording is a *miss*. Its explanation looks for a recording with the
//! same design and parameters and compares the inputs: which input file's hash differs, and for
//! text inputs kept in the manifest the first differing line, recorded and now.

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};

use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

use super::store::write_atomic;

/// Manifest file name inside a recording.
pub const MANIFEST: &str = "manifest.json";
/// Text inputs up to this size are kept whole in the manifest, so a miss can show the changed line.
const KEEP_TEXT: usize = 64 * 1024;

/// What made a recording.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    pub key: String,
    pub design: String,
    /// `sample` or `check`.
    pub role: String,
    pub parameters: IndexMap<String, f64>,
    pub command: Vec<String>,
    pub adapter: String,
    /// Every rendered input by path: its BLAKE3 hash and, when small text, the text.
    pub inputs: BTreeMap<String, InputDigest>,
    /// Files referenced by the inputs but shared between runs (the design's mesh), by name.
    #[serde(default)]
    pub shared: BTreeMap<String, String>,
    /// The recorded output files.
    pub outputs: Vec<String>,
    /// How the recorded run failed, for the recording of a run that failed (absent: it succeeded).
    /// A replay commits this outcome as it is, so that it plans around the failure as the live
    /// sequence did; a recording without it that fails to be read is damaged.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub outcome: Option<super::Outcome>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InputDigest {
    pub blake3: String,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub text: Option<String>,
}

impl InputDigest {
    pub fn of(bytes: &[u8]) -> Self {
        let text = (bytes.len() <= KEEP_TEXT)
            .then(|| String::from_utf8(bytes.to_vec()).ok())
            .flatten();
        InputDigest {
            blake3: blake3::hash(bytes).to_hex().to_string(),
            text,
        }
    }
}

/// The recording of `key` in `dir`, if it has a manifest.
pub fn find(dir: &Path, key: &str) -> Option<PathBuf> {
    let at = dir.join(key);
    at.join(MANIFEST).is_file().then_some(at)
}

/// Copies `outputs` of the finished run in `run_dir` into `dir/<key>/` with its manifest. The
/// manifest is written last (atomically), so a recording without one is incomplete and ignored.
pub fn record(dir: &Path, run_dir: &Path, manifest: &Manifest) -> std::io::Result<()> {
    let at = dir.join(&manifest.key);
    fs::create_dir_all(&at)?;
    // An output the run did not write (glstat of a deck that asks for none) is not recorded.
    let mut manifest = manifest.clone();
    manifest.outputs.retain(|rel| run_dir.join(rel).is_file());
    for rel in &manifest.outputs {
        let from = run_dir.join(rel);
        let to = at.join(rel);
        if let Some(parent) = to.parent() {
            fs::create_dir_all(parent)?;
        }
        fs::copy(&from, &to).map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", from.display())))?;
    }
    let text = serde_json::to_vec_pretty(&manifest).expect("manifests serialize");
    write_atomic(&at.join(MANIFEST), &text)
}

/// The manifest of the recording at `at`, if it has a readable one.
pub fn read_manifest(at: &Path) -> Option<Manifest> {
    serde_json::from_slice(&fs::read(at.join(MANIFEST)).ok()?).ok()
}

/// A recording of a run that succeeded, which this replay could not read as a finished run: the
/// file is damaged (cut short, lines lost, bytes written over), or it is read with other settings
/// than it was recorded with.
#[derive(Debug, Clone, PartialEq)]
pub struct Damaged {
    pub key: String,
    /// The recording's directory.
    pub at: PathBuf,
    pub design: String,
    pub parameters: IndexMap<String, f64>,
    /// How it was judged, naming the file and line where the adapter says.
    pub outcome: super::Outcome,
}

impl Damaged {
    /// `recording DIR/KEY (design `C3T7`, sigma_y = 152.0): rcforc:380:1: missing …`
    pub fn words(&self) -> String {
        let params: Vec<String> = self.parameters.iter().map(|(k, v)| format!("{k} = {v}")).collect();
        format!(
            "recording {} (design `{}`, {}): {}",
            self.at.display(),
            self.design,
            params.join(", "),
            self.outcome
        )
    }
}

/// Every readable manifest in `dir`.
pub fn manifests(dir: &Path) -> Vec<Manifest> {
    let Ok(entries) = fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut out: Vec<Manifest> = entries
        .filter_map(|e| e.ok())
        .filter_map(|e| fs::read(e.path().join(MANIFEST)).ok())
        .filter_map(|b| serde_json::from_slice(&b).ok())
        .collect();
    out.sort_by(|a, b| a.key.cmp(&b.key));
    out
}

/// Why the run `wanted` has no recording in `dir`: the closest recording (same design and
/// parameters, else same design) and what differs in its inputs.
pub fn explain_miss(dir: &Path, wanted: &Manifest, recorded: &[Manifest]) -> String {
    let params: Vec<String> = wanted.parameters.iter().map(|(k, v)| format!("{k} = {v}")).collect();
    let mut text = format!(
        "run of design `{}` ({} run, {}) has no recording in {} (key {})",
        wanted.design,
        wanted.role,
        params.join(", "),
        dir.display(),
        wanted.key
    );
    if recorded.is_empty() {
        text.push_str(&format!(
            "; {} holds no recordings at all (make them with `lab run STUDY --record {}` where the solver is installed)",
            dir.display(),
            dir.display()
        ));
        return text;
    }
    let same_point = recorded
        .iter()
        .find(|m| m.design == wanted.design && m.parameters == wanted.parameters);
    let same_design = recorded.iter().find(|m| m.design == wanted.design);
    let Some(m) = same_point.or(same_design) else {
        text.push_str(&format!("; no recording has design `{}`", wanted.design));
        return text;
    };
    if same_point.is_some() {
        text.push_str(&format!(
            "; recording {} has the same design and parameters but ",
            m.key
        ));
    } else {
        let p: Vec<String> = m.parameters.iter().map(|(k, v)| format!("{k} = {v}")).collect();
        text.push_str(&format!(
            "; no recording has these parameters (the sampling plan changed?); recording {} of the same design ({}) ",
            m.key,
            p.join(", ")
        ));
    }
    text.push_str(&differences(m, wanted).join("; "));
    text
}

/// What differs between a recording's inputs and a run's.
pub fn differences(recorded: &Manifest, now: &Manifest) -> Vec<String> {
    let mut out = Vec::new();
    if recorded.command != now.command {
        out.push(format!(
            "the command changed: recorded {:?}, now {:?}",
            recorded.command, now.command
        ));
    }
    if recorded.adapter != now.adapter {
        out.push(format!(
            "the adapter settings changed: recorded `{}`, now `{}`",
            recorded.adapter, now.adapter
        ));
    }
    for (name, was) in &recorded.shared {
        match now.shared.get(name) {
            Some(is) if is != was => out.push(format!(
                "shared file {name} changed (hash {} → {})",
                short(was),
                short(is)
            )),
            None => out.push(format!("shared file {name} is no longer used")),
            _ => {}
        }
    }
    for (path, d) in &now.inputs {
        match recorded.inputs.get(path) {
            None => out.push(format!("input {path} is new")),
            Some(r) if r.blake3 != d.blake3 => out.push(changed_input(path, r, d)),
            _ => {}
        }
    }
    for path in recorded.inputs.keys().filter(|p| !now.inputs.contains_key(*p)) {
        out.push(format!("input {path} is no longer rendered"));
    }
    if out.is_empty() {
        out.push("differs in no recorded input (the recording's key was made differently)".into());
    }
    out
}

fn short(hash: &str) -> &str {
    &hash[..hash.len().min(12)]
}

fn changed_input(path: &str, recorded: &InputDigest, now: &InputDigest) -> String {
    let head = format!(
        "input {path} changed (hash {} → {})",
        short(&recorded.blake3),
        short(&now.blake3)
    );
    let (Some(a), Some(b)) = (&recorded.text, &now.text) else {
        return head;
    };
    let (la, lb): (Vec<&str>, Vec<&str>) = (a.lines().collect(), b.lines().collect());
    let n = la.len().max(lb.len());
    let Some(i) = (0..n).find(|&i| la.get(i) != lb.get(i)) else {
        return head;
    };
    let changed = (i..n).filter(|&k| la.get(k) != lb.get(k)).count();
    let show = |l: Option<&&str>| l.map_or("(none)".to_string(), |s| format!("`{}`", s.trim_end()));
    format!(
        "{head}: first at line {}: recorded {}, now {}{}",
        i + 1,
        show(la.get(i)),
        show(lb.get(i)),
        if changed > 1 {
            format!(" ({changed} lines differ)")
        } else {
            String::new()
        }
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn manifest(key: &str, sigma: f64, deck: &str) -> Manifest {
        let mut parameters = IndexMap::new();
        parameters.insert("sigma_y".to_string(), sigma);
        let mut inputs = BTreeMap::new();
        inputs.insert("main.k".to_string(), InputDigest::of(deck.as_bytes()));
        Manifest {
            key: key.into(),
            design: "C3T7".into(),
            role: "sample".into(),
            parameters,
            command: vec!["crushsim".into()],
            adapter: "lsdyna/1".into(),
            inputs,
            shared: BTreeMap::new(),
            outputs: vec![],
            outcome: None,
        }
    }

    #[test]
    fn a_miss_names_the_run_and_the_changed_line() {
        let old = manifest("aaa", 150.0, "*KEYWORD\nR SIGY 150.0\n*END\n");
        let new = manifest("bbb", 150.0, "*KEYWORD\nR SIGY 150.0\n$ new comment\n*END\n");
        let why = explain_miss(Path::new("rec"), &new, &[old]);
        assert!(why.contains("design `C3T7`") && why.contains("sigma_y = 150"), "{why}");
        assert!(why.contains("same design and parameters"), "{why}");
        assert!(why.contains("input main.k changed") && why.contains("line 3"), "{why}");
        assert!(why.contains("`$ new comment`"), "{why}");
    }

    #[test]
    fn record_then_find() {
        let run = tempfile::tempdir().unwrap();
        let rec = tempfile::tempdir().unwrap();
        fs::write(run.path().join("out"), "1").unwrap();
        let mut m = manifest("k1", 1.0, "x");
        m.outputs = vec!["out".into()];
        record(rec.path(), run.path(), &m).unwrap();
        let found = find(rec.path(), "k1").unwrap();
        assert_eq!(fs::read_to_string(found.join("out")).unwrap(), "1");
        assert_eq!(manifests(rec.path()), vec![m]);
        assert!(find(rec.path(), "k2").is_none());
    }
}
