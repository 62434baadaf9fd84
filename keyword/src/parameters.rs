//! A deck as it is, with values set where its author left them: the `*PARAMETER` entries by name,
//! LS-OPT's `<<name>>` marks, and the files it `*INCLUDE`s.
//!
//! An engineer's deck carries its tunable values in `*PARAMETER` cards (type letter and name in
//! one 10-column field, the value in the next, four pairs a card; or the same comma-separated).
//! Setting a value rewrites only that value's field, in the card's own format: fixed columns stay
//! fixed (the value right-aligned in its 10 columns, exact or an error, never truncated), a free
//! card gets the shortest exact text. `*PARAMETER_EXPRESSION` entries are left as they are: the
//! solver evaluates them from the values set here.

use std::collections::HashMap;
use std::ops::Range;

use crate::deck::blocks;
use crate::field;

/// A deck line that cannot be read or set, 1-based, with what was expected.
#[derive(Debug, Clone, PartialEq)]
pub struct DeckError {
    pub line: usize,
    pub column: usize,
    pub message: String,
}

impl std::fmt::Display for DeckError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "line {}, column {}: {}", self.line, self.column, self.message)
    }
}

impl std::error::Error for DeckError {}

/// One `*PARAMETER` entry where it stands.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// Upper case, as LS-DYNA compares names.
    pub name: String,
    /// `R`, `I` or `C`.
    pub kind: char,
    /// 1-based line of its card.
    pub line: usize,
    /// The value's bytes in the line: the 10 fixed columns (which may lie past the end of a short
    /// line), or the token between commas.
    pub value: Range<usize>,
    /// The card is comma-separated.
    pub free: bool,
}

/// The `*PARAMETER` (and `*PARAMETER_LOCAL`) entries of `text`, in order; a name defined twice is
/// an error at its second definition.
pub fn entries(text: &str) -> Result<Vec<Entry>, DeckError> {
    let mut out: Vec<Entry> = Vec::new();
    for block in blocks(text)
        .iter()
        .filter(|b| matches!(b.keyword.as_str(), "PARAMETER" | "PARAMETER_LOCAL"))
    {
        for card in &block.cards {
            for entry in card_entries(card.line, &card.text)? {
                if let Some(first) = out.iter().find(|e| e.name == entry.name) {
                    return Err(DeckError {
                        line: entry.line,
                        column: 1,
                        message: format!(
                            "parameter {} is defined twice (first at line {})",
                            entry.name, first.line
                        ),
                    });
                }
                out.push(entry);
            }
        }
    }
    Ok(out)
}

/// A name field and its value field, as byte ranges of a card.
type Pair = (Range<usize>, Range<usize>);

/// The name/value pairs of one card, and whether it is comma-separated.
fn pairs(text: &str) -> (Vec<Pair>, bool) {
    if text.contains(',') {
        let mut cuts = vec![0];
        cuts.extend(text.match_indices(',').map(|(i, _)| i + 1));
        let spans: Vec<Range<usize>> = cuts
            .iter()
            .enumerate()
            .map(|(k, &a)| a..cuts.get(k + 1).map_or(text.len(), |b| b - 1))
            .collect();
        let pairs = spans
            .chunks(2)
            .map(|c| (c[0].clone(), c.get(1).cloned().unwrap_or(text.len()..text.len())));
        return (pairs.collect(), true);
    }
    let pairs = (0..4).map(|k| (20 * k..20 * k + 10, 20 * k + 10..20 * k + 20));
    (pairs.collect(), false)
}

fn card_entries(line: usize, text: &str) -> Result<Vec<Entry>, DeckError> {
    let (pairs, free) = pairs(text);
    let mut out = Vec::new();
    for (name_at, value) in pairs {
        let field = text
            .get(name_at.start.min(text.len())..name_at.end.min(text.len()))
            .unwrap_or("")
            .trim();
        if field.is_empty() {
            continue;
        }
        let bad = |message: String| DeckError {
            line,
            column: name_at.start + 1,
            message,
        };
        let kind = field.chars().next().unwrap_or(' ').to_ascii_uppercase();
        let name = field[1..].trim().to_ascii_uppercase();
        if !matches!(kind, 'R' | 'I' | 'C') {
            return Err(bad(format!(
                "`{field}`: a parameter's type letter R, I or C, then its name"
            )));
        }
        if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err(bad(format!(
                "`{field}`: a parameter name of letters, digits and `_` after the type letter"
            )));
        }
        out.push(Entry {
            name,
            kind,
            line,
            value,
            free,
        });
    }
    Ok(out)
}

