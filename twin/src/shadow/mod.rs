//! The twin beside a running machine: fed the machine's commands and measurements as they
//! arrive (late, irregular, out of order, duplicated), it keeps an estimate of the machine's
//! state and of the parameters it tracks with an extended Kalman filter on its own model
//! ([`filter`]), tests the normalised innovations for anomalies ([`detector`]) and names the
//! parameter that explains one.
//!
//! Samples carry their source timestamps. They wait in an intake for `latency` seconds behind
//! the newest one, so that those arriving out of order within it are processed in time order;
//! one older than what has been processed is counted late and dropped, and a repeated one
//! (same signal, same time) is counted and dropped.

mod detector;
mod error;
mod filter;
mod intake;
mod model;
mod options;
mod record;
mod watch;

pub use detector::{AnomalyChange, DetectorView};
pub use error::ShadowError;
pub use filter::Innovation;
pub use options::{ShadowOptions, TrackedParameter, DEFAULT_PROCESS_NOISE};
pub use record::{describe, ShadowRecording};
pub use watch::{Anomaly, Attribution, IntakeCounts, Shadow, ShadowStep, MAX_GAP};
