//! The two-wheeled mobile platform seen from above (Kalinski et al. 2013, §4): a chassis on a
//! planar base, two driven wheels and a swivel caster, each wheel a `<wheel>` of the URDF.
//!
//! Per physics step the machine
//! - drives each driven wheel through its DC gear motor ([`models::gear_motor`], with the
//!   rotor and gearbox of [`motor`]),
//! - integrates every wheel's spin (implicit in the tyre force, which is stiff at low speed),
//! - applies the tyre forces of `models::platform::tyre` at the contacts as loads on the wheels'
//!   links, with the static normal loads from the centre of mass and the contacts
//!   (`floor_gravity`).
//!
//! The controller measures the wheel encoders (`<wheel>.position`), the motor currents
//! (`<wheel>.current`) and the desired motion of point H from the path (`path_x`, `path_y`,
//! `path_vx`, `path_vy`, `path_heading`). The true pose of H (the "direct measurement") is recorded
//! as diagnostics only, with Δβ (heading against the desired motion's heading), the distance of H
//! from the path, and each wheel's slip.
//!
//! The desired heading β̄ is that of the desired motion: the heading the platform has when H moves
//! exactly along the path, `dβ̄/dt = (−sin β̄·ẋ̄_H + cos β̄·ẏ̄_H)/d` (d: H ahead of the axle),
//! integrated from the path's start heading. On a straight it settles on the path's heading.

mod motor;

use super::actuators::{key_of, kind_of, ActuatorKind, ActuatorSpecs};
use super::error::MachineError;
use super::machine::Machine;
use super::parts::{link, process_params};
use super::points::LinkPoint;
use crate::mechanism::{wrap_angle, Mechanism, Pose2};
use crate::physics::{Load, MechanismState, NO_DAMPING, NO_STIFFNESS};
use crate::scene::{colors, Bounds, Drawing, Marker, MarkerSource, Scene};
use framework::{Actuator, EffortKind};
use framework::{SignalSpec, Unit};
use models::gear_motor::GearMotor;
use models::platform::path::{Path, PathSpec};
use models::platform::tyre::{static_normal_loads, TyreParams};
use motor::MotorParams;
use serde::Deserialize;

/// The `[process]` table of a platform scenario.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct ProcessParams {
    /// The link the base carries.
    #[serde(default = "default_chassis")]
    chassis: String,
    /// Point H in the chassis frame, m.
    #[serde(default = "default_point_h")]
    point_h: [f64; 2],
    /// Gravity pressing the wheels on the floor, m/s² (the simulated plane is the floor).
    #[serde(default = "default_floor_gravity")]
    floor_gravity: f64,
    /// Tyre–floor μ for every wheel instead of the URDF's (a slippery floor).
    friction: Option<f64>,
    #[serde(default)]
    tyre: TyreParams,
    #[serde(default)]
    motor: MotorParams,
    path: PathSpec,
}

fn default_chassis() -> String {
    "chassis".into()
}

fn default_point_h() -> [f64; 2] {
    [0.1, 0.0]
}

fn default_floor_gravity() -> f64 {
    9.81
}

/// One wheel in operation.
struct WheelState {
    name: String,
    /// Where the tyre touches the floor: a point of the wheel's link.
    contact: LinkPoint,
    heading: [f64; 2],
    radius: f64,
    friction: f64,
    /// Spin inertia with the reflected rotor for a driven wheel, kg·m².
    inertia: f64,
    normal_load: f64,
    /// Index among the actuators, for a driven wheel.
    actuator: Option<usize>,
    motor: GearMotor,
    drive_torque: f64,
    spin: f64,
    angle: f64,
    slip: [f64; 2],
}

pub struct Platform {
    chassis: usize,
    point_h: [f64; 2],
    tyre: TyreParams,
    motor: MotorParams,
    path: Path,
    wheels: Vec<WheelState>,
    actuators: Vec<Actuator>,
    dt: f64,
    last_time: Option<f64>,
    desired_heading: f64,
    nearest_s: f64,
    figures: Figures,
}

