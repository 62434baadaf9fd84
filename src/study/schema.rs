//! The study file's YAML schema (serde), before validation.
//!
//! Every struct denies unknown keys. Values a later semantic check must point at are [`Spanned`].
//! No `flatten` and no untagged enums: serde buffers those and the locations would be lost.

use indexmap::IndexMap;
use serde::Deserialize;

use super::yaml::Spanned;

/// A name (map key or list item) with its location.
pub type Name = Spanned<String>;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudyFile {
    pub name: Name,
    #[serde(default)]
    pub constants: IndexMap<Name, Spanned<f64>>,
    pub design: Spanned<IndexMap<Name, Option<DesignFile>>>,
    pub parameters: Spanned<IndexMap<Name, ParameterFile>>,
    pub simulation: Spanned<SimulationFile>,
    pub experiments: ExperimentsFile,
    pub training: Spanned<Vec<Name>>,
    #[serde(default)]
    pub validation: Vec<Name>,
    pub calibration: Option<CalibrationFile>,
    pub diagnosis: Option<DiagnosisFile>,
    /// Extra train/validate splits calibrated from the same runs (reported under `splits`).
    pub splits: Option<Spanned<Vec<SplitFile>>>,
    /// Known parameter values (synthetic tests): each method's error against them is reported.
    #[serde(default)]
    pub truth: IndexMap<Name, Spanned<f64>>,
}

/// One entry of `splits`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SplitFile {
    pub training: Spanned<Vec<Name>>,
    #[serde(default)]
    pub validation: Vec<Name>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignFile {
    pub unit: Option<String>,
    pub min: Option<Spanned<f64>>,
    pub max: Option<Spanned<f64>>,
    /// A length (in the variable's unit) that makes it dimensionless: the L of `exp(-x/L)` and
    /// `ln(x/L)` in the discovery library.
    pub scale: Option<Spanned<f64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParameterFile {
    pub min: Spanned<f64>,
    pub max: Spanned<f64>,
    pub unit: Option<String>,
}

/// `simulation:`: exactly one of `expression` and `solver`; `response`, `sampling` and `surrogate`
/// go with `solver`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimulationFile {
    pub expression: Option<Spanned<String>>,
    pub solver: Option<Spanned<SolverFile>>,
    pub response: Option<Spanned<ResponseFile>>,
    pub sampling: Option<Spanned<SamplingFile>>,
    pub surrogate: Option<Spanned<String>>,
    /// A generated mesh, once per design (`{kind: honeycomb_tube, element_size: 2.0}`).
    pub mesh: Option<Spanned<MeshFile>>,
    /// Default replay directory (relative to the study file), used when the solver is not on PATH.
    pub replay: Option<Spanned<String>>,
    /// The gates a run's glstat energies must keep, and what becomes of runs that break them.
    pub quality: Option<Spanned<QualityFile>>,
    /// The solver's own scatter: the confirmation runs made at several seeds of a random
    /// imperfection, a template variable (`{count: 3, variable: seed}`) or OpenRadioss's nodal
    /// noise (`{count: 3}`).
    pub seeds: Option<Spanned<SeedsFile>>,
}

/// `simulation.seeds`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SeedsFile {
    pub count: Spanned<usize>,
    /// Absent for an `openradioss` solver with nodal noise: its starter's `-rseed`.
    pub variable: Option<Spanned<String>>,
}

/// `simulation.quality`: limits as fractions, and `suspect: exclude | use`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QualityFile {
    pub hourglass: Option<Spanned<f64>>,
    pub energy: Option<Spanned<f64>>,
    pub added_mass: Option<Spanned<f64>>,
    /// Kinetic / internal energy (a quasi-static crush; reported by `openradioss` runs).
    pub kinetic: Option<Spanned<f64>>,
    pub suspect: Option<Spanned<String>>,
}

/// `simulation.mesh`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshFile {
    pub kind: Spanned<String>,
    pub element_size: Spanned<f64>,
    /// The design variable holding the cell size across flats (default `c`).
    pub cell: Option<Spanned<String>>,
    pub diameter: Option<Spanned<f64>>,
    pub length: Option<Spanned<f64>>,
    /// The id of a `*SET_NODE_LIST` of the nodes where the cylinder cut the walls, appended to the
    /// mesh include (default: none).
    pub edge_set: Option<Spanned<u32>>,
}

