//! The machining robot's program, after Ilyukhin, Poduraev & Tatarintseva (DAAAM 2014, §2): a part
//! contour of lines and arcs in the arm's plane, cut into control points an equal path length
//! `L` apart, turned into joint coordinates by the arm's inverse kinematics, and interpolated per
//! segment by a cubic in the path length (Ilyukhin eq (2)) whose coefficients come from the
//! neighbouring control points (Ilyukhin eqs (3)–(4)). The path length `l` is integrated from the
//! path speed; a segment is left when `l` reaches `L` ([`JointPath::advance`]).
//!
//! **Coefficients.** With the end derivatives `q'_k = (q_{k+1} − q_{k−1})/2L` and
//! `q'_{k+1} = (q_{k+2} − q_k)/2L` (their choice), the cubic through both points with both
//! derivatives has `d = q_k`, `c = Δ1/2L`, `b = (6Δ0 − 2Δ1 − Δ2)/L²` and
//! `a = (−12Δ0 + 3Δ1 + 3Δ2)/L³`, with `Δ0 = q_{k+1} − q_k`, `Δ1 = q_{k+1} − q_{k−1}`,
//! `Δ2 = q_{k+2} − q_k`. The printed Ilyukhin eq (4) has `−3Δ2` in `a`, and Ilyukhin eq (3)
//! `−2(q'_{k+1} − q'_k)` where the end-point condition needs `−2(q_{k+1} − q_k)`; both are
//! misprints (with them the cubic misses `q_{k+1}`), and the twin uses the Hermite form, which the
//! unit tests check. At the contour's ends the missing neighbour is extrapolated linearly (`q_{−1}
//! = 2q_0 − q_1`).
//!
//! # Arm
//!
//! Three revolute joints in a vertical plane: `shoulder` at `base`, `elbow` at `upper` along the
//! upper arm, `wrist` at `fore` along the forearm, and the spindle axis at `hand` along the hand.
//! Joint angles are relative (each to the previous link; the shoulder's to +x), counter-clockwise
//! positive, zero with the arm stretched along +x. The program holds the hand at a fixed angle
//! `tool_angle` to +x, so the three joints are determined by the tool point and the elbow side.

use serde::Deserialize;
use std::f64::consts::{PI, TAU};
use thiserror::Error;

/// Link lengths of the planar arm, m.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ArmGeometry {
    /// Shoulder axis in the world, m.
    pub base: [f64; 2],
    /// Shoulder to elbow, m.
    pub upper: f64,
    /// Elbow to wrist, m.
    pub fore: f64,
    /// Wrist to spindle axis, m.
    pub hand: f64,
}

impl Default for ArmGeometry {
    /// The twin's `urdf/arm.urdf` (a small industrial arm; notes in `twin/src/machines/arm.rs`).
    fn default() -> Self {
        Self {
            base: [0.0, 0.0],
            upper: 0.40,
            fore: 0.36,
            hand: 0.12,
        }
    }
}

/// Which side of the shoulder–wrist line the elbow is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Elbow {
    /// Counter-clockwise side (above the line when the wrist is to the right of the shoulder).
    #[default]
    Up,
    /// Clockwise side (below the line when the wrist is to the right of the shoulder).
    Down,
}

/// Why an arm, a contour or its joint-space program is rejected.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum PathError {
    /// A contour point cannot be reached with the hand at the tool angle: the wrist would lie
    /// outside the annulus the upper arm and forearm sweep.
    #[error(
        "contour point ({x:.4}, {y:.4}) m is out of the arm's reach: the wrist would be {distance:.4} m \
         from the shoulder, the arm reaches {inner:.4}…{outer:.4} m"
    )]
    OutOfReach {
        /// x of the contour point, m.
        x: f64,
        /// y of the contour point, m.
        y: f64,
        /// Shoulder-to-wrist distance the point would need, m.
        distance: f64,
        /// Nearest reachable wrist distance, |upper − fore|, m.
        inner: f64,
        /// Farthest reachable wrist distance, upper + fore, m.
        outer: f64,
    },
    /// An [`ArmGeometry`] length is not finite and positive, or the base is not finite; holds the
    /// field's name.
    #[error("arm: {0} must be finite and > 0")]
    BadArm(&'static str),
    /// The [`Contour`] cannot be measured (non-finite start, no or zero-length segments, an arc
    /// over a full turn, a bad spacing); holds what to change.
    #[error("contour: {0}")]
    BadContour(String),
}

