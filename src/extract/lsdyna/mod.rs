//! Readers for LS-DYNA ASCII output files: one module per file type, each with `parse(file, text)` and
//! `read(file)` returning a typed value or an [`InputError`](crate::error::InputError) that names the
//! file, the line and what was expected. No reader panics on any input (property-tested).
//!
//! Formats come from facts.md and from LSTC's `l2a.c` (the binout-to-ASCII converter, which prints the
//! same layouts the solver writes); details are in each module's doc and in
//! `fixtures/format-samples/README.md`. Everything is parsed by tokens, not by columns.
//!
//! Beyond parsing: [`controls`] reads what a deck asks of its outputs, [`complete`] checks parsed
//! histories against it, and [`quality`] computes the energy figures of glstat and their gates.

pub mod binout;
pub mod bndout;
pub mod complete;
pub mod controls;
pub mod d3hsp;
pub mod glstat;
pub mod nodout;
pub mod quality;
pub mod rcforc;
pub mod secforc;
pub mod spcforc;
pub mod termination;
pub mod text;
