//! # lsda — LS-DYNA's binout (LSDA) files, read and written
//!
//! LS-DYNA writes its time-history databases (RCFORC, NODOUT, GLSTAT, RWFORC, MATSUM, …) into
//! `binout` files instead of ASCII files when a `*DATABASE_...` card's BINARY option is 2 (or 3:
//! both), and always under MPP. Their format is LSTC's LSDA ("LS-DYNA Data Archive"). This crate
//! reads it without LSTC's library, checked on files LS-DYNA R7.1.2, R9.3.1 and R12.2.1 wrote and
//! against LSTC's own `lsda` module as lasso-python 2.0.4 bundles it (see the repository's
//! `docs/binout.md`), and writes it so that module reads the files back equal.
//!
//! ## The format
//!
//! - **Header**, 8 bytes: header length (8), then the sizes in bytes of a record length, a file
//!   offset, a command code and a type code (LS-DYNA: 8, 8, 1, 1; offsets of 4 bytes occur in
//!   old files), then the byte order of every number in the file (1 little-endian, 0
//!   big-endian), then two zero bytes ([`Header`]).
//! - **Records** follow one after another: `length | command | payload`, the length counting the
//!   whole record. Commands: 2 CD (payload: a directory path, absolute or relative with `..`),
//!   3 DATA (a type code, a 1-byte name length, the name, then the values), 5 BEGIN SYMBOL TABLE,
//!   7 SYMBOL TABLE OFFSET (the offset of the first symbol table; the record right after the
//!   header).
//! - **Symbol tables** index the DATA records written before them: CD entries, then per
//!   variable a VARIABLE entry (4: name, type code, offset of its DATA record, number of values),
//!   ended by an END record (6) holding the offset of the next table (0: none). LS-DYNA writes
//!   one after every output step, so a killed run's file is readable up to its last table.
//! - **Types** ([`TypeId`]): I1, I2, I4, I8 (signed), U1…U8 (unsigned), R4, R8 (IEEE reals) and
//!   LINK. Text (titles, dates, versions) is stored as I1 arrays.
//! - **Sets**: a file past the writer's size limit goes on in `NAME%001`, `NAME%002`, …; MPP
//!   writes `binout0000`, `binout0001`, … All are read as one tree ([`set`]).
//!
//! LS-DYNA's own layout inside a binout (directories `/glstat`, `/rcforc`, `/rwforc/forces`, …,
//! each with a `metadata` directory and one directory `d000001`, `d000002`, … per output step) is
//! a convention above this crate: see lab's `extract::lsdyna::binout`.
//!
//! ## Reading
//!
//! [`Database::open`] reads a file and its continuations; [`set::find`] names the files of a
//! run's database in a directory (SMP `binout` or MPP `binout0000…`), for
//! [`Database::open_files`]. The reader walks every record from the header to the end and checks
//! each symbol table against the records it indexes, so it never trusts an offset it has not
//! seen a record at. It never panics on any input: a broken file is an [`Error`] naming the file
//! and the byte offset; a file that ends inside a record (a writer stopped mid-record) is read up
//! to its last whole record and says so in [`Database::notes`].
//!
//! ```
//! use lsda::{Database, Header, Values, Writer};
//! let mut w = Writer::new(Header::default());
//! w.cd("/glstat/d000001");
//! w.write("time", &Values::R4(vec![0.5]))?;
//! w.write("cycle", &Values::I4(vec![17]))?;
//! let files = w.finish()?;
//! let db = Database::from_bytes(vec![("binout".into(), files[0].clone())])?;
//! assert_eq!(db.variable("glstat/d000001/time").unwrap().to_f64(), [0.5]);
//! assert_eq!(db.subdirs("/glstat").unwrap().collect::<Vec<_>>(), ["d000001"]);
//! assert!(db.notes().is_empty());
//! # Ok::<(), lsda::Error>(())
//! ```
//!
//! ## Writing
//!
//! [`Writer`]: [`Writer::cd`] to a directory, [`Writer::write`] variables, [`Writer::flush`] a
//! symbol table after each output step (as LS-DYNA does), then [`Writer::save`] or
//! [`Writer::finish`].

mod database;
mod error;
mod header;
pub mod set;
mod value;
mod walk;
mod write;

pub use database::{Database, NameId, Note, Variable};
pub use error::Error;
pub use header::{Endian, Header};
pub use value::{TypeId, Values};
pub use write::Writer;
