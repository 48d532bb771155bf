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

mod background;
mod blueprint;
mod columns;
mod drawing;
mod entities;
mod error;
mod footer;
mod ids;
mod inspect;
mod layout;
mod live;
mod plot_data;
mod plots;
mod recorder;
mod salvage;
mod signals;
mod study;
mod style;
mod writer;

pub use background::BackgroundRecorder;
pub use error::RecordingError;
pub use inspect::{inspect, FigureLayer, RecordingContents};
pub use layout::{
    ColumnRole, PlotSpec, PlotTab, RecordingLayout, SeriesColumn, SeriesRole, SeriesSpec,
};
pub use live::LiveViewer;
pub use plot_data::{Plot2D, PlotAxis, PlotGeometry, PlotLayer};
pub use plots::{write_figures, write_plot};
pub use recorder::Recorder;
pub use salvage::{salvage, SalvageReport};
pub use signals::read_signals;
pub use study::{write_study_plots, Histogram, Scatter, StudyPlots};

#[cfg(test)]
mod tests;