/// `text` with the value of each entry named in `values` (upper-case names) set in its card's
/// format, and the names it set. A value that does not fit its 10 columns exactly, a non-integral
/// value for an `I` entry, or a number for a `C` entry is an error at the entry's line.
pub fn set(text: &str, values: &HashMap<String, f64>) -> Result<(String, Vec<String>), DeckError> {
    let found = entries(text)?;
    let mut lines: Vec<String> = text.split('\n').map(str::to_string).collect();
    let mut set = Vec::new();
    for e in found.iter().filter(|e| values.contains_key(&e.name)) {
        let v = values[&e.name];
        let written = value_text(e, v).map_err(|message| DeckError {
            line: e.line,
            column: e.value.start + 1,
            message,
        })?;
        let line = &mut lines[e.line - 1];
        let cr = line.ends_with('\r');
        let body = line.trim_end_matches('\r');
        // A fixed card shorter than its value field is padded out to it.
        let mut body = format!("{body:<width$}", width = e.value.start);
        let end = e.value.end.min(body.len());
        body.replace_range(e.value.start..end, &written);
        *line = if cr { format!("{body}\r") } else { body };
        set.push(e.name.clone());
    }
    Ok((lines.join("\n"), set))
}

/// The value's text for its entry: 10 right-aligned columns, or the shortest exact text in a free
/// card (kept 20 characters at most, LS-DYNA's free-format limit).
fn value_text(e: &Entry, v: f64) -> Result<String, String> {
    let integral = || {
        (v.fract() == 0.0 && v.abs() < 1e15)
            .then_some(v as i64)
            .ok_or_else(|| format!("parameter {} is an integer (I), {v} is not", e.name))
    };
    let written = match (e.kind, e.free) {
        ('R', false) => field::real(v, 10),
        ('R', true) => field::real_text(v, 20),
        ('I', false) => field::int(integral()?, 10),
        ('I', true) => field::int(integral()?, 20).map(|s| s.trim().to_string()),
        _ => {
            return Err(format!(
                "parameter {} is text (C): it cannot take the number {v}",
                e.name
            ));
        }
    };
    written.map_err(|err| format!("parameter {}: {err}", e.name))
}

/// An LS-OPT substitution mark: `<<name>>` (the shortest exact text), `<<name:W>>` (right-aligned
/// in W columns, exact or an error) or `<<name:iW>>` (an integer in W columns).
#[derive(Debug, Clone, PartialEq)]
pub struct Mark {
    pub name: String,
    pub line: usize,
    /// The mark's bytes in the line, `<<` to `>>`.
    pub span: Range<usize>,
    pub width: Option<usize>,
    pub integer: bool,
}

/// The marks of `text`, in order.
pub fn marks(text: &str) -> Result<Vec<Mark>, DeckError> {
    let mut out = Vec::new();
    for (i, line) in text.split('\n').enumerate() {
        let mut from = 0;
        while let Some(a) = line[from..].find("<<").map(|a| a + from) {
            let bad = |message: String| DeckError {
                line: i + 1,
                column: a + 1,
                message,
            };
            let b = line[a..]
                .find(">>")
                .map(|b| a + b)
                .ok_or_else(|| bad("`<<` without its closing `>>`".into()))?;
            let inner = line[a + 2..b].trim();
            let (name, format) = inner.split_once(':').unwrap_or((inner, ""));
            let name = name.trim();
            if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                return Err(bad(format!(
                    "`<<{inner}>>`: a variable name (an expression is not supported)"
                )));
            }
            let format = format.trim();
            let integer = format.starts_with(['i', 'I']);
            let width = match format.trim_start_matches(['i', 'I']) {
                "" => None,
                w => Some(
                    w.parse::<usize>()
                        .map_err(|_| bad(format!("`<<{inner}>>`: a field width after `:`")))?,
                ),
            };
            out.push(Mark {
                name: name.to_string(),
                line: i + 1,
                span: a..b + 2,
                width,
                integer,
            });
            from = b + 2;
        }
    }
    Ok(out)
}

