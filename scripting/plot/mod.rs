//! Figures for simulation results, rendered headlessly to SVG or PNG.
//!
//! - [`LineChart`]: one or more `y(x)` series with markers, a legend and
//!   labelled axes, e.g. a stress–strain curve.
//! - [`ParticlePicture`]: particles drawn as filled circles of their true
//!   radius on equal-scale axes, coloured by a per-particle value through a
//!   perceptual colour map with a colour bar, or through a discrete palette
//!   with a legend when the values are a few integer classes.
//! - [`ForceChainPicture`]: a section with a line per contact, width and colour by force.
//! - [`Rose`]: a polar histogram of directions (contact normals) in a plane.
//!
//! Text uses the DejaVu Sans font compiled into the binary, so rendering needs
//! no system fonts, fontconfig or display. Every figure has `render_svg`,
//! `render_png` and `save`; [`save`](LineChart::save) picks the format from the
//! file extension and writes files atomically (see [`write_atomic`]).

pub mod bars;
pub mod chart;
pub mod force_chains;
pub mod picture;
pub mod rose;
mod style;
pub mod thin;

use plotters::coord::Shift;
use plotters::prelude::{BitMapBackend, DrawingArea, DrawingBackend, IntoDrawingArea, SVGBackend};
use std::path::{Path, PathBuf};

pub use bars::BarChart;
pub use chart::{Gap, LineChart, Series};
pub use force_chains::ForceChainPicture;
pub use picture::ParticlePicture;
pub use rose::Rose;

/// Why a figure could not be rendered or written.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The drawing backend failed.
    #[error("drawing failed: {0}")]
    Draw(String),
    /// The rendered image could not be encoded as PNG.
    #[error("png encoding failed: {0}")]
    Encode(String),
    /// The built-in font could not be loaded.
    #[error("font setup failed: {0}")]
    Font(String),
    /// A figure with nothing in it.
    #[error("nothing to plot in `{figure}`: {reason}")]
    Empty { figure: String, reason: String },
    /// A series (or the particle set) without a single finite point.
    #[error("series `{series}` has no finite points to plot")]
    EmptySeries { series: String },
    /// Parallel data vectors of different lengths.
    #[error("series `{series}` has mismatched lengths: {detail}")]
    LengthMismatch { series: String, detail: String },
    /// `save` was given a file extension it cannot write.
    #[error(
        "cannot save `{}`: unsupported extension `.{ext}`; use .svg, .png, \
         or no extension to write both",
        path.display()
    )]
    UnsupportedExtension { path: PathBuf, ext: String },
    /// A signal cancelled the drawing (the run is stopping).
    #[error("cancelled by a signal")]
    Cancelled,
    /// Reading or writing a file failed.
    #[error("cannot write `{}`: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// Turns any backend error into [`PlotError::Draw`].
pub(crate) fn draw_err(e: impl std::fmt::Display) -> PlotError {
    PlotError::Draw(e.to_string())
}

/// Writes a figure through [`crate::atomic_write::write`] (temporary file, then rename), naming
/// the path when it fails.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), PlotError> {
    crate::atomic_write::write(path, bytes).map_err(|source| PlotError::Io { path: path.to_path_buf(), source })
}

/// A figure that draws itself on any plotters backend at a fixed size: SVG, PNG and `save`
/// come with it.
pub trait Figure {
    /// Width and height in pixels.
    const SIZE: (u32, u32);

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError>;

    fn render_svg(&self) -> Result<String, PlotError> {
        style::ensure_fonts()?;
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, Self::SIZE).into_drawing_area();
            self.draw(&root)?;
            root.present().map_err(draw_err)?;
        }
        Ok(svg)
    }

    fn render_png(&self) -> Result<Vec<u8>, PlotError> {
        style::ensure_fonts()?;
        let (w, h) = Self::SIZE;
        let mut rgb = vec![0u8; w as usize * h as usize * 3];
        {
            let root = BitMapBackend::with_buffer(&mut rgb, Self::SIZE).into_drawing_area();
            self.draw(&root)?;
            root.present().map_err(draw_err)?;
        }
        encode_png(&rgb, w, h)
    }

    /// Writes `.svg` or `.png` by extension, or both without one.
    fn save(&self, path: &Path) -> Result<Vec<PathBuf>, PlotError> {
        save_figure(path, || self.render_svg(), || self.render_png())
    }
}

/// Shared body of every figure's `save`: `.svg` writes SVG, `.png` writes PNG,
/// no extension writes both `<path>.svg` and `<path>.png`. Everything is
/// rendered before anything is written, so a rendering error leaves no files.
pub(crate) fn save_figure(
    path: &Path,
    svg: impl FnOnce() -> Result<String, PlotError>,
    png: impl FnOnce() -> Result<Vec<u8>, PlotError>,
) -> Result<Vec<PathBuf>, PlotError> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    match ext.as_deref() {
        Some("svg") => {
            write_atomic(path, svg()?.as_bytes())?;
            Ok(vec![path.to_path_buf()])
        }
        Some("png") => {
            write_atomic(path, &png()?)?;
            Ok(vec![path.to_path_buf()])
        }
        None => {
            let (svg, png) = (svg()?, png()?);
            let with = |ext: &str| {
                let mut p = path.as_os_str().to_owned();
                p.push(".");
                p.push(ext);
                PathBuf::from(p)
            };
            let (svg_path, png_path) = (with("svg"), with("png"));
            write_atomic(&svg_path, svg.as_bytes())?;
            write_atomic(&png_path, &png)?;
            Ok(vec![svg_path, png_path])
        }
        Some(other) => Err(PlotError::UnsupportedExtension { path: path.to_path_buf(), ext: other.to_string() }),
    }
}

