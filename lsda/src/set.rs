//! Which files make one database.
//!
//! - **Continuation files**: when a file grows past the writer's size limit LSTC's `lsda` goes
//!   on in `NAME%001`, `NAME%002`, …; the set is read as one database.
//! - **MPP families**: MPP LS-DYNA writes `binout0000`, `binout0001`, … (one per writing
//!   process, each possibly with its own continuations); `lasso.dyna.Binout("binout*")` and
//!   LSTC's `l2a` read them together.
//!
//! Numbering must be whole: a gap (`binout%001` and `binout%003` without `%002`; `binout0000`
//! and `binout0002` without `binout0001`) is an [`Error::Set`] naming the missing file.

use std::path::{Path, PathBuf};

use crate::error::Error;

fn io(file: &Path, source: std::io::Error) -> Error {
    Error::Set {
        file: file.to_path_buf(),
        detail: format!("cannot list its directory: {source}"),
    }
}

/// The file names in `dir`.
fn listing(dir: &Path) -> Result<Vec<String>, Error> {
    let listing = std::fs::read_dir(if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    })
    .map_err(|e| io(dir, e))?;
    let mut out = Vec::new();
    for entry in listing {
        let entry = entry.map_err(|e| io(dir, e))?;
        if let Some(name) = entry.file_name().to_str() {
            out.push(name.to_string());
        }
    }
    Ok(out)
}

/// The names of `names` of the form `stem` + suffix whose suffix `number` reads, with their
/// numbers, sorted.
fn numbered(dir: &Path, names: &[String], stem: &str, number: impl Fn(&str) -> Option<u32>) -> Vec<(u32, PathBuf)> {
    let mut out: Vec<(u32, PathBuf)> = names
        .iter()
        .filter_map(|name| name.strip_prefix(stem).and_then(&number).map(|n| (n, dir.join(name))))
        .collect();
    out.sort();
    out
}

/// Checks that `found` numbers run first, first+1, … without a gap; names the first missing.
fn whole(found: &[(u32, PathBuf)], first: u32, name: impl Fn(u32) -> PathBuf) -> Result<(), Error> {
    for (k, (n, _)) in found.iter().enumerate() {
        let want = first + k as u32;
        if *n != want {
            let missing = name(want);
            let present: Vec<String> = found.iter().map(|(_, p)| file_name(p)).collect();
            return Err(Error::Set {
                file: missing.clone(),
                detail: format!(
                    "missing from its set: {} is not there, though {} is (present: {})",
                    file_name(&missing),
                    file_name(&found[k].1),
                    present.join(", ")
                ),
            });
        }
    }
    Ok(())
}

fn file_name(p: &Path) -> String {
    p.file_name()
        .map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned())
}

/// `path` and its continuation files `path%001`, `path%002`, … in order.
pub fn with_continuations(path: &Path) -> Result<Vec<PathBuf>, Error> {
    if !path.is_file() {
        return Err(Error::Io {
            file: path.to_path_buf(),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
        });
    }
    let dir = path.parent().unwrap_or(Path::new(""));
    continuations(dir, &listing(dir)?, &file_name(path))
}

/// `dir/stem` and its continuation files among `names`.
fn continuations(dir: &Path, names: &[String], stem: &str) -> Result<Vec<PathBuf>, Error> {
    let digits = |s: &str| {
        (s.len() >= 3 && s.bytes().all(|b| b.is_ascii_digit()))
            .then(|| s.parse().ok())
            .flatten()
    };
    let found = numbered(dir, names, &format!("{stem}%"), digits);
    whole(&found, 1, |n| dir.join(format!("{stem}%{n:03}")))?;
    Ok(std::iter::once(dir.join(stem))
        .chain(found.into_iter().map(|(_, p)| p))
        .collect())
}

/// The files of the database named `stem` in `dir`: `stem` itself (SMP) or the MPP family
/// `stem0000`, `stem0001`, … (both, when both are there: `stem` first), each with its
/// continuations. Empty when there is none.
pub fn find(dir: &Path, stem: &str) -> Result<Vec<PathBuf>, Error> {
    let names = listing(dir)?;
    let mut out = Vec::new();
    if names.iter().any(|n| n == stem) {
        out.extend(continuations(dir, &names, stem)?);
    }
    let four = |s: &str| {
        (s.len() == 4 && s.bytes().all(|b| b.is_ascii_digit()))
            .then(|| s.parse().ok())
            .flatten()
    };
    let family = numbered(dir, &names, stem, four);
    whole(&family, 0, |n| dir.join(format!("{stem}{n:04}")))?;
    for (_, member) in family {
        out.extend(continuations(dir, &names, &file_name(&member))?);
    }
    Ok(out)
}
