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
use rerun::datatypes::Angle;
use rerun::external::arrow::array::Float64Array;
use rerun::{
    EntityPath, EntityPathPart, RecordingStream, RecordingStreamBuilder, SerializedComponentBatch,
    TimeColumn,
};

use crate::mechanism::{Outline, Pose2, Shape};

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
    links: Vec<EntityPath>,
    groups: Vec<Group>,
    /// Total number of values per sample (sum of the groups' widths).
    width: usize,
    steps: Vec<i64>,
    times: Vec<f64>,
    /// Per link, per buffered sample: x, y, angle wrapped to (-π, π].
    poses: Vec<Vec<[f32; 3]>>,
    /// The first error met while sending buffered columns from `push`, reported by `finish`.
    deferred_error: Option<String>,
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

        let links: Vec<EntityPath> = layout
            .links
            .iter()
            .map(|(name, _)| {
                EntityPath::new(vec![
                    EntityPathPart::new(MECHANISM),
                    EntityPathPart::new(name.as_str()),
                ])
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

        let stream =
            RecordingStreamBuilder::new(rerun::ApplicationId::new_or_unknown(layout.app.clone()))
                .recording_name(layout.app.as_str())
                // Ignore the `RERUN` environment variable: the file is the run's product.
                .enabled(true)
                .with_blueprint(blueprint::default_blueprint(&plots))
                .save(path)
                .map_err(|err| create_error(error_chain(&err)))?;

        let log_static = |entity: &EntityPath, archetype: &dyn rerun::AsComponents| {
            stream
                .log_static(entity.clone(), archetype)
                .map_err(|err| create_error(error_chain(&err)))
        };
        log_static(
            &EntityPath::from(MECHANISM),
            &Transform3D::from_scale([1.0, -1.0, 1.0]),
        )?;
        for (index, ((_, shapes), entity)) in layout.links.iter().zip(&links).enumerate() {
            if let Some(strips) = link_strips(shapes, PALETTE[index % PALETTE.len()]) {
                log_static(entity, &strips)?;
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
            poses: vec![Vec::with_capacity(FLUSH_EVERY); links.len()],
            links,
            groups,
            width,
            steps: Vec::with_capacity(FLUSH_EVERY),
            times: Vec::with_capacity(FLUSH_EVERY),
            deferred_error: None,
        })
    }

    /// Buffers one sample: step index, simulated time (s), every link's world pose (in the order of
    /// `layout.links`) and the concatenated series values. Missing values are recorded as NaN,
    /// extra ones ignored; a missing or non-finite pose leaves the link at its last finite pose.
    pub fn push(&mut self, step: i64, time: f64, link_poses: &[Pose2], values: &[f64]) {
        debug_assert_eq!(link_poses.len(), self.links.len(), "one pose per link");
        debug_assert_eq!(values.len(), self.width, "one value per signal");
        self.steps.push(step);
        self.times.push(time);
        for (link, buffer) in self.poses.iter_mut().enumerate() {
            buffer.push(match link_poses.get(link) {
                Some(pose) => [pose.x as f32, pose.y as f32, wrap_angle(pose.angle) as f32],
                None => [f32::NAN; 3],
            });
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

        for (entity, poses) in self.links.iter().zip(&mut self.poses) {
            let finite = |p: &[f32; 3]| p.iter().all(|v| v.is_finite());
            let result = if poses.iter().all(finite) {
                send_poses(stream, entity, timelines.clone(), poses.iter())
            } else {
                let kept: Vec<usize> = (0..rows).filter(|&i| finite(&poses[i])).collect();
                if kept.is_empty() {
                    Ok(())
                } else {
                    let steps: Vec<i64> = kept.iter().map(|&i| self.steps[i]).collect();
                    let times: Vec<f64> = kept.iter().map(|&i| self.times[i]).collect();
                    send_poses(
                        stream,
                        entity,
                        timeline_columns(&steps, &times),
                        kept.iter().map(|&i| &poses[i]),
                    )
                }
            };
            note(result);
            poses.clear();
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
        TimeColumn::new_duration_secs(SIM_TIME, times.iter().map(|&t| sanitize_time(t))),
    ]
}

/// A non-finite time would be clamped with a warning per sample; map it to 0 quietly.
fn sanitize_time(t: f64) -> f64 {
    if t.is_finite() {
        t
    } else {
        0.0
    }
}

fn send_poses<'a>(
    stream: &RecordingStream,
    entity: &EntityPath,
    timelines: [TimeColumn; 2],
    poses: impl Iterator<Item = &'a [f32; 3]> + Clone,
) -> Result<(), String> {
    let columns = Transform3D::update_fields()
        .with_many_translation(poses.clone().map(|p| Translation3D::new(p[0], p[1], 0.0)))
        .with_many_rotation_axis_angle(
            poses.map(|p| RotationAxisAngle::new([0.0, 0.0, 1.0], Angle::from_radians(p[2]))),
        )
        .columns_of_unit_batches()
        .map_err(|err| error_chain(&err))?;
    stream
        .send_columns(entity.clone(), timelines, columns)
        .map_err(|err| error_chain(&err))
}

/// The angle in (-π, π], keeping f32 precision over many turns.
fn wrap_angle(angle: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    if angle.is_finite() && !(-PI < angle && angle <= PI) {
        let wrapped = angle.rem_euclid(TAU);
        if wrapped > PI {
            wrapped - TAU
        } else {
            wrapped
        }
    } else {
        angle
    }
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
