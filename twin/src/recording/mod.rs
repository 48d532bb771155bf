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
//!   ([`PlotSpec`]), with static `SeriesLines` naming (with the unit) and colouring the series;
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
//! [`salvage`] completes what a killed run left.

mod blueprint;
mod footer;
mod ids;
mod inspect;
mod live;
mod plots;
mod salvage;
mod study;
mod writer;

pub use controllers::EventLevel;
pub use inspect::{inspect, FigureLayer, RecordingContents};
pub use plots::{write_figures, write_plot, Plot2D, PlotAxis, PlotGeometry, PlotLayer};
pub use salvage::{salvage, SalvageReport};
pub use study::{write_study_plots, Histogram, Scatter, StudyPlots};

use std::path::{Path, PathBuf};
use std::sync::Arc;

use rerun::archetypes::{
    LineStrips2D, Points2D, Scalars, SeriesLines, TextDocument, TextLog, Transform3D,
};
use rerun::components::{
    Color, MediaType, Position2D, Radius, RotationAxisAngle, TextLogLevel, Translation3D,
};
use rerun::external::arrow::array::{
    ArrayRef, FixedSizeListArray, Float32Array, Float64Array, StructArray,
};
use rerun::external::arrow::datatypes::DataType;
use rerun::log::ChunkBatcherConfig;
use rerun::sink::LogSink;
use rerun::{
    ApplicationId, EntityPath, EntityPathPart, Loggable, RecordingStream, RecordingStreamBuilder,
    SerializedComponentBatch, SerializedComponentColumn, TimeColumn,
};

use crate::mechanism::{wrap_angle, Outline, Pose2, Shape};
use crate::scene::{Marker, Scene};
use controllers::Unit;
use live::LiveHandle;
use writer::{FileState, FileWriter, PartFile};

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

/// What a recording contains, fixed before the run starts.
#[derive(Debug, Clone, Default)]
pub struct RecordingLayout {
    /// Application id / recording name (the scenario name).
    pub app: String,
    /// The recording's id: the same for the same inputs (two such files are byte-identical).
    pub recording_id: String,
    /// The scenario TOML, stored as a static text document (provenance).
    pub scenario_toml: String,
    /// Links to draw: name and shapes in the link frame (drawn as 2D line strips).
    pub links: Vec<(String, Vec<Shape>)>,
    /// The scenario's bodies, drawn like links: name and shapes in the body's frame.
    pub bodies: Vec<(String, Vec<Shape>)>,
    /// The mechanism view's frame, drawings and markers; the positions of its markers are passed
    /// to [`Recorder::push`] in the order of `scene.markers`.
    pub scene: Option<Scene>,
    /// The plots. Their series pick, by index, from the values passed to [`Recorder::push`].
    pub plots: Vec<PlotSpec>,
    /// The run's figures (its spectra, a lobe diagram), drawn when it ends
    /// ([`Recorder::figure`]): each a name (its entity is `figures/<name>`) and its frame
    /// (title, axes, aspect), from which the layout frames its view before the run. The y range
    /// of a frame may be a guess; its x range and aspect must be those of the drawing.
    pub figures: Vec<(String, Plot2D)>,
    /// Also stream the run to a live viewer while it is written to the file.
    pub live: Option<LiveViewer>,
}

/// `figures/<name>`, with the name made path-safe.
fn figure_entity(name: &str) -> String {
    let slug: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    format!("{FIGURES}/{slug}")
}

/// Which tab of the layout a plot is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PlotTab {
    /// A reference or a command on the plot of what it commands.
    Tracking,
    /// The machine's own signals.
    Process,
    /// Per actuator, the effort commanded and applied.
    Efforts,
    Joints,
    Controller,
    /// Model checks.
    Diagnostics,
}

impl PlotTab {
    /// The tabs in the order the layout shows them.
    pub const ALL: [PlotTab; 6] = [
        PlotTab::Tracking,
        PlotTab::Process,
        PlotTab::Efforts,
        PlotTab::Joints,
        PlotTab::Controller,
        PlotTab::Diagnostics,
    ];

    pub fn label(self) -> &'static str {
        match self {
            PlotTab::Tracking => "tracking",
            PlotTab::Process => "process",
            PlotTab::Efforts => "efforts",
            PlotTab::Joints => "joints",
            PlotTab::Controller => "controller",
            PlotTab::Diagnostics => "diagnostics",
        }
    }
}

/// What a series is to its plot; it sets the series' colour, the same in every plot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SeriesRole {
    Reference,
    /// The simulated (true) value.
    True,
    /// What the controller measures (through a sensor).
    Measured,
    /// An effort or set-point the controller commands.
    Commanded,
    /// The effort the joint receives.
    Applied,
    Other,
}

/// One series of a plot.
#[derive(Debug, Clone, PartialEq)]
pub struct SeriesSpec {
    /// Its name without the unit (the plot adds it).
    pub name: String,
    pub role: SeriesRole,
    /// Index of its SI value in the values passed to [`Recorder::push`].
    pub value: usize,
}

