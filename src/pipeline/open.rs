//! What "no model error" leaves open, read from the solver: each listed extension the tests do not
//! exclude is run over its amplitude (issue 53 item 4).
//!
//! The screening reads an extension's open range from its probes, linearised about the baseline
//! against the emulators: where these are off, the range is off with them. So a small loop runs the
//! solver at the open range's ends — at the parameters the range puts there, at every tested design
//! and seed, as a confirmation runs — and reads the range again from the profile those runs give
//! ([`crate::diagnose::open::Profile`]); it goes on while an end of the range has no run near it, for
//! [`open::ROUNDS`] rounds at most, and within a sequential study's budget.

use super::confirm::{self, ConfirmRuns, Made, Subject};
use super::diagnosis::Reading;
use super::{Reporter, RunContext};
use crate::diagnose::confirm::{Confirmation, Confirming, UNCORRECTED};
use crate::diagnose::open::{self, NotExcluded, Profile};
use crate::diagnose::verdict::Verdict;
use crate::diagnose::{Diagnosis, Inputs, Levels, NoiseModel};
use crate::error::Error;
use crate::study::Hypothesis;

/// `d` with each open extension's range read from the solver run over its amplitude (where `d`
/// says no model error and the uncorrected simulation's confirmation was judged), and the runs
/// made (`screening`: the inputs the confirmation read, the tests' noise alone).
pub(super) fn over_amplitudes(
    cx: RunContext,
    (rendered, executed, sequence): Made,
    d: Diagnosis,
    (screening, read, noise): (&Inputs, &Reading, &NoiseModel),
    before: Option<&ConfirmRuns>,
    reporter: &mut dyn Reporter,
) -> Result<(Diagnosis, Option<ConfirmRuns>), Error> {
    let anchor = (d.checked.confirmation.iter()).find(|c| c.model == UNCORRECTED && c.lack_of_fit.is_some());
    let (Verdict::NoModelError, Some(anchor)) = (d.finding.verdict, anchor.cloned()) else {
        return Ok((d, None));
    };
    let mut made: Option<ConfirmRuns> = None;
    let mut open = Vec::new();
    for n in &d.checked.not_excluded {
        let Some((k, h)) = over_runs(cx, n) else {
            open.push(n.clone());
            continue;
        };
        let one = Extension {
            h,
            k,
            anchor: &anchor,
            d: &d,
        };
        let (read_again, runs) = one.run(
            cx,
            (rendered, &mut *executed, &mut *sequence),
            (screening, read, noise),
            before,
            reporter,
        )?;
        open.push(read_again.unwrap_or_else(|| n.clone()));
        for r in runs {
            made = Some(match made {
                Some(m) => m.merge(r),
                None => r,
            });
        }
    }
    let designs: Vec<String> = crate::plan::sweep::tested_designs(cx.study)
        .map(|(n, _)| n.clone())
        .collect();
    Ok((d.with_open(open, &designs), made))
}

/// The study's hypothesis of an open range, where the solver can be run over it: an extension
/// with one ranged variable whose lower bound is the baseline (so the uncorrected simulation's
/// runs are the extension's there).
fn over_runs<'s>(cx: RunContext<'s>, n: &NotExcluded) -> Option<(usize, &'s Hypothesis)> {
    let hypotheses = &cx.study.diagnosis.hypotheses;
    let k = hypotheses.iter().position(|h| h.name == n.hypothesis)?;
    let spec = hypotheses[k].extension_spec()?;
    (spec.ranges.len() == 1 && spec.baseline_at_edge).then_some((k, &hypotheses[k]))
}

/// One open extension and what its runs are read against.
struct Extension<'d> {
    h: &'d Hypothesis,
    /// Its index in the study's hypotheses.
    k: usize,
    /// The uncorrected simulation's confirmation: the extension at its baseline value.
    anchor: &'d Confirmation,
    d: &'d Diagnosis,
}

