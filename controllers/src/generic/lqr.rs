//! `lqr`: a linear-quadratic regulator about the reference's first point, designed at reset on
//! the twin's own linearisation of the mechanism, for any mechanism (underactuated ones too: the
//! cart-pole's pole balanced upright by its cart).
//!
//! The state is the independent coordinates and their rates, x = (q, q̇); the inputs every
//! actuator's effort. At reset the law finds the efforts u_eq that hold the reference's first
//! point x_r(0) (least squares on q̈(x_r, u) = 0; refused if the actuators cannot hold it there),
//! linearises ẋ = f(x, u) about (x_r(0), u_eq) by central differences of the engine's own
//! equations (as `twin linearize` does), and solves the regulator's Riccati equation
//! (`design::lqr`) for Q = diag(position_weight…, velocity_weight…), R = diag(effort_weight…).
//! The law, each period: `u = u_eq − K·(x − x_r(t))`, clipped to the actuators' limits; an angle's
//! error is taken the short way round.
//!
//! A point of the scenario may be given a path instead (`[controller.params.points.<name>]`
//! `x`, `y`, as joint-pid's and computed-torque's): the joints with no reference of their own
//! take the positions and rates that put it on its path, by the twin's own kinematics
//! ([`PointFollower`](super::point_reference)). The design's first point is where the path
//! starts, solved from the run's `[initial]` coordinates (which say which way the mechanism
//! bends); `<name>.reach` says how far off the point is.

use super::joint_reference;
use super::model::{coordinate_signals, linearise, position_error, response, CoordinateSignals};
use super::point_reference::{moved_joints, named, PointFollower, PointReference};
use crate::check::{finite, non_negative, positive};
use crate::design::lqr::lqr;
use framework::{parse_params, Entry, Event, EventKind, ANY_MACHINE};
use framework::{Controller, ControllerError, Dynamics, Measurement, PlantInterface};
use framework::{SignalSpec, Unit};
use models::reference::Reference;
use nalgebra::{DMatrix, DVector};
use serde::Deserialize;
use std::collections::BTreeMap;

const NAME: &str = "lqr";

/// Largest acceleration (rad/s² or m/s², per unit of the largest free one) left at the
/// reference's first point under u_eq: more, and it is no equilibrium the actuators can hold.
const EQUILIBRIUM_TOLERANCE: f64 = 1e-6;

/// Parameters of `lqr`: per joint, by the URDF's name.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LqrParams {
    /// `[controller.params.joints.<joint>]`: the independent coordinates' weights and
    /// references (a coordinate not named: no weight, reference 0) and every actuator's
    /// `effort_weight`.
    #[serde(default)]
    pub joints: BTreeMap<String, LqrJoint>,
    /// `[controller.params.points.<name>]`: a point of the scenario's `[points]` on a path (`x`,
    /// `y`); it moves every joint named here that has no `reference` of its own.
    #[serde(default)]
    pub points: BTreeMap<String, PointReference>,
}

/// One joint's weights and reference (SI).
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct LqrJoint {
    /// Q's weight on the coordinate's position error, 1/rad² or 1/m².
    pub position_weight: f64,
    /// Q's weight on its rate error, s²/rad² or s²/m².
    pub velocity_weight: f64,
    /// R's weight on the joint's actuator, 1/(N·m)² or 1/N²; > 0 for every actuator.
    pub effort_weight: f64,
    /// The coordinate's reference, rad or m; none: `target` held.
    pub reference: Option<Reference>,
    /// The position held without a reference, rad or m.
    pub target: f64,
}

/// A joint's checked weights and reference.
#[derive(Debug, Clone, PartialEq)]
pub struct LqrWeights {
    /// The joint, as the URDF names it.
    pub joint: String,
    /// Q on position and on rate.
    pub position_weight: f64,
    /// Q on the rate.
    pub velocity_weight: f64,
    /// R on its actuator (0: not given).
    pub effort_weight: f64,
    /// What it tracks.
    pub reference: Reference,
}

/// Checks the weights and references (a joint without a reference holds its `target`).
pub fn weights(params: &LqrParams) -> Result<Vec<LqrWeights>, ControllerError> {
    let mut weights = Vec::with_capacity(params.joints.len());
    for (joint, j) in &params.joints {
        let key = |k: &str| format!("joints.{joint}.{k}");
        let target = finite(NAME, &key("target"), j.target)?;
        let reference = (j.reference.clone()).unwrap_or(Reference::Constant { value: target });
        joint_reference::check(NAME, &key("reference"), &reference)?;
        weights.push(LqrWeights {
            joint: joint.clone(),
            position_weight: non_negative(NAME, &key("position_weight"), j.position_weight)?,
            velocity_weight: non_negative(NAME, &key("velocity_weight"), j.velocity_weight)?,
            effort_weight: non_negative(NAME, &key("effort_weight"), j.effort_weight)?,
            reference,
        });
    }
    moved_by_points(params)?;
    Ok(weights)
}

