//! Validation of `experiments.unit` (the response's unit) and `experiments.curves` (the test
//! machine's force–displacement CSVs of each specimen). Every error is at the offending node or,
//! for a bad CSV, at its line.
//!
//! `curves` is a path pattern relative to the study file: `{design}` stands for a design name and
//! `*` for any characters of the file name (not of a directory), e.g. `tests/{design}-*.csv`. Each
//! training and validation design must match at least one file — a pattern that finds nothing for
//! a design is far likelier a typo than a design tested without a recorded curve.

use std::path::{Path, PathBuf};

use super::super::experiments::SpecimenCurves;
use super::super::schema::CalibrationFile;
use super::super::yaml::Spanned;
use super::super::{CfcFilter, CurveMetric, CurveSettings, Experiments, Response, Simulation, Targets};
use super::Checker;
use crate::base::curve as crush;
use crate::error::InputError;

/// The stand-in for the design name in `experiments.curves`.
const DESIGN: &str = "{design}";

impl Checker<'_> {
    /// `experiments.unit`: not blank; with a crush-force response it must be the extractor's kN.
    pub(super) fn response_unit(
        &self,
        node: Option<&Spanned<String>>,
        simulation: &Simulation,
    ) -> Result<Option<String>, InputError> {
        let Some(node) = node else { return Ok(None) };
        let unit = node.value.trim();
        if unit.is_empty() {
            return Err(self.at_key(
                "unit",
                node,
                "`experiments.unit` is empty: give the response's unit (e.g. `mm`, `kN`) or leave the key out",
            ));
        }
        if let Simulation::Solver(sim) = simulation
            && let Response::CrushForce { .. } = sim.response
            && unit != "kN"
        {
            return Err(self.at(
                node,
                format!(
                    "`experiments.unit` is `{unit}`, but the `crush_force` response is extracted in kN \
                     (solver forces are converted with `force_to_kn`): write `unit: kN` and give the tests in kN"
                ),
            ));
        }
        Ok(Some(unit.to_string()))
    }

    /// `experiments.curves`: every file the pattern matches for each tested design, read as a test
    /// machine's CSV; each of `required` (the training and validation designs) must have one.
    pub(super) fn specimen_curves(
        &self,
        node: Option<&Spanned<String>>,
        experiments: &Experiments,
        required: &[String],
    ) -> Result<Vec<SpecimenCurves>, InputError> {
        let Some(node) = node else { return Ok(Vec::new()) };
        let pattern = node.value.trim();
        if !pattern.contains(DESIGN) {
            return Err(self.at(
                node,
                format!(
                    "`experiments.curves` must contain `{DESIGN}` (replaced by each design's name), \
                     e.g. `tests/{DESIGN}-*.csv`"
                ),
            ));
        }
        let dir = self.path.parent().unwrap_or(Path::new(""));
        let mut out = Vec::new();
        for test in &experiments.designs {
            let files = self.curve_files(node, dir, &pattern.replace(DESIGN, &test.name))?;
            if files.is_empty() {
                if required.contains(&test.name) {
                    return Err(self.at(
                        node,
                        format!(
                            "`experiments.curves`: no file matches `{}` for design `{}` (looked in {}; \
                             paths are relative to the study file)",
                            pattern.replace(DESIGN, &test.name),
                            test.name,
                            dir.join(pattern.replace(DESIGN, &test.name))
                                .parent()
                                .unwrap_or(dir)
                                .display()
                        ),
                    ));
                }
                continue;
            }
            let specimens = files
                .into_iter()
                .map(|f| crush::read_test_csv(&f, crush::CsvOptions::default()).map(|c| (f, c)))
                .collect::<Result<Vec<_>, _>>()?;
            out.push(SpecimenCurves {
                design: test.name.clone(),
                specimens,
            });
        }
        Ok(out)
    }

    /// The files matching `pattern` (one design's), sorted by name.
    fn curve_files(&self, node: &Spanned<String>, dir: &Path, pattern: &str) -> Result<Vec<PathBuf>, InputError> {
        let full = dir.join(pattern);
        let (Some(parent), Some(name)) = (full.parent(), full.file_name().and_then(|n| n.to_str())) else {
            return Err(self.at(node, "`experiments.curves` must end in a file name pattern"));
        };
        if parent.to_string_lossy().contains('*') {
            return Err(self.at(
                node,
                "`experiments.curves`: `*` may only stand in the file name, not in a directory",
            ));
        }
        let Ok(entries) = std::fs::read_dir(parent) else {
            return Ok(Vec::new());
        };
        let mut files: Vec<PathBuf> = entries
            .filter_map(|e| e.ok())
            .filter(|e| e.path().is_file())
            .filter(|e| e.file_name().to_str().is_some_and(|n| wildcard(name, n)))
            .map(|e| e.path())
            .collect();
        files.sort();
        Ok(files)
    }
}