/// `simulation.solver`: how one run is made.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolverFile {
    pub adapter: Spanned<String>,
    #[serde(default)]
    pub templates: Vec<Spanned<String>>,
    /// A keyword deck used as it is, in place of `templates`: its `*PARAMETER` values set by name.
    pub deck: Option<Spanned<DeckSpecFile>>,
    /// Files copied verbatim into every run directory (part of the run key).
    #[serde(default)]
    pub files: Vec<Spanned<String>>,
    /// Required for `command`; `lsdyna` defaults to `[ls-dyna, i=<first template>, ncpu=1]`,
    /// `calculix` to `[ccx, -i, JOB]`.
    pub command: Option<Spanned<Vec<Spanned<String>>>>,
    pub timeout: Option<Spanned<f64>>,
    pub retries: Option<Spanned<RetriesFile>>,
    /// `adapter: calculix`: the job name (`JOB.inp` in the run directory).
    pub job: Option<Spanned<String>>,
    /// Settings of `--executor slurm`.
    pub slurm: Option<Spanned<SlurmFile>>,
    /// `adapter: openradioss`: its programs, threads, nodal noise and environment.
    pub openradioss: Option<Spanned<OpenRadiossFile>>,
}

/// `simulation.solver.deck`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeckSpecFile {
    /// The main deck, relative to the study file; its includes are found relative to it.
    pub file: Spanned<String>,
    /// Study variable → the deck's `*PARAMETER` name (default: the variable's name in upper case).
    #[serde(default)]
    pub names: IndexMap<Name, Spanned<String>>,
    /// An include of the deck (its name as the deck writes it) → each tested design's own file, a
    /// path relative to the study file with `{design}` in it (`meshes/{design}.k`).
    #[serde(default)]
    pub per_design: IndexMap<Name, Spanned<String>>,
}

/// `simulation.solver.openradioss` (all optional).
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OpenRadiossFile {
    /// The starter program (default `starter_linux64_gf`).
    pub starter: Option<Spanned<String>>,
    /// The engine program (default `engine_linux64_gf`).
    pub engine: Option<Spanned<String>>,
    /// Threads per program (default 1: one thread repeats bit for bit).
    pub threads: Option<Spanned<u32>>,
    /// The starter's random nodal noise (`-rxalea`, `-rseed`): a geometric imperfection.
    pub noise: Option<Spanned<NoiseFile>>,
    /// Environment variables for both programs (RAD_CFG_PATH, LD_LIBRARY_PATH, OMP_STACKSIZE, ...).
    #[serde(default)]
    pub environment: IndexMap<Name, Spanned<String>>,
    /// The stand-in's recordings of the same decks (relative to the study file), for the
    /// report's comparison of the two solvers' curves.
    pub standin: Option<Spanned<String>>,
}

/// `openradioss.noise`: the largest random displacement of each node (mm) and the seed.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseFile {
    pub amplitude: Spanned<f64>,
    pub seed: Spanned<f64>,
}

/// `simulation.solver.retries`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RetriesFile {
    pub max_attempts: Spanned<u32>,
    /// Seconds before the first retry; doubled for each further retry.
    pub backoff: Option<Spanned<f64>>,
    /// Longest delay between attempts, seconds.
    pub max_backoff: Option<Spanned<f64>>,
    /// Outcome classes retried.
    pub on: Option<Vec<Spanned<String>>>,
}

