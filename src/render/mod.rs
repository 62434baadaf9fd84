//! Rendering: a study's Tera templates into the input files of one run, in memory.
//!
//! The context of every template is the run's design variables, parameters and the study's
//! constants, each by name as a number, plus `design_name` (the design's name in the experiments
//! file); the runs of a model-extension hypothesis add its variables ([`run_context`]). Rendering
//! happens in memory so that the run key ([`crate::execute::store::run_key`]) can
//! be computed before anything is written; [`crate::execute::RunStore::prepare`] writes the files.
//!
//! Templates are Tera 2 with autoescaping off (solver inputs are not HTML) and the fixed-field
//! filters of [`lsdyna::filters`] (`dyna_real`, `dyna_int`, `dyna_text`) registered. Every error, at parse
//! or at render time, names the template file and the line.
//!
//! ```
//! use lab::render::Renderer;
//! use lab::study::Template;
//! let t = Template { file: "in.txt.tera".into(), output: "in.txt".into(), source: "E = {{ E }}\n".into() };
//! let r = Renderer::new(&[t]).unwrap();
//! let mut ctx = tera::Context::new();
//! ctx.insert("E", &60000.5);
//! assert_eq!(r.render(&ctx).unwrap()[0].1, b"E = 60000.5\n");
//! ```

pub mod lsdyna;
pub mod mesh;

use tera::Context;

pub use crate::base::template::{Inputs, Renderer, extend};
use crate::error::InputError;
use crate::study::{CopiedFile, Study};

/// The template context of a run: design variables, parameters, constants, `design_name`
/// ([`Study::context`]).
pub fn context(study: &Study, design_name: &str, design: &[f64], theta: &[f64]) -> Context {
    study.context(design_name, design, theta)
}

/// The template context of a planned run: [`context`], plus the model extension's variables the
/// plan set for it (screening and joint runs of an extension hypothesis).
pub fn run_context(study: &Study, run: &crate::plan::PlannedRun) -> Context {
    let mut ctx = study.context(&run.design, &run.design_values, &run.theta);
    extend(&mut ctx, &run.extension);
    ctx
}

/// The rendered templates plus the copied files: every input of a run.
pub fn inputs(renderer: &Renderer, files: &[CopiedFile], context: &Context) -> Result<Inputs, InputError> {
    let mut inputs = renderer.render(context)?;
    inputs.extend(files.iter().map(|f| (f.output.clone(), f.bytes.clone())));
    Ok(inputs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::Template;
    use std::path::PathBuf;

    fn template(source: &str) -> Template {
        Template {
            file: "dir/in.txt.tera".into(),
            output: "in.txt".into(),
            source: source.into(),
        }
    }

    #[test]
    fn syntax_error_names_file_and_line() {
        let e = Renderer::new(&[template("a\nb = {{ E \n")])
            .err()
            .expect("syntax error");
        assert_eq!(e.file, PathBuf::from("dir/in.txt.tera"));
        assert_eq!(e.span.as_ref().map(|s| s.line), Some(2), "{e}");
        assert!(e.message.contains("syntax"), "{e}");
    }

    #[test]
    fn undefined_variable_names_file_and_line() {
        let r = Renderer::new(&[template("a\n\nb = {{ nope }}\n")]).unwrap();
        let e = r.render(&Context::new()).expect_err("undefined variable");
        assert_eq!(e.span.as_ref().map(|s| s.line), Some(3), "{e}");
    }

    #[test]
    fn numbers_render_round_trip_and_nothing_is_escaped() {
        let r = Renderer::new(&[template("{{ x }} {{ s }}")]).unwrap();
        let mut ctx = Context::new();
        ctx.insert("x", &0.1_f64);
        ctx.insert("s", "<&>");
        assert_eq!(r.render(&ctx).unwrap()[0].1, b"0.1 <&>");
    }
}
