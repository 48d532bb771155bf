//! The generic machine: any planar mechanism the twin accepts, with nothing of its own but what
//! the scenario names. Its signals are the joints' (as every machine's) and the task-space
//! points of `[points.<name>]`: `<name>.x`, `<name>.y` and their rates `<name>.vx`, `<name>.vy`.
//! A point may carry a load: a constant force, a force in time from a table
//! ([`super::force_table`]), or a spring-damper to a fixed anchor (a contact with a workpiece, a
//! buffer). Its actuators are the URDF's driven joints, ideal unless the
//! scenario says otherwise ([`super::actuators`]).

use super::actuators::ActuatorSpecs;
use super::error::MachineError;
use super::force_table::ForceTable;
use super::joint_drives::JointDrives;
use super::machine::effort_unit;
use super::machine::Machine;
use super::parts::link;
use crate::mechanism::Mechanism;
use crate::physics::{Load, MechanismState, NO_DAMPING, NO_STIFFNESS};
use crate::scene::{colors, Bounds, Marker, MarkerSource, Scene};
use framework::{Actuator, SignalSpec, Unit};
use serde::Deserialize;
use std::collections::BTreeMap;

/// The machine's name in a scenario (`machine = "generic"`, or no `machine` at all).
pub const GENERIC: &str = "generic";

/// A point of a link named in the scenario, `[points.<name>]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointSpec {
    /// The link it is fixed to, as the URDF names it.
    pub link: String,
    /// Where on the link, m (default its origin): [x, y] in the link's frame on the plane, or
    /// [x, y, z] in the URDF's link frame (laid onto the plane with the URDF).
    #[serde(default)]
    pub at: PointAt,
    /// A constant force on the point, world frame, N.
    #[serde(default)]
    pub force: Option<[f64; 2]>,
    /// A force in time from a table (CSV or Parquet: `time [s]`, `fx [N]`, `fy [N]`), world frame, added
    /// to `force`; a file relative to the scenario's folder.
    #[serde(default)]
    pub force_table: Option<String>,
    /// The table, read when the scenario is loaded.
    #[serde(skip)]
    pub force_samples: Option<ForceTable>,
    /// A spring-damper from the point to a fixed anchor.
    #[serde(default)]
    pub spring: Option<SpringSpec>,
}

/// Where a point is on its link.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(try_from = "Vec<f64>")]
pub enum PointAt {
    /// [x, y] in the link's frame on the plane, m.
    InPlane([f64; 2]),
    /// [x, y, z] in the URDF's link frame, m.
    InUrdf([f64; 3]),
}

impl Default for PointAt {
    fn default() -> Self {
        PointAt::InPlane([0.0; 2])
    }
}

impl TryFrom<Vec<f64>> for PointAt {
    type Error = String;

    fn try_from(values: Vec<f64>) -> Result<Self, String> {
        match values.as_slice() {
            &[x, y] => Ok(PointAt::InPlane([x, y])),
            &[x, y, z] => Ok(PointAt::InUrdf([x, y, z])),
            other => Err(format!(
                "{} elements: give 2 (in the link's frame on the plane, m) or 3 (in the URDF's link frame)",
                other.len()
            )),
        }
    }
}

impl PointAt {
    /// The point on the plane `plane` lays the URDF onto (its offset along the plane's normal
    /// moves nothing in the plane).
    pub(crate) fn on(&self, plane: &crate::mechanism::Plane) -> [f64; 2] {
        match *self {
            PointAt::InPlane(at) => at,
            PointAt::InUrdf(at) => {
                let [x, y, _] = plane.vector(at);
                [x, y]
            }
        }
    }
}

/// A spring-damper between a point and a fixed anchor in the world, acting along both axes.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpringSpec {
    /// The anchor, world frame, m.
    pub anchor: [f64; 2],
    /// Stiffness, N/m.
    pub stiffness: f64,
    /// Damping, N·s/m (default 0).
    #[serde(default)]
    pub damping: f64,
    /// Its rest length per axis, m: the force is `−k·(p − anchor − rest) − c·v` (default 0).
    #[serde(default)]
    pub rest: [f64; 2],
}

