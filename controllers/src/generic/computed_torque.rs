//! `computed-torque`: each joint of a fully driven mechanism tracks its own reference through the
//! mechanism's inverse dynamics, the twin's own equations of motion.
//!
//! `τ = M(q)·(q̈_r + kd·(q̇_r − q̇) + kp·(q_r − q)) + h(q, q̇)`, clipped to the actuators' limits:
//! with the model exact, every joint's error obeys ë + kd·ė + kp·e = 0 whatever the others do
//! (kp = ωn², kd = 2ζωn). M and h are the engine's ([`framework::Dynamics`]): gravity, the
//! joints' springs and damping; not dry friction or a scenario's point loads, which the law meets
//! as disturbances. It needs every independent coordinate driven: a tree's every moving joint,
//! a closed loop's independent joints (the five-bar's two cranks), each with its gains and
//! reference; an underactuated mechanism (the cart-pole) is refused, by name.
//!
//! A point of the scenario may be given a path instead (`[controller.params.points.<name>]`
//! `x`, `y`, as joint-pid's): it moves the joints with no reference of their own, which are
//! given the positions, rates and accelerations that put it on its path by the twin's own
//! kinematics ([`PointFollower`](super::point_reference)); `<name>.reach` says how far off.

use super::joint_reference;
use super::model::{coordinate_signals, position_error, response, CoordinateSignals};
use super::point_reference::{moved_joints, named, PointFollower, PointReference};
use crate::check::{finite, non_negative};
use framework::{parse_params, Entry, Event, EventKind, ANY_MACHINE};
use framework::{Controller, ControllerError, Dynamics, Measurement, PlantInterface};
use framework::{SignalSpec, Unit};
use models::reference::Reference;
use nalgebra::DVector;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::sync::Arc;

const NAME: &str = "computed-torque";

/// Parameters of `computed-torque`: per joint, by the URDF's name.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ComputedTorqueParams {
    /// `[controller.params.joints.<joint>]`: one per independent coordinate.
    #[serde(default)]
    pub joints: BTreeMap<String, JointTracking>,
    /// `[controller.params.points.<name>]`: a point of the scenario's `[points]` on a path (`x`,
    /// `y`); it moves every joint named here that has no `reference` of its own.
    #[serde(default)]
    pub points: BTreeMap<String, PointReference>,
}

/// One joint's error dynamics and reference (SI).
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct JointTracking {
    /// Position gain kp = ωn², 1/s².
    pub kp: f64,
    /// Rate gain kd = 2ζωn, 1/s.
    pub kd: f64,
    /// The joint's reference, rad or m; none: `target` held.
    pub reference: Option<Reference>,
    /// The position held without a reference, rad or m.
    pub target: f64,
}

/// A joint's checked gains and reference.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackingGains {
    /// The joint, as the URDF names it.
    pub joint: String,
    /// kp, 1/s².
    pub kp: f64,
    /// kd, 1/s.
    pub kd: f64,
    /// What it tracks.
    pub reference: Reference,
}

/// Checks the parameters; a joint without a reference holds its `target`.
pub fn design(params: &ComputedTorqueParams) -> Result<Vec<TrackingGains>, ControllerError> {
    let mut gains = Vec::with_capacity(params.joints.len());
    for (joint, j) in &params.joints {
        let key = |k: &str| format!("joints.{joint}.{k}");
        let target = finite(NAME, &key("target"), j.target)?;
        let reference = (j.reference.clone()).unwrap_or(Reference::Constant { value: target });
        joint_reference::check(NAME, &key("reference"), &reference)?;
        gains.push(TrackingGains {
            joint: joint.clone(),
            kp: non_negative(NAME, &key("kp"), j.kp)?,
            kd: non_negative(NAME, &key("kd"), j.kd)?,
            reference,
        });
    }
    moved_by_points(params)?;
    Ok(gains)
}

/// A coordinate bound to the plant: its gains, signals, actuator and last error.
struct Bound {
    gains: TrackingGains,
    signals: CoordinateSignals,
    actuator: usize,
    limit: f64,
    error: f64,
}

/// The running law.
pub struct ComputedTorque {
    gains: Vec<TrackingGains>,
    /// The points' references and the joints they move.
    points: Vec<(String, PointReference)>,
    moved: Vec<String>,
    follower: Option<PointFollower>,
    dynamics: Option<Arc<dyn Dynamics>>,
    actuators: usize,
    joints: Vec<Bound>,
    position: Vec<f64>,
    velocity: Vec<f64>,
    /// Whether a failed evaluation has been said (once).
    failure_said: bool,
    events: Vec<Event>,
}

impl ComputedTorque {
    /// Checks the parameters; the joints are bound to the mechanism's coordinates at `reset`.
    pub fn new(params: ComputedTorqueParams) -> Result<Self, ControllerError> {
        let moved = moved_by_points(&params)?;
        Ok(Self {
            gains: design(&params)?,
            points: params.points.into_iter().collect(),
            moved,
            follower: None,
            dynamics: None,
            actuators: 0,
            joints: Vec::new(),
            position: Vec::new(),
            velocity: Vec::new(),
            failure_said: false,
            events: Vec::new(),
        })
    }

