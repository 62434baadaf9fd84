//! A read LSDA database: the directory tree of one file or of a set of files read as one (as
//! LSTC's `lsda` does: a later file's variable of the same path replaces an earlier one), with
//! the notes the reading left (a file cut mid-record, data no symbol table indexes).
//!
//! Values stay in the file's bytes until asked for ([`Variable::values`]): opening a database
//! reads its records' headers, not its numbers.

use std::collections::{BTreeSet, HashMap};
use std::hash::{BuildHasherDefault, Hasher};

/// FNV-1a: the names and paths hashed here are short, and a file has thousands of them; the
/// standard library's SipHash costs more than the rest of filing a variable.
#[derive(Default)]
pub(crate) struct Fnv(u64);

impl Hasher for Fnv {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        let mut h = if self.0 == 0 { 0xcbf2_9ce4_8422_2325 } else { self.0 };
        for &b in bytes {
            h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
        self.0 = h;
    }
}

type FastMap<K, V> = HashMap<K, V, BuildHasherDefault<Fnv>>;
use std::fmt;
use std::path::{Path, PathBuf};

use crate::error::Error;
use crate::header::Header;
use crate::value::{TypeId, Values};

/// Where a variable's values are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Var {
    pub file: usize,
    /// Offset of its DATA record.
    pub record: usize,
    /// Offset of its first value.
    pub data: usize,
    pub type_id: TypeId,
    pub count: usize,
}

/// One directory: the names of its subdirectories and its variables.
#[derive(Debug, Clone, Default)]
pub(crate) struct Dir {
    pub dirs: BTreeSet<String>,
    /// Variables by interned name number (see [`Database::names`]); a few dozen at most.
    pub vars: Vec<(u32, Var)>,
}

/// Something the reader passed over or could only partly read, and where.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Note {
    pub file: PathBuf,
    pub offset: u64,
    pub detail: String,
}

impl fmt::Display for Note {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: offset {}: {}", self.file.display(), self.offset, self.detail)
    }
}

struct File {
    path: PathBuf,
    bytes: Vec<u8>,
    header: Option<Header>,
}

/// The contents of an LSDA file or set of files.
pub struct Database {
    files: Vec<File>,
    /// Directories by number, and their numbers by path.
    dirs: Vec<Dir>,
    index: FastMap<String, usize>,
    /// Variable names, each once (a binout repeats `time`, `x_force`, … in every step), and
    /// their numbers.
    names: Vec<Box<str>>,
    name_ids: FastMap<Box<str>, u32>,
    notes: Vec<Note>,
}

/// A variable of a [`Database`]: its type, length, place, and values on request.
#[derive(Clone, Copy)]
pub struct Variable<'a> {
    db: &'a Database,
    var: Var,
}

/// `/a/b` for `a/b`, `/a/b/`, `/a//b`.
pub(crate) fn normal(path: &str) -> String {
    crate::walk::change_dir("/", path)
}

/// The directory part and the last name of a path.
fn split(path: &str) -> (String, &str) {
    let trimmed = path.trim_end_matches('/');
    match trimmed.rfind('/') {
        Some(k) => (normal(&trimmed[..k]), &trimmed[k + 1..]),
        None => ("/".into(), trimmed),
    }
}

impl Database {
    fn empty() -> Database {
        Database {
            files: Vec::new(),
            dirs: vec![Dir::default()],
            index: FastMap::from_iter([("/".to_string(), 0)]),
            names: Vec::new(),
            name_ids: FastMap::default(),
            notes: Vec::new(),
        }
    }

    fn dir(&self, path: &str) -> Option<&Dir> {
        self.index.get(path).map(|&k| &self.dirs[k])
    }

    /// Opens `path` with its continuation files (`path%001`, `path%002`, … as LSTC's writer
    /// names them), read as one database.
    pub fn open(path: impl AsRef<Path>) -> Result<Database, Error> {
        Database::open_files(&crate::set::with_continuations(path.as_ref())?)
    }

    /// Opens `paths`, in this order, as one database (a later file's variable replaces an
    /// earlier one of the same path).
    pub fn open_files(paths: &[PathBuf]) -> Result<Database, Error> {
        let mut files = Vec::with_capacity(paths.len());
        for p in paths {
            let bytes = std::fs::read(p).map_err(|source| Error::Io {
                file: p.clone(),
                source,
            })?;
            files.push((p.clone(), bytes));
        }
        Database::from_bytes(files)
    }

    /// Reads files already in memory: (name for messages, bytes), in order.
    pub fn from_bytes(files: Vec<(PathBuf, Vec<u8>)>) -> Result<Database, Error> {
        let mut db = Database::empty();
        for (k, (path, bytes)) in files.into_iter().enumerate() {
            db.files.push(File {
                path: path.clone(),
                bytes: Vec::new(),
                header: None,
            });
            crate::walk::walk(&mut db, k, &path, &bytes)?;
            db.files[k].bytes = bytes;
        }
        Ok(db)
    }

    pub(crate) fn set_header(&mut self, file: usize, h: Header) {
        self.files[file].header = Some(h);
    }

    pub(crate) fn push_note(&mut self, n: Note) {
        self.notes.push(n);
    }

    /// Creates `path` (normalised) and its parents; its number.
    pub(crate) fn ensure_dir(&mut self, path: &str) -> usize {
        if let Some(&k) = self.index.get(path) {
            return k;
        }
        let k = self.dirs.len();
        self.dirs.push(Dir::default());
        self.index.insert(path.to_string(), k);
        let (parent, name) = split(path);
        let name = name.to_string();
        let p = self.ensure_dir(&parent);
        self.dirs[p].dirs.insert(name);
        k
    }

