//! Constant-cutting-velocity reference of the Whitworth paper (Perrusquía et al. 2022, §4,
//! Algorithm 1, Perrusquía eqs (2)–(5)): a trapezoidal velocity profile with parabolic position
//! blends over the cutting stroke, from the stroke end where cutting starts (`x_min`) to the one
//! where it ends (`x_max`).
//!
//! The stroke is covered in three phases:
//! 1. blend, `0 ≤ t < t_a`: constant acceleration `v/t_a` from rest at `x_min`, reaching `v` at
//!    `x_a` (Perrusquía eq (4): `x_a = x_min + (v/2t_a)·t_a²`);
//! 2. cut, `t_a ≤ t < t_a + t_c`: constant velocity `v` from `x_a` to `x_b` (Perrusquía eq (5)),
//!    over the workpiece length `L_d = |x_b − x_a|` in `t_c = L_d/|v|` (Perrusquía eq (2));
//! 3. blend, `t_d = t_a` long, decelerating back to rest.
//!
//! Consistency: each blend covers `|v|·t_a/2`, so the whole profile covers
//! `|v|·(t_c + t_a) = L_c` with `t_a = L_c/|v| − t_c` (Perrusquía eq (3)) — it ends exactly on `x_max` at
//! `t_a + t_c + t_d`. Equivalently `t_a = (L_c − L_d)/|v|` and each blend is `(L_c − L_d)/2` long,
//! whatever `v` is. The paper defines `L_c = x_max − x_min`; it is used here as the unsigned
//! length `|x_max − x_min|`, the direction of travel being the sign of `x_max − x_min`, which
//! `v` must share (the twin's cutting stroke runs downward, so there `v < 0`).
//!
//! The paper's worked example (§6.2: `L_d = 0.3 m`, `L_c = 0.4667 m`, `v = −1.25 m/s`,
//! `y_min = 0.05428 m`) prints `t_c = 0.3937 s`, `t_a = 0.2187 s`. Perrusquía eqs (2)–(3) give
//! `t_c = 0.24 s`, `t_a = 0.13336 s`; the printed times are what the same equations give for
//! `|v| ≈ 0.762 m/s` (= 0.3/0.3937). Its `y_a = −0.0291 m`, `y_b = −0.3291 m` agree with Perrusquía eqs (4)–(5)
//! (`−0.02907`, `−0.32907`), which do not depend on `|v|`. The equations are implemented as
//! written.

use serde::Deserialize;
use thiserror::Error;

/// Inputs of Algorithm 1 (SI units).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProfileParams {
    /// Stroke end where the cutting stroke starts (the paper's `x_min`, a singular point), m.
    pub x_min: f64,
    /// Stroke end where the cutting stroke ends (the paper's `x_max`), m.
    pub x_max: f64,
    /// Workpiece length `L_d`, m.
    pub workpiece_length: f64,
    /// Cutting velocity `v`, m/s, signed along the stroke (`x_min → x_max`).
    pub velocity: f64,
}

/// Why the profile parameters are rejected.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ProfileError {
    /// A [`ProfileParams`] field is infinite or NaN.
    #[error("velocity profile parameter {name} is not finite ({value})")]
    NonFinite {
        /// The field's name.
        name: &'static str,
        /// The rejected value, m or m/s.
        value: f64,
    },
    /// `x_min` equals `x_max`, so there is no stroke to cut.
    #[error("stroke ends coincide (x_min = x_max = {x}): no stroke to cut")]
    ZeroStroke {
        /// The common stroke end, m.
        x: f64,
    },
    /// The workpiece length `L_d` is zero or negative.
    #[error("workpiece length must be > 0, got {length} m")]
    NonPositiveWorkpiece {
        /// The rejected `L_d`, m.
        length: f64,
    },
    /// The cutting velocity `v` is zero.
    #[error("cutting velocity must be non-zero")]
    ZeroVelocity,
    /// The sign of `v` is not the direction from `x_min` to `x_max`.
    #[error("cutting velocity {velocity} m/s points against the stroke (x_min → x_max runs {direction})")]
    WrongDirection {
        /// The rejected `v`, m/s.
        velocity: f64,
        /// The stroke's direction in words: `upward (+)` or `downward (−)`.
        direction: &'static str,
    },
    /// The workpiece is not shorter than the stroke, which leaves no room for the blends.
    #[error("workpiece ({workpiece} m) must be shorter than the stroke L_c = {stroke} m")]
    WorkpieceTooLong {
        /// Workpiece length `L_d`, m.
        workpiece: f64,
        /// Stroke length `L_c`, m.
        stroke: f64,
    },
    /// The speed is so extreme that the blend time or its acceleration is not a usable number
    /// (floating-point underflow or overflow).
    #[error("cutting speed {velocity} m/s leaves no usable blend (t_a = {t_a:e} s, blend acceleration {acceleration:e} m/s²)")]
    DegenerateBlend {
        /// Cutting velocity `v`, m/s.
        velocity: f64,
        /// Blend time `t_a` it gives, s.
        t_a: f64,
        /// Blend acceleration `v/t_a` it gives, m/s².
        acceleration: f64,
    },
}

