//! A read LSDA database: the directory tree of one file or of a set of files read as one (as
//! LSTC's `lsda` does: a later file's variable of the same path replaces an earlier one), with
//! the notes the reading left (a file cut mid-record, data no symbol table indexes).
//!
//! Values stay in the file's bytes until asked for ([`Variable::values`]): opening a database
//! reads its records' headers, not its numbers.
//!
//! The tree is kept flat, without an allocation per variable or per directory: directory paths
//! one after another in one string, variables in one list (each directory's linked through it),
//! paths and names found by a hash read eight bytes at a time.

use std::collections::HashMap;
use std::fmt;
use std::hash::{BuildHasherDefault, Hasher};
use std::path::{Path, PathBuf};

use crate::error::Error;
use crate::header::Header;
use crate::value::{TypeId, Values};

/// A hash of a name or path, read eight bytes at a time.
fn hash(bytes: &[u8]) -> u64 {
    const K: u64 = 0x517c_c1b7_2722_0a95;
    let mut h = (bytes.len() as u64).wrapping_mul(K);
    let mut chunks = bytes.chunks_exact(8);
    for c in &mut chunks {
        let w = u64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]);
        h = (h.rotate_left(5) ^ w).wrapping_mul(K);
    }
    let rest = chunks.remainder();
    if !rest.is_empty() {
        let mut b = [0u8; 8];
        b[..rest.len()].copy_from_slice(rest);
        h = (h.rotate_left(5) ^ u64::from_le_bytes(b)).wrapping_mul(K);
    }
    h ^= h >> 32;
    h = h.wrapping_mul(0x9e37_79b9_7f4a_7c15);
    h ^ (h >> 29)
}

/// Whether `a` and `b` are the same bytes, compared eight at a time (names and paths are
/// short: a call to `memcmp` costs more than the comparison).
#[inline]
pub(crate) fn same(a: &[u8], b: &[u8]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    let mut x = a.chunks_exact(8);
    let mut y = b.chunks_exact(8);
    for (p, q) in (&mut x).zip(&mut y) {
        if u64::from_ne_bytes([p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]])
            != u64::from_ne_bytes([q[0], q[1], q[2], q[3], q[4], q[5], q[6], q[7]])
        {
            return false;
        }
    }
    x.remainder().iter().zip(y.remainder()).all(|(p, q)| p == q)
}

/// The keys of a [`HashIndex`] are already hashes: used as they are.
#[derive(Default)]
struct Id(u64);

impl Hasher for Id {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0.rotate_left(8) ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = v;
    }
}

/// String → number, keyed by the string's [`hash`]. A key another string holds moves on to the
/// next key (`+ 1`): a lookup follows the same probe, comparing the strings.
#[derive(Default)]
struct HashIndex(HashMap<u64, u32, BuildHasherDefault<Id>>);

impl HashIndex {
    /// The number of `s` (`of` gives each number's string), or the key where it would go.
    fn find<'s>(&self, s: &[u8], of: impl Fn(u32) -> &'s [u8]) -> Result<u32, u64> {
        let mut key = hash(s);
        loop {
            match self.0.get(&key) {
                None => return Err(key),
                Some(&k) if same(of(k), s) => return Ok(k),
                Some(_) => key = key.wrapping_add(1),
            }
        }
    }
}

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

/// No variable (the end of a directory's list).
const END: u32 = u32::MAX;

/// One directory: its path (a range of [`Database::paths`]), its subdirectories, and the first
/// and last of its variables in [`Database::vars`].
#[derive(Debug, Clone)]
struct Dir {
    path: (usize, usize),
    children: Vec<u32>,
    first: u32,
    last: u32,
    /// Bit `n % 64` set for every name number `n` of its variables: a name whose bit is clear
    /// is not there (a binout has fewer than 64 names, so the list is seldom walked).
    names: u64,
    /// The variable of the directory made before it in the same parent that the next variable
    /// filed here probably matches: LS-DYNA writes every step's variables in the same order, so
    /// the name is checked against that one's before it is looked up by its hash.
    guide: u32,
}

/// A variable filed in a directory: its name's number, the next variable of the directory,
/// where it is.
#[derive(Debug, Clone, Copy)]
struct Filed {
    name: u32,
    next: u32,
    var: Var,
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
    /// Directories by number; their paths, one after another; their numbers by path.
    dirs: Vec<Dir>,
    paths: String,
    index: HashIndex,
    /// Every variable filed, in the order read (see [`Dir`]).
    vars: Vec<Filed>,
    /// Variable names, each once (a binout repeats `time`, `x_force`, … in every step), and
    /// their numbers.
    names: Vec<Box<str>>,
    name_index: HashIndex,
    notes: Vec<Note>,
}

