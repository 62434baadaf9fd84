//! A deck used as it is (`simulation.solver.deck`): the engineer's own keyword deck and the files it
//! `*INCLUDE`s, written into each run directory with the values of its `*PARAMETER` entries and
//! LS-OPT `<<name>>` marks set from the run's design variables, parameters and extension
//! variables (`lsdyna_keyword::parameters`); nothing else in the files changes. The run key hashes
//! what is written, so editing an include reruns exactly the runs that read it.

use std::collections::HashMap;
use std::path::{Component, Path, PathBuf};

use lsdyna_keyword::parameters::{self, DeckError, Entry};
use tera::Context;

use super::template::Inputs;
use crate::error::InputError;

/// One file of a deck: where it was read, its name in the run directory, its text.
#[derive(Debug, Clone)]
pub struct DeckFile {
    pub file: PathBuf,
    pub output: PathBuf,
    pub source: String,
    /// blake3 of the text, hex: names the study's one copy of a file no run changes.
    pub hash: String,
}

/// The main deck (first) and every file it includes, and the names its values are set by.
#[derive(Debug, Clone)]
pub struct Deck {
    pub files: Vec<DeckFile>,
    /// Study name → the deck's parameter name (upper case).
    pub names: Vec<(String, String)>,
    /// The includes that differ per design (the geometry of each tested design).
    pub per_design: Vec<PerDesign>,
    /// The included files no run changes, by index ([`Deck::read`] finds them once).
    pub shared: Vec<usize>,
}

/// An `*INCLUDE` of the deck whose file is the tested design's own (`per_design:` in the study):
/// each design's bytes, written once per study under the output directory's meshes (named by their
/// content's hash) and named on the include's line of each run's deck in place of the deck's name.
#[derive(Debug, Clone)]
pub struct PerDesign {
    /// The include's name as the deck writes it.
    pub include: String,
    /// Where each design's file is: a path with `{design}` in it.
    pub pattern: PathBuf,
    /// Design name → the file read, its bytes (shared, not copied, by the runs) and their blake3
    /// hash (hex), computed once.
    pub files: std::collections::BTreeMap<String, (PathBuf, std::sync::Arc<Vec<u8>>, String)>,
}

/// The context key a run's path to the per-design include `k` is given under.
pub fn include_key(k: usize) -> String {
    format!("deck_include_{k}")
}

/// The context key a run's path to the study's one copy of the deck's file `k` is given under.
pub fn shared_key(k: usize) -> String {
    format!("deck_shared_{k}")
}

/// A deck's `*PARAMETER` entry and the file it is in.
pub struct Defined {
    pub file: PathBuf,
    pub entry: Entry,
}

impl Deck {
    /// Reads `main` and, recursively, every file it includes, each found relative to the main
    /// deck's directory as LS-DYNA finds it; a missing include, one outside that directory, a bad
    /// `*PARAMETER` entry or a name defined twice (in one file or across two) is an error at its
    /// file and line.
    pub fn read(
        main: &Path,
        names: Vec<(String, String)>,
        per_design: &[(String, PathBuf)],
    ) -> Result<(Deck, Vec<Defined>), InputError> {
        let dir = main.parent().unwrap_or(Path::new("")).to_path_buf();
        let output = PathBuf::from(main.file_name().unwrap_or_default());
        let mut deck = Deck {
            files: vec![read_file(main, output)?],
            names,
            per_design: per_design
                .iter()
                .map(|(include, pattern)| PerDesign {
                    include: include.clone(),
                    pattern: pattern.clone(),
                    files: Default::default(),
                })
                .collect(),
            shared: Vec::new(),
        };
        let mut k = 0;
        while k < deck.files.len() {
            for include in parameters::includes(&deck.files[k].source) {
                if per_design.iter().any(|(name, _)| *name == include.file) {
                    continue;
                }
                let at = &deck.files[k];
                let output = included_name(at, include.line, &include.file)?;
                if deck.files.iter().any(|f| f.output == output) {
                    continue;
                }
                let file = dir.join(&output);
                if !file.is_file() {
                    return Err(error(
                        at,
                        include.line,
                        1,
                        format!(
                            "*INCLUDE `{}`: no such file (looked for {}; includes are found relative to the main deck)",
                            include.file,
                            file.display()
                        ),
                    ));
                }
                deck.files.push(read_file(&file, output)?);
            }
            k += 1;
        }
        let defined = deck.defined()?;
        deck.shared = deck.unchanged();
        Ok((deck, defined))
    }