impl ArmGeometry {
    fn validate(&self) -> Result<(), PathError> {
        for (name, value) in [
            ("upper", self.upper),
            ("fore", self.fore),
            ("hand", self.hand),
        ] {
            if !(value > 0.0 && value.is_finite()) {
                return Err(PathError::BadArm(name));
            }
        }
        if !self.base.iter().all(|v| v.is_finite()) {
            return Err(PathError::BadArm("base"));
        }
        Ok(())
    }

    /// The spindle axis for joint angles `q`, m.
    pub fn tool_point(&self, q: [f64; 3]) -> [f64; 2] {
        let (a1, a2, a3) = (q[0], q[0] + q[1], q[0] + q[1] + q[2]);
        [
            self.base[0] + self.upper * a1.cos() + self.fore * a2.cos() + self.hand * a3.cos(),
            self.base[1] + self.upper * a1.sin() + self.fore * a2.sin() + self.hand * a3.sin(),
        ]
    }

    /// Joint angles putting the spindle axis at `point` with the hand at `tool_angle` (rad).
    pub fn inverse(
        &self,
        point: [f64; 2],
        tool_angle: f64,
        elbow: Elbow,
    ) -> Result<[f64; 3], PathError> {
        let wx = point[0] - self.hand * tool_angle.cos() - self.base[0];
        let wy = point[1] - self.hand * tool_angle.sin() - self.base[1];
        let distance = wx.hypot(wy);
        let (inner, outer) = ((self.upper - self.fore).abs(), self.upper + self.fore);
        let cos_elbow = (distance * distance - self.upper.powi(2) - self.fore.powi(2))
            / (2.0 * self.upper * self.fore);
        if !(distance >= inner && distance <= outer && cos_elbow.abs() <= 1.0) {
            return Err(PathError::OutOfReach {
                x: point[0],
                y: point[1],
                distance,
                inner,
                outer,
            });
        }
        let sin_elbow = (1.0 - cos_elbow * cos_elbow).sqrt()
            * match elbow {
                Elbow::Up => -1.0,
                Elbow::Down => 1.0,
            };
        let elbow_angle = sin_elbow.atan2(cos_elbow);
        let shoulder =
            wy.atan2(wx) - (self.fore * sin_elbow).atan2(self.upper + self.fore * cos_elbow);
        Ok([shoulder, elbow_angle, tool_angle - shoulder - elbow_angle])
    }
}

/// One piece of a contour, starting where the previous one ends.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Segment {
    /// A straight line to this point, m.
    Line([f64; 2]),
    /// An arc about `center` (m) turning by `sweep` (rad, counter-clockwise positive).
    Arc {
        /// Centre of the arc, m; the radius is its distance from the segment's start.
        center: [f64; 2],
        /// Angle turned about the centre, rad, counter-clockwise positive, at most one turn.
        sweep: f64,
    },
}

/// A part contour: the tool's programmed path in the arm's plane.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Contour {
    /// Where the tool starts, m.
    pub start: [f64; 2],
    /// The lines and arcs of the contour, in the order the tool follows them.
    pub segments: Vec<Segment>,
    /// Angle of the hand to +x along the whole contour, rad.
    pub tool_angle: f64,
    /// Largest distance between control points, m (the program uses the next equal spacing below).
    pub spacing: f64,
}

impl Default for Contour {
    /// A rounded corner of a cast part, the stock below and to the left of the tool path: 140 mm
    /// along −0.25 m, a 30 mm-radius quarter arc turning down, 40 mm down; the hand hangs
    /// straight down; control points at most 2.5 mm apart.
    fn default() -> Self {
        Self {
            start: [0.36, -0.25],
            segments: vec![
                Segment::Line([0.50, -0.25]),
                Segment::Arc {
                    center: [0.50, -0.28],
                    sweep: -PI / 2.0,
                },
                Segment::Line([0.53, -0.32]),
            ],
            tool_angle: -PI / 2.0,
            spacing: 0.0025,
        }
    }
}

