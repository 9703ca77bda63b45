//! Material training (paper 003 §3.1, appendix A): a packed, bonded sample, the numerical
//! tests that measure its macro properties, and the loop that corrects micro parameters
//! until the sample shows the target E, ν, Tu, Cu and μi.

pub mod dimension;
pub mod fit;
pub mod lab_tests;
pub mod sample;
pub mod train;

pub use dimension::Dimension;
pub use lab_tests::{run_test, CurvePoint, LabTest, Loading, TestResult};
pub use sample::{PackedSample, SampleSpec};
pub use train::{measure, train, validate_targets, Round, Tolerances, TrainOptions, TrainedMaterial, Training};
