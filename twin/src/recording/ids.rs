//! Ids that follow from the run, not from the clock: Rerun stamps every chunk, row and store-info
//! message with a TUID made of the wall-clock time and a random number, so two runs of the same
//! scenario would write different bytes.
//!
//! - The recorder's own chunks (the sampled columns, events, crashes, traces) are made with ids
//!   counted by the recorder ([`RunIds`]), in the order it sends them, and reach the file as
//!   they are.
//! - Every other message (the static parts, the store's info) is renumbered from a counter of
//!   the file's ([`Renumbering`]), in the order it reaches the file — the order Rerun gave it.
//!
//! The two counters' ranges never meet (the run's lie above the file's), and each counts in the
//! order of sending, so among an entity's temporal rows, and among its static ones, a later row
//! still wins a tie. A static row shadows the temporal ones whatever their ids.

use rerun::external::arrow::array::{Array, FixedSizeBinaryArray};
use rerun::external::arrow::buffer::Buffer;
use rerun::external::re_log_types::SetStoreInfo;
use rerun::external::re_tuid::Tuid;
use rerun::log::{Chunk, ChunkComponents, ChunkId, LogMsg, RowId};
use rerun::{EntityPath, RecordingStream, SerializedComponentColumn, TimeColumn};

use super::error::error_chain;

/// The first id handed out: 2020-01-01T00:00:00Z in the TUID's nanosecond field, so the ids read
/// as a plausible (fixed) time in tools that show it.
const FIRST_ID: u128 = (1_577_836_800_000_000_000_u128) << 64;

/// The first id the recorder gives its own chunks: a nanosecond after [`FIRST_ID`], in the TUID's
/// time field, so clear of every id the file's counter hands out (it counts in the low 64 bits).
const RUN_FIRST_ID: u128 = FIRST_ID + (1 << 64);

/// Counts the ids of the recorder's own chunks, one recording's worth.
#[derive(Debug)]
pub(super) struct RunIds {
    next: u128,
}

impl RunIds {
    pub(super) fn new() -> Self {
        Self { next: RUN_FIRST_ID }
    }

    /// Whether a chunk's id is one of the run's, its rows numbered already: the run's ids share
    /// their time field (a clock's TUID is of the day it was made).
    fn owns(chunk: &Tuid) -> bool {
        chunk.as_u128() >> 64 == RUN_FIRST_ID >> 64
    }

    /// Sends `columns` of `entity` at `timelines` as one chunk numbered by the run: its id, then
    /// one per row, counted on (what `RecordingStream::send_columns` does with ids from the clock).
    /// The rows go in the order given: the recorder's columns are in time order.
    pub(super) fn send_columns(
        &mut self,
        stream: &RecordingStream,
        entity: EntityPath,
        timelines: impl IntoIterator<Item = TimeColumn>,
        columns: impl IntoIterator<Item = SerializedComponentColumn>,
    ) -> Result<(), String> {
        let timelines = timelines
            .into_iter()
            .map(|column| (*column.timeline().name(), column))
            .collect();
        let components: ChunkComponents = columns
            .into_iter()
            .map(|column| (column.descriptor, column.list_array))
            .collect();
        let rows = components.list_arrays().next().map_or(0, |rows| rows.len());
        let chunk = ChunkId::from_u128(self.next);
        let first_row = self.next + 1;
        self.next = first_row + rows as u128;
        let bytes: Vec<u8> = (first_row..self.next).flat_map(u128::to_be_bytes).collect();
        let row_ids = FixedSizeBinaryArray::try_new(16, Buffer::from(bytes), None)
            .map_err(|err| error_chain(&err))?;
        let chunk = Chunk::new(chunk, entity, Some(true), row_ids, timelines, components)
            .map_err(|err| error_chain(&err))?;
        stream.send_chunk(chunk);
        Ok(())
    }
}

/// Hands out consecutive ids for one file.
#[derive(Debug)]
pub(super) struct Renumbering {
    next: u128,
}

impl Renumbering {
    pub(super) fn new() -> Self {
        Self { next: FIRST_ID }
    }

    fn id(&mut self) -> u128 {
        let id = self.next;
        self.next += 1;
        id
    }

    /// `msg` with its ids replaced, or `None` when it carries none (written as it is).
    pub(super) fn apply(&mut self, msg: &LogMsg) -> Result<Option<LogMsg>, String> {
        match msg {
            LogMsg::SetStoreInfo(info) => Ok(Some(LogMsg::SetStoreInfo(SetStoreInfo {
                row_id: Tuid::from_u128(self.id()),
                info: info.info.clone(),
            }))),
            LogMsg::ArrowMsg(_, arrow) if RunIds::owns(&arrow.chunk_id) => Ok(None),
            LogMsg::ArrowMsg(store, arrow) => {
                let chunk = Chunk::from_arrow_msg(arrow).map_err(|e| e.to_string())?;
                let rows: Vec<RowId> = (0..chunk.num_rows())
                    .map(|_| RowId::from_u128(self.id()))
                    .collect();
                let renumbered = Chunk::from_native_row_ids(
                    ChunkId::from_u128(self.id()),
                    chunk.entity_path().clone(),
                    Some(true),
                    &rows,
                    chunk.timelines().clone(),
                    chunk.components().clone(),
                )
                .and_then(|c| c.to_arrow_msg())
                .map_err(|e| e.to_string())?;
                Ok(Some(LogMsg::ArrowMsg(store.clone(), renumbered)))
            }
            LogMsg::BlueprintActivationCommand(_) => Ok(None),
        }
    }
}