/// A point of the contour seen from a tool position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// Path length to the nearest contour point, m.
    pub along: f64,
    /// Distance from the contour, m.
    pub distance: f64,
    /// Offset to the right of the direction of travel (positive on the right), m.
    pub right_offset: f64,
    /// Unit direction of travel at the nearest point.
    pub tangent: [f64; 2],
}

/// A contour checked and measured, ready to be sampled and projected on.
#[derive(Debug, Clone, PartialEq)]
pub struct ContourPath {
    /// Per segment: start point, start path length, length.
    pieces: Vec<Piece>,
    length: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Piece {
    start: [f64; 2],
    along: f64,
    length: f64,
    segment: Segment,
    /// Arc: radius and start angle from the centre.
    radius: f64,
    angle: f64,
}

impl ContourPath {
    /// Measures each segment of `contour`; rejects a non-finite start or tool angle, no or
    /// zero-length segments, and arcs of more than one turn.
    pub fn new(contour: &Contour) -> Result<Self, PathError> {
        let bad = |reason: String| PathError::BadContour(reason);
        if !contour.start.iter().all(|v| v.is_finite()) || !contour.tool_angle.is_finite() {
            return Err(bad("start and tool_angle must be finite".into()));
        }
        if contour.segments.is_empty() {
            return Err(bad("needs at least one segment".into()));
        }
        let mut pieces = Vec::new();
        let (mut point, mut along) = (contour.start, 0.0);
        for (i, segment) in contour.segments.iter().enumerate() {
            let (length, radius, angle, end) = match *segment {
                Segment::Line(to) => {
                    let length = (to[0] - point[0]).hypot(to[1] - point[1]);
                    (length, 0.0, 0.0, to)
                }
                Segment::Arc { center, sweep } => {
                    let radius = (point[0] - center[0]).hypot(point[1] - center[1]);
                    let angle = (point[1] - center[1]).atan2(point[0] - center[0]);
                    let end = [
                        center[0] + radius * (angle + sweep).cos(),
                        center[1] + radius * (angle + sweep).sin(),
                    ];
                    if sweep.abs() > TAU {
                        return Err(bad(format!("segment {i}: an arc turns at most one turn")));
                    }
                    (radius * sweep.abs(), radius, angle, end)
                }
            };
            if !(length > 1e-9 && length.is_finite()) {
                return Err(bad(format!("segment {i} has no length")));
            }
            pieces.push(Piece {
                start: point,
                along,
                length,
                segment: *segment,
                radius,
                angle,
            });
            point = end;
            along += length;
        }
        Ok(Self {
            pieces,
            length: along,
        })
    }

    /// Total path length, m.
    pub fn length(&self) -> f64 {
        self.length
    }

    /// The point and unit tangent at path length `along` (clamped to the contour), m.
    pub fn point(&self, along: f64) -> ([f64; 2], [f64; 2]) {
        let along = along.clamp(0.0, self.length);
        let piece = self
            .pieces
            .iter()
            .rev()
            .find(|p| p.along <= along)
            .unwrap_or(&self.pieces[0]);
        piece.point(along - piece.along)
    }

    /// The contour point nearest to `position`.
    pub fn project(&self, position: [f64; 2]) -> Projection {
        let mut best: Option<(f64, f64, [f64; 2])> = None;
        for piece in &self.pieces {
            let local = piece.nearest(position);
            let (p, _) = piece.point(local);
            let distance = (position[0] - p[0]).hypot(position[1] - p[1]);
            if best.is_none_or(|(d, _, _)| distance < d) {
                best = Some((distance, piece.along + local, p));
            }
        }
        let (distance, along, nearest) = best.unwrap_or((0.0, 0.0, self.pieces[0].start));
        let (_, tangent) = self.point(along);
        let right = [tangent[1], -tangent[0]];
        let right_offset =
            (position[0] - nearest[0]) * right[0] + (position[1] - nearest[1]) * right[1];
        Projection {
            along,
            distance,
            right_offset,
            tangent,
        }
    }
}

impl Piece {
    fn point(&self, local: f64) -> ([f64; 2], [f64; 2]) {
        match self.segment {
            Segment::Line(to) => {
                let t = [
                    (to[0] - self.start[0]) / self.length,
                    (to[1] - self.start[1]) / self.length,
                ];
                (
                    [self.start[0] + t[0] * local, self.start[1] + t[1] * local],
                    t,
                )
            }
            Segment::Arc { center, sweep } => {
                let turn = sweep.signum();
                let angle = self.angle + turn * local / self.radius;
                let (s, c) = angle.sin_cos();
                (
                    [center[0] + self.radius * c, center[1] + self.radius * s],
                    [-turn * s, turn * c],
                )
            }
        }
    }

