//! The answer in an engineer's words, first (`results.json` `answer`): what the model gets wrong and
//! which parameters to use, what to do next, and the one line of statistics that decided. Built once
//! from the typed verdict and the figures the tables print under the same names; the terminal, the
//! report's verdict box and `results.json` all carry these words.

use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

use super::results::Results;
use crate::base::format::{num, p_text, pct};
use crate::diagnose::verdict::Verdict;
use crate::diagnose::{Diagnosis, Extended, LackOfFit, NextTest};

/// `results.json` `answer`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Answer {
    /// What the model gets wrong and what to use, without test statistics.
    pub verdict: String,
    /// What to do next.
    pub action: String,
    /// The statistics that decided, in one line.
    pub decided_by: String,
    /// The model the verdict recommends, with its parameters (absent when it recommends none).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub recommended: Option<Model>,
}

/// A model with its calibrated parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Model {
    /// `uncorrected` (the simulation as it is), or the hypothesis whose model it is.
    pub model: String,
    /// The study's parameters.
    pub parameters: Vec<Quantity>,
    /// An extension's calibrated variables (the model's change of the solver's input).
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub variables: Vec<Quantity>,
    /// An additive correction the model adds to the simulation (`amplitude × term`), when it is
    /// not a change of the solver's input.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub correction: Option<String>,
}

/// One calibrated value, with its 95 % interval and unit when known.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Quantity {
    pub name: String,
    pub value: f64,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub interval95: Option<[f64; 2]>,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub unit: Option<String>,
}

impl Quantity {
    /// `sigma_y = 184.6 MPa (182.6–186.7)`.
    pub fn words(&self) -> String {
        let unit = self.unit.as_ref().map_or(String::new(), |u| format!(" {u}"));
        let interval = self
            .interval95
            .map_or(String::new(), |[a, b]| format!(" ({}–{})", num(a), num(b)));
        format!("{} = {}{unit}{interval}", self.name, num(self.value))
    }
}

impl Model {
    /// `sigma_y = 184.6 MPa (182.6–186.7) with etan = 195.2 MPa (171.4–219.1)`.
    pub fn words(&self) -> String {
        let list = |q: &[Quantity]| q.iter().map(Quantity::words).collect::<Vec<_>>().join(", ");
        let mut s = list(&self.parameters);
        if !self.variables.is_empty() {
            s.push_str(&format!(" with {}", list(&self.variables)));
        }
        if let Some(c) = &self.correction {
            s.push_str(&format!(" plus the correction {c}"));
        }
        s
    }

    fn value(&self, name: &str) -> Option<f64> {
        self.parameters.iter().find(|q| q.name == name).map(|q| q.value)
    }

    /// A model of `values` (parameters and, named in `variables`, an extension's variables).
    fn of(
        model: &str,
        values: &IndexMap<String, f64>,
        intervals: Option<&IndexMap<String, [f64; 2]>>,
        units: &IndexMap<String, String>,
        variables: &[&String],
    ) -> Model {
        let all = quantities(values, intervals, units);
        let (variables, parameters) = all.into_iter().partition(|q| variables.contains(&&q.name));
        Model {
            model: model.to_string(),
            parameters,
            variables,
            correction: None,
        }
    }
}

/// The calibration methods' estimates of one parameter beside the recommended model's value.
#[derive(Debug, Clone, PartialEq)]
pub struct Shift {
    pub parameter: String,
    /// The methods that ran, with their estimates.
    pub methods: Vec<(String, f64)>,
    pub recommended: f64,
}

/// A listed hypothesis the tests do not exclude: its variable's open range and the parameter's
/// range over it.
#[derive(Debug, Clone, PartialEq)]
pub struct Open {
    pub hypothesis: String,
    pub amplitude: Quantity,
    pub parameter: Option<Quantity>,
    /// The solver's runs over its amplitude favour it beyond its level (`not_excluded[].favoured`):
    /// χ²'s fall from its absence, and the critical value.
    pub favoured: Option<[f64; 2]>,
}

/// What the words are built from: the typed verdict and the figures it rests on.
#[derive(Debug, Clone, PartialEq)]
pub struct Reading {
    pub verdict: Verdict,
    /// The verdict's cause (named, or the partial one), and the explanations it leaves open.
    pub cause: Option<String>,
    pub leading: Vec<String>,
    /// The recommended model (`cause_named`, `no_model_error`), or the uncorrected calibration the
    /// verdict does not vouch for; and each leading explanation's parameters.
    pub model: Option<Model>,
    pub alternatives: Vec<Model>,
    pub shift: Option<Shift>,
    pub open: Vec<Open>,
    /// How far the calibrated parameter moves when the misfit is absorbed (parameter, fraction).
    pub absorbed: Option<(String, f64)>,
    pub next: Option<NextTest>,
    pub evidence: Evidence,
}

/// The statistics a verdict rests on.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Evidence {
    /// The uncorrected model's lack of fit (the solver's at the fitted parameters when it ran).
    pub uncorrected: Option<LackOfFit>,
    /// The cause's (or the partial cause's) model's lack of fit.
    pub with_cause: Option<LackOfFit>,
    /// Why no test of model error was possible, in words (`too_few_tests`).
    pub too_few: Option<String>,
    /// The two decisions an emulator-limited verdict stands between: with the tests' noise alone
    /// and with the emulators' error counted.
    pub between: Option<[(Verdict, Option<String>); 2]>,
    /// A rival that still explains part of the misfit with the cause's shape in the model (its
    /// name and the encompassing test's p).
    pub rival: Option<(String, f64)>,
    /// The observation that carries most of what the cause's model removes, and its share.
    pub carried_by: Option<(String, f64)>,
    /// The share of the misfit a partial cause's model removes.
    pub share_removed: Option<f64>,
    /// The seeds of the solver's imperfection whose scatter the verdict's model's confirmation
    /// counted beside the tests' (`simulation.seeds`; `None`: the tests' scatter alone).
    pub solver_seeds: Option<usize>,
}

/// The answer of `results`, when it has a diagnosis.
pub fn of(results: &Results) -> Option<Answer> {
    let d = results.diagnosed.diagnosis.as_ref()?;
    let reading = Reading::of(results, d);
    Some(reading.answer())
}

