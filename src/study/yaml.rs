//! The one place that knows which YAML crate parses study files (serde-saphyr).
//!
//! Everything else sees [`parse`] (text → schema value, or an [`InputError`] at the offending node)
//! and [`Spanned`] (a value with the line and column of the node it came from).

use std::hash::{Hash, Hasher};
use std::path::Path;

use serde::de::{Deserialize, DeserializeOwned, Deserializer};

use crate::error::InputError;

/// A value and where its node starts in the study file (lines and columns count from 1; both are
/// 0 when the YAML crate could not tell). Equality and hashing look at the value only, so a
/// `Spanned<String>` can key a map.
#[derive(Debug, Clone)]
pub struct Spanned<T> {
    pub value: T,
    pub line: usize,
    pub column: usize,
}

impl<T> Spanned<T> {
    /// Where the node is, without its value (to list nodes of different types together).
    pub fn place(&self) -> Spanned<()> {
        Spanned {
            value: (),
            line: self.line,
            column: self.column,
        }
    }
}

impl<T: PartialEq> PartialEq for Spanned<T> {
    fn eq(&self, other: &Self) -> bool {
        self.value == other.value
    }
}

impl<T: Eq> Eq for Spanned<T> {}

impl<T: Hash> Hash for Spanned<T> {
    fn hash<H: Hasher>(&self, state: &mut H) {
        self.value.hash(state)
    }
}

impl<'de, T: Deserialize<'de>> Deserialize<'de> for Spanned<T> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let spanned = serde_saphyr::Spanned::<T>::deserialize(deserializer)?;
        let at = spanned.referenced;
        Ok(Spanned {
            value: spanned.value,
            line: usize::try_from(at.line()).unwrap_or(0),
            column: usize::try_from(at.column()).unwrap_or(0),
        })
    }
}

/// Parses one YAML document of `source` (the text of `file`) into `T`. Syntax errors, duplicate
/// keys, unknown keys, missing keys and wrong types come back located at the offending node.
pub fn parse<T: DeserializeOwned>(file: &Path, source: &str) -> Result<T, InputError> {
    serde_saphyr::from_str::<T>(source).map_err(|error| {
        let inner = error.without_snippet();
        let mut message = inner.render_with_formatter(&serde_saphyr::UserMessageFormatter);
        match inner.location().map(|l| (l.line(), l.column())) {
            Some((line, column)) if line > 0 => {
                let (line, column) = (line as usize, column.max(1) as usize);
                // The crate appends the location to its message; ours is shown separately.
                let suffix = format!(" at line {line}, column {column}");
                if let Some(stripped) = message.strip_suffix(&suffix) {
                    message = stripped.to_string();
                }
                InputError::at(file, source, line, column, friendlier(&message))
            }
            _ => InputError::file(file, friendlier(&message)),
        }
    })
}

/// Rewords the YAML crate's terser messages for people editing a study file.
fn friendlier(message: &str) -> String {
    let message = message.trim();
    match message {
        "invalid floating point" => "expected a number".to_string(),
        "unexpected end of file" | "unexpected end of input" => {
            "the study file is empty (or ends early): expected a YAML mapping with `name`, `design`, ...".to_string()
        }
        _ if is_integer_message(message) => format!("expected a whole number ({message})"),
        _ => message.to_string(),
    }
}

/// Whether `message` is the crate's "invalid u64" (etc.) for a scalar that is not an integer.
fn is_integer_message(message: &str) -> bool {
    const KINDS: [&str; 13] = [
        "integer", "u8", "u16", "u32", "u64", "u128", "usize", "i8", "i16", "i32", "i64", "i128", "isize",
    ];
    message
        .strip_prefix("invalid ")
        .is_some_and(|kind| KINDS.contains(&kind))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Doc {
        #[allow(dead_code)]
        a: Spanned<f64>,
        b: Option<Spanned<String>>,
    }

    #[test]
    fn spans_count_from_one() {
        let doc: Doc = parse(Path::new("x.yaml"), "a: 1\nb: \"text\"\n").unwrap();
        let b = doc.b.unwrap();
        assert_eq!((b.line, b.column), (2, 4));
    }

    #[test]
    fn errors_are_located_without_the_crate_suffix() {
        let err = parse::<Doc>(Path::new("x.yaml"), "a: 1\nc: 2\n").unwrap_err();
        let span = err.span.unwrap();
        assert_eq!((span.line, span.column), (2, 1));
        assert!(err.message.contains("unknown field `c`"), "{}", err.message);
        assert!(!err.message.contains("at line"), "{}", err.message);
    }
}
