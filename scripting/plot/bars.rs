//! Bar charts: one named bar per category with optional horizontal threshold lines, e.g.
//! the F value of each factor of an ANOVA against the critical F at 0.05 and 0.01.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::chart::CHART_SIZE;
use super::style::{self, FONT};
use super::Figure;
use super::{draw_err, PlotError};

#[derive(Debug, Clone, PartialEq)]
pub struct BarChart {
    pub title: String,
    pub y_label: String,
    /// (category, value); a non-finite value draws no bar and says so in its label.
    pub bars: Vec<(String, f64)>,
    /// (legend name, value): dashed horizontal lines across the chart.
    pub thresholds: Vec<(String, f64)>,
}

impl BarChart {
    pub fn new(title: impl Into<String>, y_label: impl Into<String>) -> Self {
        BarChart { title: title.into(), y_label: y_label.into(), bars: Vec::new(), thresholds: Vec::new() }
    }
}

impl Figure for BarChart {
    const SIZE: (u32, u32) = CHART_SIZE;

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        if self.bars.is_empty() {
            return Err(PlotError::Empty { figure: self.title.clone(), reason: "the chart has no bars".into() });
        }
        let n = self.bars.len() as f64;
        let finite =
            self.bars.iter().map(|b| b.1).chain(self.thresholds.iter().map(|t| t.1)).filter(|v| style::plottable(*v));
        let top = finite.clone().fold(0.0f64, f64::max);
        let bottom = finite.fold(0.0f64, f64::min);
        let (y0, y1) = if top > bottom { (bottom, top + 0.08 * (top - bottom)) } else { (0.0, 1.0) };
        let fmt_y = style::tick_formatter(y0, y1);
        let y_area = style::y_label_area_width(&style::sample_labels(&fmt_y, y0, y1));
        root.fill(&WHITE).map_err(draw_err)?;
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, (FONT, style::title_size(root, &self.title)))
            .margin(style::MARGIN)
            .margin_right(style::MARGIN + 10)
            .x_label_area_size(style::X_LABEL_AREA)
            .y_label_area_size(y_area)
            .build_cartesian_2d(0.0..n, y0..y1)
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(0)
            .y_desc(self.y_label.as_str())
            .y_label_formatter(&fmt_y)
            .y_labels(8)
            .label_style((FONT, style::TICK_SIZE))
            .axis_desc_style((FONT, style::LABEL_SIZE))
            .bold_line_style(BLACK.mix(0.12))
            .light_line_style(BLACK.mix(0.04))
            .draw()
            .map_err(draw_err)?;
        let colour = style::categorical(0);
        for (i, (_, v)) in self.bars.iter().enumerate() {
            if style::plottable(*v) {
                let x = i as f64;
                chart
                    .draw_series(std::iter::once(Rectangle::new([(x + 0.2, 0.0), (x + 0.8, *v)], colour.filled())))
                    .map_err(draw_err)?;
            }
        }
        for (k, (name, t)) in self.thresholds.iter().enumerate() {
            if !style::plottable(*t) {
                continue;
            }
            let c = style::categorical(k + 1);
            chart
                .draw_series(DashedLineSeries::new(vec![(0.0, *t), (n, *t)], 8, 5, c.stroke_width(2)))
                .map_err(draw_err)?
                .label(name.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x - 10, y), (x + 10, y)], c.stroke_width(2)));
        }
        // Category names under the bars, values above them.
        let below = TextStyle::from((FONT, style::TICK_SIZE).into_font()).pos(Pos::new(HPos::Center, VPos::Top));
        let above = TextStyle::from((FONT, style::TICK_SIZE - 2).into_font()).pos(Pos::new(HPos::Center, VPos::Bottom));
        for (i, (name, v)) in self.bars.iter().enumerate() {
            let (px, py) = chart.backend_coord(&(i as f64 + 0.5, y0));
            root.draw(&Text::new(name.clone(), (px, py + 6), below.clone())).map_err(draw_err)?;
            let label = if style::plottable(*v) { format!("{v:.3}") } else { format!("{v}") };
            let (qx, qy) = chart.backend_coord(&(i as f64 + 0.5, if style::plottable(*v) { v.max(0.0) } else { y0 }));
            root.draw(&Text::new(label, (qx, qy - 3), above.clone())).map_err(draw_err)?;
        }
        if !self.thresholds.is_empty() {
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
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

#[cfg(test)]
mod tests {
    use super::super::test_util::{png_size, TempDir};
    use super::*;

    #[test]
    fn f_bars_with_thresholds_render_to_svg_and_png_with_every_name() {
        let mut c = BarChart::new("F of each factor", "F");
        c.bars = vec![("lambda".into(), 12.5), ("mu".into(), 0.8), ("pooled".into(), f64::NAN)];
        c.thresholds = vec![("F 0.05".into(), 6.39), ("F 0.01".into(), 15.98)];
        let svg = c.render_svg().unwrap();
        for text in ["lambda", "mu", "pooled", "F 0.05", "F 0.01", "12.500"] {
            assert!(svg.contains(text), "{text} missing");
        }
        let tmp = TempDir::new("bars");
        let files = c.save(&tmp.0.join("f")).unwrap();
        assert_eq!(files.len(), 2);
        assert_eq!(png_size(&std::fs::read(&files[1]).unwrap()), CHART_SIZE);
        assert!(matches!(BarChart::new("x", "y").render_svg(), Err(PlotError::Empty { .. })));
    }
}
