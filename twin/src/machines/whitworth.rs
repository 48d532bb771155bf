//! The inverted Whitworth quick-return shaper: crank angle and ram motion as the machine's own
//! signals, checked every step against the closed-form kinematics of `models::whitworth`; with a
//! `[process.workpiece]`, the cutting process of [`cutting`] (contact force and cutting figures).

mod cutting;

use super::error::MachineError;
use super::machine::Machine;
use super::parts::{joint, link, process_params};
use super::points::LinkPoint;
use crate::mechanism::Mechanism;
use crate::physics::{Load, MechanismState, NO_DAMPING, NO_STIFFNESS};
use crate::scene::{colors, Bounds, Drawing, Marker, MarkerSource, Scene};
use cutting::{Cutting, Workpiece};
use framework::{SignalSpec, Unit};
use models::whitworth::Geometry;
use serde::Deserialize;

/// The `[process]` table of a Whitworth scenario.
#[derive(Debug, Clone, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
struct ProcessParams {
    /// Linkage dimensions for the analytic check; they must describe the URDF.
    geometry: Option<Geometry>,
    /// The workpiece under the ram; absent: the shaper runs idle.
    workpiece: Option<Workpiece>,
}

pub struct Whitworth {
    geometry: Geometry,
    crank_joint: usize,
    /// The ram, `ram_position` and `ram_velocity` (its origin's y).
    ram: LinkPoint,
    /// Crank angle at zero joint coordinate: the crank joint's origin angle on the ground.
    crank_zero: f64,
    ram_model_error_max: f64,
    ram_velocity_error_max: f64,
    ram_speed_max: f64,
    ram_highest: f64,
    ram_lowest: f64,
    crank_start: Option<f64>,
    crank_angle: f64,
    /// Last sign of the crank speed outside the dead band, and how often it changed.
    crank_direction: Option<f64>,
    crank_reversals: usize,
    cutting: Option<Cutting>,
    contact_force: f64,
    /// Process-fault factor on the contact force (1: none).
    process_factor: f64,
}

/// Dead band on the crank speed when counting reversals, rad/s.
const CRANK_SPEED_DEAD_BAND: f64 = 0.05;

impl Whitworth {
    pub fn new(mechanism: &Mechanism, process: &toml::Table) -> Result<Self, MachineError> {
        let params: ProcessParams = process_params("whitworth", process)?;
        let geometry = params.geometry.unwrap_or_default();
        geometry
            .validate()
            .map_err(|e| MachineError::BadParameters {
                machine: "whitworth".into(),
                reason: e.to_string(),
            })?;
        let crank_joint = joint("whitworth", mechanism, "crank")?;
        let cutting = params
            .workpiece
            .map(|w| Cutting::new(&geometry, w))
            .transpose()
            .map_err(|reason| MachineError::BadParameters {
                machine: "whitworth".into(),
                reason,
            })?;
        Ok(Self {
            geometry,
            crank_joint,
            ram: LinkPoint::origin(link("whitworth", mechanism, "ram")?),
            crank_zero: mechanism.joints[crank_joint].origin.angle,
            ram_model_error_max: 0.0,
            ram_velocity_error_max: 0.0,
            ram_speed_max: 0.0,
            ram_highest: f64::NEG_INFINITY,
            ram_lowest: f64::INFINITY,
            crank_start: None,
            crank_angle: 0.0,
            crank_direction: None,
            crank_reversals: 0,
            cutting,
            contact_force: 0.0,
            process_factor: 1.0,
        })
    }
}

impl Machine for Whitworth {
    fn signals(&self) -> Vec<SignalSpec> {
        vec![
            SignalSpec::new("crank_angle", Unit::DegreeWrapped, "crank angle"),
            SignalSpec::new("ram_position", Unit::Millimetre, "ram position"),
            SignalSpec::new("ram_velocity", Unit::MetrePerSecond, "ram velocity"),
        ]
    }

    fn diagnostics(&self) -> Vec<SignalSpec> {
        let mut specs = vec![
            SignalSpec::new("ram_model_error", Unit::Micrometre, "ram model error"),
            SignalSpec::new(
                "ram_velocity_model_error",
                Unit::MillimetrePerSecond,
                "ram velocity model error",
            ),
        ];
        if self.cutting.is_some() {
            specs.push(SignalSpec::new(
                "contact_force",
                Unit::Newton,
                "contact force",
            ));
        }
        specs
    }

    fn reference(&self) -> Option<[SignalSpec; 3]> {
        Some([
            SignalSpec::new("reference", Unit::Millimetre, "ram position"),
            SignalSpec::new("reference_rate", Unit::MetrePerSecond, "ram velocity"),
            SignalSpec::new(
                "reference_acceleration",
                Unit::MetrePerSecondSquared,
                "ram acceleration",
            ),
        ])
    }

    fn scene(&self) -> Scene {
        scene(&self.geometry, self.cutting.as_ref().map(Cutting::zone))
    }

