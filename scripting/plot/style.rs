//! Look shared by every figure: the built-in font, colours, sizes and tick labels.

use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::{DrawingArea, DrawingBackend};
use plotters::style::{Color, FontStyle, RGBColor};

use super::PlotError;

/// Font family every text element asks for; registered from the DejaVu bytes.
pub(crate) const FONT: &str = "sans-serif";

pub(crate) const TITLE_SIZE: u32 = 24;
/// Axis descriptions, colour-bar label and legend title.
pub(crate) const LABEL_SIZE: u32 = 17;
pub(crate) const TICK_SIZE: u32 = 14;
pub(crate) const LEGEND_SIZE: u32 = 15;
/// Blank border around every chart, in pixels.
pub(crate) const MARGIN: u32 = 14;
/// Height of the area under the x axis: tick labels plus the axis description.
pub(crate) const X_LABEL_AREA: u32 = 56;

/// Drawn for a point or particle whose value is missing (NaN or infinite).
pub(crate) const NO_DATA: RGBColor = RGBColor(200, 200, 200);

/// Ten well separated colours for lines and categories, readable on white
/// and distinguishable by most colour-blind viewers for the first six.
const CATEGORICAL: [RGBColor; 10] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(117, 112, 179),
    RGBColor(140, 86, 75),
    RGBColor(102, 102, 102),
    RGBColor(188, 189, 34),
];

/// Stops of a perceptually uniform dark-blue → green → yellow ramp, evenly
/// spaced on [0, 1]; colours in between are interpolated linearly.
const RAMP: [(f64, f64, f64); 9] = [
    (68.0, 1.0, 84.0),
    (71.0, 44.0, 122.0),
    (59.0, 81.0, 139.0),
    (44.0, 113.0, 142.0),
    (33.0, 144.0, 141.0),
    (39.0, 173.0, 129.0),
    (92.0, 200.0, 99.0),
    (170.0, 220.0, 50.0),
    (253.0, 231.0, 37.0),
];

/// Registers the built-in DejaVu Sans as [`FONT`]; must run before any text is
/// drawn, by any backend. Cheap after the first call.
pub(crate) fn ensure_fonts() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular())
                .map_err(|_| "the built-in DejaVu Sans font could not be parsed".to_string())
        })
        .clone()
        .map_err(PlotError::Font)
}

/// Colour of the `i`-th series or category; cycles after ten.
pub(crate) fn categorical(i: usize) -> RGBColor {
    CATEGORICAL[i % CATEGORICAL.len()]
}

