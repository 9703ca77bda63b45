//! Force chain pictures: a section of the packing with a line between the centres of each
//! pair in contact, its width and colour by the contact's normal force, the elements as
//! faint outlines and the walls as dark lines.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::picture::{equal_scale, plot_builder, section_axes, PICTURE_SIZE};
use super::style::{self, FONT};
use super::Figure;
use super::{draw_err, PlotError};

/// Widest chain line, in pixels (the largest force); the smallest drawn is 1 px.
const MAX_WIDTH: f64 = 9.0;

/// One chain: the two centres in the picture's plane and the normal force (N).
pub type Chain = ((f64, f64), (f64, f64), f64);

/// A force chain picture in the plane of its two axes.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ForceChainPicture {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    /// Elements of the section: (x, y, r).
    pub elements: Vec<(f64, f64, f64)>,
    /// Chains: the two centres and the normal force (N, compression > 0).
    pub chains: Vec<Chain>,
    /// Wall sections as segments.
    pub walls: Vec<((f64, f64), (f64, f64))>,
}

impl Figure for ForceChainPicture {
    const SIZE: (u32, u32) = PICTURE_SIZE;

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        if self.elements.is_empty() {
            return Err(PlotError::Empty { figure: self.title.clone(), reason: "no element in the section".into() });
        }
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for &(x, y, r) in &self.elements {
            (x0, x1, y0, y1) = (x0.min(x - r), x1.max(x + r), y0.min(y - r), y1.max(y + r));
        }
        let pad = 0.03 * (x1 - x0).max(y1 - y0);
        let ((x0, x1), (y0, y1)) = ((x0 - pad, x1 + pad), (y0 - pad, y1 + pad));
        root.fill(&WHITE).map_err(draw_err)?;
        let area = root.margin(6, 0, 0, 0).titled(&self.title, (FONT, style::TITLE_SIZE)).map_err(draw_err)?;
        let (area_w, _) = area.dim_in_pixel();
        let (main, side) = area.split_horizontally(area_w.saturating_sub(150));
        let y_area = 70;
        let ((x0, x1), (y0, y1)) = equal_scale(&main, y_area, (x0, x1), (y0, y1))?;
        let mut chart = plot_builder(&main, y_area).build_cartesian_2d(x0..x1, y0..y1).map_err(draw_err)?;
        section_axes(&mut chart, &self.x_label, &self.y_label, (x0, x1), (y0, y1))?;
        let (xs, _) = chart.plotting_area().get_pixel_range();
        let scale = f64::from(xs.end - xs.start) / (x1 - x0);
        let faint = RGBColor(205, 205, 205);
        chart
            .draw_series(
                self.elements
                    .iter()
                    .map(|&(x, y, r)| Circle::new((x, y), ((r * scale).round() as i32).max(1), faint.stroke_width(1))),
            )
            .map_err(draw_err)?;
        for &(a, b) in &self.walls {
            chart
                .draw_series(std::iter::once(PathElement::new(vec![a, b], BLACK.stroke_width(3))))
                .map_err(draw_err)?;
        }
        let top = self.chains.iter().map(|c| c.2).fold(0.0, f64::max);
        let mut order: Vec<&Chain> = self.chains.iter().filter(|c| c.2 > 0.0).collect();
        // The strongest on top.
        order.sort_by(|a, b| a.2.total_cmp(&b.2));
        for &(a, b, f) in order {
            let t = f / top;
            let width = (1.0 + (MAX_WIDTH - 1.0) * t).round() as u32;
            let colour = style::colormap(t);
            chart
                .draw_series(std::iter::once(PathElement::new(vec![a, b], colour.stroke_width(width))))
                .map_err(draw_err)?;
        }
        chart.plotting_area().draw(&Rectangle::new([(x0, y0), (x1, y1)], BLACK.stroke_width(1))).map_err(draw_err)?;
        // The key: the colour ramp with the widths at 0, ½ and the largest force.
        let text = TextStyle::from((FONT, style::LEGEND_SIZE));
        side.draw_text("normal force", &TextStyle::from((FONT, style::LABEL_SIZE)), (10, 20)).map_err(draw_err)?;
        for (k, t) in [1.0, 0.5, 0.1].into_iter().enumerate() {
            let y = 60 + 36 * k as i32;
            let width = (1.0 + (MAX_WIDTH - 1.0) * t).round() as u32;
            side.draw(&PathElement::new(vec![(10, y), (50, y)], style::colormap(t).stroke_width(width)))
                .map_err(draw_err)?;
            side.draw_text(&format!("{:.3e} N", t * top), &text, (58, y - 8)).map_err(draw_err)?;
        }
        side.draw_text(&format!("{} chains", self.chains.len()), &text, (10, 60 + 36 * 3)).map_err(draw_err)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_force_chain_picture_renders_its_chains_walls_and_key() {
        let pic = ForceChainPicture {
            title: "chains".into(),
            x_label: "x [m]".into(),
            y_label: "z [m]".into(),
            elements: vec![(0.0, 0.0, 0.5), (1.0, 0.0, 0.5), (0.5, 0.87, 0.5)],
            chains: vec![((0.0, 0.0), (1.0, 0.0), 2.0), ((0.0, 0.0), (0.5, 0.87), 1.0)],
            walls: vec![((-0.6, -0.5), (1.6, -0.5))],
        };
        let svg = pic.render_svg().unwrap();
        assert!(svg.contains("chains") && svg.contains("normal force") && svg.contains("2.000e0 N"), "{svg}");
        assert!(!pic.render_png().unwrap().is_empty());
        assert!(matches!(ForceChainPicture::default().render_svg(), Err(PlotError::Empty { .. })));
    }
}
