//! Writing a simulation run to a Rerun `.rrd` recording. This is the only module of the crate that
//! knows Rerun types.
//!
//! Layout of a recording:
//! - `/mechanism`: a static `Transform3D` flipping y (2D views are y-down; the mechanism is y-up);
//! - `/mechanism/<link>`: the link's shapes as static 2D line strips in the link frame, and its
//!   world pose as a temporal `Transform3D` (translation + rotation about z);
//! - `/signals/<group>`: one multi-instance `Scalars` per series group, with static `SeriesLines`
//!   naming the instances;
//! - `/events`: a `TextLog`;
//! - `/scenario`: the scenario TOML as a static plain-text `TextDocument`.
//!
//! Every sample is on two timelines: `step` (sequence) and `sim_time` (duration). Samples are
//! buffered in columns and sent with `send_columns` every [`FLUSH_EVERY`] samples and at the end.

mod blueprint;
mod plots;

pub use plots::{write_plot, Plot2D, PlotGeometry, PlotLayer};

use std::path::{Path, PathBuf};
use std::sync::Arc;

use rerun::archetypes::{LineStrips2D, Scalars, SeriesLines, TextDocument, TextLog, Transform3D};
use rerun::components::{Color, MediaType, RotationAxisAngle, TextLogLevel, Translation3D};
use rerun::external::arrow::array::{
    ArrayRef, FixedSizeListArray, Float32Array, Float64Array, StructArray,
};
use rerun::external::arrow::datatypes::DataType;
use rerun::log::ChunkBatcherConfig;
use rerun::{
    ApplicationId, EntityPath, EntityPathPart, Loggable, RecordingStream, RecordingStreamBuilder,
    SerializedComponentBatch, SerializedComponentColumn, TimeColumn,
};

use crate::mechanism::{wrap_angle, Outline, Pose2, Shape};

const MECHANISM: &str = "mechanism";
const SIGNALS: &str = "signals";
const EVENTS: &str = "events";
const SCENARIO: &str = "scenario";
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
/// Colours of shapes without a material, per link.
const PALETTE: [[u8; 3]; 6] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
];

/// What a recording contains, fixed before the run starts.
#[derive(Debug, Clone, Default)]
pub struct RecordingLayout {
    /// Application id / recording name (the scenario name).
    pub app: String,
    /// The scenario TOML, stored as a static text document (provenance).
    pub scenario_toml: String,
    /// Links to draw: name and shapes in the link frame (drawn as 2D line strips).
    pub links: Vec<(String, Vec<Shape>)>,
    /// Time-series groups: each is a Rerun entity path under `signals/` (e.g. "joints/position",
    /// "effort/commanded", "effort/applied", "task", "controller", "process") and the names of its
    /// signals. The values passed to [`Recorder::push`] are these groups' signals concatenated in
    /// this order.
    pub series: Vec<SeriesGroup>,
    /// Also stream the run to a live viewer while it is written to the file.
    pub live: Option<LiveViewer>,
}

/// A Rerun viewer watching the run as it happens, besides the file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LiveViewer {
    /// A viewer already listening at this gRPC URL (e.g. `rerun+http://127.0.0.1:9876/proxy`).
    Connect(String),
    /// Start a viewer from the `rerun` executable on PATH and stream to it.
    Spawn,
}

/// A set of signals plotted together, recorded as one multi-instance scalar entity.
#[derive(Debug, Clone, Default)]
pub struct SeriesGroup {
    pub path: String,
    pub names: Vec<String>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EventLevel {
    Info,
    Warning,
    Error,
}

#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    #[error("cannot create the recording {}: {reason}", path.display())]
    Create { path: PathBuf, reason: String },
    #[error("cannot write the recording {}: {reason}", path.display())]
    Write { path: PathBuf, reason: String },
}

