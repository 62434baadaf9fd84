//! Seeded damage to recordings, shared by the corruption experiments of a fixed design
//! (`corruption.rs`) and of a sequential study (`failed_runs.rs`).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use rand::Rng;
use rand_chacha::ChaCha8Rng;

pub const TIME_LIMIT: Duration = Duration::from_secs(120);

pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

pub fn copy_recordings(from: &Path, keys: &[String], to: &Path) {
    for k in keys {
        std::fs::create_dir(to.join(k)).unwrap();
        for f in std::fs::read_dir(from.join(k)).unwrap().filter_map(|e| e.ok()) {
            std::fs::copy(f.path(), to.join(k).join(f.file_name())).unwrap();
        }
    }
}

/// One seeded mutation: what was done, to which file.
pub struct Mutation {
    pub kind: &'static str,
    pub file: &'static str,
    pub what: String,
}

pub fn mutate(rng: &mut ChaCha8Rng, dir: &Path) -> Mutation {
    let roll = rng.random_range(0..6);
    let (kind, file) = match roll {
        0..=2 => ("delete", ["rcforc", "nodout"][rng.random_range(0..2)]),
        3 | 4 => ("truncate", ["rcforc", "nodout", "glstat"][rng.random_range(0..3)]),
        _ => ("garbage", ["rcforc", "nodout", "glstat"][rng.random_range(0..3)]),
    };
    let path = dir.join(file);
    let bytes = std::fs::read(&path).unwrap();
    let (out, what) = match kind {
        "delete" => delete_lines(rng, &bytes),
        "truncate" => {
            let at = rng.random_range(bytes.len() / 10..bytes.len() * 9 / 10);
            (bytes[..at].to_vec(), format!("cut at byte {at} of {}", bytes.len()))
        }
        _ => inject(rng, &bytes),
    };
    std::fs::write(&path, out).unwrap();
    Mutation { kind, file, what }
}

/// Deletes 1–30 lines from the middle 80 % of the file, starting at a line that is not blank.
fn delete_lines(rng: &mut ChaCha8Rng, bytes: &[u8]) -> (Vec<u8>, String) {
    let text = String::from_utf8(bytes.to_vec()).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let n = lines.len();
    let mut start = rng.random_range(n / 10..n * 9 / 10);
    while lines[start].trim().is_empty() {
        start += 1;
    }
    let count = rng.random_range(1..=30).min(n - start);
    let kept: String = lines
        .iter()
        .enumerate()
        .filter(|(i, _)| !(start..start + count).contains(i))
        .map(|(_, l)| format!("{l}\n"))
        .collect();
    (
        kept.into_bytes(),
        format!("deleted lines {}..={}", start + 1, start + count),
    )
}

/// Inserts a garbage line at a line break in the middle 80 % of the file.
fn inject(rng: &mut ChaCha8Rng, bytes: &[u8]) -> (Vec<u8>, String) {
    let breaks: Vec<usize> = (bytes.len() / 10..bytes.len() * 9 / 10)
        .filter(|&i| bytes[i] == b'\n')
        .collect();
    let at = breaks[rng.random_range(0..breaks.len())] + 1;
    let len = rng.random_range(8..80);
    let garbage: Vec<u8> = if rng.random_bool(0.5) {
        (0..len)
            .map(|_| rng.random_range(0..=255u8))
            .filter(|b| *b != b'\n')
            .collect()
    } else {
        const CHARS: &[u8] = b"abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789 .-+E=#*";
        let mut g: Vec<u8> = (0..len).map(|_| CHARS[rng.random_range(0..CHARS.len())]).collect();
        g[0] = b'x'; // not a blank line
        g
    };
    let mut out = bytes[..at].to_vec();
    out.extend_from_slice(&garbage);
    out.push(b'\n');
    out.extend_from_slice(&bytes[at..]);
    (out, format!("{} garbage bytes inserted at byte {at}", garbage.len()))
}

/// `lab run` with a time limit; `None` when it hung and was killed.
pub fn run_lab(study: &Path, copy: &Path, out: &Path) -> Option<(Option<i32>, String)> {
    let mut child = Command::new(env!("CARGO_BIN_EXE_lab"))
        .arg("run")
        .arg(study)
        .arg("--replay")
        .arg(copy)
        .arg("--out")
        .arg(out)
        .current_dir(root())
        .env("PATH", "/usr/bin:/bin")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut stderr = String::new();
            use std::io::Read;
            child.stderr.take().unwrap().read_to_string(&mut stderr).unwrap();
            return Some((status.code(), stderr));
        }
        if started.elapsed() > TIME_LIMIT {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}
