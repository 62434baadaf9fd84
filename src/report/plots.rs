//! The report's plots as inline SVG strings, drawn with `plotters`' SVG backend (default features
//! off: text is laid out by the naive estimator and rendered by the browser, so no font library).
//!
//! Three kinds cover every figure: [`XyPlot`] (lines, markers, error bars, shaded x-bands, marker
//! lines), [`histogram`] (with marked values), [`BarPlot`] (horizontal grouped bars).
//! Every plot has a title and labelled axes; callers put units into the labels.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::summary::significant;

/// Plot size in SVG pixels; CSS scales it to the column.
pub const WIDTH: u32 = 640;
pub const HEIGHT: u32 = 400;

/// Colour-blind-safe palette (Okabe–Ito), then grey.
const PALETTE: [RGBColor; 8] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
    RGBColor(120, 120, 120),
];

pub fn color(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

pub const BLACK_: usize = 6;
pub const GREY: usize = 7;

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Style {
    Line,
    /// A thin line (one of many: simulated runs behind the highlighted one).
    Thin,
    Dashed,
    Markers,
    /// Hollow markers (check points, validation designs).
    Hollow,
    LineMarkers,
}

#[derive(Debug, Clone)]
pub struct Series {
    pub label: String,
    pub color: usize,
    pub style: Style,
    pub points: Vec<(f64, f64)>,
    /// Symmetric y error bars, one per point.
    pub y_err: Option<Vec<f64>>,
}

impl Series {
    pub fn new(label: impl Into<String>, color: usize, style: Style, points: Vec<(f64, f64)>) -> Series {
        Series {
            label: label.into(),
            color,
            style,
            points,
            y_err: None,
        }
    }
}

/// A shaded interval of x (a stroke window, a 95 % interval).
#[derive(Debug, Clone)]
pub struct Band {
    pub label: String,
    pub x0: f64,
    pub x1: f64,
}

/// A vertical marker line.
#[derive(Debug, Clone)]
pub struct VLine {
    pub label: String,
    pub x: f64,
    pub color: usize,
}

#[derive(Debug, Clone, Default)]
pub struct XyPlot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    pub bands: Vec<Band>,
    pub vlines: Vec<VLine>,
    /// A horizontal reference line (zero residual, the parity diagonal is a series instead).
    pub hline: Option<f64>,
    /// The y axis starts exactly here when every value is above it (forces from 0).
    pub y_floor: Option<f64>,
    /// Extra room above the data, as a fraction of the y span, for the legend to sit in.
    pub legend_room: f64,
}

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// Draws into an SVG string; a drawing error becomes a visible message, never a panic.
fn svg(draw: impl FnOnce(&DrawingArea<SVGBackend, Shift>) -> Result<()>) -> String {
    svg_sized((WIDTH, HEIGHT), draw)
}

fn svg_sized(size: (u32, u32), draw: impl FnOnce(&DrawingArea<SVGBackend, Shift>) -> Result<()>) -> String {
    let mut out = String::new();
    let outcome = {
        let root = SVGBackend::with_string(&mut out, size).into_drawing_area();
        root.fill(&WHITE)
            .map_err(|e| e.to_string().into())
            .and_then(|_| draw(&root))
            .and_then(|_| {
                root.present()?;
                Ok(())
            })
    };
    match outcome {
        // Inline SVG in HTML needs no namespace declaration; leaving it out keeps the page free of URLs.
        Ok(()) => out.replacen(" xmlns=\"http://www.w3.org/2000/svg\"", "", 1),
        Err(e) => format!(
            "<p class=warn>plot failed: {}</p>",
            super::markup::escape(&e.to_string())
        ),
    }
}

/// A padded range around `values` (never empty, never inverted).
fn range(values: impl Iterator<Item = f64>, pad: f64) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let span = hi - lo;
    if span > 0.0 {
        return (lo - pad * span, hi + pad * span);
    }
    // One value: a box around it (an empty range would give the axis no ticks to draw).
    let half = if lo != 0.0 { lo.abs() * 0.05 } else { 0.5 };
    (lo - half, hi + half)
}