/// A plot: series of one display unit, on one tab.
#[derive(Debug, Clone, PartialEq)]
pub struct PlotSpec {
    pub tab: PlotTab,
    /// What is plotted, without the unit.
    pub name: String,
    pub unit: Unit,
    pub series: Vec<SeriesSpec>,
}

impl PlotSpec {
    /// The plot's title: its name and unit, e.g. `ram position [mm]`.
    pub fn title(&self) -> String {
        format!("{} [{}]", self.name, self.unit.label())
    }

    /// A series' name as shown: with the plot's unit.
    pub fn series_label(&self, series: &SeriesSpec) -> String {
        format!("{} [{}]", series.name, self.unit.label())
    }

    /// The plot's entity under `signals/`: its tab and a path-safe form of its title.
    pub fn entity(&self) -> String {
        let slug: String = format!("{}_{}", self.name, unit_slug(self.unit))
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
            .collect();
        format!("{SIGNALS}/{}/{slug}", self.tab.label())
    }
}

/// An ASCII form of a unit for entity paths.
fn unit_slug(unit: Unit) -> String {
    unit.label()
        .replace('µ', "u")
        .replace('°', "deg")
        .replace('²', "2")
        .replace('·', "")
        .replace('/', "_per_")
}

/// A Rerun viewer watching the run as it happens, besides the file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LiveViewer {
    /// A viewer already listening at this gRPC URL (e.g. `rerun+http://127.0.0.1:9876/proxy`).
    Connect(String),
    /// Start a viewer from the `rerun` executable on PATH and stream to it.
    Spawn,
}

#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    #[error("cannot create the recording {}: {reason}", path.display())]
    Create { path: PathBuf, reason: String },
    #[error("cannot write the recording {}: {reason}", path.display())]
    Write { path: PathBuf, reason: String },
    #[error("cannot read the recording {}: {reason}", path.display())]
    Read { path: PathBuf, reason: String },
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

/// Writes one run to an `.rrd` file, atomically: the data goes to a temporary file beside `path`
/// (`X.rrd.<random>.part`), which [`Recorder::finish`] completes and renames onto `path`. A file at
/// `path` is therefore always a complete recording; on an error, or when the recorder is dropped
/// without `finish` (a panic), the temporary file is removed. A run killed outright (`kill -9`)
/// leaves it behind, and [`salvage`] makes a complete recording of it.
///
/// Samples are buffered and sent in columns. A failed write to the file (disk full, quota, file
/// size limit) is returned, with the OS's reason, by the next [`Recorder::push`] or
/// [`Recorder::event`] once Rerun's pipeline has reached it, and at the latest by the `push` that
/// sends the next buffer ([`FLUSH_EVERY`] samples): the file is kept at most one buffer behind.
pub struct Recorder {
    path: PathBuf,
    /// The temporary file being written, as named on disk.
    /// Where the data is until `finish` (the tests read the file being written).
    #[cfg(test)]
    part_path: PathBuf,
    /// `None` once closed (dropping it drains Rerun's pipeline into the file).
    stream: Option<RecordingStream>,
    /// The file and its first write failure, shared with the stream's sink.
    file: Arc<FileState>,
    /// How the live viewer fared, if there is one.
    live: Option<LiveHandle>,
    /// Flushes of the pipeline started, one per buffer sent from `push`.
    flushes: u64,
    links: Vec<LinkPoses>,
    groups: Vec<Group>,
    markers: Vec<MarkerBuffer>,
    /// Samples pushed so far.
    samples: usize,
    steps: Vec<i64>,
    times: Vec<f64>,
    /// The last finite time pushed, which stands in for a non-finite one.
    last_time: f64,
}

/// A link's buffered world poses.
struct LinkPoses {
    entity: EntityPath,
    /// x, y, 0 per buffered sample.
    translations: Vec<f32>,
    /// Rotation about z, wrapped to (-π, π], per buffered sample.
    angles: Vec<f32>,
    /// Whether every buffered pose is finite (otherwise the non-finite ones are left out).
    all_finite: bool,
}

/// A plot's buffered samples, in its display unit.
struct Group {
    entity: EntityPath,
    unit: Unit,
    /// Index of each series' value in the pushed values.
    indices: Vec<usize>,
    /// Row-major: one value per series and buffered sample.
    values: Vec<f64>,
}

/// A scene marker's buffered positions and the trace it has drawn so far.
struct MarkerBuffer {
    entity: EntityPath,
    /// x, y per buffered sample (NaN when unknown; left out when sent).
    positions: Vec<f32>,
    /// The trace's entity, when the marker leaves one.
    trace: Option<EntityPath>,
    /// Every `stride`-th position of the run so far.
    trace_points: Vec<[f32; 2]>,
    stride: usize,
}

