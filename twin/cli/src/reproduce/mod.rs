//! `twin reproduce <paper>`: each seed paper's claims next to the twin's own figures.
//!
//! A paper's module runs its scenarios (every recording into one folder) and returns a
//! [`Report`]: one row per claim with the paper's figure, the twin's figure and a verdict.

mod arm;
mod command;
mod error;
mod feed_axis;
pub mod lathe;
mod milling;
mod papers;
mod platform;
mod report;
mod scenarios;
mod whitworth;

pub use command::{reproduce, run, to_table, ReproduceArgs};
pub use error::ReproduceError;
pub use report::{Claim, Report, Verdict};
