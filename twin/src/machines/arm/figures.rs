//! The figures a machining run of the arm is judged by, gathered every physics step while the tool
//! is on the contour: from the moment it leaves the start point (after the approach) until it
//! reaches the end.

use models::filters::FirstOrderFilter;

/// Distance from the contour's start and end that marks leaving and reaching them, m.
pub const ON_POINT: f64 = 5e-4;
/// Time constant of the low-pass whose residue is the path-speed oscillation, s.
const SPEED_TREND: f64 = 0.1;

/// Where the tool is in the machining cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Moving to the start point.
    Approach,
    /// At the start point, not yet moving along.
    AtStart,
    /// On the contour since the time given.
    Machining { since: f64 },
    /// Reached the end, after the time given.
    Done { took: f64 },
}

/// One sample of what the figures need.
pub struct Sample<'a> {
    pub time: f64,
    pub dt: f64,
    /// Path length of the tool's nearest contour point, m.
    pub along: f64,
    pub deviation: f64,
    /// Tool speed along the contour, m/s.
    pub path_speed: f64,
    pub in_deep_zone: bool,
    /// Per motor: |current|, A, and whether its drive clips the command.
    pub currents: &'a [f64],
    pub at_limit: &'a [bool],
}

pub struct Figures {
    motors: Vec<String>,
    tolerance: f64,
    length: f64,
    phase: Phase,
    samples: usize,
    deviation_max: f64,
    deviation_squares: f64,
    peak_current: Vec<f64>,
    limit_samples: Vec<usize>,
    /// Time and path-speed integral inside and outside the deep zone.
    deep: [f64; 2],
    outside: [f64; 2],
    trend: FirstOrderFilter,
    oscillation_squares: f64,
    oscillation_samples: usize,
}

impl Figures {
    pub fn new(motors: Vec<String>, tolerance: f64, length: f64) -> Self {
        let count = motors.len();
        Self {
            motors,
            tolerance,
            length,
            phase: Phase::Approach,
            samples: 0,
            deviation_max: 0.0,
            deviation_squares: 0.0,
            peak_current: vec![0.0; count],
            limit_samples: vec![0; count],
            deep: [0.0; 2],
            outside: [0.0; 2],
            trend: FirstOrderFilter::low_pass(SPEED_TREND).expect("a positive constant"),
            oscillation_squares: 0.0,
            oscillation_samples: 0,
        }
    }

    pub fn observe(&mut self, s: &Sample) {
        self.phase = match self.phase {
            Phase::Approach if s.along < ON_POINT && s.deviation < ON_POINT => Phase::AtStart,
            Phase::AtStart if s.along >= ON_POINT => Phase::Machining { since: s.time },
            Phase::Machining { since } if s.along >= self.length - ON_POINT => Phase::Done {
                took: s.time - since,
            },
            phase => phase,
        };
        if !matches!(self.phase, Phase::Machining { .. }) {
            return;
        }
        self.samples += 1;
        self.deviation_max = self.deviation_max.max(s.deviation);
        self.deviation_squares += s.deviation * s.deviation;
        for (m, (&current, &limited)) in s.currents.iter().zip(s.at_limit).enumerate() {
            self.peak_current[m] = self.peak_current[m].max(current);
            self.limit_samples[m] += usize::from(limited);
        }
        let zone = if s.in_deep_zone {
            &mut self.deep
        } else {
            &mut self.outside
        };
        zone[0] += s.dt;
        zone[1] += s.path_speed * s.dt;
        let trend = self.trend.update(s.path_speed, s.dt);
        if s.in_deep_zone {
            self.oscillation_squares += (s.path_speed - trend).powi(2);
            self.oscillation_samples += 1;
        }
    }

    /// Time on the contour so far (or to its end), and whether the end was reached.
    fn contour_time(&self, now: f64) -> (f64, bool) {
        match self.phase {
            Phase::Done { took } => (took, true),
            Phase::Machining { since } => (now - since, false),
            _ => (0.0, false),
        }
    }

    pub fn metrics(&self, now: f64) -> Vec<(String, f64)> {
        let (took, finished) = self.contour_time(now);
        let n = self.samples.max(1) as f64;
        let mean = |zone: [f64; 2]| {
            if zone[0] > 0.0 {
                zone[1] / zone[0]
            } else {
                0.0
            }
        };
        let mut metrics = vec![
            (
                "contour_finished".to_string(),
                f64::from(u8::from(finished)),
            ),
            ("contour_time".to_string(), took),
            ("path_deviation_max".to_string(), self.deviation_max),
            (
                "path_deviation_rms".to_string(),
                (self.deviation_squares / n).sqrt(),
            ),
            ("path_speed_mean_deep_zone".to_string(), mean(self.deep)),
            ("path_speed_mean_outside".to_string(), mean(self.outside)),
            (
                "path_speed_oscillation_deep_zone".to_string(),
                std::f64::consts::SQRT_2
                    * (self.oscillation_squares / self.oscillation_samples.max(1) as f64).sqrt(),
            ),
            ("current_tolerance".to_string(), self.tolerance),
        ];
        for (m, motor) in self.motors.iter().enumerate() {
            metrics.push((format!("peak_current/{motor}"), self.peak_current[m]));
            metrics.push((
                format!("peak_current_ratio/{motor}"),
                self.peak_current[m] / self.tolerance,
            ));
            metrics.push((
                format!("at_limit_fraction/{motor}"),
                self.limit_samples[m] as f64 / n,
            ));
        }
        metrics
    }
}