impl MarkerBuffer {
    /// Adds the `sample`-th position to the buffer and, every `stride` samples, to the trace;
    /// past [`MAX_TRACE_POINTS`] the trace keeps every other point and the stride doubles.
    fn add(&mut self, sample: usize, [x, y]: [f64; 2]) {
        let point = [x as f32, y as f32];
        self.positions.extend_from_slice(&point);
        if self.trace.is_none()
            || !sample.is_multiple_of(self.stride)
            || !point.iter().all(|v| v.is_finite())
        {
            return;
        }
        self.trace_points.push(point);
        if self.trace_points.len() > MAX_TRACE_POINTS {
            let kept = self.trace_points.iter().copied().step_by(2).collect();
            self.trace_points = kept;
            self.stride *= 2;
        }
    }
}

impl Recorder {
    /// Starts a recording of `path` and logs the static parts: the y-up root transform, the link
    /// shapes, the scenario text, the series names and the default blueprint.
    ///
    /// Fails at once, naming `path`, when it is a directory, its folder does not exist or is not
    /// writable, or the live viewer cannot be set up. Concurrent runs may record the same `path`:
    /// each writes a file of its own, and the last to finish replaces the others' (last complete
    /// run wins; the file is never a mix).
    pub fn create(path: &Path, layout: &RecordingLayout) -> Result<Recorder, RecordingError> {
        let create_error = |reason: String| RecordingError::Create {
            path: path.to_path_buf(),
            reason,
        };
        let part = PartFile::create(path).map_err(create_error)?;
        #[cfg(test)]
        let part_path = part.temp_path();
        let file = FileState::new(part);
        let (feed, live) = match &layout.live {
            Some(viewer) => {
                let (feed, handle) = live::start(viewer).map_err(create_error)?;
                (Some(feed), Some(handle))
            }
            None => (None, None),
        };
        let (links, groups, markers) = buffers(layout);
        let sink: Box<dyn LogSink> = Box::new(FileWriter::new(file.clone(), feed));
        let app = application_id(&layout.app);
        // A fixed id and no start time: the file holds what the run computed, not when.
        let stream = RecordingStreamBuilder::new(app.clone())
            .recording_id(layout.recording_id.as_str())
            // Ignore the `RERUN` environment variable: the file is the run's product.
            .enabled(true)
            // Bounds the data queued towards the file (the default allows 100 MiB); no flush on
            // a clock tick, so that chunks end where the run flushes, the same every time.
            .batcher_config(ChunkBatcherConfig {
                max_bytes_in_flight: MAX_BYTES_IN_FLIGHT,
                flush_tick: std::time::Duration::MAX,
                ..ChunkBatcherConfig::DEFAULT
            })
            .set_sinks(vec![sink])
            .map_err(|err| create_error(error_chain(&err)))?;
        stream.set_log_time_enabled(false);
        stream
            .send_recording_name(layout.app.as_str())
            .map_err(|err| create_error(error_chain(&err)))?;
        let plots: Vec<(String, &PlotSpec)> = layout
            .plots
            .iter()
            .filter(|plot| !plot.series.is_empty())
            .map(|plot| (plot.entity(), plot))
            .collect();
        let scene = layout.scene.as_ref();
        let title = scene.map_or("mechanism", |s| s.title.as_str());
        let figures: Vec<blueprint::FigureView> = layout
            .figures
            .iter()
            .map(|(name, frame)| blueprint::FigureView {
                entity: figure_entity(name),
                title: frame.title.clone(),
                bounds: plots::visual_bounds(frame),
            })
            .collect();
        let bounds = scene.map(|s| s.bounds);
        blueprint::send_default(&stream, &app, title, bounds, &plots, &figures)
            .map_err(create_error)?;
        log_layout(&stream, layout).map_err(create_error)?;
        Ok(Recorder {
            path: path.to_path_buf(),
            #[cfg(test)]
            part_path,
            stream: Some(stream),
            file,
            live,
            flushes: 0,
            links,
            groups,
            markers,
            samples: 0,
            steps: Vec::with_capacity(FLUSH_EVERY),
            times: Vec::with_capacity(FLUSH_EVERY),
            last_time: 0.0,
        })
    }

    /// Where the run is being written until [`Recorder::finish`] renames it onto its path: what a
    /// killed run leaves behind, for [`salvage`].
    #[cfg(test)]
    pub fn part_path(&self) -> &Path {
        &self.part_path
    }

