//! Particle pictures: every particle a filled circle of its true radius,
//! coloured by a per-particle value.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::style::{self, FONT};
use super::{draw_err, PlotError};

/// Size of a rendered picture in pixels.
pub const PICTURE_SIZE: (u32, u32) = (800, 700);

/// At most this many distinct integer values are shown as classes with a
/// legend rather than on a continuous colour bar.
pub const MAX_CLASSES: usize = 10;

/// Width of the gradient strip of the colour bar, in pixels.
/// The comment a particle picture's SVG carries right after its `<svg>` tag.
pub const PICTURE_MARK: &str = "<!-- matdem-rs particle picture -->";

const BAR_WIDTH: u32 = 26;

/// A 2-D view of particles at `(x[i], y[i])` with radius `r[i]` (data units,
/// equal scale on both axes, so circles stay round), filled by `value[i]`.
///
/// Values are shown through a perceptual colour map with a colour bar from
/// their minimum to maximum, labelled `field`. When every finite value is an
/// integer and there are at most [`MAX_CLASSES`] distinct ones (size classes,
/// groups, flags), each gets its own colour from a discrete palette and a
/// legend replaces the bar. Particles with a non-finite value (or one beyond
/// ±1e300) are drawn grey;
/// particles with a non-finite position or radius (or one beyond ±1e300), or a
/// negative radius, are skipped.
#[derive(Debug, Clone, PartialEq)]
pub struct ParticlePicture {
    pub title: String,
    /// Label of the colour bar or legend, with units, e.g. `"speed [m/s]"`.
    pub field: String,
    /// Axis labels with units, e.g. `"x [m]"`.
    pub x_label: String,
    pub y_label: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub r: Vec<f64>,
    pub value: Vec<f64>,
}

/// How values become colours.
#[derive(Debug, Clone, PartialEq)]
enum Colouring {
    /// Continuous map over `[lo, hi]` (equal when every value is the same).
    Ramp { lo: f64, hi: f64 },
    /// Discrete classes, sorted ascending.
    Classes(Vec<i64>),
    /// No particle has a usable value.
    Nothing,
}

impl Colouring {
    fn of(values: impl Iterator<Item = f64>) -> Colouring {
        let mut scale = ValueScale::default();
        values.for_each(|v| scale.add(v));
        scale.colouring()
    }

    fn colour(&self, v: f64) -> RGBColor {
        if !style::plottable(v) {
            return style::NO_DATA;
        }
        match self {
            Colouring::Ramp { lo, hi } => style::colormap(ramp_position(v, *lo, *hi)),
            Colouring::Classes(classes) => match classes.binary_search(&(v as i64)) {
                Ok(k) => style::categorical(k),
                Err(_) => style::NO_DATA,
            },
            Colouring::Nothing => style::NO_DATA,
        }
    }
}

/// Where `v` sits on the colour map for data spanning `[lo, hi]`.
fn ramp_position(v: f64, lo: f64, hi: f64) -> f64 {
    if hi > lo {
        (v - lo) / (hi - lo)
    } else {
        0.5
    }
}

/// The values seen so far, for choosing a [`Colouring`]: their range, and their distinct
/// integers while there are at most [`MAX_CLASSES`] and no other value.
#[derive(Debug, Clone)]
struct ValueScale {
    lo: f64,
    hi: f64,
    /// `None` once a value is not an integer or there are too many.
    classes: Option<Vec<i64>>,
}

impl Default for ValueScale {
    fn default() -> Self {
        ValueScale { lo: f64::INFINITY, hi: f64::NEG_INFINITY, classes: Some(Vec::new()) }
    }
}

impl ValueScale {
    fn add(&mut self, v: f64) {
        if !style::plottable(v) {
            return;
        }
        self.lo = self.lo.min(v);
        self.hi = self.hi.max(v);
        if let Some(classes) = &mut self.classes {
            if v.fract() != 0.0 || v.abs() >= 1e15 {
                self.classes = None;
            } else if let Err(at) = classes.binary_search(&(v as i64)) {
                if classes.len() == MAX_CLASSES {
                    self.classes = None;
                } else {
                    classes.insert(at, v as i64);
                }
            }
        }
    }

    fn colouring(&self) -> Colouring {
        if self.lo > self.hi {
            return Colouring::Nothing;
        }
        match &self.classes {
            Some(classes) if !classes.is_empty() => Colouring::Classes(classes.clone()),
            _ => Colouring::Ramp { lo: self.lo, hi: self.hi },
        }
    }
}

