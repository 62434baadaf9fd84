//! Reading one file: its records walked in order from the header to the end.
//!
//! Every record is `length | command | payload` (the length counts the whole record). The walk
//! keeps the current directory (CD records, absolute or relative with `..`), files every DATA
//! record as a variable of that directory, and checks each symbol table against the records it
//! indexes: an entry must point at a DATA record of the same name, type and length, and every
//! table link at a table (or nowhere). A record that runs past the end of the file ends the walk
//! with a [`Note`]: what a writer stopped mid-record leaves, read up to its last whole record.
//! Anything else that breaks the format is an [`Error::Format`] naming the offset.

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

/// The directory `path` leads to from `cwd` (`/a/b`, `../c`, `.`); both absolute, normalised.
pub(crate) fn change_dir(cwd: &str, path: &str) -> String {
    // Already absolute and normal (what LS-DYNA mostly writes): as it is.
    let clean =
        |p: &str| p.len() > 1 && !p.ends_with('/') && !p.contains("//") && !p.split('/').any(|c| c == "." || c == "..");
    if path.starts_with('/') && clean(path) {
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
    cwd: String,
    /// The number of `cwd` in the database.
    cwd_id: usize,
    /// The symbol tables met: where each starts and the offset its end record links to.
    tables: Vec<(usize, i64)>,
    /// Every link (where, target): the symbol-table offset record's and each table's.
    links: Vec<(usize, i64)>,
    /// DATA records met after the last symbol table.
    unindexed: usize,
    /// Every DATA record met, in file order: (offset, type, count, name's byte range), what the
    /// symbol tables' entries are checked against.
    records: Vec<(usize, TypeId, usize, std::ops::Range<usize>)>,
    /// Where the file was cut, when it was.
    cut: Option<usize>,
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
        cwd: "/".into(),
        cwd_id: 0,
        tables: Vec::new(),
        links: Vec::new(),
        unindexed: 0,
        records: Vec::new(),
        cut: None,
    };
    let mut pos = h.header_len as usize;
    while pos < bytes.len() {
        match w.record(pos)? {
            Some(len) => pos += len,
            None => break,
        }
    }
    w.check_links()?;
    if w.unindexed > 0 && w.cut.is_none() {
        w.note(
            pos,
            format!(
                "{} data record(s) after the last symbol table are not indexed (the writer stopped before its next symbol table); read anyway",
                w.unindexed
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
                self.links.push((pos, target));
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
        // A directory met before, named absolutely (most CDs): no new string.
        if let Some(id) = path.starts_with('/').then(|| self.db.dir_id(path)).flatten() {
            self.cwd.clear();
            self.cwd.push_str(path);
            self.cwd_id = id;
            return Ok(());
        }
        self.cwd = change_dir(&self.cwd, path);
        self.cwd_id = self.db.ensure_dir(&self.cwd);
        Ok(())
    }

    /// A DATA record's type, name and the range of its values.
    fn data_parts(
        &self,
        pos: usize,
        body: std::ops::Range<usize>,
    ) -> Result<(TypeId, &'a str, std::ops::Range<usize>), Error> {
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
        let raw = &bytes[name_start..data_start];
        let name =
            std::str::from_utf8(raw).map_err(|_| self.err(pos, format!("a variable name is not text: {raw:?}")))?;
        let data = data_start..body.end;
        if data.len() % t.size() != 0 {
            return Err(self.err(
                pos,
                format!(
                    "`{name}`: {} bytes of data, not a whole number of {} values",
                    data.len(),
                    t.name()
                ),
            ));
        }
        Ok((t, name, data))
    }

    fn data(&mut self, pos: usize, body: std::ops::Range<usize>) -> Result<(), Error> {
        let (type_id, name, data) = self.data_parts(pos, body)?;
        self.unindexed += 1;
        let name_at = data.start - name.len()..data.start;
        self.records.push((pos, type_id, data.len() / type_id.size(), name_at));
        let var = Var {
            file: self.file,
            record: pos,
            data: data.start,
            type_id,
            count: data.len() / type_id.size(),
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
        self.unindexed = 0;
        let h = self.h;
        let mut cwd = String::from("/");
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
                CD => cwd = change_dir(&cwd, self.text(at, inner, "a directory name")?),
                VARIABLE => self.entry(at, inner, &cwd)?,
                END_SYMBOL_TABLE => {
                    let target = self.offset_field(at, &inner)?;
                    self.links.push((at, target));
                    self.tables.push((pos, target));
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
    fn entry(&mut self, at: usize, inner: std::ops::Range<usize>, cwd: &str) -> Result<(), Error> {
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
        // The DATA records met so far are in file order: find the one at `record`.
        let Ok(k) = self.records.binary_search_by_key(&record, |r| r.0) else {
            return Err(bad(format!("no DATA record starts at offset {record}")));
        };
        let (_, t, count_there, name_at) = self.records[k].clone();
        let data_name = &self.bytes[name_at];
        if data_name != name_bytes || Some(t) != TypeId::from_code(code) || count_there as i64 != count {
            return Err(bad(format!(
                "says type code {code} and {count} value(s) at offset {record}, where the record holds `{}` of {} × {}",
                String::from_utf8_lossy(data_name),
                count_there,
                t.name()
            )));
        }
        Ok(())
    }

    /// Every link must lead to a symbol table (or be 0); a whole file's chain reaches them all.
    fn check_links(&mut self) -> Result<(), Error> {
        let len = self.bytes.len();
        if let (None, Some(&(at, target))) = (self.cut, self.links.iter().find(|l| l.1 >= len as i64)) {
            // Cut exactly between two records: a link says more was written.
            self.cut = Some(len);
            self.note(len, format!("the file ends here, though offset {at} links to a symbol table at offset {target}: read up to the end"));
        }
        for &(at, target) in &self.links {
            let ok = target == 0
                || usize::try_from(target)
                    .is_ok_and(|t| self.tables.iter().any(|s| s.0 == t) || self.cut.is_some_and(|c| t >= c));
            if !ok {
                return Err(self.err(
                    at,
                    format!("link to a symbol table at offset {target}, where none starts"),
                ));
            }
        }
        let Some(&(_, first)) = self.links.first() else {
            return Ok(());
        };
        let mut reached = 0;
        let mut next = first;
        while next != 0 && reached <= self.tables.len() {
            let Some(table) = self.tables.iter().find(|s| s.0 as i64 == next) else {
                break;
            };
            reached += 1;
            next = table.1;
        }
        let missed = self.tables.len().saturating_sub(reached);
        if missed == 0 || self.cut.is_some() {
            return Ok(());
        }
        let last = self.tables[self.tables.len() - 1].0;
        if missed == 1 && next == 0 {
            self.note(last, "the last symbol table is not linked from the one before (the writer stopped before linking it); read anyway".into());
            return Ok(());
        }
        Err(self.err(
            last,
            format!(
                "the symbol-table chain reaches {reached} of the file's {} tables",
                self.tables.len()
            ),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::change_dir;

    #[test]
    fn directories_change_as_lsda_does() {
        assert_eq!(change_dir("/", "/rcforc/metadata"), "/rcforc/metadata");
        assert_eq!(change_dir("/rcforc/metadata", "../d000001"), "/rcforc/d000001");
        assert_eq!(change_dir("/a/b", "c/"), "/a/b/c");
        assert_eq!(change_dir("/a", "../../.."), "/");
        assert_eq!(change_dir("/a", "./b//c"), "/a/b/c");
        assert_eq!(change_dir("/x", "/"), "/");
    }
}
