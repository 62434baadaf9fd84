//! Shared pieces of the LS-DYNA ASCII readers: Fortran-style numbers, a line tokenizer, and the common
//! preamble (title line, ` ls-dyna ...` line, `{BEGIN LEGEND} ... {END LEGEND}` blocks).
//!
//! # Numbers
//! LS-DYNA and `l2a` write fixed-width `E` fields (`%12.5E`, `%13.4E`, ...). Token parsing splits on
//! white space, but two things can break a naive split, and both are handled here:
//! - a negative value that fills its field exactly is glued to its left neighbour
//!   (`-1.31E-01-1.43E-03`): after a complete number a sign starts a new one;
//! - Fortran `Ew.d` output drops the `E` when |exponent| > 99 and writes `±nnn` instead
//!   (`1.234-100`; Oracle and Intel Fortran references both document this form). A signed
//!   group of exactly three digits right after a mantissa that holds a `.` is read as that exponent.
//!   `D` is accepted as an exponent letter. A field of asterisks (Fortran's overflow marker) reads as NaN,
//!   as do `NaN`/`Infinity` words; the crush extractor rejects non-finite values in what it uses.

pub use crate::base::number::read_text;
use crate::base::number::{measured_value, special_word};
pub use crate::base::number::{number_len, number_value, parse_number};
use crate::error::InputError;
use std::path::Path;

/// One token of a line: a number, or any other run of text.
#[derive(Debug, Clone, PartialEq)]
pub enum Tok<'a> {
    Num(f64, &'a str),
    Word(&'a str),
}

impl<'a> Tok<'a> {
    pub fn num(&self) -> Option<f64> {
        match self {
            Tok::Num(v, _) => Some(*v),
            Tok::Word(w) => special_word(w),
        }
    }
    pub fn text(&self) -> &'a str {
        match self {
            Tok::Num(_, s) | Tok::Word(s) => s,
        }
    }
}

/// Split a line into tokens. Words run to white space and end after `=` or `#`; numbers start at a token
/// boundary and glued numbers are split (see the module doc).
pub fn tokens(line: &str) -> Vec<Tok<'_>> {
    let mut out = Vec::new();
    tokens_into(line, &mut out);
    out
}

/// [`tokens`] into a buffer the caller reuses line after line (the readers' hot loop).
pub fn tokens_into<'a>(line: &'a str, out: &mut Vec<Tok<'a>>) {
    out.clear();
    let b = line.as_bytes();
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        if c.is_ascii_whitespace() {
            i += 1;
            continue;
        }
        if c == b'*' {
            let s = i;
            while i < b.len() && b[i] == b'*' {
                i += 1;
            }
            out.push(Tok::Num(f64::NAN, &line[s..i]));
            continue;
        }
        let n = number_len(&b[i..]);
        if n > 0 {
            let t = &line[i..i + n];
            match measured_value(t) {
                Some(v) => out.push(Tok::Num(v, t)),
                None => out.push(Tok::Word(t)),
            }
            i += n;
            continue;
        }
        // A word: up to white space, or through a '=' or '#'.
        let s = i;
        while i < b.len() && !b[i].is_ascii_whitespace() {
            let ch = b[i];
            i += 1;
            if ch == b'=' || ch == b'#' {
                break;
            }
        }
        // Keep char boundaries: extend to the next boundary if we stopped inside a multi-byte char.
        while i < b.len() && !line.is_char_boundary(i) {
            i += 1;
        }
        out.push(Tok::Word(&line[s..i]));
    }
}

/// All numbers of a line, or None if any token is not a number.
pub fn all_numbers(line: &str) -> Option<Vec<f64>> {
    tokens(line).iter().map(Tok::num).collect()
}

/// `v` as an id: a whole number from 0 to below 10¹⁸.
pub fn whole(v: f64) -> Option<u64> {
    (v >= 0.0 && v.fract() == 0.0 && v < 1e18).then_some(v as u64)
}

/// The data lines of an LS-DYNA ASCII file: numbered from 1, preamble and legend blocks removed.
pub struct Body<'a> {
    pub title: &'a str,
    pub version: &'a str,
    pub lines: Vec<(usize, &'a str)>,
}

/// An error at `line` of `file` (column 1), with the line as excerpt.
pub fn err(file: &Path, text: &str, line: usize, msg: impl Into<String>) -> InputError {
    InputError::at(file, text, line, 1, msg)
}

