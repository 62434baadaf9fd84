//! A reader for LS-DYNA keyword text: blocks of card lines, fixed or comma fields, `*PARAMETER`
//! values and `&name` references.
//!
//! Shared by the deck lint and by `crushsim`. It knows the syntax, not the physics: a block is a
//! keyword line (`*SECTION_SHELL`) and the non-comment lines after it up to the next keyword.
//! Lines starting with `$` are comments. A card containing a comma is read as comma-separated
//! free format; otherwise fields are cut at fixed columns (10 characters unless a keyword says
//! otherwise, e.g. `*NODE` uses 8/16).

use std::collections::HashMap;

/// One card line of a block, with its 1-based line number in its file.
#[derive(Debug, Clone, PartialEq)]
pub struct Card {
    pub line: usize,
    pub text: String,
}

/// A keyword and its cards.
#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    /// The keyword, upper case, without the leading `*` or trailing options after a space.
    pub keyword: String,
    pub line: usize,
    pub cards: Vec<Card>,
}

/// Splits keyword text into blocks. Card lines before the first keyword are dropped. A blank line
/// is a card (LS-DYNA reads it as a card with every field at its default).
pub fn blocks(text: &str) -> Vec<Block> {
    let mut out: Vec<Block> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim_end_matches('\r');
        if line.starts_with('$') {
            continue;
        }
        if let Some(rest) = line.strip_prefix('*') {
            let keyword = rest.split_whitespace().next().unwrap_or("").to_ascii_uppercase();
            out.push(Block {
                keyword,
                line: i + 1,
                cards: Vec::new(),
            });
        } else if let Some(block) = out.last_mut() {
            block.cards.push(Card {
                line: i + 1,
                text: line.to_string(),
            });
        }
    }
    out
}

/// The fields of a card: comma-separated if it has a comma, else cut at the given widths
/// (the last width repeats). Fields are returned untrimmed for fixed format.
pub fn fields<'a>(card: &'a str, widths: &[usize]) -> Vec<&'a str> {
    if card.contains(',') {
        return card.split(',').collect();
    }
    let mut out = Vec::new();
    let mut start = 0;
    let mut k = 0;
    while start < card.len() {
        let w = widths.get(k).or(widths.last()).copied().unwrap_or(10);
        let end = (start + w).min(card.len());
        let end = (start..=end)
            .rev()
            .find(|&e| card.is_char_boundary(e))
            .unwrap_or(card.len());
        if end == start {
            break;
        }
        out.push(&card[start..end]);
        start = end;
        k += 1;
    }
    out
}

/// A parameter value.
#[derive(Debug, Clone, PartialEq)]
pub enum Param {
    Real(f64),
    Int(i64),
    Text(String),
}

impl Param {
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Param::Real(v) => Some(*v),
            Param::Int(v) => Some(*v as f64),
            Param::Text(_) => None,
        }
    }
}

/// A `*PARAMETER` entry that could not be read.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamError {
    pub line: usize,
    pub column: usize,
    pub message: String,
}

/// Reads the name/value pairs of one `*PARAMETER` card into `table`.
pub fn read_parameter_card(card: &Card, table: &mut HashMap<String, Param>) -> Result<(), ParamError> {
    let f = fields(&card.text, &[10]);
    for (pair, chunk) in f.chunks(2).enumerate() {
        let column = pair * 20 + 1;
        let name_field = chunk[0].trim();
        if name_field.is_empty() {
            continue;
        }
        let bad = |message: String| ParamError {
            line: card.line,
            column,
            message,
        };
        let mut chars = name_field.chars();
        let kind = chars.next().unwrap_or(' ').to_ascii_uppercase();
        let name = chars.as_str().trim().to_ascii_uppercase();
        if name.is_empty() || name.len() > 9 || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err(bad(format!(
                "bad parameter name field {name_field:?}: a type letter then a name of 1-9 characters"
            )));
        }
        let value_text = chunk.get(1).map(|s| s.trim()).unwrap_or("");
        let value = match kind {
            'R' => parse_real(value_text).map(Param::Real),
            'I' => value_text.parse::<i64>().ok().map(Param::Int),
            'C' => Some(Param::Text(value_text.to_string())),
            _ => return Err(bad(format!("parameter {name}: type letter {kind:?} is not R, I or C"))),
        };
        let value =
            value.ok_or_else(|| bad(format!("parameter {name}: {value_text:?} is not a valid {kind} value")))?;
        table.insert(name, value);
    }
    Ok(())
}

/// Reads a real number as LS-DYNA does: `185`, `185.`, `.5`, `1.85e+02`, `1.85E2`, `1.85d2`.
pub fn parse_real(text: &str) -> Option<f64> {
    let t = text.trim();
    if t.is_empty() || t.contains(char::is_whitespace) {
        return None;
    }
    let t = t.replace(['d', 'D'], "e");
    t.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// Reads an integer field (an integral real such as `3.` is accepted, as LS-DYNA does).
pub fn parse_int(text: &str) -> Option<i64> {
    let t = text.trim();
    t.parse::<i64>().ok().or_else(|| {
        parse_real(t)
            .filter(|v| v.fract() == 0.0 && v.abs() < 9e15)
            .map(|v| v as i64)
    })
}

/// The parameter name a field refers to (`&SIGY` or `-&SIGY`), and whether it is negated.
pub fn reference(field: &str) -> Option<(String, bool)> {
    let t = field.trim();
    let (neg, rest) = match t.strip_prefix('-') {
        Some(r) => (true, r),
        None => (false, t),
    };
    rest.strip_prefix('&').map(|name| (name.to_ascii_uppercase(), neg))
}
