//! Writing LSDA files the way LSTC's `lsda` does: the header and a symbol-table offset record,
//! then CD and DATA records as variables are written, and at each [`Writer::flush`] a symbol
//! table indexing the variables written since the last one, linked from the one before. A
//! reader therefore sees everything up to the last flush even if the writer is stopped later.
//!
//! The file is built in memory and written out by [`Writer::save`] (or taken as bytes by
//! [`Writer::finish`]); [`Writer::next_file`] starts a continuation file (`NAME%001`, …).

use std::path::{Path, PathBuf};

use crate::error::Error;
use crate::header::Header;
use crate::value::Values;
use crate::walk::{BEGIN_SYMBOL_TABLE, CD, DATA, END_SYMBOL_TABLE, SYMBOL_TABLE_OFFSET, VARIABLE, change_dir};

/// A variable written since the last symbol table.
struct Entry {
    dir: String,
    name: String,
    code: u8,
    offset: usize,
    count: usize,
}

/// Writes one LSDA file (or a file and its continuations).
pub struct Writer {
    h: Header,
    done: Vec<Vec<u8>>,
    buf: Vec<u8>,
    /// The directory new variables go into, and the one the data stream last changed to.
    cwd: String,
    stream_cwd: Option<String>,
    pending: Vec<Entry>,
    /// Where the offset of the next symbol table is to be patched in.
    link_at: usize,
}

fn too_big(name: &str, what: &str) -> Error {
    Error::Write {
        name: name.into(),
        detail: format!("{what} does not fit the header's sizes"),
    }
}

impl Writer {
    /// A new file with header `h` (8-byte lengths and offsets unless `h` says otherwise).
    pub fn new(h: Header) -> Writer {
        let mut w = Writer {
            h: Header { header_len: 8, ..h },
            done: Vec::new(),
            buf: Vec::new(),
            cwd: "/".into(),
            stream_cwd: None,
            pending: Vec::new(),
            link_at: 0,
        };
        w.start_file();
        w
    }

    fn start_file(&mut self) {
        self.buf = self.h.encode().to_vec();
        let len = self.h.record_head() + self.h.offset_size as usize;
        self.head(len as i64, SYMBOL_TABLE_OFFSET).expect("a tiny record fits");
        self.link_at = self.buf.len();
        self.h.put_int(&mut self.buf, 0, self.h.offset_size).expect("0 fits");
        self.stream_cwd = None;
    }

    fn head(&mut self, len: i64, cmd: i64) -> Option<()> {
        self.h.put_int(&mut self.buf, len, self.h.length_size)?;
        self.h.put_int(&mut self.buf, cmd, self.h.command_size)
    }

    /// Changes the directory new variables go into (absolute, or relative to the current one).
    pub fn cd(&mut self, path: &str) {
        self.cwd = change_dir(&self.cwd, path);
    }

    fn write_cd(&mut self, path: &str) -> Result<(), Error> {
        let len = (self.h.record_head() + path.len()) as i64;
        self.head(len, CD)
            .ok_or_else(|| too_big(path, "the directory record"))?;
        self.buf.extend_from_slice(path.as_bytes());
        Ok(())
    }

    /// Writes variable `name` (1 to 255 bytes, no `/`) into the current directory.
    pub fn write(&mut self, name: &str, values: &Values) -> Result<(), Error> {
        if name.is_empty() || name.len() > 255 || name.contains('/') {
            return Err(Error::Write {
                name: name.into(),
                detail: "a variable name has 1 to 255 bytes and no `/`".into(),
            });
        }
        if self.stream_cwd.as_deref() != Some(self.cwd.as_str()) {
            let cwd = self.cwd.clone();
            self.write_cd(&cwd)?;
            self.stream_cwd = Some(cwd);
        }
        let t = values.type_id();
        let offset = self.buf.len();
        let len = self.h.record_head() + self.h.type_size as usize + 1 + name.len() + values.len() * t.size();
        self.head(len as i64, DATA)
            .ok_or_else(|| too_big(name, "the record length"))?;
        self.h
            .put_int(&mut self.buf, t.code() as i64, self.h.type_size)
            .ok_or_else(|| too_big(name, "the type code"))?;
        self.buf.push(name.len() as u8);
        self.buf.extend_from_slice(name.as_bytes());
        values.encode(&self.h, &mut self.buf);
        if (self.buf.len() as i128) >= 1i128 << (8 * self.h.offset_size as u32 - 1) {
            return Err(too_big(name, "the file's size"));
        }
        self.pending.push(Entry {
            dir: self.cwd.clone(),
            name: name.into(),
            code: t.code(),
            offset,
            count: values.len(),
        });
        Ok(())
    }