/// What a movie keeps the same in every frame, so that its frames compare: one colouring (one
/// colour scale, or one set of classes) and one part of the plane shown. Made by
/// [`FixedBuilder`] from every frame's data; used by [`ParticlePicture::render_rgb`].
#[derive(Debug, Clone, PartialEq)]
pub struct Fixed {
    colouring: Colouring,
    /// The extent of the discs (x0, x1, y0, y1), before the picture's padding.
    extent: (f64, f64, f64, f64),
}

/// Gathers, particle by particle over many frames, the range of the values and the extent of
/// the discs, for a [`Fixed`] scale and view.
#[derive(Debug, Clone)]
pub struct FixedBuilder {
    values: ValueScale,
    extent: (f64, f64, f64, f64),
}

impl Default for FixedBuilder {
    fn default() -> Self {
        FixedBuilder { values: ValueScale::default(), extent: (f64::MAX, f64::MIN, f64::MAX, f64::MIN) }
    }
}

impl FixedBuilder {
    /// Takes one particle into account (one a picture would skip is left out here too).
    pub fn add(&mut self, x: f64, y: f64, r: f64, value: f64) {
        if !(style::plottable(x) && style::plottable(y) && style::plottable(r) && r >= 0.0) {
            return;
        }
        let e = &mut self.extent;
        *e = (e.0.min(x - r), e.1.max(x + r), e.2.min(y - r), e.3.max(y + r));
        self.values.add(value);
    }

    /// The scale and view of every particle added; `range` = (lo, hi), when given, is the
    /// colour scale instead of the values' own. `None` when no particle could be drawn.
    pub fn build(&self, range: Option<(f64, f64)>) -> Option<Fixed> {
        if self.extent.0 > self.extent.1 {
            return None;
        }
        let colouring = match range {
            Some((lo, hi)) => Colouring::Ramp { lo, hi },
            None => self.values.colouring(),
        };
        Some(Fixed { colouring, extent: self.extent })
    }
}

/// One particle placed on the canvas, in backend pixels.
///
/// Particles are painted by this module rather than by plotters, whose
/// circles have whole-pixel centres and radii: at the 1–3 px radii of a large
/// assembly those turn into crosses and squares. Here they are anti-aliased
/// discs (PNG) or `<circle>`s with fractional geometry (SVG).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Disc {
    cx: f64,
    cy: f64,
    r: f64,
    fill: RGBColor,
    /// A 1 px rim inside the radius, for large discs.
    outline: Option<RGBColor>,
}

/// Smallest radius painted, so that tiny particles still show.
const MIN_RADIUS_PX: f64 = 0.7;

impl Disc {
    /// Paints the disc into a packed RGB buffer `width` pixels wide, limited
    /// to the pixels in `clip` = (x0, y0, x1, y1), end-exclusive.
    fn paint(&self, rgb: &mut [u8], width: usize, clip: (i32, i32, i32, i32)) {
        let r = self.r.max(MIN_RADIUS_PX);
        let height = (rgb.len() / 3 / width.max(1)) as i32;
        let x0 = ((self.cx - r - 1.0).floor() as i32).max(clip.0).max(0);
        let x1 = ((self.cx + r + 1.0).ceil() as i32).min(clip.2).min(width as i32);
        let y0 = ((self.cy - r - 1.0).floor() as i32).max(clip.1).max(0);
        let y1 = ((self.cy + r + 1.0).ceil() as i32).min(clip.3).min(height);
        for j in y0..y1 {
            let dy = f64::from(j) + 0.5 - self.cy;
            for i in x0..x1 {
                let dx = f64::from(i) + 0.5 - self.cx;
                let dist = (dx * dx + dy * dy).sqrt();
                // Approximate pixel coverage from the distance to the edge.
                let outer = (r + 0.5 - dist).clamp(0.0, 1.0);
                if outer <= 0.0 {
                    continue;
                }
                let at = (j as usize * width + i as usize) * 3;
                let px = &mut rgb[at..at + 3];
                match self.outline {
                    Some(rim) => {
                        blend(px, rim, outer);
                        blend(px, self.fill, (r - 0.5 - dist).clamp(0.0, 1.0));
                    }
                    None => blend(px, self.fill, outer),
                }
            }
        }
    }

