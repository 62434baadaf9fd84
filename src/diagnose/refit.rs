//! Where the solver moves a named cause's parameters.
//!
//! The solver in the loop calibrates a cause's model through emulators; its confirmation runs the
//! solver at that fitted point and refits the parameters along the emulators' slope from the
//! solver's own values there ([`super::confirm`], step 2). Where that refit lies outside the loop's
//! 95 % interval of a variable, the solver contradicts the loop's parameters — its emulators are
//! off there (a crude fixed design of the loop, a response they do not follow) — while the model
//! the confirmation judged fit is the refitted one. So the parameters handed over are the refit's,
//! with its own interval, and the words say from where; the loop's stay in its record.

use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

use super::verdict::Verdict;

/// A named cause's parameters moved by the solver's runs at the loop's fitted point
/// (`diagnosis.solver_refit`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SolverRefit {
    /// The cause whose model was refitted.
    pub model: String,
    /// The loop's fitted point, where the solver ran.
    pub from: IndexMap<String, f64>,
    /// The refitted point (an extension variable held within its range), and its 95 % interval
    /// (Student's t on the tests' degrees of freedom).
    pub to: IndexMap<String, f64>,
    pub interval95: IndexMap<String, [f64; 2]>,
    /// The variables whose refit lies outside the loop's 95 % interval.
    pub outside: Vec<String>,
}

/// The refit of `d`'s named cause where its confirmation fits and puts a variable outside the
/// loop's 95 % interval; `None` otherwise (no loop model, no bridge, a refit inside the interval).
pub fn of(d: &super::Diagnosis) -> Option<SolverRefit> {
    let cause = d
        .finding
        .cause
        .as_ref()
        .filter(|_| d.finding.verdict == Verdict::CauseNamed)?;
    let x = d.explained.extensions.iter().find(|x| &x.setup.hypothesis == cause)?;
    let loop_interval = x.fitted.interval95.as_ref()?;
    let c = (d.checked.confirmation.iter())
        .find(|c| &c.model == cause && c.lack_of_fit.as_ref().is_some_and(|l| l.fits))?;
    let dof = c.lack_of_fit.as_ref().map_or(0, |l| l.noise_dof);
    let t = super::stats::t_quantile(0.975, dof as f64);
    let held = |name: &str, v: f64| match x.setup.variables.get(name) {
        Some(r) => v.clamp(r.min, r.max),
        None => v,
    };
    let to: IndexMap<String, f64> = (c.refitted.iter()).map(|(n, v)| (n.clone(), held(n, *v))).collect();
    let interval95 = (c.refitted_se.iter())
        .filter_map(|(n, se)| {
            let v = to.get(n)?;
            Some((n.clone(), [held(n, v - t * se), held(n, v + t * se)]))
        })
        .collect();
    let outside: Vec<String> = (to.iter())
        .filter(|(n, v)| loop_interval.get(*n).is_some_and(|[lo, hi]| *v < lo || *v > hi))
        .map(|(n, _)| n.clone())
        .collect();
    (!outside.is_empty()).then(|| SolverRefit {
        model: cause.clone(),
        from: c.at.clone(),
        to,
        interval95,
        outside,
    })
}

impl super::Diagnosis {
    /// The named cause's model with the solver's refit in place of the loop's parameters, where
    /// the solver moved them ([`of`]); recorded in `checked.solver_refit`. The standard errors are
    /// the refit's; each parameter's change from the uncorrected calibration is kept on the same
    /// base.
    pub(crate) fn with_solver_refit(mut self) -> super::Diagnosis {
        let Some(r) = of(&self) else { return self };
        if let Some(e) = self.explained.extended.as_mut() {
            let model = &mut e.model;
            for (n, v) in &r.to {
                let Some(old) = model.parameters.get(n).copied() else {
                    continue;
                };
                if let Some(change) = model.parameter_change.get_mut(n) {
                    *change = (1.0 + *change) * v / old - 1.0;
                }
                model.parameters.insert(n.clone(), *v);
            }
            if let Some(se) = model.parameter_se.as_mut() {
                let confirmed = self.checked.confirmation.iter().find(|c| c.model == r.model);
                for (n, s) in confirmed.map(|c| c.refitted_se.iter()).into_iter().flatten() {
                    if se.contains_key(n) {
                        se.insert(n.clone(), *s);
                    }
                }
            }
        }
        self.checked.solver_refit = Some(r);
        self
    }
}