/// Writes one run to an `.rrd` file. Samples are buffered and sent in columns; the file is complete
/// (footer written) after [`Recorder::finish`], or when the recorder is dropped.
pub struct Recorder {
    path: PathBuf,
    /// `None` once closed.
    stream: Option<RecordingStream>,
    links: Vec<LinkPoses>,
    groups: Vec<Group>,
    /// Total number of values per sample (sum of the groups' widths).
    width: usize,
    steps: Vec<i64>,
    times: Vec<f64>,
    /// The last finite time pushed, which stands in for a non-finite one.
    last_time: f64,
    /// The first error met while sending buffered columns from `push`, reported by `finish`.
    deferred_error: Option<String>,
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

struct Group {
    entity: EntityPath,
    width: usize,
    /// Row-major: `width` values per buffered sample.
    values: Vec<f64>,
}

impl Recorder {
    /// Opens `path` for writing and logs the static parts: the y-up root transform, the link
    /// shapes, the scenario text, the series names and the default blueprint.
    pub fn create(path: &Path, layout: &RecordingLayout) -> Result<Recorder, RecordingError> {
        let create_error = |reason: String| RecordingError::Create {
            path: path.to_path_buf(),
            reason,
        };

        let links: Vec<LinkPoses> = layout
            .links
            .iter()
            .map(|(name, _)| LinkPoses {
                entity: EntityPath::new(vec![
                    EntityPathPart::new(MECHANISM),
                    EntityPathPart::new(name.as_str()),
                ]),
                translations: Vec::with_capacity(3 * FLUSH_EVERY),
                angles: Vec::with_capacity(FLUSH_EVERY),
                all_finite: true,
            })
            .collect();
        let groups: Vec<Group> = layout
            .series
            .iter()
            .map(|group| Group {
                entity: EntityPath::from(format!("{SIGNALS}/{}", group.path.trim_matches('/'))),
                width: group.names.len(),
                values: Vec::with_capacity(FLUSH_EVERY * group.names.len()),
            })
            .collect();
        let plots: Vec<(EntityPath, String)> = groups
            .iter()
            .zip(&layout.series)
            .filter(|(group, _)| group.width > 0)
            .map(|(group, series)| (group.entity.clone(), series.path.clone()))
            .collect();

        let builder = RecordingStreamBuilder::new(application_id(&layout.app))
            .recording_name(layout.app.as_str())
            // Ignore the `RERUN` environment variable: the file is the run's product.
            .enabled(true)
            // Bounds the data queued towards the file (the default allows 100 MiB).
            .batcher_config(ChunkBatcherConfig {
                max_bytes_in_flight: MAX_BYTES_IN_FLIGHT,
                ..ChunkBatcherConfig::DEFAULT
            })
            .with_blueprint(blueprint::default_blueprint(&plots));
        let stream = match &layout.live {
            None => builder.save(path),
            Some(live) => {
                let viewer = grpc_sink(live).map_err(create_error)?;
                match rerun::sink::FileSink::new(path) {
                    Ok(file) => builder.set_sinks((file, viewer)),
                    Err(err) => Err(rerun::RecordingStreamError::FileSink(err)),
                }
            }
        }
        .map_err(|err| match err {
            // The usual case (missing directory, no permission): the OS's reason is enough.
            rerun::RecordingStreamError::FileSink(rerun::sink::FileSinkError::CreateFile {
                source,
                ..
            }) => create_error(source.to_string()),
            other => create_error(error_chain(&other)),
        })?;

        let log_static = |entity: &EntityPath, archetype: &dyn rerun::AsComponents| {
            stream
                .log_static(entity.clone(), archetype)
                .map_err(|err| create_error(error_chain(&err)))
        };
        log_static(
            &EntityPath::from(MECHANISM),
            &Transform3D::from_scale([1.0, -1.0, 1.0]),
        )?;
        for (index, ((_, shapes), link)) in layout.links.iter().zip(&links).enumerate() {
            if let Some(strips) = link_strips(shapes, PALETTE[index % PALETTE.len()]) {
                log_static(&link.entity, &strips)?;
            }
        }
        log_static(
            &EntityPath::from(SCENARIO),
            &TextDocument::new(layout.scenario_toml.as_str())
                .with_media_type(MediaType::plain_text()),
        )?;
        for (group, series) in groups.iter().zip(&layout.series) {
            if group.width > 0 {
                log_static(
                    &group.entity,
                    &SeriesLines::new().with_names(series.names.iter().map(String::as_str)),
                )?;
            }
        }

        let width = groups.iter().map(|g| g.width).sum();
        Ok(Recorder {
            path: path.to_path_buf(),
            stream: Some(stream),
            links,
            groups,
            width,
            steps: Vec::with_capacity(FLUSH_EVERY),
            times: Vec::with_capacity(FLUSH_EVERY),
            last_time: 0.0,
            deferred_error: None,
        })
    }