/// The regulator designed at the reference's first point.
#[derive(Debug, Clone, PartialEq)]
pub struct LqrGains {
    /// The efforts that hold the point, per actuator.
    pub equilibrium: DVector<f64>,
    /// K, actuators × 2·coordinates.
    pub gain: DMatrix<f64>,
    /// The closed loop's slowest pole's real part, 1/s (for the design note).
    pub slowest: f64,
}

/// Designs the regulator on `dynamics` about x0 (positions, then rates) for the weights `q` (per
/// state) and `r` (per actuator).
pub fn design(
    dynamics: &dyn Dynamics,
    x0: &[f64],
    q: &[f64],
    r: &[f64],
) -> Result<LqrGains, ControllerError> {
    let table = |reason: String| ControllerError::parameter_table(NAME, "joints", reason);
    let k = x0.len() / 2;
    let at_point = response(dynamics, r.len(), &x0[..k], &x0[k..]).map_err(table)?;
    let equilibrium = (at_point.per_effort.clone().svd(true, true))
        .solve(&-&at_point.free, 1e-12)
        .map_err(|e| table(e.to_string()))?;
    let left = &at_point.free + &at_point.per_effort * &equilibrium;
    let scale = at_point.free.amax().max(1.0);
    if left.amax() > EQUILIBRIUM_TOLERANCE * scale {
        return Err(table(format!(
            "the references' first point is no equilibrium the actuators can hold ({:.3e} rad/s² or m/s² left); start the references where it is one",
            left.amax()
        )));
    }
    let model = linearise(dynamics, x0, equilibrium.as_slice()).map_err(table)?;
    let solved = lqr(
        &model.a,
        &model.b,
        &DMatrix::from_diagonal(&DVector::from_row_slice(q)),
        &DMatrix::from_diagonal(&DVector::from_row_slice(r)),
    )
    .map_err(|e| table(e.to_string()))?;
    let closed = &model.a - &model.b * &solved.gain;
    let slowest = (closed.complex_eigenvalues().iter())
        .map(|l| l.re)
        .fold(f64::NEG_INFINITY, f64::max);
    Ok(LqrGains {
        equilibrium,
        gain: solved.gain,
        slowest,
    })
}

/// The running law.
pub struct Lqr {
    weights: Vec<LqrWeights>,
    /// Per coordinate: its signals and reference.
    coordinates: Vec<(CoordinateSignals, Reference)>,
    /// The points' references, the joints they move, and per coordinate which moved joint it is.
    points: Vec<(String, PointReference)>,
    moved: Vec<String>,
    moved_at: Vec<Option<usize>>,
    follower: Option<PointFollower>,
    /// The coordinates' joints (fixed at reset).
    names: Vec<String>,
    gains: Option<LqrGains>,
    limits: Vec<f64>,
    error: DVector<f64>,
    events: Vec<Event>,
}

impl Lqr {
    /// Checks the parameters; the regulator is designed when bound to the plant.
    pub fn new(params: LqrParams) -> Result<Self, ControllerError> {
        let moved = moved_by_points(&params)?;
        Ok(Self {
            weights: weights(&params)?,
            coordinates: Vec::new(),
            points: params.points.into_iter().collect(),
            moved,
            moved_at: Vec::new(),
            follower: None,
            names: Vec::new(),
            gains: None,
            limits: Vec::new(),
            error: DVector::zeros(0),
            events: Vec::new(),
        })
    }

    /// Binds the coordinates to their weights, signals and references; the state weights (q)
    /// and the input weights (r) in the model's orders.
    fn bind(
        &mut self,
        plant: &PlantInterface,
        dynamics: &dyn Dynamics,
    ) -> Result<(Vec<f64>, Vec<f64>), ControllerError> {
        let coordinates = dynamics.coordinates();
        let known = |joint: &str| {
            coordinates.iter().any(|c| c.joint == joint)
                || plant.actuators.iter().any(|a| a.joint == joint)
        };
        if let Some(w) = self.weights.iter().find(|w| !known(&w.joint)) {
            return Err(ControllerError::parameter_table(
                NAME,
                format!("joints.{}", w.joint),
                "neither an independent coordinate of the mechanism nor an actuator",
            ));
        }
        let find = |joint: &str| self.weights.iter().find(|w| w.joint == joint);
        let signals = coordinate_signals(plant, dynamics)?;
        let (mut positions, mut rates) = (Vec::new(), Vec::new());
        self.coordinates.clear();
        self.names = coordinates.iter().map(|c| c.joint.clone()).collect();
        for (c, signals) in coordinates.iter().zip(signals) {
            let w = find(&c.joint);
            positions.push(w.map_or(0.0, |w| w.position_weight));
            rates.push(w.map_or(0.0, |w| w.velocity_weight));
            let mut reference =
                w.map_or(Reference::Constant { value: 0.0 }, |w| w.reference.clone());
            let key = format!("joints.{}.reference", c.joint);
            joint_reference::read_table(NAME, &key, &mut reference, plant, c.kind)?;
            self.coordinates.push((signals, reference));
        }
        let r = (plant.actuators.iter())
            .map(|a| {
                let weight = find(&a.joint).map_or(0.0, |w| w.effort_weight);
                positive(NAME, &format!("joints.{}.effort_weight", a.joint), weight)
            })
            .collect::<Result<_, _>>()?;
        positions.extend(rates);
        Ok((positions, r))
    }
}

