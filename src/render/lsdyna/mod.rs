//! LS-DYNA keyword decks: the format itself is the workspace crate `lsdyna-keyword` (fixed-width
//! fields, a reader for keyword text, a deck lint); the Tera filters that write its fields are the
//! template engine's ([`crate::base::dyna_filters`]).
//!
//! ```
//! use lab::render::lsdyna::{field, lint};
//! assert_eq!(field::real(185.0, 10).unwrap(), "     185.0");
//! ```

pub use crate::base::dyna_filters as filters;
pub use crate::base::dyna_filters::register;
pub use lsdyna_keyword::{Problem, deck, field, lint};
