//! Reading one file: its records walked in order from the header to the end.
//!
//! Every record is `length | command | payload` (the length counts the whole record). The walk
//! keeps the current directory (CD records, absolute or relative with `..`), files every DATA
//! record as a variable of that directory, and checks each symbol table against the records it
//! indexes: an entry must point at a DATA record of the same name, type and length, and every
//! table link at a table (or nowhere). A record that runs past the end of the file ends the walk
//! with a [`Note`]: what a writer stopped mid-record leaves, read up to its last whole record.
//! Anything else that breaks the format is an [`Error::Format`] naming the offset.

use std::borrow::Cow;
use std::path::Path;

use crate::database::{Database, Note, Var};
use crate::error::Error;
use crate::header::Header;
use crate::value::TypeId;

pub(crate) const CD: i64 = 2;
pub(crate) const DATA: i64 = 3;
pub(crate) const VARIABLE: i64 = 4;
pub(crate) const BEGIN_SYMBOL_TABLE: i64 = 5;
pub(crate) const END_SYMBOL_TABLE: i64 = 6;
pub(crate) const SYMBOL_TABLE_OFFSET: i64 = 7;

/// Whether `path` is absolute and normal already (what LS-DYNA mostly writes): `/a/b`, not
/// `/`, `a/b`, `/a/`, `/a//b`, `/a/./b` or `/a/../b`.
pub(crate) fn is_normal(path: &str) -> bool {
    let b = path.as_bytes();
    if b.len() < 2 || b[0] != b'/' || b[b.len() - 1] == b'/' {
        return false;
    }
    // No empty, `.` or `..` component: every `/` followed by something other than `/`, `./`
    // or `../` (or a final `.` or `..`).
    let mut k = 0;
    while k < b.len() {
        if b[k] == b'/' {
            let rest = &b[k + 1..];
            let dots = rest.iter().take_while(|&&c| c == b'.').count();
            let end = rest.get(dots).is_none_or(|&c| c == b'/');
            if rest.first() == Some(&b'/') || ((dots == 1 || dots == 2) && end) {
                return false;
            }
        }
        k += 1;
    }
    true
}

/// The directory `path` leads to from `cwd` (`/a/b`, `../c`, `.`); both absolute, normalised.
pub(crate) fn change_dir(cwd: &str, path: &str) -> String {
    if is_normal(path) {
        return path.to_string();
    }
    let mut parts: Vec<&str> = if path.starts_with('/') {
        Vec::new()
    } else {
        cwd.split('/').filter(|p| !p.is_empty()).collect()
    };
    for part in path.split('/') {
        match part {
            "" | "." => {}
            ".." => {
                parts.pop();
            }
            p => parts.push(p),
        }
    }
    format!("/{}", parts.join("/"))
}

/// State of the walk through one file.
struct Walker<'a> {
    db: &'a mut Database,
    file: usize,
    path: &'a Path,
    bytes: &'a [u8],
    h: Header,
    /// The number of the current directory in the database.
    cwd_id: usize,
    /// What the walk met: the symbol tables, their links and the DATA records.
    met: Met,
    /// Where the file was cut, when it was.
    cut: Option<usize>,
}

/// What the walk met, to check the symbol tables against the records.
#[derive(Default)]
struct Met {
    /// The symbol tables met: where each starts and the offset its end record links to.
    tables: Vec<(usize, i64)>,
    /// Every link (where, target): the symbol-table offset record's and each table's.
    links: Vec<(usize, i64)>,
    /// DATA records met after the last symbol table.
    unindexed: usize,
    /// Every DATA record met, in file order: (offset, type, number of values), what the symbol
    /// tables' entries are checked against.
    records: Vec<(usize, TypeId, usize)>,
    /// Where in `records` the last entry checked was found (the next is most often the next).
    last_found: usize,
    /// The DATA records between the table being read and the one before.
    unindexed_at_table: usize,
}

