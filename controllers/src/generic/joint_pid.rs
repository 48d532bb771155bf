//! `joint-pid`: one PID loop per actuated joint named in its parameters, on the joint's measured
//! position and velocity, for any mechanism.
//!
//! `u = kp·(r − q) + ki·∫(r − q) dt + kd·(ṙ − q̇)`, clipped to the actuator's effort limit. The
//! setpoint r is the joint's `target` (held, ṙ = 0), or the joint's own `reference` (any
//! [`Reference`]: a step, a ramp, waypoints, a table, …) plus `target` as an offset, or with
//! `follow_reference` the scenario's `[reference]` (`reference`, `reference_rate`) plus `target`. Anti-windup: the
//! integral stops growing while the effort is clipped. The derivative acts on the measured
//! velocity (no filter: `<joint>.velocity` is the drive's own speed signal). No gravity
//! feed-forward: the law knows only what it measures.
//!
//! A point of the scenario may be given a path instead (`[controller.params.points.<name>]`
//! `x`, `y`, any [`Reference`], m): the joints with no reference of their own then follow the
//! positions and rates that put the point on it, by the twin's own kinematics
//! ([`PointFollower`](super::point_reference)), and `<name>.reach` says how far it is off.

use super::joint_reference;
use super::point_reference::{moved_joints, NamedJoint, PointFollower, PointReference};
use crate::check::{finite, non_negative};
use framework::{parse_params, Entry, ANY_MACHINE};
use framework::{Controller, ControllerError, Measurement, PlantInterface, SignalSpec, Unit};
use models::reference::Reference;
use serde::Deserialize;
use std::collections::BTreeMap;

const NAME: &str = "joint-pid";

/// Parameters of `joint-pid`: a loop per joint, by the URDF's joint name.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct JointPidParams {
    /// `[controller.params.joints.<joint>]`: the joints driven; an actuator not named gets no
    /// effort. At least one is needed to run (checked when bound to the plant).
    #[serde(default)]
    pub joints: BTreeMap<String, JointLoop>,
    /// `[controller.params.points.<name>]`: a point of the scenario's `[points]` on a path (`x`,
    /// `y`); it moves every joint named here that has no `reference` of its own.
    #[serde(default)]
    pub points: BTreeMap<String, PointReference>,
}

/// One joint's loop (SI: rad or m, N·m or N).
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct JointLoop {
    /// Proportional gain, N·m/rad or N/m.
    pub kp: f64,
    /// Integral gain, N·m/(rad·s) or N/(m·s).
    pub ki: f64,
    /// Derivative gain, N·m·s/rad or N·s/m.
    pub kd: f64,
    /// The setpoint held, rad or m; with `reference` or `follow_reference`, an offset on it.
    pub target: f64,
    /// The joint's own reference, rad or m (`reference = { kind = "waypoints", … }`).
    pub reference: Option<Reference>,
    /// Follow the scenario's `[reference]` (its value and rate).
    pub follow_reference: bool,
}

/// A loop's gains, checked.
#[derive(Debug, Clone, PartialEq)]
pub struct LoopGains {
    /// The joint, as the URDF names it.
    pub joint: String,
    /// Proportional, integral and derivative gains.
    pub kp: f64,
    /// Integral gain.
    pub ki: f64,
    /// Derivative gain.
    pub kd: f64,
    /// Setpoint or offset.
    pub target: f64,
    /// The joint's own reference (its table read when bound to the plant).
    pub reference: Option<Reference>,
    /// Whether the setpoint is the scenario's reference.
    pub follow_reference: bool,
}

/// Checks the parameters and returns each loop's gains, in joint-name order.
pub fn design(params: &JointPidParams) -> Result<Vec<LoopGains>, ControllerError> {
    let mut gains = Vec::with_capacity(params.joints.len());
    for (joint, l) in &params.joints {
        let key = |k: &str| format!("joints.{joint}.{k}");
        if let Some(reference) = &l.reference {
            joint_reference::check(NAME, &key("reference"), reference)?;
            if l.follow_reference {
                return Err(ControllerError::parameter_table(
                    NAME,
                    key("reference"),
                    "give a joint its own reference or follow_reference = true, not both",
                ));
            }
        }
        gains.push(LoopGains {
            joint: joint.clone(),
            kp: non_negative(NAME, &key("kp"), l.kp)?,
            ki: non_negative(NAME, &key("ki"), l.ki)?,
            kd: non_negative(NAME, &key("kd"), l.kd)?,
            target: finite(NAME, &key("target"), l.target)?,
            reference: l.reference.clone(),
            follow_reference: l.follow_reference,
        });
    }
    moved_joints(NAME, &params.points, &named(&gains))?;
    Ok(gains)
}