/// Running figures of a run.
#[derive(Default)]
struct Figures {
    samples: usize,
    heading_error_max: f64,
    heading_error_square_sum: f64,
    heading_error: f64,
    path_error_max: f64,
    path_error_square_sum: f64,
    final_position_error: f64,
    slip_max: f64,
    current_max: f64,
    position_h: [f64; 2],
}

impl Platform {
    pub fn new(
        mechanism: &Mechanism,
        process: &toml::Table,
        actuators: &ActuatorSpecs,
    ) -> Result<Self, MachineError> {
        let params = checked_params(process)?;
        let chassis = link("platform", mechanism, &params.chassis)?;
        if mechanism
            .wheels
            .iter()
            .filter(|w| w.effort_limit.is_some())
            .count()
            != 2
        {
            return Err(bad(
                "the URDF must declare exactly two driven <wheel>s".into()
            ));
        }
        ideal_wheels_refused(mechanism, actuators)?;
        let poses = mechanism.zero_pose();
        let start_pose = poses[chassis];
        let start = start_pose.apply(params.point_h[0], params.point_h[1]);
        let path =
            Path::new(&params.path, start, start_pose.angle).map_err(|e| bad(e.to_string()))?;

        let loads = static_loads(mechanism, &poses, params.floor_gravity)?;
        let (actuators, wheels) = wheel_states(mechanism, loads, &params)?;
        Ok(Self {
            chassis,
            point_h: params.point_h,
            tyre: params.tyre,
            motor: params.motor,
            desired_heading: start_pose.angle,
            path,
            wheels,
            actuators,
            dt: 0.0,
            last_time: None,
            nearest_s: 0.0,
            figures: Figures::default(),
        })
    }

    fn driven(&self) -> impl Iterator<Item = &WheelState> {
        self.wheels.iter().filter(|w| w.actuator.is_some())
    }
}

/// A refusal of the platform's parameters.
fn bad(reason: String) -> MachineError {
    MachineError::BadParameters {
        machine: "platform".into(),
        reason,
    }
}

/// The `[process]` table, read and checked (tyre, motor, floor gravity, point H, friction).
fn checked_params(process: &toml::Table) -> Result<ProcessParams, MachineError> {
    let params: ProcessParams = process_params("platform", process)?;
    params.tyre.validate().map_err(|e| bad(e.to_string()))?;
    params.motor.validate().map_err(bad)?;
    // Up to 10 g: beyond that no tyre model here holds.
    if !(params.floor_gravity > 0.0 && params.floor_gravity <= 100.0) {
        return Err(bad(format!(
            "floor_gravity must be in (0, 100] m/s², got {}",
            params.floor_gravity
        )));
    }
    if params.point_h.iter().any(|v| !v.is_finite()) || params.point_h[0] <= 0.0 {
        return Err(bad(
            "point_h must be ahead of the axle (x > 0): otherwise H cannot be steered".into(),
        ));
    }
    if let Some(mu) = params.friction.filter(|mu| !(mu.is_finite() && *mu > 0.0)) {
        return Err(bad(format!("friction must be > 0, got {mu}")));
    }
    Ok(params)
}

/// Each wheel's static normal load, N: the mechanism's weight under `floor_gravity`, shared by
/// the wheel contacts at the zero pose `poses`.
fn static_loads(
    mechanism: &Mechanism,
    poses: &[Pose2],
    floor_gravity: f64,
) -> Result<Vec<f64>, MachineError> {
    let (mut mass, mut moment) = (0.0, [0.0, 0.0]);
    for (pose, link) in poses.iter().zip(&mechanism.links) {
        if let Some(inertial) = link.inertial {
            let [x, y] = pose.apply(inertial.centre_of_mass[0], inertial.centre_of_mass[1]);
            mass += inertial.mass;
            moment = [moment[0] + inertial.mass * x, moment[1] + inertial.mass * y];
        }
    }
    let contacts: Vec<[f64; 2]> = mechanism
        .wheels
        .iter()
        .map(|w| poses[w.link].apply(w.origin.x, w.origin.y))
        .collect();
    static_normal_loads(
        mass,
        [moment[0] / mass, moment[1] / mass],
        &contacts,
        floor_gravity,
    )
    .map_err(|e| bad(e.to_string()))
}

