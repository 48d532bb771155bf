//! The shadow's intake: samples held in source-time order until they are `latency` behind the
//! newest, late ones and repeats counted and dropped.

use std::collections::BTreeMap;

/// What a sample is of.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(super) enum SampleKind {
    /// An actuator's command (index into the actuators).
    Command(usize),
    /// A watched signal's measurement (index into the watched signals).
    Measurement(usize),
}

/// One sample: what, when (s since the first sample), the value in SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Sample {
    pub kind: SampleKind,
    pub time: f64,
    pub value: f64,
}

/// Samples by (time, kind), waiting.
#[derive(Debug, Default)]
pub(super) struct Intake {
    waiting: BTreeMap<(u64, SampleKind), f64>,
    /// Time up to which samples have been released.
    released: f64,
    newest: f64,
    /// Per stream (a command or a signal), its newest time and when it was last heard from
    /// (on the arrival clock, s).
    streams: BTreeMap<SampleKind, (f64, f64)>,
    /// Live: the arrival clock now (s on any steady clock); None for a logged run.
    pub clock: Option<f64>,
    pub counts: IntakeCounts,
}

/// A stream silent for this long no longer holds the others back, s: of the arrival clock when
/// there is one (live), of data time behind the newest sample otherwise.
const STALLED: f64 = 1.0;

/// A key that orders times as numbers (times here are finite and ≥ 0).
fn key(time: f64) -> u64 {
    time.max(0.0).to_bits()
}

impl Intake {
    /// Takes a sample; drops it if it is late (returning false) or repeats one.
    pub fn push(&mut self, sample: Sample) -> bool {
        if sample.time < self.released {
            self.counts.late += 1;
            if matches!(sample.kind, SampleKind::Command(_)) {
                self.counts.late_commands += 1;
            }
            return false;
        }
        if sample.time < self.newest {
            self.counts.reordered += 1;
        }
        self.newest = self.newest.max(sample.time);
        let heard = self.clock.unwrap_or(sample.time);
        let stream = self
            .streams
            .entry(sample.kind)
            .or_insert((sample.time, heard));
        *stream = (stream.0.max(sample.time), heard);
        let slot = (key(sample.time), sample.kind);
        if self.waiting.insert(slot, sample.value).is_some() {
            self.counts.duplicate += 1;
        }
        true
    }

    /// The newest source time seen.
    pub fn newest(&self) -> f64 {
        self.newest
    }

    /// How far every live stream has come: the oldest of the streams' newest times, among the
    /// streams heard from within [`STALLED`] (a stream that stopped does not hold the others
    /// back). Samples arrive in batches per stream; a shadow that waits for the slowest live
    /// one takes them all in order however late the batches come. Live, a stream's silence is
    /// measured on the arrival clock: a machine that sends a second of one stream before the
    /// next (a server that publishes per node) holds nothing up.
    pub fn watermark(&self) -> f64 {
        let now = self.clock.unwrap_or(self.newest);
        self.streams
            .values()
            .filter(|&&(_, heard)| heard >= now - STALLED)
            .map(|&(time, _)| time)
            .fold(self.newest, f64::min)
    }

    /// Releases the samples up to `until` in time order (those at one time together, commands
    /// first).
    pub fn release(&mut self, until: f64) -> Vec<Sample> {
        let rest = self
            .waiting
            .split_off(&(key(until), SampleKind::Measurement(usize::MAX)));
        let ready = std::mem::replace(&mut self.waiting, rest);
        self.released = self.released.max(until);
        self.counts.processed += ready.len() as u64;
        ready
            .into_iter()
            .map(|((bits, kind), value)| Sample {
                kind,
                time: f64::from_bits(bits),
                value,
            })
            .collect()
    }
}

/// Counts of what the intake did with the samples.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct IntakeCounts {
    /// Samples processed.
    pub processed: u64,
    /// Samples older than what had been processed: dropped.
    pub late: u64,
    /// Of those, commands: the model ran under an older command for a while, so the state was
    /// taken up again with the parameters held and the tests paused.
    pub late_commands: u64,
    /// Samples repeating one already taken (same signal and time): dropped.
    pub duplicate: u64,
    /// Samples taken out of their arrival order.
    pub reordered: u64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_come_out_in_time_order_and_late_and_repeated_ones_are_dropped() {
        let mut intake = Intake::default();
        let at = |time: f64, s: usize| Sample {
            kind: SampleKind::Measurement(s),
            time,
            value: time,
        };
        for sample in [at(0.02, 0), at(0.01, 0), at(0.02, 0), at(0.03, 1)] {
            intake.push(sample);
        }
        let out = intake.release(0.025);
        assert_eq!(out.iter().map(|s| s.time).collect::<Vec<_>>(), [0.01, 0.02]);
        intake.push(at(0.015, 0));
        assert_eq!(
            intake.counts,
            IntakeCounts {
                processed: 2,
                late: 1,
                late_commands: 0,
                duplicate: 1,
                reordered: 1,
            }
        );
        assert_eq!(intake.release(1.0).len(), 1);
    }
}