    /// Writes a symbol table for the variables written since the last one (none: nothing).
    pub fn flush(&mut self) -> Result<(), Error> {
        if self.pending.is_empty() {
            return Ok(());
        }
        let mut entries = std::mem::take(&mut self.pending);
        entries.sort_by(|a, b| a.dir.cmp(&b.dir));
        let h = self.h;
        let start = self.buf.len();
        self.head(0, BEGIN_SYMBOL_TABLE).expect("0 fits");
        let mut cwd: Option<&str> = None;
        for e in &entries {
            if cwd != Some(e.dir.as_str()) {
                self.write_cd(&e.dir)?;
                cwd = Some(&e.dir);
            }
            let len = h.record_head() + e.name.len() + (h.type_size + h.offset_size + h.length_size) as usize;
            let fits = self.head(len as i64, VARIABLE).and_then(|_| {
                self.buf.extend_from_slice(e.name.as_bytes());
                h.put_int(&mut self.buf, e.code as i64, h.type_size)?;
                h.put_int(&mut self.buf, e.offset as i64, h.offset_size)?;
                h.put_int(&mut self.buf, e.count as i64, h.length_size)
            });
            fits.ok_or_else(|| too_big(&e.name, "its symbol-table entry"))?;
        }
        let end_len = h.record_head() + h.offset_size as usize;
        self.head(end_len as i64, END_SYMBOL_TABLE).expect("a tiny record fits");
        let next_link = self.buf.len();
        h.put_int(&mut self.buf, 0, h.offset_size).expect("0 fits");
        let table_len = self.buf.len() - start;
        h.patch_int(&mut self.buf, start, table_len as i64, h.length_size)
            .ok_or_else(|| too_big("symbol table", "its length"))?;
        h.patch_int(&mut self.buf, self.link_at, start as i64, h.offset_size)
            .ok_or_else(|| too_big("symbol table", "its offset"))?;
        self.link_at = next_link;
        Ok(())
    }

    /// Flushes, closes this file and goes on in a continuation file.
    pub fn next_file(&mut self) -> Result<(), Error> {
        self.flush()?;
        let full = std::mem::take(&mut self.buf);
        self.done.push(full);
        self.start_file();
        Ok(())
    }

    /// Flushes and returns the bytes of the file and its continuations, in order.
    pub fn finish(mut self) -> Result<Vec<Vec<u8>>, Error> {
        self.flush()?;
        self.done.push(std::mem::take(&mut self.buf));
        Ok(self.done)
    }

    /// Flushes and writes the file to `path` (continuations to `path%001`, …); returns the
    /// paths written.
    pub fn save(self, path: &Path) -> Result<Vec<PathBuf>, Error> {
        let files = self.finish()?;
        let mut written = Vec::new();
        for (k, bytes) in files.iter().enumerate() {
            let p = if k == 0 {
                path.to_path_buf()
            } else {
                let mut name = path.as_os_str().to_owned();
                name.push(format!("%{k:03}"));
                PathBuf::from(name)
            };
            std::fs::write(&p, bytes).map_err(|source| Error::Io {
                file: p.clone(),
                source,
            })?;
            written.push(p);
        }
        Ok(written)
    }
}