/// A bar's label. Errors (percent): two significant figures, the tables hold the digits. Weights
/// (fractions of 1): two decimals, and "< 0.01" rather than a "0" that would read as impossible.
fn bar_text(v: f64, percent: bool, max: f64) -> String {
    match (percent, v) {
        (true, v) if v.abs() < 1e-9 * max => "0 %".to_string(),
        (true, v) => format!("{} %", significant(100.0 * v, 2)),
        (false, v) if v > 0.0 && v < 0.005 => "< 0.01".to_string(),
        (false, v) => format!("{v:.2}"),
    }
}

/// `sig` significant figures without trailing zeros (`7`, `0.25`, `6.02e-5`).
pub fn short(v: f64, sig: usize) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let s = significant(v, sig);
    match s.split_once('e') {
        Some((m, e)) if m.contains('.') => format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.')),
        Some(_) => s,
        None if s.contains('.') => s.trim_end_matches('0').trim_end_matches('.').to_string(),
        None => s,
    }
}

/// Tick label: few significant digits, no trailing noise.
pub fn tick(v: f64) -> String {
    short(v, 4)
}

/// Tick label on an axis spanning `span`: rounding noise around zero shows as 0.
fn tick_on(v: f64, span: f64) -> String {
    if v.abs() < 1e-9 * span { "0".into() } else { tick(v) }
}

/// Where the legend hides the fewest points: the corner of the plot with the fewest data in it.
fn legend_corner(points: &[(f64, f64)], x: (f64, f64), y: (f64, f64)) -> SeriesLabelPosition {
    let count = |right: bool, top: bool| {
        points
            .iter()
            .filter(|(px, py)| {
                let fx = (px - x.0) / (x.1 - x.0);
                let fy = (py - y.0) / (y.1 - y.0);
                (if right { fx > 0.55 } else { fx < 0.45 }) && (if top { fy > 0.6 } else { fy < 0.4 })
            })
            .count()
    };
    let corners = [
        (count(true, true), SeriesLabelPosition::UpperRight),
        (count(false, true), SeriesLabelPosition::UpperLeft),
        (count(true, false), SeriesLabelPosition::LowerRight),
        (count(false, false), SeriesLabelPosition::LowerLeft),
    ];
    corners
        .into_iter()
        .min_by_key(|c| c.0)
        .map(|c| c.1)
        .unwrap_or(SeriesLabelPosition::UpperRight)
}

const TITLE_SIZE: u32 = 20;
const LABEL_SIZE: u32 = 15;

impl XyPlot {
    pub fn render(&self) -> String {
        svg(|root| self.draw(root))
    }