/// Reference sample `z_d = [x_d, ẋ_d]` plus `ẍ_d`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProfileSample {
    /// `x_d`, m.
    pub position: f64,
    /// `ẋ_d`, m/s.
    pub velocity: f64,
    /// `ẍ_d`, m/s² (piecewise constant; jumps at the blend joins).
    pub acceleration: f64,
}

impl ProfileSample {
    /// `z_d = [x_d, ẋ_d]` as in the paper's error `e = z_d − z` (Perrusquía eq (12)).
    pub fn z(&self) -> [f64; 2] {
        [self.position, self.velocity]
    }
}

/// The outputs of Algorithm 1 and the reference they define.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VelocityProfile {
    x_min: f64,
    x_max: f64,
    velocity: f64,
    stroke_length: f64,
    t_c: f64,
    t_a: f64,
    x_a: f64,
    x_b: f64,
    blend_acceleration: f64,
}

impl VelocityProfile {
    /// Runs Algorithm 1 steps 3–4 after validating the inputs.
    pub fn new(params: &ProfileParams) -> Result<Self, ProfileError> {
        let ProfileParams {
            x_min,
            x_max,
            workpiece_length,
            velocity,
        } = *params;
        for (name, value) in [
            ("x_min", x_min),
            ("x_max", x_max),
            ("workpiece_length", workpiece_length),
            ("velocity", velocity),
        ] {
            if !value.is_finite() {
                return Err(ProfileError::NonFinite { name, value });
            }
        }
        if x_min == x_max {
            return Err(ProfileError::ZeroStroke { x: x_min });
        }
        if workpiece_length <= 0.0 {
            return Err(ProfileError::NonPositiveWorkpiece {
                length: workpiece_length,
            });
        }
        if velocity == 0.0 {
            return Err(ProfileError::ZeroVelocity);
        }
        let direction = (x_max - x_min).signum();
        if velocity.signum() != direction {
            return Err(ProfileError::WrongDirection {
                velocity,
                direction: if direction > 0.0 {
                    "upward (+)"
                } else {
                    "downward (−)"
                },
            });
        }
        let stroke_length = (x_max - x_min).abs();
        if workpiece_length >= stroke_length {
            return Err(ProfileError::WorkpieceTooLong {
                workpiece: workpiece_length,
                stroke: stroke_length,
            });
        }
        let speed = velocity.abs();
        // Perrusquía eq (2).
        let t_c = workpiece_length / speed;
        // Perrusquía eq (3); positive whenever L_d < L_c, so only an absurd speed (floating-point
        // underflow/overflow) can make the blend degenerate.
        let t_a = stroke_length / speed - t_c;
        let blend_acceleration = velocity / t_a;
        if t_a <= 0.0 || !blend_acceleration.is_finite() {
            return Err(ProfileError::DegenerateBlend {
                velocity,
                t_a,
                acceleration: blend_acceleration,
            });
        }
        // Perrusquía eqs (4)–(5).
        let x_a = x_min + velocity / (2.0 * t_a) * t_a * t_a;
        let x_b = x_min + velocity / (2.0 * t_a) * t_a * t_a + velocity * t_c;
        Ok(Self {
            x_min,
            x_max,
            velocity,
            stroke_length,
            t_c,
            t_a,
            x_a,
            x_b,
            blend_acceleration,
        })
    }

