//! The twin beside a running machine: a [`Shadow`] fed the machine's commands and measurements
//! as they arrive (late, irregular, out of order, duplicated) estimates its state and the
//! parameters it tracks with an extended Kalman filter on the twin's own model (`filter`), tests
//! the normalised innovations (`detector`) and raises [`Anomaly`] events, named after the
//! parameter that explains them.
//!
//! Samples carry their source timestamps. They wait in an intake for `latency` seconds behind
//! the newest one, so that those arriving out of order within it are processed in time order;
//! one older than what has been processed is counted late and dropped, and a repeated one
//! (same signal, same time) is counted and dropped. This file only declares the modules and
//! re-exports what the library shows.

mod anomaly;
mod detector;
mod error;
mod filter;
mod intake;
mod model;
mod options;
mod record;
mod student;
mod watch;

pub use anomaly::{Anomaly, Attribution};
pub use detector::{AnomalyChange, DetectorView};
pub use error::ShadowError;
pub use filter::Innovation;
pub use intake::IntakeCounts;
pub use options::{ShadowOptions, TrackedParameter, DEFAULT_PROCESS_NOISE};
pub use record::{describe, ShadowRecording};
pub use watch::{Shadow, ShadowStep, MAX_GAP};