impl Reading {
    pub fn answer(&self) -> Answer {
        let recommends = matches!(self.verdict, Verdict::CauseNamed | Verdict::NoModelError);
        Answer {
            verdict: self.verdict_words(),
            action: self.action_words(),
            decided_by: self.decided_words(),
            recommended: self.model.clone().filter(|_| recommends),
        }
    }

    fn of(results: &Results, d: &Diagnosis) -> Reading {
        let units = units(results);
        let model = match d.finding.verdict {
            Verdict::CauseNamed => d
                .explained
                .extended
                .as_ref()
                .filter(|e| d.finding.cause.as_ref() == Some(&e.model.cause))
                .map(|e| cause_model(d, e, &units)),
            _ => None,
        }
        .or_else(|| Some(uncorrected_model(d, &units)));
        // Too few tests: the uncorrected model is the one quoted already; the others beside it.
        let alternatives = match d.finding.verdict {
            Verdict::CannotTellApart => d.finding.leading.iter().collect(),
            Verdict::TooFewTests => d.finding.leading.iter().filter(|n| *n != "uncorrected").collect(),
            _ => Vec::new(),
        }
        .into_iter()
        .filter_map(|n| named_model(d, n, &units))
        .collect();
        Reading {
            verdict: d.finding.verdict,
            cause: d
                .finding
                .cause
                .clone()
                .or_else(|| d.finding.partial.as_ref().map(|p| p.name.clone())),
            leading: d.finding.leading.clone(),
            shift: model.as_ref().and_then(|m| shift(results, m)),
            model,
            alternatives,
            open: open(d, &units),
            absorbed: d
                .explained
                .parameter_limits
                .first()
                .map(|l| (l.parameter.clone(), l.relative)),
            // A named cause needs no confirming test the specimens in hand already give.
            next: d
                .explained
                .next_test
                .clone()
                .filter(|t| !(d.finding.verdict == Verdict::CauseNamed && t.in_hand())),
            evidence: Evidence::of(d),
        }
    }
}

/// Each parameter's and extension variable's unit, by name.
pub(super) fn units(results: &Results) -> IndexMap<String, String> {
    let mut units = results.stated.units.parameters.clone();
    units.extend(results.stated.units.variables.clone());
    units
}

fn quantities(
    values: &IndexMap<String, f64>,
    intervals: Option<&IndexMap<String, [f64; 2]>>,
    units: &IndexMap<String, String>,
) -> Vec<Quantity> {
    values
        .iter()
        .map(|(name, &value)| Quantity {
            name: name.clone(),
            value,
            interval95: intervals.and_then(|i| i.get(name).copied()),
            unit: units.get(name).cloned(),
        })
        .collect()
}

fn uncorrected_model(d: &Diagnosis, units: &IndexMap<String, String>) -> Model {
    let u = &d.record.uncorrected;
    Model::of(
        "uncorrected",
        &u.parameters,
        u.precision.as_ref().map(|p| &p.interval95),
        units,
        &[],
    )
}

/// The model of a cause whose extended model is `e` (the named cause's, or a partial one's): the
/// solver-in-the-loop model when the loop calibrated it (its parameters and the extension's
/// variables), else the screening's extended model (its parameters, ±1.96 standard errors, and the
/// correction term it adds).
fn cause_model(d: &Diagnosis, e: &Extended, units: &IndexMap<String, String>) -> Model {
    let cause = e.model.cause.as_str();
    if let Some(x) = d.explained.extensions.iter().find(|x| x.setup.hypothesis == cause) {
        let variables: Vec<&String> = x.setup.variables.keys().collect();
        // Where the solver's runs at the loop's point moved it, the refit is the model's.
        if let Some(r) = d.checked.solver_refit.as_ref().filter(|r| r.model == cause) {
            return Model::of(cause, &r.to, Some(&r.interval95), units, &variables);
        }
        return Model::of(
            cause,
            &x.fitted.parameters,
            x.fitted.interval95.as_ref(),
            units,
            &variables,
        );
    }
    let intervals: Option<IndexMap<String, [f64; 2]>> = e.model.parameter_se.as_ref().map(|se| {
        se.iter()
            .filter_map(|(n, s)| {
                Some((
                    n.clone(),
                    e.model.parameters.get(n).map(|v| [v - 1.96 * s, v + 1.96 * s])?,
                ))
            })
            .collect()
    });
    Model {
        correction: Some(format!("{} × ({})", num(e.model.amplitude), e.model.term)),
        ..Model::of(cause, &e.model.parameters, intervals.as_ref(), units, &[])
    }
}

/// The models the answer may quote, each with its validation (or leave-one-out) error where the
/// diagnosis measured one: the uncorrected simulation, the cause's (or the partial cause's) model,
/// and, when the tests cannot tell them apart, each leading explanation's; for the terminal's
/// table of the diagnosis's models, so that every figure the answer quotes has its row.
pub(super) fn quoted_models(results: &Results, d: &Diagnosis) -> Vec<(Model, Option<f64>)> {
    let units = units(results);
    let extended = d.extended_model();
    let before =
        extended
            .map(|e| e.gains.validation_error_before)
            .or(d.record.uncorrected.validation.as_ref().map(|v| v.error));
    let mut out = vec![(uncorrected_model(d, &units), before)];
    if let Some(e) = extended {
        // The validation error measured is the loop's model's at its own point, not at the
        // solver's refit ([`crate::diagnose::refit`]): none is quoted for the refit.
        let refit = (d.checked.solver_refit.as_ref()).is_some_and(|r| r.model == e.model.cause);
        let after = (!refit).then_some(e.gains.validation_error_after);
        out.push((cause_model(d, e, &units), after));
    }
    if matches!(d.finding.verdict, Verdict::CannotTellApart | Verdict::TooFewTests) {
        for name in &d.finding.leading {
            if !out.iter().any(|(m, _)| m.model == *name)
                && let Some(m) = named_model(d, name, &units)
            {
                out.push((m, None));
            }
        }
    }
    out
}