    /// Binds each independent coordinate to its gains and actuator; refuses a coordinate not
    /// named or not driven, and a joint named that is not a coordinate.
    fn bind(
        &mut self,
        plant: &PlantInterface,
        dynamics: &dyn Dynamics,
    ) -> Result<(), ControllerError> {
        let coordinates = dynamics.coordinates();
        let names: Vec<&str> = coordinates.iter().map(|c| c.joint.as_str()).collect();
        if let Some(g) = self
            .gains
            .iter()
            .find(|g| !names.contains(&g.joint.as_str()))
        {
            return Err(ControllerError::parameter_table(
                NAME,
                format!("joints.{}", g.joint),
                format!(
                    "not an independent coordinate of the mechanism (they are: {})",
                    names.join(", ")
                ),
            ));
        }
        let signals = coordinate_signals(plant, dynamics)?;
        self.joints.clear();
        for (coordinate, signals) in coordinates.iter().zip(signals) {
            let gains = (self.gains.iter().find(|g| g.joint == coordinate.joint)).ok_or_else(|| {
                ControllerError::parameter_table(
                    NAME,
                    "joints",
                    format!(
                        "name every independent coordinate ({}); `{}` has no [controller.params.joints.{}]",
                        names.join(", "),
                        coordinate.joint,
                        coordinate.joint
                    ),
                )
            })?;
            let actuator = plant.actuator_of_kind(&coordinate.joint, coordinate.kind)?;
            let mut gains = gains.clone();
            let key = format!("joints.{}.reference", gains.joint);
            joint_reference::read_table(NAME, &key, &mut gains.reference, plant, coordinate.kind)?;
            self.joints.push(Bound {
                gains,
                signals,
                actuator,
                limit: plant.actuators[actuator].effort_limit,
                error: 0.0,
            });
        }
        Ok(())
    }

    /// The efforts the law asks for at this measurement, per coordinate.
    fn efforts(&mut self, measurement: &Measurement) -> Result<DVector<f64>, String> {
        let dynamics = self.dynamics.as_deref().ok_or("not bound to a plant")?;
        let k = self.joints.len();
        let from_points = (self.follower.as_mut()).map(|f| {
            let targets = f.targets(measurement);
            let accelerations = f.accelerations(measurement.time, &targets);
            (targets, accelerations)
        });
        let mut wanted = DVector::zeros(k);
        for (i, j) in self.joints.iter_mut().enumerate() {
            let (q, v) = (
                measurement.get(j.signals.position),
                measurement.get(j.signals.velocity),
            );
            (self.position[i], self.velocity[i]) = (q, v);
            let moved = self.moved.iter().position(|m| *m == j.gains.joint);
            let (position, rate, acceleration) = match (moved, &from_points) {
                (Some(m), Some((targets, accelerations))) => {
                    (targets[m][0], targets[m][1], accelerations[m])
                }
                _ => {
                    let r = j.gains.reference.sample(measurement.time);
                    (r.position, r.rate, r.acceleration)
                }
            };
            j.error = position_error(position, q, j.signals.turns);
            wanted[i] = acceleration + j.gains.kd * (rate - v) + j.gains.kp * j.error;
        }
        let answer = response(dynamics, self.actuators, &self.position, &self.velocity)?;
        // q̈ = a₀ + M⁻¹·S·u: the coordinates' own actuators, u = (M⁻¹·S_c)⁻¹·(q̈_wanted − a₀).
        let own = answer
            .per_effort
            .select_columns(self.joints.iter().map(|j| &j.actuator));
        own.lu()
            .solve(&(wanted - answer.free))
            .ok_or_else(|| "the mass matrix is singular at this state".to_string())
    }
}

/// The joints the points move (those named with no reference of their own), checked.
fn moved_by_points(params: &ComputedTorqueParams) -> Result<Vec<String>, ControllerError> {
    let joints = named(&params.joints, |j| (j.reference.is_some(), j.target));
    moved_joints(NAME, &params.points, &joints)
}

pub(crate) fn entry() -> Entry {
    Entry {
        name: NAME,
        machine: ANY_MACHINE,
        summary: "per joint, a reference tracked through the mechanism's own inverse dynamics",
        build: |table| Ok(Box::new(ComputedTorque::new(parse_params(NAME, table)?)?)),
    }
}