/// `simulation.response`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResponseFile {
    /// `command` adapter: the file and the regex whose first group is the response.
    pub file: Option<Spanned<String>>,
    pub regex: Option<Spanned<String>>,
    /// `lsdyna` adapter: `crush_force` (the only kind so far).
    pub kind: Option<Spanned<String>>,
    /// Stroke window `[s0, s1]`, mm.
    pub window: Option<Spanned<Vec<Spanned<f64>>>>,
    /// rcforc interface id (default 1).
    pub interface: Option<Spanned<u64>>,
    /// A rigid wall's id: its normal force from rwforc (binout) is the force instead of rcforc's.
    pub rigid_wall: Option<Spanned<u64>>,
    /// `master` / `surfb` (default) or `slave` / `surfa`.
    pub side: Option<Spanned<String>>,
    /// Force component: x, y or z (default z).
    pub axis: Option<Spanned<String>>,
    /// nodout node whose displacement is the stroke (the striker).
    pub node: Option<Spanned<u64>>,
    /// Displacement component (default: `axis`).
    pub node_axis: Option<Spanned<String>>,
    /// Multiplies the solver's force into kN (default 1; 0.001 for N).
    pub force_to_kn: Option<Spanned<f64>>,
    /// Multiplies the solver's length into mm (default 1).
    pub disp_to_mm: Option<Spanned<f64>>,
    /// `adapter: calculix`: a block of `JOB.dat`.
    pub dat: Option<Spanned<DatFile>>,
}

/// `simulation.sampling`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SamplingFile {
    pub method: Spanned<String>,
    /// Samples per design (`lhs`, `grid`); not for `sequential`, which takes `initial`.
    pub count: Option<Spanned<usize>>,
    /// `sequential`: the initial space-filling samples per design.
    pub initial: Option<Spanned<usize>>,
    /// `sequential`: runs per batch (default: `--jobs`).
    pub batch: Option<Spanned<usize>>,
    /// `sequential`: the most solver runs in all.
    pub budget: Option<Spanned<usize>>,
    /// `sequential`: the emulator's error at the posterior allowed, as a fraction of the tests' noise.
    pub tolerance: Option<Spanned<f64>>,
    /// `sequential`: one emulator across the tested designs (their values and the parameters), not
    /// one per design.
    pub across_designs: Option<Spanned<bool>>,
    #[serde(default)]
    pub seed: u64,
    /// Extra Latin-hypercube runs per design that measure the surrogate's error (paper: 5).
    pub check_runs: Option<Spanned<usize>>,
    /// `sequential`: the fixed design (`lhs` or `grid`) it replaces, counted (never run) for the
    /// terminal's `246 → 45 solver runs` and `results.json` `sampling.replaces`.
    pub replaces: Option<Spanned<Box<SamplingFile>>>,
    /// In `replaces` only: the surrogate the fixed design was fitted with, when not the study's.
    pub surrogate: Option<Spanned<String>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentsFile {
    pub file: Spanned<String>,
    pub response: Spanned<String>,
    /// The response's unit (axis labels, tables).
    pub unit: Option<Spanned<String>>,
    /// Test-machine force–displacement CSVs per design: a path pattern relative to the study file,
    /// `{design}` for the design name and `*` in the file name (`tests/{design}-*.csv`).
    pub curves: Option<Spanned<String>>,
    /// The measurement's uncertainty of one test (`{absolute: a, relative: b}`, σ² = a² + (b·y)²):
    /// the noise where the tests have no replicates.
    pub uncertainty: Option<Spanned<UncertaintyFile>>,
}

/// `experiments.uncertainty`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UncertaintyFile {
    /// σ's absolute part, in the response's unit.
    pub absolute: Option<Spanned<f64>>,
    /// σ's part proportional to the level (a fraction: 0.01 is 1 %).
    pub relative: Option<Spanned<f64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationFile {
    pub methods: Option<Spanned<Vec<Name>>>,
    #[serde(default)]
    pub bayesian: BayesianFile,
    /// What the parameters are calibrated against: `response` (the default) and/or `curves`.
    pub against: Option<Spanned<Vec<Name>>>,
    /// How curves are compared (`against: [.., curves]`).
    pub curve: Option<Spanned<CurveFile>>,
}

/// `calibration.curve`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CurveFile {
    /// mse (default) | pcm | frechet | dtw | area.
    pub metric: Option<Spanned<String>>,
    /// Points of the common stroke grid (default 200).
    pub points: Option<Spanned<usize>>,
    /// SAE J211 CFC low-pass filter before resampling.
    pub filter: Option<Spanned<FilterFile>>,
    /// Stroke window of the grid, mm (default: the response's window).
    pub window: Option<Spanned<Vec<Spanned<f64>>>>,
    /// Surrogate of each curve component (default: the study's `surrogate`).
    pub surrogate: Option<Spanned<String>>,
}