/// `text` with every mark replaced by its variable's value (names compared in upper case); a mark
/// whose variable is not in `values` is an error.
pub fn set_marks(text: &str, values: &HashMap<String, f64>) -> Result<String, DeckError> {
    let found = marks(text)?;
    let mut lines: Vec<String> = text.split('\n').map(str::to_string).collect();
    // Right to left within a line, so earlier spans stay where they are.
    for m in found.iter().rev() {
        let bad = |message: String| DeckError {
            line: m.line,
            column: m.span.start + 1,
            message,
        };
        let v = *values
            .get(&m.name.to_ascii_uppercase())
            .ok_or_else(|| bad(format!("`{}` is not a variable of the study", m.name)))?;
        let written = match (m.integer, m.width) {
            (true, w) if v.fract() == 0.0 => field::int(v as i64, w.unwrap_or(20))
                .map(|s| s.trim_start().to_string())
                .map(|s| pad(&s, w)),
            (true, _) => return Err(bad(format!("`{}` is an integer mark, {v} is not", m.name))),
            (false, Some(w)) => field::real(v, w),
            (false, None) => field::real_text(v, 20),
        }
        .map_err(|e| bad(format!("`{}`: {e}", m.name)))?;
        lines[m.line - 1].replace_range(m.span.clone(), &written);
    }
    Ok(lines.join("\n"))
}

fn pad(s: &str, width: Option<usize>) -> String {
    match width {
        Some(w) => format!("{s:>w$}"),
        None => s.to_string(),
    }
}

/// A file a deck includes: the keyword's line and the file name as written (relative to the
/// including deck, or absolute).
#[derive(Debug, Clone, PartialEq)]
pub struct Include {
    pub line: usize,
    pub file: String,
}

