//! Streaming a run to a live Rerun viewer on a path of its own, so that a missing, slow or
//! vanished viewer never holds up the run nor costs the file.
//!
//! The file's sink offers each message to a bounded queue without waiting ([`LiveFeed::offer`]);
//! a feeder thread passes them on to Rerun's gRPC sink, which may block (it waits for a viewer
//! that is not there yet, or for a slow one). When the queue is full, messages are dropped for the
//! viewer only, and counted. At the end, the recorder waits at most [`LIVE_FINISH_TIMEOUT`] for the
//! viewer to have taken everything; a feeder still blocked then is left behind (it ends with the
//! process), and the outcome carries a warning instead.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, SyncSender, TrySendError};
use std::sync::Arc;
use std::time::Duration;

use rerun::log::LogMsg;
use rerun::sink::{GrpcSink, LogSink};

/// Messages queued for the viewer beyond what Rerun's gRPC sink holds itself (100). A message is
/// one chunk: at most a few hundred kB, so this bounds the memory a stalled viewer can cost.
const LIVE_QUEUE: usize = 256;
/// The longest `Recorder::finish` waits for the viewer. Rerun's gRPC sink gives up connecting
/// after 5 s as well.
pub(super) const LIVE_FINISH_TIMEOUT: Duration = Duration::from_secs(5);

/// The file sink's side of the viewer path: never blocks.
pub(super) struct LiveFeed {
    queue: SyncSender<LogMsg>,
    dropped: Arc<AtomicU64>,
}

impl LiveFeed {
    /// Queues a message for the viewer, or drops it (counted) when the viewer is behind.
    pub(super) fn offer(&self, msg: LogMsg) {
        match self.queue.try_send(msg) {
            Ok(()) => {}
            Err(TrySendError::Full(_)) => {
                self.dropped.fetch_add(1, Ordering::Relaxed);
            }
            // The feeder is gone (it cannot be, short of a panic): the viewer gets nothing more.
            Err(TrySendError::Disconnected(_)) => {}
        }
    }
}

/// The recorder's side of the viewer path: how the viewer fared, asked once at the end.
pub(super) struct LiveHandle {
    url: String,
    done: Receiver<Result<(), String>>,
    dropped: Arc<AtomicU64>,
}

impl LiveHandle {
    /// Waits, at most [`LIVE_FINISH_TIMEOUT`], for the feeder to have passed everything to the
    /// viewer (the feed must be closed first: the sink holding it dropped). Returns a warning when
    /// the viewer did not get the whole run.
    pub(super) fn finish(self) -> Option<String> {
        let dropped = self.dropped.load(Ordering::Relaxed);
        let result = match self.done.recv_timeout(LIVE_FINISH_TIMEOUT) {
            Ok(result) => result,
            Err(RecvTimeoutError::Timeout) => Err(format!(
                "it did not take the recording within {} s (is a viewer listening there?)",
                LIVE_FINISH_TIMEOUT.as_secs()
            )),
            Err(RecvTimeoutError::Disconnected) => Err("the feeder thread ended early".to_owned()),
        };
        let missed = (dropped > 0)
            .then(|| format!("{dropped} messages were not sent to it (it fell behind)"));
        let reasons: Vec<String> = result.err().into_iter().chain(missed).collect();
        (!reasons.is_empty()).then(|| {
            format!(
                "live viewer {}: {}; the recording file is complete",
                self.url,
                reasons.join("; ")
            )
        })
    }
}

/// Connects to (or spawns) the viewer and starts the feeder thread. Fails on a bad URL, a viewer
/// that cannot be started or a thread that cannot be spawned: all known before the run starts.
pub(super) fn start(live: &LiveViewer) -> Result<(LiveFeed, LiveHandle), String> {
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
    let (queue, messages) = mpsc::sync_channel(LIVE_QUEUE);
    let (report, done) = mpsc::sync_channel(1);
    std::thread::Builder::new()
        .name("twin-live-viewer".to_owned())
        .spawn(move || feed(GrpcSink::new(uri), messages, report))
        .map_err(|e| format!("cannot start the live viewer thread: {e}"))?;
    let dropped = Arc::new(AtomicU64::new(0));
    Ok((
        LiveFeed {
            queue,
            dropped: dropped.clone(),
        },
        LiveHandle { url, done, dropped },
    ))
}

/// The feeder thread: passes the messages on until the feed is closed, then flushes and reports.
/// It alone owns the gRPC sink, whose sends and drop may block for as long as no viewer answers.
fn feed(viewer: GrpcSink, messages: Receiver<LogMsg>, report: SyncSender<Result<(), String>>) {
    for msg in messages {
        viewer.send(msg);
    }
    let flushed = viewer
        .flush_blocking(LIVE_FINISH_TIMEOUT)
        .map_err(|err| err.to_string());
    // The recorder may have stopped waiting (or been dropped without finishing): nothing to do.
    let _ = report.try_send(flushed);
}

/// A Rerun viewer watching the run as it happens, besides the file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LiveViewer {
    /// A viewer already listening at this gRPC URL (e.g. `rerun+http://127.0.0.1:9876/proxy`).
    Connect(String),
    /// Start a viewer from the `rerun` executable on PATH and stream to it.
    Spawn,
}
