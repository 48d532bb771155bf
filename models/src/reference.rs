//! Reference signals a scenario gives the controller: position, rate and acceleration at a time.

use serde::Deserialize;

/// A reference trajectory r(t) with its first two derivatives, in the controlled coordinate's
/// SI unit (m or rad).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Reference {
    /// r = value.
    Constant {
        /// The position held, m or rad.
        value: f64,
    },
    /// r = offset + amplitude·sin(angular_frequency·t + phase).
    Sine {
        /// Centre of the oscillation, m or rad; 0 when omitted.
        #[serde(default)]
        offset: f64,
        /// Peak deviation from the offset, m or rad.
        amplitude: f64,
        /// rad/s.
        angular_frequency: f64,
        /// Phase at t = 0, rad; 0 when omitted.
        #[serde(default)]
        phase: f64,
    },
    /// r = initial before `time`, value from `time` on.
    Step {
        /// The position before the step, m or rad; 0 when omitted.
        #[serde(default)]
        initial: f64,
        /// The position from the step on, m or rad.
        value: f64,
        /// When it steps, s; 0 when omitted.
        #[serde(default)]
        time: f64,
    },
    /// r = initial before `start`, initial + rate·(t − start) from `start` on.
    Ramp {
        /// The position before the ramp, m or rad; 0 when omitted.
        #[serde(default)]
        initial: f64,
        /// m/s or rad/s.
        rate: f64,
        /// When it starts, s; 0 when omitted.
        #[serde(default)]
        start: f64,
    },
    /// A point-to-point move through `[time, position]` waypoints, at rest at each: before the
    /// first its position, after the last its position.
    Waypoints {
        /// `[[t0, p0], [t1, p1], …]`: times strictly increasing, s; positions, m or rad.
        points: Vec<[f64; 2]>,
        /// How each move between two waypoints goes (default `quintic`).
        #[serde(default)]
        profile: Profile,
        /// With `profile = "trapezoidal"`: the share of each move spent accelerating, and as
        /// much braking, in (0, 0.5]; 0.25 when omitted.
        acceleration_share: Option<f64>,
    },
    /// `[time, position]` rows read from a CSV table (`time [s]`, `position [unit]`), linear
    /// between them; before the first row its position, after the last its position.
    Table {
        /// The table, relative to the scenario's file.
        file: String,
        /// The rows, SI, once read (the engine reads the file; see [`Reference::set_rows`]).
        #[serde(skip)]
        rows: Vec<[f64; 2]>,
    },
}

/// How a move between two waypoints goes, from rest to rest.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Profile {
    /// The fifth-order polynomial with zero rate and acceleration at both ends: smooth
    /// acceleration, a peak rate 15/8 of the mean.
    #[default]
    Quintic,
    /// Constant acceleration, cruise, constant braking: a trapezoid of rate.
    Trapezoidal,
}

/// The share of a trapezoidal move spent accelerating when none is given.
const DEFAULT_ACCELERATION_SHARE: f64 = 0.25;

/// One sample of a reference.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ReferenceSample {
    /// r(t), m or rad.
    pub position: f64,
    /// dr/dt, m/s or rad/s.
    pub rate: f64,
    /// d²r/dt², m/s² or rad/s².
    pub acceleration: f64,
}

impl ReferenceSample {
    /// At rest at `position`.
    fn held(position: f64) -> Self {
        Self {
            position,
            ..Self::default()
        }
    }
}

impl Reference {
    /// The reference and its first two derivatives at `time`, s. (A table not yet read holds 0.)
    pub fn sample(&self, time: f64) -> ReferenceSample {
        match self {
            Reference::Constant { value } => ReferenceSample::held(*value),
            &Reference::Sine {
                offset,
                amplitude,
                angular_frequency: w,
                phase,
            } => {
                let (s, c) = (w * time + phase).sin_cos();
                ReferenceSample {
                    position: offset + amplitude * s,
                    rate: amplitude * w * c,
                    acceleration: -amplitude * w * w * s,
                }
            }
            &Reference::Step {
                initial,
                value,
                time: at,
            } => ReferenceSample::held(if time < at { initial } else { value }),
            &Reference::Ramp {
                initial,
                rate,
                start,
            } => match time < start {
                true => ReferenceSample::held(initial),
                false => ReferenceSample {
                    position: initial + rate * (time - start),
                    rate,
                    acceleration: 0.0,
                },
            },
            Reference::Waypoints {
                points,
                profile,
                acceleration_share,
            } => {
                let share = acceleration_share.unwrap_or(DEFAULT_ACCELERATION_SHARE);
                waypoints_at(points, *profile, share, time)
            }
            Reference::Table { rows, .. } => table_at(rows, time),
        }
    }

