//! The other commands, each a short sequence of the same stages as [`super::run`], returning what
//! the command line prints: `lab check`, `lab status`, `lab report`, `lab extract`, `lab compare`
//! and the internal `lab slurm-worker`.

use crate::extract::adapters::solver;
use std::path::Path;

use super::sequence::record::Replaced;
use crate::error::{Error, InputError};
use crate::execute::store::Snapshot;
use crate::execute::{lock, sweep};
use crate::extract::crush;
use crate::extract::grid::{self, StrokeGrid};
use crate::plan::Plan;
use crate::study::{Simulation, Study};

/// `lab check`: what was validated beyond loading the study.
pub struct Checked {
    /// A solver study's planned runs, every one rendered in memory.
    pub rendered_runs: Option<usize>,
    /// The runs the solver in the loop would add if every ranged extension were chosen, rendered too.
    pub loop_runs: usize,
    /// Force–displacement curves read: (specimens, designs).
    pub curves: (usize, usize),
    /// With sequential sampling, the most solver runs the study may make (its budget).
    pub budget: Option<usize>,
    /// With `sampling.replaces`: that fixed design counted without the loop, and its solver runs
    /// with the loop for every ranged extension.
    pub replaces: Option<(Replaced, usize)>,
}

/// `lab check`: renders every planned run in memory (undefined template variables show up here),
/// and the solver-in-the-loop runs of every extension with ranges (which a `lab run` plans only for
/// the hypotheses its screening chooses); loading the study has already read everything else it
/// references.
pub fn check(study: &Study) -> Result<Checked, Error> {
    let (rendered_runs, loop_runs) = match &study.simulation {
        Simulation::Solver(sim) => {
            let plan = Plan::new(study, sim);
            sweep::prepare(study, &solver(sim)?, &plan)?;
            let ranged: Vec<usize> = study.extension_hypotheses().map(|(k, _)| k).collect();
            let joint = Plan::joint(study, sim, &ranged);
            sweep::prepare(study, &solver(sim)?, &joint)?;
            (Some(plan.runs.len()), joint.runs.len())
        }
        Simulation::Expression(_) => (None, 0),
    };
    let curves = &study.experiments.curves;
    let budget = match &study.simulation {
        Simulation::Solver(sim) => crate::plan::sweep::sequential_budget(study, sim),
        Simulation::Expression(_) => None,
    };
    let replaces = match &study.simulation {
        Simulation::Solver(sim) => sim
            .sampling
            .sequential
            .as_ref()
            .and_then(|q| q.replaces.as_deref())
            .map(|fixed| {
                let every: Vec<usize> = study.extension_hypotheses().map(|(k, _)| k).collect();
                let with_loop = Replaced::counted(study, sim, fixed, &every).runs;
                (Replaced::counted(study, sim, fixed, &[]), with_loop)
            }),
        Simulation::Expression(_) => None,
    };
    Ok(Checked {
        rendered_runs,
        loop_runs,
        curves: (curves.iter().map(|c| c.specimens.len()).sum(), curves.len()),
        budget,
        replaces,
    })
}

/// `lab status`: counts of the planned runs.
pub struct Status {
    pub planned: usize,
    pub done: usize,
    pub failed: usize,
    /// Of `failed`, per stage (`screening`, `probes`, `loop: <hypothesis>`, `confirmation`), in
    /// the order the stages ran.
    pub failed_by_stage: Vec<(String, usize)>,
    pub running: usize,
    pub pending: usize,
    /// Whether a lab holds the output directory: `Some(None)` while the holder is being written.
    pub holder: Option<Option<crate::execute::Holder>>,
    /// A sequential study: the batches done, and the one in flight (`OUT/sequence.json`).
    pub batches: Option<Batches>,
}

/// A sequential study's batches as `lab status` shows them.
pub struct Batches {
    /// (stage, batches done in it), in order.
    pub done: Vec<(String, usize)>,
    /// The batch whose runs are under way: its stage, number and runs.
    pub in_flight: Option<(String, usize, usize)>,
    /// Why the stages that ended stopped: (stage, reason).
    pub stopped: Vec<(String, String)>,
}