    /// Appends the disc as an SVG `<circle>`.
    fn write_svg(&self, out: &mut String) {
        use std::fmt::Write;
        let hex = |c: RGBColor| format!("#{:02x}{:02x}{:02x}", c.0, c.1, c.2);
        let r = self.r.max(MIN_RADIUS_PX);
        let _ = match self.outline {
            // The stroke is centred on the rim: keep the outer edge at r.
            Some(rim) => writeln!(
                out,
                r#"<circle cx="{:.2}" cy="{:.2}" r="{:.2}" fill="{}" stroke="{}" stroke-width="1"/>"#,
                self.cx,
                self.cy,
                (r - 0.5).max(0.0),
                hex(self.fill),
                hex(rim)
            ),
            None => writeln!(
                out,
                r#"<circle cx="{:.2}" cy="{:.2}" r="{:.2}" fill="{}"/>"#,
                self.cx,
                self.cy,
                r,
                hex(self.fill)
            ),
        };
    }
}

/// Mixes `colour` into the pixel with weight `alpha`.
fn blend(px: &mut [u8], colour: RGBColor, alpha: f64) {
    if alpha <= 0.0 {
        return;
    }
    for (p, c) in px.iter_mut().zip([colour.0, colour.1, colour.2]) {
        *p = (f64::from(*p) + (f64::from(c) - f64::from(*p)) * alpha).round() as u8;
    }
}

/// What `draw` leaves for the caller to paint.
struct Layout {
    discs: Vec<Disc>,
    /// The plotting area in backend pixels: (x0, y0, x1, y1), end-exclusive.
    clip: (i32, i32, i32, i32),
}

impl ParticlePicture {
    /// An empty picture; fill the data vectors or use [`push`](Self::push).
    pub fn new(title: impl Into<String>, field: impl Into<String>) -> Self {
        ParticlePicture {
            title: title.into(),
            field: field.into(),
            x_label: "x".into(),
            y_label: "y".into(),
            x: Vec::new(),
            y: Vec::new(),
            r: Vec::new(),
            value: Vec::new(),
        }
    }

    /// Adds one particle.
    pub fn push(&mut self, x: f64, y: f64, r: f64, value: f64) -> &mut Self {
        self.x.push(x);
        self.y.push(y);
        self.r.push(r);
        self.value.push(value);
        self
    }

    /// Renders the picture as an SVG document (marked with [`PICTURE_MARK`]).
    pub fn render_svg(&self) -> Result<String, PlotError> {
        style::ensure_fonts()?;
        let mut svg = String::new();
        let layout;
        {
            let root = SVGBackend::with_string(&mut svg, PICTURE_SIZE).into_drawing_area();
            layout = self.draw(&root, None)?;
            root.present().map_err(draw_err)?;
        }
        // Particles go in with sub-pixel precision; nothing else overlaps them.
        let mut circles = String::with_capacity(layout.discs.len() * 64);
        for d in &layout.discs {
            d.write_svg(&mut circles);
        }
        let at = svg.rfind("</svg>").unwrap_or(svg.len());
        svg.insert_str(at, &circles);
        // Marks the file as a particle picture, which report pages show as an image (its
        // PNG) rather than inline: it can hold a circle per element.
        if let Some(end) = svg.find('>') {
            svg.insert_str(end + 1, PICTURE_MARK);
        }
        Ok(svg)
    }

    /// Renders the picture as PNG-encoded bytes.
    pub fn render_png(&self) -> Result<Vec<u8>, PlotError> {
        let (w, h) = PICTURE_SIZE;
        super::encode_png(&self.render_rgb(None)?, w, h)
    }

    /// Renders the picture into a packed RGB buffer of [`PICTURE_SIZE`], with the colour scale
    /// and view of `fixed` when given (a movie's frames) instead of its own data's.
    pub fn render_rgb(&self, fixed: Option<&Fixed>) -> Result<Vec<u8>, PlotError> {
        style::ensure_fonts()?;
        let (w, h) = PICTURE_SIZE;
        let mut rgb = vec![0u8; w as usize * h as usize * 3];
        let layout;
        {
            let root = BitMapBackend::with_buffer(&mut rgb, PICTURE_SIZE).into_drawing_area();
            layout = self.draw(&root, fixed)?;
            root.present().map_err(draw_err)?;
        }
        for d in &layout.discs {
            d.paint(&mut rgb, w as usize, layout.clip);
        }
        Ok(rgb)
    }

    /// Writes the picture to `path`: `.svg` or `.png` by extension, or both
    /// `<path>.svg` and `<path>.png` when `path` has no extension. Returns the
    /// files written.
    pub fn save(&self, path: &Path) -> Result<Vec<PathBuf>, PlotError> {
        super::save_figure(path, || self.render_svg(), || self.render_png())
    }

