//! Closed-form expressions (`simulation.expression`, hypothesis terms), parsed by exmex.
//!
//! An [`Expression`] is compiled against a [`Symbols`] table: every name it uses must be one of
//! the table's, and evaluation takes the values in the table's order. exmex's built-in constants
//! are left out on purpose: its `E` (Euler's number) would silently shadow a Young's modulus `E`.

use exmex::{Express, FlatEx, FloatOpsFactory, MakeOperators, Operator};

/// exmex's float operators without its named constants (`E`, `PI`, `π`, `τ`, ...).
#[derive(Clone, Debug)]
pub struct NoConstants;

impl MakeOperators<f64> for NoConstants {
    fn make<'a>() -> Vec<Operator<'a, f64>> {
        FloatOpsFactory::<f64>::make()
            .into_iter()
            .filter(|op| op.constant().is_none())
            .collect()
    }
}

type Flat = FlatEx<f64, NoConstants>;

/// The names an expression may use, in the order their values are passed to [`Expression::eval`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Symbols {
    names: Vec<String>,
}

impl Symbols {
    pub fn new(names: impl IntoIterator<Item = impl Into<String>>) -> Self {
        Symbols {
            names: names.into_iter().map(Into::into).collect(),
        }
    }

    pub fn names(&self) -> &[String] {
        &self.names
    }

    pub fn index(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    pub fn len(&self) -> usize {
        self.names.len()
    }

    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }
}

/// Why an expression did not compile. `offset` is a character offset into the expression text.
#[derive(Debug, Clone, PartialEq)]
pub struct ExprError {
    pub message: String,
    pub offset: Option<usize>,
}

/// Where an unknown name is a mathematical constant: how to define it (none is built in, so that
/// exmex's `E` never shadows a Young's modulus).
fn constant_hint(name: &str) -> String {
    let value = match name {
        "pi" | "PI" | "Pi" | "π" => "3.141592653589793",
        "e" => "2.718281828459045",
        _ => return String::new(),
    };
    format!(" (no constant is built in: define it under `constants`, e.g. `{name}: {value}`)")
}

/// A parsed expression bound to a symbol table.
#[derive(Debug, Clone)]
pub struct Expression {
    text: String,
    flat: Flat,
    /// For each exmex variable (exmex sorts them by name), its index in the symbol table.
    slots: Vec<usize>,
}

