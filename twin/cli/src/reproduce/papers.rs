//! Each paper of [`crate::papers::PAPERS`] with the module that runs its scenarios.

use super::error::ReproduceError;
use super::report::Report;
use super::{arm, feed_axis, lathe, milling, platform, whitworth};
use framework::Registry;
use std::path::Path;
use twin::Engine;

/// Runs a paper's scenarios (on the engine given, else each scenario's own), recordings into
/// the folder, and compares.
pub type Reproduction = fn(&Path, &Registry, Option<Engine>) -> Result<Report, ReproduceError>;

/// The reproduction of the paper named `name`, if it is one of [`crate::papers::PAPERS`].
pub fn reproduction(name: &str) -> Option<Reproduction> {
    Some(match name {
        "whitworth" => whitworth::run,
        "arm" => arm::run,
        "lathe" => lathe::run,
        "feed-axis" => feed_axis::run,
        "platform" => platform::run,
        "milling" => milling::run,
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::papers::PAPERS;

    #[test]
    fn every_listed_paper_has_its_reproduction() {
        for paper in PAPERS {
            assert!(reproduction(paper.name).is_some(), "{}", paper.name);
        }
        assert!(reproduction("kalman").is_none());
    }
}