    /// Indices of the particles that can be drawn, after checking the data.
    fn drawable(&self) -> Result<Vec<usize>, PlotError> {
        let n = self.x.len();
        if [self.y.len(), self.r.len(), self.value.len()].iter().any(|&len| len != n) {
            return Err(PlotError::LengthMismatch {
                series: if self.field.is_empty() { "particles".to_string() } else { self.field.clone() },
                detail: format!(
                    "x has {} values, y has {}, r has {}, value has {}",
                    n,
                    self.y.len(),
                    self.r.len(),
                    self.value.len()
                ),
            });
        }
        if n == 0 {
            return Err(PlotError::Empty { figure: self.title.clone(), reason: "the picture has no particles".into() });
        }
        let ok: Vec<usize> = (0..n)
            .filter(|&i| {
                style::plottable(self.x[i])
                    && style::plottable(self.y[i])
                    && style::plottable(self.r[i])
                    && self.r[i] >= 0.0
            })
            .collect();
        if ok.is_empty() {
            return Err(PlotError::Empty {
                figure: self.title.clone(),
                reason: "no particle has a finite position and a valid radius".into(),
            });
        }
        Ok(ok)
    }

    /// Draws everything but the particles, and returns where they go; with `fixed`, in its
    /// colouring and view rather than those of this picture's own data.
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        fixed: Option<&Fixed>,
    ) -> Result<Layout, PlotError> {
        let drawable = self.drawable()?;
        let colouring = match fixed {
            Some(f) => f.colouring.clone(),
            None => Colouring::of(drawable.iter().map(|&i| self.value[i])),
        };

        // Extent of the discs themselves, not just their centres.
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for &i in &drawable {
            let (x, y, r) = (self.x[i], self.y[i], self.r[i]);
            x0 = x0.min(x - r);
            x1 = x1.max(x + r);
            y0 = y0.min(y - r);
            y1 = y1.max(y + r);
        }
        if let Some(f) = fixed {
            (x0, x1, y0, y1) = f.extent;
        }
        let pad = 0.03 * (x1 - x0).max(y1 - y0);
        let ((x0, x1), (y0, y1)) = if pad > 0.0 {
            ((x0 - pad, x1 + pad), (y0 - pad, y1 + pad))
        } else {
            (style::padded_range(x0, x1, 0.0), style::padded_range(y0, y1, 0.0))
        };

        root.fill(&WHITE).map_err(draw_err)?;
        let area = root.margin(6, 0, 0, 0).titled(&self.title, (FONT, style::TITLE_SIZE)).map_err(draw_err)?;

        // The colour bar or legend column, sized to its labels.
        let bar_labels = match &colouring {
            Colouring::Ramp { lo, hi } => {
                let (blo, bhi) = style::padded_range(*lo, *hi, 0.0);
                let fmt = style::tick_formatter(blo, bhi);
                let labels = style::sample_labels(&fmt, blo, bhi);
                Some((blo, bhi, style::y_label_area_width(&labels)))
            }
            _ => None,
        };
        let side_width = match bar_labels {
            Some((_, _, label_w)) => 10 + BAR_WIDTH + label_w + 6,
            None => 170,
        };
        let (area_w, _) = area.dim_in_pixel();
        let (main, side) = area.split_horizontally(area_w.saturating_sub(side_width));

        // Equal scale: widen whichever range has room to spare.
        let mut y_area = style::y_label_area_width(&style::sample_labels(&style::tick_formatter(y0, y1), y0, y1));
        let mut ranges = equal_scale(&main, y_area, (x0, x1), (y0, y1))?;
        let wider = style::y_label_area_width(&style::sample_labels(
            &style::tick_formatter(ranges.1 .0, ranges.1 .1),
            ranges.1 .0,
            ranges.1 .1,
        ));
        if wider != y_area {
            y_area = wider;
            ranges = equal_scale(&main, y_area, (x0, x1), (y0, y1))?;
        }
        let ((x0, x1), (y0, y1)) = ranges;

        let mut chart = plot_builder(&main, y_area).build_cartesian_2d(x0..x1, y0..y1).map_err(draw_err)?;
        section_axes(&mut chart, &self.x_label, &self.y_label, (x0, x1), (y0, y1))?;

        // Place the discs in backend pixels; the caller paints them (see `Disc`).
        let (xs, ys) = chart.plotting_area().get_pixel_range();
        let (pw, ph) = (f64::from(xs.end - xs.start), f64::from(ys.end - ys.start));
        let scale = pw / (x1 - x0);
        let to_px = |x: f64, y: f64| {
            (f64::from(xs.start) + pw * (x - x0) / (x1 - x0), f64::from(ys.end) - ph * (y - y0) / (y1 - y0))
        };
        let mean_radius = drawable.iter().map(|&i| self.r[i]).sum::<f64>() * scale / drawable.len() as f64;
        let outlined = mean_radius >= 4.0;
        let discs = drawable
            .iter()
            .map(|&i| {
                let (cx, cy) = to_px(self.x[i], self.y[i]);
                let fill = colouring.colour(self.value[i]);
                Disc { cx, cy, r: self.r[i] * scale, fill, outline: outlined.then(|| style::darker(fill)) }
            })
            .collect();
        let clip = (xs.start, ys.start, xs.end, ys.end);
        // Full frame; the discs never reach it thanks to the padding.
        chart.plotting_area().draw(&Rectangle::new([(x0, y0), (x1, y1)], BLACK.stroke_width(1))).map_err(draw_err)?;

        match (&colouring, bar_labels) {
            (Colouring::Ramp { lo, hi }, Some((blo, bhi, label_w))) => {
                self.draw_colour_bar(&side, (*lo, *hi), (blo, bhi), label_w)?
            }
            (Colouring::Classes(classes), _) => {
                let mut entries: Vec<(String, RGBColor)> =
                    classes.iter().enumerate().map(|(k, v)| (v.to_string(), style::categorical(k))).collect();
                if drawable.iter().any(|&i| !style::plottable(self.value[i])) {
                    entries.push(("no value".into(), style::NO_DATA));
                }
                self.draw_legend(&side, &entries)?
            }
            _ => self.draw_legend(&side, &[("no value".into(), style::NO_DATA)])?,
        }
        Ok(Layout { discs, clip })
    }

    /// A vertical gradient strip for data `[lo, hi]` on axis range `[blo, bhi]`.
    fn draw_colour_bar<DB: DrawingBackend>(
        &self,
        side: &DrawingArea<DB, Shift>,
        (lo, hi): (f64, f64),
        (blo, bhi): (f64, f64),
        label_w: u32,
    ) -> Result<(), PlotError> {
        let mut bar = ChartBuilder::on(side)
            .margin_top(style::MARGIN)
            .margin_bottom(style::MARGIN + style::X_LABEL_AREA)
            .margin_left(10)
            .margin_right(6)
            .set_label_area_size(LabelAreaPosition::Right, label_w)
            .build_cartesian_2d(0.0..1.0, blo..bhi)
            .map_err(draw_err)?;
        let steps = 256;
        let edge = |k: usize| blo + (bhi - blo) * k as f64 / steps as f64;
        bar.draw_series((0..steps).map(|k| {
            let (a, b) = (edge(k), edge(k + 1));
            let c = style::colormap(ramp_position(0.5 * (a + b), lo, hi));
            Rectangle::new([(0.0, a), (1.0, b)], c.filled())
        }))
        .map_err(draw_err)?;
        let fmt = style::tick_formatter(blo, bhi);
        bar.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .set_tick_mark_size(LabelAreaPosition::Right, 5)
            .y_desc(self.field.as_str())
            .y_label_formatter(&fmt)
            .y_labels(8)
            .label_style((FONT, style::TICK_SIZE))
            .axis_desc_style((FONT, style::LABEL_SIZE))
            .draw()
            .map_err(draw_err)?;
        bar.plotting_area().draw(&Rectangle::new([(0.0, blo), (1.0, bhi)], BLACK.stroke_width(1))).map_err(draw_err)?;
        Ok(())
    }

    /// The field label (wrapped to the column) over one swatch per class.
    fn draw_legend<DB: DrawingBackend>(
        &self,
        side: &DrawingArea<DB, Shift>,
        entries: &[(String, RGBColor)],
    ) -> Result<(), PlotError> {
        let (w, _) = side.dim_in_pixel();
        let left = 10;
        let heading: TextStyle = (FONT, style::LABEL_SIZE).into();
        let text = TextStyle::from((FONT, style::LEGEND_SIZE)).pos(Pos::new(HPos::Left, VPos::Center));
        let mut y = style::MARGIN as i32;
        for line in wrap(side, &self.field, &heading, w.saturating_sub(2 * left as u32))? {
            side.draw_text(&line, &heading, (left, y)).map_err(draw_err)?;
            y += style::LABEL_SIZE as i32 + 5;
        }
        y += 8;
        let row = style::LEGEND_SIZE as i32 + 11;
        for (label, colour) in entries {
            let centre = (left + 8, y + row / 2 - 2);
            side.draw(&Circle::new(centre, 8, colour.filled())).map_err(draw_err)?;
            side.draw(&Circle::new(centre, 8, style::darker(*colour).stroke_width(1))).map_err(draw_err)?;
            // Digits have no descender: nudge down to look centred.
            side.draw_text(label, &text, (left + 24, centre.1 + 2)).map_err(draw_err)?;
            y += row;
        }
        Ok(())
    }
}