/// One palette of 256 colours for every frame of a movie (a GIF holds at most 256 colours a
/// frame): 128 steps of the colour map, their outline shades, the class colours, "no value"
/// and 64 greys for text, axes and the white background. Fixed rather than chosen per frame,
/// so a colour is the same in every frame and no frame pays for choosing one (NeuQuant took
/// about 60 ms a frame).
pub struct GifPalette {
    /// r, g, b of each entry.
    pub rgb: Vec<u8>,
    /// Palette index of each colour bucket (6 bits a channel), worked out when first needed;
    /// `u16::MAX` for not yet.
    nearest: Vec<u16>,
}

impl Default for GifPalette {
    fn default() -> Self {
        let mut colours: Vec<plotters::style::RGBColor> = Vec::with_capacity(256);
        colours.extend((0..128).map(|k| style::colormap(k as f64 / 127.0)));
        colours.extend((0..48).map(|k| style::darker(style::colormap(k as f64 / 47.0))));
        colours.extend((0..10).map(style::categorical));
        colours.extend((0..10).map(|k| style::darker(style::categorical(k))));
        colours.push(style::NO_DATA);
        colours.push(style::darker(style::NO_DATA));
        let greys = 256 - colours.len();
        colours.extend((0..greys).map(|k| {
            let v = (k * 255 / (greys - 1)) as u8;
            plotters::style::RGBColor(v, v, v)
        }));
        GifPalette { rgb: colours.iter().flat_map(|c| [c.0, c.1, c.2]).collect(), nearest: vec![u16::MAX; 1 << 18] }
    }
}

impl GifPalette {
    /// Each pixel of a packed RGB buffer as the index of the nearest palette colour (to the
    /// centre of its bucket, so the answer does not depend on which pixel came first).
    pub fn indices(&mut self, rgb: &[u8]) -> Vec<u8> {
        let GifPalette { rgb: palette, nearest } = self;
        rgb.chunks_exact(3)
            .map(|p| {
                let bucket = (usize::from(p[0] >> 2) << 12) | (usize::from(p[1] >> 2) << 6) | usize::from(p[2] >> 2);
                if nearest[bucket] == u16::MAX {
                    let centre = [p[0] & !3 | 2, p[1] & !3 | 2, p[2] & !3 | 2].map(i32::from);
                    let distance = |c: &[u8]| -> i32 { (0..3).map(|k| (i32::from(c[k]) - centre[k]).pow(2)).sum() };
                    let best =
                        palette.chunks_exact(3).enumerate().min_by_key(|(_, c)| distance(c)).map_or(0, |(k, _)| k);
                    nearest[bucket] = best as u16;
                }
                nearest[bucket] as u8
            })
            .collect()
    }
}

/// Encodes a packed RGB buffer as PNG.
pub(crate) fn encode_png(rgb: &[u8], width: u32, height: u32) -> Result<Vec<u8>, PlotError> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(rgb, width, height, image::ColorType::Rgb8)
        .map_err(|e| PlotError::Encode(e.to_string()))?;
    Ok(out)
}

#[cfg(test)]
pub(crate) mod test_util {
    use std::path::PathBuf;
    use std::sync::atomic::{AtomicU64, Ordering};

    /// A fresh, empty folder under the system temp dir, removed on drop.
    pub(crate) struct TempDir(pub PathBuf);

    impl TempDir {
        pub(crate) fn new(tag: &str) -> Self {
            static N: AtomicU64 = AtomicU64::new(0);
            let dir = std::env::temp_dir().join(format!(
                "matdem-plot-{tag}-{}-{}",
                std::process::id(),
                N.fetch_add(1, Ordering::Relaxed)
            ));
            let _ = std::fs::remove_dir_all(&dir);
            std::fs::create_dir_all(&dir).unwrap();
            TempDir(dir)
        }

        /// Names of the files in the folder, sorted.
        pub(crate) fn listing(&self) -> Vec<String> {
            let mut names: Vec<String> = std::fs::read_dir(&self.0)
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect();
            names.sort();
            names
        }
    }

    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    /// Width and height of a PNG, decoded for real.
    pub(crate) fn png_size(bytes: &[u8]) -> (u32, u32) {
        assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"), "missing PNG signature");
        let img = image::load_from_memory_with_format(bytes, image::ImageFormat::Png).expect("PNG decodes");
        (img.width(), img.height())
    }
}

#[cfg(test)]
mod tests {
    use super::test_util::TempDir;
    use super::*;
    use std::fs;

    #[test]
    fn write_atomic_reports_the_path_when_it_cannot_write() {
        let tmp = TempDir::new("atomic-err");
        // A file standing where a folder is needed.
        fs::write(tmp.0.join("blocker"), b"x").unwrap();
        let path = tmp.0.join("blocker/out.txt");
        let err = write_atomic(&path, b"data").unwrap_err();
        assert!(matches!(err, PlotError::Io { .. }));
        assert!(err.to_string().contains("out.txt"), "{err}");
    }

    #[test]
    fn save_rejects_unknown_extensions_naming_the_supported_ones() {
        let err = save_figure(Path::new("figure.jpg"), || Ok(String::new()), || Ok(Vec::new())).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains(".jpg") && msg.contains(".svg") && msg.contains(".png"), "{msg}");
    }
}
