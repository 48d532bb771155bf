//! Paths of the mobile platform's point H: straights and curves (clothoid – circular arc –
//! clothoid), with position, heading, curvature and their derivatives along the arc length s, and
//! a timing law that starts and ends at rest.
//!
//! A curve of radius R (positive: turning left) and clothoid length L_c is three pieces whose
//! curvature is linear in s: 0 → 1/R over L_c, 1/R over the arc length, 1/R → 0 over L_c. Heading
//! and curvature are therefore continuous (the lateral acceleration v²κ has no jumps). Position
//! is the integral of (cos θ, sin θ) with θ quadratic in s: the Fresnel integrals, evaluated by
//! composite 5-point Gauss–Legendre quadrature (5 cm panels: error far below 1e-12 m here).
//!
//! Timing: from standstill, the speed rises as `v = V·(1 − cos(π t/T))/2` over T, cruises at V
//! and falls back the same way to stop at the end of the path.

use serde::Deserialize;
use std::f64::consts::PI;
use thiserror::Error;

/// One segment of a path.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Segment {
    /// A straight line, m.
    Straight {
        /// Length of the line, m.
        length: f64,
    },
    /// Clothoid – circular arc – clothoid. `radius` (m) is signed: positive turns left.
    Curve {
        /// Radius R of the circular arc, m; positive turns left.
        radius: f64,
        /// Length L_c of each clothoid, m; 0 joins the arc with a jump in curvature.
        clothoid_length: f64,
        /// Length of the circular arc between the clothoids, m.
        arc_length: f64,
    },
}

/// A path and its timing.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PathSpec {
    /// The straights and curves of the path, in the order H follows them.
    pub segments: Vec<Segment>,
    /// Cruise speed V of point H, m/s.
    #[serde(default = "default_speed")]
    pub speed: f64,
    /// Time T to reach V from rest (and to stop again), s.
    #[serde(default = "default_acceleration_time")]
    pub acceleration_time: f64,
}

fn default_speed() -> f64 {
    0.1
}

fn default_acceleration_time() -> f64 {
    2.0
}

/// Why a [`PathSpec`] cannot be made into a [`Path`].
#[derive(Debug, Clone, PartialEq, Error)]
pub enum PathError {
    /// A segment's length is negative or not finite.
    #[error("path segment {segment}: {name} must be finite and ≥ 0, got {value}")]
    NegativeLength {
        /// Index of the segment, from 0.
        segment: usize,
        /// Which length: `length`, `clothoid_length` or `arc_length`.
        name: &'static str,
        /// The rejected length, m.
        value: f64,
    },
    /// A curve's radius is zero or not finite.
    #[error("path segment {segment}: radius must be finite and non-zero, got {value}")]
    BadRadius {
        /// Index of the segment, from 0.
        segment: usize,
        /// The rejected radius, m.
        value: f64,
    },
    /// There are no segments, or all of them have zero length.
    #[error("path has no length")]
    Empty,
    /// The cruise speed or the acceleration time is not finite and positive.
    #[error("path {name} must be finite and > 0, got {value}")]
    BadTiming {
        /// `speed` or `acceleration_time`.
        name: &'static str,
        /// The rejected value, m/s or s.
        value: f64,
    },
    /// The path is shorter than the distance needed to reach the cruise speed and stop again.
    #[error(
        "path is {length:.3} m long, shorter than the {needed:.3} m needed to speed up and stop"
    )]
    TooShort {
        /// Total arc length of the path, m.
        length: f64,
        /// V·T: the distance covered speeding up and slowing down, m.
        needed: f64,
    },
}

/// A point of the path at arc length s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathPoint {
    /// Arc length from the start of the path, m.
    pub s: f64,
    /// m.
    pub position: [f64; 2],
    /// θ, rad; dθ/ds = curvature.
    pub heading: f64,
    /// κ, 1/m (positive: turning left).
    pub curvature: f64,
    /// dκ/ds, 1/m².
    pub curvature_rate: f64,
}

impl PathPoint {
    /// dp/ds: the unit tangent.
    pub fn tangent(&self) -> [f64; 2] {
        [self.heading.cos(), self.heading.sin()]
    }

    /// d²p/ds² = κ·n.
    pub fn normal_acceleration(&self) -> [f64; 2] {
        [
            -self.curvature * self.heading.sin(),
            self.curvature * self.heading.cos(),
        ]
    }
}

