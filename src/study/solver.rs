//! A simulation run by a program (`simulation.solver`, `response`, `sampling`, `surrogate`), as
//! validated by [`super::load`]: templates read and parsed, regex compiled, counts checked.

use std::path::PathBuf;

pub use crate::base::template::Template;
use std::time::Duration;

use crate::study::settings::RetryPolicy;

/// The default `tolerance`: the emulator's error at the posterior may be half the tests' noise of the
/// mean. Counted as noise, it then widens the intervals by at most √(1 + 0.5²) − 1 ≈ 12 %.
pub const DEFAULT_TOLERANCE: f64 = 0.5;

/// The default budget: this many solver runs per tested design, in all.
pub const DEFAULT_BUDGET_PER_DESIGN: usize = 30;

/// `simulation.solver` plus the keys that go with it.
#[derive(Debug, Clone)]
pub struct SolverSimulation {
    /// `command`, `lsdyna`, `calculix` or `openradioss`.
    pub adapter: String,
    /// What each run directory gets.
    pub inputs: RunInputs,
    /// How the solver process is run.
    pub execution: Execution,
    /// How the response is read from a finished run.
    pub response: Response,
    pub sampling: Sampling,
    pub surrogate: SurrogateKind,
    /// Default replay directory (absolute or relative to the current directory), used when the
    /// solver program is not on PATH and no `--replay` is given.
    pub replay: Option<PathBuf>,
    /// `simulation.quality`: the gates on each run's sanity figures (defaults when absent).
    pub quality: QualitySettings,
    /// `adapter: openradioss`: `solver.openradioss` (defaults when absent); `None` for the others.
    pub openradioss: Option<OpenRadiossSettings>,
}

/// What each run directory of a solver study gets: its rendered templates, its copied files, the
/// design's mesh, and the width the values are written in.
#[derive(Debug, Clone)]
pub struct RunInputs {
    pub templates: Vec<Template>,
    /// A deck used as it is (`simulation.solver.deck`), in place of templates.
    pub deck: Option<crate::base::deck::Deck>,
    /// Files copied verbatim into every run directory.
    pub files: Vec<CopiedFile>,
    /// A mesh generated once per design and included by the deck (`mesh_file` in the context).
    pub mesh: Option<MeshSpec>,
    /// `simulation.seeds`: the template variable a run's seed of its random imperfection sets.
    pub seeds: Option<Seeds>,
    /// Width of the solver's fixed number fields: sampled parameters are rounded to fit them
    /// (10 for `lsdyna`), so the surrogates see exactly the values the solver read.
    pub parameter_width: Option<usize>,
}

impl RunInputs {
    /// The deck the solver reads: the deck used as it is, or the first template's rendered name
    /// (empty without either).
    pub fn deck(&self) -> PathBuf {
        match &self.deck {
            Some(d) => d.files[0].output.clone(),
            None => self.templates.first().map(|t| t.output.clone()).unwrap_or_default(),
        }
    }

    /// What renders a run's inputs: the templates and the deck used as it is.
    pub fn renderer(&self) -> Result<crate::base::template::Renderer, crate::error::InputError> {
        Ok(crate::base::template::Renderer::new(&self.templates)?.with_deck(self.deck.as_ref()))
    }
}

/// How the solver process is run: its argv (never through a shell), its time limit, its retries,
/// and the settings of `--executor slurm`.
#[derive(Debug, Clone)]
pub struct Execution {
    /// argv, run in the run directory. Not empty.
    pub command: Vec<String>,
    pub timeout: Option<Duration>,
    pub retry: RetryPolicy,
    /// `solver.slurm`: settings of `--executor slurm` (defaults when absent).
    pub slurm: Option<crate::study::settings::SlurmSettings>,
}

impl SolverSimulation {
    /// Whether one emulator spans the tested designs (`sampling.across_designs`).
    pub fn across_designs(&self) -> bool {
        self.sampling.sequential.as_ref().is_some_and(|q| q.across_designs)
    }
}

/// `solver.openradioss`: how OpenRadioss is run. `command` is the starter's argv built from these.
#[derive(Debug, Clone, PartialEq)]
pub struct OpenRadiossSettings {
    pub starter: String,
    pub engine: String,
    pub threads: u32,
    /// The starter's nodal noise: amplitude (mm) and seed.
    pub noise: Option<(f64, f64)>,
    /// Set for both programs, on top of lab's own environment.
    pub environment: Vec<(String, String)>,
    /// `openradioss.standin`: crushsim's recordings of the same decks, `<dir>/<run key>/`
    /// (resolved against the study file); the report compares the two solvers' curves.
    pub standin: Option<std::path::PathBuf>,
}

impl OpenRadiossSettings {
    /// The nodal noise's seed of a run at seed `k` (`simulation.seeds`): the study's own for k = 0,
    /// then stepped by the golden ratio's conjugate modulo 1 (0.618…: seeds spread over (0, 1], no
    /// two alike), as the starter accepts them.
    pub fn seed(&self, k: usize) -> Option<f64> {
        let (_, nominal) = self.noise?;
        let s = (nominal + k as f64 * 0.618_033_988_749_894_8).fract();
        Some(if s <= 0.0 { 1.0 } else { s })
    }

    /// The starter's argv on `deck`.
    pub fn starter_argv(&self, deck: &std::path::Path) -> Vec<String> {
        let mut argv = vec![
            self.starter.clone(),
            "-i".into(),
            deck.display().to_string(),
            "-np".into(),
            "1".into(),
            "-nt".into(),
            self.threads.to_string(),
        ];
        if let Some((amplitude, seed)) = self.noise {
            argv.extend([
                "-rxalea".into(),
                amplitude.to_string(),
                "-rseed".into(),
                seed.to_string(),
            ]);
        }
        argv
    }
}