/// Walks file number `file` of `db` (its bytes already stored), filing its variables.
pub(crate) fn walk(db: &mut Database, file: usize, path: &Path, bytes: &[u8]) -> Result<(), Error> {
    let h = Header::parse(bytes).map_err(|d| Error::format(path, 0, d))?;
    db.set_header(file, h);
    let mut w = Walker {
        db,
        file,
        path,
        bytes,
        h,
        cwd_id: 0,
        met: Met::default(),
        cut: None,
    };
    // A binout's DATA records hold a few values each (with their symbol-table entries, some 70
    // bytes), and its directories a few dozen: room for about as many as its size says.
    w.db.reserve(bytes.len() / 64, bytes.len() / 1024);
    w.met.records.reserve(bytes.len() / 64);
    let mut pos = h.header_len as usize;
    while pos < bytes.len() {
        match w.record(pos)? {
            Some(len) => pos += len,
            None => break,
        }
    }
    w.check_links()?;
    if w.met.unindexed > 0 && w.cut.is_none() {
        w.note(
            pos,
            format!(
                "{} data record(s) after the last symbol table are not indexed (the writer stopped before its next symbol table); read anyway",
                w.met.unindexed
            ),
        );
    }
    Ok(())
}

impl<'a> Walker<'a> {
    fn err(&self, at: usize, detail: impl Into<String>) -> Error {
        Error::format(self.path, at, detail)
    }

    fn note(&mut self, at: usize, detail: String) {
        self.db.push_note(Note {
            file: self.path.to_path_buf(),
            offset: at as u64,
            detail,
        });
    }

    /// Stops the walk at `at`: the file ends inside the record starting there.
    fn cut_at(&mut self, at: usize, what: String) -> Option<usize> {
        self.cut = Some(at);
        let left = self.bytes.len() - at;
        self.note(
            at,
            format!(
                "the file ends inside {what} ({left} byte(s) of it present): read up to the last whole record before it"
            ),
        );
        None
    }

    #[inline(always)]
    fn int(&self, at: usize, size: u8) -> Option<i64> {
        self.h.int(self.bytes, at, size)
    }

    /// The record at `pos`: its length, or `None` when the file ends inside it.
    fn record(&mut self, pos: usize) -> Result<Option<usize>, Error> {
        let h = self.h;
        let (Some(len), Some(cmd)) = (
            self.int(pos, h.length_size),
            self.int(pos + h.length_size as usize, h.command_size),
        ) else {
            return Ok(self.cut_at(pos, "a record's length and command".into()));
        };
        if cmd == BEGIN_SYMBOL_TABLE && len == 0 {
            // Its length is written last: a writer stopped while writing the table.
            return Ok(self.cut_at(pos, "a symbol table whose length was never written".into()));
        }
        if len < h.record_head() as i64 {
            return Err(self.err(
                pos,
                format!(
                    "record length {len} is shorter than the record's own length and command ({} bytes)",
                    h.record_head()
                ),
            ));
        }
        let Some(end) = usize::try_from(len)
            .ok()
            .and_then(|l| pos.checked_add(l))
            .filter(|&e| e <= self.bytes.len())
        else {
            let what = if len as u64 > self.bytes.len() as u64 {
                format!(
                    "a record announcing {len} bytes (command {cmd}), more than the whole file: cut there, or its length is corrupt"
                )
            } else {
                format!("a record of {len} bytes (command {cmd})")
            };
            return Ok(self.cut_at(pos, what));
        };
        let body = pos + h.record_head()..end;
        match cmd {
            CD => self.cd(pos, body)?,
            DATA => self.data(pos, body)?,
            BEGIN_SYMBOL_TABLE => self.symbol_table(pos, body)?,
            SYMBOL_TABLE_OFFSET => {
                let target = self.offset_field(pos, &body)?;
                self.met.links.push((pos, target));
            }
            VARIABLE | END_SYMBOL_TABLE => {
                return Err(self.err(pos, format!("command {cmd} outside a symbol table")));
            }
            other => {
                return Err(self.err(
                    pos,
                    format!("unknown command {other} (expected 2 CD, 3 DATA, 5 symbol table or 7 symbol table offset)"),
                ));
            }
        }
        Ok(Some(end - pos))
    }