impl Lqr {
    /// The design's point x_r(0) (positions, then rates): each coordinate's reference at 0, the
    /// points' joints where the path starts, solved from the run's `[initial]` coordinates.
    fn first_point(
        &mut self,
        plant: &PlantInterface,
        dynamics: &dyn Dynamics,
    ) -> Result<Vec<f64>, ControllerError> {
        let mut first: Vec<[f64; 2]> = (self.coordinates.iter())
            .map(|(_, reference)| {
                let sample = reference.sample(0.0);
                [sample.position, sample.rate]
            })
            .collect();
        self.moved_at = (self.names.iter())
            .map(|name| self.moved.iter().position(|m| m == name))
            .collect();
        self.follower = None;
        if !self.points.is_empty() {
            let refuse = |reason: String| ControllerError::parameter_table(NAME, "points", reason);
            let mut follower = PointFollower::bind(NAME, &self.points, &self.moved, plant)?;
            let start = dynamics.start().ok_or_else(|| {
                refuse("the plant does not say where the run starts, which the path's first point is solved from".into())
            })?;
            let targets = follower.first(start).ok_or_else(|| {
                let off = follower.reach.iter().fold(0.0_f64, |a, &b| a.max(b));
                refuse(format!("the path's first point is out of reach from the run's [initial] coordinates ({off:.3e} m off): start the path where the mechanism reaches"))
            })?;
            for (slot, m) in first.iter_mut().zip(&self.moved_at) {
                if let Some(m) = m {
                    *slot = targets[*m];
                }
            }
            self.follower = Some(follower);
        }
        let positions = first.iter().map(|f| f[0]);
        Ok(positions.chain(first.iter().map(|f| f[1])).collect())
    }
}

/// The joints the points move (those named with no reference of their own), checked.
fn moved_by_points(params: &LqrParams) -> Result<Vec<String>, ControllerError> {
    let joints = named(&params.joints, |j| (j.reference.is_some(), j.target));
    moved_joints(NAME, &params.points, &joints)
}

pub(crate) fn entry() -> Entry {
    Entry {
        name: NAME,
        machine: ANY_MACHINE,
        summary: "a linear-quadratic regulator about the references, designed on the mechanism's own linearisation",
        build: |table| Ok(Box::new(Lqr::new(parse_params(NAME, table)?)?)),
    }
}

impl Controller for Lqr {
    fn name(&self) -> &str {
        NAME
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        let dynamics = plant.dynamics(NAME)?;
        let (q, r) = self.bind(plant, dynamics.as_ref())?;
        let x0 = self.first_point(plant, dynamics.as_ref())?;
        let gains = design(dynamics.as_ref(), &x0, &q, &r)?;
        self.events.clear();
        self.events.push(Event::info(
            EventKind::Design,
            format!(
                "lqr: designed about the references' first point; the closed loop's slowest pole at {:.3} 1/s",
                gains.slowest
            ),
        ));
        self.limits = plant.actuators.iter().map(|a| a.effort_limit).collect();
        self.error = DVector::zeros(x0.len());
        self.gains = Some(gains);
        Ok(())
    }

    fn update(&mut self, measurement: &Measurement, _period: f64, efforts: &mut [f64]) {
        let Some(gains) = &self.gains else {
            return;
        };
        let k = self.coordinates.len();
        let from_points = self.follower.as_mut().map(|f| f.targets(measurement));
        for (i, (signals, reference)) in self.coordinates.iter().enumerate() {
            let [position, rate] = match (self.moved_at[i], &from_points) {
                (Some(m), Some(targets)) => targets[m],
                _ => {
                    let r = reference.sample(measurement.time);
                    [r.position, r.rate]
                }
            };
            let q = measurement.get(signals.position);
            // x − x_r: the measured less the reference.
            self.error[i] = -position_error(position, q, signals.turns);
            self.error[k + i] = measurement.get(signals.velocity) - rate;
        }
        let u = &gains.equilibrium - &gains.gain * &self.error;
        for ((effort, u), limit) in efforts.iter_mut().zip(u.iter()).zip(&self.limits) {
            *effort = u.clamp(-limit, *limit);
        }
    }

