//! Writing `.rrd` bytes to a file ourselves, rather than through Rerun's `FileSink`.
//!
//! Rerun's file sink writes on a thread of its own and, when a write fails, only ever reports
//! "File-writer thread shut down prematurely", at the end of the run. Here the same encoder
//! (`re_log_encoding::Encoder`) writes straight to the file from Rerun's forwarding thread, and the
//! first failure is kept with the OS's reason for the recorder to report at once. Unlike the
//! `FileSink`'s, the ids come from the run ([`super::ids`]) and the footer's manifests are in a
//! fixed order ([`super::footer`]): the same run writes the same bytes.
//!
//! Files are written under a unique temporary name next to their final one and renamed onto it
//! once complete, so a file at the final path is always a complete recording.

use std::fs::File;
use std::path::Path;
use std::sync::{Arc, Condvar, Mutex, OnceLock, PoisonError};
use std::time::Duration;

use rerun::external::re_log_encoding::{CrateVersion, EncodeError, Encoder, EncodingOptions};
use rerun::log::LogMsg;
use rerun::sink::{LogSink, SinkFlushError};
use tempfile::TempPath;

use super::error::error_chain;
use super::ids::Renumbering;
use super::live::LiveFeed;

/// An `.rrd` stream being written to a temporary file beside its final path.
pub(super) struct PartFile {
    encoder: Encoder<File>,
    temp: TempPath,
    ids: Renumbering,
}

impl PartFile {
    /// Creates the temporary file beside `path` ([`crate::output::temporary_beside`]) and writes
    /// the stream header.
    pub(super) fn create(path: &Path) -> Result<PartFile, String> {
        let (file, temp) = crate::output::temporary_beside(path)?.into_parts();
        let encoder = Encoder::new_eager(
            CrateVersion::LOCAL,
            EncodingOptions::PROTOBUF_COMPRESSED,
            file,
        )
        .map_err(|err| encode_reason(&err))?;

        Ok(PartFile {
            encoder,
            temp,
            ids: Renumbering::new(),
        })
    }

    /// Encodes one message into the file, with ids that follow from the run ([`Renumbering`]).
    pub(super) fn append(&mut self, msg: &LogMsg) -> Result<(), String> {
        let renumbered = self.ids.apply(msg)?;
        self.encoder
            .append(renumbered.as_ref().unwrap_or(msg))
            .map(|_| ())
            .map_err(|err| encode_reason(&err))
    }

    /// Writes the footer (the manifest of every chunk), syncs the file to disk and renames it onto
    /// `path`, replacing what is there. Returns the file's size. On error the temporary file is
    /// removed.
    pub(super) fn complete(mut self, path: &Path) -> Result<u64, String> {
        self.encoder.finish().map_err(|err| encode_reason(&err))?;
        let mut file = self
            .encoder
            .into_inner()
            .map_err(|err| encode_reason(&err))?;
        super::footer::order_manifests(&mut file)?;
        // Synced before the rename, so that a crash cannot leave an empty or partial file there.
        file.sync_all().map_err(|err| err.to_string())?;
        let bytes = file.metadata().map_err(|err| err.to_string())?.len();
        drop(file);
        self.temp
            .persist(path)
            .map_err(|err| format!("cannot rename the finished file onto it: {}", err.error))?;
        // Best effort: syncing the folder makes the rename itself survive a power loss. The file
        // is in place either way, so a failure here is no reason to report the recording lost.
        if let Ok(folder) = File::open(crate::output::folder_of(path)) {
            let _ = folder.sync_all();
        }
        Ok(bytes)
    }

    /// Removes the temporary file without writing a footer.
    pub(super) fn discard(self) {
        // Unwrapping the file stops the encoder's `Drop` from writing a footer to a doomed file.
        drop(self.encoder.into_inner());
        drop(self.temp);
    }

    /// The temporary file's path: where the data is until [`PartFile::complete`].
    #[cfg(test)]
    pub(super) fn temp_path(&self) -> std::path::PathBuf {
        self.temp.to_path_buf()
    }
}

/// The state the recorder shares with its sink: the file, its first write failure and how far the
/// writing has got.
pub(super) struct FileState {
    /// `None` once taken by the recorder to complete or discard it.
    part: Mutex<Option<PartFile>>,
    /// The first write failure; nothing more is written after it.
    failure: OnceLock<String>,
    /// Flushes of the pipeline the sink has reached: every message sent before the n-th flush has
    /// been written (or has failed) once this is n.
    flushes: Mutex<u64>,
    flushed: Condvar,
}

impl FileState {
    pub(super) fn new(part: PartFile) -> Arc<FileState> {
        Arc::new(FileState {
            part: Mutex::new(Some(part)),
            failure: OnceLock::new(),
            flushes: Mutex::new(0),
            flushed: Condvar::new(),
        })
    }

    /// Blocks until the sink has reached the `n`-th flush of the pipeline.
    pub(super) fn wait_for_flush(&self, n: u64) {
        let mut flushes = self.flushes.lock().unwrap_or_else(PoisonError::into_inner);
        while *flushes < n {
            flushes = self
                .flushed
                .wait(flushes)
                .unwrap_or_else(PoisonError::into_inner);
        }
    }

    /// The first write failure, if any: a single atomic load, cheap enough for every sample.
    pub(super) fn failure(&self) -> Option<&str> {
        self.failure.get().map(String::as_str)
    }

    /// Takes the file out, so that the sink writes no more to it.
    pub(super) fn take(&self) -> Option<PartFile> {
        self.part
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .take()
    }

    fn append(&self, msg: &LogMsg) {
        if self.failure.get().is_some() {
            return;
        }
        let mut part = self.part.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(part) = part.as_mut() {
            if let Err(reason) = part.append(msg) {
                // Only the first failure is kept: it is the cause of any later one.
                let _ = self.failure.set(reason);
            }
        }
    }
}

/// The recording stream's sink: each message is written to the file, and offered to the live
/// viewer, if any, without waiting for it.
pub(super) struct FileWriter {
    file: Arc<FileState>,
    live: Option<LiveFeed>,
}

impl FileWriter {
    pub(super) fn new(file: Arc<FileState>, live: Option<LiveFeed>) -> FileWriter {
        FileWriter { file, live }
    }
}

impl LogSink for FileWriter {
    fn send(&self, msg: LogMsg) {
        self.file.append(&msg);
        if let Some(live) = &self.live {
            live.offer(msg);
        }
    }

    /// Writes are not buffered: there is nothing to flush, only progress to count and a failure
    /// to report. Rerun calls this in order, after every message sent before the flush.
    fn flush_blocking(&self, _timeout: Duration) -> Result<(), SinkFlushError> {
        let mut flushes = self
            .file
            .flushes
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        *flushes += 1;
        self.file.flushed.notify_all();
        drop(flushes);
        match self.file.failure() {
            Some(reason) => Err(SinkFlushError::failed(reason)),
            None => Ok(()),
        }
    }
}

/// The OS's own words for a failed write (e.g. "No space left on device (os error 28)"), else the
/// encoder's error and its causes.
fn encode_reason(err: &EncodeError) -> String {
    match err {
        EncodeError::Write(io) => io.to_string(),
        other => error_chain(other),
    }
}
