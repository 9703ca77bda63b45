//! Animations of a run (MatDEM: `fs.movie2gif`): `d.movie_every(steps, field, name)` takes a
//! particle picture coloured by `field` every `steps` steps of the model's runs and balances,
//! and `d.movie_end()` (or the end of the script) writes them as the animated GIF `name.gif`.
//!
//! **One colour scale and one view for every frame.** A frame's colours mean the same in every
//! frame: the scale runs from the smallest to the largest value of the field over *all* the
//! frames (or over `range` when the script gives one), and the view holds every particle of
//! every frame. Taking the scale from the first frame would make a movie of `dz` or `speed`
//! unreadable (both start at zero everywhere), so the frames are drawn when the movie ends,
//! from a spool.
//!
//! **Memory stays bounded.** Each frame's particles (x, z, r and the value, 32 bytes each) are
//! appended to a hidden spool file in the output folder, `.NAME.gif.frames`, as they are
//! taken; at the end the spool is read twice, one frame at a time — once for the scale and
//! the view, once to draw each frame and stream it into the GIF encoder. Nothing holds more
//! than one frame.
//!
//! **One palette.** Every frame uses one fixed palette of 256 colours
//! ([`crate::plot::GifPalette`]): a colour is the same in every frame, and no frame pays for
//! choosing its own (a frame costs about 20 ms to draw, map and encode at 800 × 700).
//!
//! **Atomic, and an interrupted run keeps what it took.** The GIF is written to a temporary
//! file and renamed into place ([`crate::atomic_write::write_with`]), so `name.gif` is always whole.
//! A run stopped by Ctrl-C or SIGTERM (or failing) still ends its movies: the GIF holds the
//! frames taken so far. An interrupted run keeps the spool beside its resume point, and the
//! movie's state travels in the checkpoint, so `--resume` continues the same movie and ends
//! with the GIF an uninterrupted run writes. (SIGKILL leaves the previous `name.gif`, if any,
//! and the spool.)

use crate::eoutln;
use crate::plot::picture::{FixedBuilder, PICTURE_SIZE};
use crate::plot::ParticlePicture;
use matdem_engine::plan::StepPlan;
use matdem_engine::Model;
use serde::{Deserialize, Serialize};
use std::fs;
use std::io::{BufReader, Read, Seek, Write};
use std::path::PathBuf;

/// Frames a movie takes unless told otherwise (about 30–45 kB each in the GIF).
pub const DEFAULT_MAX_FRAMES: u64 = 200;
/// Time each frame is shown, in hundredths of a second (GIF's unit), unless told otherwise.
pub const DEFAULT_DELAY_CS: u16 = 10;

/// What a movie takes and where it goes, fixed when the script starts it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MovieSettings {
    /// Steps of the model's clock between frames (≥ 1).
    pub every: u64,
    /// The field the particles are coloured by (one of
    /// [`crate::picture_fields::PICTURE_FIELDS`]), and its label with units.
    pub field: String,
    pub label: String,
    /// The model's name, for the frames' titles.
    pub model: String,
    /// Only the particles within this distance of the mid-plane in y (m).
    pub slice: Option<f64>,
    /// Also write each frame as a PNG into `frames_dir`.
    pub frames_png: bool,
    /// Frames after this many are left out (with a warning).
    pub max_frames: u64,
    /// Time each frame is shown (1/100 s).
    pub delay_cs: u16,
    /// The colour scale (lo, hi) instead of the frames' own range.
    pub range: Option<(f64, f64)>,
    /// Resolved when the movie was started (through the host's output resolver).
    pub gif: PathBuf,
    pub spool: PathBuf,
    pub frames_dir: PathBuf,
}

/// A model's movie: its state, and the end it is given when its model goes away.
#[derive(Debug, Default)]
pub struct Movie {
    pub state: MovieState,
}

/// A movie's settings while one is being taken, and how far it has got. Travels in the model's
/// checkpoint, so a resumed run continues it.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct MovieState {
    pub settings: Option<MovieSettings>,
    /// Frames in the spool.
    pub frames: u64,
    /// Bytes of the spool holding them.
    pub spool_len: u64,
    /// Frames left out past `max_frames`.
    pub left_out: u64,
}

/// Bytes of a frame's header in the spool: the step, the time (f64 bits) and the particle count.
const FRAME_HEADER: usize = 24;

impl Movie {
    /// Whether a movie is being taken.
    pub fn is_on(&self) -> bool {
        self.state.settings.is_some()
    }

    /// Takes a frame of `m` (the observer's call, every `every` steps).
    pub fn capture(&mut self, m: &Model) -> Result<(), String> {
        self.state.capture(m)
    }

