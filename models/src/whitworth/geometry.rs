//! Inverted Whitworth quick-return linkage: closed-form kinematics of the twin's geometry.
//!
//! Crank O2–A turns fully about the ground pivot O2 (the origin). The block on the crank pin A
//! slides in the slotted link, pivoted on the ground at O3; the slotted link carries the coupler
//! pin B at a fixed distance from O3; the coupler B–C drives the ram C on a vertical guide `x =
//! guide_x`. Angles are measured from +x, counter-clockwise; gravity acts along −y.
//!
//! Coordinates follow the paper's Appendix B: crank angle q, secondary coordinates
//! s = [r3, θ3, θ4, y] (block distance along the slot, slot angle, coupler angle, ram height).
//! The paper attaches the coupler at r3 + AB along the slot (Perrusquía eq (B.1)); the twin pins it
//! to the slotted link at a fixed distance, the classical layout, because the printed dimensions
//! cannot close the loop over a full crank turn (see the guide's Whitworth chapter).

use serde::Deserialize;
use std::f64::consts::{PI, TAU};
use thiserror::Error;

/// Dimensions of the linkage, m.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Geometry {
    /// |O2A|.
    pub crank_length: f64,
    /// O3, the slotted link's ground pivot (O2 is the origin).
    pub slot_pivot: [f64; 2],
    /// |O3B|: where the coupler is pinned on the slotted link.
    pub coupler_pin_radius: f64,
    /// |BC|.
    pub coupler_length: f64,
    /// x of the ram's vertical guide.
    pub guide_x: f64,
}

impl Default for Geometry {
    /// The twin's shaper: stroke 0.4667 m between y = 0.05428 m and y = −0.41242 m (the paper's
    /// printed stroke ends), quick-return ratio 1.383.
    fn default() -> Self {
        Self {
            crank_length: 0.5,
            slot_pivot: [-0.125, 0.12093],
            coupler_pin_radius: 0.23335,
            coupler_length: 0.30,
            guide_x: -0.125,
        }
    }
}

/// Why a [`Geometry`] cannot make a working linkage.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum GeometryError {
    /// A length that must be positive is zero, negative or NaN; holds the field's name.
    #[error("whitworth geometry: {0} must be > 0")]
    NonPositive(&'static str),
    /// The slot pivot O3 lies on or outside the crank circle, so the crank cannot make a full turn.
    #[error("whitworth geometry: the slot pivot is {distance} m from the crank pivot, not less than the crank length {crank} m, so the crank cannot turn fully")]
    CrankCannotTurn {
        /// |O2O3|, m.
        distance: f64,
        /// Crank length |O2A|, m.
        crank: f64,
    },
    /// The coupler cannot span from B to the ram guide at every slot angle.
    #[error("whitworth geometry: the coupler ({coupler} m) cannot reach the guide for every slot angle (needs ≥ {needed} m)")]
    CouplerTooShort {
        /// Coupler length |BC|, m.
        coupler: f64,
        /// |guide_x − O3x| + |O3B|, m: the coupler must be longer than this.
        needed: f64,
    },
}

/// The linkage's pose at one crank angle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Crank angle q the pose was computed at, rad.
    pub crank_angle: f64,
    /// r3 = |O3A|.
    pub slot_distance: f64,
    /// θ3.
    pub slot_angle: f64,
    /// θ4, on the branch with the ram below B (sin θ4 < 0).
    pub coupler_angle: f64,
    /// y of C.
    pub ram_position: f64,
    /// Crank pin A, (x, y) in m.
    pub crank_pin: [f64; 2],
    /// Coupler pin B on the slotted link, (x, y) in m.
    pub coupler_pin: [f64; 2],
    /// Ram pin C on the guide, (x, y) in m.
    pub ram_pin: [f64; 2],
}

/// d s / d q: the extended Jacobian of the secondary coordinates (Perrusquía eq (B.3)'s column,
/// here for the twin's layout). `ram` is ρ_y = dy/dq.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Jacobian {
    /// dr3/dq: how fast the block slides along the slot, m/rad.
    pub slot_distance: f64,
    /// dθ3/dq: slot angle turned per crank angle, rad/rad.
    pub slot_angle: f64,
    /// dθ4/dq: coupler angle turned per crank angle, rad/rad.
    pub coupler_angle: f64,
    /// ρ_y = dy/dq: ram travel per crank angle, m/rad; zero at the stroke ends.
    pub ram: f64,
}

impl Jacobian {
    /// [1, dr3/dq, dθ3/dq, dθ4/dq, dy/dq]: ρ of Perrusquía eqs (6)–(9), with q itself as the first
    /// entry.
    pub fn extended(&self) -> [f64; 5] {
        [
            1.0,
            self.slot_distance,
            self.slot_angle,
            self.coupler_angle,
            self.ram,
        ]
    }
}