    /// The file a table reference reads, for the engine to read it ([`Reference::set_rows`]).
    pub fn table_file(&self) -> Option<&str> {
        match self {
            Reference::Table { file, .. } => Some(file),
            _ => None,
        }
    }

    /// Gives a table reference the rows read from its file (`[time s, position SI]`), checked:
    /// at least two, finite, times strictly increasing. Another kind of reference is left as it
    /// is.
    pub fn set_rows(&mut self, read: Vec<[f64; 2]>) -> Result<(), String> {
        if let Reference::Table { rows, .. } = self {
            check_points("row", &read)?;
            *rows = read;
        }
        Ok(())
    }

    /// Checks the values are usable; the message names the offending field.
    pub fn validate(&self) -> Result<(), String> {
        match self {
            Reference::Constant { value } => finite("value", *value),
            &Reference::Sine {
                offset,
                amplitude,
                angular_frequency,
                phase,
            } => {
                finite("offset", offset)?;
                finite("amplitude", amplitude)?;
                finite("phase", phase)?;
                finite("angular_frequency", angular_frequency)?;
                if angular_frequency <= 0.0 {
                    return Err("reference angular_frequency must be > 0".into());
                }
                Ok(())
            }
            &Reference::Step {
                initial,
                value,
                time,
            } => [("initial", initial), ("value", value), ("time", time)]
                .into_iter()
                .try_for_each(|(name, v)| finite(name, v)),
            &Reference::Ramp {
                initial,
                rate,
                start,
            } => [("initial", initial), ("rate", rate), ("start", start)]
                .into_iter()
                .try_for_each(|(name, v)| finite(name, v)),
            Reference::Waypoints {
                points,
                profile,
                acceleration_share,
            } => validate_waypoints(points, *profile, *acceleration_share),
            Reference::Table { file, rows } => match (file.trim().is_empty(), rows.is_empty()) {
                (true, _) => Err("reference file must name a CSV table (time, position)".into()),
                (false, true) => Ok(()),
                (false, false) => check_points("row", rows),
            },
        }
    }
}

fn finite(name: &str, v: f64) -> Result<(), String> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(format!("reference {name} must be finite"))
    }
}

/// Waypoints: at least two, their times increasing; a share only for a trapezoid, in (0, 0.5].
fn validate_waypoints(
    points: &[[f64; 2]],
    profile: Profile,
    acceleration_share: Option<f64>,
) -> Result<(), String> {
    check_points("points", points)?;
    match (profile, acceleration_share) {
        (Profile::Quintic, Some(_)) => {
            Err("reference acceleration_share is for profile = \"trapezoidal\" only".into())
        }
        (_, Some(share)) if !(share > 0.0 && share <= 0.5) => Err(format!(
            "reference acceleration_share = {share} must be in (0, 0.5]"
        )),
        _ => Ok(()),
    }
}

/// `[time, position]` pairs: at least two, finite, times strictly increasing; `what` names them.
fn check_points(what: &str, points: &[[f64; 2]]) -> Result<(), String> {
    if points.len() < 2 {
        return Err(format!(
            "reference {what}s: give at least two [time, position] pairs, not {}",
            points.len()
        ));
    }
    if let Some(k) = points
        .iter()
        .position(|p| !(p[0].is_finite() && p[1].is_finite()))
    {
        return Err(format!("reference {what} {k} must be finite numbers"));
    }
    if let Some(k) = (1..points.len()).find(|&k| points[k][0] <= points[k - 1][0]) {
        return Err(format!(
            "reference {what} {k}: its time {} s must be after the one before, {} s",
            points[k][0],
            points[k - 1][0]
        ));
    }
    Ok(())
}

/// The segment `time` falls in: k with points[k].t ≤ time < points[k+1].t, or None outside.
fn segment(points: &[[f64; 2]], time: f64) -> Result<usize, ReferenceSample> {
    let (Some(first), Some(last)) = (points.first(), points.last()) else {
        return Err(ReferenceSample::default());
    };
    if time <= first[0] {
        return Err(ReferenceSample::held(first[1]));
    }
    if time >= last[0] {
        return Err(ReferenceSample::held(last[1]));
    }
    Ok(points.partition_point(|p| p[0] <= time) - 1)
}