/// The wheels at rest, with an actuator (torque, up to the URDF's effort limit) per driven wheel.
fn wheel_states(
    mechanism: &Mechanism,
    loads: Vec<f64>,
    params: &ProcessParams,
) -> Result<(Vec<Actuator>, Vec<WheelState>), MachineError> {
    let motor = GearMotor::new(params.motor.gear_motor()).map_err(|e| bad(format!("motor.{e}")))?;
    let mut actuators = Vec::new();
    let mut wheels = Vec::new();
    for (wheel, normal_load) in mechanism.wheels.iter().zip(loads) {
        let actuator = wheel.effort_limit.map(|limit| {
            actuators.push(Actuator {
                joint: wheel.name.clone(),
                kind: EffortKind::Torque,
                effort_limit: limit,
            });
            actuators.len() - 1
        });
        let reflected = if actuator.is_some() {
            params.motor.reflected_inertia()
        } else {
            0.0
        };
        let [hx, hy] = wheel.heading();
        wheels.push(WheelState {
            name: wheel.name.clone(),
            contact: LinkPoint {
                link: wheel.link,
                at: [wheel.origin.x, wheel.origin.y],
            },
            heading: wheel.origin.rotate(hx, hy),
            radius: wheel.radius,
            friction: params.friction.unwrap_or(wheel.friction),
            inertia: wheel.spin_inertia + reflected,
            normal_load,
            actuator,
            motor,
            drive_torque: 0.0,
            spin: 0.0,
            angle: 0.0,
            slip: [0.0; 2],
        });
    }
    Ok((actuators, wheels))
}

/// The driven wheels are the platform's own actuators: their torque spins the wheel model (the
/// gear motor's reflected inertia and damping, the tyre), not a joint, so an ideal drive has
/// nothing to apply it to; `[process.motor]` sets the motor instead.
fn ideal_wheels_refused(
    mechanism: &Mechanism,
    actuators: &ActuatorSpecs,
) -> Result<(), MachineError> {
    let driven = mechanism.wheels.iter().filter(|w| w.effort_limit.is_some());
    for wheel in driven {
        if kind_of(actuators, &wheel.name) == ActuatorKind::Effort {
            return Err(MachineError::Actuator {
                key: key_of(actuators, &wheel.name),
                reason: format!(
                    "the platform's wheel `{}` is driven through the machine's own wheel model \
                     (gear motor and tyre), not a joint, so it cannot take an ideal drive; use \
                     kind = \"drive\" and set its motor in [process.motor]",
                    wheel.name
                ),
            });
        }
    }
    Ok(())
}

impl Machine for Platform {
    /// Only the wheel encoders are sensors: the planar base stands for the floor (the true pose,
    /// recorded as the "direct measurement") and the caster's swivel carries no encoder.
    fn unmeasured_joints(&self) -> Vec<String> {
        ["floor_x", "floor_y", "floor_yaw", "caster_swivel"]
            .map(String::from)
            .to_vec()
    }

    fn signals(&self) -> Vec<SignalSpec> {
        let mut specs: Vec<SignalSpec> = self
            .actuators
            .iter()
            .flat_map(|a| {
                [
                    SignalSpec::new(
                        format!("{}.position", a.joint),
                        Unit::DegreeWrapped,
                        "wheel angles",
                    ),
                    SignalSpec::new(
                        format!("{}.current", a.joint),
                        Unit::Ampere,
                        format!("{} current", a.joint),
                    ),
                ]
            })
            .collect();
        specs.extend([
            SignalSpec::new("path_x", Unit::Metre, "point h x"),
            SignalSpec::new("path_y", Unit::Metre, "point h y"),
            SignalSpec::new("path_vx", Unit::MillimetrePerSecond, "planned velocity"),
            SignalSpec::new("path_vy", Unit::MillimetrePerSecond, "planned velocity"),
            SignalSpec::new("path_heading", Unit::Degree, "heading"),
        ]);
        specs
    }