/// The files `text` includes: every card of `*INCLUDE`, the first card of `*INCLUDE_TRANSFORM` and
/// the other `*INCLUDE_…` forms that name one file, a name continued over cards ending in ` +`
/// joined. `*INCLUDE_PATH` lists directories, not files, and is left out.
pub fn includes(text: &str) -> Vec<Include> {
    let mut out = Vec::new();
    for block in blocks(text)
        .iter()
        .filter(|b| b.keyword.starts_with("INCLUDE") && !b.keyword.starts_with("INCLUDE_PATH"))
    {
        let mut name = String::new();
        let mut start = block.line;
        for card in &block.cards {
            let t = card.text.trim();
            if name.is_empty() {
                start = card.line;
            }
            match t.strip_suffix(" +") {
                Some(part) => name.push_str(part),
                None => {
                    name.push_str(t);
                    if !name.is_empty() {
                        out.push(Include {
                            line: start,
                            file: std::mem::take(&mut name),
                        });
                    }
                    if block.keyword != "INCLUDE" {
                        break;
                    }
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::deck::{Param, read_parameter_card};

    fn values(pairs: &[(&str, f64)]) -> HashMap<String, f64> {
        pairs.iter().map(|(n, v)| (n.to_string(), *v)).collect()
    }

    /// Reads every `*PARAMETER` value back with the crate's reader.
    fn read_back(text: &str) -> HashMap<String, Param> {
        let mut table = HashMap::new();
        for b in blocks(text).iter().filter(|b| b.keyword == "PARAMETER") {
            for c in &b.cards {
                read_parameter_card(c, &mut table).unwrap();
            }
        }
        table
    }

    const DECK: &str = "*KEYWORD\n$ tunable values\n*PARAMETER\nR SIGY         185.0I NIP              5\nR ETAN           0.0\n*PARAMETER_EXPRESSION\nR SIGU     SIGY*1.2\n*PARAMETER\nR THICK,0.05,R RHO,2.7e-9\n*END\n";

    #[test]
    fn values_are_set_in_their_fields_and_read_back() {
        let (out, named) = set(
            DECK,
            &values(&[("SIGY", 184.644), ("NIP", 3.0), ("THICK", 0.0625), ("SIGU", 1.0)]),
        )
        .unwrap();
        assert_eq!(named, ["SIGY", "NIP", "THICK"], "the expression is not an entry");
        let lines: Vec<&str> = out.lines().collect();
        assert_eq!(lines[3], "R SIGY       184.644I NIP              3");
        assert_eq!(lines[8], "R THICK,0.0625,R RHO,2.7e-9");
        assert_eq!(lines[6], "R SIGU     SIGY*1.2", "expressions stay as they are");
        let back = read_back(&out);
        assert_eq!(back["SIGY"], Param::Real(184.644));
        assert_eq!(back["NIP"], Param::Int(3));
        assert_eq!(back["THICK"], Param::Real(0.0625));
        assert_eq!(back["ETAN"], Param::Real(0.0), "an entry not named stays");
        // Everything else byte for byte.
        let (same, _) = set(DECK, &HashMap::new()).unwrap();
        assert_eq!(same, DECK);
    }

    #[test]
    fn what_cannot_be_set_is_an_error_at_its_line() {
        let too_wide = set(DECK, &values(&[("SIGY", 184.64445967236142)])).unwrap_err();
        assert_eq!((too_wide.line, too_wide.column), (4, 11));
        assert!(
            too_wide.message.contains("parameter SIGY") && too_wide.message.contains("10-character"),
            "{too_wide}"
        );
        let not_integral = set(DECK, &values(&[("NIP", 2.5)])).unwrap_err();
        assert_eq!(not_integral.line, 4);
        assert!(not_integral.message.contains("integer"), "{not_integral}");
        let twice = entries("*PARAMETER\nR A            1.0\n*PARAMETER\nR A            2.0\n").unwrap_err();
        assert_eq!(twice.line, 4);
        assert!(twice.message.contains("defined twice (first at line 2)"), "{twice}");
        let letter = entries("*PARAMETER\nX A            1.0\n").unwrap_err();
        assert_eq!((letter.line, letter.column), (2, 1));
    }

    #[test]
    fn a_short_card_is_padded_to_its_value_field() {
        let (out, _) = set("*PARAMETER\nR SIGY\n", &values(&[("SIGY", 200.0)])).unwrap();
        assert_eq!(out, "*PARAMETER\nR SIGY         200.0\n");
        let (crlf, _) = set("*PARAMETER\r\nR SIGY         185.0\r\n", &values(&[("SIGY", 200.0)])).unwrap();
        assert_eq!(crlf, "*PARAMETER\r\nR SIGY         200.0\r\n");
    }

    #[test]
    fn ls_opt_marks_are_replaced_in_their_widths() {
        let text = "*MAT_PIECEWISE\n         1   2.7e-09<<E:10>>      0.33<<sigy>>\n  <<nip:i10>>\n";
        let found = marks(text).unwrap();
        assert_eq!(
            found
                .iter()
                .map(|m| (m.name.as_str(), m.width, m.integer))
                .collect::<Vec<_>>(),
            [("E", Some(10), false), ("sigy", None, false), ("nip", Some(10), true)]
        );
        let out = set_marks(text, &values(&[("E", 70000.0), ("SIGY", 184.5), ("NIP", 5.0)])).unwrap();
        assert_eq!(
            out,
            "*MAT_PIECEWISE\n         1   2.7e-09   70000.0      0.33184.5\n           5\n"
        );
        let unknown = set_marks(text, &values(&[("E", 1.0), ("NIP", 5.0)])).unwrap_err();
        assert_eq!((unknown.line, unknown.column), (2, 39));
        assert!(unknown.message.contains("`sigy` is not a variable"), "{unknown}");
        assert!(
            marks("<<a+b>>")
                .unwrap_err()
                .message
                .contains("expression is not supported")
        );
        assert!(marks("x <<a").unwrap_err().message.contains("closing"));
    }

    #[test]
    fn includes_are_listed_with_their_lines() {
        let text = "*KEYWORD\n*INCLUDE\nmesh.k\n$ a comment\nsub/parts.k\n*INCLUDE_PATH\n/opt/lib\n*INCLUDE_TRANSFORM\nlong/dir/ +\nname.k\n         0         0\n*END\n";
        let found = includes(text);
        let files: Vec<(usize, &str)> = found.iter().map(|i| (i.line, i.file.as_str())).collect();
        assert_eq!(files, [(3, "mesh.k"), (5, "sub/parts.k"), (9, "long/dir/name.k")]);
    }
}
