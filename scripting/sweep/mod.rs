//! Sweeps: one script or package run at many parameter sets, kept as a folder.
//!
//! ```text
//! SWEEP/sweep.ron          the plan: source and its SHA-256, backend, fixed parameters,
//!                          the design (a grid, or runs given one by one), every point's parameters
//! SWEEP/run01/ …           each point's run folder: the output folder of its `matdem-rs run`
//! SWEEP/outcomes/run01.ron how each point ended (ok, failed with its error, interrupted), its
//!                          wall time and host — written by the host after the run, outside the
//!                          run folder, so a script cannot forge it
//! SWEEP/sweep.sbatch       the Slurm job array (`sweep slurm`), one array task per point
//! SWEEP/sweep.csv          the merged table (`sweep collect`); timings.csv beside it
//! ```
//!
//! The folder is the only state: `sweep run --local`, Slurm's array tasks and `sweep status`
//! all read and write it, never a scheduler's database. A point with an outcome of `ok` or
//! `failed` is finished and skipped by the next run; one without an outcome, or interrupted,
//! is pending (an interrupted point resumes from its run's resume point).
//!
//! A calibration or any other design hands its runs over as plain parameter sets:
//! [`plan_runs`], then [`run_local`], then [`collect::results`].

pub mod collect;
mod digest;
pub mod local;
pub mod page;
pub mod plan;
pub mod point;
pub mod slurm;

pub use collect::{results, PointResult};
pub use local::{run_local, run_local_held, LocalOptions};
pub use plan::{load, plan, plan_grid, plan_runs, read_runs_csv, Design, PlanRequest, PlannedPoint, SweepPlan};
pub use point::{Outcome, PointStatus};