/// A `(low, high)` axis range.
pub(super) type Span = (f64, f64);

/// Builder for the particle axes, identical for the probe and the real chart.
pub(super) fn plot_builder<'a, 'b, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    y_area: u32,
) -> ChartBuilder<'a, 'b, DB> {
    let mut builder = ChartBuilder::on(area);
    builder.margin(style::MARGIN).x_label_area_size(style::X_LABEL_AREA).y_label_area_size(y_area);
    builder
}

/// Widens `xr` or `yr` about its centre so that one data unit spans the same
/// number of pixels on both axes of the plotting area.
pub(super) fn equal_scale<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    y_area: u32,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> Result<(Span, Span), PlotError> {
    let probe = plot_builder(area, y_area).build_cartesian_2d(0.0..1.0, 0.0..1.0).map_err(draw_err)?;
    let (pw, ph) = probe.plotting_area().dim_in_pixel();
    let (pw, ph) = (f64::from(pw.max(1)), f64::from(ph.max(1)));
    let scale = (pw / (x1 - x0)).min(ph / (y1 - y0));
    let (wx, wy) = (pw / scale, ph / scale);
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    Ok(((cx - 0.5 * wx, cx + 0.5 * wx), (cy - 0.5 * wy, cy + 0.5 * wy)))
}

