//! The report page: `index.html` in every run folder and every sweep folder, so a result can
//! be read in a browser without a terminal — the run record, the plan, what the run reported,
//! every chart (SVG inline; one over 2 MB linked instead), particle pictures, tables and the files written. One file with
//! no network access needed: styles inline, images by relative path beside it.
//!
//! A run's page is [`write_run_page`]; a sweep's is written by the sweep (`sweep::page`),
//! from the same parts (`html`), as this module sits below the workflows.
//!
//! The page checks itself: a few lines of inline script mark `<body data-images>` with how
//! many images loaded and how many did not, which the headless-browser test reads.

pub(crate) mod html;
mod run_page;

pub use run_page::{write_run_page, RunSummary};

/// The page's file name, which the sandbox keeps for the host.
pub use crate::sandbox::PAGE_FILE;
