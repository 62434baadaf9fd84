//! How many solver runs a sequential study makes at least, and the rules that count them: owned by
//! the study, whose settings they read, so that the budget is checked when the study is loaded.

use super::{SolverSimulation, Study};

/// A sequential study's initial samples per design over `d` variables: `sampling.initial`, else
/// just enough for every surrogate the study fits (its response's, its curve components') plus one.
pub fn initial_samples(study: &Study, sim: &SolverSimulation, d: usize) -> usize {
    if sim.sampling.count > 0 {
        return sim.sampling.count;
    }
    let curves = if study.calibration.against.curves {
        study
            .calibration
            .curve
            .surrogate
            .unwrap_or(sim.surrogate)
            .min_samples(d)
    } else {
        0
    };
    sim.surrogate.min_samples(d).max(curves) + 1
}

/// With sequential sampling, the most solver runs the study may make: its `budget`, or
/// [`crate::study::solver::DEFAULT_BUDGET_PER_DESIGN`] per tested design (and never less than
/// the sequence makes whatever its runs show, [`SequenceFloor`]).
pub fn sequential_budget(study: &Study, sim: &SolverSimulation) -> Option<usize> {
    let q = sim.sampling.sequential.as_ref()?;
    let designs = tested_designs(study).count();
    Some(if q.budget > 0 {
        q.budget
    } else {
        let floor = SequenceFloor::of(study, sim).map_or(0, |f| f.runs());
        (crate::study::solver::DEFAULT_BUDGET_PER_DESIGN * designs).max(floor)
    })
}

/// The solver runs a sequence makes whatever its runs show, stage by stage: what a budget must at
/// least pay for, and what the screening leaves for the stages after it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SequenceFloor {
    /// Tested designs.
    pub designs: usize,
    /// The screening's first batch (its space-filling start at every design).
    pub initial: usize,
    /// The extension hypotheses' probes: p + 1 per design and hypothesis, at the screening's
    /// posterior.
    pub probes: usize,
    /// The solver in the loop's first batches, were every ranged extension looped: per design, the
    /// start its joint space needs beyond the runs it already has there (the probes, and the
    /// screening's first batch where the baseline is the space's edge), and one held-out run.
    pub looped: usize,
    /// The confirmation runs: the solver at the fitted parameters of the uncorrected simulation and
    /// of a named cause, one run per design each ([`CONFIRMED_MODELS`]) at each seed
    /// (`simulation.seeds`).
    pub confirmation: usize,
}

/// The models a verdict's confirmation runs the solver for within a budget: the uncorrected
/// simulation and the cause a decision names. (Where the two decisions name different causes a
/// third is run if the budget has room, else that decision stays unconfirmed.)
pub const CONFIRMED_MODELS: usize = 2;

/// Whether the extension hypotheses' probes are one per design, the designs taking the probe points
/// in turn for one emulator across the designs, rather than p + 1 at every design. Across the
/// designs for the response alone; per design when the calibration reads the curves, whose
/// extension shapes the diagnosis compares at a few tenths of a percent of the plateau: from one
/// probe per design the emulator interpolates each shape across the designs, and on the honeycomb
/// diagnosis that left 'scale error' explaining part of what 'strain hardening' did not
/// (encompassing test p < 1e-6), where p + 1 probes per design named hardening before the loop.
pub fn probes_across(study: &Study, sim: &SolverSimulation) -> bool {
    sim.across_designs() && !study.calibration.against.curves
}

impl SequenceFloor {
    /// `None` for a fixed design.
    pub fn of(study: &Study, sim: &SolverSimulation) -> Option<SequenceFloor> {
        sim.sampling.sequential.as_ref()?;
        let designs = tested_designs(study).count();
        let p = study.parameters.len();
        let extensions = study.extension_hypotheses().count();
        let screened = initial_samples(study, sim, p);
        let looped = study
            .extension_hypotheses()
            .filter_map(|(_, h)| h.extension_spec().filter(|e| !e.ranges.is_empty()))
            .map(|e| {
                let have = p + 1 + if e.baseline_at_edge { screened } else { 0 };
                designs * (initial_samples(study, sim, p + e.ranges.len()).saturating_sub(have) + 1)
            })
            .sum();
        Some(SequenceFloor {
            designs,
            initial: initial_runs(study, sim),
            probes: designs * (if probes_across(study, sim) { 1 } else { p + 1 }) * extensions,
            looped,
            confirmation: designs * CONFIRMED_MODELS * sim.inputs.seeds.as_ref().map_or(1, |s| s.count),
        })
    }

    /// The least a budget must allow: the screening's first batch, one held-out run per design to
    /// check its emulators, and what the screening leaves for later stages.
    pub fn runs(&self) -> usize {
        self.initial + self.designs + self.reserve()
    }

    /// What the screening may not spend: the probes, the loop's first batches and the
    /// confirmation runs.
    pub fn reserve(&self) -> usize {
        self.probes + self.looped + self.confirmation
    }
}

/// Every tested design (training, then validation) with its values.
pub fn tested_designs(study: &Study) -> impl Iterator<Item = (&String, &Vec<f64>)> {
    study
        .split
        .training
        .iter()
        .chain(&study.split.validation)
        .filter_map(|name| study.experiments.get(name).map(|t| (name, &t.values))) // validated: always there
}

/// The runs of a sequential study's first batch: [`initial_samples`] at every tested design, or
/// with one emulator across the designs [`initial_across`] in all.
pub fn initial_runs(study: &Study, sim: &SolverSimulation) -> usize {
    if sim.across_designs() {
        initial_across(study, sim)
    } else {
        initial_samples(study, sim, study.parameters.len()) * tested_designs(study).count()
    }
}

/// The first batch with one emulator across the designs: `sampling.count` runs, or as many as its
/// linear trend over the designs' values and θ needs with a run to spare, at least one a design.
pub fn initial_across(study: &Study, sim: &SolverSimulation) -> usize {
    let designs = tested_designs(study).count();
    let d = study.design.len();
    match sim.sampling.count {
        0 => designs.max(d + study.parameters.len() + 2),
        n => n,
    }
}