/// A variable name of a [`Database`], looked up once ([`Database::name_id`]) to read the
/// variable of that name in many directories ([`Database::variable_by_id`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct NameId(u32);

impl NameId {
    /// Its number: below the number of distinct names of the database (for a table by name).
    pub fn index(self) -> usize {
        self.0 as usize
    }
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

/// The last name of a normalised path (`d000001` of `/rcforc/d000001`; `` of `/`).
fn last_name(path: &str) -> &str {
    path.rfind('/').map_or(path, |k| &path[k + 1..])
}

impl Database {
    fn empty() -> Database {
        let mut db = Database {
            files: Vec::new(),
            dirs: Vec::new(),
            paths: String::new(),
            index: HashIndex::default(),
            vars: Vec::new(),
            names: Vec::new(),
            name_index: HashIndex::default(),
            notes: Vec::new(),
        };
        db.ensure_dir("/");
        db
    }

    fn path_of(&self, k: u32) -> &str {
        let (a, b) = self.dirs[k as usize].path;
        &self.paths[a..b]
    }

    fn dir(&self, path: &str) -> Option<&Dir> {
        self.dir_id(path).map(|k| &self.dirs[k])
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

    /// Room for about `vars` more variables and `dirs` more directories (what a file's size
    /// suggests).
    pub(crate) fn reserve(&mut self, vars: usize, dirs: usize) {
        self.vars.reserve(vars);
        self.dirs.reserve(dirs);
        self.index.0.reserve(dirs);
        self.paths.reserve(16 * dirs);
    }

    /// Creates `path` (normalised) and its parents; its number.
    pub(crate) fn ensure_dir(&mut self, path: &str) -> usize {
        let key = match self.index.find(path.as_bytes(), |k| {
            let (a, b) = self.dirs[k as usize].path;
            &self.paths.as_bytes()[a..b]
        }) {
            Ok(k) => return k as usize,
            Err(key) => key,
        };
        let parent = match path.rfind('/') {
            Some(0) if path.len() > 1 => Some(self.ensure_dir("/")),
            Some(k) if k > 0 => Some(self.ensure_dir(&path[..k])),
            _ => None,
        };
        let guide = parent
            .and_then(|p| self.dirs[p].children.last())
            .map_or(END, |&c| self.dirs[c as usize].first);
        let k = self.dirs.len();
        let start = self.paths.len();
        self.paths.push_str(path);
        self.dirs.push(Dir {
            path: (start, self.paths.len()),
            children: Vec::new(),
            first: END,
            last: END,
            names: 0,
            guide,
        });
        self.index.0.insert(key, k as u32);
        if let Some(p) = parent {
            self.dirs[p].children.push(k as u32);
        }
        k
    }

    /// Files variable `name` in directory number `dir` (a later one of the name replaces it).
    pub(crate) fn insert(&mut self, dir: usize, name: &[u8], var: Var) {
        let guide = self.vars.get(self.dirs[dir].guide as usize).copied();
        self.dirs[dir].guide = guide.map_or(END, |g| g.next);
        let names = &self.names;
        let id = if let Some(g) = guide
            && same(names[g.name as usize].as_bytes(), name)
        {
            g.name
        } else {
            match self.name_index.find(name, |k| names[k as usize].as_bytes()) {
                Ok(id) => id,
                Err(key) => {
                    let id = self.names.len() as u32;
                    // The walk checked it is text.
                    self.names.push(String::from_utf8_lossy(name).into());
                    self.name_index.0.insert(key, id);
                    id
                }
            }
        };
        let d = &mut self.dirs[dir];
        let bit = 1u64 << (id % 64);
        let mut at = if d.names & bit == 0 { END } else { d.first };
        d.names |= bit;
        while at != END {
            let f = &mut self.vars[at as usize];
            if f.name == id {
                f.var = var;
                return;
            }
            at = f.next;
        }
        let k = self.vars.len() as u32;
        self.vars.push(Filed {
            name: id,
            next: END,
            var,
        });
        if d.last == END {
            d.first = k;
        } else {
            self.vars[d.last as usize].next = k;
        }
        d.last = k;
    }

    /// The variables of a directory, in the order first written.
    fn filed(&self, d: &Dir) -> impl Iterator<Item = &Filed> {
        let mut at = d.first;
        std::iter::from_fn(move || {
            let f = self.vars.get(at as usize)?;
            at = f.next;
            Some(f)
        })
    }

    /// Variable number `id` of a directory.
    fn find_id(&self, d: &Dir, id: u32) -> Option<Var> {
        if d.names & (1u64 << (id % 64)) == 0 {
            return None;
        }
        self.filed(d).find(|f| f.name == id).map(|f| f.var)
    }

    /// Variable `name` of a directory.
    fn find(&self, d: &Dir, name: &str) -> Option<Var> {
        self.find_id(d, self.name_id(name)?.0)
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
        self.dir_id(&normal(path)).is_some()
    }

    /// The subdirectory names of `path`, sorted; `None` when it is not a directory.
    pub fn subdirs(&self, path: &str) -> Option<impl Iterator<Item = &str>> {
        let k = self.dir_id(&normal(path))?;
        Some(self.subdirs_at(k).into_iter().map(|(name, _)| name))
    }

    /// The subdirectories of directory number `dir` (see [`Database::dir_id`]) by name, sorted,
    /// with their numbers; empty when there is no such directory.
    pub fn subdirs_at(&self, dir: usize) -> Vec<(&str, usize)> {
        let Some(d) = self.dirs.get(dir) else {
            return Vec::new();
        };
        let mut out: Vec<(&str, usize)> = d
            .children
            .iter()
            .map(|&c| (last_name(self.path_of(c)), c as usize))
            .collect();
        out.sort_unstable_by(|a, b| a.0.cmp(b.0));
        out
    }

    /// The path of directory number `dir` (`/rcforc/d000001`).
    pub fn dir_path(&self, dir: usize) -> Option<&str> {
        (dir < self.dirs.len()).then(|| self.path_of(dir as u32))
    }

    /// The variables of directory `path` by name, sorted; `None` when it is not a directory.
    pub fn variables(&self, path: &str) -> Option<impl Iterator<Item = (&str, Variable<'_>)>> {
        self.dir(&normal(path)).map(|d| {
            let mut vars: Vec<(&str, Variable<'_>)> = self
                .filed(d)
                .map(|f| (&*self.names[f.name as usize], Variable { db: self, var: f.var }))
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
        let mut paths: Vec<&str> = (0..self.dirs.len() as u32).map(|k| self.path_of(k)).collect();
        paths.sort_unstable();
        paths.into_iter()
    }

    /// The number of directory `path` (normalised: `/glstat/d000001`), for
    /// [`Database::variable_at`]: one lookup of the path for many variables.
    pub fn dir_id(&self, path: &str) -> Option<usize> {
        self.index
            .find(path.as_bytes(), |k| self.path_of(k).as_bytes())
            .ok()
            .map(|k| k as usize)
    }

    /// Variable `name` of directory number `dir` (see [`Database::dir_id`]).
    pub fn variable_at(&self, dir: usize, name: &str) -> Option<Variable<'_>> {
        let var = self.find(self.dirs.get(dir)?, name)?;
        Some(Variable { db: self, var })
    }

    /// The number of variable name `name`, when some directory has a variable of that name.
    pub fn name_id(&self, name: &str) -> Option<NameId> {
        self.name_index
            .find(name.as_bytes(), |k| self.names[k as usize].as_bytes())
            .ok()
            .map(NameId)
    }

    /// The variables of directory number `dir` (see [`Database::dir_id`]) by name number, in the
    /// order first written: a step's variables read in one pass.
    pub fn variables_by_id(&self, dir: usize) -> impl Iterator<Item = (NameId, Variable<'_>)> {
        let first = self.dirs.get(dir).map_or(END, |d| d.first);
        let mut at = first;
        std::iter::from_fn(move || {
            let f = self.vars.get(at as usize)?;
            at = f.next;
            Some((NameId(f.name), Variable { db: self, var: f.var }))
        })
    }

    /// The variable of name `name` (see [`Database::name_id`]) in directory number `dir`
    /// (see [`Database::dir_id`]): no string compared.
    pub fn variable_by_id(&self, dir: usize, name: NameId) -> Option<Variable<'_>> {
        let var = self.find_id(self.dirs.get(dir)?, name.0)?;
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

    /// Its values as `f64`, as [`Variable::to_f64`] gives them, into `out` (cleared first): one
    /// buffer for many variables.
    pub fn to_f64_into(&self, out: &mut Vec<f64>) {
        let f = &self.db.files[self.var.file];
        let h = f.header.expect("a file with variables has a header");
        crate::value::decode_f64_into(&h, self.var.type_id, self.raw(), out)
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