/// Check the title and ` ls-dyna ...` lines and drop `{BEGIN LEGEND ... {END LEGEND}` blocks.
pub fn body<'a>(file: &Path, text: &'a str, what: &str) -> Result<Body<'a>, InputError> {
    let mut it = text.lines().enumerate().map(|(i, l)| (i + 1, l));
    let Some((_, title)) = it.next() else {
        return Err(InputError::file(
            file,
            format!("empty file: expected an LS-DYNA {what} file (a title line first)"),
        ));
    };
    let Some((vno, version)) = it.next() else {
        return Err(err(
            file,
            text,
            1,
            "file ends after the title: expected a ` ls-dyna (version ...)  date ...` line",
        ));
    };
    if !version.to_ascii_lowercase().contains("ls-dyna") {
        return Err(err(
            file,
            text,
            vno,
            format!("expected the ` ls-dyna (version ...)  date ...` line of a {what} file"),
        ));
    }
    let mut lines = Vec::new();
    let mut legend_start: Option<usize> = None;
    for (no, l) in it {
        let t = l.trim_start();
        if let Some(_start) = legend_start {
            if t.starts_with("{END LEGEND") {
                legend_start = None;
            }
            continue;
        }
        if t.starts_with("{BEGIN LEGEND") {
            legend_start = Some(no);
            continue;
        }
        if t.starts_with("{END LEGEND") {
            return Err(err(file, text, no, "`{END LEGEND}` without a `{BEGIN LEGEND}`"));
        }
        lines.push((no, l));
    }
    if let Some(start) = legend_start {
        return Err(err(
            file,
            text,
            start,
            "legend block never ends: expected `{END LEGEND}`",
        ));
    }
    Ok(Body {
        title: title.trim(),
        version: version.trim(),
        lines,
    })
}

/// Collapse the letter-spaced headings LS-DYNA writes (` n o d a l   p r i n t`) to `nodalprint`.
pub fn squash(line: &str) -> String {
    squashed(line).collect()
}

/// The characters [`squash`] keeps, without allocating (the readers test every line).
fn squashed(line: &str) -> impl Iterator<Item = char> + '_ {
    line.chars().filter(|c| !c.is_whitespace()).flat_map(char::to_lowercase)
}

/// `squash(line) == target` for a lower-case `target`.
pub fn squash_eq(line: &str, target: &str) -> bool {
    squashed(line).eq(target.chars())
}

/// `squash(line).starts_with(prefix)` for a lower-case `prefix`.
pub fn squash_starts_with(line: &str, prefix: &str) -> bool {
    let mut it = squashed(line);
    prefix.chars().all(|p| it.next() == Some(p))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fortran_numbers() {
        assert_eq!(parse_number("1.23456E+02"), Some(123.456));
        assert_eq!(parse_number("-1.2E-05"), Some(-1.2e-5));
        assert_eq!(parse_number("1.234-100"), Some(1.234e-100));
        assert_eq!(parse_number("-1.234+100"), Some(-1.234e100));
        assert_eq!(parse_number("1.5D+03"), Some(1500.0));
        assert!(parse_number("***").unwrap().is_nan());
        assert_eq!(parse_number("12"), Some(12.0));
        assert_eq!(parse_number("x"), None);
        assert_eq!(parse_number("1.2.3"), None);
    }

    #[test]
    fn glued_numbers_split() {
        let v = all_numbers("-1.31E-01-1.43E-03 1.0-100-2.5+101 7").unwrap();
        assert_eq!(v, vec![-0.131, -1.43e-3, 1.0e-100, -2.5e101, 7.0]);
        // Two-digit signed groups are a new number, not an exponent.
        assert_eq!(all_numbers("1.5-12").unwrap(), vec![1.5, -12.0]);
        assert_eq!(all_numbers("123-456").unwrap(), vec![123.0, -456.0]);
    }

    #[test]
    fn words_and_keys() {
        let t = tokens(" nd#      12  xforce=-1.0E+00 x-disp");
        assert_eq!(t[0], Tok::Word("nd#"));
        assert_eq!(t[1].num(), Some(12.0));
        assert_eq!(t[2], Tok::Word("xforce="));
        assert_eq!(t[3].num(), Some(-1.0));
        assert_eq!(t[4], Tok::Word("x-disp"));
    }
}