/// The joints the loops name, as the points' check reads them.
fn named(gains: &[LoopGains]) -> Vec<NamedJoint<'_>> {
    (gains.iter())
        .map(|g| NamedJoint {
            joint: &g.joint,
            own_reference: g.reference.is_some() || g.follow_reference,
            target: g.target,
        })
        .collect()
}

/// A loop bound to the plant: where its signals and actuator are, and its state.
#[derive(Debug, Clone)]
struct Bound {
    gains: LoopGains,
    position: usize,
    velocity: usize,
    actuator: usize,
    limit: f64,
    integral: f64,
    error: f64,
    effort: f64,
}

/// The running law.
pub struct JointPid {
    gains: Vec<LoopGains>,
    /// The points' references and the joints they move.
    points: Vec<(String, PointReference)>,
    moved: Vec<String>,
    follower: Option<PointFollower>,
    loops: Vec<Bound>,
    /// The reference's value and rate signals, when a loop follows it.
    reference: Option<[usize; 2]>,
}

impl JointPid {
    /// Checks the parameters; the loops are bound to the plant at `reset`.
    pub fn new(params: JointPidParams) -> Result<Self, ControllerError> {
        let gains = design(&params)?;
        Ok(Self {
            moved: moved_joints(NAME, &params.points, &named(&gains))?,
            points: params.points.into_iter().collect(),
            follower: None,
            gains,
            loops: Vec::new(),
            reference: None,
        })
    }
}

pub(crate) fn entry() -> Entry {
    Entry {
        name: NAME,
        machine: ANY_MACHINE,
        summary: "a PID loop per actuated joint, on a held target or the scenario's reference",
        build: |table| Ok(Box::new(JointPid::new(parse_params(NAME, table)?)?)),
    }
}

impl Controller for JointPid {
    fn name(&self) -> &str {
        NAME
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        if self.gains.is_empty() {
            return Err(ControllerError::BadParameter {
                controller: NAME.into(),
                key: "joints".into(),
                value: None,
                reason: "name at least one joint: [controller.params.joints.<joint>] kp = …".into(),
            });
        }
        self.loops.clear();
        for gains in &self.gains {
            let actuator = plant.actuator(&gains.joint)?;
            let mut gains = gains.clone();
            if let Some(reference) = &mut gains.reference {
                let key = format!("joints.{}.reference", gains.joint);
                let kind = plant.actuators[actuator].kind;
                joint_reference::read_table(NAME, &key, reference, plant, kind)?;
            }
            self.loops.push(Bound {
                position: plant.signal(&format!("{}.position", gains.joint))?,
                velocity: plant.signal(&format!("{}.velocity", gains.joint))?,
                actuator,
                limit: plant.actuators[actuator].effort_limit,
                gains,
                integral: 0.0,
                error: 0.0,
                effort: 0.0,
            });
        }
        self.follower = match self.points.is_empty() {
            true => None,
            false => Some(PointFollower::bind(NAME, &self.points, &self.moved, plant)?),
        };
        self.reference = match self.gains.iter().any(|g| g.follow_reference) {
            true => Some([plant.signal("reference")?, plant.signal("reference_rate")?]),
            false => None,
        };
        Ok(())
    }

    fn update(&mut self, measurement: &Measurement, period: f64, efforts: &mut [f64]) {
        let reference = self.reference.map(|[r, rate]| {
            let value = |i: usize| measurement.get(i);
            [value(r), value(rate)]
        });
        let from_points = (self.follower.as_mut()).map(|f| f.targets(measurement));
        for l in &mut self.loops {
            let g = &l.gains;
            let moved = self.moved.iter().position(|j| *j == g.joint);
            let [r, rate] = match (&g.reference, g.follow_reference, reference) {
                _ if moved.is_some() && from_points.is_some() => from_points
                    .as_ref()
                    .zip(moved)
                    .map_or([0.0; 2], |(t, k)| t[k]),
                (Some(own), _, _) => {
                    let sample = own.sample(measurement.time);
                    [sample.position + g.target, sample.rate]
                }
                (None, true, Some([r, rate])) => [r + g.target, rate],
                _ => [g.target, 0.0],
            };
            l.error = r - measurement.get(l.position);
            let candidate = l.integral + l.error * period;
            let rate_error = rate - measurement.get(l.velocity);
            let effort = g.kp * l.error + g.ki * candidate + g.kd * rate_error;
            if effort.abs() <= l.limit {
                l.integral = candidate;
            }
            l.effort = effort.clamp(-l.limit, l.limit);
            efforts[l.actuator] = l.effort;
        }
    }