/// A leading explanation's parameters: its loop model's, else its screening candidate's.
fn named_model(d: &Diagnosis, name: &str, units: &IndexMap<String, String>) -> Option<Model> {
    if name == "uncorrected" {
        return Some(uncorrected_model(d, units));
    }
    if let Some(x) = d.explained.extensions.iter().find(|x| x.setup.hypothesis == name) {
        let variables: Vec<&String> = x.setup.variables.keys().collect();
        return Some(Model::of(name, &x.fitted.parameters, None, units, &variables));
    }
    let c = d.explained.candidates.iter().find(|c| c.shape.name == name)?;
    Some(Model::of(name, &c.fit.parameters, None, units, &[]))
}

/// The methods' estimates of the study parameter whose estimate the model moves most.
fn shift(results: &Results, model: &Model) -> Option<Shift> {
    let methods: Vec<(&String, &IndexMap<String, f64>)> = results
        .calibration
        .iter()
        .filter(|(_, m)| m.error.is_none())
        .map(|(k, m)| (k, &m.parameters))
        .collect();
    let moved = |name: &String| -> f64 {
        let at = model.value(name).unwrap_or(f64::NAN);
        methods
            .iter()
            .filter_map(|(_, p)| p.get(name))
            .map(|v| ((v - at) / at).abs())
            .fold(0.0, f64::max)
    };
    let parameter = results
        .stated
        .units
        .parameters
        .keys()
        .chain(methods.first().map(|m| m.1.keys()).into_iter().flatten())
        .filter(|n| model.value(n).is_some())
        .max_by(|a, b| moved(a).total_cmp(&moved(b)))?
        .clone();
    Some(Shift {
        methods: methods
            .iter()
            .filter_map(|(k, p)| Some((k.to_string(), *p.get(&parameter)?)))
            .collect(),
        recommended: model.value(&parameter)?,
        parameter,
    })
}

fn open(d: &Diagnosis, units: &IndexMap<String, String>) -> Vec<Open> {
    let one = |m: &IndexMap<String, [f64; 2]>| -> Option<Quantity> {
        let (name, &[lo, hi]) = m.first()?;
        Some(Quantity {
            name: name.clone(),
            value: hi,
            interval95: Some([lo, hi]),
            unit: units.get(name).cloned(),
        })
    };
    d.checked
        .not_excluded
        .iter()
        .filter_map(|n| {
            Some(Open {
                hypothesis: n.hypothesis.clone(),
                amplitude: one(&n.amplitude)?,
                parameter: one(&n.parameters),
                favoured: n.favoured.as_ref().map(|f| [f.drop, f.critical]),
            })
        })
        .collect()
}

impl Evidence {
    fn of(d: &Diagnosis) -> Evidence {
        // The solver's own runs at the fitted parameters judge a model where they ran.
        let confirmed = |model: &str| {
            d.checked
                .confirmation
                .iter()
                .find(|c| c.model == model)
                .and_then(|c| c.lack_of_fit.clone())
        };
        let cause = d
            .finding
            .cause
            .as_deref()
            .or(d.finding.partial.as_ref().map(|p| p.name.as_str()));
        let extended = d.extended_model();
        let judged = match d.finding.verdict {
            Verdict::CauseNamed => cause.unwrap_or_default(),
            _ => "uncorrected",
        };
        let solver_seeds = (d.checked.confirmation.iter())
            .find(|c| c.model == judged && c.lack_of_fit.is_some())
            .and_then(|c| Some(c.scatter.as_ref()?.seeds));
        Evidence {
            solver_seeds,
            uncorrected: confirmed("uncorrected").or_else(|| d.record.lack_of_fit.clone()),
            with_cause: cause
                .and_then(confirmed)
                .or_else(|| extended.and_then(|e| e.check.lack_of_fit.clone())),
            too_few: (d.finding.verdict == Verdict::TooFewTests).then(|| {
                let h = d.finding.headline.as_str();
                h.split_once(": ").map_or(h, |(_, why)| why).to_string()
            }),
            // Cannot tell apart: a rival that survives; partly explained: the rival that explains
            // most of what remains with the leader in the model.
            carried_by: d
                .checked
                .features
                .as_ref()
                .and_then(|f| Some((f.decided_by.clone()?, f.decided_share?))),
            share_removed: d.finding.partial.as_ref().and_then(|p| p.share_removed),
            rival: d
                .explained
                .rivals
                .iter()
                .filter(|r| d.finding.verdict != Verdict::CannotTellApart || !r.beaten)
                .filter_map(|r| Some((r.rival.clone(), r.p_rival_given_leader?)))
                .min_by(|a, b| a.1.total_cmp(&b.1)),
            between: d.checked.emulator.as_ref().filter(|e| e.differ).map(|e| {
                [
                    (e.noise_alone.verdict, e.noise_alone.cause.clone()),
                    (e.counted.verdict, e.counted.cause.clone()),
                ]
            }),
        }
    }
}

// The words.

impl Reading {
    /// What a fit is within: the tests' scatter, and where the solver ran at several seeds of its
    /// imperfection, its own scatter between them ("within the tests' scatter" is said of the
    /// tests' scatter only).
    fn within(&self) -> String {
        match self.evidence.solver_seeds {
            Some(n) => format!("their scatter and the solver's own between {n} seeds"),
            None => "their scatter".to_string(),
        }
    }

