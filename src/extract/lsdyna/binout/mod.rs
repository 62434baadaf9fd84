//! LS-DYNA's binout: the time histories LS-DYNA writes into its LSDA database instead of (or
//! beside) the ASCII files, read through the workspace crate [`lsda`].
//!
//! LS-DYNA's layout inside the database (what LSTC's `l2a` and lasso-python read): one directory
//! per history (`/glstat`, `/rcforc`, `/nodout`, `/rwforc/forces`, `/matsum`, …), each with a
//! `metadata` directory (title, version, date, revision; `ids` and `side` of the entries of an
//! rcforc, the node `ids` of a nodout, …) and one directory per output step, `d000001`,
//! `d000002`, …, holding `time` and the step's values (one per entry for per-id histories).
//!
//! - [`Binout::series`]: a variable over the output steps in lasso-python's naming
//!   (`rwforc/forces/normal_force`: `Binout.read("rwforc", "forces", "normal_force")`), sorted by
//!   time as lasso-python sorts it; a `metadata` variable as it is.
//! - [`Binout::list`]: the histories a database holds, with their variables.
//! - [`histories`]: rcforc, nodout and glstat into the ASCII readers' types (so the same
//!   completeness checks, quality figures and curves apply), and rwforc.

pub mod histories;

use std::path::{Path, PathBuf};

use crate::error::InputError;

/// The file name LS-DYNA gives the database (MPP: `binout0000`, `binout0001`, …).
pub const STEM: &str = "binout";

/// An opened binout (one file, or a set read as one).
pub struct Binout {
    pub db: lsda::Database,
    /// The first file: what messages name.
    pub name: PathBuf,
}

/// The error of the `lsda` crate as a file error (its text names the file and the offset).
pub fn input_error(e: lsda::Error) -> InputError {
    let file = match &e {
        lsda::Error::Io { file, .. } | lsda::Error::Format { file, .. } | lsda::Error::Set { file, .. } => file.clone(),
        lsda::Error::Write { name, .. } => PathBuf::from(name),
    };
    let text = e.to_string();
    let prefix = format!("{}: ", file.display());
    InputError::file(&file, text.strip_prefix(&prefix).unwrap_or(&text).to_string())
}

/// The binout of run directory `dir` (SMP `binout` or MPP `binout0000…`, each with its
/// continuation files); `None` when there is none.
pub fn open_dir(dir: &Path) -> Result<Option<Binout>, InputError> {
    let files = lsda::set::find(dir, STEM).map_err(input_error)?;
    let Some(first) = files.first().cloned() else {
        return Ok(None);
    };
    let db = lsda::Database::open_files(&files).map_err(input_error)?;
    Ok(Some(Binout { db, name: first }))
}

/// The binout at `path`: a file (with its continuations; an MPP member brings its family), or
/// a run directory holding one.
pub fn open(path: &Path) -> Result<Binout, InputError> {
    if path.is_dir() {
        return open_dir(path)?
            .ok_or_else(|| InputError::file(path, "no binout (binout, binout0000, …) in this directory"));
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mpp = name.len() > 4 && name[name.len() - 4..].bytes().all(|b| b.is_ascii_digit()) && !name.contains('%');
    let files = if mpp {
        let dir = path.parent().unwrap_or(Path::new(""));
        lsda::set::find(dir, &name[..name.len() - 4]).map_err(input_error)?
    } else {
        lsda::set::with_continuations(path).map_err(input_error)?
    };
    let db = lsda::Database::open_files(&files).map_err(input_error)?;
    Ok(Binout {
        db,
        name: path.to_path_buf(),
    })
}

/// A variable over the output steps (or a metadata variable, `time` empty).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Series {
    pub time: Vec<f64>,
    pub values: SeriesValues,
    /// The entries' ids (metadata `ids`) of a per-id variable.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ids: Option<Vec<f64>>,
}

/// One value per step, one list per id (each over the steps), or text (a metadata title).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(untagged)]
pub enum SeriesValues {
    Scalar(Vec<f64>),
    PerId(Vec<Vec<f64>>),
    Text(String),
}

/// Whether `name` is an output step's directory (`d` and six digits).
pub fn is_step(name: &str) -> bool {
    name.len() == 7 && name.starts_with('d') && name[1..].bytes().all(|b| b.is_ascii_digit())
}

impl Binout {
    /// The notes of the reading (a cut file), as lines.
    pub fn notes(&self) -> Vec<String> {
        self.db.notes().iter().map(|n| n.to_string()).collect()
    }