impl Expression {
    pub fn compile(text: &str, symbols: &Symbols) -> Result<Expression, ExprError> {
        let flat = Flat::parse(text).map_err(|e| ExprError {
            message: e.msg().to_string(),
            offset: None,
        })?;
        let slots = flat
            .var_names()
            .iter()
            .map(|name| {
                symbols.index(name).ok_or_else(|| ExprError {
                    message: format!(
                        "unknown symbol `{name}`; defined are: {}{}",
                        if symbols.is_empty() {
                            "(none)".to_string()
                        } else {
                            symbols.names().join(", ")
                        },
                        constant_hint(name)
                    ),
                    offset: find_identifier(text, name),
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Expression {
            text: text.to_string(),
            flat,
            slots,
        })
    }

    pub fn text(&self) -> &str {
        &self.text
    }

    /// Whether the expression uses the symbol at `index` of its table.
    pub fn uses(&self, index: usize) -> bool {
        self.slots.contains(&index)
    }

    /// The exponents written as constants in the expression (`h^3`, `t^(5/3)`, `c^-0.5`), in the
    /// order they appear; an exponent that is not a constant (`x^a`) is left out. The discovery
    /// library adds the fractional ones to its exponents (a simulation's own scaling laws).
    pub fn exponents(&self) -> Vec<f64> {
        let chars: Vec<char> = self.text.chars().collect();
        let mut out = Vec::new();
        for (i, _) in chars.iter().enumerate().filter(|(_, c)| **c == '^') {
            let mut j = i + 1;
            while chars.get(j).is_some_and(|c| c.is_whitespace()) {
                j += 1;
            }
            let written: String = if chars.get(j) == Some(&'(') {
                let mut depth = 0usize;
                let Some(close) = (j..chars.len()).find(|&k| {
                    match chars[k] {
                        '(' => depth += 1,
                        ')' => depth -= 1,
                        _ => {}
                    }
                    depth == 0
                }) else {
                    continue;
                };
                chars[j + 1..close].iter().collect()
            } else {
                let mut k = j;
                if chars.get(k).is_some_and(|c| *c == '-' || *c == '+') {
                    k += 1;
                }
                while chars.get(k).is_some_and(|c| c.is_ascii_digit() || *c == '.') {
                    k += 1;
                }
                chars[j..k].iter().collect()
            };
            if let Ok(e) = Expression::compile(&written, &Symbols::default()) {
                let v = e.eval(&[]);
                if v.is_finite() {
                    out.push(v);
                }
            }
        }
        out
    }

    /// Evaluates with `values[i]` bound to the table's i-th symbol. Domain errors give NaN.
    pub fn eval(&self, values: &[f64]) -> f64 {
        let args: Vec<f64> = self.slots.iter().map(|&i| values[i]).collect();
        self.flat.eval(&args).unwrap_or(f64::NAN)
    }
}

/// Character offset of the first whole-word occurrence of `name` in `text`.
fn find_identifier(text: &str, name: &str) -> Option<usize> {
    let is_ident = |c: char| c.is_alphanumeric() || c == '_';
    let mut start = 0;
    while let Some(pos) = text[start..].find(name) {
        let at = start + pos;
        let before = text[..at].chars().next_back();
        let after = text[at + name.len()..].chars().next();
        if !before.is_some_and(is_ident) && !after.is_some_and(is_ident) {
            return Some(text[..at].chars().count());
        }
        start = at + name.len();
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn e_is_a_variable_not_eulers_number() {
        let symbols = Symbols::new(["h", "E", "F", "L", "b"]);
        let expr = Expression::compile("4*F*L^3/(E*b*h^3)", &symbols).unwrap();
        let y = expr.eval(&[8.0, 60_000.0, 600.0, 20.0, 2.0]);
        let expected = 4.0 * 600.0 * 20f64.powi(3) / (60_000.0 * 2.0 * 512.0);
        assert!((y - expected).abs() < 1e-15 * expected, "{y} vs {expected}");
    }

    #[test]
    fn unknown_symbol_names_it_and_its_position() {
        let err = Expression::compile("a*x + bb", &Symbols::new(["a", "x"])).unwrap_err();
        assert!(err.message.contains("`bb`"), "{}", err.message);
        assert_eq!(err.offset, Some(6));
        assert!(!err.message.contains("constants"), "{}", err.message);
    }

    /// `pi` is not built in (nor is any constant): the error says how to define it.
    #[test]
    fn an_unknown_pi_says_how_to_define_it() {
        let err = Expression::compile("pi*x", &Symbols::new(["x"])).unwrap_err();
        assert!(err.message.contains("`pi: 3.141592653589793`"), "{}", err.message);
        assert_eq!(err.offset, Some(0));
    }

    #[test]
    fn exponents_written_as_constants() {
        let symbols = Symbols::new(["t", "c", "s", "a"]);
        let expr = Expression::compile("8.61*s*t^(5/3)/c^(1/3) + t^2 - c ^ -0.5 + t^a", &symbols).unwrap();
        let e = expr.exponents();
        assert_eq!(e.len(), 4, "{e:?}");
        for (got, want) in e.iter().zip([5.0 / 3.0, 1.0 / 3.0, 2.0, -0.5]) {
            assert!((got - want).abs() < 1e-15, "{e:?}");
        }
    }

    #[test]
    fn syntax_error_is_an_error_not_a_panic() {
        assert!(Expression::compile("4*(x", &Symbols::new(["x"])).is_err());
        assert!(Expression::compile("", &Symbols::new(["x"])).is_err());
    }
}