/// `lab status`: the planned runs counted from the store, read without taking its lock; `None`
/// for a closed-form study (no runs). The solver-in-the-loop runs count once a `lab run` has
/// chosen them (`OUT/extension-plan.json`), the confirmation runs once it has planned them
/// (`OUT/confirmation-plan.json`).
pub fn status(study: &Study, out: &Path) -> Result<Option<Status>, Error> {
    let Simulation::Solver(sim) = &study.simulation else {
        return Ok(None);
    };
    let sequence = sim
        .sampling
        .sequential
        .as_ref()
        .and_then(|_| super::sequence::Sequence::read(out));
    let plan = match &sequence {
        // A sequential study's runs are the batches planned so far.
        Some(s) => Plan {
            runs: s.planned.iter().map(|p| p.run()).collect(),
        },
        None => {
            let mut plan = Plan::new(study, sim);
            plan.runs.extend(super::extend::recorded_plan(study, sim, out).runs);
            plan.runs.extend(super::confirm::recorded_plan(out));
            plan
        }
    };
    let prepared = sweep::prepare(study, &solver(sim)?, &plan)?;
    let snapshot = Snapshot::read(out)?;
    let holder = lock::probe(out).map_err(|e| Error::Failed(e.to_string()))?;
    let mut status = Status {
        planned: plan.runs.len(),
        done: 0,
        failed: 0,
        failed_by_stage: Vec::new(),
        running: 0,
        pending: 0,
        holder,
        batches: sequence.as_ref().map(batches),
    };
    for (key, run) in prepared.keys.iter().zip(&plan.runs) {
        match snapshot.records.get(key) {
            Some(r) if r.outcome.is_success() => status.done += 1,
            Some(_) => {
                status.failed += 1;
                let stage = run.role.stage(study);
                match status.failed_by_stage.iter_mut().find(|(s, _)| *s == stage) {
                    Some((_, n)) => *n += 1,
                    None => status.failed_by_stage.push((stage, 1)),
                }
            }
            None if status.holder.is_some() && snapshot.run_dirs.contains(key) => status.running += 1,
            None => status.pending += 1,
        }
    }
    Ok(Some(status))
}

/// The batches of a sequence, by stage.
fn batches(s: &super::sequence::Sequence) -> Batches {
    let mut done: Vec<(String, usize)> = Vec::new();
    let mut in_flight = None;
    for b in &s.sequence {
        if b.state != super::sequence::BatchState::Done {
            in_flight = Some((b.stage.clone(), b.batch, b.count.runs));
            continue;
        }
        match done.last_mut() {
            Some((stage, n)) if *stage == b.stage => *n += 1,
            _ => done.push((b.stage.clone(), 1)),
        }
    }
    Batches {
        done,
        in_flight,
        stopped: s
            .stopped
            .iter()
            .map(|x| (x.stage.clone(), x.reason.key().to_string()))
            .collect(),
    }
}

/// `lab extract`: the mean crush force of a test machine's force–displacement CSV over a window.
pub fn extract(curve: &Path, window: crush::Window) -> Result<crush::CrushResult, Error> {
    let data = crush::read_test_csv(curve, crush::CsvOptions::default())?;
    Ok(crush::crush_force(&data, window).map_err(|e| InputError::file(curve, e.to_string()))?)
}

/// `lab slurm-worker` (inside a Slurm job): runs `keys` of the study and commits their records.
pub fn slurm_worker(study: &Study, out: &Path, jobs: usize, keys: &[String]) -> Result<i32, Error> {
    let Simulation::Solver(sim) = &study.simulation else {
        return Err(Error::Failed("slurm-worker: not a solver study".into()));
    };
    sweep::worker(study, &solver(sim)?, out, jobs, keys)
}

// --- issue 24: `lab compare` (curve metrics) ---

/// `lab compare`'s grid, as printed.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct CompareGrid {
    pub s0: f64,
    pub s1: f64,
    pub points: usize,
}

/// `lab compare`: curve B (computed) against curve A (target). Metrics the definitions leave
/// undefined are NaN (JSON null).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Comparison {
    pub target: String,
    pub computed: String,
    /// `raw`: pcm, frechet, dtw, area on the recorded points of both files; `grid`: every metric
    /// on both curves resampled onto `grid` (`--window`).
    pub on: &'static str,
    pub pcm: f64,
    pub frechet: f64,
    pub dtw: f64,
    pub area: f64,
    /// LS-OPT MSE on `grid`; null when no common grid exists (see `note`).
    pub mse: Option<f64>,
    /// The grid of `mse` (and of every metric with `--window`): the window, or without it the
    /// overlap of the two strokes.
    pub grid: Option<CompareGrid>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// `--window S0:S1` (mm, finite, S0 < S1).
pub fn parse_window(text: &str) -> Result<crush::Window, String> {
    let bad = || format!("`{text}`: give S0:S1 in mm with S0 < S1, e.g. 5:60");
    let (a, b) = text.split_once(':').ok_or_else(bad)?;
    let (s0, s1) = (
        a.trim().parse::<f64>().map_err(|_| bad())?,
        b.trim().parse::<f64>().map_err(|_| bad())?,
    );
    if !(s0.is_finite() && s1.is_finite() && s1 > s0) {
        return Err(bad());
    }
    Ok(crush::Window { s0, s1 })
}