impl Checker<'_> {
    /// `calibration.against` and `calibration.curve`: curves need a crush-force response and the
    /// specimens' curves, and every specimen of a tested design must cover the grid's window with a
    /// stroke that does not go back there (each error names the CSV file).
    pub(super) fn curve_calibration(
        &self,
        spec: Option<&CalibrationFile>,
        simulation: &Simulation,
        experiments: &Experiments,
        training: &[String],
        validation: &[String],
    ) -> Result<(Targets, CurveSettings), InputError> {
        let against = self.against(spec.and_then(|c| c.against.as_ref()))?;
        let settings = match spec.and_then(|c| c.curve.as_ref()) {
            None => CurveSettings::default(),
            Some(node) => self.curve_settings(&node.value, simulation)?,
        };
        if against.curves {
            self.curves_possible(
                spec.and_then(|c| c.against.as_ref()),
                simulation,
                experiments,
                &settings,
            )?;
            self.specimens_cover(experiments, training, validation, &settings, simulation)?;
        }
        Ok((against, settings))
    }

    /// `calibration.curve`: metric, points, filter, window and surrogate, each checked.
    fn curve_settings(
        &self,
        c: &crate::study::schema::CurveFile,
        simulation: &Simulation,
    ) -> Result<CurveSettings, InputError> {
        let metric = match &c.metric {
            None => CurveMetric::Mse,
            Some(m) => CurveMetric::from_key(m.value.trim()).ok_or_else(|| {
                self.at(
                    m,
                    format!(
                        "unknown curve metric `{}`: choose from {}",
                        m.value,
                        CurveMetric::KEYS.join(", ")
                    ),
                )
            })?,
        };
        let points = match &c.points {
            None => 200,
            Some(p) if (10..=100_000).contains(&p.value) => p.value,
            Some(p) => return Err(self.at(p, "`calibration.curve.points` must be between 10 and 100000")),
        };
        let filter = match &c.filter {
            None => None,
            Some(f) => Some(self.cfc_filter(&f.value)?),
        };
        let window = match &c.window {
            None => None,
            Some(w) => Some(self.curve_window(w, simulation)?),
        };
        let surrogate = match &c.surrogate {
            None => None,
            Some(k) => Some(self.surrogate_named(k, k.value.trim())?),
        };
        Ok(CurveSettings {
            metric,
            points,
            filter,
            window,
            surrogate,
        })
    }

    /// `calibration.curve.filter`: a positive channel frequency class and crush speed.
    fn cfc_filter(&self, f: &crate::study::schema::FilterFile) -> Result<CfcFilter, InputError> {
        let cfc = self.finite(&f.cfc, "`calibration.curve.filter.cfc`")?;
        let speed = self.finite(&f.speed, "`calibration.curve.filter.speed`")?;
        if cfc <= 0.0 {
            return Err(self.at(
                &f.cfc,
                "the channel frequency class must be positive (e.g. 60, 180, 600)",
            ));
        }
        if speed <= 0.0 {
            return Err(self.at(
                &f.speed,
                "the crush speed (m/s) must be positive: it turns the stroke a curve is sampled at into time",
            ));
        }
        Ok(CfcFilter { cfc, speed })
    }

    /// `calibration.curve.window`: [s0, s1], increasing, containing the response's window.
    fn curve_window(&self, w: &Spanned<Vec<Spanned<f64>>>, simulation: &Simulation) -> Result<[f64; 2], InputError> {
        let [a, b] = w.value.as_slice() else {
            return Err(self.at(w, "`calibration.curve.window` is two strokes in mm: [s0, s1]"));
        };
        let (a, b) = (self.finite(a, "window start")?, self.finite(b, "window end")?);
        if a >= b {
            return Err(self.at(w, format!("`calibration.curve.window`: {a} must be less than {b}")));
        }
        if let Simulation::Solver(sim) = simulation
            && let Response::CrushForce { window: r, .. } = sim.response
            && (a > r.s0 || b < r.s1)
        {
            return Err(self.at(
                w,
                format!(
                    "`calibration.curve.window` [{a}, {b}] must contain the response's window [{}, {}]: the plateau \
                     features are read there",
                    r.s0, r.s1
                ),
            ));
        }
        Ok([a, b])
    }

    /// `calibration.against`: `response` and/or `curves`, each once.
    fn against(&self, node: Option<&Spanned<Vec<super::super::schema::Name>>>) -> Result<Targets, InputError> {
        let Some(node) = node else {
            return Ok(Targets::default());
        };
        if node.value.is_empty() {
            return Err(self.at(
                node,
                "`calibration.against` is empty: give `response`, `curves` or both",
            ));
        }
        let mut t = Targets {
            response: false,
            curves: false,
        };
        for name in &node.value {
            let slot = match name.value.as_str() {
                "response" => &mut t.response,
                "curves" => &mut t.curves,
                other => {
                    return Err(self.at(
                        name,
                        format!("unknown calibration target `{other}`: choose from response, curves"),
                    ));
                }
            };
            if *slot {
                return Err(self.at(name, format!("`{}` is listed twice", name.value)));
            }
            *slot = true;
        }
        Ok(t)
    }

    /// Curves need runs that write a force–displacement history and the specimens' curves.
    fn curves_possible(
        &self,
        node: Option<&Spanned<Vec<super::super::schema::Name>>>,
        simulation: &Simulation,
        experiments: &Experiments,
        _settings: &CurveSettings,
    ) -> Result<(), InputError> {
        let at = |message: &str| match node {
            Some(n) => self.at(n, message),
            None => InputError::file(self.path, message),
        };
        let crush =
            matches!(simulation, Simulation::Solver(sim) if matches!(sim.response, Response::CrushForce { .. }));
        if !crush {
            return Err(at(
                "`calibration.against: [.., curves]` needs a solver study with a `crush_force` response: its runs \
                 write the force–displacement histories the curves are read from",
            ));
        }
        if experiments.curves.is_empty() {
            return Err(at(
                "`calibration.against: [.., curves]` needs the specimens' curves: give `experiments.curves`",
            ));
        }
        Ok(())
    }

    /// Every specimen of a training or validation design covers the grid's window.
    fn specimens_cover(
        &self,
        experiments: &Experiments,
        training: &[String],
        validation: &[String],
        settings: &CurveSettings,
        simulation: &Simulation,
    ) -> Result<(), InputError> {
        let grid = super::super::curve_grid(settings, simulation).expect("a crush-force response");
        for sc in &experiments.curves {
            if !training.contains(&sc.design) && !validation.contains(&sc.design) {
                continue;
            }
            for (file, curve) in &sc.specimens {
                crate::base::grid::resample(curve, &grid).map_err(|e| {
                    InputError::file(
                        file,
                        format!("cannot put this specimen's curve on the calibration grid: {e}"),
                    )
                })?;
            }
        }
        Ok(())
    }
}

