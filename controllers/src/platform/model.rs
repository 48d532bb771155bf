//! The two-wheeled platform as its controllers model it: kinematics of point H, encoder odometry
//! and the inertia matrix M* in wheel-rate coordinates.
//!
//! **Kinematics.** A is the midpoint of the driving axle, β the heading, r the wheel radius, b half
//! the track, H a point d ahead of A. Rolling without slip (the non-holonomic constraints: no
//! sideways motion of A, each wheel's rim speed equals its contact's speed) gives, with the
//! wheel rates φ̇_L, φ̇_R,
//!
//! ```text
//! v = r (φ̇_R + φ̇_L)/2,   ω = β̇ = r (φ̇_R − φ̇_L)/(2b),
//! ẋ_H = v cos β − d ω sin β,   ẏ_H = v sin β + d ω cos β.
//! ```
//!
//! For d ≠ 0 the map (v, ω) → (ẋ_H, ẏ_H) is invertible: `v = ẋ_H cos β + ẏ_H sin β`,
//! `ω = (−ẋ_H sin β + ẏ_H cos β)/d` — the inverse kinematics that turns velocities of H into wheel
//! rates.
//!
//! **M\*.** Take the wheel rates q̇ = (φ̇_L, φ̇_R) as the generalised velocities (the constraints
//! eliminate ẋ_A, ẏ_A and β̇). The platform of mass m has its centre of mass c ahead of A and the
//! yaw inertia I_c about it; each wheel spins with J_w (wheel and reflected rotor, N²·J_m). The
//! centre of mass moves with v along the heading and c·ω across it, so the kinetic energy is
//!
//! ```text
//! T = ½ m (v² + c²ω²) + ½ I_c ω² + ½ J_w (φ̇_L² + φ̇_R²) = ½ m v² + ½ I_A ω² + ½ J_w (φ̇_L² + φ̇_R²),
//! ```
//!
//! with I_A = I_c + m c² the yaw inertia about A. Substituting the constraints, T = ½ q̇ᵀ M* q̇
//! with
//!
//! ```text
//! M*_LL = M*_RR = m r²/4 + I_A r²/(4b²) + J_w,   M*_LR = M*_RL = m r²/4 − I_A r²/(4b²).
//! ```
//!
//! Lagrange's equations with the constraints (equivalently Appell's, or projecting Newton–Euler
//! onto the two admissible motions) give `M* q̈ + L* q̇ + g(q̇) = τ`, where L* is the wheels'
//! viscous friction and `g` the velocity-product terms `± m c r² ω v/(2b)`; for c = 0 they vanish,
//! and over one sampling interval the controllers treat them as frozen (the paper's assumption
//! that motion parameters do not change within Δt).

use crate::check::{non_negative, positive};
use framework::ControllerError;
use serde::Deserialize;

/// The platform's geometry and mass data as the controller assumes them (SI). Defaults describe
/// `urdf/platform.urdf` with its default motors.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlatformModel {
    /// r, m.
    pub wheel_radius: f64,
    /// b: half the distance between the wheels' contacts, m.
    pub half_track: f64,
    /// d: point H ahead of the axle midpoint A, m.
    pub point_h: f64,
    /// m: everything the wheels carry, kg.
    pub mass: f64,
    /// I_A: yaw inertia about A, kg·m².
    pub yaw_inertia: f64,
    /// J_w: spin inertia of one wheel with its reflected rotor, kg·m².
    pub wheel_inertia: f64,
}

impl Default for PlatformModel {
    fn default() -> Self {
        Self {
            wheel_radius: 0.04,
            half_track: 0.1,
            point_h: 0.1,
            mass: 2.92,
            yaw_inertia: 0.0365,
            wheel_inertia: 1.18e-3,
        }
    }
}

impl PlatformModel {
    /// Checks the values as the `model` table of `controller`'s parameters: all finite, the
    /// wheel inertia ≥ 0 and the rest > 0.
    pub fn validate(&self, controller: &str) -> Result<(), ControllerError> {
        for (name, value) in [
            ("wheel_radius", self.wheel_radius),
            ("half_track", self.half_track),
            ("point_h", self.point_h),
            ("mass", self.mass),
            ("yaw_inertia", self.yaw_inertia),
        ] {
            positive(controller, &format!("model.{name}"), value)?;
        }
        non_negative(controller, "model.wheel_inertia", self.wheel_inertia)?;
        Ok(())
    }

    /// M* in wheel-rate coordinates (left, right), kg·m².
    pub fn inertia_matrix(&self) -> [[f64; 2]; 2] {
        let (r, b) = (self.wheel_radius, self.half_track);
        let translation = self.mass * r * r / 4.0;
        let rotation = self.yaw_inertia * r * r / (4.0 * b * b);
        let diagonal = translation + rotation + self.wheel_inertia;
        let coupling = translation - rotation;
        [[diagonal, coupling], [coupling, diagonal]]
    }

