//! What both platform controllers do before their law: read the wheel encoders, dead-reckon the
//! pose (the "incremental measurement"), form the correcting velocities of H (Kalinski et al.
//! 2013, Kaliński eq (19)) and turn desired plus correcting velocities of H into wheel rates by
//! inverse kinematics.
//!
//! Kaliński eq (19): `ẋ̂_H = (x̄_H − x_H)/(k·Δt)`, `ẏ̂_H = (ȳ_H − y_H)/(k·Δt)`, with x_H, y_H from
//! odometry (the controller never sees the true pose). The odometry starts at the path's first
//! point and heading (the platform is placed there).

use super::model::{Odometry, PlatformModel};
use framework::{ControllerError, Measurement, PlantInterface, SignalSpec, Unit};

/// Signals the platform controllers read.
const SIGNALS: [&str; 7] = [
    "left_wheel.position",
    "right_wheel.position",
    "path_x",
    "path_y",
    "path_vx",
    "path_vy",
    "path_heading",
];

/// One period's guidance: what the wheels should do and what they do.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Guidance {
    /// q̄̇ + q̂̇: wheel rates (left, right) for the path's and the correcting velocities, rad/s.
    pub wheel_rates_wanted: [f64; 2],
    /// q̇ from the encoders (backward difference over the period), rad/s.
    pub wheel_rates: [f64; 2],
}

/// Encoder odometry and Kaliński eq (19), bound to a plant.
#[derive(Debug, Clone)]
pub struct Guide {
    model: PlatformModel,
    /// k·Δt, s.
    correction_time: f64,
    signals: [usize; 7],
    odometry: Odometry,
    last_angles: Option<[f64; 2]>,
    correction: [f64; 2],
    tracking_error: f64,
}

impl Guide {
    /// A guide for the platform `model` with the correction time k·Δt, s, of Kaliński eq (19).
    pub fn new(model: PlatformModel, correction_time: f64) -> Self {
        Self {
            model,
            correction_time,
            signals: [0; 7],
            odometry: Odometry::default(),
            last_angles: None,
            correction: [0.0; 2],
            tracking_error: 0.0,
        }
    }

    /// Resolves the signals and forgets the past.
    pub fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        for (index, name) in self.signals.iter_mut().zip(SIGNALS) {
            *index = plant.signal(name)?;
        }
        self.odometry = Odometry::default();
        self.last_angles = None;
        self.correction = [0.0; 2];
        self.tracking_error = 0.0;
        Ok(())
    }

    /// One period: dead-reckons the pose from the wheel angles, forms the correcting velocities
    /// of H and returns the wheel rates wanted and measured.
    pub fn update(&mut self, measurement: &Measurement, period: f64) -> Guidance {
        let [left, right, x, y, vx, vy, heading] = self.signals.map(|i| measurement.get(i));
        let angles = [left, right];
        let wheel_rates = match self.last_angles {
            None => {
                self.odometry.start(&self.model, [x, y], heading);
                [0.0; 2]
            }
            Some(last) if period > 0.0 => [
                (angles[0] - last[0]) / period,
                (angles[1] - last[1]) / period,
            ],
            Some(_) => [0.0; 2],
        };
        self.last_angles = Some(angles);
        self.odometry.update(&self.model, angles);
        let h = self.odometry.point_h(&self.model);
        let error = [x - h[0], y - h[1]];
        self.tracking_error = error[0].hypot(error[1]);
        self.correction = error.map(|e| e / self.correction_time);
        let velocity_h = [vx + self.correction[0], vy + self.correction[1]];
        let body = self
            .model
            .body_rates_for_h(velocity_h, self.odometry.pose[2]);
        Guidance {
            wheel_rates_wanted: self.model.wheel_rates(body),
            wheel_rates,
        }
    }

    /// The platform model the guide works with.
    pub fn model(&self) -> &PlatformModel {
        &self.model
    }

    /// What [`values`](Self::values) are: the odometry's estimate of point h and heading (on
    /// the plots of the planned and true ones), its tracking error and the correction.
    pub fn internals() -> Vec<SignalSpec> {
        vec![
            SignalSpec::new("odometry.x_h", Unit::Metre, "point h x"),
            SignalSpec::new("odometry.y_h", Unit::Metre, "point h y"),
            SignalSpec::new("odometry.heading", Unit::Degree, "heading"),
            SignalSpec::new(
                "odometry.tracking_error",
                Unit::Millimetre,
                "tracking error",
            ),
            SignalSpec::new(
                "correction.vx_h",
                Unit::MillimetrePerSecond,
                "velocity correction",
            ),
            SignalSpec::new(
                "correction.vy_h",
                Unit::MillimetrePerSecond,
                "velocity correction",
            ),
        ]
    }

    /// The values of [`internals`](Self::internals) after the last update: x_H, y_H (m),
    /// heading (rad), tracking error (m), correcting velocities of H (m/s).
    pub fn values(&self) -> [f64; 6] {
        let h = self.odometry.point_h(&self.model);
        [
            h[0],
            h[1],
            self.odometry.pose[2],
            self.tracking_error,
            self.correction[0],
            self.correction[1],
        ]
    }
}

/// Torque limit of Kaliński eq (10) for both wheels: the smaller of the controller's and the
/// drive's.
pub fn wheel_actuators(
    plant: &PlantInterface,
    torque_limit: f64,
) -> Result<([usize; 2], f64), ControllerError> {
    let left = plant.actuator("left_wheel")?;
    let right = plant.actuator("right_wheel")?;
    let limit = torque_limit
        .min(plant.actuators[left].effort_limit)
        .min(plant.actuators[right].effort_limit);
    Ok(([left, right], limit))
}
