//! The words of the diagnosis, generated from the numbers and the decision alone: a verdict line,
//! one action, the evidence one fact per line, and the limits. Every word of significance comes from
//! the test, and the α, that made the decision; the only other words it knows are the design
//! variables', parameters' and candidates' names.

use super::after_loop::AfterLoop;
use super::ranking::RivalTest;
use super::shapes::Origin;
use super::verdict::{Decision, Verdict, Who};
use super::{Candidate, Context, Extended, LackOfFit, NextTest, NoiseModel, Residual, Role};

pub(crate) use crate::base::format::{num, p_text, params, pct};

pub(crate) struct Facts<'a> {
    pub cx: &'a Context<'a>,
    pub noise: &'a NoiseModel,
    /// The candidates, the residuals and their trends, the confounded shapes.
    pub found: &'a super::Found<'a>,
    /// The uncorrected model's entry and the rival tests.
    pub ranked: &'a super::ranking::Ranked,
    pub decision: &'a Decision,
    pub extended: Option<&'a Extended>,
    pub next_test: Option<&'a NextTest>,
    /// The hypotheses the loop's models extend (their names), by loop index.
    pub loop_names: &'a [String],
    /// How the loop's models changed the screening's verdict.
    pub after_loop: Option<&'a AfterLoop>,
    /// How far the final model's parameters move when its misfit is absorbed.
    pub parameter_limits: &'a [super::limits::ParameterLimit],
}

impl Facts<'_> {
    fn name(&self, who: Who) -> String {
        super::verdict::name_of(who, self.found.candidates, self.loop_names)
    }

    /// The screening candidate behind an explanation (a loop model's: the one it extends).
    fn candidate(&self, who: Who) -> Option<&Candidate> {
        let name = self.name(who);
        self.found.candidates.iter().find(|c| c.shape.name == name)
    }
}

pub(crate) struct Words {
    pub headline: String,
    pub action: String,
    pub evidence: Vec<String>,
    pub limits: Vec<String>,
    pub summary: String,
}

fn direction(mean_rel: f64) -> &'static str {
    if mean_rel < 0.0 {
        "under-predicts"
    } else {
        "over-predicts"
    }
}

