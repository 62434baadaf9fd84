//! # lsdyna-keyword — LS-DYNA keyword decks
//!
//! An LS-DYNA input deck is text: `*KEYWORD` lines open blocks of cards, `$` starts a comment,
//! and a card is a line of fixed-width fields (8 columns of 10 characters by default, 20 with a
//! `+` long format). A number that does not fit its field is not truncated by the solver: it reads
//! another number. This crate is that format, with nothing of `lab` in it:
//!
//! - [`field`]: numbers written into fixed-width fields, exactly or as an error ([`field::real`]),
//!   or rounded on request ([`field::fit_real`]).
//! - [`deck`]: a reader for keyword text: blocks, cards, `*PARAMETER` values.
//! - [`parameters`]: a deck as it is with its `*PARAMETER` values and LS-OPT `<<name>>` marks set
//!   in their cards' own format, and the files it `*INCLUDE`s.
//! - [`lint`]: checks a deck (and, through the caller's resolver, every file it `*INCLUDE`s): on
//!   the keywords it knows, every fixed field holds one token of the right kind.
//!
//! ```
//! use lsdyna_keyword::{field, lint};
//! assert_eq!(field::real(185.0, 10).unwrap(), "     185.0");
//! assert!(field::real(137.28391029384012, 10).is_err()); // never truncated
//! let deck = "*KEYWORD\n*PARAMETER\nR SIGY         185.0\n*END\n";
//! assert!(lint::lint(deck, &|_| None).is_empty());
//! ```

pub mod deck;
pub mod field;
pub mod lint;
pub mod parameters;

pub use lint::{Problem, lint};