    /// Files variable `name` in directory number `dir` (a later one of the name replaces it).
    pub(crate) fn insert(&mut self, dir: usize, name: &str, var: Var) {
        let id = match self.name_ids.get(name) {
            Some(&id) => id,
            None => {
                let id = self.names.len() as u32;
                self.names.push(name.into());
                self.name_ids.insert(name.into(), id);
                id
            }
        };
        let vars = &mut self.dirs[dir].vars;
        match vars.iter_mut().find(|v| v.0 == id) {
            Some(v) => v.1 = var,
            None => vars.push((id, var)),
        }
    }

    /// Variable `name` of a directory.
    fn find(&self, d: &Dir, name: &str) -> Option<Var> {
        let id = *self.name_ids.get(name)?;
        d.vars.iter().find(|v| v.0 == id).map(|v| v.1)
    }

    /// The files read, in order.
    pub fn files(&self) -> impl Iterator<Item = &Path> {
        self.files.iter().map(|f| f.path.as_path())
    }

    /// The header of file number `k`.
    pub fn header(&self, k: usize) -> Option<Header> {
        self.files.get(k).and_then(|f| f.header)
    }

    /// What the reading passed over (a cut file, unindexed data); empty for a whole file.
    pub fn notes(&self) -> &[Note] {
        &self.notes
    }

    /// Whether `path` (`/rcforc/metadata`, or without the leading `/`) is a directory.
    pub fn is_dir(&self, path: &str) -> bool {
        self.index.contains_key(&normal(path))
    }

    /// The subdirectory names of `path`, sorted; `None` when it is not a directory.
    pub fn subdirs(&self, path: &str) -> Option<impl Iterator<Item = &str>> {
        self.dir(&normal(path)).map(|d| d.dirs.iter().map(String::as_str))
    }

    /// The variables of directory `path` by name, sorted; `None` when it is not a directory.
    pub fn variables(&self, path: &str) -> Option<impl Iterator<Item = (&str, Variable<'_>)>> {
        self.dir(&normal(path)).map(|d| {
            let mut vars: Vec<(&str, Variable<'_>)> = d
                .vars
                .iter()
                .map(|(n, v)| (&*self.names[*n as usize], Variable { db: self, var: *v }))
                .collect();
            vars.sort_unstable_by(|a, b| a.0.cmp(b.0));
            vars.into_iter()
        })
    }

    /// The variable at `path` (`/glstat/d000001/time`).
    pub fn variable(&self, path: &str) -> Option<Variable<'_>> {
        let (dir, name) = split(path);
        self.variable_in(&dir, name)
    }

    /// The variable `name` of directory `dir` (already normalised: `/glstat/d000001`).
    pub fn variable_in(&self, dir: &str, name: &str) -> Option<Variable<'_>> {
        let var = self.find(self.dir(dir)?, name)?;
        Some(Variable { db: self, var })
    }

    /// Every directory path, sorted (`/`, `/glstat`, `/glstat/d000001`, …).
    pub fn dirs(&self) -> impl Iterator<Item = &str> {
        let mut paths: Vec<&str> = self.index.keys().map(String::as_str).collect();
        paths.sort_unstable();
        paths.into_iter()
    }

    /// The number of directory `path` (normalised: `/glstat/d000001`), for
    /// [`Database::variable_at`]: one lookup of the path for many variables.
    pub fn dir_id(&self, path: &str) -> Option<usize> {
        self.index.get(path).copied()
    }

    /// Variable `name` of directory number `dir` (see [`Database::dir_id`]).
    pub fn variable_at(&self, dir: usize, name: &str) -> Option<Variable<'_>> {
        let var = self.find(self.dirs.get(dir)?, name)?;
        Some(Variable { db: self, var })
    }
}

impl<'a> Variable<'a> {
    pub fn type_id(&self) -> TypeId {
        self.var.type_id
    }

    /// Number of values.
    pub fn len(&self) -> usize {
        self.var.count
    }

    pub fn is_empty(&self) -> bool {
        self.var.count == 0
    }

    /// The file it is in, and the offset of its DATA record.
    pub fn place(&self) -> (&'a Path, u64) {
        (&self.db.files[self.var.file].path, self.var.record as u64)
    }

    /// The stored bytes of its values, in the file's byte order.
    pub fn raw(&self) -> &'a [u8] {
        let f = &self.db.files[self.var.file];
        &f.bytes[self.var.data..self.var.data + self.var.count * self.var.type_id.size()]
    }

    /// Its values, decoded exactly.
    pub fn values(&self) -> Values {
        let f = &self.db.files[self.var.file];
        let h = f.header.expect("a file with variables has a header");
        Values::decode(&h, self.var.type_id, self.raw())
    }

    /// Its values as `f64` (see [`Values::to_f64`]), decoded straight from the file's bytes.
    pub fn to_f64(&self) -> Vec<f64> {
        let f = &self.db.files[self.var.file];
        let h = f.header.expect("a file with variables has a header");
        crate::value::decode_f64(&h, self.var.type_id, self.raw())
    }

    /// Value `k` as `f64` (NaN past the end), decoded from the file's bytes alone.
    pub fn f64_at(&self, k: usize) -> f64 {
        let size = self.var.type_id.size();
        let Some(bytes) = self.raw().get(k * size..(k + 1) * size) else {
            return f64::NAN;
        };
        let h = self.db.files[self.var.file]
            .header
            .expect("a file with variables has a header");
        crate::value::decode_one(&h, self.var.type_id, bytes)
    }

    /// Its first value as `f64`, if it has one.
    pub fn first_f64(&self) -> Option<f64> {
        if self.is_empty() {
            None
        } else {
            self.values().to_f64().first().copied()
        }
    }
}

impl fmt::Debug for Variable<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} × {}", self.var.count, self.var.type_id.name())
    }
}