    /// Buffers one sample: step index, simulated time (s), every link's world pose (in the order of
    /// `layout.links`, then the bodies' in the order of `layout.bodies`), the SI values the plots' series pick from and the scene markers'
    /// positions (in the order of `layout.scene.markers`). Values are recorded in their plot's
    /// unit (NaN and infinities included); missing ones are recorded as NaN. A missing or
    /// non-finite pose or marker position is left out, so it stays drawn at its last finite
    /// place. A non-finite time is replaced by the last finite one.
    ///
    /// Fails once a write to the file has failed (with the OS's reason): the run should stop, as
    /// the rest of it could not be recorded.
    pub fn push(
        &mut self,
        step: i64,
        time: f64,
        link_poses: &[Pose2],
        values: &[f64],
        markers: &[[f64; 2]],
    ) -> Result<(), RecordingError> {
        if time.is_finite() {
            self.last_time = time;
        }
        self.steps.push(step);
        self.times.push(self.last_time);
        for (index, link) in self.links.iter_mut().enumerate() {
            let [x, y, angle] = match link_poses.get(index) {
                Some(pose) => [pose.x as f32, pose.y as f32, wrap_angle(pose.angle) as f32],
                None => [f32::NAN; 3],
            };
            link.all_finite &= x.is_finite() && y.is_finite() && angle.is_finite();
            link.translations.extend_from_slice(&[x, y, 0.0]);
            link.angles.push(angle);
        }
        for group in &mut self.groups {
            let unit = group.unit;
            group.values.extend(
                group
                    .indices
                    .iter()
                    .map(|&i| values.get(i).map_or(f64::NAN, |&v| unit.from_si(v))),
            );
        }
        for (index, marker) in self.markers.iter_mut().enumerate() {
            let position = markers.get(index).copied().unwrap_or([f64::NAN; 2]);
            marker.add(self.samples, position);
        }
        self.samples += 1;
        if self.samples.is_multiple_of(TRACE_EVERY) {
            self.send_traces()
                .map_err(|reason| self.write_error(reason))?;
        }
        if self.steps.len() >= FLUSH_EVERY {
            self.send_buffered()
                .map_err(|reason| self.write_error(reason))?;
            self.pace()?;
        }
        self.check()
    }

    /// Marks the end of the buffer just sent with a flush of the pipeline, and waits for the file
    /// to have been written up to the previous buffer. The file thus stays at most one buffer
    /// behind the run (rather than all the data Rerun lets queue up), so that a failed write is
    /// reported at the latest at the next buffer; writing the current buffer still overlaps with
    /// the run.
    fn pace(&mut self) -> Result<(), RecordingError> {
        if let Some(stream) = &self.stream {
            stream
                .flush_async()
                .map_err(|err| self.write_error(error_chain(&err)))?;
            self.flushes += 1;
            self.file.wait_for_flush(self.flushes - 1);
        }
        Ok(())
    }

    /// Logs an event to the text log `events` at that step and time. Fails, like
    /// [`Recorder::push`], once a write to the file has failed.
    pub fn event(
        &mut self,
        step: i64,
        time: f64,
        level: EventLevel,
        text: &str,
    ) -> Result<(), RecordingError> {
        let Some(stream) = &self.stream else {
            return Ok(());
        };
        let level = match level {
            EventLevel::Info => TextLogLevel::INFO,
            EventLevel::Warning => TextLogLevel::WARN,
            EventLevel::Error => TextLogLevel::ERROR,
        };
        let time = if time.is_finite() {
            time
        } else {
            self.last_time
        };
        TextLog::new(event_text(text))
            .with_level(level)
            .columns_of_unit_batches()
            .map_err(|err| error_chain(&err))
            .and_then(|columns| {
                stream
                    .send_columns(EVENTS, timeline_columns(&[step], &[time]), columns)
                    .map_err(|err| error_chain(&err))
            })
            .map_err(|reason| self.write_error(reason))?;
        self.check()
    }

    /// Draws the crashes so far (world points, each with its pair's label) from this step on.
    /// Fails, like [`Recorder::push`], once a write to the file has failed.
    pub fn collisions(
        &mut self,
        step: i64,
        time: f64,
        collisions: &[([f64; 2], String)],
    ) -> Result<(), RecordingError> {
        let Some(stream) = &self.stream else {
            return Ok(());
        };
        let time = if time.is_finite() {
            time
        } else {
            self.last_time
        };
        let points = collisions.iter().map(|([x, y], _)| [*x as f32, *y as f32]);
        let [r, g, b] = COLLISION_COLOR;
        let count = collisions.len();
        Points2D::update_fields()
            .with_positions(points)
            .with_labels(collisions.iter().map(|(_, pair)| pair.as_str()))
            .with_colors(std::iter::repeat_n(Color::from_rgb(r, g, b), count))
            .with_radii(std::iter::repeat_n(Radius::new_ui_points(6.0), count))
            .columns([count])
            .map_err(|err| error_chain(&err))
            .and_then(|columns| {
                stream
                    .send_columns(COLLISIONS, timeline_columns(&[step], &[time]), columns)
                    .map_err(|err| error_chain(&err))
            })
            .map_err(|reason| self.write_error(reason))?;
        self.check()
    }

