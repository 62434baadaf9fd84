//! The real solver beside the stand-in, inside the `force-displacement` section: per design a table
//! of the measures of [`crate::report::solvers`] (mean ± standard deviation over the design's
//! runs, each run's deck crushed by both solvers) and one run's two curves (`solvers-<design>`).

use std::fmt::Write;

use super::{Page, escape, figure, id_part};
use crate::report::plots::{Band, Series, Style, XyPlot, short};
use crate::report::solvers::{CurveMeasures, DesignComparison, SolverComparison};

/// Mean ± standard deviation of the finite values, with their count.
fn stat(values: impl Iterator<Item = f64>) -> Option<(f64, f64, usize)> {
    let v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let sd = if v.len() > 1 {
        (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    } else {
        0.0
    };
    Some((mean, sd, v.len()))
}

type Measure = (&'static str, fn(&CurveMeasures) -> Option<f64>);

const MEASURES: [Measure; 6] = [
    ("initial peak (kN)", |m| m.peak),
    ("initial peak at (mm)", |m| m.peak_at),
    ("plateau (kN)", |m| Some(m.plateau)),
    ("peak / plateau", |m| m.peak.map(|p| p / m.plateau)),
    ("plateau noise (RMS about its line / plateau)", |m| Some(m.noise)),
    ("fold period (mm)", |m| m.period),
];

fn cell(runs: &[CurveMeasures], f: fn(&CurveMeasures) -> Option<f64>) -> String {
    match stat(runs.iter().filter_map(f)) {
        Some((mean, sd, n)) if n < runs.len() => {
            format!("{} ± {} ({n} of {} runs)", short(mean, 3), short(sd, 2), runs.len())
        }
        Some((mean, sd, _)) => format!("{} ± {}", short(mean, 3), short(sd, 2)),
        None => "–".into(),
    }
}

impl Page<'_> {
    pub(super) fn solver_comparison(&self) -> String {
        let Some(c) = self.d.and_then(|d| d.solver_comparison.as_ref()) else {
            return String::new();
        };
        let mut s = format!(
            "<h3 id=solvers>{} and the stand-in {} on the same decks</h3><p>Every successful run's deck crushed \
             by both solvers, measured alike over the stroke window {}–{} mm (mean ± standard deviation over the \
             design's runs).</p>",
            escape(&c.solver),
            escape(&c.standin),
            short(c.window[0], 3),
            short(c.window[1], 3)
        );
        for d in &c.designs {
            s += &self.design_table(c, d);
        }
        s += "<div class=grid>";
        for d in &c.designs {
            s += &self.design_figure(c, d);
        }
        s + "</div>"
    }

    fn design_table(&self, c: &SolverComparison, d: &DesignComparison) -> String {
        let mut s = format!(
            "<table><tr><th class=l>design {} ({} runs)</th><th>{}</th><th>{}</th></tr>",
            escape(&d.design),
            d.real.len(),
            escape(&c.solver),
            escape(&c.standin)
        );
        for (name, f) in MEASURES {
            let _ = write!(
                s,
                "<tr><td class=l>{name}</td><td>{}</td><td>{}</td></tr>",
                cell(&d.real, f),
                cell(&d.standin, f)
            );
        }
        s + "</table>"
    }

    fn design_figure(&self, c: &SolverComparison, d: &DesignComparison) -> String {
        let Some((real, standin)) = &d.example else {
            return String::new();
        };
        let series = [(real, 0), (standin, 1)]
            .into_iter()
            .map(|(curve, color)| {
                let points = curve
                    .displacement
                    .iter()
                    .copied()
                    .zip(curve.force.iter().copied())
                    .collect();
                Series::new(curve.label.clone(), color, Style::Line, points)
            })
            .collect();
        let plot = XyPlot {
            title: format!("{} and {}, design {}", c.solver, c.standin, d.design),
            x_label: "displacement (mm)".into(),
            y_label: "force (kN)".into(),
            series,
            bands: vec![Band {
                label: format!("stroke window {}–{} mm", short(c.window[0], 3), short(c.window[1], 3)),
                x0: c.window[0],
                x1: c.window[1],
            }],
            y_floor: Some(0.0),
            ..Default::default()
        };
        let caption = format!(
            "The same deck (the design's first compared run) crushed by {} and by {}.",
            escape(&c.solver),
            escape(&c.standin)
        );
        figure(&format!("solvers-{}", id_part(&d.design)), plot.render(), &caption)
    }
}
