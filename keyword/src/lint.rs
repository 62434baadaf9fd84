//! A lint for rendered keyword decks, used by the tests and available to the run engine.
//!
//! [`lint`] checks the main deck and, through the caller's resolver, every file it `*INCLUDE`s:
//! - `*KEYWORD` first and `*END` last in the main deck;
//! - no card line longer than 80 columns and no blank card lines (LS-DYNA reads a blank line as
//!   a card with all defaults, which is never what a template means);
//! - on the keywords it knows (see [`schema`]), every fixed field holds one token of the right
//!   kind (integer, real, text) — a value that spilled over its field shows up as a malformed
//!   neighbour — and no card has more fields than the keyword defines;
//! - every `&name` is defined by a `*PARAMETER` before it is used, and fits its field;
//! - every `*INCLUDE` file (the name is on the next line) can be resolved.

use std::collections::HashMap;
use std::fmt;

use super::deck::{self, Block, Card, Param};

/// One thing wrong with a deck, at `file:line:column` (1-based).
#[derive(Debug, Clone, PartialEq)]
pub struct Problem {
    pub file: String,
    pub line: usize,
    pub column: usize,
    pub message: String,
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}: {}", self.file, self.line, self.column, self.message)
    }
}

/// The kind of one fixed field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kind {
    Int,
    Real,
    Text,
    /// A `*PARAMETER` name field: type letter then name.
    ParamName,
    /// A `*PARAMETER` value field: its kind follows the name field before it.
    ParamValue,
}

/// A card layout: field widths and kinds.
pub type Layout = &'static [(usize, Kind)];

/// How a keyword's cards are laid out: the fixed cards in order, then an optional card that
/// repeats until the next keyword.
pub struct Schema {
    pub cards: &'static [Layout],
    pub repeat: Option<Layout>,
}

use Kind::{Int as I, Real as R, Text as A};

const I10: (usize, Kind) = (10, I);
const R10: (usize, Kind) = (10, R);
const PN: (usize, Kind) = (10, Kind::ParamName);
const PV: (usize, Kind) = (10, Kind::ParamValue);
const TITLE: Layout = &[(80, A)];
const PART_CARD: Layout = &[I10, I10, I10, I10, I10, I10, I10, I10];
const CONTACT: &[Layout] = &[
    &[I10, I10, I10, I10, I10, I10, I10, I10],
    &[R10, R10, R10, R10, R10, I10, R10, R10],
    &[R10, R10, R10, R10, R10, R10, R10, R10],
];
const DATABASE: &[Layout] = &[&[R10, I10, I10, I10]];

/// The layout of the keywords this lint knows (the ones the honeycomb template writes).
pub fn schema(keyword: &str) -> Option<Schema> {
    let s = |cards: &'static [Layout], repeat: Option<Layout>| Some(Schema { cards, repeat });
    match keyword {
        "KEYWORD" | "END" => s(&[], None),
        "TITLE" | "INCLUDE" => s(&[TITLE], None),
        "PARAMETER" => s(&[], Some(&[PN, PV, PN, PV, PN, PV, PN, PV])),
        "CONTROL_TERMINATION" => s(&[&[R10, I10, R10, R10, R10, I10]], None),
        "CONTROL_TIMESTEP" => s(&[&[R10, R10, I10, R10, R10, I10, I10, I10]], None),
        "CONTROL_HOURGLASS" => s(&[&[I10, R10]], None),
        "HOURGLASS" => s(&[&[I10, I10, R10, I10, R10, R10, R10, R10]], None),
        "DATABASE_RCFORC" | "DATABASE_GLSTAT" | "DATABASE_NODOUT" | "DATABASE_MATSUM" => s(DATABASE, None),
        "DATABASE_BINARY_D3PLOT" => s(&[&[R10, I10, I10, I10, I10]], None),
        "DATABASE_HISTORY_NODE" => s(&[], Some(PART_CARD)),
        "PART" => s(&[TITLE, PART_CARD], None),
        "PART_INERTIA" => s(
            &[TITLE, PART_CARD, &[R10, R10, R10, R10, I10, I10], &[R10; 6], &[R10; 6]],
            None,
        ),
        "SECTION_SHELL" => s(
            &[
                &[I10, I10, R10, I10, R10, R10, I10, I10],
                &[R10, R10, R10, R10, R10, R10, I10, I10],
            ],
            None,
        ),
        "MAT_PLASTIC_KINEMATIC" | "MAT_003" => s(&[&[I10, R10, R10, R10, R10, R10, R10], &[R10; 4]], None),
        "MAT_RIGID" | "MAT_020" => s(&[&[I10, R10, R10, R10, R10, R10, R10, R10], &[R10; 3], &[R10; 6]], None),
        "SET_PART_LIST" => s(&[&[I10, R10, R10, R10, R10, (10, A)]], Some(PART_CARD)),
        "DEFINE_CURVE" => s(&[&[I10, I10, R10, R10, R10, R10, I10, I10]], Some(&[(20, R), (20, R)])),
        "BOUNDARY_PRESCRIBED_MOTION_RIGID" => s(&[&[I10, I10, I10, I10, R10, I10, R10, R10]], None),
        "INITIAL_VELOCITY_RIGID_BODY" => s(&[&[I10, R10, R10, R10, R10, R10, R10]], None),
        "CONTACT_AUTOMATIC_NODES_TO_SURFACE" | "CONTACT_AUTOMATIC_SINGLE_SURFACE" => s(CONTACT, None),
        "CRUSHSIM_TEST" => s(&[&[(10, A), R10]], None),
        "NODE" => s(&[], Some(&[(8, I), (16, R), (16, R), (16, R), (8, I), (8, I)])),
        "ELEMENT_SHELL" => s(&[], Some(&[(8, I); 10])),
        _ => None,
    }
}