    fn diagnostics(&self) -> Vec<SignalSpec> {
        let mut specs = vec![
            SignalSpec::new("pose.x_h", Unit::Metre, "point h x"),
            SignalSpec::new("pose.y_h", Unit::Metre, "point h y"),
            SignalSpec::new("pose.heading", Unit::Degree, "heading"),
            SignalSpec::new("desired_heading", Unit::Degree, "heading"),
            SignalSpec::new("heading_error", Unit::Degree, "heading error"),
            SignalSpec::new("path_error", Unit::Millimetre, "tracking error"),
        ];
        for wheel in &self.wheels {
            specs.extend([
                SignalSpec::new(
                    format!("{}.longitudinal_slip", wheel.name),
                    Unit::Dimensionless,
                    "longitudinal slip",
                ),
                SignalSpec::new(
                    format!("{}.lateral_slip", wheel.name),
                    Unit::Dimensionless,
                    "lateral slip",
                ),
                SignalSpec::new(
                    format!("{}.spin_rate", wheel.name),
                    Unit::Rpm,
                    "wheel spin rates",
                ),
            ]);
        }
        specs
    }

    fn scene(&self) -> Scene {
        scene(&self.path)
    }

    fn extra_actuators(&self) -> Vec<Actuator> {
        self.actuators.clone()
    }

    fn measure(
        &mut self,
        time: f64,
        state: &MechanismState,
        signals: &mut [f64],
        diagnostics: &mut [f64],
    ) {
        let chassis = state.link_poses[self.chassis];
        let h = chassis.apply(self.point_h[0], self.point_h[1]);
        let desired = self.path.sample(time);
        let step = time - self.last_time.unwrap_or(time);
        self.last_time = Some(time);
        let (s, c) = self.desired_heading.sin_cos();
        self.desired_heading +=
            step * (-s * desired.velocity[0] + c * desired.velocity[1]) / self.point_h[0];

        let mut k = 0;
        for wheel in self.driven() {
            signals[k] = wheel.angle;
            signals[k + 1] = wheel.motor.current();
            k += 2;
        }
        signals[k..].copy_from_slice(&[
            desired.point.position[0],
            desired.point.position[1],
            desired.velocity[0],
            desired.velocity[1],
            desired.point.heading,
        ]);

        let heading_error = wrap_angle(chassis.angle - self.desired_heading);
        let (nearest, path_error) = self.path.nearest(h, self.nearest_s);
        self.nearest_s = nearest;
        diagnostics[..6].copy_from_slice(&[
            h[0],
            h[1],
            chassis.angle,
            self.desired_heading,
            heading_error,
            path_error,
        ]);
        for (w, wheel) in self.wheels.iter().enumerate() {
            diagnostics[6 + 3 * w..9 + 3 * w].copy_from_slice(&[
                wheel.slip[0],
                wheel.slip[1],
                wheel.spin,
            ]);
        }

        let f = &mut self.figures;
        f.samples += 1;
        f.heading_error = heading_error;
        f.heading_error_max = f.heading_error_max.max(heading_error.abs());
        f.heading_error_square_sum += heading_error * heading_error;
        f.path_error_max = f.path_error_max.max(path_error);
        f.path_error_square_sum += path_error * path_error;
        let end = desired.point.position;
        f.final_position_error = (h[0] - end[0]).hypot(h[1] - end[1]);
        f.position_h = h;
        for wheel in self.wheels.iter().filter(|w| w.actuator.is_some()) {
            f.slip_max = f.slip_max.max(wheel.slip[0].hypot(wheel.slip[1]));
            f.current_max = f.current_max.max(wheel.motor.current().abs());
        }
    }

    fn drive(&mut self, dt: f64, commanded: &[f64], applied: &mut [f64]) {
        self.dt = dt;
        for wheel in &mut self.wheels {
            if let Some(a) = wheel.actuator {
                wheel.drive_torque = wheel.motor.step(dt, commanded[a], wheel.spin);
                applied[a] = wheel.drive_torque;
            }
        }
    }