    /// Writes the run's summary as the recording's `summary` text document (Markdown).
    pub fn summary(&mut self, markdown: &str) -> Result<(), RecordingError> {
        let Some(stream) = &self.stream else {
            return Ok(());
        };
        stream
            .log_static(
                SUMMARY,
                &TextDocument::new(markdown).with_media_type(MediaType::markdown()),
            )
            .map_err(|err| self.write_error(error_chain(&err)))?;
        self.check()
    }

    /// Draws the figure `name` of the layout (static): `plot` in the frame the layout gave it.
    /// Fails, like [`Recorder::push`], once a write to the file has failed.
    pub fn figure(&mut self, name: &str, plot: &Plot2D) -> Result<(), RecordingError> {
        let Some(stream) = &self.stream else {
            return Ok(());
        };
        let log = |entity: EntityPath, archetype: &dyn rerun::AsComponents| {
            stream
                .log_static(entity, archetype)
                .map_err(|err| self.write_error(error_chain(&err)))
        };
        plots::draw(&log, &figure_entity(name), plot)?;
        self.check()
    }

    /// Sends each marker's trace so far as one line strip at the last sample's time.
    fn send_traces(&mut self) -> Result<(), String> {
        let (Some(stream), Some(&step)) = (&self.stream, self.steps.last()) else {
            return Ok(());
        };
        for marker in &self.markers {
            let Some(entity) = &marker.trace else {
                continue;
            };
            if marker.trace_points.len() < 2 {
                continue;
            }
            let strip = LineStrips2D::update_fields().with_strips([marker.trace_points.clone()]);
            let columns = strip
                .columns_of_unit_batches()
                .map_err(|err| error_chain(&err))?;
            stream
                .send_columns(
                    entity.clone(),
                    timeline_columns(&[step], &[self.last_time]),
                    columns,
                )
                .map_err(|err| error_chain(&err))?;
        }
        Ok(())
    }

    /// Sends what is buffered, drains Rerun's pipeline into the file, writes the footer and renames
    /// the file onto its path (replacing what is there: when runs record the same path, the last
    /// to finish wins). Then waits for the live viewer, if any, at most
    /// [`live::LIVE_FINISH_TIMEOUT`] (5 s); its failure is a warning in the outcome. On error the
    /// temporary file is removed and nothing is written at the path.
    pub fn finish(mut self) -> Result<RecordingOutcome, RecordingError> {
        let sent = self.send_traces().and_then(|()| self.send_buffered());
        // The last handle: dropping it sends everything pending through the sink and joins
        // Rerun's threads, so the file holds every message afterwards.
        drop(self.stream.take());
        let part = self.file.take();
        let live = self.live.take();
        let written = sent.and_then(|()| match self.file.failure() {
            Some(reason) => Err(reason.to_owned()),
            None => Ok(()),
        });
        let bytes = match (written, part) {
            (Ok(()), Some(part)) => part.complete(&self.path),
            (Ok(()), None) => Err("the file was closed early".to_owned()),
            (Err(reason), part) => {
                if let Some(part) = part {
                    part.discard();
                }
                Err(reason)
            }
        }
        .map_err(|reason| self.write_error(reason))?;
        Ok(RecordingOutcome {
            path: self.path.clone(),
            bytes,
            live_warning: live.and_then(LiveHandle::finish),
        })
    }

    /// The first failed write to the file, as an error naming the recording.
    fn check(&self) -> Result<(), RecordingError> {
        match self.file.failure() {
            Some(reason) => Err(self.write_error(reason.to_owned())),
            None => Ok(()),
        }
    }

    fn write_error(&self, reason: String) -> RecordingError {
        RecordingError::Write {
            path: self.path.clone(),
            reason,
        }
    }

    /// Sends the buffered samples as columns, one chunk per entity, and empties the buffers.
    fn send_buffered(&mut self) -> Result<(), String> {
        let Some(stream) = &self.stream else {
            return Ok(());
        };
        let rows = self.steps.len();
        if rows == 0 {
            return Ok(());
        }
        let timelines = timeline_columns(&self.steps, &self.times);
        let mut first_error = None;
        let mut note = |result: Result<(), String>| {
            if let Err(reason) = result {
                first_error.get_or_insert(reason);
            }
        };

        for group in &mut self.groups {
            let width = group.indices.len();
            if width == 0 {
                continue;
            }
            let values =
                std::mem::replace(&mut group.values, Vec::with_capacity(FLUSH_EVERY * width));
            let batch = SerializedComponentBatch::new(
                Arc::new(Float64Array::from(values)),
                Scalars::descriptor_scalars(),
            );
            note(
                batch
                    .partitioned(std::iter::repeat_n(width, rows))
                    .map_err(|err| error_chain(&err))
                    .and_then(|column| {
                        stream
                            .send_columns(group.entity.clone(), timelines.clone(), [column])
                            .map_err(|err| error_chain(&err))
                    }),
            );
        }

        for link in &mut self.links {
            let result = if link.all_finite {
                send_poses(stream, link, timelines.clone())
            } else {
                let kept: Vec<usize> = (0..rows)
                    .filter(|&i| {
                        link.angles[i].is_finite()
                            && link.translations[3 * i..3 * i + 2]
                                .iter()
                                .all(|v| v.is_finite())
                    })
                    .collect();
                let steps: Vec<i64> = kept.iter().map(|&i| self.steps[i]).collect();
                let times: Vec<f64> = kept.iter().map(|&i| self.times[i]).collect();
                link.angles = kept.iter().map(|&i| link.angles[i]).collect();
                link.translations = kept
                    .iter()
                    .flat_map(|&i| link.translations[3 * i..3 * i + 3].iter().copied())
                    .collect();
                send_poses(stream, link, timeline_columns(&steps, &times))
            };
            note(result);
            link.translations.clear();
            link.angles.clear();
            link.all_finite = true;
        }

        for marker in &mut self.markers {
            note(send_marker(stream, marker, &self.steps, &self.times));
            marker.positions.clear();
        }

        self.steps.clear();
        self.times.clear();
        first_error.map_or(Ok(()), Err)
    }
}