/// The scenario's points, by name.
pub type PointSpecs = BTreeMap<String, PointSpec>;

/// A point, resolved on the mechanism.
struct Point {
    name: String,
    link: usize,
    at: [f64; 2],
    force: [f64; 2],
    table: Option<ForceTable>,
    spring: Option<SpringSpec>,
}

pub struct Generic {
    points: Vec<Point>,
    /// The driven joints' actuators: through their transmission, or a DC servo.
    drives: JointDrives,
    /// The view: wide enough for every link turned any way about the base.
    bounds: Bounds,
}

impl Generic {
    pub fn new(
        mechanism: &Mechanism,
        points: &PointSpecs,
        actuators: &ActuatorSpecs,
    ) -> Result<Self, MachineError> {
        let mut resolved = Vec::with_capacity(points.len());
        for (name, spec) in points {
            let bad = |reason: String| MachineError::Point {
                key: format!("points.{name}"),
                reason,
            };
            let at = spec.at.on(&mechanism.plane);
            let numbers = at.iter().chain(spec.force.iter().flatten());
            if numbers.clone().any(|v| !v.is_finite()) {
                return Err(bad("`at` and `force` must be finite numbers".into()));
            }
            if let Some(spring) = spec.spring {
                check_spring(&spring).map_err(bad)?;
            }
            resolved.push(Point {
                name: name.clone(),
                link: link(GENERIC, mechanism, &spec.link)?,
                at,
                force: spec.force.unwrap_or([0.0; 2]),
                table: table_of(name, spec)?,
                spring: spec.spring,
            });
        }
        Ok(Self {
            points: resolved,
            drives: JointDrives::new(mechanism, actuators)?,
            bounds: reach(mechanism),
        })
    }

    /// Where point `p` is and how fast it moves, world frame.
    fn locate(&self, p: &Point, state: &MechanismState) -> ([f64; 2], [f64; 2]) {
        let pose = state.link_poses[p.link];
        let position = pose.apply(p.at[0], p.at[1]);
        let [vx, vy] = state.link_velocities[p.link];
        let omega = state.link_angular_velocities[p.link];
        let (rx, ry) = (position[0] - pose.x, position[1] - pose.y);
        (position, [vx - omega * ry, vy + omega * rx])
    }
}

/// The point's force table, read with the scenario.
fn table_of(name: &str, spec: &PointSpec) -> Result<Option<ForceTable>, MachineError> {
    match (&spec.force_table, &spec.force_samples) {
        (None, _) => Ok(None),
        (Some(_), Some(table)) => Ok(Some(table.clone())),
        (Some(file), None) => Err(MachineError::Point {
            key: format!("points.{name}.force_table"),
            reason: format!("`{file}` was not read: load the scenario from its file"),
        }),
    }
}

/// Refuses a spring that is not finite or not dissipative.
fn check_spring(spring: &SpringSpec) -> Result<(), String> {
    let all = [spring.stiffness, spring.damping]
        .into_iter()
        .chain(spring.anchor)
        .chain(spring.rest);
    if all.into_iter().any(|v| !v.is_finite()) {
        return Err("the spring's values must be finite numbers".into());
    }
    if spring.stiffness < 0.0 || spring.damping < 0.0 {
        return Err("the spring's stiffness and damping must be ≥ 0".into());
    }
    Ok(())
}

/// A square about the world origin holding every link's shapes turned any way about it, with a
/// margin: a tree swinging about its base stays in view.
fn reach(mechanism: &Mechanism) -> Bounds {
    let poses = mechanism.zero_pose();
    let radius = (mechanism.links.iter().zip(&poses))
        .flat_map(|(link, pose)| {
            (link.visuals.iter()).flat_map(|shape| shape.extent().map(|[x, y]| pose.apply(x, y)))
        })
        .chain(poses.iter().map(|p| [p.x, p.y]))
        .map(|[x, y]| x.hypot(y))
        .fold(0.1_f64, f64::max);
    let r = 1.1 * radius;
    Bounds {
        x: [-r, r],
        y: [-r, r],
    }
}