/// Continuous colour map: `t` in [0, 1] (clamped) to a colour on the ramp.
pub(crate) fn colormap(t: f64) -> RGBColor {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let pos = t * (RAMP.len() - 1) as f64;
    let i = (pos.floor() as usize).min(RAMP.len() - 2);
    let f = pos - i as f64;
    let (a, b) = (RAMP[i], RAMP[i + 1]);
    let mix = |p: f64, q: f64| (p + (q - p) * f).round().clamp(0.0, 255.0) as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// A darker shade of `c`, for outlines.
pub(crate) fn darker(c: RGBColor) -> RGBColor {
    let d = |v: u8| (f64::from(v) * 0.55).round() as u8;
    RGBColor(d(c.0), d(c.1), d(c.2))
}

/// Largest magnitude drawn. Beyond it a value is treated like NaN: spans of
/// such values overflow to infinity and cannot be mapped onto pixels.
pub(crate) const LARGEST: f64 = 1e300;

/// Whether `v` can be placed on an axis: finite and at most [`LARGEST`].
pub(crate) fn plottable(v: f64) -> bool {
    v.abs() <= LARGEST
}

/// `[lo, hi]` widened by `frac` of its span on each side. A degenerate range
/// (a single value) is opened up around the value so that axes still have ticks.
pub(crate) fn padded_range(lo: f64, hi: f64, frac: f64) -> (f64, f64) {
    let span = hi - lo;
    if span > 0.0 {
        let pad = span * frac;
        let (a, b) = (lo - pad, hi + pad);
        return if a.is_finite() && b.is_finite() { (a, b) } else { (lo, hi) };
    }
    let half = if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
    (lo - half, lo + half)
}

/// Formats tick values on an axis spanning `[lo, hi]` with as many decimals as
/// the span calls for, switching to scientific notation for very large or very
/// small magnitudes.
pub(crate) fn tick_formatter(lo: f64, hi: f64) -> impl Fn(&f64) -> String {
    let span = (hi - lo).abs().max(f64::MIN_POSITIVE);
    let magnitude = lo.abs().max(hi.abs());
    let scientific = !(1e-3..1e5).contains(&magnitude);
    let decimals = if scientific {
        // Enough mantissa digits to tell neighbouring ticks apart.
        ((magnitude / span).log10().ceil() + 1.0).clamp(1.0, 15.0) as usize
    } else {
        (2.0 - span.log10().floor()).clamp(0.0, 15.0) as usize
    };
    move |v: &f64| {
        let v = *v;
        if v.abs() < span * 1e-9 {
            return "0".to_string();
        }
        if scientific {
            let s = format!("{v:.decimals$e}");
            match s.split_once('e') {
                Some((mantissa, exp)) => format!("{}e{exp}", trim_zeros(mantissa)),
                None => s,
            }
        } else {
            trim_zeros(&format!("{v:.decimals$}")).to_string()
        }
    }
}

fn trim_zeros(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

/// Tick labels an axis over `[lo, hi]` might show, to size its label area.
pub(crate) fn sample_labels(fmt: &impl Fn(&f64) -> String, lo: f64, hi: f64) -> Vec<String> {
    (0..=8).map(|k| fmt(&(lo + (hi - lo) * f64::from(k) / 8.0))).collect()
}

/// The smallest size a title is shrunk to; a title still wider than the figure at this size
/// is clipped at its ends (the caption is centred).
pub(crate) const TITLE_MIN_SIZE: u32 = 12;

/// The title's font size on `area`: [`TITLE_SIZE`], or smaller until the title fits the
/// area's width less its margins (a long title drawn at full size is clipped at both ends,
/// as the CPT study's qc–depth chart's was).
pub(crate) fn title_size<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, title: &str) -> u32 {
    let room = area.dim_in_pixel().0.saturating_sub(2 * MARGIN);
    let mut size = TITLE_SIZE;
    while size > TITLE_MIN_SIZE {
        match area.estimate_text_size(title, &(FONT, size).into()) {
            Ok((w, _)) if w > room => size -= 1,
            _ => break,
        }
    }
    size
}

/// Width in pixels for a y label area holding `labels` and a rotated axis description.
pub(crate) fn y_label_area_width(labels: &[String]) -> u32 {
    let chars = labels.iter().map(|s| s.chars().count()).max().unwrap_or(1);
    // DejaVu Sans digits are about 0.64 em wide.
    let text = (chars as f64 * f64::from(TICK_SIZE) * 0.64).ceil() as u32;
    (text + LABEL_SIZE + 22).max(56)
}

/// Draws a filled, anti-aliased round marker of `radius` pixels centred on
/// pixel `at` of `area`. For raster output, where plotters' own small circles
/// look square; vector output should use `Circle`, which becomes `<circle>`.
pub(crate) fn draw_dot<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    at: (i32, i32),
    radius: f64,
    colour: RGBColor,
) -> Result<(), PlotError> {
    let reach = radius.ceil() as i32 + 1;
    for dy in -reach..=reach {
        for dx in -reach..=reach {
            let dist = f64::from(dx * dx + dy * dy).sqrt();
            let coverage = (radius + 0.5 - dist).clamp(0.0, 1.0);
            if coverage > 0.0 {
                area.draw_pixel((at.0 + dx, at.1 + dy), &colour.mix(coverage)).map_err(super::draw_err)?;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colormap_runs_dark_to_light_and_hits_the_end_stops() {
        assert_eq!(colormap(0.0), RGBColor(68, 1, 84));
        assert_eq!(colormap(1.0), RGBColor(253, 231, 37));
        assert_eq!(colormap(-3.0), colormap(0.0));
        let lum = |c: RGBColor| 0.3 * f64::from(c.0) + 0.59 * f64::from(c.1) + 0.11 * f64::from(c.2);
        let mut last = -1.0;
        for k in 0..=50 {
            let l = lum(colormap(k as f64 / 50.0));
            assert!(l > last, "luminance must increase along the ramp");
            last = l;
        }
    }

    #[test]
    fn padded_range_opens_a_degenerate_range() {
        assert_eq!(padded_range(0.0, 0.0, 0.05), (-1.0, 1.0));
        let (a, b) = padded_range(5.0, 5.0, 0.05);
        assert!(a < 5.0 && b > 5.0);
        let (a, b) = padded_range(0.0, 10.0, 0.05);
        assert!((a + 0.5).abs() < 1e-12 && (b - 10.5).abs() < 1e-12);
    }

    #[test]
    fn tick_labels_are_short_and_switch_to_scientific_at_extremes() {
        let f = tick_formatter(0.0, 1.0);
        assert_eq!(f(&0.2), "0.2");
        assert_eq!(f(&0.30000000000000004), "0.3");
        assert_eq!(f(&5.551115123125783e-17), "0");
        let f = tick_formatter(0.0, 200.0);
        assert_eq!(f(&150.0), "150");
        let f = tick_formatter(0.0, 3.0e7);
        assert_eq!(f(&1.5e7), "1.5e7");
        let f = tick_formatter(0.0, 2.0e-5);
        assert_eq!(f(&1.0e-5), "1e-5");
    }
}