/// Where the ram stops and turns: the crank angles with dy/dq = 0 and the ram there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stroke {
    /// Crank angle at the top of the stroke (start of the downward cutting stroke), in (−π, π].
    pub top_crank_angle: f64,
    /// Crank angle at the bottom of the stroke (end of the cutting stroke), in (−π, π].
    pub bottom_crank_angle: f64,
    /// Ram height y at the top of the stroke, m.
    pub top: f64,
    /// Ram height y at the bottom of the stroke, m.
    pub bottom: f64,
}

impl Stroke {
    /// L_c, m.
    pub fn length(&self) -> f64 {
        self.top - self.bottom
    }

    /// Crank travel from top to bottom turning clockwise (q decreasing), rad.
    pub fn cutting_crank_travel(&self) -> f64 {
        (self.top_crank_angle - self.bottom_crank_angle).rem_euclid(TAU)
    }

    /// Cutting-stroke time over return-stroke time at constant crank speed (clockwise crank).
    pub fn quick_return_ratio(&self) -> f64 {
        let cutting = self.cutting_crank_travel();
        cutting / (TAU - cutting)
    }
}

impl Geometry {
    /// Checks that the crank turns fully and the coupler closes the loop at every slot angle.
    pub fn validate(&self) -> Result<(), GeometryError> {
        for (name, value) in [
            ("crank_length", self.crank_length),
            ("coupler_pin_radius", self.coupler_pin_radius),
            ("coupler_length", self.coupler_length),
        ] {
            if value.is_nan() || value <= 0.0 {
                return Err(GeometryError::NonPositive(name));
            }
        }
        let distance = self.slot_pivot[0].hypot(self.slot_pivot[1]);
        if distance.is_nan() || distance >= self.crank_length {
            return Err(GeometryError::CrankCannotTurn {
                distance,
                crank: self.crank_length,
            });
        }
        let needed = (self.guide_x - self.slot_pivot[0]).abs() + self.coupler_pin_radius;
        if self.coupler_length.is_nan() || self.coupler_length <= needed {
            return Err(GeometryError::CouplerTooShort {
                coupler: self.coupler_length,
                needed,
            });
        }
        Ok(())
    }

    /// Forward kinematics (the twin's counterpart of Perrusquía eq (B.2)).
    pub fn pose(&self, crank_angle: f64) -> Pose {
        let [o3x, o3y] = self.slot_pivot;
        let crank_pin = [
            self.crank_length * crank_angle.cos(),
            self.crank_length * crank_angle.sin(),
        ];
        let (dx, dy) = (crank_pin[0] - o3x, crank_pin[1] - o3y);
        let slot_angle = dy.atan2(dx);
        let coupler_pin = [
            o3x + self.coupler_pin_radius * slot_angle.cos(),
            o3y + self.coupler_pin_radius * slot_angle.sin(),
        ];
        let coupler_angle = -((self.guide_x - coupler_pin[0]) / self.coupler_length).acos();
        let ram_position = coupler_pin[1] + self.coupler_length * coupler_angle.sin();
        Pose {
            crank_angle,
            slot_distance: dx.hypot(dy),
            slot_angle,
            coupler_angle,
            ram_position,
            crank_pin,
            coupler_pin,
            ram_pin: [self.guide_x, ram_position],
        }
    }

    /// y(q).
    pub fn ram_position(&self, crank_angle: f64) -> f64 {
        self.pose(crank_angle).ram_position
    }

    /// First-order kinematics at q (the counterpart of Perrusquía eq (B.3)).
    pub fn jacobian(&self, crank_angle: f64) -> Jacobian {
        let p = self.pose(crank_angle);
        let relative = crank_angle - p.slot_angle;
        let slot_angle = self.crank_length * relative.cos() / p.slot_distance;
        let slot_distance = -self.crank_length * relative.sin();
        // The ram stays on its guide: d/dq [R cos θ3 + r4 cos θ4] = 0.
        let coupler_angle = -self.coupler_pin_radius * p.slot_angle.sin() * slot_angle
            / (self.coupler_length * p.coupler_angle.sin());
        let ram = self.coupler_pin_radius * slot_angle * (p.coupler_angle - p.slot_angle).sin()
            / p.coupler_angle.sin();
        Jacobian {
            slot_distance,
            slot_angle,
            coupler_angle,
            ram,
        }
    }

    /// ρ_y(q) = dy/dq.
    pub fn ram_jacobian(&self, crank_angle: f64) -> f64 {
        self.jacobian(crank_angle).ram
    }

