//! Writing a simulation run to a Rerun `.rrd` recording. This is the only module of the crate that
//! knows Rerun types.
//!
//! Layout of a recording:
//! - `/mechanism`: a static `Transform3D` flipping y (2D views are y-down; the mechanism is y-up);
//! - `/mechanism/<link>`: the link's shapes as static 2D line strips in the link frame, labelled
//!   and coloured per link, and its world pose as a temporal `Transform3D`;
//! - `/mechanism/scene/<drawing>`: what is machined (static line strips, machine coordinates);
//! - `/mechanism/markers/<marker>` and `/mechanism/traces/<marker>`: points placed every sample
//!   and the path they covered so far;
//! - `/mechanism/bodies/<body>`: the scenario's bodies, drawn and posed like links;
//! - `/mechanism/collisions`: every crash so far, a point labelled with its pair, from its step;
//! - `/signals/<tab>/<plot>`: one multi-instance `Scalars` per plot, all of one display unit
//!   ([`PlotSpec`]), with static `SeriesLines` naming (with the unit) and colouring the series,
//!   and a static annotation saying which series carry the run's commands, measurements and true
//!   signals, for reading them back as data ([`read_signals`]);
//! - `/figures/<name>`: the run's 2D figures drawn at its end (its spectra, a milling run's lobe
//!   diagram), each axes and data as a static plot of [`plots`] (`axes/…`, `data/<layer>`);
//! - `/events`: a `TextLog`, from the run's start (scenario, controller, parameters digest) to its
//!   end (status, headline figures);
//! - `/summary`: the run's summary as a static text document, written at the end;
//! - `/scenario`: the scenario TOML as a static plain-text `TextDocument`.
//!
//! Every sample is on two timelines: `step` (sequence) and `sim_time` (duration). Samples are
//! buffered in columns and sent with `send_columns` every [`FLUSH_EVERY`] samples and at the end.
//!
//! A recording is never lost, corrupt or half-written: it is written under a temporary name beside
//! its path and renamed onto it once complete, write failures stop the run with the OS's reason
//! (see [`Recorder`]), a live viewer streams on a path of its own that cannot fail the file, and
//! [`salvage()`] completes what a killed run left.

mod blueprint;
mod columns;
mod drawing;
mod footer;
mod ids;
mod inspect;
mod layout;
mod live;
mod plots;
mod recorder;
mod salvage;
mod signals;
mod study;
mod writer;

pub use inspect::{inspect, FigureLayer, RecordingContents};
pub use layout::{
    ColumnRole, PlotSpec, PlotTab, RecordingLayout, SeriesColumn, SeriesRole, SeriesSpec,
};
pub use plots::{write_figures, write_plot, Plot2D, PlotAxis, PlotGeometry, PlotLayer};
pub use recorder::Recorder;
pub use salvage::{salvage, SalvageReport};
pub use signals::read_signals;
pub use study::{write_study_plots, Histogram, Scatter, StudyPlots};

use std::path::PathBuf;

use rerun::ApplicationId;

const MECHANISM: &str = "mechanism";
const SIGNALS: &str = "signals";
const EVENTS: &str = "events";
const SCENARIO: &str = "scenario";
const SUMMARY: &str = "summary";
const FIGURES: &str = "figures";
/// Where the crashes are drawn.
const COLLISIONS: &str = "mechanism/collisions";
/// The crashes' colour (red: nothing else in the view is).
const COLLISION_COLOR: [u8; 3] = [255, 40, 40];
/// The bodies' colour when their shapes have none (neutral beside the links' palette).
const BODY_COLOR: [u8; 3] = [158, 163, 178];
/// Sequence timeline: the physics step index.
const STEP: &str = "step";
/// Duration timeline: simulated time.
const SIM_TIME: &str = "sim_time";

