//! Line charts: several `y(x)` series with point markers, a legend and labelled axes.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use super::style::{self, FONT};
use super::thin::thin;
use super::{draw_err, PlotError};

/// Size of a rendered chart in pixels.
pub const CHART_SIZE: (u32, u32) = (800, 500);

/// One named curve: `y[i]` against `x[i]`, with optional error bars.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    pub name: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    /// Half-lengths of the horizontal and vertical error bars at each point (a standard
    /// deviation, say), or empty for none; a non-finite or negative value draws no bar.
    pub x_err: Vec<f64>,
    pub y_err: Vec<f64>,
}

/// A chart of one or more series drawn as lines with point markers.
///
/// Axis labels are free text and carry their units, e.g.
/// `"axial stress σzz [MPa]"`. Ranges are chosen from the data with a small
/// margin; points with a non-finite coordinate (or one beyond ±1e300) are
/// skipped and break the line.
#[derive(Debug, Clone, PartialEq)]
pub struct LineChart {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
}

/// Points of one series that a chart leaves out (see [`LineChart::gaps`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Gap {
    pub series: String,
    /// How many points are left out.
    pub count: usize,
    /// The first one's index and coordinates.
    pub first: usize,
    pub x: f64,
    pub y: f64,
}

/// A series ready to draw: unbroken runs of finite points, and the error bars as segments.
struct Prepared<'a> {
    name: &'a str,
    runs: Vec<Vec<(f64, f64)>>,
    bars: Vec<[(f64, f64); 2]>,
}

impl LineChart {
    pub fn new(title: impl Into<String>, x_label: impl Into<String>, y_label: impl Into<String>) -> Self {
        LineChart { title: title.into(), x_label: x_label.into(), y_label: y_label.into(), series: Vec::new() }
    }

    /// Appends a series. Lengths are checked when the chart is rendered.
    pub fn add_series(&mut self, name: impl Into<String>, x: impl Into<Vec<f64>>, y: impl Into<Vec<f64>>) -> &mut Self {
        self.series.push(Series { name: name.into(), x: x.into(), y: y.into(), x_err: Vec::new(), y_err: Vec::new() });
        self
    }

    /// Appends a series with error bars: `x_err[i]` and `y_err[i]` are the half-lengths of
    /// the bars at point i (either may be empty for none). Lengths are checked when the
    /// chart is rendered.
    pub fn add_series_with_errors(
        &mut self,
        name: impl Into<String>,
        x: impl Into<Vec<f64>>,
        y: impl Into<Vec<f64>>,
        x_err: impl Into<Vec<f64>>,
        y_err: impl Into<Vec<f64>>,
    ) -> &mut Self {
        let (x, y, x_err, y_err) = (x.into(), y.into(), x_err.into(), y_err.into());
        self.series.push(Series { name: name.into(), x, y, x_err, y_err });
        self
    }

    /// Renders the chart as an SVG document.
    pub fn render_svg(&self) -> Result<String, PlotError> {
        self.render_svg_until(&|| false)
    }