/// The waypoints' move at `time`.
fn waypoints_at(points: &[[f64; 2]], profile: Profile, share: f64, time: f64) -> ReferenceSample {
    let k = match segment(points, time) {
        Ok(k) => k,
        Err(held) => return held,
    };
    let ([t0, p0], [t1, p1]) = (points[k], points[k + 1]);
    let (span, distance, tau) = (t1 - t0, p1 - p0, time - t0);
    let [s, ds, dds] = match profile {
        Profile::Quintic => quintic(tau / span),
        Profile::Trapezoidal => trapezoid(tau / span, share),
    };
    ReferenceSample {
        position: p0 + distance * s,
        rate: distance * ds / span,
        acceleration: distance * dds / (span * span),
    }
}

/// The rest-to-rest quintic s(u) = 10u³ − 15u⁴ + 6u⁵ on u ∈ [0, 1] and its first two
/// derivatives in u.
fn quintic(u: f64) -> [f64; 3] {
    let (u2, u3) = (u * u, u * u * u);
    [
        u3 * (10.0 - 15.0 * u + 6.0 * u2),
        30.0 * u2 * (1.0 - 2.0 * u + u2),
        60.0 * u * (1.0 - 3.0 * u + 2.0 * u2),
    ]
}

/// The rest-to-rest trapezoid on u ∈ [0, 1] accelerating over the first `share` and braking over
/// the last, and its first two derivatives in u: cruise rate v = 1/(1 − share), acceleration
/// a = v/share.
fn trapezoid(u: f64, share: f64) -> [f64; 3] {
    let v = 1.0 / (1.0 - share);
    let a = v / share;
    if u < share {
        [0.5 * a * u * u, a * u, a]
    } else if u <= 1.0 - share {
        [0.5 * a * share * share + v * (u - share), v, 0.0]
    } else {
        let rest = 1.0 - u;
        [1.0 - 0.5 * a * rest * rest, a * rest, -a]
    }
}