impl Extension<'_> {
    /// The rounds of runs over the amplitude; the range read from them (`None`: no run was made, or
    /// they give no profile) and the runs.
    fn run(
        &self,
        cx: RunContext,
        (rendered, executed, sequence): Made,
        (screening, read, noise): (&Inputs, &Reading, &NoiseModel),
        before: Option<&ConfirmRuns>,
        reporter: &mut dyn Reporter,
    ) -> Result<(Option<NotExcluded>, Vec<ConfirmRuns>), Error> {
        let r = &self.h.ranges()[0];
        let (lo, hi) = (r.min, r.max);
        let mut at: Vec<(f64, Confirmation)> = Vec::new();
        let mut made = Vec::new();
        let mut read_again: Option<NotExcluded> = None;
        let mut next = self.first(screening);
        for _ in 0..open::ROUNDS {
            if next.is_empty() {
                break;
            }
            let subjects: Vec<Subject> = next
                .iter()
                .map(|(v, theta)| self.subject(screening, *v, theta))
                .collect();
            let made_now = (rendered, &mut *executed, &mut *sequence);
            let earlier = confirm::Earlier {
                joint: None,
                confirmed: before,
            };
            let (confirmations, runs) = confirm::run(cx, made_now, &subjects, (read, noise, earlier), reporter)?;
            made.extend(runs);
            if confirmations.is_empty() {
                break; // no room left in the budget
            }
            // A round whose runs all failed adds nothing to read, and would be planned again.
            let failed = (confirmations.iter()).all(|c| c.runs.iter().any(|r| r.solver.is_none()));
            at.extend(next.iter().map(|(v, _)| *v).zip(confirmations));
            let points: Vec<(f64, &Confirmation)> = std::iter::once((lo, self.anchor))
                .chain(at.iter().map(|(v, c)| (*v, c)))
                .collect();
            let Some(profile) = Profile::new(screening, noise, &points) else {
                break;
            };
            read_again = profile.read(&self.h.name, (&r.name, lo, hi), self.levels(screening));
            let Some(open) = &read_again else { break };
            if failed {
                break;
            }
            next = (open::next_amplitudes(open, &profile.fresh(open), (lo, hi)).into_iter())
                .filter_map(|v| Some((v, profile.at(v)?.1)))
                .collect();
        }
        Ok((read_again, made))
    }

    /// The first round: the screening's open range's ends, at the parameters its joint fit puts
    /// there.
    fn first(&self, screening: &Inputs) -> Vec<(f64, Vec<f64>)> {
        let Some(open) = self.d.checked.not_excluded.iter().find(|n| n.hypothesis == self.h.name) else {
            return Vec::new();
        };
        let r = &self.h.ranges()[0];
        let candidate = (self.d.explained.candidates.iter()).find(|c| c.shape.name == self.h.name);
        let names = &screening.space.parameter_names;
        let anchor: Vec<f64> = names
            .iter()
            .map(|n| self.anchor.at.get(n).copied().unwrap_or(f64::NAN))
            .collect();
        (open::next_amplitudes(open, &[(r.min, true)], (r.min, r.max)).into_iter())
            .map(|v| {
                let theta = candidate.map_or_else(
                    || anchor.clone(),
                    |c| {
                        let at = open::linearised_at(c, v);
                        names
                            .iter()
                            .zip(&anchor)
                            .map(|(n, a)| at.get(n).copied().unwrap_or(*a))
                            .collect()
                    },
                );
                (v, theta)
            })
            .collect()
    }

    /// The extension run at value `v` of its variable and parameters `theta`, judged as the
    /// uncorrected simulation's confirmation is (its bridge over the same inputs).
    fn subject<'a>(&self, screening: &'a Inputs<'a>, v: f64, theta: &[f64]) -> Subject<'a> {
        let spec = self.h.extension_spec().expect("an extension (over_runs)");
        Subject {
            confirming: Confirming {
                name: self.h.name.clone(),
                inputs: screening,
                point: theta.to_vec(),
                correction: vec![0.0; screening.observations.len()],
                rivals: Vec::new(),
            },
            theta: theta.to_vec(),
            extension: spec.at(&[v]),
            level: self.d.record.levels.uncorrected_fit,
            ran: None,
            role: crate::plan::RunRole::NotExcluded(self.k),
            noise_held: false,
        }
    }

    /// The levels the range and the detectable effect are read at: α, one of the candidates'
    /// amplitude tests, and the power.
    fn levels(&self, screening: &Inputs) -> (f64, f64) {
        let levels = Levels::new(self.d.record.levels.alpha, true);
        let k = self.d.explained.candidates.len();
        (levels.amplitude(k), screening.settings.power)
    }
}
