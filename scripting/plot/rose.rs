//! Rose diagrams: a polar histogram of directions in a plane (contact normals, optionally
//! weighted by their normal force). Directions are axial (n and −n are one contact), so
//! every direction is counted at θ and θ + π and the rose is symmetric.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::style::{self, FONT};
use super::Figure;
use super::{draw_err, PlotError};

/// Size of a rendered rose in pixels.
pub const ROSE_SIZE: (u32, u32) = (640, 680);

/// A rose of `angles` (rad, in the plane's axes) with `weights`, in `bins` sectors over the
/// full circle.
#[derive(Debug, Clone, PartialEq)]
pub struct Rose {
    pub title: String,
    /// Names of the plane's two axes (the horizontal first), e.g. `["x", "z"]`.
    pub axes: [String; 2],
    /// What a sector's length measures, e.g. "contacts" or "Σ normal force [N]".
    pub measure: String,
    pub angles: Vec<f64>,
    pub weights: Vec<f64>,
    pub bins: usize,
}

impl Rose {
    /// Each sector's total over the full circle, both ends of every direction counted.
    pub fn sectors(&self) -> Vec<f64> {
        let tau = std::f64::consts::TAU;
        let bins = self.bins.max(1);
        let mut out = vec![0.0; bins];
        for (&a, &w) in self.angles.iter().zip(&self.weights) {
            if !(a.is_finite() && w.is_finite()) {
                continue;
            }
            for t in [a, a + std::f64::consts::PI] {
                let k = ((t.rem_euclid(tau) / tau) * bins as f64).floor() as usize;
                out[k.min(bins - 1)] += w;
            }
        }
        out
    }
}

impl Figure for Rose {
    const SIZE: (u32, u32) = ROSE_SIZE;

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        let sectors = self.sectors();
        let top = sectors.iter().copied().fold(0.0, f64::max);
        if top.is_nan() || top <= 0.0 {
            return Err(PlotError::Empty { figure: self.title.clone(), reason: "no direction to count".into() });
        }
        root.fill(&WHITE).map_err(draw_err)?;
        let area = root.margin(6, 0, 0, 0).titled(&self.title, (FONT, style::TITLE_SIZE)).map_err(draw_err)?;
        let (w, h) = area.dim_in_pixel();
        let side = w.min(h.saturating_sub(40));
        let (main, rest) = area.split_vertically(side);
        let mut chart = ChartBuilder::on(&main)
            .margin(style::MARGIN + 10)
            .build_cartesian_2d(-1.15..1.15, -1.15..1.15)
            .map_err(draw_err)?;
        let circle = |r: f64| {
            (0..=120).map(move |k| {
                let t = std::f64::consts::TAU * k as f64 / 120.0;
                (r * t.cos(), r * t.sin())
            })
        };
        for r in [0.25, 0.5, 0.75, 1.0] {
            chart
                .draw_series(std::iter::once(PathElement::new(circle(r).collect::<Vec<_>>(), RGBColor(200, 200, 200))))
                .map_err(draw_err)?;
        }
        for (a, b) in [((-1.05, 0.0), (1.05, 0.0)), ((0.0, -1.05), (0.0, 1.05))] {
            chart
                .draw_series(std::iter::once(PathElement::new(vec![a, b], RGBColor(170, 170, 170))))
                .map_err(draw_err)?;
        }
        let n = sectors.len();
        let fill = style::categorical(0);
        for (k, v) in sectors.iter().enumerate() {
            let r = v / top;
            if r <= 0.0 {
                continue;
            }
            let (a0, a1) =
                (std::f64::consts::TAU * k as f64 / n as f64, std::f64::consts::TAU * (k + 1) as f64 / n as f64);
            let mut pts = vec![(0.0, 0.0)];
            for s in 0..=8 {
                let t = a0 + (a1 - a0) * s as f64 / 8.0;
                pts.push((r * t.cos(), r * t.sin()));
            }
            chart.draw_series(std::iter::once(Polygon::new(pts.clone(), fill.mix(0.75).filled()))).map_err(draw_err)?;
            pts.push((0.0, 0.0));
            chart.draw_series(std::iter::once(PathElement::new(pts, style::darker(fill)))).map_err(draw_err)?;
        }
        let label = TextStyle::from((FONT, style::LABEL_SIZE));
        chart
            .draw_series([
                Text::new(self.axes[0].clone(), (1.07, 0.03), label.clone()),
                Text::new(self.axes[1].clone(), (0.03, 1.12), label.clone()),
            ])
            .map_err(draw_err)?;
        let note = format!("outer circle: {} = {:.4e} per {:.0}° sector", self.measure, top, 360.0 / n as f64);
        rest.draw_text(&note, &TextStyle::from((FONT, style::LEGEND_SIZE)), (20, 8)).map_err(draw_err)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sectors_count_both_ends_of_each_direction_and_the_picture_renders() {
        let rose = Rose {
            title: "normals".into(),
            axes: ["x".into(), "z".into()],
            measure: "contacts".into(),
            angles: vec![0.1, std::f64::consts::FRAC_PI_2 + 0.01, 0.1],
            weights: vec![1.0, 1.0, 2.0],
            bins: 4,
        };
        assert_eq!(rose.sectors(), vec![3.0, 1.0, 3.0, 1.0]);
        let svg = rose.render_svg().unwrap();
        assert!(svg.contains("normals") && svg.contains("outer circle"));
        assert!(!rose.render_png().unwrap().is_empty());
        let empty = Rose { weights: vec![0.0; 3], ..rose };
        assert!(matches!(empty.render_svg(), Err(PlotError::Empty { .. })));
    }
}