    /// Local path length of the point nearest to `position`.
    fn nearest(&self, position: [f64; 2]) -> f64 {
        match self.segment {
            Segment::Line(_) => {
                let (_, t) = self.point(0.0);
                ((position[0] - self.start[0]) * t[0] + (position[1] - self.start[1]) * t[1])
                    .clamp(0.0, self.length)
            }
            Segment::Arc { center, sweep } => {
                let angle = (position[1] - center[1]).atan2(position[0] - center[0]);
                // Turned from the start in the arc's sense, in [0, 2π).
                let turned = (sweep.signum() * (angle - self.angle)).rem_euclid(TAU);
                let end = sweep.abs();
                let local = if turned <= end {
                    turned
                } else if turned - end < TAU - turned {
                    end
                } else {
                    0.0
                };
                local * self.radius
            }
        }
    }
}

/// The joint-space program: per segment and joint, the cubic of Ilyukhin eq (2) in the path length.
#[derive(Debug, Clone, PartialEq)]
pub struct JointPath {
    /// Equal segment length L, m.
    spacing: f64,
    /// Per segment, per joint: `[a, b, c, d]` of Ilyukhin eq (2).
    coefficients: Vec<[[f64; 4]; 3]>,
    /// Joint angles at the control points.
    points: Vec<[f64; 3]>,
}

/// Where the program is: segment `k` and the path length `l_k` along it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PathCursor {
    /// Index k of the current segment, from 0.
    pub segment: usize,
    /// Path length l_k covered within the segment, m, in [0, L].
    pub along: f64,
}

/// Joint reference at a path position: angles and their first and second derivatives in l.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointSample {
    /// Shoulder, elbow and wrist angles q, rad.
    pub position: [f64; 3],
    /// dq/dl, rad/m.
    pub slope: [f64; 3],
    /// d²q/dl², rad/m².
    pub curvature: [f64; 3],
}

impl JointPath {
    /// Control points along `contour` an equal `L ≤ spacing` apart, through the inverse kinematics.
    pub fn new(arm: &ArmGeometry, contour: &Contour, elbow: Elbow) -> Result<Self, PathError> {
        arm.validate()?;
        if !(contour.spacing > 0.0 && contour.spacing.is_finite()) {
            return Err(PathError::BadContour(format!(
                "spacing must be finite and > 0 (got {})",
                contour.spacing
            )));
        }
        let path = ContourPath::new(contour)?;
        let segments = (path.length() / contour.spacing).ceil().max(1.0) as usize;
        let spacing = path.length() / segments as f64;
        let mut points: Vec<[f64; 3]> = Vec::with_capacity(segments + 1);
        for k in 0..=segments {
            let (point, _) = path.point(k as f64 * spacing);
            let mut q = arm.inverse(point, contour.tool_angle, elbow)?;
            // Keep the angles continuous from one control point to the next.
            if let Some(previous) = points.last() {
                for (angle, last) in q.iter_mut().zip(previous) {
                    *angle += TAU * ((*last - *angle) / TAU).round();
                }
            }
            points.push(q);
        }
        let n = points.len();
        let at = |k: isize, i: usize| -> f64 {
            if k < 0 {
                2.0 * points[0][i] - points[1][i]
            } else if k as usize >= n {
                2.0 * points[n - 1][i] - points[n - 2][i]
            } else {
                points[k as usize][i]
            }
        };
        let l = spacing;
        let coefficients = (0..segments as isize)
            .map(|k| {
                std::array::from_fn(|i| {
                    let d0 = at(k + 1, i) - at(k, i);
                    let d1 = at(k + 1, i) - at(k - 1, i);
                    let d2 = at(k + 2, i) - at(k, i);
                    [
                        (-12.0 * d0 + 3.0 * d1 + 3.0 * d2) / l.powi(3),
                        (6.0 * d0 - 2.0 * d1 - d2) / (l * l),
                        d1 / (2.0 * l),
                        at(k, i),
                    ]
                })
            })
            .collect();
        Ok(Self {
            spacing,
            coefficients,
            points,
        })
    }