impl Controller for ComputedTorque {
    fn name(&self) -> &str {
        NAME
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        if self.gains.is_empty() {
            return Err(ControllerError::parameter_table(
                NAME,
                "joints",
                "name every independent coordinate: [controller.params.joints.<joint>] kp = …",
            ));
        }
        let dynamics = Arc::clone(plant.dynamics(NAME)?);
        self.bind(plant, dynamics.as_ref())?;
        self.follower = match self.points.is_empty() {
            true => None,
            false => Some(PointFollower::bind(NAME, &self.points, &self.moved, plant)?),
        };
        let k = self.joints.len();
        (self.position, self.velocity) = (vec![0.0; k], vec![0.0; k]);
        self.actuators = plant.actuators.len();
        self.dynamics = Some(dynamics);
        self.failure_said = false;
        self.events.clear();
        Ok(())
    }

    fn update(&mut self, measurement: &Measurement, _period: f64, efforts: &mut [f64]) {
        match self.efforts(measurement) {
            Ok(tau) => {
                for (j, tau) in self.joints.iter().zip(tau.iter()) {
                    efforts[j.actuator] = tau.clamp(-j.limit, j.limit);
                }
            }
            Err(reason) if !self.failure_said => {
                self.failure_said = true;
                self.events.push(Event::warning(
                    EventKind::Note,
                    format!(
                        "computed-torque: no effort at t = {:.6} s: {reason}",
                        measurement.time
                    ),
                ));
            }
            Err(_) => {}
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
        for (value, g) in values.iter_mut().zip(&self.gains) {
            let bound = self.joints.iter().find(|j| j.gains.joint == g.joint);
            *value = bound.map_or(0.0, |j| j.error);
        }
        if let Some(follower) = &self.follower {
            let reach = values.iter_mut().skip(self.gains.len());
            for (value, distance) in reach.zip(&follower.reach) {
                *value = *distance;
            }
        }
    }

    fn drain_events(&mut self, events: &mut Vec<Event>) {
        events.append(&mut self.events);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generic::model::tests::TwoJoints;
    use framework::{Actuator, EffortKind};

    fn plant() -> PlantInterface {
        let actuator = |joint: &str| Actuator {
            joint: joint.into(),
            kind: EffortKind::Torque,
            effort_limit: 100.0,
        };
        PlantInterface {
            machine: "generic".into(),
            signals: ["a.position", "a.velocity", "b.position", "b.velocity"]
                .map(String::from)
                .into(),
            // The model's S: actuator 0 drives coordinate b, actuator 1 coordinate a.
            actuators: vec![actuator("b"), actuator("a")],
            dynamics: Some(Arc::new(TwoJoints::new())),
            ..Default::default()
        }
    }

    #[test]
    fn the_efforts_are_the_inverse_dynamics_of_the_wanted_acceleration() {
        let params: ComputedTorqueParams = toml::from_str(
            "[joints.a]\nkp = 100.0\nkd = 20.0\nreference = { kind = \"ramp\", rate = 0.5 }\n\
             [joints.b]\nkp = 25.0\nkd = 10.0\ntarget = -0.2",
        )
        .unwrap();
        let mut law = ComputedTorque::new(params).unwrap();
        law.reset(&plant()).unwrap();
        let signals = [0.3, 0.1, 0.05, 0.4];
        let mut efforts = [0.0; 2];
        let measurement = Measurement {
            time: 1.0,
            signals: &signals,
        };
        law.update(&measurement, 0.001, &mut efforts);
        // q̈ wanted: a = 100·(0.5 − 0.3) + 20·(0.5 − 0.1), b = 25·(−0.2 − 0.05) + 10·(0 − 0.4).
        let wanted = DVector::from_row_slice(&[28.0, -10.25]);
        let tau = TwoJoints::mass() * wanted + TwoJoints::bias(&[0.3, 0.05], &[0.1, 0.4]);
        assert!((efforts[1] - tau[0]).abs() < 1e-9, "{efforts:?} vs {tau}");
        assert!((efforts[0] - tau[1]).abs() < 1e-9, "{efforts:?} vs {tau}");
    }

    #[test]
    fn coordinates_unnamed_undriven_or_unknown_are_refused_by_name() {
        let refusal = |text: &str, plant: PlantInterface| {
            let params: ComputedTorqueParams = toml::from_str(text).unwrap();
            let mut law = ComputedTorque::new(params).unwrap();
            law.reset(&plant).unwrap_err().to_string()
        };
        let both = "[joints.a]\nkp = 1.0\n[joints.b]\nkp = 1.0";
        let unnamed = refusal("[joints.a]\nkp = 1.0", plant());
        assert!(
            unnamed.contains("`b` has no [controller.params.joints.b]"),
            "{unnamed}"
        );
        let unknown = refusal("[joints.c]\nkp = 1.0", plant());
        assert!(
            unknown.contains("joints.c: not an independent coordinate"),
            "{unknown}"
        );
        let mut one_motor = plant();
        one_motor.actuators.truncate(1);
        let undriven = refusal(both, one_motor);
        assert!(undriven.contains("actuator on joint `a`"), "{undriven}");
        let no_model = refusal(
            both,
            PlantInterface {
                dynamics: None,
                ..plant()
            },
        );
        assert!(no_model.contains("equations of motion"), "{no_model}");
    }
}
