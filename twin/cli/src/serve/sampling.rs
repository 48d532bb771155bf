//! How the served values reach subscribers: every control update is a sample. The server's
//! limits follow the scenario's control period (sampling intervals down to one control period,
//! zero revised to it; per-item queues that hold [`BACKLOG`] of control updates), and each
//! control update's values carry its simulated time, counted from the wall-clock time of the
//! first update, as their source timestamp: the machine's own clock, whatever `--rate` or
//! lockstep does to the wall clock's pace. Successive updates are then exactly one control
//! period apart, which passes async-opcua's sampling-interval filter (it compares source
//! timestamps), and a shadow watching the served machine reads machine time from them.

use opcua::server::ServerBuilder;
use opcua::types::DateTime;

/// What the server holds for a subscriber that has not yet asked for it: the longest queue a
/// monitored item may have, in control updates, spans this long, s.
pub const BACKLOG: f64 = 2.0;

/// The subscription timer, ms: how often the server looks for notifications to publish, and so
/// the shortest publishing interval it grants.
pub const PUBLISHING_TICK_MS: u64 = 10;

/// Notifications per publish response at most, so that a response to a client that fell behind
/// stays well under the message size (5 chunks of 64 KiB; one notification of a number is
/// about 35 bytes); the rest follow in the next responses.
const NOTIFICATIONS_PER_PUBLISH: u64 = 4000;

/// The shortest queue granted (async-opcua's default).
const QUEUE_FLOOR: usize = 10;

/// The longest queue granted, whatever the control period.
const QUEUE_CEILING: usize = 100_000;

/// The server's sampling and publishing limits for a run whose control period is
/// `control_period`, s (positive).
pub fn limits(builder: ServerBuilder, control_period: f64) -> ServerBuilder {
    let mut builder = builder.subscription_poll_interval_ms(PUBLISHING_TICK_MS);
    let subscriptions = &mut builder.limits_mut().subscriptions;
    subscriptions.min_sampling_interval_ms = control_period * 1e3;
    subscriptions.min_publishing_interval_ms = PUBLISHING_TICK_MS as f64;
    subscriptions.max_monitored_item_queue_size = queue_ceiling(control_period);
    subscriptions.max_notifications_per_publish = NOTIFICATIONS_PER_PUBLISH;
    // A response per publishing tick over the backlog, for a client slow to take them.
    subscriptions.max_queued_notifications = (BACKLOG * 1e3) as usize / PUBLISHING_TICK_MS as usize;
    builder
}

/// The longest monitored-item queue: [`BACKLOG`] of control updates, within the floor and
/// ceiling.
fn queue_ceiling(control_period: f64) -> usize {
    let updates = (BACKLOG / control_period).ceil();
    if updates.is_finite() && updates > 0.0 {
        (updates as usize).clamp(QUEUE_FLOOR, QUEUE_CEILING)
    } else {
        QUEUE_CEILING
    }
}

/// OPC UA ticks (100 ns) per second.
const TICKS_PER_SECOND: f64 = 1e7;

/// The source timestamps of the run's values: simulated time after the wall-clock time of the
/// first control update stamped.
#[derive(Debug, Clone, Default)]
pub struct SourceClock {
    /// The wall clock at simulated time zero, in OPC UA ticks; set at the first stamp.
    start: Option<i64>,
}

impl SourceClock {
    /// The source timestamp of simulated time `time`, s; the first call ties the simulated
    /// time to the wall clock.
    pub fn stamp(&mut self, time: f64) -> DateTime {
        let offset = ticks(time);
        let start =
            *(self.start).get_or_insert_with(|| DateTime::now().ticks().saturating_sub(offset));
        DateTime::from(
            start
                .saturating_add(offset)
                .clamp(0, DateTime::endtimes_ticks() - 1),
        )
    }
}

/// `seconds` in OPC UA ticks, rounded (0 for what is not a number; saturated beyond ±i64).
fn ticks(seconds: f64) -> i64 {
    let ticks = (seconds * TICKS_PER_SECOND).round();
    if ticks.is_nan() {
        0
    } else {
        // `as` saturates at the ends of i64.
        ticks as i64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_updates_are_stamped_one_period_apart() {
        let mut clock = SourceClock::default();
        let first = clock.stamp(0.0).ticks();
        for step in 1..=3000_u32 {
            let stamp = clock.stamp(f64::from(step) * 1e-3).ticks();
            assert_eq!(stamp - first, i64::from(step) * 10_000, "step {step}");
        }
        assert!(clock.stamp(f64::NAN).ticks() >= 0);
        assert!(clock.stamp(f64::INFINITY).ticks() < i64::MAX);
        assert!(clock.stamp(-1e300).ticks() >= 0);
    }

    #[test]
    fn queues_hold_the_backlog_of_control_updates() {
        assert_eq!(queue_ceiling(1e-3), 2000);
        assert_eq!(queue_ceiling(0.01), 200);
        assert_eq!(queue_ceiling(1.0), QUEUE_FLOOR);
        assert_eq!(queue_ceiling(1e-9), QUEUE_CEILING);
        assert_eq!(queue_ceiling(0.0), QUEUE_CEILING);
    }
}