    /// The equal segment length L, m.
    pub fn spacing(&self) -> f64 {
        self.spacing
    }

    /// Total path length, m.
    pub fn length(&self) -> f64 {
        self.spacing * self.coefficients.len() as f64
    }

    /// Joint angles at the control points.
    pub fn points(&self) -> &[[f64; 3]] {
        &self.points
    }

    /// Moves `cursor` on by `distance` (m, ≥ 0): segments switch when `l_k` reaches L; the cursor
    /// stops at the end of the last segment.
    pub fn advance(&self, cursor: &mut PathCursor, distance: f64) {
        cursor.along += distance.max(0.0);
        let last = self.coefficients.len() - 1;
        while cursor.along >= self.spacing && cursor.segment < last {
            cursor.along -= self.spacing;
            cursor.segment += 1;
        }
        if cursor.segment == last {
            cursor.along = cursor.along.min(self.spacing);
        }
    }

    /// Path length covered at `cursor`, m.
    pub fn covered(&self, cursor: &PathCursor) -> f64 {
        cursor.segment as f64 * self.spacing + cursor.along
    }

    /// Whether `cursor` has reached the end of the contour.
    pub fn finished(&self, cursor: &PathCursor) -> bool {
        cursor.segment + 1 == self.coefficients.len() && cursor.along >= self.spacing
    }