/// Whether `text` matches `pattern`, where `*` matches any run of characters (none included).
fn wildcard(pattern: &str, text: &str) -> bool {
    let (p, t): (Vec<char>, Vec<char>) = (pattern.chars().collect(), text.chars().collect());
    let (mut i, mut j) = (0, 0);
    // The last `*` seen and the text position it was tried at: backtrack there on a mismatch.
    let mut star: Option<(usize, usize)> = None;
    while j < t.len() {
        if i < p.len() && p[i] != '*' && p[i] == t[j] {
            i += 1;
            j += 1;
        } else if i < p.len() && p[i] == '*' {
            star = Some((i, j));
            i += 1;
        } else if let Some((si, sj)) = star {
            i = si + 1;
            j = sj + 1;
            star = Some((si, sj + 1));
        } else {
            return false;
        }
    }
    p[i..].iter().all(|&c| c == '*')
}

#[cfg(test)]
mod tests {
    use super::wildcard;

    #[test]
    fn wildcards_match_runs_of_characters() {
        assert!(wildcard("C3T7-*.csv", "C3T7-1.csv"));
        assert!(wildcard("C3T7-*.csv", "C3T7-.csv"));
        assert!(!wildcard("C3T7-*.csv", "C3T75-1.csv"));
        assert!(!wildcard("C3T7-*.csv", "C3T7-1.csv.bak"));
        assert!(wildcard("*", "anything"));
        assert!(wildcard("a*b*c", "aXbYbc"));
        assert!(!wildcard("a*b*c", "aXbYb"));
        assert!(wildcard("exact.csv", "exact.csv"));
        assert!(!wildcard("exact.csv", "exact.csvx"));
    }
}