impl Machine for Generic {
    fn signals(&self) -> Vec<SignalSpec> {
        let mut specs = Vec::with_capacity(4 * self.points.len());
        for p in &self.points {
            let plot = format!("{} point", p.name);
            let rates = format!("{} point velocity", p.name);
            specs.extend([
                SignalSpec::new(format!("{}.x", p.name), Unit::Millimetre, &plot),
                SignalSpec::new(format!("{}.y", p.name), Unit::Millimetre, &plot),
                SignalSpec::new(format!("{}.vx", p.name), Unit::MetrePerSecond, &rates),
                SignalSpec::new(format!("{}.vy", p.name), Unit::MetrePerSecond, &rates),
            ]);
        }
        specs.extend(self.drives.signals());
        specs
    }

    /// A DC servo's command is a current, A; an ideal actuator's its effort.
    fn command_unit(&self, actuator: &Actuator) -> Unit {
        (self.drives.command_unit(actuator)).unwrap_or_else(|| effort_unit(actuator.kind))
    }

    /// A DC servo's current limit; an ideal actuator's effort limit less its reduction.
    fn command_limit(&self, actuator: &Actuator) -> f64 {
        self.drives.command_limit(actuator)
    }

    /// Through each transmission, or each DC servo.
    fn drive(&mut self, dt: f64, commanded: &[f64], applied: &mut [f64]) {
        self.drives.drive(dt, commanded, applied);
    }

    fn scene(&self) -> Scene {
        let markers = (self.points.iter())
            .map(|p| Marker {
                name: p.name.clone(),
                color: colors::TOOL,
                label: p.name.clone(),
                source: MarkerSource::at(&format!("{}.x", p.name), &format!("{}.y", p.name)),
                trace: true,
            })
            .collect();
        Scene {
            title: "mechanism (m, y up)".into(),
            bounds: self.bounds,
            drawings: Vec::new(),
            markers,
        }
    }

    fn measure(
        &mut self,
        _time: f64,
        state: &MechanismState,
        signals: &mut [f64],
        _diagnostics: &mut [f64],
    ) {
        for (k, p) in self.points.iter().enumerate() {
            let ([x, y], [vx, vy]) = self.locate(p, state);
            signals[4 * k..4 * k + 4].copy_from_slice(&[x, y, vx, vy]);
        }
        let points = 4 * self.points.len();
        self.drives.measure(state, &mut signals[points..]);
    }

    fn loads(&mut self, time: f64, state: &MechanismState, loads: &mut Vec<Load>) {
        for p in &self.points {
            let (point, velocity) = self.locate(p, state);
            let mut force = p.force;
            if let Some(table) = &p.table {
                let [fx, fy] = table.at(time);
                force = [force[0] + fx, force[1] + fy];
            }
            let mut load = Load {
                link: p.link,
                force,
                point,
                damping: NO_DAMPING,
                stiffness: NO_STIFFNESS,
            };
            if let Some(spring) = p.spring {
                spring_force(&spring, point, velocity, &mut load);
            }
            if p.spring.is_some() || p.table.is_some() || p.force != [0.0; 2] {
                loads.push(load);
            }
        }
    }

    fn metrics(&self) -> Vec<(String, f64)> {
        Vec::new()
    }
}

/// Adds the spring-damper's force at `point` moving at `velocity` to `load`, with its
/// derivatives (so that a stiff spring is integrated with the motion within the step).
fn spring_force(spring: &SpringSpec, point: [f64; 2], velocity: [f64; 2], load: &mut Load) {
    for axis in 0..2 {
        let stretch = point[axis] - spring.anchor[axis] - spring.rest[axis];
        load.force[axis] -= spring.stiffness * stretch + spring.damping * velocity[axis];
        load.stiffness[axis][axis] -= spring.stiffness;
        load.damping[axis][axis] -= spring.damping;
    }
}
