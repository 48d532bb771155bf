//! The recording off the run's thread. A [`BackgroundRecorder`] copies each sample a run gives it
//! into a batch and hands the batches, with the run's events, crashes, summary and figures, in
//! the order it got them, to a writer thread that owns the [`Recorder`]. A recorded step then
//! costs the run's thread a copy of its values; converting, buffering, encoding and writing are
//! the writer's. The file is byte for byte the one the recorder alone writes: it gets the same
//! calls in the same order.
//!
//! A failed write is reported by the next call once the writer has met it. The run is at most
//! [`QUEUED`] batches of [`BATCH`] samples ahead of the writer, and the writer at most one
//! buffer ahead of the file ([`Recorder::push`]), so a run still stops within a few thousand
//! samples of a full disk.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{channel, sync_channel, Receiver, Sender, SyncSender};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

use super::error::RecordingError;
use super::plot_data::Plot2D;
use super::recorder::{Recorder, RecordingOutcome};
use crate::mechanism::Pose2;
use framework::EventLevel;

/// Samples a batch holds before it is handed to the writer.
pub(super) const BATCH: usize = 256;
/// Batches and messages waiting for the writer before the run waits for it.
pub(super) const QUEUED: usize = 8;

/// A recording written by a thread of its own. Dropped without [`BackgroundRecorder::finish`]
/// (an error or a panic), it leaves no file, as [`Recorder`] does.
pub struct BackgroundRecorder {
    path: PathBuf,
    /// `None` once finished.
    work: Option<SyncSender<Work>>,
    writer: Option<JoinHandle<Result<RecordingOutcome, RecordingError>>>,
    failure: Arc<Failure>,
    batch: Batch,
    /// Batches the writer is done with, to be filled again.
    spare: Receiver<Batch>,
}

/// What the writer is given, in the run's order.
enum Work {
    Samples(Batch),
    Event {
        step: i64,
        time: f64,
        level: EventLevel,
        text: String,
    },
    Collisions {
        step: i64,
        time: f64,
        collisions: Vec<([f64; 2], String)>,
    },
    Summary(String),
    Figure(String, Plot2D),
    /// The run is over: complete the file.
    Finish,
}

/// Samples laid end to end, each with where its poses, values and markers end.
#[derive(Default)]
struct Batch {
    steps: Vec<i64>,
    times: Vec<f64>,
    ends: Vec<[usize; 3]>,
    poses: Vec<Pose2>,
    values: Vec<f64>,
    markers: Vec<[f64; 2]>,
}

impl Batch {
    /// An empty batch with room for as much as this one holds.
    fn empty_alike(&self) -> Self {
        Self {
            steps: Vec::with_capacity(self.steps.len()),
            times: Vec::with_capacity(self.times.len()),
            ends: Vec::with_capacity(self.ends.len()),
            poses: Vec::with_capacity(self.poses.len()),
            values: Vec::with_capacity(self.values.len()),
            markers: Vec::with_capacity(self.markers.len()),
        }
    }
}

/// The writer's first error, seen by the run's thread.
#[derive(Default)]
struct Failure {
    set: AtomicBool,
    error: Mutex<Option<RecordingError>>,
}

impl BackgroundRecorder {
    /// Hands `recorder`, created (its path checked, its static parts logged), to a writer thread.
    pub fn start(recorder: Recorder) -> Result<Self, RecordingError> {
        let path = recorder.path().to_path_buf();
        let (work, queue) = sync_channel(QUEUED);
        let (give_back, spare) = channel();
        let failure = Arc::new(Failure::default());
        let seen = Arc::clone(&failure);
        let writer = std::thread::Builder::new()
            .name("twin-recorder".into())
            .spawn(move || write(recorder, &queue, &give_back, &seen))
            .map_err(|err| RecordingError::Create {
                path: path.clone(),
                reason: format!("cannot start its writer thread: {err}"),
            })?;
        Ok(Self {
            path,
            work: Some(work),
            writer: Some(writer),
            failure,
            batch: Batch::default(),
            spare,
        })
    }

    /// Records one sample, as [`Recorder::push`].
    pub fn push(
        &mut self,
        step: i64,
        time: f64,
        link_poses: &[Pose2],
        values: &[f64],
        markers: &[[f64; 2]],
    ) -> Result<(), RecordingError> {
        self.check()?;
        let batch = &mut self.batch;
        batch.steps.push(step);
        batch.times.push(time);
        batch.poses.extend_from_slice(link_poses);
        batch.values.extend_from_slice(values);
        batch.markers.extend_from_slice(markers);
        (batch.ends).push([batch.poses.len(), batch.values.len(), batch.markers.len()]);
        if batch.steps.len() >= BATCH {
            self.hand_over()?;
        }
        Ok(())
    }

    /// Logs an event, as [`Recorder::event`].
    pub fn event(
        &mut self,
        step: i64,
        time: f64,
        level: EventLevel,
        text: &str,
    ) -> Result<(), RecordingError> {
        let text = text.to_owned();
        self.send(Work::Event {
            step,
            time,
            level,
            text,
        })
    }

    /// Draws the crashes so far, as [`Recorder::collisions`].
    pub fn collisions(
        &mut self,
        step: i64,
        time: f64,
        collisions: &[([f64; 2], String)],
    ) -> Result<(), RecordingError> {
        let collisions = collisions.to_vec();
        self.send(Work::Collisions {
            step,
            time,
            collisions,
        })
    }