/// A test-machine CSV read as `lab extract` reads it, with its text kept to name lines in errors.
struct CurveFile<'a> {
    path: &'a Path,
    text: String,
    curve: crush::ForceDisplacement,
}

impl<'a> CurveFile<'a> {
    fn read(path: &'a Path) -> Result<Self, InputError> {
        let text = crate::extract::lsdyna::text::read_text(path)?;
        let curve = crush::parse_test_csv(path, &text, crush::CsvOptions::default())?;
        Ok(CurveFile { path, text, curve })
    }

    fn resample(&self, grid: &StrokeGrid) -> Result<Vec<f64>, InputError> {
        grid::resample(&self.curve, grid).map_err(|e| grid::to_input_error(&e, self.path, &self.text))
    }
}

/// `lab compare A B [--window S0:S1] [--points N]`: every metric of B against A. Without a window:
/// pcm, frechet, dtw and area on the raw points, and mse on `points` grid strokes over the overlap
/// of the two strokes (null, with a note, when they do not overlap or a stroke goes back there).
/// With a window: both curves on one grid over it, every metric on the grid points; a window a curve
/// does not cover, or a stroke that goes back inside it, is bad input naming the file and line.
pub fn compare(a: &Path, b: &Path, window: Option<crush::Window>, points: usize) -> Result<Comparison, Error> {
    use crate::extract::metrics;
    let (fa, fb) = (CurveFile::read(a)?, CurveFile::read(b)?);
    let mut c = Comparison {
        target: a.display().to_string(),
        computed: b.display().to_string(),
        on: "raw",
        pcm: f64::NAN,
        frechet: f64::NAN,
        dtw: f64::NAN,
        area: f64::NAN,
        mse: None,
        grid: None,
        note: None,
    };
    let (pa, pb) = match window {
        Some(w) => {
            let g = StrokeGrid {
                s0: w.s0,
                s1: w.s1,
                points,
            };
            let (ya, yb) = (fa.resample(&g)?, fb.resample(&g)?);
            c.on = "grid";
            c.mse = Some(metrics::mse(&ya, &yb));
            c.grid = Some(CompareGrid {
                s0: g.s0,
                s1: g.s1,
                points,
            });
            let s = g.stroke();
            let on_grid = |y: &[f64]| s.iter().zip(y).map(|(&x, &y)| [x, y]).collect::<Vec<_>>();
            (on_grid(&ya), on_grid(&yb))
        }
        None => {
            overlap_mse(&fa, &fb, points, &mut c);
            (metrics::curve_points(&fa.curve), metrics::curve_points(&fb.curve))
        }
    };
    c.pcm = metrics::pcm(&pa, &pb);
    c.frechet = metrics::frechet(&pa, &pb);
    c.dtw = metrics::dtw(&pa, &pb);
    c.area = metrics::area(&pa, &pb);
    Ok(c)
}

/// MSE on `points` strokes over the overlap of the two curves' loading strokes (first sample to
/// largest stroke), or a note saying why there is none.
fn overlap_mse(fa: &CurveFile<'_>, fb: &CurveFile<'_>, points: usize, c: &mut Comparison) {
    let range = |f: &CurveFile<'_>| {
        let d = &f.curve.displacement;
        (d[0], d.iter().copied().fold(f64::NEG_INFINITY, f64::max))
    };
    let ((a0, a1), (b0, b1)) = (range(fa), range(fb));
    let g = StrokeGrid {
        s0: a0.max(b0),
        s1: a1.min(b1),
        points,
    };
    if g.s1 <= g.s0 {
        c.note = Some(format!(
            "mse needs a common stroke range: A runs {a0}..{a1} mm, B {b0}..{b1} mm"
        ));
        return;
    }
    match (fa.resample(&g), fb.resample(&g)) {
        (Ok(ya), Ok(yb)) => {
            c.mse = Some(crate::extract::metrics::mse(&ya, &yb));
            c.grid = Some(CompareGrid {
                s0: g.s0,
                s1: g.s1,
                points,
            });
        }
        (Err(e), _) | (_, Err(e)) => c.note = Some(format!("no mse on the strokes' overlap: {e}")),
    }
}

