//! The termination line LS-DYNA writes at the end of d3hsp, messag and stdout:
//! ` N o r m a l    t e r m i n a t i o n` or ` E r r o r    t e r m i n a t i o n`, followed by a date
//! (and time). The exit code is not a reliable signal (facts.md), so this is what decides. Matching
//! ignores spacing and case; the last termination line in the text wins.

use super::text::{read_text, squash_starts_with};
use crate::error::InputError;
use std::path::Path;

#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Termination {
    /// Normal termination; the text after the phrase (the date), trimmed.
    Normal(String),
    /// Error termination; the text after the phrase (the date), trimmed.
    Error(String),
    /// No termination line.
    Missing,
}

/// The termination status of `text` (infallible: anything without the line is `Missing`).
pub fn parse(text: &str) -> Termination {
    let mut found = Termination::Missing;
    for line in text.lines() {
        let kind = if squash_starts_with(line, "normaltermination") {
            Some(true)
        } else if squash_starts_with(line, "errortermination") {
            Some(false)
        } else {
            None
        };
        let Some(normal) = kind else { continue };
        let date = after_phrase(line).trim().to_string();
        found = if normal {
            Termination::Normal(date)
        } else {
            Termination::Error(date)
        };
    }
    found
}

/// The text after the letter-spaced word `termination` (its last letter `n`).
fn after_phrase(line: &str) -> &str {
    let target = "termination";
    let mut matched = 0;
    let mut started = false;
    for (i, c) in line.char_indices() {
        if c.is_whitespace() {
            continue;
        }
        let lc = c.to_ascii_lowercase();
        if !started {
            // Skip the first word (normal / error) up to the `t` of termination.
            if lc == 't' {
                started = true;
                matched = 1;
            }
            continue;
        }
        if matched < target.len() && target.as_bytes()[matched] as char == lc {
            matched += 1;
            if matched == target.len() {
                return &line[i + c.len_utf8()..];
            }
        } else {
            break;
        }
    }
    ""
}

/// The termination status of one file.
pub fn read(file: &Path) -> Result<Termination, InputError> {
    Ok(parse(&read_text(file)?))
}

/// The first non-missing status among `files` that exist (e.g. messag, d3hsp, stdout); `Missing` if none.
pub fn scan(files: &[&Path]) -> Result<Termination, InputError> {
    for f in files {
        if !f.exists() {
            continue;
        }
        let t = read(f)?;
        if t != Termination::Missing {
            return Ok(t);
        }
    }
    Ok(Termination::Missing)
}
