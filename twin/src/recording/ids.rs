//! Ids that follow from the run, not from the clock: Rerun stamps every chunk, row and store-info
//! message with a TUID made of the wall-clock time and a random number, so two runs of the same
//! scenario would write different bytes. The file's messages are renumbered from a counter, in
//! the order they reach the file — the order Rerun gave them, so a later row still wins a tie.

use rerun::external::re_log_types::SetStoreInfo;
use rerun::external::re_tuid::Tuid;
use rerun::log::{Chunk, ChunkId, LogMsg, RowId};

/// The first id handed out: 2020-01-01T00:00:00Z in the TUID's nanosecond field, so the ids read
/// as a plausible (fixed) time in tools that show it.
const FIRST_ID: u128 = (1_577_836_800_000_000_000_u128) << 64;

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
