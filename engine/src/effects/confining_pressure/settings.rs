//! The confining pressure's settings (the `confining_pressure` stage), its state in the model
//! (`state.rs`); the model-level calls are in `mod.rs`.

use serde::{Deserialize, Serialize};

/// The most cells a membrane may have (each is three words on the device).
pub const MAX_CELLS: usize = 1 << 20;

/// A confining pressure on the side of a vertical cylindrical sample between two platens, as a
/// triaxial cell's membrane and water apply it: off until a script confines the sample.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Confinement {
    /// The cell pressure σ3 (Pa, > 0).
    pub pressure: f64,
    /// (x, y) of the sample's vertical axis (m).
    pub axis: [f64; 2],
    /// The plane walls below and above the sample (their normals along ±z): the membrane spans
    /// the height between them, wherever they move.
    pub bottom: String,
    pub top: String,
    /// The membrane's cells: bands along the height, sectors around the axis.
    pub bands: u32,
    pub sectors: u32,
}
