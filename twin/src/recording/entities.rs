//! Where a recording puts what it logs: its entity paths, its two timelines, its application id,
//! and how often its buffered samples and traces are sent.

use rerun::ApplicationId;

pub(super) const MECHANISM: &str = "mechanism";
pub(super) const SIGNALS: &str = "signals";
pub(super) const EVENTS: &str = "events";
pub(super) const SCENARIO: &str = "scenario";
pub(super) const SUMMARY: &str = "summary";
pub(super) const FIGURES: &str = "figures";
/// Where the crashes are drawn.
pub(super) const COLLISIONS: &str = "mechanism/collisions";
/// Sequence timeline: the physics step index.
pub(super) const STEP: &str = "step";
/// Duration timeline: simulated time.
pub(super) const SIM_TIME: &str = "sim_time";
/// Buffered samples are sent after this many (bounds memory: ~8 bytes per value and sample).
pub(super) const FLUSH_EVERY: usize = 4096;
/// Bound on the data queued between the recorder and the file writer.
pub(super) const MAX_BYTES_IN_FLIGHT: u64 = 32 << 20;
/// A trace is sent every this many samples (and at the end).
pub(super) const TRACE_EVERY: usize = 1024;
/// A trace keeps at most this many points: beyond, every other one is dropped.
pub(super) const MAX_TRACE_POINTS: usize = 4000;

/// Rerun's application id for the scenario name. Rerun accepts ASCII letters, digits and
/// `_- []:` in at most 180 bytes and otherwise rewrites the id with a hash suffix and a warning;
/// this does a quiet, readable version of that (the recording name keeps the full name).
pub(super) fn application_id(app: &str) -> ApplicationId {
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