    fn verdict_words(&self) -> String {
        let cause = self.cause.as_deref().unwrap_or("a listed cause");
        let model = self.model.as_ref().map(Model::words).unwrap_or_default();
        match self.verdict {
            Verdict::CauseNamed => {
                let shift = self.shift_words("Without it, ");
                format!("The model misses {cause}: use {model}.{shift}")
            }
            Verdict::NoModelError => {
                let open: Vec<String> = self.open.iter().map(open_words).collect();
                let open = match open.is_empty() {
                    true => String::new(),
                    false => format!(" These tests do not rule out {}.", open.join("; nor ")),
                };
                let within = self.within();
                format!("The model fits the tests within {within}: use {model} as calibrated.{open}")
            }
            Verdict::PartlyExplained => format!(
                "The model misses the tests beyond their scatter, and {cause} explains only part of it{}. {}",
                self.others(cause),
                self.absorbed_words(&model)
            ),
            Verdict::Unexplained => format!(
                "The model misses the tests beyond their scatter, and none of the listed causes explains it. {}",
                self.absorbed_words(&model)
            ),
            Verdict::CannotTellApart => self.cannot_tell_words(),
            Verdict::TooFewTests => format!(
                "Too few tests to tell whether the model errs. As calibrated, {model}, which holds only if the \
                 model is right{}.",
                self.under_each()
            ),
            Verdict::EmulatorLimited => match self.favoured().as_slice() {
                [o] => format!(
                    "Not decided: the emulators found no model error, but the solver's runs favour {}: these tests do \
                     not rule out {}, and rule out its absence. Without it, as calibrated, {model}.",
                    o.hypothesis,
                    open_words(o)
                ),
                [_, _, ..] => {
                    let fav = self.favoured();
                    let names: Vec<&str> = fav.iter().map(|o| o.hypothesis.as_str()).collect();
                    let open: Vec<String> = fav.iter().map(|o| open_words(o)).collect();
                    format!(
                        "Not decided: the emulators found no model error, but the solver's runs favour {}, each against \
                         its absence (not yet against each other): these tests do not rule out {}, and rule out the \
                         absence of each. Without them, as calibrated, {model}.",
                        names.join(" and "),
                        open.join(", nor ")
                    )
                }
                [] => format!(
                    "Not decided: the emulators' error, not the tests, decides whether {}. As calibrated, {model}.",
                    self.between_words()
                ),
            },
        }
    }

    /// `; 'cubic wear' may account for the rest`.
    fn others(&self, cause: &str) -> String {
        let others: Vec<String> = self
            .leading
            .iter()
            .filter(|n| *n != cause && *n != "uncorrected")
            .cloned()
            .collect();
        match others.len() {
            0 => String::new(),
            _ => format!("; {} may account for the rest", others.join(" or ")),
        }
    }

    /// The calibrated parameters absorb what no cause explains.
    fn absorbed_words(&self, model: &str) -> String {
        let moved = self.absorbed.as_ref().map_or(String::new(), |(p, r)| {
            format!(" ({p} moves {}{} when the misfit is taken out)", sign(*r), pct(*r))
        });
        format!(
            "As calibrated, {model} absorbs the error{moved}: a fitted value of this model, not a measured property."
        )
    }

    /// Each leading explanation's parameters (without its correction) beside its name, as `each`
    /// words them: `E = 68000 MPa under shear deformation`.
    fn alternative_words(&self, each: impl Fn(&str, &str) -> String) -> Vec<String> {
        (self.alternatives.iter())
            .map(|m| {
                let bare = Model {
                    correction: None,
                    ..m.clone()
                };
                each(&bare.words(), &m.model)
            })
            .collect()
    }

    /// `; with 'shear deformation' E = 68000 MPa, with 'root rotation' E = 78770 MPa` (empty with
    /// no leading explanation beside the uncorrected model).
    fn under_each(&self) -> String {
        match self
            .alternative_words(|values, name| format!("with '{name}' {values}"))
            .as_slice()
        {
            [] => String::new(),
            each => format!("; {}", each.join(", ")),
        }
    }

    fn cannot_tell_words(&self) -> String {
        let names: Vec<&str> = self.leading.iter().map(String::as_str).collect();
        let values = self.alternative_words(|values, name| format!("{values} under {name}"));
        let values = match values.is_empty() {
            true => String::new(),
            false => format!(": {}", values.join("; ")),
        };
        format!(
            "The model misses the tests beyond their scatter, but these tests cannot tell {} apart{values}.",
            names.join(" from ")
        )
    }

    /// `the model fits or it misses 'strain hardening'`.
    fn between_words(&self) -> String {
        let Some([a, b]) = &self.evidence.between else {
            return "the model fits".into();
        };
        format!("{} or {}", plain(a.0, a.1.as_deref()), plain(b.0, b.1.as_deref()))
    }