    /// `x_min`, m: where the profile starts, at rest.
    pub fn x_min(&self) -> f64 {
        self.x_min
    }
    /// `x_max`, m: where the profile ends, at rest.
    pub fn x_max(&self) -> f64 {
        self.x_max
    }
    /// `v`, m/s.
    pub fn velocity(&self) -> f64 {
        self.velocity
    }
    /// `L_c = |x_max − x_min|`, m.
    pub fn stroke_length(&self) -> f64 {
        self.stroke_length
    }
    /// Cutting time `t_c` (Perrusquía eq (2)), s.
    pub fn t_c(&self) -> f64 {
        self.t_c
    }
    /// Acceleration blend time `t_a` (Perrusquía eq (3)), s.
    pub fn t_a(&self) -> f64 {
        self.t_a
    }
    /// Deceleration blend time `t_d = t_a` (Perrusquía eq (3)), s.
    pub fn t_d(&self) -> f64 {
        self.t_a
    }
    /// Start of the constant-velocity segment `x_a` (Perrusquía eq (4)), m.
    pub fn x_a(&self) -> f64 {
        self.x_a
    }
    /// End of the constant-velocity segment `x_b` (Perrusquía eq (5)), m.
    pub fn x_b(&self) -> f64 {
        self.x_b
    }
    /// Signed blend acceleration `v/t_a`, m/s².
    pub fn blend_acceleration(&self) -> f64 {
        self.blend_acceleration
    }
    /// Whole cutting stroke `t_a + t_c + t_d`, s.
    pub fn duration(&self) -> f64 {
        2.0 * self.t_a + self.t_c
    }

    /// The reference at `t` seconds after the cutting stroke starts. Before 0 it rests at
    /// `x_min`, after [`duration`](Self::duration) at `x_max`.
    pub fn sample(&self, t: f64) -> ProfileSample {
        let a = self.blend_acceleration;
        let cut_end = self.t_a + self.t_c;
        if t < 0.0 {
            rest(self.x_min)
        } else if t < self.t_a {
            ProfileSample {
                position: self.x_min + 0.5 * a * t * t,
                velocity: a * t,
                acceleration: a,
            }
        } else if t < cut_end {
            ProfileSample {
                position: self.x_a + self.velocity * (t - self.t_a),
                velocity: self.velocity,
                acceleration: 0.0,
            }
        } else if t < self.duration() {
            let tau = t - cut_end;
            ProfileSample {
                position: self.x_b + self.velocity * tau - 0.5 * a * tau * tau,
                velocity: self.velocity - a * tau,
                acceleration: -a,
            }
        } else {
            rest(self.x_max)
        }
    }
}