    fn internals(&self) -> Vec<SignalSpec> {
        let errors = (self.gains.iter())
            .map(|g| SignalSpec::new(format!("{}.error", g.joint), Unit::Dimensionless, "errors"));
        let reach = (self.points.iter())
            .map(|(name, _)| SignalSpec::new(format!("{name}.reach"), Unit::Metre, "errors"));
        errors.chain(reach).collect()
    }

    fn internal_values(&self, values: &mut [f64]) {
        for (value, l) in values.iter_mut().zip(&self.loops) {
            *value = l.error;
        }
        if let Some(follower) = &self.follower {
            let reach = values.iter_mut().skip(self.loops.len());
            for (value, distance) in reach.zip(&follower.reach) {
                *value = *distance;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use framework::{Actuator, EffortKind};

    fn plant() -> PlantInterface {
        PlantInterface {
            machine: "generic".into(),
            signals: ["a.position", "a.velocity"].map(String::from).into(),
            actuators: vec![Actuator {
                joint: "a".into(),
                kind: EffortKind::Torque,
                effort_limit: 10.0,
            }],
            ..Default::default()
        }
    }

    #[test]
    fn the_law_is_pid_clipped_and_its_integral_stops_while_clipped() {
        let params: JointPidParams =
            toml::from_str("[joints.a]\nkp = 100.0\nki = 50.0\nkd = 5.0\ntarget = 0.01").unwrap();
        let mut pid = JointPid::new(params).unwrap();
        pid.reset(&plant()).unwrap();
        let mut efforts = [0.0];
        let signals = [0.0, 0.2];
        pid.update(
            &Measurement {
                time: 0.0,
                signals: &signals,
            },
            0.1,
            &mut efforts,
        );
        // 100·0.01 + 50·0.001 − 5·0.2 = 0.05
        assert!((efforts[0] - 0.05).abs() < 1e-12, "{efforts:?}");
        let far = [-1.0, 0.0];
        pid.update(
            &Measurement {
                time: 0.1,
                signals: &far,
            },
            0.1,
            &mut efforts,
        );
        assert_eq!(efforts[0], 10.0);
        assert!((pid.loops[0].integral - 0.001).abs() < 1e-15);
    }

    #[test]
    fn a_joints_own_reference_is_its_setpoint_and_rate() {
        let params: JointPidParams = toml::from_str(
            "[joints.a]\nkp = 10.0\nkd = 1.0\ntarget = 0.1\n\
             reference = { kind = \"ramp\", rate = 0.5, start = 1.0 }",
        )
        .unwrap();
        let mut pid = JointPid::new(params).unwrap();
        pid.reset(&plant()).unwrap();
        let mut efforts = [0.0];
        let signals = [0.0, 0.0];
        pid.update(
            &Measurement {
                time: 2.0,
                signals: &signals,
            },
            0.01,
            &mut efforts,
        );
        // r = 0.5·(2 − 1) + 0.1, ṙ = 0.5: 10·0.6 + 1·0.5
        assert!((efforts[0] - 6.5).abs() < 1e-12, "{efforts:?}");
        let both: JointPidParams = toml::from_str(
            "[joints.a]\nfollow_reference = true\nreference = { kind = \"constant\", value = 1.0 }",
        )
        .unwrap();
        let error = JointPid::new(both).err().unwrap().to_string();
        assert!(error.contains("params.joints.a.reference: give"), "{error}");
        let table: JointPidParams =
            toml::from_str("[joints.a]\nreference = { kind = \"table\", file = \"moves.csv\" }")
                .unwrap();
        let error = JointPid::new(table).unwrap().reset(&plant()).unwrap_err();
        assert!(error.to_string().contains("data files"), "{error}");
    }

    #[test]
    fn a_joint_the_plant_does_not_drive_is_named() {
        let params: JointPidParams = toml::from_str("[joints.b]\nkp = 1.0").unwrap();
        let mut pid = JointPid::new(params).unwrap();
        let error = pid.reset(&plant()).unwrap_err().to_string();
        assert!(error.contains('b'), "{error}");
        let mut none = JointPid::new(JointPidParams::default()).unwrap();
        let error = none.reset(&plant()).unwrap_err().to_string();
        assert!(error.contains("joints"), "{error}");
    }
}