    fn draw(&self, root: &DrawingArea<SVGBackend, Shift>) -> Result<()> {
        let (x, y) = self.ranges();
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, ("sans-serif", TITLE_SIZE))
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(72)
            .build_cartesian_2d(x.0..x.1, y.0..y.1)?;
        let xfmt = |v: &f64| tick_on(*v, x.1 - x.0);
        let yfmt = |v: &f64| tick_on(*v, y.1 - y.0);
        chart
            .configure_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .x_labels(7)
            .y_labels(7)
            .x_label_formatter(&xfmt)
            .y_label_formatter(&yfmt)
            .light_line_style(RGBColor(238, 238, 238))
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", LABEL_SIZE))
            .draw()?;
        let mut legend = false;
        let all: Vec<(f64, f64)> = self.series.iter().flat_map(|s| s.points.iter().copied()).collect();
        let corner = legend_corner(&all, x, y);
        for band in &self.bands {
            // Pale yellow: grey lines (simulated runs) stay visible over it.
            let style = RGBColor(230, 159, 0).mix(0.12).filled();
            let a = chart.draw_series([Rectangle::new([(band.x0, y.0), (band.x1, y.1)], style)])?;
            if !band.label.is_empty() {
                legend = true;
                a.label(&band.label)
                    .legend(move |(px, py)| Rectangle::new([(px, py - 5), (px + 16, py + 5)], style));
            }
        }
        if let Some(h) = self.hline {
            chart.draw_series(LineSeries::new(
                [(x.0, h), (x.1, h)],
                RGBColor(150, 150, 150).stroke_width(1),
            ))?;
        }
        for v in &self.vlines {
            let c = color(v.color);
            let a = chart.draw_series(DashedLineSeries::new([(v.x, y.0), (v.x, y.1)], 6, 4, c.stroke_width(2)))?;
            if !v.label.is_empty() {
                legend = true;
                a.label(&v.label)
                    .legend(move |(px, py)| PathElement::new([(px, py), (px + 16, py)], c.stroke_width(2)));
            }
        }
        if self.draw_data(&mut chart)? {
            legend = true;
        }
        if legend {
            draw_legend(&mut chart, corner)?;
        }
        Ok(())
    }

    /// The axes' ranges: every point (with its error bar), band and line, padded; the y range
    /// starts at `y_floor` when everything is above it, and leaves `legend_room` on top.
    fn ranges(&self) -> ((f64, f64), (f64, f64)) {
        let xs = self.series.iter().flat_map(|s| s.points.iter().map(|p| p.0));
        let xs = xs
            .chain(self.bands.iter().flat_map(|b| [b.x0, b.x1]))
            .chain(self.vlines.iter().map(|v| v.x));
        let x = range(xs, 0.04);
        let ys = self.series.iter().flat_map(|s| {
            s.points.iter().enumerate().flat_map(move |(i, p)| {
                let e = s.y_err.as_ref().and_then(|e| e.get(i)).copied().unwrap_or(0.0);
                [p.1 - e, p.1 + e]
            })
        });
        let y = range(ys.clone().chain(self.hline), 0.08);
        let y = match self.y_floor {
            Some(floor) if ys.chain(self.hline).all(|v| !v.is_finite() || v >= floor) && floor < y.1 => (floor, y.1),
            _ => y,
        };
        (x, (y.0, y.1 + self.legend_room * (y.1 - y.0)))
    }

    /// Draws the series (error bars, then lines or markers) with their legend entries; returns
    /// whether any has a label.
    fn draw_data<'a>(&self, chart: &mut XyChart<'a>) -> Result<bool> {
        let mut legend = false;
        for s in &self.series {
            let c = color(s.color);
            if let Some(errs) = &s.y_err {
                chart.draw_series(
                    s.points
                        .iter()
                        .zip(errs)
                        .filter(|(_, e)| **e > 0.0)
                        .map(|(&(px, py), &e)| ErrorBar::new_vertical(px, py - e, py, py + e, c.stroke_width(1), 8)),
                )?;
            }
            let pts = s.points.iter().copied();
            let a = match s.style {
                Style::Line => chart.draw_series(LineSeries::new(pts, c.stroke_width(2)))?,
                Style::Thin => chart.draw_series(LineSeries::new(pts, c.mix(0.7).stroke_width(1)))?,
                Style::Dashed => chart.draw_series(DashedLineSeries::new(pts, 8, 5, c.stroke_width(2)))?,
                Style::Markers => chart.draw_series(pts.map(|p| Circle::new(p, 4, c.filled())))?,
                Style::Hollow => chart.draw_series(pts.map(|p| Circle::new(p, 5, c.stroke_width(2))))?,
                Style::LineMarkers => {
                    chart.draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))?;
                    chart.draw_series(pts.map(|p| Circle::new(p, 3, c.filled())))?
                }
            };
            if !s.label.is_empty() {
                legend = true;
                let style = s.style;
                a.label(&s.label)
                    .legend(move |(px, py)| -> DynElement<'static, SVGBackend, (i32, i32)> {
                        match style {
                            Style::Markers => Circle::new((px + 8, py), 4, c.filled()).into_dyn(),
                            Style::Hollow => Circle::new((px + 8, py), 5, c.stroke_width(2)).into_dyn(),
                            _ => PathElement::new([(px, py), (px + 16, py)], c.stroke_width(2)).into_dyn(),
                        }
                    });
            }
        }
        Ok(legend)
    }
}