fn rest(position: f64) -> ProfileSample {
    ProfileSample {
        position,
        velocity: 0.0,
        acceleration: 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The twin's cutting stroke: ram from 0.05428 m down to −0.41242 m (L_c = 0.4667 m).
    fn twin() -> ProfileParams {
        ProfileParams {
            x_min: 0.05428,
            x_max: -0.41242,
            workpiece_length: 0.3,
            velocity: -1.25,
        }
    }

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn twin_numbers_match_hand_computation() {
        let p = VelocityProfile::new(&twin()).unwrap();
        // L_c = 0.05428 + 0.41242 = 0.4667; t_c = 0.3/1.25 = 0.24;
        // t_a = 0.4667/1.25 − 0.24 = 0.37336 − 0.24 = 0.13336;
        // x_a = 0.05428 − 1.25·0.13336/2 = 0.05428 − 0.08335 = −0.02907;
        // x_b = −0.02907 − 1.25·0.24 = −0.32907; a = −1.25/0.13336 = −9.37313…
        assert!(close(p.stroke_length(), 0.4667, 1e-12));
        assert!(close(p.t_c(), 0.24, 1e-12));
        assert!(close(p.t_a(), 0.13336, 1e-12));
        assert_eq!(p.t_a(), p.t_d());
        assert!(close(p.x_a(), -0.02907, 1e-12));
        assert!(close(p.x_b(), -0.32907, 1e-12));
        assert!(close(p.duration(), 0.50672, 1e-12));
        assert!(close(p.blend_acceleration(), -1.25 / 0.13336, 1e-9));
        // The paper's printed y_a, y_b (4 decimals) agree; its printed t_c = 0.3937 s does not.
        assert!(close(p.x_a(), -0.0291, 5e-5) && close(p.x_b(), -0.3291, 5e-5));
        assert!(!close(p.t_c(), 0.3937, 1e-3));
    }

    #[test]
    fn printed_times_correspond_to_a_slower_cut() {
        // Perrusquía eqs (2)–(3) with |v| = 0.3/0.3937 reproduce the paper's printed t_c and t_a.
        let slow = ProfileParams {
            velocity: -0.3 / 0.3937,
            ..twin()
        };
        let p = VelocityProfile::new(&slow).unwrap();
        assert!(close(p.t_c(), 0.3937, 1e-12));
        assert!(close(p.t_a(), 0.2187, 1e-4));
    }

    #[test]
    fn profile_is_continuous_and_lands_on_x_max() {
        for params in [
            twin(),
            ProfileParams {
                x_min: -0.2,
                x_max: 0.3,
                workpiece_length: 0.1,
                velocity: 0.4,
            },
        ] {
            let p = VelocityProfile::new(&params).unwrap();
            let eps = 1e-12;
            for join in [0.0, p.t_a(), p.t_a() + p.t_c(), p.duration()] {
                let (before, after) = (p.sample(join - eps), p.sample(join + eps));
                assert!(
                    close(before.position, after.position, 1e-10),
                    "x jumps at {join}"
                );
                assert!(
                    close(before.velocity, after.velocity, 1e-10),
                    "ẋ jumps at {join}"
                );
            }
            let at_a = p.sample(p.t_a());
            assert!(close(at_a.position, p.x_a(), 1e-12) && at_a.velocity == params.velocity);
            let at_b = p.sample(p.t_a() + p.t_c());
            assert!(close(at_b.position, p.x_b(), 1e-12) && at_b.velocity == params.velocity);
            let end = p.sample(p.duration() - 1e-15);
            assert!(
                close(end.position, params.x_max, 1e-12),
                "ends at {}",
                end.position
            );
            assert!(close(end.velocity, 0.0, 1e-12));
            assert_eq!(p.sample(-1.0).z(), [params.x_min, 0.0]);
            assert_eq!(p.sample(10.0).z(), [params.x_max, 0.0]);
            // ẋ_d integrates to x_d (midpoint rule is exact for the piecewise-linear ẋ_d).
            let steps = 20_000;
            let dt = p.duration() / steps as f64;
            let mut x = params.x_min;
            for k in 0..steps {
                x += p.sample((k as f64 + 0.5) * dt).velocity * dt;
            }
            assert!(close(x, params.x_max, 1e-9), "∫ẋ_d = {x}");
        }
    }

    #[test]
    fn rejects_bad_parameters() {
        let err = |params: ProfileParams| VelocityProfile::new(&params).unwrap_err();
        assert!(matches!(
            err(ProfileParams {
                workpiece_length: 0.0,
                ..twin()
            }),
            ProfileError::NonPositiveWorkpiece { .. }
        ));
        assert!(matches!(
            err(ProfileParams {
                workpiece_length: -0.1,
                ..twin()
            }),
            ProfileError::NonPositiveWorkpiece { .. }
        ));
        assert_eq!(
            err(ProfileParams {
                velocity: 0.0,
                ..twin()
            }),
            ProfileError::ZeroVelocity
        );
        assert!(matches!(
            err(ProfileParams {
                velocity: 1.25,
                ..twin()
            }),
            ProfileError::WrongDirection { .. }
        ));
        assert!(matches!(
            err(ProfileParams {
                workpiece_length: 0.4667,
                ..twin()
            }),
            ProfileError::WorkpieceTooLong { .. }
        ));
        assert!(matches!(
            err(ProfileParams {
                workpiece_length: 0.5,
                ..twin()
            }),
            ProfileError::WorkpieceTooLong { .. }
        ));
        assert!(matches!(
            err(ProfileParams {
                velocity: -1e308,
                ..twin()
            }),
            ProfileError::DegenerateBlend { .. }
        ));
        assert!(matches!(
            err(ProfileParams {
                x_max: 0.05428,
                ..twin()
            }),
            ProfileError::ZeroStroke { .. }
        ));
        assert!(matches!(
            err(ProfileParams {
                velocity: f64::NAN,
                ..twin()
            }),
            ProfileError::NonFinite {
                name: "velocity",
                ..
            }
        ));
    }
}
