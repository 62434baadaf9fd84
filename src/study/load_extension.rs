//! Validation of a model-extension hypothesis (`diagnosis.hypotheses[].extension`): template
//! variables set for the extra runs of a solver study, each a value or a range `{min, max, unit,
//! probe}` (validated like `parameters`; the probe, by default the middle, is its screening value).
//! Every error is at the offending node.
//!
//! A variable is *used* when setting it changes what the templates render: the templates are
//! rendered for the first training design at the centre of the parameter box with all the
//! extension's variables, then without each one in turn; a variable whose absence renders the same
//! bytes (or whose value equals what the template would render anyway) has no effect and is an
//! error. A template that does not render without the variable (no `default`) uses it as well.
//!
//! An extension with ranges is also checked for whether the baseline is its joint space's edge
//! ([`Extension::baseline_at_edge`]): the same rendering without the extension and with its ranges
//! at their lower bounds.

use indexmap::IndexMap;

use super::super::schema::{ExtensionRangeFile, ExtensionValueFile, Name};
use super::super::yaml::Spanned;
use super::super::{Extension, Parameter, Simulation, Study};
use super::Checker;
use crate::error::InputError;

/// Template-context names an extension cannot set: they are every run's own.
const RESERVED: [&str; 1] = ["design_name"];

impl Checker<'_> {
    /// `extension:` of hypothesis `hypothesis`: a solver study's, not empty, each variable valid
    /// and used by the templates.
    pub(super) fn extension(
        &self,
        study: &Study,
        hypothesis: &Name,
        node: &Spanned<IndexMap<Name, Spanned<ExtensionValueFile>>>,
    ) -> Result<Extension, InputError> {
        let who = format!("hypothesis `{}`", hypothesis.value);
        let Simulation::Solver(sim) = &study.simulation else {
            return Err(self.at_key(
                "extension",
                node,
                format!(
                    "{who}: `extension` sets template variables for extra solver runs, but this study's simulation \
                     is a closed-form `expression` (no templates, no runs); write the effect as a `term:`, or run \
                     the simulation with `simulation.solver`"
                ),
            ));
        };
        if node.value.is_empty() {
            return Err(self.at_key(
                "extension",
                node,
                format!("{who}: empty `extension`: give the template variables it sets, e.g. {{shear: 1}}"),
            ));
        }
        let mut extension = Extension {
            screening: Vec::new(),
            ranges: Vec::new(),
            baseline_at_edge: false,
        };
        for (var, value) in &node.value {
            let (screening, range) = self.extension_variable(study, &who, var, value)?;
            extension.screening.push(screening);
            extension.ranges.extend(range);
        }
        let renderer = sim.inputs.renderer()?;
        self.used_by_templates(study, &renderer, &who, node, &extension.screening)?;
        if !extension.ranges.is_empty() {
            let edge = render_at_centre(study, &renderer, &extension.at_lower_bounds());
            let base = render_at_centre(study, &renderer, &[]);
            extension.baseline_at_edge = matches!((base, edge), (Ok(b), Ok(e)) if b == e);
        }
        Ok(extension)
    }

    /// One variable of an extension: an identifier of its own (not a design variable, parameter
    /// or name lab sets), with a finite value or a range; its screening value, and the range.
    fn extension_variable(
        &self,
        study: &Study,
        who: &str,
        var: &Name,
        value: &Spanned<ExtensionValueFile>,
    ) -> Result<((String, f64), Option<Parameter>), InputError> {
        let text = var.value.as_str();
        let identifier = text.chars().next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
            && text.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !identifier {
            return Err(self.at(
                var,
                format!(
                    "{who}: invalid template variable `{text}`: use letters, digits and '_', starting with a letter"
                ),
            ));
        }
        let clash = if study.design.iter().any(|d| d.name == text) {
            Some("a design variable")
        } else if study.parameters.iter().any(|p| p.name == text) {
            Some("a calibration parameter")
        } else if RESERVED.contains(&text) {
            Some("set by lab for every run")
        } else {
            None
        };
        if let Some(what) = clash {
            return Err(self.at(
                var,
                format!(
                    "{who}: `{text}` is {what}; an extension sets a template variable of its own (or overrides a \
                     constant)"
                ),
            ));
        }
        match &value.value {
            ExtensionValueFile::Value(v) if !v.is_finite() => {
                Err(self.at(value, format!("{who}: `{text}` must be a finite number, not {v}")))
            }
            ExtensionValueFile::Value(v) => Ok(((text.to_string(), *v), None)),
            ExtensionValueFile::Range(range) => {
                let (probe, parameter) = self.extension_range(&format!("{who}: `{text}`"), text, range)?;
                Ok(((text.to_string(), probe), Some(parameter)))
            }
        }
    }

    /// A range `{min, max, unit, probe}`: finite, min < max, the probe (default: the middle) inside.
    fn extension_range(
        &self,
        what: &str,
        name: &str,
        range: &ExtensionRangeFile,
    ) -> Result<(f64, Parameter), InputError> {
        let min = self.finite(&range.min, &format!("{what}: min"))?;
        let max = self.finite(&range.max, &format!("{what}: max"))?;
        if min >= max {
            return Err(self.at(&range.min, format!("{what}: min ({min}) must be less than max ({max})")));
        }
        let probe = match &range.probe {
            Some(p) => {
                let v = self.finite(p, &format!("{what}: probe"))?;
                if !(min..=max).contains(&v) {
                    return Err(self.at(p, format!("{what}: probe ({v}) must lie in [{min}, {max}]")));
                }
                v
            }
            None => 0.5 * (min + max),
        };
        let parameter = Parameter {
            name: name.to_string(),
            min,
            max,
            unit: range.unit.clone(),
        };
        Ok((probe, parameter))
    }

    /// The render test: each variable must change what the templates render, at the first training
    /// design and the centre of the parameter box.
    fn used_by_templates(
        &self,
        study: &Study,
        renderer: &crate::base::template::Renderer,
        who: &str,
        node: &Spanned<IndexMap<Name, Spanned<ExtensionValueFile>>>,
        vars: &[(String, f64)],
    ) -> Result<(), InputError> {
        let render = |vars: &[(String, f64)]| render_at_centre(study, renderer, vars);
        let design = &study.split.training[0];
        let full = render(vars).map_err(|mut e| {
            e.message = format!("{} (rendering the extension of {who})", e.message);
            e
        })?;
        for (i, (var, _)) in node.value.iter().enumerate() {
            let without: Vec<(String, f64)> = vars
                .iter()
                .enumerate()
                .filter(|&(k, _)| k != i)
                .map(|(_, v)| v.clone())
                .collect();
            if render(&without).is_ok_and(|inputs| inputs == full) {
                return Err(self.at(
                    var,
                    format!(
                        "{who}: template variable `{}` does not change what the templates render (design `{design}`, \
                         parameters at the centre of their bounds): no template uses it, so its runs would repeat \
                         the baseline's",
                        var.value
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// The templates rendered at the first training design, the parameters at the centre of their
/// bounds, with the template variables `vars` set.
fn render_at_centre(
    study: &Study,
    renderer: &crate::base::template::Renderer,
    vars: &[(String, f64)],
) -> Result<crate::base::template::Inputs, InputError> {
    let design = &study.split.training[0];
    let values = study
        .experiments
        .get(design)
        .map(|t| t.values.clone())
        .unwrap_or_default();
    let theta: Vec<f64> = study.parameter_bounds().center().iter().copied().collect();
    let mut ctx = study.context(design, &values, &theta);
    crate::base::template::extend(&mut ctx, vars);
    renderer.render(&ctx)
}