    /// The output-step directories of history `dir` (`/rcforc`), in file order of their names.
    pub fn steps(&self, dir: &str) -> Vec<String> {
        self.db
            .subdirs(dir)
            .map(|d| {
                d.filter(|n| is_step(n))
                    .map(|n| format!("{}/{n}", dir.trim_end_matches('/')))
                    .collect()
            })
            .unwrap_or_default()
    }

    fn no_such(&self, path: &str, detail: String) -> InputError {
        InputError::file(&self.name, format!("`{path}`: {detail}"))
    }

    /// `path` in lasso-python's naming: `DIR/NAME` where DIR holds `metadata` and step
    /// directories. Sorted by time (steps without a `time` keep their order).
    pub fn series(&self, path: &str) -> Result<Series, InputError> {
        let trimmed = path.trim_matches('/');
        let (dir, name) = trimmed.rsplit_once('/').map_or(("/", trimmed), |(d, n)| (d, n));
        let dir = format!("/{}", dir.trim_matches('/'));
        if !self.db.is_dir(&dir) {
            return Err(self.no_such(
                path,
                format!("no directory {dir}; `lab extract FILE --list` lists what there is"),
            ));
        }
        if let Some(v) = self.db.variable(&format!("{dir}/metadata/{name}")) {
            let values = v.values();
            let values = match values.text().filter(|_| v.type_id() == lsda::TypeId::I1) {
                Some(t) => SeriesValues::Text(t),
                None => SeriesValues::Scalar(values.to_f64()),
            };
            return Ok(Series {
                time: Vec::new(),
                values,
                ids: None,
            });
        }
        let mut rows: Vec<(Option<f64>, Vec<f64>)> = Vec::new();
        for step in self.steps(&dir) {
            if let Some(v) = self.db.variable_in(&step, name) {
                let t = self.db.variable_in(&step, "time").and_then(|t| t.first_f64());
                rows.push((t, v.to_f64()));
            }
        }
        if rows.is_empty() {
            return Err(self.no_such(path, format!("no variable `{name}` in the steps of {dir}")));
        }
        if rows.iter().all(|r| r.0.is_some()) {
            rows.sort_by(|a, b| a.0.unwrap_or(0.0).total_cmp(&b.0.unwrap_or(0.0)));
        }
        let time = rows.iter().filter_map(|r| r.0).collect();
        let per_id = rows.iter().any(|r| r.1.len() != 1);
        let values = if per_id {
            let n = rows.iter().map(|r| r.1.len()).max().unwrap_or(0);
            SeriesValues::PerId(
                (0..n)
                    .map(|k| rows.iter().map(|r| r.1.get(k).copied().unwrap_or(f64::NAN)).collect())
                    .collect(),
            )
        } else {
            SeriesValues::Scalar(rows.iter().map(|r| r.1[0]).collect())
        };
        let ids = per_id
            .then(|| self.db.variable(&format!("{dir}/metadata/ids")).map(|v| v.to_f64()))
            .flatten();
        Ok(Series { time, values, ids })
    }

    /// What the database holds: per history directory its steps and variables (name, type,
    /// values per step), and its metadata (texts shown).
    pub fn list(&self) -> String {
        let mut out = String::new();
        for dir in self.db.dirs() {
            let Some(subdirs) = self.db.subdirs(dir) else { continue };
            let subdirs: Vec<&str> = subdirs.collect();
            let steps = self.steps(dir);
            let has_meta = subdirs.contains(&"metadata");
            if steps.is_empty() && !has_meta {
                continue;
            }
            let short = dir.trim_start_matches('/');
            let times = self
                .series(&format!("{short}/time"))
                .ok()
                .map(|s| s.time)
                .unwrap_or_default();
            out += &match (times.first(), times.last()) {
                (Some(a), Some(b)) => format!("{short}: {} output steps, time {a:e} to {b:e}\n", steps.len()),
                _ => format!("{short}: {} output steps\n", steps.len()),
            };
            if has_meta {
                for (name, v) in self.db.variables(&format!("{dir}/metadata")).into_iter().flatten() {
                    out += &format!(
                        "  {short}/{name:<28} {:>4} × {:<5} metadata",
                        v.type_id().name(),
                        v.len()
                    );
                    if let Some(t) = v.values().text().filter(|_| v.type_id() == lsda::TypeId::I1) {
                        out += &format!(" {:?}", t.trim_end());
                    }
                    out += "\n";
                }
            }
            let mut seen = std::collections::BTreeMap::new();
            for step in &steps {
                for (name, v) in self.db.variables(step).into_iter().flatten() {
                    seen.entry(name.to_string()).or_insert((v.type_id().name(), v.len()));
                }
            }
            for (name, (t, n)) in seen {
                out += &format!("  {short}/{name:<28} {t:>4} × {n:<5} per step\n");
            }
        }
        out
    }
}
