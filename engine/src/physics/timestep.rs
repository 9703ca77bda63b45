//! Time-step estimates. MatDEM's standard step is a fraction of the smallest element
//! period T = 2π·√(m/k); the explicit integrator is stable for a single spring of an
//! element between two contacts up to dt = 2/ω with ω = √(2k/m), i.e. T/(√2·π).

/// The most sub-steps a field stage (conduction, moisture, pore flow) may take within one
/// step. Far above what a scene needs (the examples use up to 5,000, stiff test columns a
/// million as a ceiling), it keeps a forged checkpoint or a typo (4e9) from making one step
/// run for hours without hearing a signal.
pub const MAX_SUBSTEPS: u32 = 1_000_000;

/// MatDEM's standard time step: this fraction of the smallest element period.
pub const STANDARD_FRACTION: f64 = 1.0 / 50.0;

/// Element period 2π·√(m/k) (s).
pub fn element_period(mass: f64, stiffness: f64) -> f64 {
    2.0 * std::f64::consts::PI * (mass / stiffness).sqrt()
}

/// The largest stable step for an element of this mass and stiffness (s).
pub fn critical_step(mass: f64, stiffness: f64) -> f64 {
    element_period(mass, stiffness) / (std::f64::consts::SQRT_2 * std::f64::consts::PI)
}