    /// Every `*PARAMETER` entry of every file; a name defined twice is an error at the second.
    fn defined(&self) -> Result<Vec<Defined>, InputError> {
        let mut all: Vec<Defined> = Vec::new();
        for f in &self.files {
            let entries = parameters::entries(&f.source).map_err(|e| deck_error(f, e))?;
            for entry in entries {
                if let Some(first) = all.iter().find(|d| d.entry.name == entry.name) {
                    let message = format!(
                        "parameter {} is defined twice (first at {}:{})",
                        entry.name,
                        first.file.display(),
                        first.entry.line
                    );
                    return Err(error(f, entry.line, 1, message));
                }
                all.push(Defined {
                    file: f.file.clone(),
                    entry,
                });
            }
        }
        Ok(all)
    }

    /// The included files no run changes — none holds an entry or a mark the runs set, nor an
    /// include of its own — by index: written once per study rather than into every run (a mesh
    /// of megabytes, say).
    fn unchanged(&self) -> Vec<usize> {
        (1..self.files.len())
            .filter(|&k| {
                let f = &self.files[k];
                let entries = parameters::entries(&f.source).unwrap_or_default();
                let marks = parameters::marks(&f.source).unwrap_or_default();
                let sets = |d: &String| {
                    entries.iter().any(|e| e.name == *d) || marks.iter().any(|m| m.name.eq_ignore_ascii_case(d))
                };
                parameters::includes(&f.source).is_empty() && !self.names.iter().any(|(_, d)| sets(d))
            })
            .collect()
    }

    /// What a run sets and what it leaves: the (study name, deck name) pairs the deck defines, and
    /// the deck's other `*PARAMETER` names, in file order (for `lab check`).
    pub fn settings(&self) -> (Vec<(String, String)>, Vec<String>) {
        let entries: Vec<String> = self
            .files
            .iter()
            .flat_map(|f| parameters::entries(&f.source).unwrap_or_default())
            .map(|e| e.name)
            .collect();
        let marks = self.marks().unwrap_or_default();
        let set: Vec<(String, String)> = self
            .names
            .iter()
            .filter(|(_, d)| entries.contains(d) || marks.contains(d))
            .cloned()
            .collect();
        let left = entries
            .into_iter()
            .filter(|e| !set.iter().any(|(_, d)| d == e))
            .collect();
        (set, left)
    }

    /// The deck's name of the marks (`<<name>>`) in its files, upper case.
    pub fn marks(&self) -> Result<Vec<String>, InputError> {
        let mut out = Vec::new();
        for f in &self.files {
            let marks = parameters::marks(&f.source).map_err(|e| deck_error(f, e))?;
            out.extend(marks.into_iter().map(|m| m.name.to_ascii_uppercase()));
        }
        Ok(out)
    }

