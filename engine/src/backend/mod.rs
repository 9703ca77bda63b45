//! Where time steps run. The CPU backend is the f64 reference; the GPU backend (feature
//! `gpu`) runs the same stages as WGSL kernels in f32.

pub mod cpu;
#[cfg(feature = "gpu")]
pub mod gpu;

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