    /// `Without it, all three methods put sigma_y 7.9–8.5 % too high (199.2–200.2 MPa).`
    fn shift_words(&self, lead: &str) -> String {
        let Some(s) = &self.shift else {
            return String::new();
        };
        let rel: Vec<f64> = s.methods.iter().map(|(_, v)| v / s.recommended - 1.0).collect();
        let (lo, hi) = rel
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &r| (a.min(r), b.max(r)));
        if rel.is_empty() || (lo.abs().max(hi.abs())) < 0.005 {
            return String::new();
        }
        let who = match s.methods.len() {
            1 => format!("{} puts", method_name(&s.methods[0].0)),
            2 => "both methods put".to_string(),
            n => format!("all {} methods put", count_word(n)),
        };
        let how = if lo > 0.0 || hi < 0.0 {
            let (a, b) = (pct(lo.abs().min(hi.abs())), pct(lo.abs().max(hi.abs())));
            let range = if a == b {
                a
            } else {
                format!("{}–{}", a.trim_end_matches(" %"), b)
            };
            format!("{} {range} too {}", s.parameter, if hi < 0.0 { "low" } else { "high" })
        } else {
            format!(
                "{} between {}{} and {}{} off",
                s.parameter,
                sign(lo),
                pct(lo),
                sign(hi),
                pct(hi)
            )
        };
        format!(" {lead}{who} {how}.")
    }

    /// The open extensions the solver's runs over their amplitude favour, the largest fall of χ² first.
    fn favoured(&self) -> Vec<&Open> {
        let mut f: Vec<&Open> = self.open.iter().filter(|o| o.favoured.is_some()).collect();
        f.sort_by(|a, b| {
            let drop = |o: &&Open| o.favoured.map_or(0.0, |f| f[0]);
            drop(b).total_cmp(&drop(a))
        });
        f
    }

    /// The favoured extension the next test would tell from the uncorrected model, if any: the
    /// solver's runs over its amplitude already tell it from its absence with the tests in hand,
    /// while the next test's specimens are read from the emulators those runs refuted.
    fn settled_by_the_solver(&self) -> Option<&str> {
        let [a, b] = &self.next.as_ref()?.choice.between;
        let other = match (a.as_str(), b.as_str()) {
            (h, "uncorrected") | ("uncorrected", h) => h,
            _ => return None,
        };
        self.favoured()
            .into_iter()
            .map(|o| o.hypothesis.as_str())
            .find(|h| *h == other)
    }

    fn action_words(&self) -> String {
        let next = self.next.as_ref().map(next_words);
        match (self.verdict, next) {
            (Verdict::CauseNamed, None) => {
                "Action: use that model; the tests in hand decide, no further test is needed.".into()
            }
            (Verdict::CauseNamed, Some(n)) => format!("Action: use that model; to confirm it, {n}."),
            (Verdict::NoModelError, n) => {
                let open: Vec<String> = self.open.iter().map(|o| format!("'{}'", o.hypothesis)).collect();
                let where_ = match open.is_empty() {
                    true => String::new(),
                    false => format!(
                        " where {} {} absent",
                        open.join(" and "),
                        if open.len() == 1 { "is" } else { "are" }
                    ),
                };
                let n = n.map_or(String::new(), |n| format!("; to look for what it may hide, {n}"));
                format!("Action: use the simulation as calibrated{where_}{n}.")
            }
            (Verdict::EmulatorLimited, n) => format!(
                "Action: run the solver {} before trusting either reading{}.",
                match self.favoured().as_slice() {
                    [o] => format!(
                        "in the loop over '{}' (its amplitude and the parameters together)",
                        o.hypothesis
                    ),
                    [] => "where the decision is read (more runs near the fitted parameters)".into(),
                    many => format!(
                        "in the loop over {} (their amplitudes and the parameters together)",
                        many.iter()
                            .map(|o| format!("'{}'", o.hypothesis))
                            .collect::<Vec<_>>()
                            .join(" and ")
                    ),
                },
                match (self.settled_by_the_solver(), n) {
                    (Some(h), _) => format!(
                        "; with the solver's runs, the tests in hand already rule out the absence of '{h}', so \
                         no further test is asked for until the loop has decided"
                    ),
                    (None, n) => n.map_or(String::new(), |n| format!("; then {n}")),
                }
            ),
            (_, Some(n)) => format!("Action: {n}."),
            (_, None) => "Action: look for the missing physics; no test in reach decides.".into(),
        }
    }

    fn decided_words(&self) -> String {
        let e = &self.evidence;
        let unc = e.uncorrected.as_ref().map(fit_words);
        let with = e.with_cause.as_ref().map(fit_words);
        let cause = self
            .cause
            .as_deref()
            .or(self.leading.first().map(String::as_str))
            .unwrap_or("the cause");
        let rival = e.rival.as_ref().map(|(r, p)| match self.verdict {
            Verdict::CannotTellApart => format!(
                "with '{cause}' in the model, '{r}' adds nothing the tests can tell ({})",
                p_text(*p)
            ),
            _ => format!(
                "with '{cause}' in the model, '{r}' still explains part of the misfit ({})",
                p_text(*p)
            ),
        });
        let level = e
            .uncorrected
            .as_ref()
            .map_or(String::new(), |l| format!(" at α = {}", num(l.level)));
        let text = match (self.verdict, unc, with) {
            (Verdict::CauseNamed, u, Some(w)) => {
                let u = u.map_or(String::new(), |u| format!("; without it {u}"));
                let by = e.carried_by.as_ref().map_or(String::new(), |(o, share)| {
                    format!("; the {o} carries {:.0} % of what it removes", 100.0 * share)
                });
                format!(
                    "with '{cause}' the model fits the tests within {} ({w}){u}{by}",
                    self.within()
                )
            }
            (Verdict::PartlyExplained, _, Some(w)) => {
                let share = e.share_removed.map_or(String::new(), |s| {
                    format!("removes {:.0} % of the misfit, but ", 100.0 * s)
                });
                format!("'{cause}' {share}its model still misses the tests ({w})")
            }
            (Verdict::PartlyExplained | Verdict::CannotTellApart, u, _) if rival.is_some() => {
                let u = u.map_or(String::new(), |u| format!("without a correction {u}; "));
                format!("{u}{}", rival.unwrap_or_default())
            }
            (Verdict::NoModelError, Some(u), _) => {
                let against = self.within().replacen("their", "the tests'", 1);
                format!("the calibrated model against {against}{level}: {u}")
            }
            (Verdict::TooFewTests, ..) => e.too_few.clone().unwrap_or_default(),
            (Verdict::EmulatorLimited, u, _) => {
                let favoured: Vec<String> = (self.favoured().iter())
                    .filter_map(|o| {
                        let [drop, critical] = o.favoured?;
                        Some(format!(
                            "the solver's runs over '{}' against its absence (χ² falls by {}, beyond {})",
                            o.hypothesis,
                            num(drop),
                            num(critical)
                        ))
                    })
                    .collect();
                let readings = match favoured.is_empty() {
                    false => favoured.join("; "),
                    true => {
                        "with the tests' noise alone and with the emulators' error counted the readings differ".into()
                    }
                };
                format!(
                    "{readings}{}",
                    u.map_or(String::new(), |u| format!("; the uncorrected model: {u}"))
                )
            }
            (_, Some(u), _) => format!("the uncorrected model against the tests' scatter{level}: {u}"),
            (_, None, _) => "no lack-of-fit test was possible (no measured noise)".into(),
        };
        format!("Decided by: {}.", text.trim_end_matches('.'))
    }
}

/// `χ² = 5.79 on 7 dof, p = 0.6 by F(7, 6); largest residual 1.6 σ at C6T5 (p = 0.79 over 9, each by t(6))`.
pub fn fit_words(l: &LackOfFit) -> String {
    let (by_f, by_t) = crate::diagnose::text::references(l);
    let largest = l.largest.as_ref().map_or(String::new(), |r| {
        format!(
            "; largest residual {:.1} σ at {} ({} over {}{by_t})",
            r.z.abs(),
            r.design,
            p_text(r.p_corrected),
            r.residuals
        )
    });
    format!(
        "χ² = {} on {} dof, {}{by_f}{largest}",
        num(l.chi2),
        l.dof,
        p_text(l.p_value)
    )
}

