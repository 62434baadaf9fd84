//! Tera 2 filters for fixed-format keyword fields, built on `lsdyna_keyword::field`.
//!
//! Register them on the engine's `tera::Tera` with [`register`]:
//!
//! | filter | writes | kwargs |
//! |---|---|---|
//! | `dyna_real` | a real, right-aligned, exact (shortest round-trip text) or an error | `width` (10) |
//! | `dyna_int`  | an integer (an integral real is accepted), right-aligned | `width` (10) |
//! | `dyna_text` | text or an `&name` reference, left-aligned | `width` (10) |
//!
//! A value that does not fit fails the render with the field error's message (value and width),
//! never a truncated field.

use tera::{Error, Kwargs, State, Tera, TeraResult, Value};

use lsdyna_keyword::field;

/// Registers `dyna_real`, `dyna_int` and `dyna_text` on `tera`.
pub fn register(tera: &mut Tera) {
    tera.register_filter("dyna_real", dyna_real);
    tera.register_filter("dyna_int", dyna_int);
    tera.register_filter("dyna_text", dyna_text);
}

fn width(kwargs: &Kwargs) -> TeraResult<usize> {
    Ok(kwargs.get::<usize>("width")?.unwrap_or(10))
}

fn number(value: &Value, filter: &str) -> TeraResult<f64> {
    value
        .as_f64()
        .or_else(|| value.as_i64().map(|v| v as f64))
        .ok_or_else(|| Error::message(format!("{filter}: expected a number, got {value}")))
}

/// `{{ x | dyna_real }}`: a real in a fixed field.
pub fn dyna_real(value: Value, kwargs: Kwargs, _: &State) -> TeraResult<String> {
    let v = number(&value, "dyna_real")?;
    field::real(v, width(&kwargs)?).map_err(|e| Error::message(format!("dyna_real: {e}")))
}

/// `{{ n | dyna_int }}`: an integer in a fixed field.
pub fn dyna_int(value: Value, kwargs: Kwargs, _: &State) -> TeraResult<String> {
    let v = match value.as_i64() {
        Some(i) => i,
        None => {
            let f = number(&value, "dyna_int")?;
            if f.fract() != 0.0 || f.abs() > 9.0e15 {
                return Err(Error::message(format!("dyna_int: {f} is not an integer")));
            }
            f as i64
        }
    };
    field::int(v, width(&kwargs)?).map_err(|e| Error::message(format!("dyna_int: {e}")))
}

/// `{{ s | dyna_text(width=80) }}`: text in a fixed field.
pub fn dyna_text(value: Value, kwargs: Kwargs, _: &State) -> TeraResult<String> {
    let s = match value.as_str() {
        Some(s) => s.to_string(),
        None => value.to_string(),
    };
    field::text(&s, width(&kwargs)?).map_err(|e| Error::message(format!("dyna_text: {e}")))
}
