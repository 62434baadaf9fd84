//! The settings a study names for its solver's runs and outputs, owned here so that every later
//! stage reads them from the study: which histories make a crush curve and over which stroke
//! window, which `.dat` block is a CalculiX response, the quality gates, the retry policy, the
//! Slurm options. The stages that act on them add their behaviour (`impl` blocks) where they act.

use std::path::PathBuf;
use std::time::Duration;

use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sign {
    Plus,
    Minus,
    Auto,
}

/// The stroke window `[s0, s1]` in mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Window {
    pub s0: f64,
    pub s1: f64,
}

/// Which simulation histories make the curve, and their units.
#[derive(Debug, Clone, PartialEq)]
pub struct SimSource {
    pub interface: u64,
    pub side: Side,
    /// 0 = x, 1 = y, 2 = z.
    pub force_axis: usize,
    pub force_sign: Sign,
    /// Multiplies the solver's force unit into kN (1 for the mm–ms–kg–kN system, 1e-3 for mm–s–t–N).
    pub force_to_kn: f64,
    pub node: u64,
    pub disp_axis: usize,
    pub disp_sign: Sign,
    /// Multiplies the solver's length unit into mm.
    pub disp_to_mm: f64,
    /// `Some(id)`: the force is rigid wall `id`'s normal force from rwforc (binout), not rcforc's.
    pub rigid_wall: Option<u64>,
}

impl SimSource {
    /// The honeycomb deck's striker as `studies/honeycomb.yaml` reads it: rcforc interface 1, its
    /// SURFB side, force along z in N (to kN), displacement of node 9000005 along z in mm. Shared by
    /// the tests and the fixture generator that run that deck.
    pub fn honeycomb_striker() -> Self {
        SimSource {
            interface: 1,
            side: Side::SurfB,
            force_axis: 2,
            force_sign: Sign::Auto,
            force_to_kn: 1e-3,
            node: 9_000_005,
            disp_axis: 2,
            disp_sign: Sign::Auto,
            disp_to_mm: 1.0,
            rigid_wall: None,
        }
    }
}

/// Which side of a contact interface a resultant belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Side {
    /// `slave` in older output, `SURFA` in newer.
    SurfA,
    /// `master` in older output, `SURFB` in newer.
    SurfB,
}

/// How a column of a block becomes one number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reduce {
    Mean,
    MaxAbs,
    Sum,
    /// The column of a single-row block (`total force`): an error if there are more rows.
    Value,
}

impl Reduce {
    pub const KEYS: [&'static str; 4] = ["mean", "max_abs", "sum", "value"];

    pub fn from_key(key: &str) -> Option<Reduce> {
        [Reduce::Mean, Reduce::MaxAbs, Reduce::Sum, Reduce::Value]
            .into_iter()
            .find(|r| r.key() == key)
    }

    pub fn key(self) -> &'static str {
        Self::KEYS[self as usize]
    }
}

/// The text CalculiX starts its error messages with.
pub const ERROR_TEXT: &str = "*ERROR";

/// Which `.dat` block, set and component the response is, and how the column is reduced.
#[derive(Debug, Clone, PartialEq)]
pub struct DatResponse {
    /// Block kind as in the header, lowercase: `displacements`, `forces`, `total force`, `stresses`.
    pub block: String,
    pub set: String,
    /// Component name as in the header, lowercase: `vx`, `vy`, `fz`, `sxx`, ...
    pub component: String,
    pub reduce: Reduce,
    /// Step-time window `[t0, t1]`: when given, the response is the mean of every block's reduced
    /// value over the window (`window_mean`), not the last block's value.
    pub window: Option<(f64, f64)>,
}

#[derive(Debug, Clone)]
pub struct CalculixAdapter {
    /// The job name: the input is `JOB.inp`, results `JOB.dat`.
    pub job: String,
    pub response: DatResponse,
}

impl CalculixAdapter {
    pub fn new(job: impl Into<String>, response: DatResponse) -> Self {
        CalculixAdapter {
            job: job.into(),
            response,
        }
    }

    /// `ccx -i JOB`.
    pub fn argv(&self) -> Vec<String> {
        vec!["ccx".into(), "-i".into(), self.job.clone()]
    }

    pub fn dat_file(&self) -> PathBuf {
        PathBuf::from(format!("{}.dat", self.job))
    }

    /// Files ccx writes (removed before each attempt).
    pub fn outputs(&self) -> Vec<PathBuf> {
        ["dat", "frd", "sta", "cvg"]
            .iter()
            .map(|ext| PathBuf::from(format!("{}.{ext}", self.job)))
            .collect()
    }
}