/// The table's rows at `time`, linear between them.
fn table_at(rows: &[[f64; 2]], time: f64) -> ReferenceSample {
    let k = match segment(rows, time) {
        Ok(k) => k,
        Err(held) => return held,
    };
    let ([t0, p0], [t1, p1]) = (rows[k], rows[k + 1]);
    let rate = (p1 - p0) / (t1 - t0);
    ReferenceSample {
        position: p0 + rate * (time - t0),
        rate,
        acceleration: 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sine_derivatives_match_finite_differences() {
        let r = Reference::Sine {
            offset: -0.2,
            amplitude: -0.2,
            angular_frequency: std::f64::consts::PI,
            phase: 0.0,
        };
        let (t, h) = (0.37, 1e-5);
        let (a, b, c) = (r.sample(t - h), r.sample(t), r.sample(t + h));
        assert!(((c.position - a.position) / (2.0 * h) - b.rate).abs() < 1e-8);
        assert!(((c.rate - a.rate) / (2.0 * h) - b.acceleration).abs() < 1e-6);
        assert_eq!(r.sample(0.0).position, -0.2);
    }

    #[test]
    fn bad_sine_is_rejected() {
        let r = Reference::Sine {
            offset: 0.0,
            amplitude: 1.0,
            angular_frequency: 0.0,
            phase: 0.0,
        };
        assert!(r.validate().unwrap_err().contains("angular_frequency"));
    }

    /// Central differences of `r`'s position and rate at `t` against its rate and acceleration.
    fn derivatives_agree(r: &Reference, t: f64) {
        let h = 1e-6;
        let (a, b, c) = (r.sample(t - h), r.sample(t), r.sample(t + h));
        let rate = (c.position - a.position) / (2.0 * h);
        let acceleration = (c.rate - a.rate) / (2.0 * h);
        assert!(
            (rate - b.rate).abs() < 1e-6,
            "{r:?} at {t}: {rate} vs {}",
            b.rate
        );
        assert!(
            (acceleration - b.acceleration).abs() < 1e-4,
            "{r:?} at {t}: {acceleration} vs {}",
            b.acceleration
        );
    }

    fn checked(r: Reference) -> Reference {
        r.validate().unwrap();
        r
    }

    fn waypoints(points: &[[f64; 2]], profile: Profile, share: Option<f64>) -> Reference {
        Reference::Waypoints {
            points: points.to_vec(),
            profile,
            acceleration_share: share,
        }
    }

    #[test]
    fn quintic_waypoints_rest_at_each_point_and_their_derivatives_agree() {
        let points = [[0.5, 0.0], [1.5, 0.8], [3.0, -0.3]];
        let r = checked(waypoints(&points, Profile::Quintic, None));
        for (t, p) in [(0.0, 0.0), (0.5, 0.0), (1.5, 0.8), (3.0, -0.3), (9.0, -0.3)] {
            let s = r.sample(t);
            assert!((s.position - p).abs() < 1e-12, "{t}: {s:?}");
            assert!(
                s.rate.abs() < 1e-12 && s.acceleration.abs() < 1e-9,
                "{t}: {s:?}"
            );
        }
        // Halfway through a move: half the distance at 15/8 of the mean rate.
        let s = r.sample(1.0);
        assert!((s.position - 0.4).abs() < 1e-12 && (s.rate - 0.8 * 15.0 / 8.0).abs() < 1e-12);
        for t in [0.6, 0.93, 1.2, 1.7, 2.4, 2.99] {
            derivatives_agree(&r, t);
        }
    }

    #[test]
    fn trapezoidal_waypoints_cruise_at_the_rate_their_share_sets() {
        let points = [[0.0, 0.0], [2.0, 1.0]];
        let r = checked(waypoints(&points, Profile::Trapezoidal, Some(0.2)));
        // Cruise rate D / (T·(1 − share)) = 1 / 1.6.
        let s = r.sample(1.0);
        assert!(
            (s.rate - 0.625).abs() < 1e-12 && s.acceleration == 0.0,
            "{s:?}"
        );
        assert!((s.position - 0.5).abs() < 1e-12, "{s:?}");
        assert!((r.sample(2.0).position - 1.0).abs() < 1e-12);
        for t in [0.1, 0.3, 0.7, 1.5, 1.9] {
            derivatives_agree(&r, t);
        }
    }

    #[test]
    fn steps_ramps_and_tables_sample_as_written() {
        let step = checked(Reference::Step {
            initial: 0.0,
            value: 0.3,
            time: 1.0,
        });
        assert_eq!(
            [step.sample(0.99).position, step.sample(1.0).position],
            [0.0, 0.3]
        );
        let ramp = checked(Reference::Ramp {
            initial: 0.1,
            rate: 0.2,
            start: 1.0,
        });
        assert_eq!(ramp.sample(0.5), ReferenceSample::held(0.1));
        let s = ramp.sample(2.0);
        assert!((s.position - 0.3).abs() < 1e-15 && s.rate == 0.2, "{s:?}");
        let mut table = checked(Reference::Table {
            file: "moves.csv".into(),
            rows: Vec::new(),
        });
        assert_eq!(table.table_file(), Some("moves.csv"));
        table
            .set_rows(vec![[0.0, 0.0], [1.0, 0.5], [3.0, 0.1]])
            .unwrap();
        let s = table.sample(2.0);
        assert!(
            (s.position - 0.3).abs() < 1e-15 && (s.rate + 0.2).abs() < 1e-15,
            "{s:?}"
        );
        assert_eq!(table.sample(5.0), ReferenceSample::held(0.1));
        let error = table.set_rows(vec![[0.0, 0.0], [0.0, 1.0]]).unwrap_err();
        assert!(
            error.contains("row 1: its time 0 s must be after"),
            "{error}"
        );
    }

    #[test]
    fn bad_waypoints_are_refused_by_field() {
        let check = |points: &[[f64; 2]], profile, share| {
            waypoints(points, profile, share).validate().unwrap_err()
        };
        let one = check(&[[0.0, 1.0]], Profile::Quintic, None);
        assert!(one.contains("at least two"), "{one}");
        let back = check(&[[1.0, 0.0], [0.5, 1.0]], Profile::Quintic, None);
        assert!(back.contains("points 1"), "{back}");
        let share = check(&[[0.0, 0.0], [1.0, 1.0]], Profile::Trapezoidal, Some(0.7));
        assert!(share.contains("acceleration_share = 0.7"), "{share}");
        let quintic = check(&[[0.0, 0.0], [1.0, 1.0]], Profile::Quintic, Some(0.2));
        assert!(quintic.contains("trapezoidal"), "{quintic}");
    }
}
