//! Scatter plots for `wavetrace sweep`: one colour per series, every point drawn, the
//! Pareto front of each series filled and joined by a line. Drawn with `plotters` into an
//! RGB buffer and saved through [`crate::tools::output::write_png`], so a plot is written
//! atomically like every other output and the crate keeps a single PNG encoder.

use plotters::coord::ranged1d::{AsRangedCoord, Ranged, ValueFormatter};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;
use std::sync::OnceLock;

use crate::{Error, Result};

/// Plot size in pixels.
pub const WIDTH: u32 = 900;
/// Plot height in pixels.
pub const HEIGHT: u32 = 600;

/// Colours of the series, in order: uniform and adaptive come first in a sweep, so they
/// get the blue and orange of the usual categorical palette.
const COLORS: [RGBColor; 7] = [
    RGBColor(31, 119, 180),
    RGBColor(230, 110, 0),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
];

/// One named set of points. The i-th series of a plot gets the i-th colour.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Series {
    /// Legend label.
    pub name: String,
    /// (x, y) values.
    pub points: Vec<(f64, f64)>,
    /// Per point: on the Pareto front (drawn filled and joined by a line); see
    /// [`crate::tools::sweep::pareto_front`].
    pub pareto: Vec<bool>,
    /// Per point: a label written beside it when it is on the front (empty: none).
    pub labels: Vec<String>,
}

/// Registers the embedded DejaVu Sans as plotters' sans-serif font, once: plotters'
/// `ab_glyph` text needs a font in memory, and the machine may have no system fonts.
fn register_font() -> Result<()> {
    static LOADED: OnceLock<bool> = OnceLock::new();
    let ok = *LOADED.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular()).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(Error::Internal("the embedded DejaVu font did not load".into()))
    }
}

/// Compact tick label: plain decimals for ordinary magnitudes, `1e6` style otherwise.
fn tick(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-2..1e5).contains(&a) {
        let s = format!("{v:.1e}");
        // 1.0e6 reads better as 1e6.
        s.replace(".0e", "e")
    } else {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

/// The axis range of `values` (finite, and > 0 on a log axis), padded so no point sits
/// on the frame; (1, 10) on a log axis and (0, 1) on a linear one when nothing is left.
fn span(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite() && (!log || *v > 0.0)) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        return if log { (1.0, 10.0) } else { (0.0, 1.0) };
    }
    if log {
        // A single value, or a very narrow range, is widened so the axis has room for ticks.
        let (lo, hi) = if hi / lo < 1.5 { (lo / 1.5, hi * 1.5) } else { (lo, hi) };
        (lo / 1.3, hi * 1.3)
    } else {
        let pad = if hi > lo { 0.05 * (hi - lo) } else { 0.5 * lo.abs().max(1.0) };
        (lo - pad, hi + pad)
    }
}

/// One axis of a plot.
#[derive(Clone, Copy, Debug)]
pub struct Axis<'a> {
    /// The axis title.
    pub label: &'a str,
    /// A logarithmic scale.
    pub log: bool,
}

/// Draws a scatter plot of `series` to the PNG `path`. Log axes drop values ≤ 0 (they have
/// no place on them); non-finite values are always dropped. Each series' Pareto points
/// (`Series::pareto`) are drawn filled and joined in x order; the others are hollow.
pub fn scatter_plot(path: &Path, title: &str, x: Axis, y: Axis, series: &[Series]) -> Result<()> {
    let (x_label, log_x, y_label, log_y) = (x.label, x.log, y.label, y.log);
    crate::tools::output::check_png_path(path)?;
    register_font()?;
    let (w, h) = (WIDTH, HEIGHT);
    let mut buf = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        let keep = |x: f64, y: f64| x.is_finite() && y.is_finite() && (!log_x || x > 0.0) && (!log_y || y > 0.0);
        let all = || series.iter().flat_map(|s| s.points.iter().copied()).filter(|&(x, y)| keep(x, y));
        let (x0, x1) = span(all().map(|p| p.0), log_x);
        let (y0, y1) = span(all().map(|p| p.1), log_y);
        // Labels of points in the right third go to their left, so they stay inside.
        let frac = |v: f64, lo: f64, hi: f64, log: bool| {
            if log {
                (v / lo).ln() / (hi / lo).ln()
            } else {
                (v - lo) / (hi - lo)
            }
        };
        let flip_label = |x: f64| frac(x, x0, x1, log_x) > 0.66;
        let labels = Labels { title, x: x_label, y: y_label, flip: &flip_label };
        let log_axis = |lo: f64, hi: f64| {
            let (major, minor) = log_ticks(lo, hi);
            (lo..hi).log_scale().with_key_points(major).with_light_points(minor)
        };
        let drawn = match (log_x, log_y) {
            (false, false) => draw(&root, &labels, series, &keep, x0..x1, y0..y1),
            (true, false) => draw(&root, &labels, series, &keep, log_axis(x0, x1), y0..y1),
            (false, true) => draw(&root, &labels, series, &keep, x0..x1, log_axis(y0, y1)),
            (true, true) => draw(&root, &labels, series, &keep, log_axis(x0, x1), log_axis(y0, y1)),
        };
        drawn
            .and_then(|_| root.present().map_err(|e| e.to_string()))
            .map_err(|e| Error::Internal(format!("plot `{}`: {e}", path.display())))?;
    }
    crate::tools::output::write_png(path, w, h, &buf)
}