/// `strain hardening with etan anywhere in 0–257.8 MPa (over which sigma_y = 178.4–210.7 MPa)`.
fn open_words(o: &Open) -> String {
    let range = |q: &Quantity| {
        let [a, b] = q.interval95.unwrap_or([q.value, q.value]);
        let unit = q.unit.as_ref().map_or(String::new(), |u| format!(" {u}"));
        format!("{} anywhere in {}–{}{unit}", q.name, num(a), num(b))
    };
    let over = o.parameter.as_ref().map_or(String::new(), |p| {
        let [a, b] = p.interval95.unwrap_or([p.value, p.value]);
        let unit = p.unit.as_ref().map_or(String::new(), |u| format!(" {u}"));
        format!(" (over which {} = {}–{}{unit})", p.name, num(a), num(b))
    });
    format!("{} with {}{over}", o.hypothesis, range(&o.amplitude))
}

/// `test 88 more specimens at C6T5 (c = 6, t = 0.05) to tell whether the model misses 'x'`.
fn next_words(n: &NextTest) -> String {
    let at = |design: &IndexMap<String, f64>, tested: Option<&String>| {
        let values = crate::base::format::params(design);
        tested.map_or(values.clone(), |t| format!("{t} ({values})"))
    };
    let place = if n.amount.programme.is_empty() {
        let tested = n.choice.already_tested.as_ref().map(|t| &t.0);
        match n.amount.additional_specimens.or(n.amount.specimens) {
            Some(k) => format!(
                "test {k}{} specimen{} at {}",
                if tested.is_some() { " more" } else { "" },
                plural(k),
                at(&n.choice.design, tested)
            ),
            None => format!("test at least 3 specimens at {}", at(&n.choice.design, tested)),
        }
    } else {
        let parts: Vec<String> = n
            .amount
            .programme
            .iter()
            .filter(|p| p.additional > 0)
            .enumerate()
            .map(|(i, p)| {
                let what = if i == 0 {
                    format!(" specimen{}", plural(p.additional))
                } else {
                    String::new()
                };
                // "more" only where specimens were tested already.
                let more = if p.tested_as.is_some() { " more" } else { "" };
                format!(
                    "{}{more}{what} at {}",
                    p.additional,
                    at(&p.design, p.tested_as.as_ref())
                )
            })
            .collect();
        format!("test {}", parts.join(" and "))
    };
    let [a, b] = &n.choice.between;
    let why = if n.choice.compared.len() < 2 {
        "where the model has not been checked".to_string()
    } else if b == "uncorrected" {
        format!("to tell whether the model misses '{a}'")
    } else if a == "uncorrected" {
        format!("to tell whether the model misses '{b}'")
    } else {
        format!("to tell '{a}' from '{b}'")
    };
    // Without a measured noise the specimens are replicates: they measure the scatter too.
    let place = match n.amount.scatter_dof {
        Some(_) => format!("{place} as replicates (these tests have none, so their scatter is measured too)"),
        None => place,
    };
    let first = if n.amount.limited_by_emulators {
        "run more solver runs first (the explanations differ by less than their emulators' error), then "
    } else {
        ""
    };
    format!("{first}{place} {why}")
}

/// A verdict in a few plain words, for the emulator-limited reading.
fn plain(v: Verdict, cause: Option<&str>) -> String {
    match (v, cause) {
        (Verdict::NoModelError, _) => "the model fits".into(),
        (Verdict::CauseNamed, Some(c)) => format!("it misses {c}"),
        (Verdict::TooFewTests, _) => "the tests are too few to tell".into(),
        (Verdict::CannotTellApart, _) => "it misses a cause the tests cannot name".into(),
        _ => "it misses the tests".into(),
    }
}

fn method_name(key: &str) -> &str {
    match key {
        "least_squares" => "least squares",
        "sensitivity" => "the sensitivity method",
        "bayesian" => "the Bayesian method",
        other => other,
    }
}

fn count_word(n: usize) -> String {
    match n {
        3 => "three".into(),
        4 => "four".into(),
        n => n.to_string(),
    }
}

fn sign(x: f64) -> &'static str {
    if x < 0.0 { "−" } else { "+" }
}