    /// Every file of the deck with the run's values set (those the context has; the others keep
    /// the deck's own). A value that does not fit its field is an error at its file and line.
    pub fn render(&self, context: &Context) -> Result<Inputs, InputError> {
        let values: HashMap<String, f64> = self
            .names
            .iter()
            .filter_map(|(study, deck)| Some((deck.clone(), context.get(study)?.as_f64()?)))
            .collect();
        let path = |key: String| Some(context.get(&key)?.as_str()?.to_string());
        let mut moved: Vec<(String, String)> = self
            .per_design
            .iter()
            .enumerate()
            .filter_map(|(k, p)| Some((p.include.clone(), path(include_key(k))?)))
            .collect();
        // A file the study writes once is named on its include line, not copied into the run.
        let shared: Vec<usize> = (1..self.files.len())
            .filter(|&k| path(shared_key(k)).is_some())
            .collect();
        for &k in &shared {
            moved.push((
                self.files[k].output.to_string_lossy().into_owned(),
                path(shared_key(k)).unwrap_or_default(),
            ));
        }
        let moved: Vec<(&str, String)> = moved.iter().map(|(n, p)| (n.as_str(), p.clone())).collect();
        self.files
            .iter()
            .enumerate()
            .filter(|(k, _)| !shared.contains(k))
            .map(|(_, f)| {
                let (text, _) = parameters::set(&f.source, &values).map_err(|e| deck_error(f, e))?;
                let text = parameters::set_marks(&text, &values).map_err(|e| deck_error(f, e))?;
                Ok((f.output.clone(), with_includes_at(&text, &moved).into_bytes()))
            })
            .collect()
    }

    /// Reads each design's file of every per-design include (its pattern with `{design}`
    /// replaced); a missing one is an error naming the design and the file.
    pub fn read_per_design(&mut self, designs: &[String]) -> Result<(), String> {
        for p in &mut self.per_design {
            for design in designs {
                let file = PathBuf::from(p.pattern.to_string_lossy().replace("{design}", design));
                let bytes = std::fs::read(&file).map_err(|e| {
                    format!(
                        "the include `{}` of design `{design}`: cannot read {} ({e})",
                        p.include,
                        file.display()
                    )
                })?;
                let hash = blake3::hash(&bytes).to_hex().to_string();
                p.files.insert(design.clone(), (file, std::sync::Arc::new(bytes), hash));
            }
        }
        Ok(())
    }
}

/// `text` with each `*INCLUDE` card naming one of `moved` (name, path) naming the path instead.
fn with_includes_at(text: &str, moved: &[(&str, String)]) -> String {
    if moved.is_empty() {
        return text.to_string();
    }
    let mut include = false;
    let lines: Vec<String> = text
        .split('\n')
        .map(|line| {
            if let Some(keyword) = line.strip_prefix('*') {
                include = keyword.trim_end().eq_ignore_ascii_case("INCLUDE");
            } else if include && !line.starts_with('$') {
                let bare = line.trim_end_matches('\r').trim();
                let plain = bare.trim_start_matches("./");
                if let Some((_, path)) = moved.iter().find(|(name, _)| *name == bare || *name == plain) {
                    return line.replacen(bare, path, 1);
                }
            }
            line.to_string()
        })
        .collect();
    lines.join("\n")
}

fn read_file(file: &Path, output: PathBuf) -> Result<DeckFile, InputError> {
    let bytes = std::fs::read(file).map_err(|e| InputError::file(file, format!("cannot read the deck: {e}")))?;
    let source = String::from_utf8(bytes)
        .map_err(|e| InputError::file(file, format!("a keyword deck is text; this file is not UTF-8 ({e})")))?;
    Ok(DeckFile {
        file: file.to_path_buf(),
        hash: blake3::hash(source.as_bytes()).to_hex().to_string(),
        output,
        source,
    })
}

/// An include's name in the run directory: as the deck writes it, which must stay inside the
/// directory (the run directory gets the same tree).
fn included_name(at: &DeckFile, line: usize, name: &str) -> Result<PathBuf, InputError> {
    let path = PathBuf::from(name);
    if path
        .components()
        .all(|c| matches!(c, Component::Normal(_) | Component::CurDir))
    {
        return Ok(path
            .components()
            .filter(|c| matches!(c, Component::Normal(_)))
            .collect());
    }
    Err(error(
        at,
        line,
        1,
        format!(
            "*INCLUDE `{name}`: an include outside the deck's directory cannot be copied into the run directory; \
         move it beside the deck (or below it) and name it relative to the deck"
        ),
    ))
}

fn error(f: &DeckFile, line: usize, column: usize, message: String) -> InputError {
    InputError::at(&f.file, &f.source, line, column, message)
}

fn deck_error(f: &DeckFile, e: DeckError) -> InputError {
    error(f, e.line, e.column, e.message)
}