impl Drop for Recorder {
    /// A recorder dropped without [`Recorder::finish`] (an error or a panic) leaves no file: the
    /// temporary one is removed, and nothing more is written to it.
    fn drop(&mut self) {
        let part = self.file.take();
        drop(self.stream.take());
        if let Some(part) = part {
            part.discard();
        }
    }
}

/// The empty sample buffers of the layout's links and bodies, plots and scene markers.
fn buffers(layout: &RecordingLayout) -> (Vec<LinkPoses>, Vec<Group>, Vec<MarkerBuffer>) {
    let links = layout
        .links
        .iter()
        .map(|(name, _)| link_entity(name))
        .chain(layout.bodies.iter().map(|(name, _)| body_entity(name)))
        .map(|entity| LinkPoses {
            entity,
            translations: Vec::with_capacity(3 * FLUSH_EVERY),
            angles: Vec::with_capacity(FLUSH_EVERY),
            all_finite: true,
        })
        .collect();
    let groups = layout
        .plots
        .iter()
        .filter(|plot| !plot.series.is_empty())
        .map(|plot| Group {
            entity: EntityPath::from(plot.entity()),
            unit: plot.unit,
            indices: plot.series.iter().map(|s| s.value).collect(),
            values: Vec::with_capacity(FLUSH_EVERY * plot.series.len()),
        })
        .collect();
    let markers = layout
        .scene
        .iter()
        .flat_map(|scene| &scene.markers)
        .map(|marker| MarkerBuffer {
            entity: scene_entity("markers", &marker.name),
            positions: Vec::with_capacity(2 * FLUSH_EVERY),
            trace: marker.trace.then(|| scene_entity("traces", &marker.name)),
            trace_points: Vec::new(),
            stride: 1,
        })
        .collect();
    (links, groups, markers)
}

/// `/mechanism/<link>`.
fn link_entity(name: &str) -> EntityPath {
    EntityPath::new(vec![
        EntityPathPart::new(MECHANISM),
        EntityPathPart::new(name),
    ])
}

/// `/mechanism/bodies/<body>`.
fn body_entity(name: &str) -> EntityPath {
    scene_entity("bodies", name)
}

/// `/mechanism/<kind>/<name>`.
fn scene_entity(kind: &str, name: &str) -> EntityPath {
    EntityPath::new(vec![
        EntityPathPart::new(MECHANISM),
        EntityPathPart::new(kind),
        EntityPathPart::new(name),
    ])
}

/// Logs the static parts of the recording: the y-up root transform, the links (coloured and
/// labelled), the scene, the scenario text and the plots' series names and colours.
fn log_layout(stream: &RecordingStream, layout: &RecordingLayout) -> Result<(), String> {
    let log_static = |entity: EntityPath, archetype: &dyn rerun::AsComponents| {
        stream
            .log_static(entity, archetype)
            .map_err(|err| error_chain(&err))
    };
    log_static(
        EntityPath::from(MECHANISM),
        &Transform3D::from_scale([1.0, -1.0, 1.0]),
    )?;
    for (index, (name, shapes)) in layout.links.iter().enumerate() {
        let color = LINK_PALETTE[index % LINK_PALETTE.len()];
        if let Some(strips) = link_strips(shapes, color) {
            log_static(link_entity(name), &strips.with_labels([name.as_str()]))?;
        }
    }
    for (name, shapes) in &layout.bodies {
        if let Some(strips) = link_strips(shapes, BODY_COLOR) {
            log_static(body_entity(name), &strips.with_labels([name.as_str()]))?;
        }
    }
    if let Some(scene) = &layout.scene {
        log_scene(&log_static, scene)?;
    }
    log_static(
        EntityPath::from(SCENARIO),
        &TextDocument::new(layout.scenario_toml.as_str()).with_media_type(MediaType::plain_text()),
    )?;
    for plot in layout.plots.iter().filter(|p| !p.series.is_empty()) {
        let colors = series_colors(plot);
        log_static(
            EntityPath::from(plot.entity()),
            &SeriesLines::new()
                .with_names(plot.series.iter().map(|s| plot.series_label(s)))
                .with_colors(colors.iter().map(|&[r, g, b]| Color::from_rgb(r, g, b))),
        )?;
    }
    Ok(())
}