/// `simulation.quality`: a run that breaks a gate is `suspect`; suspect runs feed the surrogates
/// only with `suspect: use`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct QualitySettings {
    pub gates: crate::study::settings::Gates,
    pub use_suspect: bool,
}

/// `simulation.response`.
#[derive(Debug, Clone)]
pub enum Response {
    /// `command`: the first capture group of `regex` in `file` (relative to the run directory).
    Regex { file: PathBuf, regex: String },
    /// `lsdyna`: mean crush force (kN) over a stroke window, from rcforc and nodout.
    CrushForce {
        window: crate::study::settings::Window,
        source: crate::study::settings::SimSource,
    },
    /// `calculix`: a value from a block of `JOB.dat` (`response.dat`), judged by the ccx adapter.
    Dat(crate::study::settings::CalculixAdapter),
}

/// `simulation.seeds`: a run's seed of its random imperfection (every run at the first seed but
/// the confirmation's, which run at each of `count`).
#[derive(Debug, Clone, PartialEq)]
pub struct Seeds {
    pub count: usize,
    /// The template variable that sets it, to 1 … `count`; `None`: OpenRadioss's nodal noise, its
    /// starter's `-rseed` ([`OpenRadiossSettings::seed`]).
    pub variable: Option<String>,
}

/// `simulation.mesh: {kind: honeycomb_tube, ...}`.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshSpec {
    /// Index of the design variable holding the cell size.
    pub cell_variable: usize,
    pub element_size: f64,
    pub diameter: f64,
    pub length: f64,
    /// `mesh.edge_set`: a node set of the cut edges appended to the include, with this id.
    pub edge_set: Option<u32>,
}

/// A file copied into every run directory unchanged.
#[derive(Debug, Clone)]
pub struct CopiedFile {
    pub file: PathBuf,
    pub output: PathBuf,
    pub bytes: Vec<u8>,
}

/// `simulation.sampling`: parameter samples per design.
#[derive(Debug, Clone, PartialEq)]
pub struct Sampling {
    pub method: SamplingMethod,
    /// Samples per design (for `grid`, a perfect power: points per axis ^ parameters).
    pub count: usize,
    pub seed: u64,
    /// Extra Latin-hypercube runs per design, from a different seed stream, to check the surrogate.
    pub check_runs: usize,
    /// `method: sequential`: batches chosen by the runs so far (`count` is then the initial design).
    pub sequential: Option<Sequential>,
    /// A fixed design named in `sampling.replaces` with its own surrogate (`None`: the study's).
    pub surrogate: Option<SurrogateKind>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SamplingMethod {
    Lhs,
    Grid,
    /// Batch after batch, where the runs most reduce what the answer depends on
    /// ([`crate::emulate::sequential`]).
    Sequential,
}

impl SamplingMethod {
    /// The study's words for them (`sampling.method`), in the order of the variants.
    pub const KEYS: [&'static str; 3] = ["lhs", "grid", "sequential"];

    pub fn key(self) -> &'static str {
        Self::KEYS[self as usize]
    }
}

/// The settings of sequential sampling (`simulation.sampling` with `method: sequential`).
#[derive(Debug, Clone, PartialEq)]
pub struct Sequential {
    /// Runs per batch (`None`: as many as can be in flight, `--jobs`).
    pub batch: Option<usize>,
    /// The most solver runs the study may make in all (screening, probes and the loop); 0: the
    /// default, [`crate::emulate::sequential::DEFAULT_BUDGET_PER_DESIGN`] per tested design.
    pub budget: usize,
    /// Enough: the emulator's error at the posterior, in units of the tests' noise of the mean,
    /// at or below this at every tested design.
    pub tolerance: f64,
    /// The fixed design this sequence replaces (`sampling.replaces`): its runs are counted, never
    /// made, so that the terminal and `results.json` say what the sequence saved.
    pub replaces: Option<Box<Sampling>>,
    /// One Gaussian process across the tested designs, over their values and the parameters
    /// (`sampling.across_designs`), for the planner and for the surrogates after it.
    pub across_designs: bool,
}

/// The per-design surrogate over the parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SurrogateKind {
    Linear,
    Quadratic,
    Gp,
}

impl SurrogateKind {
    pub const KEYS: [&'static str; 3] = ["linear", "quadratic", "gp"];

    pub fn key(self) -> &'static str {
        Self::KEYS[self as usize]
    }

    pub fn from_key(key: &str) -> Option<Self> {
        [SurrogateKind::Linear, SurrogateKind::Quadratic, SurrogateKind::Gp]
            .into_iter()
            .find(|k| k.key() == key)
    }

    /// Fewest samples per design that determine the surrogate over `p` parameters.
    pub fn min_samples(self, p: usize) -> usize {
        match self {
            SurrogateKind::Linear => p + 1,
            SurrogateKind::Quadratic => (p + 1) * (p + 2) / 2,
            // The GP's linear trend takes p + 1; one more leaves something for the kernel.
            SurrogateKind::Gp => p + 2,
        }
    }
}

impl Sampling {
    /// Points per axis of a grid of `count` points over `p` parameters, when `count` is a perfect power.
    pub fn grid_side(count: usize, p: usize) -> Option<usize> {
        let guess = (count as f64).powf(1.0 / p.max(1) as f64).round() as usize;
        (guess.saturating_sub(1)..=guess + 1).find(|&n| n.checked_pow(p as u32) == Some(count))
    }
}
