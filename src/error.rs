//! Errors as values, printed once at the edge (`cli`), each mapped to the contract's exit code.

use std::fmt;
use std::path::{Path, PathBuf};

/// Where in an input file something is wrong. Lines and columns count from 1.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Span {
    pub line: usize,
    pub column: usize,
}

/// Bad input: names the file, line and column, shows the offending text, says what was expected.
#[derive(Debug, Clone, PartialEq)]
pub struct InputError {
    pub file: PathBuf,
    pub span: Option<Span>,
    pub message: String,
    /// The offending source line with a caret under the column, when known.
    pub excerpt: Option<String>,
}

impl InputError {
    /// An error about the whole file (missing, unreadable).
    pub fn file(file: &Path, message: impl Into<String>) -> Self {
        InputError {
            file: file.to_path_buf(),
            span: None,
            message: message.into(),
            excerpt: None,
        }
    }

    /// An error at `line:column` of `source` (the file's text), with an excerpt and caret.
    pub fn at(file: &Path, source: &str, line: usize, column: usize, message: impl Into<String>) -> Self {
        InputError {
            file: file.to_path_buf(),
            span: Some(Span { line, column }),
            message: message.into(),
            excerpt: excerpt(source, line, column),
        }
    }
}

/// The line `line` of `source` with a caret under `column`.
pub fn excerpt(source: &str, line: usize, column: usize) -> Option<String> {
    let text = source.lines().nth(line.checked_sub(1)?)?;
    let gutter = format!("{line:>4} | ");
    let pad = " ".repeat(gutter.len() + column.saturating_sub(1));
    Some(format!("{gutter}{text}\n{pad}^"))
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file.display())?;
        if let Some(span) = &self.span {
            write!(f, ":{}:{}", span.line, span.column)?;
        }
        write!(f, ": {}", self.message)?;
        if let Some(excerpt) = &self.excerpt {
            write!(f, "\n{excerpt}")?;
        }
        Ok(())
    }
}

impl std::error::Error for InputError {}

/// Everything that can stop a command, by the exit code it maps to.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Invalid input or usage: exit 2.
    #[error("{0}")]
    Input(#[from] InputError),
    /// Runs or numerics failed: exit 1.
    #[error("{0}")]
    Failed(String),
    /// Interrupted by a signal: exit 130.
    #[error("interrupted")]
    Interrupted,
}

impl Error {
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Input(_) => 2,
            Error::Failed(_) => 1,
            Error::Interrupted => 130,
        }
    }
}

impl From<std::io::Error> for Error {
    fn from(e: std::io::Error) -> Self {
        Error::Failed(e.to_string())
    }
}