/// The chart an [`XyPlot`] draws on.
type XyChart<'a> = ChartContext<
    'a,
    SVGBackend<'a>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// The legend every plot draws: framed, translucent over the data, 13 px text.
fn draw_legend<'a, CT: plotters::coord::CoordTranslate>(
    chart: &mut ChartContext<'a, SVGBackend<'a>, CT>,
    corner: SeriesLabelPosition,
) -> Result<()> {
    chart
        .configure_series_labels()
        .position(corner)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(200, 200, 200))
        .label_font(("sans-serif", 13))
        .draw()?;
    Ok(())
}

/// A histogram of `samples` (density, `bins` equal bins) with shaded `band` and marked values.
pub fn histogram(
    title: &str,
    x_label: &str,
    y_label: &str,
    samples: &[f64],
    bins: usize,
    band: Option<Band>,
    marks: &[VLine],
) -> String {
    let finite: Vec<f64> = samples.iter().copied().filter(|v| v.is_finite()).collect();
    let (lo, hi) = range(finite.iter().copied(), 0.0);
    let bins = bins.max(1);
    let width = (hi - lo) / bins as f64;
    let mut counts = vec![0usize; bins];
    for v in &finite {
        counts[(((v - lo) / width) as usize).min(bins - 1)] += 1;
    }
    let n = finite.len().max(1) as f64;
    let density: Vec<f64> = counts.iter().map(|&c| c as f64 / (n * width)).collect();
    let top = density.iter().copied().fold(0.0, f64::max).max(f64::MIN_POSITIVE) * 1.12;
    let xs = [lo, hi]
        .into_iter()
        .chain(marks.iter().map(|m| m.x))
        .chain(band.iter().flat_map(|b| [b.x0, b.x1]));
    let x = range(xs, 0.04);
    svg(|root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, ("sans-serif", TITLE_SIZE))
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(72)
            .build_cartesian_2d(x.0..x.1, 0.0..top)?;
        let fmt = |v: &f64| tick(*v);
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .x_labels(6)
            .x_label_formatter(&fmt)
            .y_label_formatter(&fmt)
            .light_line_style(RGBColor(238, 238, 238))
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", LABEL_SIZE))
            .draw()?;
        draw_interval(&mut chart, band.as_ref(), (0.0, top))?;
        let bar = RGBColor(120, 120, 120);
        chart
            .draw_series(density.iter().enumerate().map(|(i, &d)| {
                let x0 = lo + i as f64 * width;
                Rectangle::new([(x0, 0.0), (x0 + width, d)], bar.mix(0.55).filled())
            }))?
            .label(format!("posterior samples ({})", finite.len()))
            .legend(move |(px, py)| Rectangle::new([(px, py - 5), (px + 16, py + 5)], bar.mix(0.55).filled()));
        draw_marks(&mut chart, marks, (0.0, top))?;
        // The legend goes where the histogram is lowest: left or right of the bulk.
        let left_mass: usize = counts[..bins / 2].iter().sum();
        let corner = if 2 * left_mass > finite.len() {
            SeriesLabelPosition::UpperRight
        } else {
            SeriesLabelPosition::UpperLeft
        };
        draw_legend(&mut chart, corner)?;
        Ok(())
    })
}

/// A posterior's shaded 95 % interval over the full height `y`, with its legend entry.
fn draw_interval(chart: &mut XyChart<'_>, band: Option<&Band>, y: (f64, f64)) -> Result<()> {
    if let Some(b) = band {
        let style = RGBColor(0, 158, 115).mix(0.15).filled();
        chart
            .draw_series([Rectangle::new([(b.x0, y.0), (b.x1, y.1)], style)])?
            .label(&b.label)
            .legend(move |(px, py)| Rectangle::new([(px, py - 5), (px + 16, py + 5)], style));
    }
    Ok(())
}

/// Marked values as dashed vertical lines over the height `y`, each with its legend entry.
fn draw_marks(chart: &mut XyChart<'_>, marks: &[VLine], y: (f64, f64)) -> Result<()> {
    for m in marks {
        let c = color(m.color);
        chart
            .draw_series(DashedLineSeries::new([(m.x, y.0), (m.x, y.1)], 6, 4, c.stroke_width(2)))?
            .label(&m.label)
            .legend(move |(px, py)| PathElement::new([(px, py), (px + 16, py)], c.stroke_width(2)));
    }
    Ok(())
}