/// Designs with their standardised misses: `h8 (+2.4 σ), h13 (-3.1 σ)`.
fn misses(z: &[(String, f64)]) -> String {
    z.iter()
        .map(|(n, z)| format!("{n} ({z:+.1} σ)"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn quoted(names: &[String]) -> String {
    names.iter().map(|n| format!("'{n}'")).collect::<Vec<_>>().join(" and ")
}

/// The words of a decision: its headline, the action, the evidence (after the verdict and the
/// action, what a library search `discovered`, marked as found, not listed), the limits, and the
/// summary of them all.
pub(crate) fn describe(f: &Facts, discovered: &[String]) -> Words {
    let headline = headline(f);
    let action = action(f);
    let mut evidence = discovered.to_vec();
    evidence.extend(evidence_lines(f));
    let limits = limits(f);
    let summary = summary(&headline, &action, &evidence, &limits);
    Words {
        headline,
        action,
        evidence,
        limits,
        summary,
    }
}

impl super::Diagnosis {
    /// Writes `summary` again from the headline, action, evidence and limits (after a later step
    /// added to them).
    pub(crate) fn resummarise(&mut self) {
        self.record.summary = summary(
            &self.finding.headline,
            &self.finding.action,
            &self.finding.evidence,
            &self.finding.limits,
        );
    }

    /// The words of what only the pipeline's later steps know, added once the decision is final:
    /// which part of the stroke decided a cause named from the curves' features (in the headline),
    /// and one line of evidence per model the solver in the loop calibrated.
    pub fn worded(mut self) -> super::Diagnosis {
        let decided = self
            .checked
            .features
            .as_ref()
            .and_then(|r| Some((r.decided_by.clone()?, r.decided_share?)));
        if let (Some((name, share)), Some(_)) = (decided, &self.finding.cause) {
            let headline = self.finding.headline.trim_end_matches('.').to_string();
            self.finding.headline = format!(
                "{headline}; decided by the {name} ({:.0} % of the misfit the extended model removes).",
                100.0 * share
            );
        }
        let lines: Vec<String> = self.explained.extensions.iter().map(|x| x.evidence_line()).collect();
        self.finding.evidence.extend(lines);
        self.resummarise();
        self
    }
}

impl super::Diagnosis {
    /// One line of evidence per model the solver confirmed at its fitted parameters, after the
    /// verdict's own evidence.
    pub(crate) fn worded_confirmation(mut self) -> super::Diagnosis {
        let measured = self.record.noise.from_replicates();
        let lines: Vec<String> = (self.checked.confirmation.iter())
            .map(|c| confirmation_line(c, measured))
            .collect();
        self.finding.evidence.extend(lines);
        if self.finding.verdict == Verdict::NoModelError {
            self.finding.headline = no_model_error_headline(&self);
        }
        if let (Some(r), Some(e)) = (&self.checked.solver_refit, &self.explained.extended) {
            let next = next_test_clause(self.finding.verdict, self.explained.next_test.as_ref());
            self.finding.action = cause_action(e, next, ", as the solver refits them");
            self.finding
                .limits
                .push(solver_refit_line(r, &self.explained.extensions));
        }
        if let Some(line) = fit_strength(&self) {
            self.finding.limits.push(line);
        }
        if self.checked.emulator.as_ref().is_some_and(|e| e.unjudged.is_some()) {
            self.finding.limits.push(
                "Not confirmed by the solver: its runs at the fitted parameters could not be judged (see the \
                 confirmation lines); the verdict rests on the emulators alone."
                    .into(),
            );
        }
        self.resummarise();
        self
    }
}

/// What a fit the verdict claims can show, where the noise is estimated from the replicates: the
/// largest standardised residual its test lets pass, t(ν) at the Šidák-corrected level of its
/// record, beside the normal's were the noise known. On three specimens at three designs (ν = 4 to
/// 6) a miss of six to nine standard deviations passes, so "fits" is weak evidence, and the reader
/// is told so rather than left to assume a known noise (docs/diagnosis.md, "Lack of fit").
fn fit_strength(d: &super::Diagnosis) -> Option<String> {
    let model = super::confirm::claims(d)
        .into_iter()
        .find_map(|(m, c)| (c == super::confirm::Claim::Fits).then_some(m))?;
    let confirmed = d.checked.confirmation.iter().find(|c| c.model == model);
    let l = confirmed.and_then(|c| c.lack_of_fit.as_ref()).filter(|l| l.fits)?;
    let r = l.largest.as_ref()?;
    if l.noise_dof >= super::noise::KNOWN_DOF || !d.record.noise.from_replicates() {
        return None;
    }
    let (t, z) = l.passes_up_to()?;
    Some(format!(
        "The fit is judged on a noise measured on {} degrees of freedom: its largest-residual test (at {}, Šidák \
         over {}) lets a residual of up to {} standard deviations pass ({} were the noise known); more specimens \
         per design would sharpen it.",
        l.noise_dof,
        num(l.level),
        r.residuals,
        num(t),
        num(z)
    ))
}

/// The solver's refit of a named cause's parameters, in words, beside the loop's interval it left.
fn solver_refit_line(r: &super::refit::SolverRefit, loops: &[super::joint::SolverExtension]) -> String {
    let interval = |(n, v): (&String, &f64)| match r.interval95.get(n) {
        Some([lo, hi]) => format!("{n} = {} (95 % {} to {})", num(*v), num(*lo), num(*hi)),
        None => format!("{n} = {}", num(*v)),
    };
    let looped = loops.iter().find(|x| x.setup.hypothesis == r.model);
    let left: Vec<String> = (r.outside.iter())
        .filter_map(|n| {
            let [lo, hi] = looped?.fitted.interval95.as_ref()?.get(n)?;
            Some(format!("{n} ({} to {})", num(*lo), num(*hi)))
        })
        .collect();
    format!(
        "The solver's runs at the loop's fitted point ({}) refit the model with '{}' to {}, outside the loop's 95 % \
         interval of {}: the loop's emulators are off there, so the parameters given are the refit's, its values \
         moved along the emulators' slope from the solver's at that point (the model judged to fit is the \
         refitted one); runs at each tested design there would confirm them.",
        params(&r.from),
        r.model,
        r.to.iter().map(interval).collect::<Vec<_>>().join(", "),
        left.join(" and ")
    )
}

/// "No model error" said of what it rests on: the solver at the fitted parameters against the
/// tests' scatter alone where it ran; else the emulators, and their error named where it was
/// counted — "within the tests' scatter" is said of the tests' scatter only.
fn no_model_error_headline(d: &super::Diagnosis) -> String {
    let solver = d
        .checked
        .confirmation
        .iter()
        .find(|c| c.model == super::confirm::UNCORRECTED)
        .and_then(|c| Some((c, c.lack_of_fit.as_ref().filter(|l| l.fits)?)));
    let counted = d
        .checked
        .emulator
        .as_ref()
        .is_some_and(|e| e.confirmed.as_deref().or(e.unjudged.as_deref()) == Some("counted"));
    let detail = match (solver, &d.record.lack_of_fit) {
        (Some((c, l)), _) => format!(
            "the solver at the fitted parameters ({}) fits the tests within {} ({})",
            params(&c.at),
            scatter_words(c),
            lack_of_fit(l)
        ),
        (None, Some(l)) if counted => format!(
            "the uncorrected simulation's emulators fit the tests within their scatter and the emulators' own \
             error ({})",
            lack_of_fit(l)
        ),
        _ => return d.finding.headline.clone(),
    };
    format!("No model error beyond the noise: {detail}.")
}

/// Named ranges in words: "etan in [0, 257.8], …".
fn range(m: &indexmap::IndexMap<String, [f64; 2]>) -> String {
    m.iter()
        .map(|(k, [lo, hi])| format!("{k} in [{}, {}]", num(*lo), num(*hi)))
        .collect::<Vec<_>>()
        .join(", ")
}

/// What no model error leaves open of one listed hypothesis, in words.
pub(crate) fn not_excluded_line(n: &super::open::NotExcluded) -> String {
    let detect = match n.detectable.is_empty() {
        true => "any size the range allows".to_string(),
        false => params(&n.detectable),
    };
    format!(
        "'{}' is not excluded by these tests ({}{}); over that range {}; an effect smaller than {detect} could not \
         have been detected. A test where it changes the response most, or an independent measurement of the \
         parameters, would tell.",
        n.hypothesis,
        range(&n.amplitude),
        open_runs(n),
        range(&n.parameters)
    )
}

impl super::Diagnosis {
    /// The decision of the loop started because the solver's runs over these extensions' amplitudes
    /// (`open`, before the loop) favoured them: where it is not "no model error" (which reads its
    /// own), the ranges those runs leave open are kept (`not_excluded`) and said beside the loop's
    /// intervals, which are its emulators'.
    pub(crate) fn after_favoured(mut self, open: &[super::open::NotExcluded]) -> super::Diagnosis {
        if self.finding.verdict == Verdict::NoModelError {
            return self;
        }
        let favoured: Vec<super::open::NotExcluded> = open.iter().filter(|n| n.favoured.is_some()).cloned().collect();
        for n in &favoured {
            self.finding.limits.push(format!(
                "before the loop, the solver's runs over '{}' left it open over {}{}, over which {}: the loop's \
                 intervals are read from its emulators, these from the solver's runs.",
                n.hypothesis,
                range(&n.amplitude),
                open_runs(n),
                range(&n.parameters)
            ));
        }
        self.checked.not_excluded = favoured;
        self.resummarise();
        self
    }
}

/// Where an open range was read from: the solver's runs over the amplitude, or the screening's
/// probes.
fn open_runs(n: &super::open::NotExcluded) -> String {
    let Some(name) = n.amplitude.keys().next() else {
        return String::new();
    };
    let values: Vec<String> = (n.runs.iter())
        .filter_map(|r| r.amplitude.get(name).map(|v| num(*v)))
        .collect();
    match values.is_empty() {
        true => ", read from the screening's probes, linearised".into(),
        false => format!(
            ", read from the solver run at {name} = {} at every tested design",
            values.join(", ")
        ),
    }
}

impl super::Diagnosis {
    /// What "no model error" leaves open read again from the solver's runs over the amplitudes
    /// (`open`, in the order of the screening's): its words replace the screening's.
    /// `designs`: the tested designs, where runs would decide ([`Self::favoured_by_the_solver`]).
    pub(crate) fn with_open(mut self, open: Vec<super::open::NotExcluded>, designs: &[String]) -> super::Diagnosis {
        for (old, new) in self.checked.not_excluded.iter().zip(&open) {
            let (was, now) = (not_excluded_line(old), not_excluded_line(new));
            for line in self.finding.limits.iter_mut().filter(|l| **l == was) {
                line.clone_from(&now);
            }
            self.finding.action = self.finding.action.replace(&open_clause(old), &open_clause(new));
        }
        self.checked.not_excluded = open;
        self.resummarise();
        self.favoured_by_the_solver(designs)
    }

    /// "No model error" refuted by the solver's runs over an open extension's amplitude
    /// ([`super::open::Favoured`]): the emulators' reading (no model error) against the solver's
    /// (the extension improves the fit beyond its level), so undecided — `emulator_limited` — with
    /// the runs that would decide: the extended model at the profile's best point, at every
    /// tested design.
    fn favoured_by_the_solver(mut self, designs: &[String]) -> super::Diagnosis {
        let favoured = super::open::favoured_first(&self.checked.not_excluded);
        let Some(&(n, f)) = favoured.first() else {
            return self;
        };
        let deciding: Vec<super::confirm::DecidingRuns> = favoured
            .iter()
            .map(|(n, f)| super::confirm::DecidingRuns {
                model: n.hypothesis.clone(),
                at: f.at.clone(),
                designs: designs.to_vec(),
                unchecked: false,
            })
            .collect();
        self.finding.headline = match favoured.len() {
            1 => format!(
                "Undecided: the emulators' error, not the tests, decides: the emulators found no model error, but \
                 the solver run over '{}' favours it — χ² falls by {} from its absence to its best ({}), beyond {} \
                 (its amplitude test's critical value at {}); these tests do not exclude it over {}, over which {}.",
                n.hypothesis,
                num(f.drop),
                params(&f.at),
                num(f.critical),
                num(f.level),
                range(&n.amplitude),
                range(&n.parameters)
            ),
            _ => format!(
                "Undecided: the emulators' error, not the tests, decides: {}; these tests do not exclude {}.",
                favoured_words(&favoured),
                (favoured.iter())
                    .map(|(n, _)| format!(
                        "'{}' over {}, over which {}",
                        n.hypothesis,
                        range(&n.amplitude),
                        range(&n.parameters)
                    ))
                    .collect::<Vec<_>>()
                    .join(", nor ")
            ),
        };
        let names: Vec<String> = favoured.iter().map(|(n, _)| n.hypothesis.clone()).collect();
        self.finding.action = format!(
            "Action: do not take the calibrated parameters as the answer yet: {} (the solver in the loop over {} \
             decides; until then, the parameters lie over the range{} above).",
            deciding_words(&deciding),
            quoted(&names),
            if names.len() == 1 { "" } else { "s" }
        );
        self.finding.verdict = Verdict::EmulatorLimited;
        self.finding.cause = None;
        for name in names.iter().rev() {
            self.finding.leading.retain(|l| l != name);
            self.finding.leading.insert(0, name.clone());
        }
        if let Some(e) = self.checked.emulator.as_mut() {
            e.deciding_runs = deciding;
        }
        self.resummarise();
        self
    }
}

/// Several extensions the solver's runs favour where the emulators found no model error, in words:
/// "the emulators found no model error, but the solver's runs over 'a' (χ² falls by … from its
/// absence to its best (…), beyond …) and 'b' (…) favour each against its absence (not yet against each
/// other)".
fn favoured_words(favoured: &[(&super::open::NotExcluded, &super::open::Favoured)]) -> String {
    let shown: Vec<String> = favoured
        .iter()
        .map(|(n, f)| {
            format!(
                "'{}' (χ² falls by {} from its absence to its best ({}), beyond {}, its amplitude test's critical \
                 value at {})",
                n.hypothesis,
                num(f.drop),
                params(&f.at),
                num(f.critical),
                num(f.level)
            )
        })
        .collect();
    format!(
        "the emulators found no model error, but the solver's runs over {} favour each against its absence (not \
         yet against each other)",
        shown.join(" and ")
    )
}

/// One open hypothesis in the action: absent, or else the parameters over its open range.
fn open_clause(n: &super::open::NotExcluded) -> String {
    format!(
        "'{}' is absent: these tests do not exclude it up to {}, over which {}",
        n.hypothesis,
        range(&n.amplitude),
        range(&n.parameters)
    )
}

/// A confirmation's model in words.
fn model_words(c: &super::confirm::Confirmation) -> String {
    named_model(&c.model)
}

/// A model of a verdict by its confirmation's name: the uncorrected simulation, or a cause's model.
fn named_model(model: &str) -> String {
    match model {
        super::confirm::UNCORRECTED => "the uncorrected simulation".to_string(),
        name => format!("the model with '{name}'"),
    }
}

/// What a confirmation was judged against: the tests' scatter alone, or with the solver's own
/// between the seeds of its imperfection.
fn scatter_words(c: &super::confirm::Confirmation) -> String {
    match &c.scatter {
        None => "their scatter alone".to_string(),
        Some(s) => format!(
            "their scatter and the solver's own between {} seeds of its imperfection (its standard deviation {} of \
             one specimen's, on {} degrees of freedom)",
            s.seeds,
            s.relative_sd.iter().map(|r| num(*r)).collect::<Vec<_>>().join(", "),
            s.dof
        ),
    }
}

/// What the solver showed of one model at its fitted parameters. Against a noise estimated from the
/// residuals (`measured` false: no replicates, no stated uncertainty) a model is never said to fit:
/// the scatter is the models' own misfit (docs/diagnosis.md, "Noise that is not measured").
fn confirmation_line(c: &super::confirm::Confirmation, measured: bool) -> String {
    let model = model_words(c);
    let shown = match &c.lack_of_fit {
        Some(l) if l.fits && !measured => format!(
            "stays within the scatter estimated from the models' residuals ({}), which is no test of fit: the \
             tests have no replicates",
            lack_of_fit(l)
        ),
        Some(l) if !measured => format!(
            "misses the tests beyond the scatter estimated from the models' residuals ({})",
            lack_of_fit(l)
        ),
        Some(l) if l.fits => format!("fits the tests within {} ({})", scatter_words(c), lack_of_fit(l)),
        Some(l) => format!("misses the tests beyond {} ({})", scatter_words(c), lack_of_fit(l)),
        None if c.runs.iter().any(|r| r.solver.is_none()) => "cannot be judged: a run failed".to_string(),
        None => "cannot be judged: the tests give no noise to judge against".to_string(),
    };
    let miss = c.emulator_miss.map_or(String::new(), |m| {
        format!(
            "; the emulators were off by up to {} of the tests' noise of the mean there",
            num(m)
        )
    });
    let rivals: String = c.rivals.iter().filter_map(rival_on_runs).collect();
    let at = match c.reused {
        true => format!(
            "The loop's solver runs at {}, within one standard error of the fitted parameters of {model}",
            params(&c.at)
        ),
        false => format!("Solver runs at the fitted parameters of {model} ({})", params(&c.at)),
    };
    format!("{at}: it {shown}{miss}{rivals}.")
}

/// A rival's shape added to a confirmed model on the solver's runs, in words (none where it could
/// not be judged).
fn rival_on_runs(r: &super::confirm::RivalOnRuns) -> Option<String> {
    let p = r.p_value?;
    Some(match r.adds() {
        true => format!(
            "; on these runs '{}' still adds to it (p = {}, below the pair's level {}): the emulators hid it",
            r.shape_of,
            num(p),
            num(r.level)
        ),
        false => format!(
            "; on these runs '{}' adds nothing to it (p = {} ≥ {})",
            r.shape_of,
            num(p),
            num(r.level)
        ),
    })
}

/// The verdict when the emulators' error decides it: the noise-alone diagnosis as the record,
/// worded from both decisions and from what the solver showed at the fitted parameters, with the
/// runs that would decide.
pub(crate) fn emulator_limited(
    noise_alone: &super::Diagnosis,
    counted: &super::Diagnosis,
    confirmations: &[super::confirm::Confirmation],
    deciding: &[super::confirm::DecidingRuns],
) -> super::Diagnosis {
    let mut d = noise_alone.clone();
    let short = |x: &super::Diagnosis| match &x.finding.cause {
        Some(c) => format!("{} ('{c}')", x.finding.verdict.words()),
        None => x.finding.verdict.words().to_string(),
    };
    let shown: Vec<String> = confirmations
        .iter()
        .filter_map(|c| {
            let l = c.lack_of_fit.as_ref()?;
            let adding: Vec<String> = c
                .rivals
                .iter()
                .filter(|r| r.adds())
                .map(|r| format!("'{}'", r.shape_of))
                .collect();
            let still = match adding.is_empty() {
                true => String::new(),
                false => format!(" but {} still adds to it", adding.join(" and ")),
            };
            Some(format!(
                "{} {} the tests{still}",
                model_words(c),
                if l.fits { "fits" } else { "misses" }
            ))
        })
        .collect();
    let solver = match shown.is_empty() {
        true => "no solver run at the fitted parameters could be judged".to_string(),
        false => format!("the solver at the fitted parameters says {}", shown.join(" and ")),
    };
    d.finding.headline = format!(
        "Undecided: the emulators' error, not the tests, decides: with the tests' scatter alone, {}; with the \
         emulators' error counted, {}; {solver}, which confirms neither.",
        short(noise_alone),
        short(counted)
    );
    d.finding.action = format!(
        "Do not take either model's parameters as the answer yet: {} (with `sampling: sequential`, a larger \
         `sampling.budget`; with a fixed design, more samples, so that the emulators follow the solver there).",
        deciding_words(deciding)
    );
    d.finding.verdict = super::verdict::Verdict::EmulatorLimited;
    let mut leading = noise_alone.finding.leading.clone();
    leading.extend(
        counted
            .finding
            .leading
            .iter()
            .filter(|l| !noise_alone.finding.leading.contains(l))
            .cloned(),
    );
    d.finding.leading = leading;
    d.finding.cause = None;
    d.finding.partial = None;
    d.explained.extended = None;
    d
}

/// The runs that would decide, in words: how many, where, at which parameters.
pub(crate) fn deciding_words(deciding: &[super::confirm::DecidingRuns]) -> String {
    let runs: usize = deciding.iter().map(|r| r.designs.len()).sum();
    let Some(first) = deciding.first() else {
        return "more solver runs around the fitted parameters at the tested designs would decide".to_string();
    };
    let points: Vec<String> = deciding
        .iter()
        .map(|r| match r.unchecked {
            false => format!("{} for {}", params(&r.at), named_model(&r.model)),
            true => format!(
                "{} for {} (its loop's fit, where the solver has not run: there it says whether that model leaves the \
                 other's shape)",
                params(&r.at),
                named_model(&r.model)
            ),
        })
        .collect();
    format!(
        "{runs} more solver runs would decide — one at each tested design ({}) at each model's parameters refitted \
         to its solver runs: {}; there the solver alone says whether each model fits",
        first.designs.join(", "),
        points.join("; ")
    )
}

/// The verdict, the action, the evidence one per line, then the limits: the terminal's and the
/// report's text.
pub(crate) fn summary(headline: &str, action: &str, evidence: &[String], limits: &[String]) -> String {
    let mut summary = format!("{headline}\n{action}");
    for e in evidence {
        summary.push_str(&format!("\n- {e}"));
    }
    for l in limits {
        summary.push_str(&format!("\n- limit: {l}"));
    }
    summary
}

pub(crate) fn headline(f: &Facts) -> String {
    let d = f.decision;
    let words = d.verdict.words();
    let first_up = |s: &str| {
        let mut ch = s.chars();
        ch.next()
            .map(|x| x.to_uppercase().collect::<String>() + ch.as_str())
            .unwrap_or_default()
    };
    let detail = match d.verdict {
        Verdict::NoModelError => match &f.ranked.base.assessed.lack_of_fit {
            Some(l) => format!(
                "the uncorrected simulation fits the tests within their scatter ({})",
                lack_of_fit(l)
            ),
            None => "no candidate improves on the uncorrected simulation beyond the residual scatter".to_string(),
        },
        Verdict::CauseNamed if f.after_loop.is_some() => {
            let who = d.cause.expect("a cause");
            after_loop_named(f, who)
        }
        Verdict::CauseNamed => {
            let k = f.candidate(d.cause.expect("a cause")).expect("a candidate");
            let worst = f
                .ranked
                .rivals
                .iter()
                .filter_map(|r| r.p_leader_given_rival)
                .fold(0.0, f64::max);
            format!(
                "'{}' ({}; weight {:.2}, {}), decisive: it beats every rival (largest p of the encompassing tests {})",
                k.shape.name,
                k.shape.term,
                k.scores.weight,
                k.fit.p_value.map_or("-".into(), p_text),
                num(worst)
            )
        }
        Verdict::CannotTellApart => cannot_tell_apart(f),
        Verdict::PartlyExplained => partly_explained(f),
        Verdict::Unexplained => unexplained(f),
        Verdict::TooFewTests => too_few_reason(f),
        // Decided from two diagnoses and the solver's runs, not from one's facts: [`emulator_limited`].
        Verdict::EmulatorLimited => "the emulators' error decides".to_string(),
    };
    format!("{}: {detail}.", first_up(words))
}

/// "Unexplained": the misfit, and the candidate the data come nearest to detecting with the level
/// its amplitude test needed (the one the next test examines).
fn unexplained(f: &Facts) -> String {
    let misfit = in_parentheses(f.ranked.base.assessed.lack_of_fit.as_ref());
    let nearest = f
        .decision
        .leading
        .first()
        .and_then(|&who| f.candidate(who))
        .and_then(|c| {
            let level = f.cx.levels().amplitude(f.found.candidates.len());
            c.fit.p_value.map(|p| {
                format!(
                    "; the nearest, '{}', has {} where p < {} was needed",
                    c.shape.name,
                    p_text(p),
                    num(level)
                )
            })
        });
    format!(
        "the simulation misses the tests beyond the noise{misfit}, and no candidate reduces the misfit significantly{}",
        nearest.unwrap_or_default()
    )
}

/// "Cannot tell apart": the open explanations, their weights, and whether each explains the misfit
/// or — every one's own model missing the tests — only part of it.
fn cannot_tell_apart(f: &Facts) -> String {
    let d = f.decision;
    let open: Vec<Who> = d.leading.clone();
    let names: Vec<String> = open.iter().take(3).map(|&w| f.name(w)).collect();
    let more = match open.len().saturating_sub(3) {
        0 => String::new(),
        n => format!(" (and {n} more)"),
    };
    let weights: Vec<String> = match f.after_loop {
        Some(a) => names
            .iter()
            .filter_map(|n| a.explanations.iter().find(|j| &j.name == n))
            .map(|j| format!("{:.2}", j.weight))
            .collect(),
        None => open
            .iter()
            .take(3)
            .filter_map(|&w| f.candidate(w))
            .map(|c| format!("{:.2}", c.scores.weight))
            .collect(),
    };
    let after = if f.after_loop.is_some() {
        " — also with the models the loop calibrated"
    } else {
        ""
    };
    // Where every open explanation's own model misses the tests, none explains the whole
    // misfit: each removes part of it, and which part is whose is what the data leave open.
    let misses = |n: &String| match f.after_loop {
        Some(a) => a.explanations.iter().find(|j| &j.name == n).is_some_and(|j| j.rejected),
        None => f
            .found
            .candidates
            .iter()
            .find(|c| &c.shape.name == n)
            .and_then(|c| c.checks.lack_of_fit.as_ref())
            .is_some_and(LackOfFit::rejects),
    };
    let all: Vec<String> = open.iter().map(|&w| f.name(w)).collect();
    let explains = if all.iter().all(misses) {
        "each explains part of the misfit and none all of it (each one's own model misses the tests), and \
         the data cannot tell which part is whose"
    } else {
        "each explains the misfit, but the data cannot tell them apart"
    };
    format!(
        "{}{more}: {explains}{after} (weights {})",
        quoted(&names),
        weights.join(", ")
    )
}

/// "Partly explained": no listed cause accounts for the misfit; which one removes part of it, how
/// much, and why its model is not a fit (each failed test with its figures).
fn partly_explained(f: &Facts) -> String {
    let d = f.decision;
    let k = f.candidate(d.cause.expect("a cause")).expect("a candidate");
    let share = f
        .extended
        .and_then(|e| e.check.lack_of_fit.as_ref())
        .zip(f.ranked.base.assessed.lack_of_fit.as_ref())
        .and_then(|(e, u)| e.share_removed(u))
        .map_or(String::new(), |s| {
            format!(" (it removes {:.0} % of the misfit beyond the noise)", 100.0 * s)
        });
    let lof = f
        .extended
        .and_then(|e| e.check.lack_of_fit.as_ref())
        .filter(|l| l.rejects())
        .map(|l| format!("its model still misses the tests beyond the noise ({})", lack_of_fit(l)));
    let bound = f.cx.levels().rival(f.ranked.rivals.len());
    // Before the loop the rivals' encompassing tests say what still adds; after it, the decision's
    // own second explanation.
    let rival = f
        .after_loop
        .is_none()
        .then_some(f.ranked.rivals.as_slice())
        .into_iter()
        .flatten()
        .filter_map(|r| Some((r, r.p_rival_given_leader.filter(|p| *p < bound)?)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(r, p)| {
            format!(
                "'{}' still explains part of what remains with it in the model (encompassing test {})",
                r.rival,
                p_text(p)
            )
        });
    let also = f
        .after_loop
        .and(d.compare.get(1))
        .filter(|w| **w != Who::Uncorrected)
        .map(|&w| {
            format!(
                "'{}' still explains part of what remains with it in the model",
                f.name(w)
            )
        });
    let mut why: Vec<String> = lof.into_iter().chain(rival).chain(also).collect();
    if why.is_empty() {
        why.push("a listed shape still explains part of what its model leaves".into());
    }
    format!(
        "no listed cause accounts for the misfit; '{}' ({}) explains part of it{share}, but {}",
        k.shape.name,
        k.shape.term,
        why.join("; and ")
    )
}

fn too_few_reason(f: &Facts) -> String {
    let cx = f.cx;
    let n = cx.train.len();
    let p = cx.p();
    if !cx.known() && n < p + 4 {
        format!(
            "{n} training design(s) without replicate tests leave nothing to measure the misfit against (a test of \
             model error needs replicates, or at least {} training designs for {p} parameter(s))",
            p + 4
        )
    } else if !cx.known() {
        let unmeasured = "the tests have no replicates and the study states no measurement uncertainty \
                          (`experiments.uncertainty`), so their noise is not measured, and on a noise estimated from \
                          the residuals of the models being judged no model is said to fit and no cause is decisive";
        match f.decision.leading.first().filter(|_| f.decision.detected) {
            Some(&w) => format!(
                "{unmeasured}; '{}' reduces the misfit beyond the residuals' scatter: model error is likely, its cause \
                 a leading candidate",
                f.name(w)
            ),
            None => format!("{unmeasured}; no candidate reduces the misfit beyond the residuals' scatter"),
        }
    } else {
        format!(
            "with {n} training design(s) for {p} parameter(s), every candidate fits the training tests; the misfit is \
             within the noise{}, but so few designs could hide an error of several times the noise",
            in_parentheses(f.ranked.base.assessed.lack_of_fit.as_ref())
        )
    }
}

/// The next test in the action's words: where, what it tells apart and how many specimens; none
/// for a named cause whose confirming test the specimens in hand already give.
fn next_test_clause(verdict: Verdict, next_test: Option<&NextTest>) -> Option<String> {
    let confirming = next_test.filter(|t| !(verdict == Verdict::CauseNamed && t.in_hand()));
    confirming.map(|t| {
        let at = params(&t.choice.design);
        let names: Vec<String> = t.choice.compared.keys().cloned().collect();
        if names.len() < 2 {
            format!("test at {at} — {}", t.choice.advice)
        } else {
            format!("test at {at} to tell {} apart — {}", quoted(&names), t.choice.advice)
        }
    })
}

/// "Action: use the model extended with 'c' (its parameters){whence}; to confirm it, …".
fn cause_action(e: &Extended, next: Option<String>, whence: &str) -> String {
    format!(
        "Action: use the model extended with '{}' ({}){whence}; {}.",
        e.model.cause,
        params(&e.model.parameters),
        next.map_or_else(
            || "the tests in hand decide, no further test is needed".into(),
            |n| format!("to confirm it, {n}")
        )
    )
}

fn action(f: &Facts) -> String {
    action_with_open(f, &[])
}

/// The action, where no model error leaves listed hypotheses open (`open`, [`super::open`]): the
/// calibrated simulation holds only where they are absent, and the parameters over what the tests
/// do not exclude are said first.
pub(crate) fn action_with_open(f: &Facts, open: &[super::open::NotExcluded]) -> String {
    let next = next_test_clause(f.decision.verdict, f.next_test);
    match (f.decision.verdict, f.extended) {
        (Verdict::CauseNamed, Some(e)) => cause_action(e, next, ""),
        (Verdict::NoModelError, _) if !open.is_empty() => format!(
            "Action: use the calibrated simulation only where {}; {}.",
            open.iter().map(open_clause).collect::<Vec<_>>().join(", and where "),
            next.map_or_else(
                || "an independent measurement of the parameters, or tests where the effect changes the response most, would tell".into(),
                |n| format!("the test most likely to tell: {n}")
            )
        ),
        (Verdict::NoModelError, _) => format!(
            "Action: use the calibrated simulation as it is{}.",
            next.map_or(String::new(), |n| format!(
                "; the test most likely to expose a hidden error: {n}"
            ))
        ),
        _ => format!(
            "Action: {}.",
            next.unwrap_or_else(|| "more tests at new designs".into())
        ),
    }
}

fn evidence_lines(f: &Facts) -> Vec<String> {
    let mut out = Vec::new();
    if let Some(l) = &f.ranked.base.assessed.lack_of_fit {
        out.push(format!(
            "Misfit of the uncorrected simulation against the replicate noise: {} ({} the noise: each test at {}, α \
             shared by the two).",
            lack_of_fit(l),
            if l.rejects() { "beyond" } else { "within" },
            num(l.level)
        ));
    }
    out.extend(where_it_errs(f));
    out.extend(leading_line(f));
    if let Some(a) = f.after_loop {
        out.extend(after_loop_lines(f, a));
    }
    if let Some(c) = f
        .decision
        .cause
        .or(f.decision.leading.first().copied())
        .and_then(|w| f.candidate(w))
    {
        out.extend(separation(c));
    }
    let unbeaten: Vec<&RivalTest> = f.ranked.rivals.iter().filter(|r| !r.beaten).collect();
    for r in unbeaten.iter().take(if f.after_loop.is_some() { 0 } else { 3 }) {
        out.push(match r.p_leader_given_rival {
            Some(p) => format!(
                "With '{}' in the model, the leader adds nothing significant (encompassing test p = {} ≥ {}).",
                r.rival,
                num(p),
                rival_level(f)
            ),
            None => format!("'{}' is not rejected by the validation designs either.", r.rival),
        });
    }
    out.extend(ruled_out(f));
    if let Some(e) = f.extended {
        out.extend(extended_lines(e));
    }
    out.extend(f.found.confounded.iter().map(|c| format!("{c}.")));
    out
}

/// The level each rival test is at, in words: α shared among the rivals, since the data chose the
/// leader among them ([`super::ranking`]).
fn rival_level(f: &Facts) -> String {
    level_words(f.cx.alpha(), f.cx.levels().rival(f.ranked.rivals.len()))
}

/// "α = 0.01", or "α/5 = 0.002" for a share of α.
fn level_words(alpha: f64, level: f64) -> String {
    let share = (alpha / level).round();
    if share > 1.0 {
        format!("α/{share} = {}", num(level))
    } else {
        format!("α = {}", num(level))
    }
}

/// Why a hypothesis the study lists is not among the leading explanations: the rival test the
/// leader won against it (a listed cause is never dropped unsaid). One the loop's models judged is
/// said by them instead.
fn ruled_out(f: &Facts) -> Vec<String> {
    let Some(leader) = f.ranked.leader.map(|l| f.ranked.entries[l].model.name().to_string()) else {
        return Vec::new();
    };
    let listed = |name: &str| {
        (f.ranked.entries.iter())
            .any(|e| e.model.name() == name && e.model.shape.as_ref().is_some_and(|s| s.origin == Origin::Study))
    };
    (f.ranked.rivals.iter())
        .filter(|r| r.beaten && listed(&r.rival) && !f.loop_names.contains(&r.rival))
        .map(|r| match r.p_leader_given_rival {
            Some(p) => format!(
                "'{}' alone does not explain the misfit: with it in the model, '{leader}' still adds (encompassing test {}, below {}).",
                r.rival,
                p_text(p),
                rival_level(f)
            ),
            None => format!(
                "'{}' is ruled out by the validation designs: its prediction misses them while the prediction of \
                 '{leader}' holds.",
                r.rival
            ),
        })
        .collect()
}

/// The leading candidates with their weights (and the uncorrected model's, where it is scored).
fn leading_line(f: &Facts) -> Option<String> {
    let ranked: Vec<String> = f
        .found
        .candidates
        .iter()
        .take(3)
        .map(|c| {
            format!(
                "'{}' {:.2}{}",
                c.shape.name,
                c.scores.weight,
                c.fit.p_value.map_or(String::new(), |p| format!(" ({})", p_text(p)))
            )
        })
        .collect();
    if ranked.is_empty() {
        return None;
    }
    let base_w = f
        .ranked
        .base
        .score
        .as_ref()
        .map(|_| format!("; uncorrected {:.2}", f.ranked.base.weight));
    Some(format!(
        "Leading candidates (weight): {}{}.",
        ranked.join(", "),
        base_w.unwrap_or_default()
    ))
}

/// The extended model's parameters and errors, and what it still misses.
fn extended_lines(e: &Extended) -> Vec<String> {
    let mut out = Vec::new();
    out.push(format!(
        "Extended model: {}; {} error {} → {}{}.",
        params(&e.model.parameters),
        e.gains.measured_on,
        pct(e.gains.validation_error_before),
        pct(e.gains.validation_error_after),
        match (e.gains.loo_error_before, e.gains.loo_error_after) {
            (Some(b), Some(a)) if e.gains.measured_on != "leave-one-out" =>
                format!("; leave-one-design-out {} → {}", pct(b), pct(a)),
            _ => String::new(),
        }
    ));
    if !e.check.remaining.is_empty() {
        let at = misses(&e.check.remaining);
        out.push(format!(
            "What remains unexplained: the extended model still misses {at}."
        ));
    }
    out
}

/// The mean and largest error of the uncorrected simulation, and the significant trends. With
/// several outputs per design (curve features) the mean is the plateau level's relative error and
/// the largest misfit is the observation furthest from its prediction in units of its noise.
fn where_it_errs(f: &Facts) -> Vec<String> {
    let r = f.found.residuals;
    let obs = &f.cx.inputs.observations;
    let mut out = Vec::new();
    let mut groups: Vec<&str> = obs
        .iter()
        .filter(|o| o.role == Role::Training)
        .map(|o| o.group.as_str())
        .collect();
    groups.dedup();
    let n_train = groups.len();
    let rel: Vec<f64> = r.iter().filter_map(|x| x.relative_error).collect();
    let mean_rel = rel.iter().sum::<f64>() / rel.len().max(1) as f64;
    let values = |x: &Residual| params(&x.values);
    let several = f.cx.inputs.outputs() > 1;
    if several {
        if let Some(w) = r
            .iter()
            .filter(|x| x.z.is_finite())
            .max_by(|a, b| a.z.abs().total_cmp(&b.z.abs()))
        {
            out.push(format!(
                "Calibrated on {n_train} training design(s), the simulation {} the plateau level by {} on average; the \
                 largest misfit is at {} ({}): {:+.1} σ of the mean.",
                direction(mean_rel),
                pct(mean_rel),
                w.design,
                values(w),
                w.z
            ));
        }
    } else if let Some((w, rel)) = r
        .iter()
        .filter_map(|x| Some((x, x.relative_error?)))
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
    {
        out.push(format!(
            "Calibrated on {n_train} training design(s), the simulation {} the tests by {} on average; the largest error \
             is at {} ({}): {} {}{}.",
            direction(mean_rel),
            pct(mean_rel),
            w.design,
            values(w),
            direction(rel),
            pct(rel),
            // In units of the noise only where the noise was measured (replicates).
            if f.noise.from_replicates() { format!(" ({:+.1} σ of the mean)", w.z) } else { String::new() }
        ));
    }
    let trends: Vec<String> = f
        .found
        .structure
        .iter()
        .filter(|t| t.significant)
        .map(|t| {
            format!(
                "{} (rank correlation {:.2}, {})",
                t.against,
                t.rank_correlation,
                p_text(t.rank_p_value.min(t.slope_p_value))
            )
        })
        .collect();
    out.push(if trends.is_empty() {
        format!("The residuals show no significant trend (α = {}).", f.cx.alpha())
    } else {
        format!(
            "The residuals trend with {} (α = {}).",
            trends.join(" and "),
            f.cx.alpha()
        )
    });
    out
}

/// The joint fit's figures for a candidate's amplitude.
fn separation(c: &Candidate) -> Option<String> {
    let s = &c.checks.separability;
    let ci = s.amplitude_ci95?;
    let corr = s
        .correlation
        .iter()
        .map(|(k, v)| format!("corr(γ, {k}) = {v:+.3}"))
        .collect::<Vec<_>>()
        .join(", ");
    Some(format!(
        "'{}': γ = {} (95 % interval {} to {}), {corr}, variance inflation {}.",
        c.shape.name,
        num(c.fit.amplitude),
        num(ci[0]),
        num(ci[1]),
        s.variance_inflation.map_or("∞".into(), num)
    ))
}

fn limits(f: &Facts) -> Vec<String> {
    let mut out = vec![format!("Noise: {}.", f.noise.note)];
    out.extend(parameter_limits(f.parameter_limits));
    if f.cx.mode == super::Mode::Few {
        out.push(format!(
            "Only {} training design(s): candidates are ranked by AIC and by their predictions at the validation \
             designs; leave-one-design-out is not possible.",
            f.cx.train.len()
        ));
    }
    if let Some(e) = f.extended {
        if let Some(x) = &e.check.extension {
            out.push(x.meaning.clone());
        }
        // Identifiability of the enlarged parameter set: γ nearly a function of one θ_j.
        let cause = f.found.candidates.iter().find(|c| c.shape.name == e.model.cause);
        for (name, r) in cause.iter().flat_map(|c| c.checks.separability.correlation.iter()) {
            if r.abs() > 0.99 {
                let se = e.model.parameter_se.as_ref().and_then(|s| s.get(name)).copied();
                out.push(format!(
                    "In the extended model γ and {name} are correlated at {r:+.3}: the tests fix them mostly together \
                     ({name} = {} ± {} in the extended fit); an independent measurement of {name} would pin both.",
                    num(e.model.parameters[name]),
                    se.map_or("?".into(), num)
                ));
            }
        }
        if !e.gains.before_within_noise.is_empty() && e.gains.measured_on == "validation" {
            out.push(format!(
                "At {} the uncorrected prediction is already within the noise, so the validation gain there says \
                 nothing; the leave-one-design-out gain {}.",
                e.gains.before_within_noise.join(", "),
                e.gains
                    .gain_loo
                    .map_or("is not available".into(), |g| format!("is {:.0} %", 100.0 * g))
            ));
        }
    }
    out
}

/// The parameters of a model that still misses the tests: how far each moves when the misfit is
/// absorbed, the one that moves most first.
fn parameter_limits(limits: &[super::limits::ParameterLimit]) -> Vec<String> {
    let Some(first) = limits.first() else {
        return Vec::new();
    };
    let at = misses(&first.absorbed);
    let moves: Vec<String> = limits
        .iter()
        .map(|l| {
            format!(
                "{} {} → {} ({:+.1} %{})",
                l.parameter,
                num(l.estimate),
                num(l.moved_to),
                100.0 * l.relative,
                l.standard_errors
                    .map_or(String::new(), |s| format!(", {} standard errors", num(s)))
            )
        })
        .collect();
    vec![format!(
        "The calibrated parameters are only as good as the model, which still misses the tests: with the misfit at          {at} absorbed, {}; {} is the most suspect.",
        moves.join(", "),
        first.parameter
    )]
}

/// The headline of a cause named from the loop's evidence.
fn after_loop_named(f: &Facts, who: Who) -> String {
    let name = f.name(who);
    let a = f.after_loop.expect("after the loop");
    let judged = a.explanations.iter().find(|j| j.name == name);
    let model = match who {
        Who::Extended(_) => "its model calibrated with the solver in the loop",
        _ => "its fitted model",
    };
    let fit = in_parentheses(judged.and_then(|j| j.lack_of_fit.as_ref()));
    let rivals: Vec<String> = a
        .explanations
        .iter()
        .filter(|j| j.name != name)
        .map(|j| {
            if j.rejected {
                format!("'{}' rejected by its lack of fit", j.name)
            } else {
                format!("'{}' beaten", j.name)
            }
        })
        .collect();
    let rest = if rivals.is_empty() {
        String::new()
    } else {
        format!("; {}", rivals.join(", "))
    };
    format!("'{name}', decisive: {model} fits the tests within the noise{fit}{rest}")
}

/// The loop's evidence, one fact per line: the screening's verdict as the step before, each open
/// explanation's final model, and the tests between them.
fn after_loop_lines(f: &Facts, a: &AfterLoop) -> Vec<String> {
    let alpha = f.cx.alpha();
    let mut out = vec![match a.favoured.is_empty() {
        true => format!("Before the loop: {}", a.screening_headline),
        false => format!(
            "Before the loop: {} But the solver's runs over the amplitude of {} favoured {} against its absence, so \
             the solver in the loop judged {}.",
            a.screening_headline,
            quoted(&a.favoured),
            if a.favoured.len() == 1 { "it" } else { "each" },
            quoted(&(a.explanations.iter()).map(|j| j.name.clone()).collect::<Vec<_>>())
        ),
    }];
    for j in &a.explanations {
        let what = if j.model == "extended" {
            "calibrated with the solver in the loop"
        } else {
            "fitted with the parameters (not extended by the loop)"
        };
        out.push(match &j.lack_of_fit {
            Some(l) if j.unchecked && !j.rejected => format!(
                "'{}' {what}: {} ({}), but no solver run checked its emulators at its fitted point (the loop \
                 stopped first: its budget ran out, or nothing its further runs could show would change the verdict), \
                 so that may be theirs: it is neither rejected nor decided on.",
                j.name,
                if l.rejects() {
                    "misses the tests"
                } else {
                    "fits within the noise"
                },
                lack_of_fit(l)
            ),
            Some(l) if j.rejected => format!(
                "'{}' {what}: rejected, its model still misses the tests beyond the noise ({}; α = {alpha}).",
                j.name,
                lack_of_fit(l)
            ),
            Some(l) => format!("'{}' {what}: fits within the noise ({}).", j.name, lack_of_fit(l)),
            None => format!("'{}' {what}: no replicates to test its lack of fit.", j.name),
        });
    }
    for p in &a.pairwise {
        out.push(match p.p_value {
            Some(v) if v < p.level => format!(
                "'{}' still counts with '{}' in the model ({}): '{}' does not account for it.",
                p.shape_of,
                p.added_to,
                p_text(v),
                p.added_to
            ),
            Some(v) => format!(
                "'{}' adds nothing significant to '{}' (p = {} ≥ {}).",
                p.shape_of,
                p.added_to,
                num(v),
                level_words(alpha, p.level)
            ),
            None => format!(
                "'{}' could not be tested with '{}' in the model.",
                p.shape_of, p.added_to
            ),
        });
    }
    out
}

/// A lack of fit's figures in parentheses after a space, or nothing without a test.
fn in_parentheses(l: Option<&LackOfFit>) -> String {
    l.map_or(String::new(), |l| format!(" ({})", lack_of_fit(l)))
}

/// Both figures of a lack-of-fit test: `χ² = … on … degrees of freedom, p = …; largest residual
/// z = … at D (Šidák p = … over N)`, each with its reference distribution when the noise is
/// estimated from the replicates (`by F(7, 4)`, `each by t(4)`): a χ² of 91 on 7 degrees of freedom
/// is p = 0.013 only against a noise measured on 4, and the reader must be able to check it.
pub fn lack_of_fit(l: &super::LackOfFit) -> String {
    let (by_f, by_t) = references(l);
    let omnibus = format!(
        "χ² = {} on {} degrees of freedom, {}{by_f}",
        num(l.chi2),
        l.dof,
        p_text(l.p_value)
    );
    match &l.largest {
        Some(r) => format!(
            "{omnibus}; largest residual z = {} at {} (Šidák {} over {}{by_t})",
            num(r.z),
            r.design,
            p_text(r.p_corrected),
            r.residuals
        ),
        None => omnibus,
    }
}

/// ` by F(dof, ν)` and `, each by t(ν)` when the noise is estimated on ν degrees of freedom; nothing
/// when it is known (stated by the study), where the references are χ² and the normal.
pub fn references(l: &super::LackOfFit) -> (String, String) {
    if l.noise_dof >= super::noise::KNOWN_DOF {
        return (String::new(), String::new());
    }
    (
        format!(" by F({}, {})", l.dof, l.noise_dof),
        format!(", each by t({})", l.noise_dof),
    )
}

#[cfg(test)]
mod tests {
    use super::super::LackOfFit;
    use super::super::noise::KNOWN_DOF;
    use super::lack_of_fit;

    /// The figures of a curve family's draw (seed 808,091): χ² = 91 on 7 with a noise measured on 4
    /// is p = 0.013 by F(7, 4) (scipy 1.17.1: `f.sf(13, 7, 4)` = 0.01300); the words name that
    /// reference, so the p can be checked. A noise the study states has none to name.
    #[test]
    fn the_words_name_the_reference_of_an_estimated_noise() {
        let z = [("C6T70".to_string(), -7.653), ("C3T60".to_string(), 0.5)];
        let estimated = lack_of_fit(&LackOfFit::new(91.0, 7, 4, &z, 0.0125));
        assert!(
            estimated.starts_with("χ² = 91 on 7 degrees of freedom, p = 0.013 by F(7, 4); "),
            "{estimated}"
        );
        assert!(estimated.ends_with("over 2, each by t(4))"), "{estimated}");
        let known = lack_of_fit(&LackOfFit::new(91.0, 7, KNOWN_DOF, &z, 0.0125));
        assert!(!known.contains(" by "), "{known}");
        assert!(known.ends_with("over 2)"), "{known}");
    }
}