/// Lints `main` (named `main_name` in messages); `resolve` returns the text of an included file
/// by the name written in the deck, or `None` when it does not exist.
pub fn lint(main: &str, resolve: &dyn Fn(&str) -> Option<String>) -> Vec<Problem> {
    lint_named("main.k", main, resolve)
}

/// [`lint`] with the main deck's name for messages.
pub fn lint_named(main_name: &str, main: &str, resolve: &dyn Fn(&str) -> Option<String>) -> Vec<Problem> {
    let mut linter = Linter {
        problems: Vec::new(),
        params: HashMap::new(),
        depth: 0,
    };
    linter.frame(main_name, main);
    linter.file(main_name, main, resolve);
    linter.problems
}

struct Linter {
    problems: Vec<Problem>,
    params: HashMap<String, Param>,
    depth: usize,
}

impl Linter {
    fn push(&mut self, file: &str, line: usize, column: usize, message: impl Into<String>) {
        self.problems.push(Problem {
            file: file.to_string(),
            line,
            column,
            message: message.into(),
        });
    }

    /// `*KEYWORD` first and `*END` last (ignoring comments and trailing blank lines).
    fn frame(&mut self, name: &str, text: &str) {
        let meaningful: Vec<(usize, &str)> = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.starts_with('$') && !l.trim().is_empty())
            .collect();
        match meaningful.first() {
            Some((_, l)) if l.to_ascii_uppercase().starts_with("*KEYWORD") => {}
            Some((i, _)) => self.push(name, i + 1, 1, "the deck must start with *KEYWORD"),
            None => self.push(name, 1, 1, "the deck is empty"),
        }
        match meaningful.last() {
            Some((_, l)) if l.trim_end().eq_ignore_ascii_case("*END") => {}
            Some((i, _)) => self.push(name, i + 1, 1, "*END must be the last line of the deck"),
            None => {}
        }
    }

    fn file(&mut self, name: &str, text: &str, resolve: &dyn Fn(&str) -> Option<String>) {
        self.line_lengths(name, text);
        for block in deck::blocks(text) {
            self.block(name, &block);
            if block.keyword == "INCLUDE" {
                self.include(name, &block, resolve);
            }
        }
    }

    fn line_lengths(&mut self, name: &str, text: &str) {
        let lines: Vec<&str> = text.lines().collect();
        let last_content = lines.iter().rposition(|l| !l.trim().is_empty()).unwrap_or(0);
        for (i, line) in lines.iter().enumerate() {
            if line.starts_with('$') {
                continue;
            }
            let n = line.trim_end_matches('\r').chars().count();
            if n > 80 {
                self.push(
                    name,
                    i + 1,
                    81,
                    format!("line is {n} columns long; fixed format reads 80"),
                );
            }
            if line.trim().is_empty() && i < last_content {
                self.push(
                    name,
                    i + 1,
                    1,
                    "blank line: LS-DYNA reads it as a card with all defaults",
                );
            }
        }
    }

    fn include(&mut self, name: &str, block: &Block, resolve: &dyn Fn(&str) -> Option<String>) {
        let Some(card) = block.cards.first() else {
            return self.push(name, block.line, 1, "*INCLUDE needs the file name on the next line");
        };
        let file = card.text.trim();
        match resolve(file) {
            None => self.push(name, card.line, 1, format!("included file {file:?} does not exist")),
            Some(_) if self.depth >= 8 => self.push(name, card.line, 1, "includes nested deeper than 8"),
            Some(text) => {
                self.depth += 1;
                self.file(file, &text, resolve);
                self.depth -= 1;
            }
        }
    }

    fn block(&mut self, name: &str, block: &Block) {
        let schema = schema(&block.keyword);
        for (k, card) in block.cards.iter().enumerate() {
            let layout = schema.as_ref().and_then(|s| s.cards.get(k).copied().or(s.repeat));
            if schema.is_some() && layout.is_none() {
                self.push(
                    name,
                    card.line,
                    1,
                    format!("*{} has only {} card(s) here", block.keyword, k),
                );
                continue;
            }
            if block.keyword == "PARAMETER"
                && let Err(e) = deck::read_parameter_card(card, &mut self.params)
            {
                self.push(name, e.line, e.column, e.message);
            }
            self.card(name, card, layout);
        }
    }

    fn card(&mut self, name: &str, card: &Card, layout: Option<Layout>) {
        let widths: Vec<usize> = layout
            .map(|l| l.iter().map(|(w, _)| *w).collect())
            .unwrap_or_else(|| vec![10]);
        let free = card.text.contains(',');
        let mut column = 1;
        let mut prev_kind = ' ';
        for (k, field) in deck::fields(&card.text, &widths).into_iter().enumerate() {
            let spec = layout.map(|l| l.get(k).copied());
            let width = widths.get(k).copied().unwrap_or(10);
            match spec {
                Some(None) if !field.trim().is_empty() => self.push(
                    name,
                    card.line,
                    column,
                    format!("extra field {:?} beyond the card's layout", field.trim()),
                ),
                Some(Some((_, kind))) => {
                    if let Some(message) = self.check_field(field, kind, width, free, &mut prev_kind) {
                        self.push(name, card.line, column, message);
                    }
                }
                _ => {
                    if let Some(message) = self.check_reference(field, width) {
                        self.push(name, card.line, column, message);
                    }
                }
            }
            column += if free { field.len() + 1 } else { field.len() };
        }
    }

    fn check_field(&self, field: &str, kind: Kind, width: usize, free: bool, prev: &mut char) -> Option<String> {
        let t = field.trim();
        if free && t.len() > width {
            return Some(format!("{t:?} is longer than its {width}-character field"));
        }
        if kind == Kind::ParamName {
            *prev = t.chars().next().unwrap_or(' ').to_ascii_uppercase();
            return None; // read_parameter_card reports bad names
        }
        if t.is_empty() || kind == Kind::Text {
            return None;
        }
        if deck::reference(t).is_some() {
            return self.check_reference(field, width);
        }
        let ok = match (kind, *prev) {
            (Kind::Int, _) | (Kind::ParamValue, 'I') => {
                deck::parse_int(t).is_some() && !t.contains(char::is_whitespace)
            }
            (Kind::Real, _) | (Kind::ParamValue, 'R') => deck::parse_real(t).is_some(),
            _ => true,
        };
        let what = if kind == Kind::Int || *prev == 'I' {
            "an integer"
        } else {
            "a real number"
        };
        (!ok).then(|| format!("field {field:?} is not {what} (a value spilling over its {width}-character field?)"))
    }

    fn check_reference(&self, field: &str, width: usize) -> Option<String> {
        let t = field.trim();
        let (name, _) = deck::reference(t)?;
        if t.len() > width {
            return Some(format!("reference {t:?} does not fit its {width}-character field"));
        }
        if name.is_empty() || name.contains(|c: char| !(c.is_ascii_alphanumeric() || c == '_')) {
            return Some(format!("malformed reference {t:?}"));
        }
        (!self.params.contains_key(&name)).then(|| format!("&{name} is not defined by a *PARAMETER before this line"))
    }
}