    /// The reference of Ilyukhin eq (2) at `cursor`.
    pub fn sample(&self, cursor: &PathCursor) -> JointSample {
        let k = cursor.segment.min(self.coefficients.len() - 1);
        let l = cursor.along;
        let mut sample = JointSample {
            position: [0.0; 3],
            slope: [0.0; 3],
            curvature: [0.0; 3],
        };
        for (i, [a, b, c, d]) in self.coefficients[k].iter().enumerate() {
            sample.position[i] = a / 6.0 * l.powi(3) + b / 2.0 * l * l + c * l + d;
            sample.slope[i] = a / 2.0 * l * l + b * l + c;
            sample.curvature[i] = a * l + b;
        }
        sample
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_kinematics_inverts_the_forward() {
        let arm = ArmGeometry::default();
        for (point, angle) in [
            ([0.4, -0.25], -PI / 2.0),
            ([0.3, 0.2], 0.3),
            ([0.6, -0.1], -1.0),
        ] {
            for elbow in [Elbow::Up, Elbow::Down] {
                let q = arm.inverse(point, angle, elbow).unwrap();
                let back = arm.tool_point(q);
                assert!((back[0] - point[0]).abs() < 1e-12 && (back[1] - point[1]).abs() < 1e-12);
                assert!(((q[0] + q[1] + q[2]) - angle).abs() < 1e-12);
                assert_eq!(q[1] < 0.0, elbow == Elbow::Up, "{q:?}");
            }
        }
    }

    #[test]
    fn out_of_reach_is_an_error_naming_the_point() {
        let arm = ArmGeometry::default();
        let err = arm.inverse([1.2, 0.0], 0.0, Elbow::Up).unwrap_err();
        assert!(err.to_string().contains("(1.2000, 0.0000)"), "{err}");
        let contour = Contour {
            segments: vec![Segment::Line([0.95, -0.25])],
            ..Default::default()
        };
        let err = JointPath::new(&arm, &contour, Elbow::Up).unwrap_err();
        assert!(matches!(err, PathError::OutOfReach { .. }), "{err}");
    }

    #[test]
    fn contour_points_and_projection() {
        let path = ContourPath::new(&Contour::default()).unwrap();
        let quarter = 0.03 * PI / 2.0;
        assert!((path.length() - (0.14 + quarter + 0.04)).abs() < 1e-12);
        let (p, t) = path.point(0.14 + quarter / 2.0);
        let r = 0.03 * (PI / 4.0).cos();
        assert!((p[0] - (0.50 + r)).abs() < 1e-12 && (p[1] - (-0.28 + r)).abs() < 1e-12);
        assert!((t[0] - t[1].abs()).abs() < 1e-12 && t[1] < 0.0, "{t:?}");
        // 1 mm below the straight part: on the right of travel along +x.
        let seen = path.project([0.42, -0.251]);
        assert!((seen.along - 0.06).abs() < 1e-12);
        assert!((seen.right_offset - 1e-3).abs() < 1e-12 && (seen.distance - 1e-3).abs() < 1e-12);
        // Outside the arc (away from its centre): on the left of travel, clockwise.
        let (p, _) = path.point(0.14 + quarter / 3.0);
        let out = [0.50 + (p[0] - 0.50) * 1.1, -0.28 + (p[1] + 0.28) * 1.1];
        let seen = path.project(out);
        assert!(
            (seen.along - (0.14 + quarter / 3.0)).abs() < 1e-9,
            "{seen:?}"
        );
        assert!((seen.right_offset + 0.003).abs() < 1e-9, "{seen:?}");
        let end = path.project([0.53, -0.40]);
        assert!((end.along - path.length()).abs() < 1e-12);
    }

    #[test]
    fn cubics_pass_the_control_points_with_continuous_slope() {
        let arm = ArmGeometry::default();
        let program = JointPath::new(&arm, &Contour::default(), Elbow::Up).unwrap();
        let l = program.spacing();
        assert!(l <= 0.0025 && l > 0.0024);
        for k in 0..program.points().len() - 1 {
            let start = program.sample(&PathCursor {
                segment: k,
                along: 0.0,
            });
            let end = program.sample(&PathCursor {
                segment: k,
                along: l,
            });
            for i in 0..3 {
                assert!((start.position[i] - program.points()[k][i]).abs() < 1e-12);
                assert!((end.position[i] - program.points()[k + 1][i]).abs() < 1e-12);
            }
            if k + 2 < program.points().len() {
                let next = program.sample(&PathCursor {
                    segment: k + 1,
                    along: 0.0,
                });
                for i in 0..3 {
                    assert!((end.slope[i] - next.slope[i]).abs() < 1e-9);
                }
            }
        }
    }

    #[test]
    fn interpolated_tool_stays_on_the_contour() {
        let arm = ArmGeometry::default();
        let contour = Contour::default();
        let program = JointPath::new(&arm, &contour, Elbow::Up).unwrap();
        let path = ContourPath::new(&contour).unwrap();
        let mut cursor = PathCursor::default();
        let mut worst: f64 = 0.0;
        while !program.finished(&cursor) {
            let q = program.sample(&cursor).position;
            let seen = path.project(arm.tool_point(q));
            worst = worst.max(seen.distance);
            // Within a hair of the programmed path length too.
            assert!((seen.along - program.covered(&cursor)).abs() < 2e-4);
            program.advance(&mut cursor, 1e-4);
        }
        // Largest where the curvature jumps (line to arc): the end slopes are central differences.
        assert!(worst < 1e-5, "interpolation error {worst} m");
        assert!((program.covered(&cursor) - path.length()).abs() < 1e-12);
    }

    #[test]
    fn advance_switches_segments_at_l() {
        let arm = ArmGeometry::default();
        let program = JointPath::new(&arm, &Contour::default(), Elbow::Up).unwrap();
        let l = program.spacing();
        let mut cursor = PathCursor::default();
        program.advance(&mut cursor, 2.5 * l);
        assert_eq!(cursor.segment, 2);
        assert!((cursor.along - 0.5 * l).abs() < 1e-12);
        program.advance(&mut cursor, 1.0);
        assert!(program.finished(&cursor));
        program.advance(&mut cursor, -1.0);
        assert!(program.finished(&cursor));
    }

    #[test]
    fn bad_contours() {
        let arm = ArmGeometry::default();
        let spacing = Contour {
            spacing: 0.0,
            ..Default::default()
        };
        assert!(JointPath::new(&arm, &spacing, Elbow::Up)
            .unwrap_err()
            .to_string()
            .contains("spacing"));
        let empty = Contour {
            segments: vec![],
            ..Default::default()
        };
        assert!(ContourPath::new(&empty).is_err());
        let still = Contour {
            segments: vec![Segment::Line([0.36, -0.25])],
            ..Default::default()
        };
        assert!(ContourPath::new(&still)
            .unwrap_err()
            .to_string()
            .contains("no length"));
        let short_arm = ArmGeometry {
            fore: 0.0,
            ..Default::default()
        };
        assert!(JointPath::new(&short_arm, &Contour::default(), Elbow::Up).is_err());
    }
}