/// Where the path should have brought point H at time t.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathSample {
    /// Position, heading and curvature at the arc length reached at t.
    pub point: PathPoint,
    /// ds/dt, m/s.
    pub speed: f64,
    /// d²s/dt², m/s².
    pub acceleration: f64,
    /// dp/dt, m/s.
    pub velocity: [f64; 2],
    /// dθ/dt, rad/s.
    pub heading_rate: f64,
}

/// A piece with curvature linear in s.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Piece {
    start: f64,
    length: f64,
    curvature: f64,
    curvature_rate: f64,
    position: [f64; 2],
    heading: f64,
}

impl Piece {
    fn heading_at(&self, u: f64) -> f64 {
        self.heading + self.curvature * u + 0.5 * self.curvature_rate * u * u
    }

    /// Position after `u` metres along the piece (the Fresnel integrals).
    fn position_at(&self, u: f64) -> [f64; 2] {
        const NODES: [f64; 5] = [
            0.0,
            -0.538_469_310_105_683_1,
            0.538_469_310_105_683_1,
            -0.906_179_845_938_664,
            0.906_179_845_938_664,
        ];
        const WEIGHTS: [f64; 5] = [
            0.568_888_888_888_888_9,
            0.478_628_670_499_366_5,
            0.478_628_670_499_366_5,
            0.236_926_885_056_189_1,
            0.236_926_885_056_189_1,
        ];
        let panels = (u / 0.05).ceil().max(1.0) as usize;
        let h = u / panels as f64;
        let [mut x, mut y] = self.position;
        for p in 0..panels {
            let mid = (p as f64 + 0.5) * h;
            for (node, weight) in NODES.iter().zip(WEIGHTS) {
                let theta = self.heading_at(mid + 0.5 * h * node);
                x += 0.5 * h * weight * theta.cos();
                y += 0.5 * h * weight * theta.sin();
            }
        }
        [x, y]
    }
}

/// A path ready to sample.
#[derive(Debug, Clone, PartialEq)]
pub struct Path {
    pieces: Vec<Piece>,
    length: f64,
    speed: f64,
    acceleration_time: f64,
}