/// The limits a run must keep to count as sound (fractions, not per cent).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Gates {
    pub hourglass: f64,
    pub energy: f64,
    pub added_mass: f64,
    /// Kinetic over internal energy (a quasi-static crush); added after the others, so a
    /// `results.json` written before it reads with the default.
    #[serde(default = "default_kinetic")]
    pub kinetic: f64,
}

fn default_kinetic() -> f64 {
    0.10
}

impl Default for Gates {
    /// Common crash-analysis practice: hourglass ≤ 10 % of internal energy, energy balance within
    /// ± 5 %, added mass ≤ 1 %; for a quasi-static crush kinetic energy ≤ 10 % of the internal
    /// energy (the usual guidance is 5–10 %; the first fold's snap-through alone reaches 3–6 %
    /// in the reduced honeycomb specimen, see docs/openradioss.md).
    fn default() -> Self {
        Gates {
            hourglass: 0.10,
            energy: 0.05,
            added_mass: 0.01,
            kinetic: default_kinetic(),
        }
    }
}

/// The class of an [`Outcome`], without its details: what retry policies and summaries count.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OutcomeClass {
    Success,
    NonZeroExit,
    FailureText,
    BadResponse,
    IncompleteOutput,
    Timeout,
    Signal,
    Cancelled,
    Lost,
}

impl OutcomeClass {
    /// Its name in `results.json` and on the terminal (`bad_response`), as serialized.
    pub fn key(self) -> String {
        serde_json::to_value(self)
            .ok()
            .and_then(|v| v.as_str().map(String::from))
            .unwrap_or_default()
    }
}

/// How often, on which outcomes, and after how long a failed attempt is retried.
#[derive(Debug, Clone, PartialEq)]
pub struct RetryPolicy {
    /// Attempts in all, counting the first; 1 means no retries.
    pub max_attempts: u32,
    /// Outcome classes that are retried; others are final at once.
    pub retry_on: Vec<OutcomeClass>,
    pub backoff: Backoff,
}

impl RetryPolicy {
    /// One attempt, no retries.
    pub fn none() -> Self {
        RetryPolicy {
            max_attempts: 1,
            retry_on: Vec::new(),
            backoff: Backoff::Fixed(Duration::ZERO),
        }
    }
}

impl Default for RetryPolicy {
    fn default() -> Self {
        RetryPolicy::none()
    }
}

/// Delay before a retry.
#[derive(Debug, Clone, PartialEq)]
pub enum Backoff {
    Fixed(Duration),
    /// `initial · 2^(retry−1)`, capped at `max`.
    Exponential {
        initial: Duration,
        max: Duration,
    },
}

impl Backoff {
    /// Delay before retry number `retry` (1 for the first retry).
    pub fn delay(&self, retry: u32) -> Duration {
        match self {
            Backoff::Fixed(d) => *d,
            Backoff::Exponential { initial, max } => {
                let factor = 2u32.saturating_pow(retry.saturating_sub(1));
                initial.saturating_mul(factor).min(*max)
            }
        }
    }
}

/// `simulation.solver.slurm`: how runs are submitted.
#[derive(Debug, Clone, PartialEq)]
pub struct SlurmSettings {
    pub partition: Option<String>,
    pub time_limit_minutes: Option<u32>,
    /// CPUs per job: the runs of one job run this many at once.
    pub cpus: u32,
    pub memory_mb: Option<u32>,
    /// Runs packed into one job (the scheduler starts about 2 jobs a second).
    pub runs_per_job: usize,
    /// More sbatch options, one argv element each.
    pub options: Vec<String>,
    /// How long a job may be unknown to squeue, scontrol and the jobcomp record before its
    /// unfinished runs are given up as `lost` (see [`lost`]).
    pub lost_after: Duration,
}

/// Default of `slurm.lost_after`: two minutes — far above the few seconds between sbatch and
/// squeue showing the job, and short enough that a vanished job does not stall a study for long.
pub const DEFAULT_LOST_AFTER: Duration = Duration::from_secs(120);

impl Default for SlurmSettings {
    fn default() -> Self {
        SlurmSettings {
            partition: None,
            time_limit_minutes: None,
            cpus: 1,
            memory_mb: None,
            runs_per_job: 8,
            options: Vec::new(),
            lost_after: DEFAULT_LOST_AFTER,
        }
    }
}

/// The `command` adapter's response regex: it compiles and has a capture group for the number.
pub fn response_regex(regex: &str) -> Result<regex::Regex, regex::Error> {
    let regex = regex::Regex::new(regex)?;
    if regex.captures_len() < 2 {
        return Err(regex::Error::Syntax(format!(
            "response regex `{regex}` has no capture group for the number"
        )));
    }
    Ok(regex)
}