/// Tick values of a log axis over [lo, hi]: labelled ones at 1, 2 and 5 times powers of
/// ten (every integer multiple when that gives fewer than three), and grid lines at every
/// integer multiple. Plotters' own log ticks leave a narrow range almost unlabelled.
fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    let mut all = Vec::new();
    let mut decade = 10f64.powi(lo.log10().floor() as i32);
    while decade <= hi {
        for m in 1..10 {
            let v = m as f64 * decade;
            if v >= lo && v <= hi {
                all.push(v);
            }
        }
        decade *= 10.0;
    }
    let major: Vec<f64> = all
        .iter()
        .copied()
        .filter(|v| {
            let m = (v / 10f64.powi(v.log10().floor() as i32)).round();
            m == 1.0 || m == 2.0 || m == 5.0
        })
        .collect();
    if major.len() < 3 {
        (all.clone(), all)
    } else {
        (major, all)
    }
}

/// The texts of a plot.
struct Labels<'a> {
    title: &'a str,
    x: &'a str,
    y: &'a str,
    /// Whether a point's label goes to its left.
    flip: &'a dyn Fn(f64) -> bool,
}

/// A point as drawn: x, y, whether it is on its series' Pareto front, and its label.
type Dot<'a> = (f64, f64, bool, &'a str);

/// The chart of one plot, with the axis kinds still open (linear or log).
type Chart<'a, 'b, X, Y> = ChartContext<'a, BitMapBackend<'b>, Cartesian2d<X, Y>>;

/// Draws the chart on `root`; generic over the axis kinds (linear or log).
fn draw<X, Y>(
    root: &DrawingArea<BitMapBackend, Shift>,
    labels: &Labels,
    series: &[Series],
    keep: &dyn Fn(f64, f64) -> bool,
    x_spec: X,
    y_spec: Y,
) -> std::result::Result<(), String>
where
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let mut chart = ChartBuilder::on(root)
        .caption(labels.title, ("sans-serif", 22))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(80)
        .build_cartesian_2d(x_spec, y_spec)
        .map_err(|e| e.to_string())?;
    draw_mesh(&mut chart, labels)?;

    // Pixel boxes of the labels drawn so far, over all series: a label that would overlap
    // one is left out (its point stays filled; the CSV has every value).
    let mut taken: Vec<(i32, i32, i32, i32)> = Vec::new();
    for (i, s) in series.iter().enumerate() {
        // Colours go by position, so a caller can keep a series' colour fixed across plots
        // by passing an empty series in its place; an empty one has no legend entry.
        let color = COLORS[i % COLORS.len()];
        if s.points.is_empty() {
            continue;
        }
        let dots = kept_dots(s, keep);
        draw_dots(&mut chart, &dots, color, &s.name)?;
        draw_labels(&mut chart, root, labels.flip, &front_labels(&dots), color, &mut taken)?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font(("sans-serif", 15))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| e.to_string())?;
    Ok(())
}

/// Draws the axes, their titles and tick labels, and the grid.
fn draw_mesh<X, Y>(chart: &mut Chart<X, Y>, labels: &Labels) -> std::result::Result<(), String>
where
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    chart
        .configure_mesh()
        .x_desc(labels.x)
        .y_desc(labels.y)
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 16))
        .light_line_style(RGBColor(235, 235, 235))
        .bold_line_style(RGBColor(205, 205, 205))
        .draw()
        .map_err(|e| e.to_string())
}