/// Greedy word wrap of `text` to lines at most `width` pixels wide (a single
/// over-long word stays on its own line).
fn wrap<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    text: &str,
    style: &TextStyle,
    width: u32,
) -> Result<Vec<String>, PlotError> {
    let mut lines: Vec<String> = Vec::new();
    let mut current = String::new();
    for word in text.split_whitespace() {
        let candidate = if current.is_empty() { word.to_string() } else { format!("{current} {word}") };
        let (w, _) = area.estimate_text_size(&candidate, style).map_err(draw_err)?;
        if w > width && !current.is_empty() {
            lines.push(std::mem::replace(&mut current, word.to_string()));
        } else {
            current = candidate;
        }
    }
    if !current.is_empty() {
        lines.push(current);
    }
    Ok(lines)
}

/// The axes of a section picture: labelled ticks, no grid (the discs are the picture).
pub(crate) fn section_axes<DB: DrawingBackend>(
    chart: &mut ChartContext<
        '_,
        DB,
        Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
    >,
    x_label: &str,
    y_label: &str,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> Result<(), PlotError> {
    let (fmt_x, fmt_y) = (style::tick_formatter(x0, x1), style::tick_formatter(y0, y1));
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .x_label_formatter(&fmt_x)
        .y_label_formatter(&fmt_y)
        .x_labels(8)
        .y_labels(8)
        .label_style((FONT, style::TICK_SIZE))
        .axis_desc_style((FONT, style::LABEL_SIZE))
        .draw()
        .map_err(draw_err)
}

#[cfg(test)]
mod tests {
    use super::super::test_util::{png_size, TempDir};
    use super::*;

    /// A deterministic pseudo-random packing-like cloud of `n` particles.
    fn cloud(n: usize, field: &str, value: impl Fn(usize, f64) -> f64) -> ParticlePicture {
        let mut pic = ParticlePicture::new("Sample after compaction", field);
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for i in 0..n {
            let (x, y) = (next() * 2.0, next() * 1.0);
            let r = 0.004 + 0.008 * next();
            pic.push(x, y, r, value(i, y));
        }
        pic
    }

    #[test]
    fn svg_contains_title_and_field_label() {
        let svg = cloud(200, "speed [m/s]", |_, y| y * 3.0).render_svg().unwrap();
        assert!(svg.starts_with("<svg"));
        assert!(svg.contains("Sample after compaction"));
        assert!(svg.contains("speed [m/s]"));
        assert!(svg.matches("<circle").count() >= 200);
    }

    #[test]
    fn png_has_signature_and_decodes_to_picture_size() {
        let png = cloud(500, "speed [m/s]", |_, y| y).render_png().unwrap();
        assert_eq!(png_size(&png), PICTURE_SIZE);
    }

    #[test]
    fn few_integer_values_get_a_legend_instead_of_a_colour_bar() {
        let pic = cloud(300, "size class", |i, _| (i % 3) as f64 + 7.0);
        assert!(matches!(
            Colouring::of(pic.value.iter().copied()),
            Colouring::Classes(ref c) if c == &[7, 8, 9]
        ));
        let svg = pic.render_svg().unwrap();
        assert!(svg.contains("size class"));
        // No colour bar, whose tick labels would show in-between values.
        assert!(!svg.contains(">\n7.5\n<"));
        for label in [">\n7\n<", ">\n8\n<", ">\n9\n<"] {
            assert!(svg.contains(label), "legend lacks {label}");
        }
        // Eleven distinct integers are too many classes: back to the bar.
        let many = cloud(300, "id", |i, _| (i % 11) as f64);
        assert!(matches!(Colouring::of(many.value.iter().copied()), Colouring::Ramp { .. }));
    }

    #[test]
    fn frames_drawn_with_one_fixed_scale_and_view_repaint_only_what_changed() {
        // Two frames of two grains: the left one's value is the same in both, the right one's
        // grows. With one scale over both frames only the right grain changes colour; with a
        // scale per frame the left one does too.
        let frame = |right: f64| {
            let mut p = ParticlePicture::new("movie", "v");
            p.push(0.0, 0.0, 0.3, 3.5).push(1.0, 0.0, 0.3, right);
            p
        };
        let (a, b) = (frame(2.25), frame(5.75));
        let mut scale = FixedBuilder::default();
        for p in [&a, &b] {
            for i in 0..p.x.len() {
                scale.add(p.x[i], p.y[i], p.r[i], p.value[i]);
            }
        }
        let fixed = scale.build(None).unwrap();
        assert_eq!(fixed.colouring, Colouring::Ramp { lo: 2.25, hi: 5.75 });
        let changed = |p: &[u8], q: &[u8]| p.chunks(3).zip(q.chunks(3)).filter(|(x, y)| x != y).count();
        let with_one = changed(&a.render_rgb(Some(&fixed)).unwrap(), &b.render_rgb(Some(&fixed)).unwrap());
        let per_frame = changed(&a.render_rgb(None).unwrap(), &b.render_rgb(None).unwrap());
        assert!(with_one > 0 && (with_one as f64) < 0.6 * per_frame as f64, "{with_one} vs {per_frame} pixels");
        // A given range wins; a builder that saw no particle gives none.
        assert_eq!(scale.build(Some((0.0, 1.0))).unwrap().colouring, Colouring::Ramp { lo: 0.0, hi: 1.0 });
        assert!(FixedBuilder::default().build(None).is_none());
    }

    #[test]
    fn circles_are_round_because_axes_share_one_scale() {
        // A wide, flat cloud must still map one unit to the same pixels on x and y.
        let mut pic = ParticlePicture::new("flat", "v");
        pic.push(0.0, 0.0, 0.1, 1.0).push(10.0, 0.5, 0.1, 2.5);
        style::ensure_fonts().unwrap();
        let mut svg = String::new();
        let root = SVGBackend::with_string(&mut svg, PICTURE_SIZE).into_drawing_area();
        let area = root.titled("flat", (FONT, style::TITLE_SIZE)).unwrap();
        let y_area = 60;
        let ((x0, x1), (y0, y1)) = equal_scale(&area, y_area, (-0.2, 10.2), (-0.2, 0.7)).unwrap();
        let chart = plot_builder(&area, y_area).build_cartesian_2d(x0..x1, y0..y1).unwrap();
        let (pw, ph) = chart.plotting_area().dim_in_pixel();
        let sx = f64::from(pw) / (x1 - x0);
        let sy = f64::from(ph) / (y1 - y0);
        assert!((sx - sy).abs() / sx < 1e-9, "x scale {sx} != y scale {sy}");
        let eps = 1e-9;
        assert!(x0 <= -0.2 + eps && x1 >= 10.2 - eps, "x range {x0}..{x1} cuts the data");
        assert!(y0 <= -0.2 + eps && y1 >= 0.7 - eps, "y range {y0}..{y1} cuts the data");
        drop(chart);
        drop(area);
        drop(root);
        pic.render_png().unwrap();
    }

    #[test]
    fn painted_discs_are_round_and_cover_their_area() {
        let (w, h) = (40usize, 40usize);
        let mut rgb = vec![255u8; w * h * 3];
        let disc = Disc { cx: 20.3, cy: 19.6, r: 8.0, fill: RGBColor(0, 0, 0), outline: None };
        disc.paint(&mut rgb, w, (0, 0, w as i32, h as i32));
        // Darkness summed over pixels approximates the disc's area.
        let ink: f64 = rgb.chunks(3).map(|p| 1.0 - f64::from(p[0]) / 255.0).sum();
        let area = std::f64::consts::PI * 64.0;
        assert!((ink - area).abs() / area < 0.02, "ink {ink} vs area {area}");
        // Same extent across as down.
        let dark = |i: usize, j: usize| rgb[(j * w + i) * 3] < 128;
        let across = (0..w).filter(|&i| dark(i, 19)).count();
        let down = (0..h).filter(|&j| dark(20, j)).count();
        assert!(across.abs_diff(down) <= 1, "{across} across vs {down} down");
        // Nothing painted outside the clip rectangle.
        let mut rgb = vec![255u8; w * h * 3];
        disc.paint(&mut rgb, w, (0, 0, 20, 40));
        assert!((20..w).all(|i| (0..h).all(|j| rgb[(j * w + i) * 3] == 255)));
    }

    #[test]
    fn save_without_extension_writes_svg_and_png_and_no_temp_files() {
        let tmp = TempDir::new("picture-save");
        let written = cloud(100, "group", |i, _| (i % 2) as f64).save(&tmp.0.join("snap")).unwrap();
        assert_eq!(written, vec![tmp.0.join("snap.svg"), tmp.0.join("snap.png")]);
        assert_eq!(tmp.listing(), vec!["snap.png", "snap.svg"]);
        let png = std::fs::read(tmp.0.join("snap.png")).unwrap();
        assert_eq!(png_size(&png), PICTURE_SIZE);
    }

    #[test]
    fn save_with_bad_extension_is_an_error() {
        let tmp = TempDir::new("picture-bad-ext");
        let err = cloud(10, "v", |_, y| y).save(&tmp.0.join("snap.gif")).unwrap_err();
        assert!(matches!(err, PlotError::UnsupportedExtension { .. }));
        assert!(tmp.listing().is_empty());
    }

    #[test]
    fn mismatched_lengths_are_an_error_not_a_panic() {
        let mut pic = cloud(10, "speed", |_, y| y);
        pic.value.pop();
        for result in [pic.render_svg().map(|_| ()), pic.render_png().map(|_| ())] {
            let err = result.unwrap_err();
            assert!(matches!(err, PlotError::LengthMismatch { .. }));
            let msg = err.to_string();
            assert!(msg.contains("speed") && msg.contains("value has 9"), "{msg}");
        }
    }

    #[test]
    fn empty_or_unplaceable_pictures_are_errors() {
        let pic = ParticlePicture::new("nothing", "v");
        assert!(matches!(pic.render_png(), Err(PlotError::Empty { .. })));
        let mut pic = ParticlePicture::new("lost", "v");
        pic.push(f64::NAN, 0.0, 1.0, 1.0).push(0.0, 0.0, -1.0, 1.0);
        assert!(matches!(pic.render_svg(), Err(PlotError::Empty { .. })));
    }

    #[test]
    fn single_particle_constant_and_missing_values_render() {
        let mut pic = ParticlePicture::new("one", "v");
        pic.push(1.0, 1.0, 0.5, 2.5);
        assert_eq!(png_size(&pic.render_png().unwrap()), PICTURE_SIZE);
        let mut pic = ParticlePicture::new("point", "v");
        pic.push(0.0, 0.0, 0.0, f64::NAN);
        assert!(pic.render_svg().unwrap().contains("no value"));
        let mut pic = cloud(50, "stress [Pa]", |_, _| 1.5e6);
        pic.value[3] = f64::INFINITY;
        assert_eq!(png_size(&pic.render_png().unwrap()), PICTURE_SIZE);
    }

    #[test]
    fn fifty_thousand_particles_render_to_png() {
        let pic = cloud(50_000, "speed [m/s]", |_, y| y);
        let start = std::time::Instant::now();
        let png = pic.render_png().unwrap();
        let took = start.elapsed();
        assert_eq!(png_size(&png), PICTURE_SIZE);
        // Generous bound: debug builds on a slow CI machine; release is far faster.
        assert!(took.as_secs_f64() < 10.0, "took {took:?}");
    }
}
