//! The inverted Whitworth quick-return shaper: crank angle and ram motion as the machine's own
//! signals, checked every step against the closed-form kinematics of `models::whitworth`.

use super::{joint, link, Machine, MachineError};
use crate::mechanism::Mechanism;
use crate::physics::MechanismState;
use models::whitworth::Geometry;
use serde::Deserialize;

/// The `[process]` table of a Whitworth scenario.
#[derive(Debug, Clone, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
struct ProcessParams {
    /// Linkage dimensions for the analytic check; they must describe the URDF.
    geometry: Option<Geometry>,
}

pub struct Whitworth {
    geometry: Geometry,
    crank_joint: usize,
    ram_link: usize,
    /// Crank angle at zero joint coordinate: the crank joint's origin angle on the ground.
    crank_zero: f64,
    ram_model_error_max: f64,
    ram_highest: f64,
    ram_lowest: f64,
    crank_start: Option<f64>,
    crank_angle: f64,
}

impl Whitworth {
    pub fn new(mechanism: &Mechanism, process: &toml::Table) -> Result<Self, MachineError> {
        let params: ProcessParams = process.clone().try_into().map_err(|e: toml::de::Error| {
            MachineError::BadParameters {
                machine: "whitworth".into(),
                reason: e.message().to_string(),
            }
        })?;
        let geometry = params.geometry.unwrap_or_default();
        geometry
            .validate()
            .map_err(|e| MachineError::BadParameters {
                machine: "whitworth".into(),
                reason: e.to_string(),
            })?;
        let crank_joint = joint("whitworth", mechanism, "crank")?;
        Ok(Self {
            geometry,
            crank_joint,
            ram_link: link("whitworth", mechanism, "ram")?,
            crank_zero: mechanism.joints[crank_joint].origin.angle,
            ram_model_error_max: 0.0,
            ram_highest: f64::NEG_INFINITY,
            ram_lowest: f64::INFINITY,
            crank_start: None,
            crank_angle: 0.0,
        })
    }
}

impl Machine for Whitworth {
    fn signal_names(&self) -> Vec<String> {
        ["crank_angle", "ram_position", "ram_velocity"]
            .map(String::from)
            .to_vec()
    }

    fn diagnostic_names(&self) -> Vec<String> {
        vec!["ram_model_error".into()]
    }

    fn measure(
        &mut self,
        _time: f64,
        state: &MechanismState,
        signals: &mut [f64],
        diagnostics: &mut [f64],
    ) {
        self.crank_angle = self.crank_zero + state.joint_positions[self.crank_joint];
        let ram_position = state.link_poses[self.ram_link].y;
        let model_error = ram_position - self.geometry.ram_position(self.crank_angle);
        signals.copy_from_slice(&[
            self.crank_angle,
            ram_position,
            state.link_velocities[self.ram_link][1],
        ]);
        diagnostics[0] = model_error;
        self.ram_model_error_max = self.ram_model_error_max.max(model_error.abs());
        self.ram_highest = self.ram_highest.max(ram_position);
        self.ram_lowest = self.ram_lowest.min(ram_position);
        self.crank_start.get_or_insert(self.crank_angle);
    }

    fn metrics(&self) -> Vec<(String, f64)> {
        let turns = (self.crank_angle - self.crank_start.unwrap_or(self.crank_angle))
            / std::f64::consts::TAU;
        vec![
            ("ram_model_error_max".into(), self.ram_model_error_max),
            ("ram_stroke".into(), self.ram_highest - self.ram_lowest),
            ("crank_turns".into(), turns),
        ]
    }
}