    /// (v, ω) of the platform from the wheel rates (left, right).
    pub fn body_rates(&self, wheel_rates: [f64; 2]) -> [f64; 2] {
        let r = self.wheel_radius;
        [
            r * (wheel_rates[1] + wheel_rates[0]) / 2.0,
            r * (wheel_rates[1] - wheel_rates[0]) / (2.0 * self.half_track),
        ]
    }

    /// (v, ω) that move H with `velocity_h` at heading `heading`.
    pub fn body_rates_for_h(&self, velocity_h: [f64; 2], heading: f64) -> [f64; 2] {
        let (s, c) = heading.sin_cos();
        [
            c * velocity_h[0] + s * velocity_h[1],
            (-s * velocity_h[0] + c * velocity_h[1]) / self.point_h,
        ]
    }

    /// Wheel rates (left, right) for (v, ω).
    pub fn wheel_rates(&self, body_rates: [f64; 2]) -> [f64; 2] {
        let [v, omega] = body_rates;
        let r = self.wheel_radius;
        [
            (v - self.half_track * omega) / r,
            (v + self.half_track * omega) / r,
        ]
    }
}

/// Dead reckoning from the wheel encoders: the pose of A and of H.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Odometry {
    /// x_A, y_A (m), β (rad).
    pub pose: [f64; 3],
    last_angles: Option<[f64; 2]>,
}

impl Odometry {
    /// Starts from H at `position_h` with heading `heading`; the next reading is the reference.
    pub fn start(&mut self, model: &PlatformModel, position_h: [f64; 2], heading: f64) {
        let (s, c) = heading.sin_cos();
        self.pose = [
            position_h[0] - model.point_h * c,
            position_h[1] - model.point_h * s,
            heading,
        ];
        self.last_angles = None;
    }

    /// Integrates the wheel angles (left, right; rad) read now, along the arc (mid-heading rule).
    pub fn update(&mut self, model: &PlatformModel, angles: [f64; 2]) {
        let last = self.last_angles.replace(angles).unwrap_or(angles);
        let [distance, turn] = model.body_rates([angles[0] - last[0], angles[1] - last[1]]);
        let mid = self.pose[2] + 0.5 * turn;
        self.pose[0] += distance * mid.cos();
        self.pose[1] += distance * mid.sin();
        self.pose[2] += turn;
    }

    /// Estimated position of H, m.
    pub fn point_h(&self, model: &PlatformModel) -> [f64; 2] {
        let (s, c) = self.pose[2].sin_cos();
        [
            self.pose[0] + model.point_h * c,
            self.pose[1] + model.point_h * s,
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_kinematics_round_trip() {
        let model = PlatformModel::default();
        let (heading, velocity_h) = (0.7, [0.08, -0.03]);
        let wheels = model.wheel_rates(model.body_rates_for_h(velocity_h, heading));
        let [v, omega] = model.body_rates(wheels);
        let (s, c) = f64::sin_cos(heading);
        let back = [
            v * c - model.point_h * omega * s,
            v * s + model.point_h * omega * c,
        ];
        assert!((back[0] - velocity_h[0]).abs() < 1e-15 && (back[1] - velocity_h[1]).abs() < 1e-15);
    }

    #[test]
    fn kinetic_energy_by_m_star_equals_the_bodies() {
        let model = PlatformModel::default();
        let rates = [1.3, 2.9];
        let m = model.inertia_matrix();
        let by_matrix = 0.5
            * (rates[0] * (m[0][0] * rates[0] + m[0][1] * rates[1])
                + rates[1] * (m[1][0] * rates[0] + m[1][1] * rates[1]));
        let [v, omega] = model.body_rates(rates);
        let by_bodies = 0.5 * model.mass * v * v
            + 0.5 * model.yaw_inertia * omega * omega
            + 0.5 * model.wheel_inertia * (rates[0] * rates[0] + rates[1] * rates[1]);
        assert!((by_matrix - by_bodies).abs() < 1e-15);
    }

    #[test]
    fn odometry_of_a_circle_closes() {
        let model = PlatformModel::default();
        let mut odometry = Odometry::default();
        odometry.start(&model, [model.point_h, 0.0], 0.0);
        // Constant wheel rates: a circle of radius v/ω; one full turn brings A back.
        let rates = model.wheel_rates([0.1, 0.5]);
        let steps = 10_000;
        let period = std::f64::consts::TAU / 0.5 / steps as f64;
        for k in 0..=steps {
            let t = k as f64 * period;
            odometry.update(&model, [rates[0] * t, rates[1] * t]);
        }
        assert!(odometry.pose[0].abs() < 1e-9 && odometry.pose[1].abs() < 1e-9);
        assert!((odometry.pose[2] - std::f64::consts::TAU).abs() < 1e-9);
    }
}