/// The series' points that have a place on the axes, with their front flag and label.
fn kept_dots<'a>(s: &'a Series, keep: &dyn Fn(f64, f64) -> bool) -> Vec<Dot<'a>> {
    s.points
        .iter()
        .enumerate()
        .filter(|(_, &(x, y))| keep(x, y))
        .map(|(k, &(x, y))| {
            (x, y, s.pareto.get(k).copied().unwrap_or(false), s.labels.get(k).map_or("", String::as_str))
        })
        .collect()
}

/// Draws one series: its front joined in x order, front points filled and the others
/// hollow, and its legend entry.
fn draw_dots<X, Y>(
    chart: &mut Chart<X, Y>,
    dots: &[Dot],
    color: RGBColor,
    name: &str,
) -> std::result::Result<(), String>
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let mut front: Vec<(f64, f64)> = dots.iter().filter(|p| p.2).map(|p| (p.0, p.1)).collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0).then(b.1.total_cmp(&a.1)));
    chart.draw_series(LineSeries::new(front, color.stroke_width(2))).map_err(|e| e.to_string())?;
    chart
        .draw_series(dots.iter().map(|&(x, y, on_front, _)| {
            let style = if on_front { color.filled() } else { color.stroke_width(2) };
            Circle::new((x, y), 5, style)
        }))
        .map_err(|e| e.to_string())?
        .label(name)
        .legend(move |(x, y)| Circle::new((x + 10, y), 5, color.filled()));
    Ok(())
}

/// The labels of the front points: points at the same place get one label; when their
/// labels differ, the count of the others hidden under it comes with it.
fn front_labels<'a>(dots: &[Dot<'a>]) -> Vec<(f64, f64, &'a str, usize)> {
    let mut labelled: Vec<(f64, f64, &str, usize)> = Vec::new();
    for &(x, y, on_front, text) in dots {
        if !on_front || text.is_empty() {
            continue;
        }
        match labelled.iter_mut().find(|l| l.0 == x && l.1 == y) {
            Some(l) if l.2 != text => l.3 += 1,
            Some(_) => {}
            None => labelled.push((x, y, text, 0)),
        }
    }
    labelled
}

/// Writes the front labels of one series beside their points (to the left where `flip`
/// says so), leaving out each one that would overlap a box in `taken`, and adds the boxes
/// of those written to `taken`.
fn draw_labels<X, Y>(
    chart: &mut Chart<X, Y>,
    root: &DrawingArea<BitMapBackend, Shift>,
    flip: &dyn Fn(f64) -> bool,
    labelled: &[(f64, f64, &str, usize)],
    color: RGBColor,
    taken: &mut Vec<(i32, i32, i32, i32)>,
) -> std::result::Result<(), String>
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let style = ("sans-serif", 12).into_font().color(&color);
    let left = style.pos(Pos::new(HPos::Right, VPos::Center));
    let right = style.pos(Pos::new(HPos::Left, VPos::Center));
    let mut texts = Vec::new();
    for &(x, y, text, more) in labelled {
        let text = if more > 0 { format!("{text} (+{more} more)") } else { text.to_string() };
        let (tw, th) = root.estimate_text_size(&text, &style).map_err(|e| e.to_string())?;
        let (tw, th) = (tw as i32, th as i32);
        let (px, py) = chart.backend_coord(&(x, y));
        let flip = flip(x);
        let x0 = if flip { px - 9 - tw } else { px + 9 };
        let b = (x0, py - th / 2, x0 + tw, py + th / 2);
        if taken.iter().any(|t| b.0 < t.2 && t.0 < b.2 && b.1 < t.3 && t.1 < b.3) {
            continue;
        }
        taken.push(b);
        let (dx, style) = if flip { (-9, left.clone()) } else { (9, right.clone()) };
        texts.push(EmptyElement::at((x, y)) + Text::new(text, (dx, 0), style));
    }
    chart.draw_series(texts).map_err(|e| e.to_string())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_compact() {
        assert_eq!(tick(1e6), "1e6");
        assert_eq!(tick(2.5e-4), "2.5e-4");
        assert_eq!(tick(0.25), "0.25");
        assert_eq!(tick(100.0), "100");
    }
}