    /// Writes the run's summary, as [`Recorder::summary`].
    pub fn summary(&mut self, markdown: &str) -> Result<(), RecordingError> {
        self.send(Work::Summary(markdown.to_owned()))
    }

    /// Draws a figure, as [`Recorder::figure`].
    pub fn figure(&mut self, name: &str, plot: &Plot2D) -> Result<(), RecordingError> {
        self.send(Work::Figure(name.to_owned(), plot.clone()))
    }

    /// Completes the file, as [`Recorder::finish`], once the writer has written everything.
    pub fn finish(mut self) -> Result<RecordingOutcome, RecordingError> {
        let sent = self.send(Work::Finish);
        drop(self.work.take());
        let written = self.join();
        sent.and(written)
    }

    /// Sends `work` after the samples before it.
    fn send(&mut self, work: Work) -> Result<(), RecordingError> {
        self.check()?;
        self.hand_over()?;
        self.queue(work)
    }

    /// Hands the batch being filled, if any, to the writer.
    fn hand_over(&mut self) -> Result<(), RecordingError> {
        if self.batch.steps.is_empty() {
            return Ok(());
        }
        // A batch the writer gave back, or one made as large as this one at once (grown
        // sample by sample it would be copied over and over).
        let fresh = (self.spare.try_recv()).unwrap_or_else(|_| self.batch.empty_alike());
        let full = std::mem::replace(&mut self.batch, fresh);
        self.queue(Work::Samples(full))
    }

    fn queue(&mut self, work: Work) -> Result<(), RecordingError> {
        let sent = self
            .work
            .as_ref()
            .is_none_or(|queue| queue.send(work).is_ok());
        match sent {
            true => Ok(()),
            // The writer is gone: it failed (its error says why) or panicked.
            false => self.check().and(Err(self.stopped())),
        }
    }

    /// The writer's first error, if it has met one.
    fn check(&self) -> Result<(), RecordingError> {
        if !self.failure.set.load(Ordering::Acquire) {
            return Ok(());
        }
        match self.failure.error.lock().map(|error| error.clone()) {
            Ok(Some(error)) => Err(error),
            _ => Err(self.stopped()),
        }
    }

    /// Waits for the writer to end, with how the file came out.
    fn join(&mut self) -> Result<RecordingOutcome, RecordingError> {
        match self.writer.take().map(JoinHandle::join) {
            Some(Ok(outcome)) => outcome,
            Some(Err(_)) | None => Err(self.stopped()),
        }
    }

    fn stopped(&self) -> RecordingError {
        RecordingError::Write {
            path: self.path.clone(),
            reason: "the recording's writer thread stopped".into(),
        }
    }
}

impl Drop for BackgroundRecorder {
    /// Without [`BackgroundRecorder::finish`], the writer drops its recorder, which removes the
    /// temporary file; the thread is waited for, so the file is gone on return.
    fn drop(&mut self) {
        drop(self.work.take());
        if let Some(writer) = self.writer.take() {
            let _ = writer.join();
        }
    }
}

/// The writer thread: every piece of work in order until the run finishes, or until the queue
/// is dropped (the run ended without finishing: nothing is left). After a failure it only
/// drains the queue, so that the run never waits on it.
fn write(
    mut recorder: Recorder,
    queue: &Receiver<Work>,
    give_back: &Sender<Batch>,
    failure: &Failure,
) -> Result<RecordingOutcome, RecordingError> {
    let path = recorder.path().to_path_buf();
    let failed = || match failure.error.lock().map(|error| error.clone()) {
        Ok(Some(error)) => error,
        _ => RecordingError::Write {
            path: path.clone(),
            reason: "the run ended without completing the recording".into(),
        },
    };
    for work in queue {
        let finish = matches!(work, Work::Finish);
        if failure.set.load(Ordering::Acquire) {
            match finish {
                true => return Err(failed()),
                false => continue,
            }
        }
        let done = match work {
            Work::Finish => return recorder.finish(),
            Work::Samples(batch) => record(&mut recorder, batch, give_back),
            Work::Event {
                step,
                time,
                level,
                text,
            } => recorder.event(step, time, level, &text),
            Work::Collisions {
                step,
                time,
                collisions,
            } => recorder.collisions(step, time, &collisions),
            Work::Summary(markdown) => recorder.summary(&markdown),
            Work::Figure(name, plot) => recorder.figure(&name, &plot),
        };
        if let Err(error) = done {
            if let Ok(mut slot) = failure.error.lock() {
                *slot = Some(error);
            }
            failure.set.store(true, Ordering::Release);
        }
    }
    Err(failed())
}

/// Pushes a batch's samples in order, then gives the emptied batch back.
fn record(
    recorder: &mut Recorder,
    mut batch: Batch,
    give_back: &Sender<Batch>,
) -> Result<(), RecordingError> {
    let mut start = [0; 3];
    for (k, end) in batch.ends.iter().enumerate() {
        recorder.push(
            batch.steps[k],
            batch.times[k],
            &batch.poses[start[0]..end[0]],
            &batch.values[start[1]..end[1]],
            &batch.markers[start[2]..end[2]],
        )?;
        start = *end;
    }
    batch.steps.clear();
    batch.times.clear();
    batch.ends.clear();
    batch.poses.clear();
    batch.values.clear();
    batch.markers.clear();
    // The run may have finished and stopped taking batches back.
    let _ = give_back.send(batch);
    Ok(())
}