    fn loads(&mut self, _time: f64, state: &MechanismState, loads: &mut Vec<Load>) {
        let dt = self.dt;
        let damping = self.motor.gear_damping;
        for wheel in &mut self.wheels {
            let pose = state.link_poses[wheel.contact.link];
            let (contact, velocity) = wheel.contact.locate(state);
            let [fx, fy] = pose.rotate(wheel.heading[0], wheel.heading[1]);
            let along = [
                velocity[0] * fx + velocity[1] * fy,
                -velocity[0] * fy + velocity[1] * fx,
            ];
            let (n, mu, r) = (wheel.normal_load, wheel.friction, wheel.radius);
            let gear_damping = if wheel.actuator.is_some() {
                damping
            } else {
                0.0
            };
            // Backward Euler on I·ω̇ = τ − b·ω − r·F_x(ω), F_x linearised about the present spin.
            let now = self.tyre.contact(wheel.spin, r, along, n, mu);
            let k = now.stiffness_per_spin.max(0.0);
            let inertia = wheel.inertia;
            wheel.spin = (wheel.spin
                + dt * (wheel.drive_torque - r * now.force[0] + r * k * wheel.spin) / inertia)
                / (1.0 + dt * (gear_damping + r * k) / inertia);
            wheel.angle += dt * wheel.spin;
            let after = self.tyre.contact(wheel.spin, r, along, n, mu);
            wheel.slip = after.slip;
            let [f_long, f_lat] = after.force;
            loads.push(Load {
                link: wheel.contact.link,
                force: [f_long * fx - f_lat * fy, f_long * fy + f_lat * fx],
                point: contact,
                damping: NO_DAMPING,
                stiffness: NO_STIFFNESS,
            });
        }
    }

    fn metrics(&self) -> Vec<(String, f64)> {
        let f = &self.figures;
        let n = f.samples.max(1) as f64;
        // The floor as run: each wheel's tyre friction (the URDF's, or `process.friction`).
        let friction = self
            .wheels
            .iter()
            .map(|w| (format!("wheel_friction/{}", w.name), w.friction));
        let mut metrics = vec![
            ("heading_error_max".into(), f.heading_error_max),
            (
                "heading_error_rms".into(),
                (f.heading_error_square_sum / n).sqrt(),
            ),
            ("heading_error_final".into(), f.heading_error),
            ("path_error_max".into(), f.path_error_max),
            (
                "path_error_rms".into(),
                (f.path_error_square_sum / n).sqrt(),
            ),
            ("final_position_error".into(), f.final_position_error),
            ("final_x_h".into(), f.position_h[0]),
            ("final_y_h".into(), f.position_h[1]),
            ("wheel_slip_max".into(), f.slip_max),
            ("motor_current_max".into(), f.current_max),
            ("path_duration".into(), self.path.duration()),
        ];
        metrics.extend(friction);
        metrics
    }
}
/// The floor around the planned path of point h (drawn whole), with point h's planned, true and
/// odometry positions traced as the run goes.
fn scene(path: &Path) -> Scene {
    const PATH_SAMPLES: usize = 400;
    let planned: Vec<[f64; 2]> = (0..=PATH_SAMPLES)
        .map(|i| {
            path.at(path.length() * i as f64 / PATH_SAMPLES as f64)
                .position
        })
        .collect();
    let start = planned[0];
    let bounds = Bounds::around(planned.iter().copied(), 0.15).unwrap_or(Bounds {
        x: [start[0] - 1.0, start[0] + 1.0],
        y: [start[1] - 1.0, start[1] + 1.0],
    });
    let marker = |name: &str, label: &str, color, x: &str, y: &str| Marker {
        name: name.into(),
        color,
        label: label.into(),
        source: MarkerSource::at(x, y),
        trace: true,
    };
    Scene {
        title: "floor (m, y up): planned, true and odometry paths of point h".into(),
        bounds,
        drawings: vec![Drawing {
            name: "planned_path".into(),
            color: colors::TARGET,
            lines: vec![planned],
            label: "planned path".into(),
        }],
        markers: vec![
            marker("true_h", "true h", colors::TRUE, "pose.x_h", "pose.y_h"),
            marker(
                "odometry_h",
                "odometry h",
                colors::ESTIMATE,
                "odometry.x_h",
                "odometry.y_h",
            ),
        ],
    }
}