impl Comparison {
    /// The human table: metric, value, unit, what it is.
    pub fn table(&self) -> String {
        let mut out = format!("A (target): {}\nB (computed): {}\n", self.target, self.computed);
        out += &match (self.on, &self.grid) {
            ("grid", Some(g)) => format!(
                "every metric on both curves resampled at {} strokes over {}:{} mm\n",
                g.points, g.s0, g.s1
            ),
            (_, Some(g)) => format!(
                "pcm, frechet, dtw, area on the recorded points; mse at {} strokes over {}:{} mm (the strokes' overlap)\n",
                g.points, g.s0, g.s1
            ),
            _ => "pcm, frechet, dtw, area on the recorded points\n".to_string(),
        };
        let rows = [
            (
                "mse",
                self.mse.unwrap_or(f64::NAN),
                "-",
                "LS-OPT mean squared error, scaled by max |F_A|",
            ),
            (
                "pcm",
                self.pcm,
                "-",
                "partial curve mapping, axes normalised by A's ranges",
            ),
            (
                "frechet",
                self.frechet,
                "mm|kN",
                "discrete Frechet distance (mm and kN mixed as one unit)",
            ),
            (
                "dtw",
                self.dtw,
                "mm|kN",
                "dynamic time warping, summed point distances (mm and kN mixed)",
            ),
            ("area", self.area, "mm*kN", "area between the curves (mm*kN = J)"),
        ];
        out += &format!("\n{:<8} {:>14}  {:<6} {}\n", "metric", "value", "unit", "definition");
        for (name, value, unit, what) in rows {
            out += &format!("{name:<8} {:>14}  {unit:<6} {what}\n", significant(value));
        }
        if let Some(note) = &self.note {
            out += &format!("\nnote: {note}\n");
        }
        out
    }
}

/// Six significant digits, fixed or scientific as the size asks; `undefined` for NaN.
fn significant(v: f64) -> String {
    if !v.is_finite() {
        return "undefined".to_string();
    }
    let e = if v == 0.0 { 0 } else { v.abs().log10().floor() as i32 };
    if (-3..6).contains(&e) {
        format!("{v:.*}", (5 - e).max(0) as usize)
    } else {
        format!("{v:.5e}")
    }
}

// --- issue 32: `lab extract` on a binout ---

/// Whether `path` is a binout (an LSDA file) or a directory, rather than a CSV: read by its
/// first bytes, not its name.
pub fn is_binout(path: &Path) -> bool {
    if path.is_dir() {
        return true;
    }
    let mut head = [0u8; 8];
    std::fs::File::open(path)
        .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut head))
        .is_ok_and(|_| lsda::Header::parse(&head).is_ok())
}

/// What `lab extract` is asked of a binout.
#[derive(Debug, Clone, PartialEq)]
pub enum BinoutQuery {
    /// `--list`: the histories and variables.
    List,
    /// `--series PATH`: one variable over time (`--json`: as JSON).
    Series { path: String, json: bool },
    /// The mean force over the stroke window.
    MeanForce(crush::Window),
}

/// What to print: the answer (stdout) and the reader's notes (stderr: a cut file).
#[derive(Debug, Clone, PartialEq)]
pub struct BinoutAnswer {
    pub text: String,
    pub notes: Vec<String>,
}

/// `lab extract BINOUT|RUN_DIR [--list | --series PATH [--json] | --window S0:S1]`.
pub fn extract_binout(path: &Path, query: &BinoutQuery) -> Result<BinoutAnswer, Error> {
    use crate::extract::lsdyna::binout;
    let b = binout::open(path)?;
    let text = match query {
        BinoutQuery::List => b.list(),
        BinoutQuery::Series { path: var, json: true } => {
            serde_json::to_string(&b.series(var)?).map_err(|e| Error::Failed(e.to_string()))? + "\n"
        }
        BinoutQuery::Series { path: var, json: false } => series_table(&b.series(var)?),
        BinoutQuery::MeanForce(w) => binout_mean_force(&b, *w)?,
    };
    Ok(BinoutAnswer { text, notes: b.notes() })
}

/// A series as text: `time value` rows (one value per id for a per-id variable).
fn series_table(s: &crate::extract::lsdyna::binout::Series) -> String {
    use crate::extract::lsdyna::binout::SeriesValues;
    let mut out = String::new();
    match &s.values {
        SeriesValues::Text(t) => out = format!("{t}\n"),
        SeriesValues::Scalar(v) if s.time.is_empty() => v.iter().for_each(|x| out += &format!("{x}\n")),
        SeriesValues::Scalar(v) => s.time.iter().zip(v).for_each(|(t, x)| out += &format!("{t:e} {x}\n")),
        SeriesValues::PerId(v) => {
            if let Some(ids) = &s.ids {
                out += &format!(
                    "# time, then ids {}\n",
                    ids.iter().map(|i| i.to_string()).collect::<Vec<_>>().join(" ")
                );
            }
            for (k, t) in s.time.iter().enumerate() {
                let row: Vec<String> = v.iter().map(|id| id[k].to_string()).collect();
                out += &format!("{t:e} {}\n", row.join(" "));
            }
        }
    }
    out
}