    /// See [`MovieState::finish`].
    pub fn finish(&mut self, keep_spool: bool) -> Result<Vec<PathBuf>, String> {
        self.state.finish(keep_spool)
    }
}

impl MovieState {
    /// Takes a frame of `m` (the observer's call, every `every` steps).
    pub fn capture(&mut self, m: &Model) -> Result<(), String> {
        let Some(s) = &self.settings else { return Ok(()) };
        if self.frames >= s.max_frames {
            if self.left_out == 0 {
                eoutln!(
                    "warning: movie `{}`: {} frames taken (its max_frames); the later ones are left out — take them less \
                     often or give a larger max_frames",
                    crate::terminal_text::one_line(&file_name(&s.gif)),
                    s.max_frames
                );
            }
            self.left_out += 1;
            return Ok(());
        }
        let (values, _) = crate::picture_fields::field_values(m, &s.field, |m| {
            matdem_engine::status::contact_loads(m, &StepPlan::build(m))
        })?;
        let keep = crate::picture_fields::pictured(m, s.slice);
        let p = &m.particles;
        let mut bytes = Vec::with_capacity(FRAME_HEADER + 32 * keep.len());
        bytes.extend_from_slice(&m.clock.step.to_le_bytes());
        bytes.extend_from_slice(&m.clock.time.to_le_bytes());
        bytes.extend_from_slice(&(keep.len() as u64).to_le_bytes());
        for &i in &keep {
            for v in [p.pos[i].x, p.pos[i].z, p.radius[i], values[i]] {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
        let spool = &s.spool;
        let fail = |e: std::io::Error| format!("movie: cannot write its frames to {}: {e}", spool.display());
        // The first frame starts the spool afresh; later ones append to what is counted.
        let mut file = fs::OpenOptions::new().create(true).write(true).truncate(false).open(spool).map_err(fail)?;
        file.set_len(self.spool_len).map_err(fail)?;
        file.seek(std::io::SeekFrom::Start(self.spool_len)).map_err(fail)?;
        file.write_all(&bytes).map_err(fail)?;
        self.spool_len += bytes.len() as u64;
        self.frames += 1;
        Ok(())
    }

    /// Ends the movie: writes the GIF (and the frames as PNG, if asked) of the frames taken,
    /// and returns what it wrote — nothing when no frame was taken (a replayed part of a
    /// resumed run takes none, and leaves the files of the interrupted run as they are).
    /// `keep_spool` keeps the frames for a resume. Either way the movie is over.
    pub fn finish(&mut self, keep_spool: bool) -> Result<Vec<PathBuf>, String> {
        let Some(s) = self.settings.take() else { return Ok(Vec::new()) };
        let frames = std::mem::take(&mut self.frames);
        let spool_len = std::mem::take(&mut self.spool_len);
        self.left_out = 0;
        if frames == 0 {
            return Ok(Vec::new());
        }
        let written = write_gif(&s, frames, spool_len);
        if !keep_spool {
            let _ = fs::remove_file(&s.spool);
        }
        written
    }

    /// After a resume restored this movie from a checkpoint: checks that its spool still
    /// holds the frames counted (else starts the movie over, saying so).
    pub fn reopen(&mut self) {
        let Some(s) = &self.settings else { return };
        let held = fs::metadata(&s.spool).map(|m| m.len()).unwrap_or(0);
        if held < self.spool_len {
            eoutln!(
                "warning: movie `{}`: the frames taken before the interruption are gone ({} is missing or short); it \
                 starts again from here",
                crate::terminal_text::one_line(&file_name(&s.gif)),
                s.spool.display()
            );
            self.frames = 0;
            self.spool_len = 0;
        }
    }
}

impl Drop for Movie {
    /// A movie whose model goes away (the end of a REPL session, a model local to a
    /// function) is ended, so its frames are not lost.
    fn drop(&mut self) {
        if self.is_on() {
            if let Err(e) = self.finish(false) {
                eoutln!("warning: {}", crate::terminal_text::one_line(&e));
            }
        }
    }
}

fn file_name(p: &std::path::Path) -> String {
    p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
}

/// One frame read back from the spool.
struct Frame {
    step: u64,
    time: f64,
    /// x, z, r, value per particle.
    particles: Vec<[f64; 4]>,
}

/// Reads the spool's frames one at a time.
struct Spool {
    reader: BufReader<fs::File>,
    /// Bytes of counted frames not read yet.
    left: u64,
}

impl Spool {
    fn open(s: &MovieSettings, len: u64) -> Result<Spool, String> {
        let file = fs::File::open(&s.spool)
            .map_err(|e| format!("movie: cannot read its frames from {}: {e}", s.spool.display()))?;
        Ok(Spool { reader: BufReader::new(file), left: len })
    }

    fn next(&mut self) -> Result<Frame, String> {
        let corrupt = |why: String| format!("movie: its frame spool is damaged ({why}); run the script again");
        let mut head = [0u8; FRAME_HEADER];
        if self.left < FRAME_HEADER as u64 {
            return Err(corrupt("a frame is cut short".into()));
        }
        self.reader.read_exact(&mut head).map_err(|e| corrupt(e.to_string()))?;
        let word = |k: usize| u64::from_le_bytes(head[8 * k..8 * k + 8].try_into().expect("8 bytes"));
        let n = word(2);
        self.left -= FRAME_HEADER as u64;
        if n.checked_mul(32).is_none_or(|b| b > self.left) {
            return Err(corrupt("a frame is cut short".into()));
        }
        self.left -= 32 * n;
        let n = n as usize;
        let mut body = vec![0u8; 32 * n];
        self.reader.read_exact(&mut body).map_err(|e| corrupt(e.to_string()))?;
        let num = |k: usize| f64::from_le_bytes(body[8 * k..8 * k + 8].try_into().expect("8 bytes"));
        let particles = (0..n).map(|i| [num(4 * i), num(4 * i + 1), num(4 * i + 2), num(4 * i + 3)]).collect();
        Ok(Frame { step: word(0), time: f64::from_bits(word(1)), particles })
    }
}

/// Draws the spool's `frames` with one scale and view and writes them as `s.gif` (and the
/// PNG frames, if asked); returns the files written.
fn write_gif(s: &MovieSettings, frames: u64, spool_len: u64) -> Result<Vec<PathBuf>, String> {
    // Pass 1: the scale and the view of every frame.
    let mut fixed = FixedBuilder::default();
    let mut spool = Spool::open(s, spool_len)?;
    for _ in 0..frames {
        for [x, z, r, v] in spool.next()?.particles {
            fixed.add(x, z, r, v);
        }
    }
    let Some(fixed) = fixed.build(s.range) else {
        return Err(format!("movie `{}`: no frame has a particle to draw", file_name(&s.gif)));
    };
    // Pass 2: each frame drawn and streamed into the encoder.
    let (w, h) = PICTURE_SIZE;
    let mut spool = Spool::open(s, spool_len)?;
    let mut pngs = Vec::new();
    let mut failure = None;
    let gif_err = |e: gif::EncodingError| std::io::Error::other(e.to_string());
    crate::atomic_write::write_with(&s.gif, |file| {
        let mut out = std::io::BufWriter::new(file);
        let mut palette = crate::plot::GifPalette::default();
        let mut encoder = gif::Encoder::new(&mut out, w as u16, h as u16, &palette.rgb).map_err(gif_err)?;
        encoder.set_repeat(gif::Repeat::Infinite).map_err(gif_err)?;
        for _ in 0..frames {
            let frame = spool.next().map_err(std::io::Error::other)?;
            let mut pic = ParticlePicture::new(
                format!(
                    "{} — step {}, t = {:.4e} s",
                    crate::picture_fields::picture_title(&s.model, &s.label, s.slice),
                    frame.step,
                    frame.time
                ),
                s.label.clone(),
            );
            pic.x_label = "x [m]".into();
            pic.y_label = "z [m]".into();
            for [x, z, r, v] in frame.particles {
                pic.push(x, z, r, v);
            }
            let rgb = match pic.render_rgb(Some(&fixed)) {
                Ok(rgb) => rgb,
                Err(e) => {
                    failure = Some(format!("movie `{}`: frame at step {}: {e}", file_name(&s.gif), frame.step));
                    return Err(std::io::Error::other("drawing failed"));
                }
            };
            if s.frames_png {
                let png = crate::plot::encode_png(&rgb, w, h).map_err(std::io::Error::other)?;
                let path = s.frames_dir.join(format!("{}_{:09}.png", gif_stem(s), frame.step));
                crate::atomic_write::write(&path, &png)?;
                pngs.push(path);
            }
            // The movie's one palette (see GifPalette): the same colours in every frame.
            let mut gif_frame = gif::Frame::from_indexed_pixels(w as u16, h as u16, palette.indices(&rgb), None);
            gif_frame.delay = s.delay_cs;
            encoder.write_frame(&gif_frame).map_err(gif_err)?;
        }
        encoder.into_inner().map_err(gif_err)?;
        out.flush()
    })
    .map_err(|e| failure.take().unwrap_or_else(|| format!("movie: cannot write {}: {e}", s.gif.display())))?;
    let mut written = vec![s.gif.clone()];
    written.extend(pngs);
    Ok(written)
}

/// The GIF's name without `.gif`.
fn gif_stem(s: &MovieSettings) -> String {
    s.gif.file_stem().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
}