    /// The two singular crank angles (dy/dq = 0) and the stroke ends, found by bracketing the sign
    /// changes of ρ_y over a full turn and bisecting each to machine precision.
    pub fn stroke(&self) -> Result<Stroke, GeometryError> {
        self.validate()?;
        const SAMPLES: usize = 3600;
        let mut roots = Vec::with_capacity(2);
        let angle = |i: usize| -PI + TAU * i as f64 / SAMPLES as f64;
        for i in 0..SAMPLES {
            let (a, b) = (angle(i), angle(i + 1));
            if self.ram_jacobian(a).signum() != self.ram_jacobian(b).signum() {
                roots.push(self.bisect_singular(a, b));
            }
        }
        let top_crank_angle = roots
            .iter()
            .copied()
            .max_by(|a, b| self.ram_position(*a).total_cmp(&self.ram_position(*b)))
            .unwrap_or(0.0);
        let bottom_crank_angle = roots
            .iter()
            .copied()
            .min_by(|a, b| self.ram_position(*a).total_cmp(&self.ram_position(*b)))
            .unwrap_or(0.0);
        Ok(Stroke {
            top_crank_angle,
            bottom_crank_angle,
            top: self.ram_position(top_crank_angle),
            bottom: self.ram_position(bottom_crank_angle),
        })
    }

    fn bisect_singular(&self, mut low: f64, mut high: f64) -> f64 {
        let low_sign = self.ram_jacobian(low).signum();
        for _ in 0..100 {
            let mid = 0.5 * (low + high);
            if mid <= low || mid >= high {
                break;
            }
            if self.ram_jacobian(mid).signum() == low_sign {
                low = mid;
            } else {
                high = mid;
            }
        }
        0.5 * (low + high)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_geometry_meets_the_design_targets() {
        let g = Geometry::default();
        let stroke = g.stroke().unwrap();
        assert!((stroke.length() - 0.4667).abs() < 1e-6, "{stroke:?}");
        assert!((stroke.top - 0.05428).abs() < 1e-6);
        assert!((stroke.bottom + 0.41242).abs() < 1e-6);
        // The ram guide passes through O3, so the ram turns where the crank pin crosses x = O3x.
        let turn = (g.slot_pivot[0] / g.crank_length).acos();
        assert!((stroke.top_crank_angle - turn).abs() < 1e-12);
        assert!((stroke.bottom_crank_angle + turn).abs() < 1e-12);
        let ratio = stroke.quick_return_ratio();
        assert!((ratio - 1.3834).abs() < 1e-3, "ratio {ratio}");
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let g = Geometry::default();
        let h = 1e-6;
        for i in 0..72 {
            let q = -PI + i as f64 * TAU / 72.0 + 0.01;
            let (lo, hi) = (g.pose(q - h), g.pose(q + h));
            let j = g.jacobian(q);
            let fd = |a: f64, b: f64| (b - a) / (2.0 * h);
            assert!((j.ram - fd(lo.ram_position, hi.ram_position)).abs() < 1e-7);
            assert!((j.slot_distance - fd(lo.slot_distance, hi.slot_distance)).abs() < 1e-7);
            assert!((j.slot_angle - fd(lo.slot_angle, hi.slot_angle)).abs() < 1e-7);
            assert!((j.coupler_angle - fd(lo.coupler_angle, hi.coupler_angle)).abs() < 1e-7);
            assert_eq!(
                j.extended(),
                [1.0, j.slot_distance, j.slot_angle, j.coupler_angle, j.ram]
            );
        }
    }

    #[test]
    fn loop_closes_at_every_crank_angle() {
        let g = Geometry::default();
        for i in 0..360 {
            let p = g.pose(i as f64 * TAU / 360.0);
            let coupler = (p.ram_pin[0] - p.coupler_pin[0]).hypot(p.ram_pin[1] - p.coupler_pin[1]);
            assert!((coupler - g.coupler_length).abs() < 1e-12);
            let on_slot = (p.crank_pin[1] - g.slot_pivot[1]) * p.slot_angle.cos()
                - (p.crank_pin[0] - g.slot_pivot[0]) * p.slot_angle.sin();
            assert!(on_slot.abs() < 1e-12);
        }
    }

    #[test]
    fn singular_angles_are_the_only_zeros_of_the_jacobian() {
        let g = Geometry::default();
        let stroke = g.stroke().unwrap();
        // Cutting runs clockwise from the top: ρ_y > 0 there (q falls, y falls).
        let mid_cut = stroke.top_crank_angle - 0.5 * stroke.cutting_crank_travel();
        assert!(g.ram_jacobian(mid_cut) > 0.0);
        assert!(g.ram_jacobian(mid_cut + PI) < 0.0);
    }

    #[test]
    fn bad_geometries_are_rejected() {
        let mut g = Geometry {
            crank_length: 0.1,
            ..Geometry::default()
        };
        assert!(matches!(
            g.validate(),
            Err(GeometryError::CrankCannotTurn { .. })
        ));
        g = Geometry {
            coupler_length: 0.2,
            ..Geometry::default()
        };
        assert!(matches!(
            g.validate(),
            Err(GeometryError::CouplerTooShort { .. })
        ));
        g = Geometry {
            coupler_pin_radius: 0.0,
            ..Geometry::default()
        };
        assert_eq!(
            g.validate(),
            Err(GeometryError::NonPositive("coupler_pin_radius"))
        );
    }
}