/// The force history for `lab extract`: rcforc's first interface (its SURFB side) when rcforc
/// has data, else rwforc's first wall's normal force; with the words saying which.
fn binout_force(
    b: &crate::extract::lsdyna::binout::Binout,
) -> Result<(crate::extract::lsdyna::binout::histories::WallSeries, String), Error> {
    use crate::extract::lsdyna::binout::histories;
    use crate::extract::lsdyna::rcforc::Side;
    if let Some(rc) = histories::rcforc(b)?
        && let Some(((_, id), s)) = rc.interfaces.iter().find(|((side, _), _)| *side == Side::SurfB)
    {
        let w = histories::WallSeries {
            time: s.time.clone(),
            normal: Vec::new(),
            force: [s.x.clone(), s.y.clone(), s.z.clone()],
        };
        return Ok((w, format!("rcforc interface {id} (SURFB/master)")));
    }
    if let Some(rw) = histories::rwforc(b)?
        && let Some((id, w)) = rw.walls.into_iter().next()
    {
        return Ok((w, format!("rwforc rigid wall {id}")));
    }
    Err(InputError::file(
        &b.name,
        "no force history: neither rcforc resultants nor rwforc rigid-wall forces",
    )
    .into())
}

/// The mean force over the stroke window: the force history against the node of nodout that
/// moves most, along its axis of largest motion. Without nodout (no stroke): the force's peak and
/// time average. Units are the solver's.
fn binout_mean_force(b: &crate::extract::lsdyna::binout::Binout, w: crush::Window) -> Result<String, Error> {
    use crate::extract::lsdyna::binout::histories;
    let (force, what) = binout_force(b)?;
    let Some(nod) = histories::nodout(b)?.filter(|n| !n.nodes.is_empty()) else {
        let f = if force.normal.is_empty() {
            &force.force[2]
        } else {
            &force.normal
        };
        let (peak, at) = force.time.iter().zip(f).fold(
            (0.0f64, 0.0),
            |m, (t, v)| if v.abs() > m.0.abs() { (*v, *t) } else { m },
        );
        let span = force.time.last().copied().unwrap_or(0.0) - force.time.first().copied().unwrap_or(0.0);
        let area: f64 = force
            .time
            .windows(2)
            .zip(f.windows(2))
            .map(|(t, v)| 0.5 * (v[0] + v[1]) * (t[1] - t[0]))
            .sum();
        let mean = if span > 0.0 { area / span } else { f64::NAN };
        return Ok(format!(
            "{what}{}: peak {peak} at time {at:e}, time average {mean} over {} outputs (the solver's force unit); no nodout in this binout, so no stroke and no mean crush force\n",
            if force.normal.is_empty() { " z" } else { " normal force" },
            force.time.len()
        ));
    };
    let moved = |s: &crate::extract::lsdyna::nodout::NodeSeries, a: usize| {
        let d = &s.disp[a];
        (d.last().copied().unwrap_or(0.0) - d.first().copied().unwrap_or(0.0)).abs()
    };
    let (node, axis) = nod
        .nodes
        .iter()
        .flat_map(|(id, s)| (0..3).map(move |a| (*id, a, moved(s, a))))
        .max_by(|x, y| x.2.total_cmp(&y.2))
        .map(|(id, a, _)| (id, a))
        .expect("nodout has nodes");
    let f = if force.normal.is_empty() {
        &force.force[axis]
    } else {
        &force.normal
    };
    let n = &nod.nodes[&node];
    let curve = crush::from_histories(
        &force.time,
        f,
        &n.time,
        &n.disp[axis],
        crush::Sign::Auto,
        crush::Sign::Auto,
    )
    .map_err(|e| InputError::file(&b.name, e.to_string()))?;
    let r = crush::crush_force(&curve, w).map_err(|e| InputError::file(&b.name, e.to_string()))?;
    let axis_name = ["x", "y", "z"][axis];
    Ok(format!(
        "mean crush force {} over stroke {}-{} (energy {}, peak {} at {}; the solver's units: {what} {axis_name} against node {node}'s {axis_name} displacement)\n",
        r.mean_force, w.s0, w.s1, r.energy, r.peak_force, r.peak_at
    ))
}
// --- end issue 32 ---
