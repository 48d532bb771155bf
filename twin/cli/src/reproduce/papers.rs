//! The papers `twin reproduce` knows, each with the module that runs its scenarios.

use super::error::ReproduceError;
use super::report::Report;
use super::{arm, feed_axis, lathe, milling, platform, whitworth};
use framework::Registry;
use std::path::Path;
use twin::Engine;

/// A paper `twin reproduce` knows.
pub struct Paper {
    pub name: &'static str,
    pub summary: &'static str,
    /// Runs the paper's scenarios (on the engine given, else each scenario's own), recordings
    /// into the folder, and compares.
    pub run: fn(&Path, &Registry, Option<Engine>) -> Result<Report, ReproduceError>,
    /// Whether `--engine` can choose its engine (not when an analysis builds its scenarios).
    pub any_engine: bool,
}

/// Every paper, in the order `twin list` shows them.
pub const PAPERS: &[Paper] = &[
    Paper {
        name: "whitworth",
        summary: "Perrusquía et al. 2022: task-space OSMC for constant-velocity cutting on a Whitworth shaper",
        run: whitworth::run,
        any_engine: true,
    },
    Paper {
        name: "arm",
        summary: "Ilyukhin et al. 2014: machining robot, path speed corrected from motor currents",
        run: arm::run,
        any_engine: true,
    },
    Paper {
        name: "lathe",
        summary: "Sudhakara & Landers 2003: parallel turning power loop, its equilibria and region of attraction",
        run: lathe::run,
        any_engine: false,
    },
    Paper {
        name: "feed-axis",
        summary: "Rubio, Ibeas & Luo: P-PI vs super-twisting SMC on a linear-motor feed axis under micro-milling (Table I)",
        run: feed_axis::run,
        any_engine: true,
    },
    Paper {
        name: "platform",
        summary: "Kalinski et al. 2013: two-wheeled platform, optimal control at the energy index vs two PIDs",
        run: platform::run,
        any_engine: true,
    },
    Paper {
        name: "milling",
        summary: "Kaliński & Galewski 2013 §3: slender ball-end milling chatter reduced by spindle-speed programmes",
        run: milling::run,
        any_engine: true,
    },
];
