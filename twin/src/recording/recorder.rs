//! The [`Recorder`]: one run written to its `.rrd` file sample by sample, atomically, with the
//! samples buffered and sent in columns.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use rerun::archetypes::{LineStrips2D, Points2D, Scalars, TextDocument, TextLog};
use rerun::components::{Color, MediaType, Radius, TextLogLevel};
use rerun::external::arrow::array::Float64Array;
use rerun::log::ChunkBatcherConfig;
use rerun::sink::LogSink;
use rerun::{EntityPath, RecordingStream, RecordingStreamBuilder, SerializedComponentBatch};

use super::columns::{send_marker, send_poses, timeline_columns, Group, LinkPoses, MarkerBuffer};
use super::drawing::{body_entity, link_entity, log_layout, scene_entity};
use super::entities::{
    application_id, COLLISIONS, EVENTS, FLUSH_EVERY, MAX_BYTES_IN_FLIGHT, SUMMARY, TRACE_EVERY,
};
use super::error::{error_chain, RecordingError};
use super::ids::RunIds;
use super::layout::{figure_entity, PlotSpec, RecordingLayout};
use super::live::LiveHandle;
use super::plot_data::Plot2D;
use super::plots;
use super::style::COLLISION_COLOR;
use super::writer::{FileState, FileWriter, PartFile};
use super::{blueprint, live};
use crate::mechanism::{wrap_angle, Pose2};
use framework::EventLevel;

/// Writes one run to an `.rrd` file, atomically: the data goes to a temporary file beside `path`
/// (`X.rrd.<random>.part`), which [`Recorder::finish`] completes and renames onto `path`. A file at
/// `path` is therefore always a complete recording; on an error, or when the recorder is dropped
/// without `finish` (a panic), the temporary file is removed. A run killed outright (`kill -9`)
/// leaves it behind, and [`salvage()`] makes a complete recording of it.
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
    pub(super) stream: Option<RecordingStream>,
    /// The file and its first write failure, shared with the stream's sink.
    file: Arc<FileState>,
    /// How the live viewer fared, if there is one.
    live: Option<LiveHandle>,
    /// Flushes of the pipeline started, one per buffer sent from `push`.
    flushes: u64,
    /// The ids of the chunks the recorder sends.
    ids: RunIds,
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
            ids: RunIds::new(),
            links,
            groups,
            markers,
            samples: 0,
            steps: Vec::with_capacity(FLUSH_EVERY),
            times: Vec::with_capacity(FLUSH_EVERY),
            last_time: 0.0,
        })
    }

    /// The recording's path, where [`Recorder::finish`] puts it.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Where the run is being written until [`Recorder::finish`] renames it onto its path: what a
    /// killed run leaves behind, for [`salvage`].
    #[cfg(test)]
    pub fn part_path(&self) -> &Path {
        &self.part_path
    }

    /// Buffers one sample: step index, simulated time (s), every link's world pose (in the order of
    /// `layout.links`, then the bodies' in the order of `layout.bodies`), the SI values the plots'
    /// series pick from and the scene markers' positions (in the order of `layout.scene.markers`).
    /// Values are recorded in their plot's unit (NaN and infinities included); missing ones are
    /// recorded as NaN. A missing or non-finite pose or marker position is left out, so it stays
    /// drawn at its last finite place. A non-finite time is replaced by the last finite one.
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
                let timelines = timeline_columns(&[step], &[time]);
                self.ids
                    .send_columns(stream, EVENTS.into(), timelines, columns)
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
                let timelines = timeline_columns(&[step], &[time]);
                self.ids
                    .send_columns(stream, COLLISIONS.into(), timelines, columns)
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
            let timelines = timeline_columns(&[step], &[self.last_time]);
            self.ids
                .send_columns(stream, entity.clone(), timelines, columns)?;
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
        let ids = &mut self.ids;
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
                        let entity = group.entity.clone();
                        ids.send_columns(stream, entity, timelines.clone(), [column])
                    }),
            );
        }

        for link in &mut self.links {
            let result = if link.all_finite {
                send_poses(stream, ids, link, timelines.clone())
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
                send_poses(stream, ids, link, timeline_columns(&steps, &times))
            };
            note(result);
            link.translations.clear();
            link.angles.clear();
            link.all_finite = true;
        }

        for marker in &mut self.markers {
            note(send_marker(stream, ids, marker, &self.steps, &self.times));
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
pub(super) fn buffers(layout: &RecordingLayout) -> (Vec<LinkPoses>, Vec<Group>, Vec<MarkerBuffer>) {
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

/// An event's text as the log shows it: without a leading "warning:" (the level says so), and
/// wrapped at word boundaries so that long events stay readable.
pub(super) fn event_text(text: &str) -> String {
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
