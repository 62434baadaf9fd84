//! The template engine: Tera 2 with autoescaping off (solver inputs are not HTML) and the
//! fixed-field filters of [`super::dyna_filters`] (`dyna_real`, `dyna_int`, `dyna_text`)
//! registered. Every error, at parse or at render time, names the template file and the line. The
//! study parses its templates with it when it is loaded; the render stage renders every run with it.
//!
//! ```
//! use lab::base::template::{Renderer, Template};
//! let t = Template { file: "in.txt.tera".into(), output: "in.txt".into(), source: "E = {{ E }}\n".into() };
//! let r = Renderer::new(&[t]).unwrap();
//! let mut ctx = tera::Context::new();
//! ctx.insert("E", &60000.5);
//! assert_eq!(r.render(&ctx).unwrap()[0].1, b"E = 60000.5\n");
//! ```

use std::path::PathBuf;

use tera::{Context, ErrorKind, Tera};

use super::dyna_filters;
use crate::error::InputError;

/// A Tera template: where it was read from, where it is rendered to, and its text (already parsed
/// once without error).
#[derive(Debug, Clone)]
pub struct Template {
    /// The template file (relative paths resolved against the study file's directory).
    pub file: PathBuf,
    /// Its name in the run directory: the file name without `.tera`.
    pub output: PathBuf,
    pub source: String,
}

/// The rendered inputs of one run: (path relative to the run directory, bytes).
pub type Inputs = Vec<(PathBuf, Vec<u8>)>;

/// A study's templates, parsed once, ready to render any number of runs; and its deck used as it
/// is, when it names one.
pub struct Renderer {
    tera: Tera,
    templates: Vec<Template>,
    deck: Option<super::deck::Deck>,
}

/// The Tera name of template `i` (no suffix, so nothing is autoescaped by name either).
fn name(i: usize) -> String {
    format!("template-{i}")
}

impl Renderer {
    /// Parses every template; a syntax error names the template file, line and column.
    pub fn new(templates: &[Template]) -> Result<Self, InputError> {
        let mut tera = Tera::new();
        tera.autoescape_on(Vec::<&str>::new());
        dyna_filters::register(&mut tera); // dyna_real / dyna_int / dyna_text for keyword decks
        for (i, t) in templates.iter().enumerate() {
            tera.add_raw_template(&name(i), &t.source).map_err(|e| located(t, &e))?;
        }
        Ok(Renderer {
            tera,
            templates: templates.to_vec(),
            deck: None,
        })
    }

    /// The templates and a deck used as it is (`simulation.solver.deck`), rendered after them.
    pub fn with_deck(mut self, deck: Option<&super::deck::Deck>) -> Self {
        self.deck = deck.cloned();
        self
    }

    /// Renders every template with `context`, in the study's order.
    pub fn render(&self, context: &Context) -> Result<Inputs, InputError> {
        let mut inputs: Inputs = self
            .templates
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let text = self.tera.render(&name(i), context).map_err(|e| located(t, &e))?;
                Ok((t.output.clone(), text.into_bytes()))
            })
            .collect::<Result<_, InputError>>()?;
        if let Some(deck) = &self.deck {
            inputs.extend(deck.render(context)?);
        }
        Ok(inputs)
    }
}

/// A Tera error as an input error at the template's file and line.
fn located(template: &Template, error: &tera::Error) -> InputError {
    let (what, report) = match error.kind() {
        ErrorKind::SyntaxError(r) => ("template syntax error", r),
        ErrorKind::RenderingError(r) => ("template rendering error", r),
        other => return InputError::file(&template.file, format!("template error: {other}")),
    };
    let span = report.span();
    let message = format!("{what}: {}", report.message());
    if span.start_line == 0 {
        return InputError::file(&template.file, message);
    }
    InputError::at(
        &template.file,
        &template.source,
        span.start_line,
        span.start_col + 1,
        message,
    )
}

/// Adds a model extension's template variables to a run's context (they override constants).
pub fn extend(ctx: &mut Context, variables: &[(String, f64)]) {
    for (name, value) in variables {
        ctx.insert(name.clone(), value);
    }
}