/// `calibration.curve.filter`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilterFile {
    /// Channel frequency class, Hz (e.g. 60, 180, 600).
    pub cfc: Spanned<f64>,
    /// The crush speed, m/s: the time base of a curve sampled in stroke.
    pub speed: Spanned<f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BayesianFile {
    pub emulator_samples: Option<Spanned<usize>>,
    pub seed: Option<u64>,
    pub mcmc_walkers: Option<Spanned<usize>>,
    pub mcmc_steps: Option<Spanned<usize>>,
    pub mcmc_burn_in: Option<Spanned<usize>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiagnosisFile {
    #[serde(default)]
    pub hypotheses: Vec<HypothesisFile>,
    /// Search a library of shapes when no listed hypothesis explains the misfit (default: true
    /// when `hypotheses` is empty).
    pub discover: Option<bool>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HypothesisFile {
    pub name: Name,
    /// An additive discrepancy shape; exactly one of `term` and `extension`.
    pub term: Option<Spanned<String>>,
    /// A model extension (solver studies): template variables set for extra runs, each a value
    /// or a range.
    pub extension: Option<Spanned<IndexMap<Name, Spanned<ExtensionValueFile>>>>,
}

/// One variable of `extension:`: a value (`etan: 200`), or a range calibrated with the solver in
/// the loop (`etan: {min: 0, max: 600, unit: MPa}`, screened at `probe`, by default the middle).
/// A number or a mapping, told apart by the node's kind (a visitor, since untagged enums lose the
/// locations).
#[derive(Debug)]
pub enum ExtensionValueFile {
    Value(f64),
    Range(ExtensionRangeFile),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExtensionRangeFile {
    pub min: Spanned<f64>,
    pub max: Spanned<f64>,
    pub unit: Option<String>,
    pub probe: Option<Spanned<f64>>,
}

impl<'de> Deserialize<'de> for ExtensionValueFile {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Visit;
        impl<'de> serde::de::Visitor<'de> for Visit {
            type Value = ExtensionValueFile;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number, or a range {min, max, unit}")
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Self::Value, E> {
                Ok(ExtensionValueFile::Value(v))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Self::Value, E> {
                Ok(ExtensionValueFile::Value(v as f64))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Self::Value, E> {
                Ok(ExtensionValueFile::Value(v as f64))
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<Self::Value, A::Error> {
                ExtensionRangeFile::deserialize(serde::de::value::MapAccessDeserializer::new(map))
                    .map(ExtensionValueFile::Range)
            }
        }
        deserializer.deserialize_any(Visit)
    }
}

// ---- Cluster and CalculiX keys (issue 6): `solver.job`, `solver.slurm`, `response.dat` ----

/// `simulation.response.dat`: `{block: displacements, set: NTIP, component: vy, reduce: mean}`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DatFile {
    pub block: Spanned<String>,
    pub set: Spanned<String>,
    pub component: Spanned<String>,
    pub reduce: Option<Spanned<String>>,
    /// Step-time window `[t0, t1]`: the response is the mean of the block's history over it.
    pub window: Option<Spanned<Vec<Spanned<f64>>>>,
}

/// `simulation.solver.slurm`: how runs are submitted by `--executor slurm`.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SlurmFile {
    pub partition: Option<Spanned<String>>,
    /// Per job, in minutes.
    pub time_limit: Option<Spanned<u32>>,
    /// CPUs per job; runs of one job run this many at once.
    pub cpus: Option<Spanned<u32>>,
    /// Memory per job in MB.
    pub memory: Option<Spanned<u32>>,
    /// Runs packed into one job.
    pub runs_per_job: Option<Spanned<usize>>,
    /// More sbatch options, each one argv element (`--account=x`).
    #[serde(default)]
    pub options: Vec<Spanned<String>>,
    /// Seconds a job may be unknown to squeue, scontrol and jobcomp before its runs are `lost`.
    pub lost_after: Option<Spanned<u32>>,
}