    /// [`LineChart::render_svg`] that gives up soon after `cancelled()` turns true.
    pub fn render_svg_until(&self, cancelled: &dyn Fn() -> bool) -> Result<String, PlotError> {
        style::ensure_fonts()?;
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, CHART_SIZE).into_drawing_area();
            self.draw(&root, true, cancelled)?;
            root.present().map_err(draw_err)?;
        }
        Ok(svg)
    }

    /// Renders the chart as PNG-encoded bytes.
    pub fn render_png(&self) -> Result<Vec<u8>, PlotError> {
        self.render_png_until(&|| false)
    }

    /// [`LineChart::render_png`] that gives up soon after `cancelled()` turns true.
    pub fn render_png_until(&self, cancelled: &dyn Fn() -> bool) -> Result<Vec<u8>, PlotError> {
        style::ensure_fonts()?;
        let (w, h) = CHART_SIZE;
        let mut rgb = vec![0u8; w as usize * h as usize * 3];
        {
            let root = BitMapBackend::with_buffer(&mut rgb, CHART_SIZE).into_drawing_area();
            self.draw(&root, false, cancelled)?;
            root.present().map_err(draw_err)?;
        }
        super::encode_png(&rgb, w, h)
    }

    /// Writes the chart to `path`: `.svg` or `.png` by extension, or both
    /// `<path>.svg` and `<path>.png` when `path` has no extension. Returns the
    /// files written.
    pub fn save(&self, path: &Path) -> Result<Vec<PathBuf>, PlotError> {
        self.save_until(path, &|| false)
    }

    /// [`LineChart::save`] that gives up (writing nothing more) soon after `cancelled()`
    /// turns true.
    pub fn save_until(&self, path: &Path, cancelled: &dyn Fn() -> bool) -> Result<Vec<PathBuf>, PlotError> {
        super::save_figure(path, || self.render_svg_until(cancelled), || self.render_png_until(cancelled))
    }

    /// The points of each series that cannot be drawn (NaN, ±inf or beyond ±1e300), which
    /// [`LineChart::save`] leaves out: one entry per series that has any, in series order.
    pub fn gaps(&self) -> Vec<Gap> {
        self.series
            .iter()
            .filter_map(|s| {
                let bad: Vec<usize> = (0..s.x.len().min(s.y.len()))
                    .filter(|&i| !(style::plottable(s.x[i]) && style::plottable(s.y[i])))
                    .collect();
                let &first = bad.first()?;
                Some(Gap { series: s.name.clone(), count: bad.len(), first, x: s.x[first], y: s.y[first] })
            })
            .collect()
    }

    /// Checks the data and splits each series into runs of finite points.
    fn prepare(&self) -> Result<Vec<Prepared<'_>>, PlotError> {
        if self.series.is_empty() {
            return Err(PlotError::Empty { figure: self.title.clone(), reason: "the chart has no series".into() });
        }
        self.series
            .iter()
            .map(|s| {
                if s.x.len() != s.y.len() {
                    return Err(PlotError::LengthMismatch {
                        series: s.name.clone(),
                        detail: format!("x has {} values, y has {}", s.x.len(), s.y.len()),
                    });
                }
                for (what, err) in [("x_err", &s.x_err), ("y_err", &s.y_err)] {
                    if !err.is_empty() && err.len() != s.x.len() {
                        return Err(PlotError::LengthMismatch {
                            series: s.name.clone(),
                            detail: format!("{what} has {} values, the points {}", err.len(), s.x.len()),
                        });
                    }
                }
                let mut bars = Vec::new();
                for (i, (&x, &y)) in s.x.iter().zip(&s.y).enumerate() {
                    let usable = |e: Option<&f64>| e.copied().filter(|e| e.is_finite() && *e > 0.0);
                    if !(style::plottable(x) && style::plottable(y)) {
                        continue;
                    }
                    if let Some(e) =
                        usable(s.x_err.get(i)).filter(|e| style::plottable(x - e) && style::plottable(x + e))
                    {
                        bars.push([(x - e, y), (x + e, y)]);
                    }
                    if let Some(e) =
                        usable(s.y_err.get(i)).filter(|e| style::plottable(y - e) && style::plottable(y + e))
                    {
                        bars.push([(x, y - e), (x, y + e)]);
                    }
                }
                let mut runs: Vec<Vec<(f64, f64)>> = Vec::new();
                let mut current = Vec::new();
                for (&x, &y) in s.x.iter().zip(&s.y) {
                    if style::plottable(x) && style::plottable(y) {
                        current.push((x, y));
                    } else if !current.is_empty() {
                        runs.push(std::mem::take(&mut current));
                    }
                }
                if !current.is_empty() {
                    runs.push(current);
                }
                if runs.is_empty() {
                    return Err(PlotError::EmptySeries { series: s.name.clone() });
                }
                Ok(Prepared { name: &s.name, runs, bars })
            })
            .collect()
    }

    /// Draws the chart; `vector` selects markers suited to SVG over raster output. Long
    /// series are thinned to what the pixels show (see [`super::thin`]).
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        vector: bool,
        cancelled: &dyn Fn() -> bool,
    ) -> Result<(), PlotError> {
        let mut prepared = self.prepare()?;

        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        let bar_ends = prepared.iter().flat_map(|p| p.bars.iter().flatten());
        for &(x, y) in prepared.iter().flat_map(|p| p.runs.iter().flatten()).chain(bar_ends) {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
        let (x0, x1) = style::padded_range(x0, x1, 0.04);
        let (y0, y1) = style::padded_range(y0, y1, 0.06);
        let fmt_x = style::tick_formatter(x0, x1);
        let fmt_y = style::tick_formatter(y0, y1);
        let y_area = style::y_label_area_width(&style::sample_labels(&fmt_y, y0, y1));

        root.fill(&WHITE).map_err(draw_err)?;
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, (FONT, style::title_size(root, &self.title)))
            .margin(style::MARGIN)
            .margin_right(style::MARGIN + 10)
            .x_label_area_size(style::X_LABEL_AREA)
            .y_label_area_size(y_area)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(draw_err)?;

        chart
            .configure_mesh()
            .x_desc(self.x_label.as_str())
            .y_desc(self.y_label.as_str())
            .x_label_formatter(&fmt_x)
            .y_label_formatter(&fmt_y)
            .x_labels(9)
            .y_labels(8)
            .label_style((FONT, style::TICK_SIZE))
            .axis_desc_style((FONT, style::LABEL_SIZE))
            .bold_line_style(BLACK.mix(0.12))
            .light_line_style(BLACK.mix(0.04))
            .draw()
            .map_err(draw_err)?;

        // Markers shrink as series get dense, where they would merge into a band.
        let most_points = prepared.iter().map(|p| p.runs.iter().map(Vec::len).sum::<usize>()).max().unwrap_or(0);
        let marker: u32 = match most_points {
            0..=200 => 3,
            201..=1000 => 2,
            _ => 1,
        };
        let columns = chart.plotting_area().dim_in_pixel().0 as usize;
        for p in &mut prepared {
            if cancelled() {
                return Err(PlotError::Cancelled);
            }
            for run in &mut p.runs {
                *run = thin(run, (x0, x1), columns);
            }
            // Error bars are drawn one by one: past a few a pixel column, every k-th.
            let k = p.bars.len().div_ceil(4 * columns.max(1)).max(1);
            if k > 1 {
                p.bars = p.bars.iter().step_by(k).copied().collect();
            }
        }

        let mut labelled = 0;
        for (i, p) in prepared.iter().enumerate() {
            let colour = style::categorical(i);
            // Error bars first, so the markers sit on top; a short cap at each end.
            for bar in &p.bars {
                chart
                    .draw_series(std::iter::once(PathElement::new(bar.to_vec(), colour.stroke_width(1))))
                    .map_err(draw_err)?;
                let vertical = bar[0].0 == bar[1].0;
                for end in bar {
                    let (px, py) = chart.backend_coord(end);
                    let cap = if vertical { [(px - 4, py), (px + 4, py)] } else { [(px, py - 4), (px, py + 4)] };
                    let area = chart.plotting_area().strip_coord_spec();
                    let (bx, by) = area.get_base_pixel();
                    area.draw(&PathElement::new(
                        cap.iter().map(|&(x, y)| (x - bx, y - by)).collect::<Vec<_>>(),
                        colour.stroke_width(1),
                    ))
                    .map_err(draw_err)?;
                }
            }
            for (k, run) in p.runs.iter().enumerate() {
                if cancelled() {
                    return Err(PlotError::Cancelled);
                }
                let drawn = chart
                    .draw_series(LineSeries::new(run.iter().copied(), colour.stroke_width(2)))
                    .map_err(draw_err)?;
                if k == 0 && !p.name.is_empty() {
                    labelled += 1;
                    drawn.label(p.name).legend(move |(x, y)| {
                        EmptyElement::at((x, y))
                            + PathElement::new(vec![(-10, 0), (10, 0)], colour.stroke_width(2))
                            + Circle::new((0, 0), marker, colour.filled())
                    });
                }
                if vector {
                    chart
                        .draw_series(run.iter().map(|&pt| Circle::new(pt, marker, colour.filled())))
                        .map_err(draw_err)?;
                } else {
                    let area = chart.plotting_area().strip_coord_spec();
                    let (bx, by) = area.get_base_pixel();
                    for pt in run {
                        let (x, y) = chart.backend_coord(pt);
                        style::draw_dot(&area, (x - bx, y - by), f64::from(marker) + 0.3, colour)?;
                    }
                }
            }
        }

        if labelled > 0 {
            let (pw, ph) = chart.plotting_area().dim_in_pixel();
            let longest = prepared.iter().map(|p| p.name.chars().count()).max().unwrap_or(0);
            // Legend box as a fraction of the plotting area.
            let box_w = (longest as f64 * f64::from(style::LEGEND_SIZE) * 0.6 + 50.0) / f64::from(pw);
            let box_h = (labelled as f64 * (f64::from(style::LEGEND_SIZE) + 8.0) + 16.0) / f64::from(ph);
            let position = quietest_corner(&prepared, (x0, x1), (y0, y1), (box_w, box_h));
            chart
                .configure_series_labels()
                .position(position)
                .margin(10)
                .label_font((FONT, style::LEGEND_SIZE))
                .background_style(WHITE.mix(0.9))
                .border_style(BLACK.mix(0.4))
                .draw()
                .map_err(draw_err)?;
        }
        Ok(())
    }
}

