//! The crate's errors: every one names the file it is about and, for a bad file, the byte offset.

use std::path::PathBuf;

/// What went wrong reading or writing an LSDA file.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The file could not be read or written.
    #[error("{}: {source}", file.display())]
    Io {
        file: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The bytes at `offset` are not what the format allows there.
    #[error("{}: offset {offset}: {detail}", file.display())]
    Format { file: PathBuf, offset: u64, detail: String },
    /// A set of files is not whole (a continuation or MPP file is missing).
    #[error("{}: {detail}", file.display())]
    Set { file: PathBuf, detail: String },
    /// What a writer was asked to write does not fit the format.
    #[error("cannot write `{name}`: {detail}")]
    Write { name: String, detail: String },
}

impl Error {
    pub(crate) fn format(file: &std::path::Path, offset: usize, detail: impl Into<String>) -> Error {
        Error::Format {
            file: file.to_path_buf(),
            offset: offset as u64,
            detail: detail.into(),
        }
    }
}
