//! The report page: `index.html` in every run folder and every sweep folder, so a result can
//! be read in a browser without a terminal — the run record, the plan, what the run reported,
//! every chart (SVG inline; one over 2 MB linked instead), particle pictures, tables and the files written. One file with
//! no network access needed: styles inline, images by relative path beside it.
//!
//! The page checks itself: a few lines of inline script mark `<body data-images>` with how
//! many images loaded and how many did not, which the headless-browser test reads.

mod html;
mod run;
mod sweep;

pub use run::{write_run_page, RunSummary};
pub use sweep::write_sweep_page;

/// The page's file name.
pub const PAGE_FILE: &str = "index.html";