/// Buffered samples are sent after this many (bounds memory: ~8 bytes per value and sample).
const FLUSH_EVERY: usize = 4096;
/// Bound on the data queued between the recorder and the file writer.
const MAX_BYTES_IN_FLIGHT: u64 = 32 << 20;
/// Segments of the polygon drawing a circle.
const CIRCLE_SEGMENTS: usize = 48;
/// Colours of the links, one each in turn (distinct on the viewer's dark background).
const LINK_PALETTE: [[u8; 3]; 8] = [
    [86, 180, 233],
    [230, 159, 0],
    [0, 158, 115],
    [204, 121, 167],
    [240, 228, 66],
    [213, 94, 0],
    [148, 103, 189],
    [0, 114, 178],
];
/// A trace is sent every this many samples (and at the end).
const TRACE_EVERY: usize = 1024;
/// A trace keeps at most this many points: beyond, every other one is dropped.
const MAX_TRACE_POINTS: usize = 4000;

/// A Rerun viewer watching the run as it happens, besides the file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LiveViewer {
    /// A viewer already listening at this gRPC URL (e.g. `rerun+http://127.0.0.1:9876/proxy`).
    Connect(String),
    /// Start a viewer from the `rerun` executable on PATH and stream to it.
    Spawn,
}

/// Why a Rerun file could not be recorded, written or read.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    /// The file cannot be started (its path is a directory, its folder is missing or not
    /// writable), or its layout or the live viewer cannot be set up.
    #[error("cannot create the recording {}: {reason}", path.display())]
    Create {
        /// The recording's path.
        path: PathBuf,
        /// What failed, as the file system or the viewer said.
        reason: String,
    },
    /// Writing to the file, or moving the finished file into place, failed.
    #[error("cannot write the recording {}: {reason}", path.display())]
    Write {
        /// The recording's path.
        path: PathBuf,
        /// What the file system or the encoder said.
        reason: String,
    },
    /// The file cannot be opened or decoded as a Rerun recording.
    #[error("cannot read the recording {}: {reason}", path.display())]
    Read {
        /// The recording's path.
        path: PathBuf,
        /// What the file system or the decoder said.
        reason: String,
    },
}

/// How a finished recording went.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecordingOutcome {
    /// The complete recording (the path given to [`Recorder::create`]).
    pub path: PathBuf,
    /// Its size, bytes.
    pub bytes: u64,
    /// Why the live viewer, if any, did not get the whole run. The file is complete regardless: a
    /// viewer's failure is a warning, never an error.
    pub live_warning: Option<String>,
}

/// Rerun's application id for the scenario name. Rerun accepts ASCII letters, digits and
/// `_- []:` in at most 180 bytes and otherwise rewrites the id with a hash suffix and a warning;
/// this does a quiet, readable version of that (the recording name keeps the full name).
fn application_id(app: &str) -> ApplicationId {
    const MAX_BYTES: usize = 180;
    let valid = |c: char| c.is_ascii_alphanumeric() || "_- []:".contains(c);
    let id: String = app
        .chars()
        .map(|c| if valid(c) { c } else { '-' })
        .take(MAX_BYTES)
        .collect();
    ApplicationId::new_or_unknown(if id.trim().is_empty() {
        "twin".to_owned()
    } else {
        id
    })
}

/// An event's text as the log shows it: without a leading "warning:" (the level says so), and
/// wrapped at word boundaries so that long events stay readable.
fn event_text(text: &str) -> String {
    const WIDTH: usize = 64;
    let trimmed = text.trim();
    let body = ["warning:", "Warning:", "WARNING:"]
        .iter()
        .find_map(|prefix| trimmed.strip_prefix(prefix))
        .map_or(trimmed, str::trim_start);
    let mut out = String::with_capacity(body.len() + body.len() / WIDTH + 1);
    let mut line = 0;
    for word in body.split(' ') {
        let width = word.chars().count();
        if line > 0 && line + 1 + width > WIDTH {
            out.push('\n');
            line = 0;
        } else if line > 0 {
            out.push(' ');
            line += 1;
        }
        out.push_str(word);
        line += width;
    }
    out
}

/// An error and its sources, for messages that name the root cause.
fn error_chain(err: &dyn std::error::Error) -> String {
    let mut message = err.to_string();
    let mut source = err.source();
    while let Some(cause) = source {
        let text = cause.to_string();
        if !message.contains(&text) {
            message.push_str(": ");
            message.push_str(&text);
        }
        source = cause.source();
    }
    message
}

#[cfg(test)]
mod tests;