/// The scene's drawings and the markers' and traces' colours and labels.
fn log_scene(
    log_static: &dyn Fn(EntityPath, &dyn rerun::AsComponents) -> Result<(), String>,
    scene: &Scene,
) -> Result<(), String> {
    for drawing in &scene.drawings {
        let strips = drawing.lines.iter().map(|line| {
            line.iter()
                .map(|&[x, y]| [x as f32, y as f32])
                .collect::<Vec<_>>()
        });
        let [r, g, b] = drawing.color;
        log_static(
            scene_entity("scene", &drawing.name),
            &LineStrips2D::new(strips)
                .with_colors([Color::from_rgb(r, g, b)])
                .with_labels([drawing.label.as_str()]),
        )?;
    }
    for marker in &scene.markers {
        log_marker_style(log_static, marker)?;
    }
    Ok(())
}

fn log_marker_style(
    log_static: &dyn Fn(EntityPath, &dyn rerun::AsComponents) -> Result<(), String>,
    marker: &Marker,
) -> Result<(), String> {
    let [r, g, b] = marker.color;
    let color = Color::from_rgb(r, g, b);
    log_static(
        scene_entity("markers", &marker.name),
        &Points2D::update_fields()
            .with_colors([color])
            .with_radii([Radius::new_ui_points(4.0)])
            .with_labels([marker.label.as_str()]),
    )?;
    if marker.trace {
        log_static(
            scene_entity("traces", &marker.name),
            &LineStrips2D::update_fields().with_colors([color]),
        )?;
    }
    Ok(())
}

/// Colours of a plot's series: each role's own colour, or, when that is taken in the plot, the
/// next free one of the palette, so that the series of a plot are always told apart.
fn series_colors(plot: &PlotSpec) -> Vec<[u8; 3]> {
    const PALETTE: [[u8; 3]; 10] = [
        [204, 121, 167],
        [0, 114, 178],
        [148, 103, 189],
        [240, 228, 66],
        [140, 86, 75],
        [127, 127, 127],
        [23, 190, 207],
        [188, 189, 34],
        [255, 152, 150],
        [197, 176, 213],
    ];
    let mut used: Vec<[u8; 3]> = Vec::with_capacity(plot.series.len());
    for series in &plot.series {
        let own = match series.role {
            SeriesRole::Reference => Some([220, 220, 220]),
            SeriesRole::True => Some([86, 180, 233]),
            SeriesRole::Measured => Some([230, 159, 0]),
            SeriesRole::Commanded => Some([0, 158, 115]),
            SeriesRole::Applied => Some([213, 94, 0]),
            SeriesRole::Other => None,
        };
        let color = own
            .filter(|c| !used.contains(c))
            .or_else(|| PALETTE.iter().copied().find(|c| !used.contains(c)))
            .unwrap_or(PALETTE[used.len() % PALETTE.len()]);
        used.push(color);
    }
    used
}

/// Sends a marker's buffered positions as a `Points2D` position column, leaving out the
/// non-finite ones.
fn send_marker(
    stream: &RecordingStream,
    marker: &MarkerBuffer,
    steps: &[i64],
    times: &[f64],
) -> Result<(), String> {
    let kept: Vec<usize> = (0..steps.len())
        .filter(|&i| {
            marker.positions[2 * i..2 * i + 2]
                .iter()
                .all(|v| v.is_finite())
        })
        .collect();
    if kept.is_empty() {
        return Ok(());
    }
    let steps: Vec<i64> = kept.iter().map(|&i| steps[i]).collect();
    let times: Vec<f64> = kept.iter().map(|&i| times[i]).collect();
    let xy: Vec<f32> = kept
        .iter()
        .flat_map(|&i| marker.positions[2 * i..2 * i + 2].iter().copied())
        .collect();
    let column = position_column(xy).map_err(|e| error_chain(&*e))?;
    stream
        .send_columns(
            marker.entity.clone(),
            timeline_columns(&steps, &times),
            [column],
        )
        .map_err(|err| error_chain(&err))
}

/// A `Points2D` positions column of one point per row from x, y pairs.
fn position_column(xy: Vec<f32>) -> Result<SerializedComponentColumn, BoxedError> {
    let rows = xy.len() / 2;
    let DataType::FixedSizeList(item, 2) = Position2D::arrow_datatype() else {
        return Err("unexpected Position2D datatype".into());
    };
    let array: ArrayRef = Arc::new(FixedSizeListArray::try_new(
        item,
        2,
        Arc::new(Float32Array::from(xy)),
        None,
    )?);
    Ok(
        SerializedComponentBatch::new(array, Points2D::descriptor_positions())
            .partitioned(std::iter::repeat_n(1, rows))?,
    )
}