impl Path {
    /// Builds the path from `spec`, starting at `start` (m) with heading `heading` (rad).
    pub fn new(spec: &PathSpec, start: [f64; 2], heading: f64) -> Result<Self, PathError> {
        let shapes = Self::shapes(spec)?;
        for (name, value) in [
            ("speed", spec.speed),
            ("acceleration_time", spec.acceleration_time),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(PathError::BadTiming { name, value });
            }
        }
        let mut pieces: Vec<Piece> = Vec::new();
        let mut at = Piece {
            start: 0.0,
            length: 0.0,
            curvature: 0.0,
            curvature_rate: 0.0,
            position: start,
            heading,
        };
        for (length, curvature, curvature_rate) in shapes.into_iter().filter(|s| s.0 > 0.0) {
            let piece = Piece {
                start: at.start + at.length,
                length,
                curvature,
                curvature_rate,
                position: at.position_at(at.length),
                heading: at.heading_at(at.length),
            };
            pieces.push(piece);
            at = piece;
        }
        let length = at.start + at.length;
        if pieces.is_empty() {
            return Err(PathError::Empty);
        }
        let needed = spec.speed * spec.acceleration_time;
        if length < needed {
            return Err(PathError::TooShort { length, needed });
        }
        Ok(Self {
            pieces,
            length,
            speed: spec.speed,
            acceleration_time: spec.acceleration_time,
        })
    }

    /// The segments of `spec` as pieces of linear curvature, in order: `(length, curvature at
    /// the start, curvature rate)` (a curve is clothoid, arc, clothoid; zero lengths kept).
    fn shapes(spec: &PathSpec) -> Result<Vec<(f64, f64, f64)>, PathError> {
        let mut shapes = Vec::new();
        for (segment, item) in spec.segments.iter().enumerate() {
            let check = |name: &'static str, value: f64| {
                if value.is_finite() && value >= 0.0 {
                    Ok(value)
                } else {
                    Err(PathError::NegativeLength {
                        segment,
                        name,
                        value,
                    })
                }
            };
            match *item {
                Segment::Straight { length } => shapes.push((check("length", length)?, 0.0, 0.0)),
                Segment::Curve {
                    radius,
                    clothoid_length,
                    arc_length,
                } => {
                    let clothoid = check("clothoid_length", clothoid_length)?;
                    let arc = check("arc_length", arc_length)?;
                    if !(radius.is_finite() && radius != 0.0) {
                        return Err(PathError::BadRadius {
                            segment,
                            value: radius,
                        });
                    }
                    let kappa = 1.0 / radius;
                    if clothoid > 0.0 {
                        shapes.push((clothoid, 0.0, kappa / clothoid));
                    }
                    shapes.push((arc, kappa, 0.0));
                    if clothoid > 0.0 {
                        shapes.push((clothoid, kappa, -kappa / clothoid));
                    }
                }
            }
        }
        Ok(shapes)
    }

    /// Total arc length, m.
    pub fn length(&self) -> f64 {
        self.length
    }

    /// Time from start to stop, s.
    pub fn duration(&self) -> f64 {
        self.length / self.speed + self.acceleration_time
    }

    /// The point at arc length `s` (clamped to the path).
    pub fn at(&self, s: f64) -> PathPoint {
        let s = s.clamp(0.0, self.length);
        let piece = self
            .pieces
            .iter()
            .rev()
            .find(|p| p.start <= s)
            .unwrap_or(&self.pieces[0]);
        let u = (s - piece.start).min(piece.length);
        PathPoint {
            s,
            position: piece.position_at(u),
            heading: piece.heading_at(u),
            curvature: piece.curvature + piece.curvature_rate * u,
            curvature_rate: piece.curvature_rate,
        }
    }

    /// Arc length, speed and acceleration along the path at time `t` (s).
    pub fn timing(&self, t: f64) -> [f64; 3] {
        let (v, ta) = (self.speed, self.acceleration_time);
        let ramp = |tau: f64| {
            // Distance, speed and acceleration τ seconds into the speed-up.
            let phase = PI * tau / ta;
            [
                0.5 * v * (tau - ta / PI * phase.sin()),
                0.5 * v * (1.0 - phase.cos()),
                0.5 * v * PI / ta * phase.sin(),
            ]
        };
        let total = self.duration();
        if t <= 0.0 {
            [0.0, 0.0, 0.0]
        } else if t < ta {
            ramp(t)
        } else if t <= total - ta {
            [0.5 * v * ta + v * (t - ta), v, 0.0]
        } else if t < total {
            let [d, speed, a] = ramp(total - t);
            [self.length - d, speed, -a]
        } else {
            [self.length, 0.0, 0.0]
        }
    }

    /// Where point H should be at time `t`.
    pub fn sample(&self, t: f64) -> PathSample {
        let [s, speed, acceleration] = self.timing(t);
        let point = self.at(s);
        let [tx, ty] = point.tangent();
        PathSample {
            point,
            speed,
            acceleration,
            velocity: [tx * speed, ty * speed],
            heading_rate: point.curvature * speed,
        }
    }

    /// Arc length of the point of the path nearest to `position`, searched from `guess` (Newton
    /// steps on the tangential offset); with it, the distance to the path.
    pub fn nearest(&self, position: [f64; 2], guess: f64) -> (f64, f64) {
        let mut s = guess.clamp(0.0, self.length);
        for _ in 0..8 {
            let p = self.at(s);
            let [tx, ty] = p.tangent();
            let (dx, dy) = (position[0] - p.position[0], position[1] - p.position[1]);
            let along = dx * tx + dy * ty;
            let across = -dx * ty + dy * tx;
            let denominator = (1.0 - p.curvature * across).max(0.2);
            let next = (s + along / denominator).clamp(0.0, self.length);
            let converged = (next - s).abs() < 1e-10;
            s = next;
            if converged {
                break;
            }
        }
        let p = self.at(s).position;
        (s, (position[0] - p[0]).hypot(position[1] - p[1]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn figure_7() -> PathSpec {
        PathSpec {
            segments: vec![
                Segment::Straight { length: 0.6 },
                Segment::Curve {
                    radius: 0.5,
                    clothoid_length: 0.3,
                    arc_length: 0.4854,
                },
                Segment::Straight { length: 0.8 },
            ],
            speed: 0.1,
            acceleration_time: 2.0,
        }
    }

    #[test]
    fn heading_and_curvature_are_continuous() {
        let path = Path::new(&figure_7(), [0.0, 0.0], 0.0).unwrap();
        let h = 1e-7;
        for piece in &path.pieces[1..] {
            let (before, after) = (path.at(piece.start - h), path.at(piece.start + h));
            assert!((before.heading - after.heading).abs() < 1e-6);
            assert!((before.curvature - after.curvature).abs() < 1e-5);
            let gap = (before.position[0] - after.position[0])
                .hypot(before.position[1] - after.position[1]);
            assert!(gap < 3e-7, "{gap}");
        }
        // Two clothoids (0.3 m each to 1/0.5 m) and the arc turn by 0.3 + 0.3 + 0.9708 rad.
        let end = path.at(path.length());
        assert!((end.heading - (0.6 + 0.4854 / 0.5)).abs() < 1e-12);
        assert_eq!(end.curvature, 0.0);
    }

    #[test]
    fn clothoid_matches_the_fresnel_series() {
        // A clothoid from rest, θ = u²/(2 R L): x = ∫cos θ, y = ∫sin θ by their power series.
        let (radius, clothoid) = (0.5, 0.3);
        let spec = PathSpec {
            segments: vec![Segment::Curve {
                radius,
                clothoid_length: clothoid,
                arc_length: 0.0,
            }],
            speed: 0.1,
            acceleration_time: 1.0,
        };
        let path = Path::new(&spec, [0.0, 0.0], 0.0).unwrap();
        let a = 1.0 / (2.0 * radius * clothoid);
        let (mut x, mut y) = (0.0, 0.0);
        let mut factorial = 1.0;
        for n in 0..12i32 {
            let k = 2 * n;
            if n > 0 {
                factorial *= (k - 1) as f64 * k as f64;
            }
            let sign = if n % 2 == 0 { 1.0 } else { -1.0 };
            x += sign * a.powi(k) * clothoid.powi(2 * k + 1) / (factorial * (2 * k + 1) as f64);
            let f1 = factorial * (k + 1) as f64;
            y += sign * a.powi(k + 1) * clothoid.powi(2 * k + 3) / (f1 * (2 * k + 3) as f64);
        }
        let p = path.at(clothoid).position;
        assert!(
            (p[0] - x).abs() < 1e-13 && (p[1] - y).abs() < 1e-13,
            "{p:?} {x} {y}"
        );
    }

    #[test]
    fn timing_starts_and_ends_at_rest() {
        let path = Path::new(&figure_7(), [0.0, 0.0], 0.0).unwrap();
        assert_eq!(path.timing(0.0), [0.0, 0.0, 0.0]);
        let end = path.timing(path.duration());
        assert!((end[0] - path.length()).abs() < 1e-12 && end[1].abs() < 1e-12);
        let mid = path.timing(10.0);
        assert_eq!(mid[1], 0.1);
        let a = path.timing(1.999_999);
        let b = path.timing(2.000_001);
        assert!((a[0] - b[0]).abs() < 1e-6 && (a[1] - b[1]).abs() < 1e-6);
    }

    #[test]
    fn nearest_point_on_the_arc() {
        let path = Path::new(&figure_7(), [0.0, 0.0], 0.0).unwrap();
        let p = path.at(1.0);
        let n = p.normal_acceleration();
        let offset = [
            p.position[0] + 0.01 * n[0] * 0.5,
            p.position[1] + 0.01 * n[1] * 0.5,
        ];
        let (s, d) = path.nearest(offset, 0.9);
        assert!((s - 1.0).abs() < 1e-6 && (d - 0.01).abs() < 1e-6, "{s} {d}");
    }

    #[test]
    fn bad_paths_are_errors() {
        let mut spec = figure_7();
        spec.segments[0] = Segment::Straight { length: -0.1 };
        let err = Path::new(&spec, [0.0; 2], 0.0).unwrap_err();
        assert!(err.to_string().contains("length must be"), "{err}");
        let mut spec = figure_7();
        spec.segments[1] = Segment::Curve {
            radius: 0.0,
            clothoid_length: 0.3,
            arc_length: 0.4,
        };
        let err = Path::new(&spec, [0.0; 2], 0.0).unwrap_err();
        assert!(err.to_string().contains("radius"), "{err}");
        spec.segments = vec![];
        assert_eq!(Path::new(&spec, [0.0; 2], 0.0), Err(PathError::Empty));
        let mut spec = figure_7();
        spec.speed = 10.0;
        assert!(matches!(
            Path::new(&spec, [0.0; 2], 0.0),
            Err(PathError::TooShort { .. })
        ));
    }
}
