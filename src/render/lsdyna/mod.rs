//! LS-DYNA keyword decks: fixed-width fields ([`field`]), Tera filters that write them
//! ([`filters`]), a reader for keyword text ([`deck`]) and a deck lint ([`lint()`]).
//!
//! ```
//! use lab::render::lsdyna::{field, lint};
//! assert_eq!(field::real(185.0, 10).unwrap(), "     185.0");
//! assert!(field::real(137.28391029384012, 10).is_err()); // never truncated
//! let deck = "*KEYWORD\n*PARAMETER\nR SIGY         185.0\n*END\n";
//! assert!(lint::lint(deck, &|_| None).is_empty());
//! ```

pub mod deck;
pub mod field;
pub mod filters;
pub mod lint;

pub use filters::register;
pub use lint::{Problem, lint};
