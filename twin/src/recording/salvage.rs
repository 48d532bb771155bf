//! Recovering what a killed run left: the `.part` file of a recorder that never finished (`kill
//! -9`, power loss) holds a valid `.rrd` stream up to some point, but no footer, and may end in a
//! torn message. Rerun's tools read such a stream but `rerun rrd verify` rejects it.

use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

use rerun::external::re_log_encoding::{Decodable, DecoderApp, StreamFooter};
use rerun::log::{Chunk, LogMsg};
use rerun::{StoreKind, TimelineName};

use super::entities::{SIM_TIME, STEP};
use super::error::RecordingError;
use super::writer::PartFile;

/// What [`salvage`] kept.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SalvageReport {
    /// Messages kept: store announcements, data chunks, blueprint activation.
    pub messages: usize,
    /// Of which data chunks (of the recording and of its blueprint).
    pub chunks: usize,
    /// The last `step` of the samples kept, if any.
    pub last_step: Option<i64>,
    /// The largest `sim_time` of the samples kept, s.
    pub last_sim_time: Option<f64>,
    /// Bytes after the last complete message that were not kept: a message torn by the kill, or
    /// anything unreadable after it. 0 for a file that was complete.
    pub dropped_bytes: u64,
    /// Whether the file already ended with a footer (a finished recording, written anew).
    pub had_footer: bool,
}

impl SalvageReport {
    /// Counts a kept message and extends the step and time ranges with its samples.
    fn note(&mut self, msg: &LogMsg) {
        self.messages += 1;
        let LogMsg::ArrowMsg(store, arrow) = msg else {
            return;
        };
        self.chunks += 1;
        if store.kind() != StoreKind::Recording {
            return;
        }
        let Ok(chunk) = Chunk::from_arrow_msg(arrow) else {
            return;
        };
        let last = |timeline: &str| {
            let column = chunk
                .timelines()
                .get(&TimelineName::try_new(timeline).ok()?)?;
            column.times_raw().iter().copied().max()
        };
        if let Some(step) = last(STEP) {
            self.last_step = Some(self.last_step.map_or(step, |s| s.max(step)));
        }
        if let Some(nanos) = last(SIM_TIME) {
            let secs = nanos as f64 / 1e9;
            self.last_sim_time = Some(self.last_sim_time.map_or(secs, |t| t.max(secs)));
        }
    }
}

/// Reads the `.rrd` stream in `part` message by message, stops cleanly at the first incomplete or
/// corrupt one, and writes what came before as a complete recording (with footer) to `out`,
/// atomically (through a temporary file beside it, like `Recorder`). `part` may also be a
/// complete recording, or `out` itself. Fails, naming `part`, when it holds no Rerun message.
pub fn salvage(part: &Path, out: &Path) -> Result<SalvageReport, RecordingError> {
    let read_error = |reason: String| RecordingError::Read {
        path: part.to_path_buf(),
        reason,
    };
    let file = File::open(part).map_err(|e| read_error(e.to_string()))?;
    let len = file
        .metadata()
        .map_err(|e| read_error(e.to_string()))?
        .len();
    let mut decoded = DecoderApp::decode_lazy(BufReader::new(file));
    let mut report = SalvageReport::default();
    let mut output: Option<PartFile> = None;
    let mut kept_end = 0;
    let ended_cleanly = loop {
        // A decoder panic on a corrupt payload ends the salvage like a decoding error would.
        let msg = match catch_unwind(AssertUnwindSafe(|| decoded.next())) {
            Ok(Some(Ok(msg))) => msg,
            Ok(Some(Err(err))) if report.messages == 0 => {
                return Err(read_error(format!("not a Rerun recording: {err}")));
            }
            Ok(None) if report.messages == 0 => {
                return Err(read_error("it holds no complete Rerun message".to_owned()));
            }
            Ok(None) => break true,
            Ok(Some(Err(_))) | Err(_) => break false,
        };
        // Right after a message is yielded, the decoder has consumed exactly up to its end.
        kept_end = decoded.num_bytes_processed();
        let writer =
            match &mut output {
                Some(writer) => writer,
                None => output.insert(PartFile::create(out).map_err(|reason| {
                    RecordingError::Create {
                        path: out.to_path_buf(),
                        reason,
                    }
                })?),
            };
        writer
            .append(&msg)
            .map_err(|reason| RecordingError::Write {
                path: out.to_path_buf(),
                reason,
            })?;
        report.note(&msg);
    };
    report.had_footer =
        ended_cleanly && decoded.num_bytes_processed() == len && ends_with_footer(part, len);
    report.dropped_bytes = if report.had_footer {
        0
    } else {
        len.saturating_sub(kept_end)
    };
    let Some(writer) = output else {
        return Err(read_error("it holds no complete Rerun message".to_owned()));
    };
    writer
        .complete(out)
        .map_err(|reason| RecordingError::Write {
            path: out.to_path_buf(),
            reason,
        })?;
    Ok(report)
}

/// Whether the file's last bytes are a well-formed stream footer.
fn ends_with_footer(path: &Path, len: u64) -> bool {
    let size = StreamFooter::ENCODED_SIZE_BYTES;
    let mut tail = vec![0; size];
    let read = File::open(path).and_then(|mut file| {
        file.seek(SeekFrom::Start(len.saturating_sub(size as u64)))?;
        file.read_exact(&mut tail)
    });
    read.is_ok() && StreamFooter::from_rrd_bytes(&tail).is_ok()
}