    fn text(&self, at: usize, range: std::ops::Range<usize>, what: &str) -> Result<&'a str, Error> {
        let bytes: &'a [u8] = self.bytes;
        let raw = &bytes[range];
        std::str::from_utf8(raw).map_err(|_| self.err(at, format!("{what} is not text: {raw:?}")))
    }

    fn cd(&mut self, pos: usize, body: std::ops::Range<usize>) -> Result<(), Error> {
        let path = self.text(pos, body, "a directory name")?;
        // Named absolutely (most CDs): no new string.
        if is_normal(path) {
            self.cwd_id = self.db.ensure_dir(path);
            return Ok(());
        }
        let cwd = self.db.dir_path(self.cwd_id).unwrap_or("/");
        let to = change_dir(cwd, path);
        self.cwd_id = self.db.ensure_dir(&to);
        Ok(())
    }

    /// A DATA record's type, name and the range of its values.
    fn data_parts(
        &self,
        pos: usize,
        body: std::ops::Range<usize>,
    ) -> Result<(TypeId, &'a [u8], std::ops::Range<usize>), Error> {
        let bytes: &'a [u8] = self.bytes;
        let ts = self.h.type_size;
        let code = self
            .int(body.start, ts)
            .filter(|_| body.len() > ts as usize)
            .ok_or_else(|| self.err(pos, "a DATA record too short for its type code and name length"))?;
        let t = TypeId::from_code(code).ok_or_else(|| {
            self.err(
                pos,
                format!("unknown type code {code} (expected 1 to 11: I1…I8, U1…U8, R4, R8, LINK)"),
            )
        })?;
        let name_len = self.bytes[body.start + ts as usize] as usize;
        let name_start = body.start + ts as usize + 1;
        let data_start = name_start + name_len;
        if name_len == 0 || data_start > body.end {
            return Err(self.err(
                pos,
                format!("a DATA record's name of {name_len} bytes does not fit its record"),
            ));
        }
        let name = &bytes[name_start..data_start];
        if !name.is_ascii() && std::str::from_utf8(name).is_err() {
            return Err(self.err(pos, format!("a variable name is not text: {name:?}")));
        }
        let data = data_start..body.end;
        // Sizes are 1, 2, 4 or 8 bytes.
        if data.len() & (t.size() - 1) != 0 {
            return Err(self.err(
                pos,
                format!(
                    "`{}`: {} bytes of data, not a whole number of {} values",
                    String::from_utf8_lossy(name),
                    data.len(),
                    t.name()
                ),
            ));
        }
        Ok((t, name, data))
    }

    fn data(&mut self, pos: usize, body: std::ops::Range<usize>) -> Result<(), Error> {
        let (type_id, name, data) = self.data_parts(pos, body)?;
        self.met.unindexed += 1;
        let count = data.len() >> type_id.size().trailing_zeros();
        self.met.records.push((pos, type_id, count));
        let var = Var {
            file: self.file,
            record: pos,
            data: data.start,
            type_id,
            count,
        };
        self.db.insert(self.cwd_id, name, var);
        Ok(())
    }

    fn offset_field(&self, pos: usize, body: &std::ops::Range<usize>) -> Result<i64, Error> {
        let os = self.h.offset_size as usize;
        if body.len() != os {
            return Err(self.err(
                pos,
                format!(
                    "a symbol-table offset record holds {} bytes, expected an offset of {os}",
                    body.len()
                ),
            ));
        }
        self.int(body.start, self.h.offset_size)
            .ok_or_else(|| self.err(pos, "offset past the end"))
    }

    /// A symbol table: CD and VARIABLE entries, then the END record with the next table's offset.
    fn symbol_table(&mut self, pos: usize, body: std::ops::Range<usize>) -> Result<(), Error> {
        self.met.unindexed_at_table = self.met.unindexed;
        self.met.unindexed = 0;
        let h = self.h;
        // The directory of the entries (for messages): borrowed from the file when normal.
        let mut cwd: Cow<'a, str> = Cow::Borrowed("/");
        let mut at = body.start;
        loop {
            let (Some(len), Some(cmd)) = (
                self.int(at, h.length_size),
                self.int(at + h.length_size as usize, h.command_size),
            ) else {
                return Err(self.err(at, "a symbol table runs past its own length"));
            };
            let end = usize::try_from(len)
                .ok()
                .filter(|&l| l >= h.record_head())
                .and_then(|l| at.checked_add(l))
                .filter(|&e| e <= body.end)
                .ok_or_else(|| {
                    self.err(
                        at,
                        format!("a symbol-table entry of length {len} does not fit its table"),
                    )
                })?;
            let inner = at + h.record_head()..end;
            match cmd {
                CD => {
                    let to = self.text(at, inner, "a directory name")?;
                    cwd = if is_normal(to) {
                        Cow::Borrowed(to)
                    } else {
                        Cow::Owned(change_dir(&cwd, to))
                    };
                }
                VARIABLE => self.met.last_found = self.entry(at, inner, &cwd)?,
                END_SYMBOL_TABLE => {
                    let target = self.offset_field(at, &inner)?;
                    self.met.links.push((at, target));
                    self.met.tables.push((pos, target));
                    if end != body.end {
                        return Err(self.err(at, "the symbol table's end record is not at the end of the table"));
                    }
                    return Ok(());
                }
                other => {
                    return Err(self.err(
                        at,
                        format!("command {other} inside a symbol table (expected CD, VARIABLE or END)"),
                    ));
                }
            }
            at = end;
        }
    }

    /// A VARIABLE entry: its DATA record must be at its offset, with its name, type and length.
    /// The record's place in `records`.
    fn entry(&self, at: usize, inner: std::ops::Range<usize>, cwd: &str) -> Result<usize, Error> {
        let h = self.h;
        let tail = h.type_size as usize + h.offset_size as usize + h.length_size as usize;
        if inner.len() <= tail {
            return Err(self.err(at, "a symbol-table entry too short for a name, type, offset and length"));
        }
        let name_bytes = &self.bytes[inner.start..inner.end - tail];
        let p = inner.end - tail;
        let fields = (
            self.int(p, h.type_size),
            self.int(p + h.type_size as usize, h.offset_size),
            self.int(p + h.type_size as usize + h.offset_size as usize, h.length_size),
        );
        let (Some(code), Some(offset), Some(count)) = fields else {
            return Err(self.err(at, "a symbol-table entry past the end"));
        };
        let bad = |why: String| {
            let name = String::from_utf8_lossy(name_bytes);
            self.err(at, format!("symbol-table entry `{cwd}/{name}`: {why}"))
        };
        let Ok(record) = usize::try_from(offset) else {
            return Err(bad(format!("negative offset {offset}")));
        };
        // The DATA records met so far are in file order: find the one at `record` (most often
        // the one after the last found).
        let next = self.met.last_found + 1;
        // Else among the records since the table before (what a table mostly indexes), else
        // among all.
        let since = self.met.records.len() - self.met.unindexed_at_table;
        let k = if self.met.records.get(next).is_some_and(|r| r.0 == record) {
            next
        } else if let Ok(k) = self.met.records[since..].binary_search_by_key(&record, |r| r.0) {
            since + k
        } else {
            let Ok(k) = self.met.records.binary_search_by_key(&record, |r| r.0) else {
                return Err(bad(format!("no DATA record starts at offset {record}")));
            };
            k
        };
        let (_, t, count_there) = self.met.records[k];
        // Its name, read when the record was met (so in the file): a length, then the bytes.
        let name_len_at = record + h.record_head() + h.type_size as usize;
        let name_len = self.bytes[name_len_at] as usize;
        let data_name = &self.bytes[name_len_at + 1..name_len_at + 1 + name_len];
        if !crate::database::same(data_name, name_bytes)
            || Some(t) != TypeId::from_code(code)
            || count_there as i64 != count
        {
            return Err(bad(format!(
                "says type code {code} and {count} value(s) at offset {record}, where the record holds `{}` of {} × {}",
                String::from_utf8_lossy(data_name),
                count_there,
                t.name()
            )));
        }
        Ok(k)
    }

    /// The symbol table starting at `at` (the tables met are in file order).
    fn table_at(&self, at: usize) -> Option<(usize, i64)> {
        self.met
            .tables
            .binary_search_by_key(&at, |s| s.0)
            .ok()
            .map(|k| self.met.tables[k])
    }

    /// Every link must lead to a symbol table (or be 0); a whole file's chain reaches them all.
    fn check_links(&mut self) -> Result<(), Error> {
        let len = self.bytes.len();
        if let (None, Some(&(at, target))) = (self.cut, self.met.links.iter().find(|l| l.1 >= len as i64)) {
            // Cut exactly between two records: a link says more was written.
            self.cut = Some(len);
            self.note(len, format!("the file ends here, though offset {at} links to a symbol table at offset {target}: read up to the end"));
        }
        for &(at, target) in &self.met.links {
            let ok = target == 0
                || usize::try_from(target)
                    .is_ok_and(|t| self.table_at(t).is_some() || self.cut.is_some_and(|c| t >= c));
            if !ok {
                return Err(self.err(
                    at,
                    format!("link to a symbol table at offset {target}, where none starts"),
                ));
            }
        }
        let Some(&(_, first)) = self.met.links.first() else {
            return Ok(());
        };
        let mut reached = 0;
        let mut next = first;
        while next != 0 && reached <= self.met.tables.len() {
            let Some(table) = usize::try_from(next).ok().and_then(|t| self.table_at(t)) else {
                break;
            };
            reached += 1;
            next = table.1;
        }
        let missed = self.met.tables.len().saturating_sub(reached);
        if missed == 0 || self.cut.is_some() {
            return Ok(());
        }
        let last = self.met.tables[self.met.tables.len() - 1].0;
        if missed == 1 && next == 0 {
            self.note(last, "the last symbol table is not linked from the one before (the writer stopped before linking it); read anyway".into());
            return Ok(());
        }
        Err(self.err(
            last,
            format!(
                "the symbol-table chain reaches {reached} of the file's {} tables",
                self.met.tables.len()
            ),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::{change_dir, is_normal};

    #[test]
    fn directories_change_as_lsda_does() {
        assert_eq!(change_dir("/", "/rcforc/metadata"), "/rcforc/metadata");
        assert_eq!(change_dir("/rcforc/metadata", "../d000001"), "/rcforc/d000001");
        assert_eq!(change_dir("/a/b", "c/"), "/a/b/c");
        assert_eq!(change_dir("/a", "../../.."), "/");
        assert_eq!(change_dir("/a", "./b//c"), "/a/b/c");
        assert_eq!(change_dir("/x", "/"), "/");
    }

    #[test]
    fn normal_paths_are_told_apart() {
        for p in ["/a", "/rcforc/d000001", "/a/.b", "/a/...", "/a/b..", "/a./b"] {
            assert!(is_normal(p), "{p}");
            assert_eq!(change_dir("/x", p), p);
        }
        for p in [
            "/", "a/b", "/a/", "/a//b", "/a/./b", "/a/../b", "/a/.", "/a/..", "/./a", "//a", "",
        ] {
            assert!(!is_normal(p), "{p}");
        }
    }
}
