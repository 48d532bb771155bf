//! The scenario's task-space points, `[points.<name>]`: a point of a link, measured as
//! `<name>.x`, `<name>.y` and their rates `<name>.vx`, `<name>.vy`, drawn and traced in the view.
//! A point may carry a load: a constant force, a force in time from a table
//! ([`super::force_table`]), or a spring-damper to a fixed anchor (a contact with a workpiece, a
//! buffer). The generic machine's task space is its points; a built-in machine takes them beside
//! its own signals ([`super::with_points`]), and measures its own (the arm's tool, the shaper's
//! ram, the spindle's tip, a wheel's contact) as the same [`LinkPoint`], under its own names.

use super::error::MachineError;
use super::force_table::ForceTable;
use super::parts::link;
use crate::mechanism::Mechanism;
use crate::physics::{Load, MechanismState, NO_DAMPING, NO_STIFFNESS};
use crate::scene::{colors, Marker, MarkerSource};
use framework::{SignalSpec, Unit};
use serde::Deserialize;
use std::collections::BTreeMap;

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

/// A point fixed on a link: where it is and how fast it moves, world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct LinkPoint {
    /// The link, by index.
    pub link: usize,
    /// Where on the link, in its frame on the plane, m.
    pub at: [f64; 2],
}

impl LinkPoint {
    /// The origin of `link`.
    pub fn origin(link: usize) -> Self {
        Self { link, at: [0.0; 2] }
    }

    /// Where the point is in `state`, world frame, m. A link's origin is its pose's, unrotated.
    pub fn position(&self, state: &MechanismState) -> [f64; 2] {
        let pose = state.link_poses[self.link];
        match self.at == [0.0; 2] {
            true => [pose.x, pose.y],
            false => pose.apply(self.at[0], self.at[1]),
        }
    }

    /// Where the point is and how fast it moves in `state`, world frame (m, m/s): the link's
    /// velocity plus ω × r from the link's origin.
    pub fn locate(&self, state: &MechanismState) -> ([f64; 2], [f64; 2]) {
        let velocity = state.link_velocities[self.link];
        if self.at == [0.0; 2] {
            return (self.position(state), velocity);
        }
        let pose = state.link_poses[self.link];
        let position = pose.apply(self.at[0], self.at[1]);
        let omega = state.link_angular_velocities[self.link];
        let (rx, ry) = (position[0] - pose.x, position[1] - pose.y);
        (
            position,
            [velocity[0] - omega * ry, velocity[1] + omega * rx],
        )
    }
}

/// A point of the scenario's, resolved on the mechanism.
struct Point {
    name: String,
    on: LinkPoint,
    force: [f64; 2],
    table: Option<ForceTable>,
    spring: Option<SpringSpec>,
}

/// The scenario's points, resolved on the mechanism.
pub(super) struct Points(Vec<Point>);

impl Points {
    /// Each of `specs` on `mechanism`, checked; `machine` names the machine in a refusal.
    pub(super) fn new(
        machine: &str,
        mechanism: &Mechanism,
        specs: &PointSpecs,
    ) -> Result<Self, MachineError> {
        let mut resolved = Vec::with_capacity(specs.len());
        for (name, spec) in specs {
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
                on: LinkPoint {
                    link: link(machine, mechanism, &spec.link)?,
                    at,
                },
                force: spec.force.unwrap_or([0.0; 2]),
                table: table_of(name, spec)?,
                spring: spec.spring,
            });
        }
        Ok(Self(resolved))
    }

    /// How many signals the points give: four each.
    pub(super) fn signal_count(&self) -> usize {
        4 * self.0.len()
    }

    /// Four signals a point: `<name>.x`, `<name>.y` (mm shown), `<name>.vx`, `<name>.vy`.
    pub(super) fn signals(&self) -> Vec<SignalSpec> {
        let mut specs = Vec::with_capacity(4 * self.0.len());
        for p in &self.0 {
            let plot = format!("{} point", p.name);
            let rates = format!("{} point velocity", p.name);
            specs.extend([
                SignalSpec::new(format!("{}.x", p.name), Unit::Millimetre, &plot),
                SignalSpec::new(format!("{}.y", p.name), Unit::Millimetre, &plot),
                SignalSpec::new(format!("{}.vx", p.name), Unit::MetrePerSecond, &rates),
                SignalSpec::new(format!("{}.vy", p.name), Unit::MetrePerSecond, &rates),
            ]);
        }
        specs
    }

    /// Fills [`Points::signals`] for `state`.
    pub(super) fn measure(&self, state: &MechanismState, signals: &mut [f64]) {
        for (k, p) in self.0.iter().enumerate() {
            let ([x, y], [vx, vy]) = p.on.locate(state);
            signals[4 * k..4 * k + 4].copy_from_slice(&[x, y, vx, vy]);
        }
    }

    /// Each point's load over the coming step, if it carries one.
    pub(super) fn loads(&self, time: f64, state: &MechanismState, loads: &mut Vec<Load>) {
        for p in &self.0 {
            let (point, velocity) = p.on.locate(state);
            let mut force = p.force;
            if let Some(table) = &p.table {
                let [fx, fy] = table.at(time);
                force = [force[0] + fx, force[1] + fy];
            }
            let mut load = Load {
                link: p.on.link,
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

    /// A traced marker a point, for the view.
    pub(super) fn markers(&self) -> Vec<Marker> {
        (self.0.iter())
            .map(|p| Marker {
                name: p.name.clone(),
                color: colors::TOOL,
                label: p.name.clone(),
                source: MarkerSource::at(&format!("{}.x", p.name), &format!("{}.y", p.name)),
                trace: true,
            })
            .collect()
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

#[cfg(test)]
mod tests {
    use super::LinkPoint;
    use crate::mechanism::Pose2;
    use crate::physics::MechanismState;

    /// A link turned by 90° at (1, 2), moving at (0.5, −0.25) m/s and turning at 2 rad/s.
    fn turning_link() -> MechanismState {
        MechanismState {
            link_poses: vec![Pose2 {
                x: 1.0,
                y: 2.0,
                angle: std::f64::consts::FRAC_PI_2,
            }],
            link_velocities: vec![[0.5, -0.25]],
            link_angular_velocities: vec![2.0],
            ..MechanismState::default()
        }
    }

    #[test]
    fn a_link_origin_is_the_links_own_pose_and_velocity_bit_for_bit() {
        let state = turning_link();
        let origin = LinkPoint::origin(0);
        assert_eq!(origin.position(&state), [1.0, 2.0]);
        assert_eq!(origin.locate(&state), ([1.0, 2.0], [0.5, -0.25]));
    }

    #[test]
    fn a_point_off_the_origin_turns_with_its_link() {
        let state = turning_link();
        let (position, velocity) = LinkPoint {
            link: 0,
            at: [0.1, 0.0],
        }
        .locate(&state);
        // r = (0, 0.1) in the world; v = v₀ + ω × r = (0.5 − 2·0.1, −0.25).
        assert!((position[0] - 1.0).abs() < 1e-15 && (position[1] - 2.1).abs() < 1e-15);
        assert!((velocity[0] - 0.3).abs() < 1e-15 && (velocity[1] + 0.25).abs() < 1e-15);
    }
}
