//! Wall-clock pacing: simulated time runs at `rate` times the wall clock; a control update
//! reached after its deadline is a deadline miss.

use std::time::{Duration, Instant};

/// The run's wall-clock schedule and its misses.
#[derive(Debug)]
pub struct Pacing {
    rate: f64,
    start: Option<Instant>,
    /// Control updates reached after their deadline.
    pub misses: u64,
    /// The latest a control update was reached after its deadline, s.
    pub worst_lateness: f64,
}

impl Pacing {
    /// Simulated time runs at `rate` × wall clock (a positive, finite number).
    pub fn new(rate: f64) -> Self {
        Self {
            rate,
            start: None,
            misses: 0,
            worst_lateness: 0.0,
        }
    }

    /// Sleeps until simulated `time`'s wall deadline, or counts a miss when it has passed and
    /// returns how late, s.
    pub fn wait_until(&mut self, time: f64) -> Option<f64> {
        let now = Instant::now();
        let start = *self.start.get_or_insert(now);
        let Ok(offset) = Duration::try_from_secs_f64(time / self.rate) else {
            return None;
        };
        let deadline = start + offset;
        if now > deadline {
            let late = now.duration_since(deadline).as_secs_f64();
            self.misses += 1;
            self.worst_lateness = self.worst_lateness.max(late);
            Some(late)
        } else {
            std::thread::sleep(deadline - now);
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_late_update_is_a_miss_and_an_early_one_waits() {
        let mut pacing = Pacing::new(1.0);
        pacing.wait_until(0.0);
        let started = Instant::now();
        pacing.wait_until(0.02);
        assert!(started.elapsed() >= Duration::from_millis(15));
        assert_eq!(pacing.misses, 0);
        std::thread::sleep(Duration::from_millis(30));
        assert!(pacing.wait_until(0.03).is_some_and(|late| late > 0.01));
        assert_eq!(pacing.misses, 1);
        assert!(pacing.worst_lateness > 0.01);
    }
}
