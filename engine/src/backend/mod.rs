//! Where time steps run. The CPU backend is the f64 reference.

pub mod cpu;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Lets a host cancel a long run between steps (Ctrl-C) and watch its progress.
#[derive(Clone, Default)]
pub struct RunControl {
    pub cancel: Arc<AtomicBool>,
}

impl RunControl {
    pub fn is_cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }
}