/// Peak-to-median ratio of a density curve above which [`density_curve`] draws a log axis: a
/// posterior with a cusp (two tests pin θ when the discrepancy is small) is a needle on a linear axis.
const LOG_DENSITY_RATIO: f64 = 30.0;

/// A density curve (`points` = x values and densities, e.g. a posterior by quadrature) with shaded
/// `band` and marked values; the density axis is logarithmic when the curve's peak is more than
/// [`LOG_DENSITY_RATIO`] times its median.
pub fn density_curve(
    title: &str,
    x_label: &str,
    y_label: &str,
    points: (&[f64], &[f64]),
    band: Option<Band>,
    marks: &[VLine],
) -> String {
    let (xs, ys) = points;
    let peak = ys.iter().copied().fold(0.0, f64::max).max(f64::MIN_POSITIVE);
    let mut sorted: Vec<f64> = ys.to_vec();
    sorted.sort_by(f64::total_cmp);
    let median = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
    let log = peak > LOG_DENSITY_RATIO * median;
    // On a log axis the curve is drawn as log10(density) down to 1e-4 of the peak.
    let floor = peak * 1e-4;
    let map = |d: f64| if log { d.max(floor).log10() } else { d };
    let (y0, y1) = if log {
        (floor.log10(), peak.log10() + 0.3)
    } else {
        (0.0, peak * 1.12)
    };
    let xr = xs
        .iter()
        .copied()
        .chain(marks.iter().map(|m| m.x))
        .chain(band.iter().flat_map(|b| [b.x0, b.x1]));
    let x = range(xr, 0.02);
    svg(|root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, ("sans-serif", TITLE_SIZE))
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(72)
            .build_cartesian_2d(x.0..x.1, y0..y1)?;
        let fmt = |v: &f64| tick(*v);
        let yfmt = |v: &f64| if log { tick(10f64.powf(*v)) } else { tick(*v) };
        let y_desc = if log {
            format!("{y_label}, log scale")
        } else {
            y_label.to_string()
        };
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_desc)
            .x_labels(6)
            .x_label_formatter(&fmt)
            .y_label_formatter(&yfmt)
            .light_line_style(RGBColor(238, 238, 238))
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", LABEL_SIZE))
            .draw()?;
        draw_interval(&mut chart, band.as_ref(), (y0, y1))?;
        let line = RGBColor(60, 60, 60);
        chart
            .draw_series(LineSeries::new(
                xs.iter().zip(ys).map(|(&x, &d)| (x, map(d))),
                line.stroke_width(2),
            ))?
            .label("posterior density (quadrature)")
            .legend(move |(px, py)| PathElement::new([(px, py), (px + 16, py)], line.stroke_width(2)));
        draw_marks(&mut chart, marks, (y0, y1))?;
        draw_legend(&mut chart, SeriesLabelPosition::UpperRight)?;
        Ok(())
    })
}

/// Horizontal grouped bars: one row per category, one bar per group (a `None` value draws nothing).
#[derive(Debug, Clone, Default)]
pub struct BarPlot {
    pub title: String,
    /// The value axis, with its unit.
    pub value_label: String,
    pub categories: Vec<String>,
    /// (group label, colour, one value per category).
    pub groups: Vec<(String, usize, Vec<Option<f64>>)>,
    /// Value axis formatter: percent when true.
    pub percent: bool,
    /// Categories drawn as a heading row across the plot (bold, no bars) instead of an axis label.
    pub headings: Vec<usize>,
}

impl BarPlot {
    /// The right-hand corner beside the shorter bars: lower right unless the bottom third's longest
    /// bar is longer than the top third's.
    fn legend_corner(&self) -> SeriesLabelPosition {
        let n = self.categories.len();
        let third = n.div_ceil(3).max(1);
        let longest = |rows: std::ops::Range<usize>| {
            let values = self
                .groups
                .iter()
                .flat_map(|g| rows.clone().filter_map(|i| g.2.get(i).copied().flatten()));
            values.fold(0.0_f64, f64::max)
        };
        if longest(n.saturating_sub(third)..n) > longest(0..third.min(n)) {
            SeriesLabelPosition::UpperRight
        } else {
            SeriesLabelPosition::LowerRight
        }
    }