    fn internals(&self) -> Vec<SignalSpec> {
        let errors = (self.names.iter())
            .map(|joint| SignalSpec::new(format!("{joint}.error"), Unit::Dimensionless, "errors"));
        let reach = (self.points.iter())
            .map(|(name, _)| SignalSpec::new(format!("{name}.reach"), Unit::Metre, "errors"));
        errors.chain(reach).collect()
    }

    fn internal_values(&self, values: &mut [f64]) {
        // The position errors, reference − measured.
        let k = self.names.len();
        for (value, error) in values.iter_mut().zip(self.error.iter().take(k)) {
            *value = -error;
        }
        if let Some(follower) = &self.follower {
            for (value, distance) in values.iter_mut().skip(k).zip(&follower.reach) {
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
    use framework::{Actuator, Coordinate, EffortKind};
    use std::sync::Arc;

    /// A mass of 1 kg on a slide, a force u and a pull `drift` (N): q̈ = u + drift.
    struct Slide {
        coordinates: Vec<Coordinate>,
        drift: f64,
    }

    impl Dynamics for Slide {
        fn coordinates(&self) -> &[Coordinate] {
            &self.coordinates
        }

        fn acceleration(
            &self,
            _position: &[f64],
            _velocity: &[f64],
            efforts: &[f64],
            acceleration: &mut [f64],
        ) -> Result<(), String> {
            acceleration[0] = efforts[0] + self.drift;
            Ok(())
        }
    }

    fn plant(drift: f64) -> PlantInterface {
        PlantInterface {
            machine: "generic".into(),
            signals: ["x.position", "x.velocity"].map(String::from).into(),
            actuators: vec![Actuator {
                joint: "x".into(),
                kind: EffortKind::Force,
                effort_limit: 100.0,
            }],
            dynamics: Some(Arc::new(Slide {
                coordinates: vec![Coordinate {
                    joint: "x".into(),
                    kind: EffortKind::Force,
                }],
                drift,
            })),
            ..Default::default()
        }
    }

    #[test]
    fn the_double_integrators_regulator_is_the_textbook_one() {
        // Q = I, R = 1 on q̈ = u: K = [1, √3]; the drift of −2 N is held by u_eq = 2 N.
        let params: LqrParams = toml::from_str(
            "[joints.x]\nposition_weight = 1.0\nvelocity_weight = 1.0\neffort_weight = 1.0\ntarget = 0.5",
        )
        .unwrap();
        let mut law = Lqr::new(params).unwrap();
        law.reset(&plant(-2.0)).unwrap();
        let gains = law.gains.clone().unwrap();
        assert!((gains.gain[(0, 0)] - 1.0).abs() < 1e-6, "{}", gains.gain);
        assert!(
            (gains.gain[(0, 1)] - 3f64.sqrt()).abs() < 1e-6,
            "{}",
            gains.gain
        );
        assert!((gains.equilibrium[0] - 2.0).abs() < 1e-12);
        let signals = [0.4, 0.1];
        let mut efforts = [0.0];
        let measurement = Measurement {
            time: 0.3,
            signals: &signals,
        };
        law.update(&measurement, 0.001, &mut efforts);
        let expected = 2.0 - (gains.gain[(0, 0)] * -0.1 + gains.gain[(0, 1)] * 0.1);
        assert!((efforts[0] - expected).abs() < 1e-12, "{efforts:?}");
    }

    #[test]
    fn an_actuator_without_an_effort_weight_is_refused_by_name() {
        let unweighted: LqrParams = toml::from_str("[joints.x]\nposition_weight = 1.0").unwrap();
        let error = Lqr::new(unweighted)
            .unwrap()
            .reset(&plant(0.0))
            .unwrap_err();
        assert!(
            error
                .to_string()
                .contains("joints.x.effort_weight = 0: must be > 0"),
            "{error}"
        );
        let params: LqrParams =
            toml::from_str("[joints.x]\nposition_weight = 1.0\neffort_weight = 1.0").unwrap();
        let mut law = Lqr::new(params).unwrap();
        let mut plant = plant(0.0);
        plant.actuators[0].joint = "y".into();
        let error = law.reset(&plant).unwrap_err().to_string();
        assert!(error.contains("joints.y.effort_weight"), "{error}");
    }
}