fn plural(k: usize) -> &'static str {
    if k == 1 { "" } else { "s" }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q(name: &str, value: f64, interval95: Option<[f64; 2]>, unit: &str) -> Quantity {
        Quantity {
            name: name.into(),
            value,
            interval95,
            unit: Some(unit.into()),
        }
    }

    fn lack_of_fit(chi2: f64, dof: usize, p: f64) -> LackOfFit {
        LackOfFit {
            chi2,
            dof,
            noise_dof: 6,
            p_value: p,
            largest: None,
            level: 0.0025,
            fits: p > 0.0025,
        }
    }

    fn a_model(name: &str, sigma_y: f64, etan: Option<f64>) -> Model {
        Model {
            model: name.into(),
            parameters: vec![q("sigma_y", sigma_y, Some([sigma_y - 2.0, sigma_y + 2.0]), "MPa")],
            variables: etan
                .map(|e| q("etan", e, Some([e - 24.0, e + 24.0]), "MPa"))
                .into_iter()
                .collect(),
            correction: None,
        }
    }

    /// A listed hypothesis the tests do not exclude (`favoured`: the solver's runs over its amplitude
    /// favour it, [fall of χ², critical value]).
    fn an_open(hypothesis: &str, amplitude: Quantity, sigma_y: Quantity, favoured: Option<[f64; 2]>) -> Open {
        Open {
            hypothesis: hypothesis.into(),
            amplitude,
            parameter: Some(sigma_y),
            favoured,
        }
    }

    /// A reading of `verdict` with the figures every verdict may quote.
    fn reading(verdict: Verdict) -> Reading {
        let cause =
            matches!(verdict, Verdict::CauseNamed | Verdict::PartlyExplained).then(|| "strain hardening".to_string());
        let model = match verdict {
            Verdict::CauseNamed => a_model("strain hardening", 184.6, Some(195.2)),
            _ => a_model("uncorrected", 172.3, None),
        };
        Reading {
            verdict,
            cause,
            leading: vec!["strain hardening".into(), "scale error".into()],
            shift: Some(Shift {
                parameter: "sigma_y".into(),
                methods: vec![
                    ("least_squares".into(), 199.2),
                    ("sensitivity".into(), 200.2),
                    ("bayesian".into(), 200.2),
                ],
                recommended: model.parameters[0].value,
            }),
            model: Some(model),
            alternatives: vec![
                a_model("strain hardening", 184.6, Some(195.2)),
                a_model("scale error", 190.1, None),
            ],
            open: Vec::new(),
            absorbed: Some(("sigma_y".into(), 0.031)),
            next: None,
            evidence: Evidence {
                uncorrected: Some(lack_of_fit(652.4, 8, 1.5e-5)),
                with_cause: Some(lack_of_fit(5.79, 7, 0.6)),
                between: Some([
                    (Verdict::NoModelError, None),
                    (Verdict::CauseNamed, Some("strain hardening".into())),
                ]),
                rival: Some(("scale error".into(), 0.16)),
                ..Default::default()
            },
        }
    }

    const ALL: [Verdict; 7] = [
        Verdict::NoModelError,
        Verdict::CauseNamed,
        Verdict::CannotTellApart,
        Verdict::PartlyExplained,
        Verdict::Unexplained,
        Verdict::TooFewTests,
        Verdict::EmulatorLimited,
    ];

    #[test]
    fn every_verdict_has_a_plain_sentence_without_test_statistics() {
        for v in ALL {
            let a = reading(v).answer();
            for stat in ["χ²", "p =", "p <", " σ ", "Šidák", "dof"] {
                assert!(!a.verdict.contains(stat), "{v:?}: {stat} in {}", a.verdict);
            }
            assert!(
                a.verdict.starts_with("The model")
                    || a.verdict.starts_with("Too few")
                    || a.verdict.starts_with("Not decided"),
                "{v:?}: {}",
                a.verdict
            );
            assert!(a.action.starts_with("Action: "), "{v:?}: {}", a.action);
            assert!(
                a.decided_by.starts_with("Decided by: ") && a.decided_by.ends_with('.'),
                "{v:?}: {}",
                a.decided_by
            );
            // A model is recommended only where the verdict vouches for one.
            let recommends = matches!(v, Verdict::CauseNamed | Verdict::NoModelError);
            assert_eq!(a.recommended.is_some(), recommends, "{v:?}");
        }
    }

    #[test]
    fn each_verdict_says_what_the_model_gets_wrong_and_what_to_use() {
        let words = |v: Verdict| reading(v).answer().verdict;
        let cause = words(Verdict::CauseNamed);
        assert!(
            cause.starts_with(
                "The model misses strain hardening: use sigma_y = 184.6 MPa (182.6–186.6) with etan = 195.2 MPa (171.2–219.2)."
            ),
            "{cause}"
        );
        // 199.2 / 184.6 − 1 = 7.9 %, 200.2 / 184.6 − 1 = 8.5 %.
        assert!(
            cause.ends_with("Without it, all three methods put sigma_y 7.9–8.5 % too high."),
            "{cause}"
        );
        assert!(
            words(Verdict::NoModelError)
                .starts_with("The model fits the tests within their scatter: use sigma_y = 172.3 MPa")
        );
        let partly = words(Verdict::PartlyExplained);
        assert!(
            partly.contains("strain hardening explains only part of it; scale error may account for the rest"),
            "{partly}"
        );
        assert!(
            partly.contains("sigma_y = 172.3 MPa (170.3–174.3) absorbs the error (sigma_y moves +3.1 %"),
            "{partly}"
        );
        assert!(words(Verdict::Unexplained).contains("none of the listed causes explains it"));
        let apart = words(Verdict::CannotTellApart);
        assert!(
            apart.contains("cannot tell strain hardening from scale error apart"),
            "{apart}"
        );
        assert!(apart.contains("sigma_y = 184.6 MPa (182.6–186.6) with etan = 195.2 MPa (171.2–219.2) under strain hardening; sigma_y = 190.1 MPa (188.1–192.1) under scale error"), "{apart}");
        let few = words(Verdict::TooFewTests);
        assert!(few.contains("holds only if the model is right"), "{few}");
        // Each leading explanation's parameters beside it: their spread.
        assert!(
            few.contains(
                "; with 'strain hardening' sigma_y = 184.6 MPa (182.6–186.6) with etan = 195.2 MPa (171.2–219.2), \
                 with 'scale error' sigma_y = 190.1 MPa (188.1–192.1)."
            ),
            "{few}"
        );
        let limited = words(Verdict::EmulatorLimited);
        assert!(
            limited.contains("decides whether the model fits or it misses strain hardening"),
            "{limited}"
        );
    }

    #[test]
    fn the_methods_shift_is_said_by_sign_and_count() {
        let mut r = reading(Verdict::CauseNamed);
        let shift = r.shift.as_mut().unwrap();
        shift.methods = vec![("least_squares".into(), 180.9)];
        assert!(
            r.answer()
                .verdict
                .ends_with("Without it, least squares puts sigma_y 2.0 % too low."),
            "{}",
            r.answer().verdict
        );
        let shift = r.shift.as_mut().unwrap();
        shift.methods = vec![("least_squares".into(), 180.9), ("bayesian".into(), 199.5)];
        assert!(
            r.answer()
                .verdict
                .ends_with("Without it, both methods put sigma_y between −2.0 % and +8.1 % off."),
            "{}",
            r.answer().verdict
        );
        // Within half a percent: nothing to say.
        r.shift.as_mut().unwrap().methods = vec![("least_squares".into(), 184.7)];
        assert!(r.answer().verdict.ends_with("(171.2–219.2)."), "{}", r.answer().verdict);
    }

    #[test]
    fn what_no_model_error_leaves_open_is_said_with_its_range() {
        let mut r = reading(Verdict::NoModelError);
        r.open = vec![an_open(
            "strain hardening",
            q("etan", 257.8, Some([0.0, 257.8]), "MPa"),
            q("sigma_y", 210.7, Some([178.4, 210.7]), "MPa"),
            None,
        )];
        let a = r.answer();
        assert!(
            a.verdict.ends_with(
                "These tests do not rule out strain hardening with etan anywhere in 0–257.8 MPa (over which sigma_y = \
                 178.4–210.7 MPa)."
            ),
            "{}",
            a.verdict
        );
        assert!(
            a.action
                .starts_with("Action: use the simulation as calibrated where 'strain hardening' is absent"),
            "{}",
            a.action
        );
        let mut second = r.open[0].clone();
        second.hypothesis = "strain rate".into();
        r.open.push(second);
        let a = r.answer();
        assert!(
            a.action.starts_with(
                "Action: use the simulation as calibrated where 'strain hardening' and 'strain rate' are absent"
            ),
            "{}",
            a.action
        );
    }

    /// Several extensions favoured by the solver's runs over their amplitudes: each is said, the
    /// largest fall of χ² first, in the first line, the action and the deciding line; one is said alone.
    #[test]
    fn every_extension_the_solver_favours_is_said() {
        let mut r = reading(Verdict::EmulatorLimited);
        let open = |name: &str, var: &str, drop: f64| {
            an_open(
                name,
                q(var, 0.03, Some([0.01, 0.05]), ""),
                q("sigma_y", 190.0, Some([180.0, 200.0]), "MPa"),
                Some([drop, 17.14]),
            )
        };
        r.open = vec![open("shear", "s", 20.4)];
        let a = r.answer();
        assert!(a.verdict.contains("the solver's runs favour shear: "), "{}", a.verdict);
        assert!(
            a.action.contains("in the loop over 'shear' (its amplitude"),
            "{}",
            a.action
        );
        r.open = vec![open("shear", "s", 20.4), open("clamp", "kr", 22.2)];
        let a = r.answer();
        assert!(
            a.verdict.contains(
                "the solver's runs favour clamp and shear, each against its absence (not yet against each other)"
            ),
            "{}",
            a.verdict
        );
        assert!(a.verdict.contains("Without them, as calibrated"), "{}", a.verdict);
        assert!(
            a.action
                .contains("in the loop over 'clamp' and 'shear' (their amplitudes and the parameters together)"),
            "{}",
            a.action
        );
        let clamp = a.decided_by.find("over 'clamp' against its absence (χ² falls by 22.2");
        let shear = a.decided_by.find("over 'shear' against its absence (χ² falls by 20.4");
        assert!(clamp.is_some() && shear.is_some() && clamp < shear, "{}", a.decided_by);
    }

    /// A next test between `between`: 7 more specimens at C6T8.
    fn a_next_test(between: [&str; 2]) -> NextTest {
        let design: IndexMap<String, f64> = [("c".to_string(), 6.0), ("t".to_string(), 0.08)].into();
        NextTest {
            choice: crate::diagnose::TestChoice {
                design,
                why: String::new(),
                advice: String::new(),
                level: 0.001,
                between: between.map(String::from),
                predictions: [47.8, 48.3],
                separation: 0.44,
                compared: between.iter().map(|b| (b.to_string(), 48.0)).collect(),
                already_tested: Some(("C6T8".into(), 4)),
                output: None,
            },
            amount: crate::diagnose::TestAmount {
                specimens: Some(11),
                additional_specimens: Some(7),
                power: Some(0.9),
                expected_power: None,
                programme: Vec::new(),
                outside_range: false,
                measurements: Vec::new(),
                limited_by_emulators: false,
                scatter_dof: None,
            },
        }
    }

    /// "More" specimens only where some were tested; without a measured noise they are replicates.
    #[test]
    fn a_next_test_says_more_only_where_tested_and_replicates_where_the_noise_is_unmeasured() {
        let mut n = a_next_test(["shear", "offset"]);
        assert!(
            next_words(&n).starts_with("test 7 more specimens at C6T8 (c = 6, t = 0.08) to tell"),
            "{}",
            next_words(&n)
        );
        n.choice.already_tested = None;
        n.amount.scatter_dof = Some(6);
        let words = next_words(&n);
        assert!(
            words.starts_with("test 7 specimens at c = 6, t = 0.08 as replicates (these tests have none"),
            "{words}"
        );
    }

    /// The solver's runs over an extension's amplitude already tell it from its absence: a next
    /// test for that, read from the emulators they refuted, is not asked for; one between two
    /// extensions (favoured each against its absence, not against each other) still is.
    #[test]
    fn no_test_is_asked_for_what_the_solver_already_tells() {
        let mut r = reading(Verdict::EmulatorLimited);
        r.open = vec![an_open(
            "shear",
            q("s", 0.03, Some([0.01, 0.05]), ""),
            q("sigma_y", 190.0, Some([180.0, 200.0]), "MPa"),
            Some([20.4, 17.14]),
        )];
        for between in [["shear", "uncorrected"], ["uncorrected", "shear"]] {
            r.next = Some(a_next_test(between));
            let a = r.answer();
            assert!(!a.action.contains("specimen"), "{}", a.action);
            assert!(
                a.action
                    .contains("the tests in hand already rule out the absence of 'shear', so no further test"),
                "{}",
                a.action
            );
        }
        for between in [["shear", "clamp"], ["clamp", "uncorrected"]] {
            r.next = Some(a_next_test(between));
            let a = r.answer();
            assert!(
                a.action.contains("; then test 7 more specimens at C6T8"),
                "{}",
                a.action
            );
        }
        r.open[0].favoured = None;
        r.next = Some(a_next_test(["shear", "uncorrected"]));
        assert!(r.answer().action.contains("; then test 7 more specimens at C6T8"));
    }

    #[test]
    fn the_deciding_line_quotes_the_fit_with_and_without_the_cause() {
        let a = reading(Verdict::CauseNamed).answer();
        assert_eq!(
            a.decided_by,
            "Decided by: with 'strain hardening' the model fits the tests within their scatter (χ² = 5.79 on 7 dof, p = 0.6 by \
             F(7, 6)); without it χ² = 652.4 on 8 dof, p = 1.500e-5 by F(8, 6)."
        );
        assert_eq!(
            a.action,
            "Action: use that model; the tests in hand decide, no further test is needed."
        );
        let apart = reading(Verdict::CannotTellApart).answer();
        assert!(
            apart.decided_by.ends_with(
                "with 'strain hardening' in the model, 'scale error' adds nothing the tests can tell (p = 0.16)."
            ),
            "{}",
            apart.decided_by
        );
    }
}