    /// Buffers one sample: step index, simulated time (s), every link's world pose (in the order of
    /// `layout.links`) and the concatenated series values. Values are recorded as given (NaN and
    /// infinities included); missing ones are recorded as NaN, extra ones ignored. A missing or
    /// non-finite pose is left out, so the link stays drawn at its last finite pose. A non-finite
    /// time is replaced by the last finite one.
    pub fn push(&mut self, step: i64, time: f64, link_poses: &[Pose2], values: &[f64]) {
        debug_assert_eq!(link_poses.len(), self.links.len(), "one pose per link");
        debug_assert_eq!(values.len(), self.width, "one value per signal");
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
        let mut offset = 0;
        for group in &mut self.groups {
            let end = offset + group.width;
            if end <= values.len() {
                group.values.extend_from_slice(&values[offset..end]);
            } else {
                let present = &values[offset.min(values.len())..];
                group.values.extend_from_slice(present);
                group
                    .values
                    .extend(std::iter::repeat_n(f64::NAN, group.width - present.len()));
            }
            offset = end;
        }
        if self.steps.len() >= FLUSH_EVERY {
            if let Err(reason) = self.send_buffered() {
                self.deferred_error.get_or_insert(reason);
            }
        }
    }

    /// Logs an event to the text log `events` at that step and time.
    pub fn event(&mut self, step: i64, time: f64, level: EventLevel, text: &str) {
        let Some(stream) = &self.stream else {
            return;
        };
        let level = match level {
            EventLevel::Info => TextLogLevel::INFO,
            EventLevel::Warning => TextLogLevel::WARN,
            EventLevel::Error => TextLogLevel::ERROR,
        };
        let result = TextLog::new(text)
            .with_level(level)
            .columns_of_unit_batches()
            .map_err(|err| error_chain(&err))
            .and_then(|columns| {
                let time = if time.is_finite() {
                    time
                } else {
                    self.last_time
                };
                stream
                    .send_columns(EVENTS, timeline_columns(&[step], &[time]), columns)
                    .map_err(|err| error_chain(&err))
            });
        if let Err(reason) = result {
            self.deferred_error.get_or_insert(reason);
        }
    }

    /// Sends the buffered samples, then closes the file so that its footer is written.
    pub fn finish(mut self) -> Result<(), RecordingError> {
        self.close()
    }

    /// Sends what is buffered, flushes and drops the stream (which writes the footer). Idempotent.
    fn close(&mut self) -> Result<(), RecordingError> {
        if self.stream.is_none() {
            return Ok(());
        }
        let sent = self.send_buffered();
        let stream = self.stream.take().expect("checked above");
        let flushed = stream.flush_blocking().map_err(|err| error_chain(&err));
        // The last handle: dropping it joins the writer thread, which writes the footer.
        drop(stream);
        let write_error = |reason: String| RecordingError::Write {
            path: self.path.clone(),
            reason,
        };
        if let Some(reason) = self.deferred_error.take() {
            return Err(write_error(reason));
        }
        sent.map_err(write_error)?;
        flushed.map_err(write_error)?;
        match std::fs::metadata(&self.path) {
            Ok(meta) if meta.len() > 0 => Ok(()),
            Ok(_) => Err(write_error("the file is empty".to_owned())),
            Err(err) => Err(write_error(err.to_string())),
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
            if group.width == 0 {
                continue;
            }
            let values = std::mem::replace(
                &mut group.values,
                Vec::with_capacity(FLUSH_EVERY * group.width),
            );
            let batch = SerializedComponentBatch::new(
                Arc::new(Float64Array::from(values)),
                Scalars::descriptor_scalars(),
            );
            note(
                batch
                    .partitioned(std::iter::repeat_n(group.width, rows))
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

        self.steps.clear();
        self.times.clear();
        first_error.map_or(Ok(()), Err)
    }
}

impl Drop for Recorder {
    /// A recorder dropped without [`Recorder::finish`] (an error path) still sends what it buffered
    /// and closes the file; errors can only be ignored here.
    fn drop(&mut self) {
        let _ = self.close();
    }
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
        match shape.outline {
            Outline::Rectangle { width, height } => {
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
            Outline::Circle { radius } => {
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

/// The gRPC sink of a live viewer: the given URL, or a viewer spawned from PATH.
fn grpc_sink(live: &LiveViewer) -> Result<rerun::sink::GrpcSink, String> {
    let url = match live {
        LiveViewer::Connect(url) => url.clone(),
        LiveViewer::Spawn => {
            let viewer = rerun::spawn(&rerun::SpawnOptions::default())
                .map_err(|e| format!("cannot start a Rerun viewer: {e}"))?;
            format!("rerun+http://127.0.0.1:{}/proxy", viewer.port)
        }
    };
    let uri = url
        .parse()
        .map_err(|e| format!("bad viewer URL `{url}`: {e}"))?;
    Ok(rerun::sink::GrpcSink::new(uri))
}

#[cfg(test)]
mod tests;