    fn measure(
        &mut self,
        time: f64,
        state: &MechanismState,
        signals: &mut [f64],
        diagnostics: &mut [f64],
    ) {
        self.crank_angle = self.crank_zero + state.joint_positions[self.crank_joint];
        let ([_, ram_position], [_, ram_velocity]) = self.ram.locate(state);
        let crank_speed = state.joint_velocities[self.crank_joint];
        let model_error = ram_position - self.geometry.ram_position(self.crank_angle);
        // The closed-form J(q)·q̇ of the same end-of-step state.
        let velocity_error =
            ram_velocity - self.geometry.ram_jacobian(self.crank_angle) * crank_speed;
        signals.copy_from_slice(&[self.crank_angle, ram_position, ram_velocity]);
        diagnostics[0] = model_error;
        diagnostics[1] = velocity_error;
        if let Some(cutting) = self.cutting.as_mut() {
            self.contact_force =
                self.process_factor * cutting.contact_force(ram_position, ram_velocity);
            diagnostics[2] = self.contact_force;
            cutting.observe(time, ram_position, ram_velocity);
        }
        if crank_speed.abs() > CRANK_SPEED_DEAD_BAND {
            let direction = crank_speed.signum();
            if self.crank_direction.is_some_and(|d| d != direction) {
                self.crank_reversals += 1;
            }
            self.crank_direction = Some(direction);
        }
        self.ram_model_error_max = self.ram_model_error_max.max(model_error.abs());
        self.ram_velocity_error_max = self.ram_velocity_error_max.max(velocity_error.abs());
        self.ram_speed_max = self.ram_speed_max.max(ram_velocity.abs());
        self.ram_highest = self.ram_highest.max(ram_position);
        self.ram_lowest = self.ram_lowest.min(ram_position);
        self.crank_start.get_or_insert(self.crank_angle);
    }

    fn set_process_factor(&mut self, factor: f64) -> bool {
        self.process_factor = factor;
        self.cutting.is_some()
    }

    fn loads(&mut self, _time: f64, state: &MechanismState, loads: &mut Vec<Load>) {
        if self.contact_force != 0.0 {
            let ram = self.ram.position(state);
            loads.push(Load {
                link: self.ram.link,
                force: [0.0, self.contact_force],
                point: ram,
                damping: NO_DAMPING,
                stiffness: NO_STIFFNESS,
            });
        }
    }

    fn metrics(&self) -> Vec<(String, f64)> {
        let turns = (self.crank_angle - self.crank_start.unwrap_or(self.crank_angle))
            / std::f64::consts::TAU;
        let mut metrics = vec![
            ("ram_model_error_max".into(), self.ram_model_error_max),
            // |ram_velocity − J(q)·q̇| at its largest, over the largest ram speed.
            (
                "ram_velocity_error_relative_max".into(),
                self.ram_velocity_error_max / self.ram_speed_max.max(f64::MIN_POSITIVE),
            ),
            ("ram_stroke".into(), self.ram_highest - self.ram_lowest),
            ("crank_turns".into(), turns),
            ("crank_reversals".into(), self.crank_reversals as f64),
        ];
        if let Some(cutting) = &self.cutting {
            metrics.extend(cutting.metrics());
        }
        metrics
    }
}

/// The shaper's view: framed on everything the linkage sweeps in a crank turn (crank circle,
/// slotted link, ram stroke), with the workpiece's cut zone beside the ram guide and the tool at
/// the ram.
fn scene(geometry: &Geometry, zone: Option<[f64; 2]>) -> Scene {
    const TURN_SAMPLES: usize = 144;
    /// How far the slotted link's outline reaches from its pivot, m (the URDF's).
    const SLOTTED_LINK_REACH: f64 = 0.7;
    let pivot = geometry.slot_pivot;
    let mut swept = Vec::with_capacity(3 * TURN_SAMPLES);
    for i in 0..TURN_SAMPLES {
        let angle = std::f64::consts::TAU * i as f64 / TURN_SAMPLES as f64;
        let pin = [
            geometry.crank_length * angle.cos(),
            geometry.crank_length * angle.sin(),
        ];
        let (dx, dy) = (pin[0] - pivot[0], pin[1] - pivot[1]);
        let reach = SLOTTED_LINK_REACH / dx.hypot(dy).max(1e-12);
        swept.push(pin);
        swept.push([pivot[0] + reach * dx, pivot[1] + reach * dy]);
        swept.push([geometry.guide_x, geometry.ram_position(angle)]);
    }
    let bounds = Bounds::around(swept, 0.06).unwrap_or(Bounds {
        x: [-1.0, 1.0],
        y: [-1.0, 1.0],
    });
    let drawings = zone
        .map(|[entry, exit]| {
            let (x0, x1) = (geometry.guide_x + 0.03, geometry.guide_x + 0.12);
            let (y0, y1) = (entry.min(exit), entry.max(exit));
            vec![Drawing {
                name: "workpiece".into(),
                color: colors::WORKPIECE,
                lines: vec![vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1], [x0, y0]]],
                label: "workpiece (cut zone)".into(),
            }]
        })
        .unwrap_or_default();
    Scene {
        title: "shaper (m, y up)".into(),
        bounds,
        drawings,
        markers: vec![Marker {
            name: "tool".into(),
            color: colors::TOOL,
            label: "tool".into(),
            source: MarkerSource {
                x: None,
                y: Some("ram_position".into()),
                scale: 1.0,
                origin: [geometry.guide_x, 0.0],
            },
            trace: false,
        }],
    }
}