fn timeline_columns(steps: &[i64], times: &[f64]) -> [TimeColumn; 2] {
    [
        TimeColumn::new_sequence(STEP, steps.iter().copied()),
        TimeColumn::new_duration_secs(SIM_TIME, times.iter().copied()),
    ]
}

/// Sends a link's buffered poses as `Transform3D` translation and rotation-axis-angle columns (one
/// row per sample, unless empty). The Arrow arrays are built directly from the buffers, with the
/// components' own datatypes: this is several times cheaper than serializing component structs.
fn send_poses(
    stream: &RecordingStream,
    link: &LinkPoses,
    timelines: [TimeColumn; 2],
) -> Result<(), String> {
    let rows = link.angles.len();
    if rows == 0 {
        return Ok(());
    }
    let columns = pose_columns(&link.translations, &link.angles).map_err(|e| error_chain(&*e))?;
    stream
        .send_columns(link.entity.clone(), timelines, columns)
        .map_err(|err| error_chain(&err))
}

type BoxedError = Box<dyn std::error::Error + Send + Sync>;

/// Translation (x, y, 0 triples) and rotation-about-z (angles) columns of unit batches.
fn pose_columns(
    translations: &[f32],
    angles: &[f32],
) -> Result<[SerializedComponentColumn; 2], BoxedError> {
    let rows = angles.len();
    debug_assert_eq!(translations.len(), 3 * rows);
    let vec3 = |xyz: Vec<f32>, datatype: DataType| -> Result<ArrayRef, BoxedError> {
        let DataType::FixedSizeList(item, 3) = datatype else {
            return Err(format!("unexpected Vec3D datatype {datatype}").into());
        };
        Ok(Arc::new(FixedSizeListArray::try_new(
            item,
            3,
            Arc::new(Float32Array::from(xyz)),
            None,
        )?))
    };
    let translation = vec3(translations.to_vec(), Translation3D::arrow_datatype())?;
    let DataType::Struct(fields) = RotationAxisAngle::arrow_datatype() else {
        return Err("unexpected RotationAxisAngle datatype".into());
    };
    let axes = vec3([0.0, 0.0, 1.0].repeat(rows), fields[0].data_type().clone())?;
    let rotation: ArrayRef = Arc::new(StructArray::try_new(
        fields,
        vec![axes, Arc::new(Float32Array::from(angles.to_vec()))],
        None,
    )?);
    let unit = std::iter::repeat_n(1, rows);
    Ok([
        SerializedComponentBatch::new(translation, Transform3D::descriptor_translation())
            .partitioned(unit.clone())?,
        SerializedComponentBatch::new(rotation, Transform3D::descriptor_rotation_axis_angle())
            .partitioned(unit)?,
    ])
}

/// The link's shapes as closed line strips in the link frame (a circle also gets a radius, so that
/// its rotation shows), or `None` when it has none.
fn link_strips(shapes: &[Shape], default_color: [u8; 3]) -> Option<LineStrips2D> {
    let mut strips: Vec<Vec<[f32; 2]>> = Vec::new();
    let mut colors: Vec<Color> = Vec::new();
    for shape in shapes {
        let color = match shape.color {
            Some(rgba) => {
                let [r, g, b, a] = rgba.map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8);
                Color::from_unmultiplied_rgba(r, g, b, a)
            }
            None => Color::from_rgb(default_color[0], default_color[1], default_color[2]),
        };
        let point = |x: f64, y: f64| {
            let [px, py] = shape.origin.apply(x, y);
            [px as f32, py as f32]
        };
        match &shape.outline {
            &Outline::Rectangle { width, height } => {
                let (hx, hy) = (width / 2.0, height / 2.0);
                strips.push(vec![
                    point(-hx, -hy),
                    point(hx, -hy),
                    point(hx, hy),
                    point(-hx, hy),
                    point(-hx, -hy),
                ]);
                colors.push(color);
            }
            &Outline::Circle { radius } => {
                strips.push(
                    (0..=CIRCLE_SEGMENTS)
                        .map(|i| {
                            let a = std::f64::consts::TAU * i as f64 / CIRCLE_SEGMENTS as f64;
                            point(radius * a.cos(), radius * a.sin())
                        })
                        .collect(),
                );
                strips.push(vec![point(0.0, 0.0), point(radius, 0.0)]);
                colors.extend([color, color]);
            }
            Outline::Polygon { points } => {
                let closed = points.iter().chain(points.first());
                strips.push(closed.map(|&[x, y]| point(x, y)).collect());
                colors.push(color);
            }
        }
    }
    (!strips.is_empty()).then(|| LineStrips2D::new(strips).with_colors(colors))
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