/// The corner of the plot where a legend of `size` (fractions of the plot)
/// covers the fewest data points and line samples; upper right on ties.
fn quietest_corner(
    prepared: &[Prepared<'_>],
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
    (w, h): (f64, f64),
) -> SeriesLabelPosition {
    // Corners in order of preference: (fx at right?, fy at top?).
    let corners = [
        (true, true, SeriesLabelPosition::UpperRight),
        (false, true, SeriesLabelPosition::UpperLeft),
        (true, false, SeriesLabelPosition::LowerRight),
        (false, false, SeriesLabelPosition::LowerLeft),
    ];
    let mut counts = [0usize; 4];
    let mut visit = |u: f64, v: f64| {
        for (c, &(right, top, _)) in corners.iter().enumerate() {
            let in_x = if right { u >= 1.0 - w } else { u <= w };
            let in_y = if top { v >= 1.0 - h } else { v <= h };
            if in_x && in_y {
                counts[c] += 1;
            }
        }
    };
    let norm = |(x, y): (f64, f64)| ((x - x0) / (x1 - x0), (y - y0) / (y1 - y0));
    for run in prepared.iter().flat_map(|p| &p.runs) {
        for (k, &pt) in run.iter().enumerate() {
            let (u, v) = norm(pt);
            visit(u, v);
            if let Some(&next) = run.get(k + 1) {
                let (u1, v1) = norm(next);
                for s in 1..8 {
                    let f = f64::from(s) / 8.0;
                    visit(u + (u1 - u) * f, v + (v1 - v) * f);
                }
            }
        }
    }
    let best = (0..4).min_by_key(|&c| (counts[c], c)).unwrap_or(0);
    corners[best].2.clone()
}

#[cfg(test)]
mod tests {
    use super::super::test_util::{png_size, TempDir};
    use super::*;

    fn stress_strain() -> LineChart {
        let strain: Vec<f64> = (0..40).map(|i| f64::from(i) * 0.0005).collect();
        let dense: Vec<f64> = strain.iter().map(|e| 50e3 * e * (-e / 0.012).exp()).collect();
        let loose: Vec<f64> = strain.iter().map(|e| 30e3 * e * (-e / 0.016).exp()).collect();
        let mut chart = LineChart::new("Triaxial test", "axial strain εzz [-]", "axial stress σzz [MPa]");
        chart.add_series("dense sample", strain.clone(), dense).add_series("loose sample", strain, loose);
        chart
    }

    #[test]
    fn svg_contains_title_legend_names_and_axis_labels() {
        let svg = stress_strain().render_svg().unwrap();
        assert!(svg.starts_with("<svg"), "not an SVG document");
        for text in ["Triaxial test", "dense sample", "loose sample", "axial strain εzz [-]", "axial stress σzz [MPa]"]
        {
            assert!(svg.contains(text), "SVG lacks {text:?}");
        }
    }

    #[test]
    fn a_long_title_is_shrunk_to_fit_the_chart_and_a_short_one_is_not() {
        style::ensure_fonts().unwrap();
        // The CPT study's qc–depth title, which at 24 px ran past both edges of the 800 px chart.
        let long = "Cone penetration: qc against depth (paper 001 groups (mean of the packings run))";
        let mut svg = String::new();
        let root = SVGBackend::with_string(&mut svg, CHART_SIZE).into_drawing_area();
        let size = style::title_size(&root, long);
        let (w, _) = root.estimate_text_size(long, &(style::FONT, size).into()).unwrap();
        let (full, _) = root.estimate_text_size(long, &(style::FONT, style::TITLE_SIZE).into()).unwrap();
        assert!(full > CHART_SIZE.0, "the test title must overflow at full size ({full} px)");
        assert!((style::TITLE_MIN_SIZE..style::TITLE_SIZE).contains(&size), "size {size}");
        assert!(w <= CHART_SIZE.0 - 2 * style::MARGIN, "{w} px at size {size} does not fit");
        assert_eq!(style::title_size(&root, "Triaxial test"), style::TITLE_SIZE);
    }

    #[test]
    fn png_has_signature_and_decodes_to_chart_size() {
        let png = stress_strain().render_png().unwrap();
        assert_eq!(png_size(&png), CHART_SIZE);
    }

    #[test]
    fn save_without_extension_writes_svg_and_png_and_no_temp_files() {
        let tmp = TempDir::new("chart-save");
        let written = stress_strain().save(&tmp.0.join("curve")).unwrap();
        assert_eq!(written, vec![tmp.0.join("curve.svg"), tmp.0.join("curve.png")]);
        assert_eq!(tmp.listing(), vec!["curve.png", "curve.svg"]);
        let png = std::fs::read(tmp.0.join("curve.png")).unwrap();
        assert_eq!(png_size(&png), CHART_SIZE);
        let svg = std::fs::read_to_string(tmp.0.join("curve.svg")).unwrap();
        assert!(svg.contains("Triaxial test"));
    }

    #[test]
    fn save_picks_format_from_extension() {
        let tmp = TempDir::new("chart-ext");
        let chart = stress_strain();
        let svg_path = tmp.0.join("sub/c.svg");
        assert_eq!(chart.save(&svg_path).unwrap(), vec![svg_path.clone()]);
        assert!(std::fs::read_to_string(&svg_path).unwrap().starts_with("<svg"));
        let png_path = tmp.0.join("c.PNG");
        chart.save(&png_path).unwrap();
        assert_eq!(png_size(&std::fs::read(&png_path).unwrap()), CHART_SIZE);
    }

    #[test]
    fn save_with_bad_extension_is_an_error_and_writes_nothing() {
        let tmp = TempDir::new("chart-bad-ext");
        let err = stress_strain().save(&tmp.0.join("c.pdf")).unwrap_err();
        assert!(matches!(err, PlotError::UnsupportedExtension { .. }));
        assert!(err.to_string().contains(".svg"), "{err}");
        assert!(tmp.listing().is_empty());
    }

    #[test]
    fn mismatched_lengths_are_an_error_naming_the_series() {
        let mut chart = LineChart::new("t", "x", "y");
        chart.add_series("ok", vec![1.0, 2.0], vec![1.0, 2.0]);
        chart.add_series("broken", vec![1.0, 2.0, 3.0], vec![1.0, 2.0]);
        for result in [chart.render_svg().map(|_| ()), chart.render_png().map(|_| ())] {
            let err = result.unwrap_err();
            assert!(matches!(err, PlotError::LengthMismatch { .. }));
            assert!(err.to_string().contains("broken"), "{err}");
        }
    }

    #[test]
    fn chart_without_series_or_finite_points_is_an_error() {
        let chart = LineChart::new("empty", "x", "y");
        assert!(matches!(chart.render_png(), Err(PlotError::Empty { .. })));
        let mut chart = LineChart::new("nan", "x", "y");
        chart.add_series("all nan", vec![f64::NAN], vec![1.0]);
        let err = chart.render_svg().unwrap_err();
        assert!(matches!(err, PlotError::EmptySeries { .. }));
        assert!(err.to_string().contains("all nan"), "{err}");
        let mut chart = LineChart::new("none", "x", "y");
        chart.add_series("no points", Vec::new(), Vec::new());
        assert!(matches!(chart.render_svg(), Err(PlotError::EmptySeries { .. })));
    }

    #[test]
    fn single_point_and_constant_data_render() {
        let mut chart = LineChart::new("degenerate", "x", "y");
        chart.add_series("one point", vec![2.0], vec![3.0]);
        chart.add_series("flat", vec![1.0, 2.0, 3.0], vec![3.0, 3.0, 3.0]);
        assert_eq!(png_size(&chart.render_png().unwrap()), CHART_SIZE);
        let mut chart = LineChart::new("zero", "x", "y");
        chart.add_series("origin", vec![0.0], vec![0.0]);
        assert!(chart.render_svg().unwrap().contains("origin"));
    }

    #[test]
    fn non_finite_points_are_skipped() {
        let mut chart = LineChart::new("gaps", "x", "y");
        chart.add_series(
            "gappy",
            vec![0.0, 1.0, f64::NAN, 3.0, 4.0, 5.0],
            vec![0.0, 1.0, 2.0, f64::INFINITY, 4.0, 1e300],
        );
        let svg = chart.render_svg().unwrap();
        assert!(svg.contains("gappy"));
        assert!(!svg.contains("NaN") && !svg.contains("inf"));
        chart.render_png().unwrap();
    }

    #[test]
    fn error_bars_widen_the_range_and_render_and_bad_lengths_are_named() {
        let mut chart = LineChart::new("study", "wall time [s]", "residual");
        chart.add_series_with_errors("B", vec![10.0], vec![0.1], vec![2.0], vec![0.05]);
        chart.add_series_with_errors("C", vec![12.0, 14.0], vec![0.2, 0.3], Vec::new(), vec![0.1, f64::NAN]);
        let prepared = chart.prepare().unwrap();
        assert_eq!(prepared[0].bars, vec![[(8.0, 0.1), (12.0, 0.1)], [(10.0, 0.05), (10.0, 0.15000000000000002)]]);
        assert_eq!(prepared[1].bars.len(), 1, "a NaN error draws no bar");
        let svg = chart.render_svg().unwrap();
        assert!(svg.contains("study") && svg.contains("C"));
        assert_eq!(png_size(&chart.render_png().unwrap()), CHART_SIZE);
        let mut bad = LineChart::new("t", "x", "y");
        bad.add_series_with_errors("short", vec![1.0, 2.0], vec![1.0, 2.0], Vec::new(), vec![0.1]);
        let err = bad.render_svg().unwrap_err();
        assert!(err.to_string().contains("short") && err.to_string().contains("y_err"), "{err}");
    }

    #[test]
    fn gaps_name_each_series_with_points_left_out_and_the_first_index() {
        let mut chart = LineChart::new("gaps", "x", "y");
        chart.add_series("clean", vec![0.0, 1.0], vec![0.0, 1.0]);
        chart.add_series("gappy", vec![0.0, 1.0, f64::NAN, 3.0, 4.0], vec![0.0, 1.0, 2.0, f64::INFINITY, 1e301]);
        let gaps = chart.gaps();
        assert_eq!(gaps.len(), 1, "{gaps:?}");
        assert_eq!((gaps[0].series.as_str(), gaps[0].count, gaps[0].first), ("gappy", 3, 2));
        assert!(gaps[0].x.is_nan() && gaps[0].y == 2.0);
    }
}