    pub fn render(&self) -> String {
        // Rows keep a readable height: the plot grows beyond the standard size when there are many.
        let rows = self.categories.len() as u32;
        svg_sized((WIDTH, HEIGHT.max(110 + 28 * rows)), |root| self.draw(root))
    }

    fn draw(&self, root: &DrawingArea<SVGBackend, Shift>) -> Result<()> {
        let n = self.categories.len().max(1);
        let max = self.value_end();
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, ("sans-serif", TITLE_SIZE))
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size((self.longest_label() * 8 + 16).clamp(40, 280))
            .build_cartesian_2d(0.0..max, -0.5..(n as f64 - 0.5))?;
        self.draw_axes(&mut chart, n, max)?;
        self.draw_headings(&mut chart, n)?;
        let g = self.groups.len().max(1) as f64;
        let thick = 0.8 / g;
        for k in 0..self.groups.len() {
            self.draw_group(&mut chart, k, n, thick, max)?;
        }
        if self.groups.iter().any(|g| !g.0.is_empty()) {
            draw_legend(&mut chart, self.legend_corner())?;
        }
        Ok(())
    }

    /// Whether category `i` is a heading row.
    fn heading(&self, i: usize) -> bool {
        self.headings.contains(&i)
    }

    /// The value axis's end: the largest value plus a fifth (room for the bars' labels), or 1
    /// when there is no positive value.
    fn value_end(&self) -> f64 {
        let values = self.groups.iter().flat_map(|g| g.2.iter().flatten().copied());
        let max = values.fold(0.0_f64, |m, v| m.max(v));
        if max > 0.0 { max * 1.2 } else { 1.0 }
    }

    /// The longest category name that labels the axis (headings do not), in characters; 4 when
    /// there is none.
    fn longest_label(&self) -> u32 {
        (self.categories.iter().enumerate())
            .filter(|(i, _)| !self.heading(*i))
            .map(|(_, c)| c.chars().count())
            .max()
            .unwrap_or(4) as u32
    }

    /// The value axis (percent or plain ticks up to `max`) and the category axis, category 0 at
    /// the top of the `n` rows and heading rows left blank.
    fn draw_axes(&self, chart: &mut XyChart<'_>, n: usize, max: f64) -> Result<()> {
        let percent = self.percent;
        let xfmt = move |v: &f64| {
            if percent {
                format!("{} %", tick_on(100.0 * v, 100.0 * max))
            } else {
                tick_on(*v, max)
            }
        };
        let cats = &self.categories;
        // Category 0 at the top.
        let yfmt = |v: &f64| {
            let i = v.round();
            if (v - i).abs() > 1e-6 || i < 0.0 {
                return String::new();
            }
            let k = n - 1 - i as usize;
            if self.heading(k) {
                return String::new();
            }
            cats.get(k).cloned().unwrap_or_default()
        };
        chart
            .configure_mesh()
            .x_desc(&self.value_label)
            .x_label_formatter(&xfmt)
            .y_label_formatter(&yfmt)
            .y_labels(n + 1)
            .disable_y_mesh()
            .light_line_style(RGBColor(238, 238, 238))
            .label_style(("sans-serif", 14))
            .axis_desc_style(("sans-serif", LABEL_SIZE))
            .draw()?;
        Ok(())
    }

    /// The heading rows' names, bold, from the left end of their rows (of `n`).
    fn draw_headings(&self, chart: &mut XyChart<'_>, n: usize) -> Result<()> {
        let titles = self.headings.iter().filter_map(|&k| {
            let text = self.categories.get(k)?;
            let row = (n - 1 - k) as f64;
            let font = ("sans-serif", 14)
                .into_font()
                .style(FontStyle::Bold)
                .color(&BLACK)
                .pos(Pos::new(HPos::Left, VPos::Center));
            Some(Text::new(text.clone(), (0.0, row), font))
        });
        chart.draw_series(titles.collect::<Vec<_>>())?;
        Ok(())
    }

    /// Group `k`'s bars (each `thick` high, in its place within the rows of `n`), its legend entry
    /// when it has a label, and each bar's value at its end (on an axis up to `max`).
    fn draw_group(&self, chart: &mut XyChart<'_>, k: usize, n: usize, thick: f64, max: f64) -> Result<()> {
        let (label, ci, vals) = &self.groups[k];
        let percent = self.percent;
        let c = color(*ci);
        let rects = vals.iter().enumerate().filter_map(|(i, v)| {
            let v = (*v)?;
            let row = (n - 1 - i) as f64;
            let top = row + 0.4 - k as f64 * thick;
            Some(Rectangle::new([(0.0, top), (v, top - thick * 0.9)], c.filled()))
        });
        let a = chart.draw_series(rects.collect::<Vec<_>>())?;
        if !label.is_empty() {
            a.label(label)
                .legend(move |(px, py)| Rectangle::new([(px, py - 5), (px + 16, py + 5)], c.filled()));
        }
        // Value at the bar's end.
        let texts = vals.iter().enumerate().filter_map(|(i, v)| {
            let v = (*v)?;
            let row = (n - 1 - i) as f64;
            let mid = row + 0.4 - (k as f64 + 0.45) * thick;
            let text = bar_text(v, percent, max);
            let v = if v.abs() < 1e-9 * max { 0.0 } else { v };
            Some(Text::new(
                text,
                (v, mid),
                ("sans-serif", 13)
                    .into_font()
                    .color(&BLACK)
                    .pos(Pos::new(HPos::Left, VPos::Center)),
            ))
        });
        chart.draw_series(texts.collect::<Vec<_>>())?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plots_are_svg_with_title_and_labels() {
        let plot = XyPlot {
            title: "t <1>".into(),
            x_label: "h (mm)".into(),
            y_label: "deflection (mm)".into(),
            series: vec![Series::new("a", 0, Style::LineMarkers, vec![(1.0, 2.0), (2.0, 3.0)])],
            ..Default::default()
        };
        let s = plot.render();
        assert!(s.starts_with("<svg"), "{s}");
        assert!(s.contains("h (mm)") && s.contains("deflection (mm)"));
        assert!(s.contains("t &lt;1&gt;"), "title escaped");
        let h = histogram("post", "E (MPa)", "density", &[1.0, 2.0, 2.5, 3.0], 5, None, &[]);
        assert!(h.starts_with("<svg") && h.contains("E (MPa)"));
        let b = BarPlot {
            title: "w".into(),
            value_label: "weight".into(),
            categories: vec!["x".into(), "y".into()],
            groups: vec![("".into(), 0, vec![Some(0.3), None])],
            percent: false,
            headings: vec![],
        };
        assert!(b.render().starts_with("<svg"));
    }

    #[test]
    fn bar_labels_keep_small_weights_visible_and_errors_short() {
        assert_eq!(bar_text(1.0, false, 1.0), "1.00");
        assert_eq!(bar_text(0.843, false, 1.0), "0.84");
        assert_eq!(bar_text(2.7e-58, false, 1.0), "< 0.01");
        assert_eq!(bar_text(0.0, false, 1.0), "0.00");
        assert_eq!(bar_text(0.1234, true, 0.2), "12 %");
        assert_eq!(bar_text(1e-14, true, 0.2), "0 %");
    }

    #[test]
    fn degenerate_data_draws() {
        let plot = XyPlot {
            title: "empty".into(),
            ..Default::default()
        };
        assert!(plot.render().starts_with("<svg"));
        assert!(histogram("one", "x", "density", &[5.0, 5.0], 10, None, &[]).starts_with("<svg"));
    }

    #[test]
    fn ticks_are_short() {
        assert_eq!(tick(60000.0), "60000");
        assert_eq!(tick(0.25), "0.25");
        assert_eq!(tick(0.0), "0");
    }
}
