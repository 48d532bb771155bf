//! A point's reference for `joint-pid` and `computed-torque` (`[controller.params.points.<name>]
//! x = …, y = …`, each any [`Reference`], m): the joints it moves are given the positions that
//! put the scenario's point `[points.<name>]` there, by the twin's own kinematics (loops closed),
//! the rates that move it at the reference's rate, and (for computed-torque) the accelerations.
//!
//! Each update solves p(q) = p_r(t) for the moved joints by Gauss–Newton from the last
//! solution (the first from the measured positions, so the mechanism keeps the branch it is
//! on), the other independent coordinates held where they are measured; the Jacobian is taken
//! by central differences of the engine's point. More joints than components take the least
//! motion (J⁺ = Jᵀ(JJᵀ)⁻¹). The rates are q̇_r = J⁺·ṗ_r. A point out of reach takes the joints
//! as near as the steps get it, at rest, and the law says so in `<point>.reach`: the distance
//! still to go, m. The accelerations are q̈_r = J⁺·(p̈_r − ∂²p[q̇_r, q̇_r]): the path's
//! acceleration less what the joints' rates make by themselves along a curved path (its second
//! derivative along q̇_r by central differences). The path may not start where the mechanism is stretched out straight (or at
//! any place where J loses rank): there the angles cannot say which way to bend.

use super::model::coordinate_signals;
use framework::{ControllerError, Dynamics, Measurement, PlantInterface};
use models::reference::Reference;
use nalgebra::{DMatrix, DVector};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::sync::Arc;

/// `[controller.params.points.<name>]`: the point's reference along x and y in the machine's
/// plane, m; a component left out is free.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PointReference {
    /// Along the plane's x, m.
    pub x: Option<Reference>,
    /// Along the plane's y (drawn up), m.
    pub y: Option<Reference>,
}

impl PointReference {
    /// The components given: (axis 0 for x, 1 for y; the reference).
    pub(crate) fn components(&self) -> impl Iterator<Item = (usize, &Reference)> {
        [&self.x, &self.y]
            .into_iter()
            .enumerate()
            .filter_map(|(axis, r)| r.as_ref().map(|r| (axis, r)))
    }
}

/// One joint a law names, for [`moved_joints`]: its name, whether it has a reference of its own
/// (or follows another), and its target.
pub(crate) struct NamedJoint<'a> {
    pub joint: &'a str,
    pub own_reference: bool,
    pub target: f64,
}

/// The joints of a law's `[controller.params.joints]`, as [`moved_joints`] reads them: `read`
/// gives each entry's (has a reference of its own, target).
pub(crate) fn named<J>(
    joints: &BTreeMap<String, J>,
    read: impl Fn(&J) -> (bool, f64),
) -> Vec<NamedJoint<'_>> {
    (joints.iter())
        .map(|(joint, j)| {
            let (own_reference, target) = read(j);
            NamedJoint {
                joint,
                own_reference,
                target,
            }
        })
        .collect()
}

/// Checks `points` against the joints a law names, and returns the joints they move: those with
/// no reference of their own. Each point names a component; the points ask no more components
/// than joints they move, and those joints take no target.
pub(crate) fn moved_joints(
    controller: &str,
    points: &BTreeMap<String, PointReference>,
    joints: &[NamedJoint],
) -> Result<Vec<String>, ControllerError> {
    let refuse = |key: String, reason: String| {
        Err(ControllerError::parameter_table(controller, key, reason))
    };
    let mut components = 0;
    for (name, point) in points {
        let key = format!("points.{name}");
        if point.components().next().is_none() {
            let reason = "give the point's path along x, y or both: x = { kind = … }";
            return refuse(key, reason.into());
        }
        for (axis, reference) in point.components() {
            let key = format!("{key}.{}", ["x", "y"][axis]);
            super::joint_reference::check(controller, &key, reference)?;
            components += 1;
        }
    }
    if points.is_empty() {
        return Ok(Vec::new());
    }
    let moved: Vec<&NamedJoint> = joints.iter().filter(|j| !j.own_reference).collect();
    if let Some(j) = moved.iter().find(|j| j.target != 0.0) {
        let reason = "a joint the points move takes its setpoint from them; leave target out";
        return refuse(format!("joints.{}.target", j.joint), reason.into());
    }
    if components > moved.len() {
        return refuse(
            "points".into(),
            format!(
                "{components} components of points to follow and {} joints to move them (the joints with no reference of their own): name more joints, or fewer components",
                moved.len()
            ),
        );
    }
    Ok(moved.iter().map(|j| j.joint.to_owned()).collect())
}

/// Newton iterations per update at most, and the distance counted as reached, m.
const ITERATIONS: usize = 30;
const REACHED: f64 = 1e-12;
/// λ of the damped Gauss–Newton steps, m² (rad² or m² per m² of the point's motion).
const DAMPING: f64 = 1e-8;
/// The step of the central differences, rad or m.
const STEP: f64 = 1e-6;
/// How far along the rates the second differences probe, rad or m.
const CURVE_STEP: f64 = 1e-4;

/// The points' references bound to the plant's kinematics.
pub(crate) struct PointFollower {
    dynamics: Arc<dyn Dynamics>,
    /// (point name, axis, reference) per component followed.
    components: Vec<(String, usize, Reference)>,
    /// Position signal of every independent coordinate.
    positions: Vec<usize>,
    /// Which coordinates the points move (indices into the coordinates).
    moved: Vec<usize>,
    /// The last solution, every coordinate.
    solution: Option<Vec<f64>>,
    /// Per point, how far the last solution leaves it from its reference, m.
    pub reach: Vec<f64>,
}

impl PointFollower {
    /// Binds `points` to `plant`, moving the joints `moved` (URDF names).
    pub(crate) fn bind(
        controller: &str,
        points: &[(String, PointReference)],
        moved: &[String],
        plant: &PlantInterface,
    ) -> Result<Self, ControllerError> {
        let dynamics = plant.dynamics(controller)?.clone();
        let signals = coordinate_signals(plant, dynamics.as_ref())?;
        let coordinates = dynamics.coordinates();
        let mut moved_at = Vec::with_capacity(moved.len());
        for joint in moved {
            let at = coordinates.iter().position(|c| &c.joint == joint);
            moved_at.push(at.ok_or_else(|| {
                ControllerError::parameter_table(
                    controller,
                    format!("joints.{joint}"),
                    "a point moves only independent coordinates of the mechanism; give this joint its own target or reference",
                )
            })?);
        }
        let mut components = Vec::new();
        for (name, point) in points {
            if !dynamics.points().contains(name) {
                return Err(ControllerError::parameter_table(
                    controller,
                    format!("points.{name}"),
                    format!("the scenario has no point `{name}`: add [points.{name}] link = …, at = […]"),
                ));
            }
            for (axis, reference) in point.components() {
                let mut reference = reference.clone();
                let key = format!("points.{name}.{}", ["x", "y"][axis]);
                super::joint_reference::read_table(
                    controller,
                    &key,
                    &mut reference,
                    plant,
                    framework::EffortKind::Force,
                )?;
                components.push((name.clone(), axis, reference));
            }
        }
        Ok(Self {
            dynamics,
            components,
            positions: signals.iter().map(|s| s.position).collect(),
            moved: moved_at,
            solution: None,
            reach: vec![0.0; points.len()],
        })
    }

    /// Per moved joint (the order given at binding): its position and rate references at this
    /// measurement.
    pub(crate) fn targets(&mut self, measurement: &Measurement) -> Vec<[f64; 2]> {
        let measured: Vec<f64> = self.positions.iter().map(|&s| measurement.get(s)).collect();
        self.targets_at(measurement.time, measured)
    }

    /// Per moved joint, its position and rate references at the path's start, solved from the
    /// coordinates `start` (the run's `[initial]`, which says which way the mechanism bends);
    /// `None` where the path's first point is out of reach from there.
    pub(crate) fn first(&mut self, start: Vec<f64>) -> Option<Vec<[f64; 2]>> {
        self.solution = None;
        let targets = self.targets_at(0.0, start);
        (self.reach.iter().all(|&r| r <= 1e-9)).then_some(targets)
    }

    /// [`PointFollower::targets`] at `time` with the coordinates `measured`.
    fn targets_at(&mut self, time: f64, measured: Vec<f64>) -> Vec<[f64; 2]> {
        let mut q = self.solution.clone().unwrap_or_else(|| measured.clone());
        for (i, value) in measured.iter().enumerate() {
            if !self.moved.contains(&i) {
                q[i] = *value;
            }
        }
        let samples: Vec<_> = (self.components.iter())
            .map(|(_, _, r)| r.sample(time))
            .collect();
        let wanted = DVector::from_iterator(samples.len(), samples.iter().map(|s| s.position));
        let rates = DVector::from_iterator(samples.len(), samples.iter().map(|s| s.rate));
        let solved = self.solve(&mut q, &wanted);
        let q_rates = (solved.and_then(|_| self.jacobian(&q)))
            .and_then(|j| least_motion(&j, &rates))
            .unwrap_or_else(|| DVector::zeros(self.moved.len()));
        // Short of the path (out of reach), the nearest place the steps found, if the loops
        // close there.
        if solved.is_some() || self.places(&q).is_some() {
            self.solution = Some(q.clone());
        }
        let q = self.solution.as_deref().unwrap_or(&q);
        (self.moved.iter().enumerate())
            .map(|(k, &i)| [q[i], q_rates[k]])
            .collect()
    }

    /// Per moved joint (as [`PointFollower::targets`]), its acceleration reference at `time`,
    /// with `targets` the last update's: J⁺·(p̈_r − ∂²p[q̇_r, q̇_r]) at the last solution. Zero
    /// where there is none (the loops do not close there, or J loses rank).
    pub(crate) fn accelerations(&self, time: f64, targets: &[[f64; 2]]) -> Vec<f64> {
        self.path_accelerations(time, targets).map_or_else(
            || vec![0.0; self.moved.len()],
            |a| a.iter().copied().collect(),
        )
    }

    fn path_accelerations(&self, time: f64, targets: &[[f64; 2]]) -> Option<DVector<f64>> {
        let q = self.solution.as_deref()?;
        let wanted = (self.components.iter()).map(|(_, _, r)| r.sample(time).acceleration);
        let mut wanted = DVector::from_iterator(self.components.len(), wanted);
        let speed = targets.iter().map(|t| t[1] * t[1]).sum::<f64>().sqrt();
        if speed > 0.0 {
            let s = CURVE_STEP / speed;
            let along = |sign: f64| {
                let mut probe = q.to_vec();
                for (k, &i) in self.moved.iter().enumerate() {
                    probe[i] += sign * s * targets[k][1];
                }
                self.places(&probe)
            };
            let (ahead, here, behind) = (along(1.0)?, self.places(q)?, along(-1.0)?);
            wanted -= (ahead - 2.0 * here + behind) / (s * s);
        }
        least_motion(&self.jacobian(q)?, &wanted)
    }

    /// The components' places at q, stacked; None where the loops do not close.
    fn places(&self, q: &[f64]) -> Option<DVector<f64>> {
        let mut out = DVector::zeros(self.components.len());
        for (k, (name, axis, _)) in self.components.iter().enumerate() {
            out[k] = self.dynamics.point(name, q).ok()?[*axis];
        }
        Some(out)
    }

    /// ∂p/∂q_moved at q by central differences.
    fn jacobian(&self, q: &[f64]) -> Option<DMatrix<f64>> {
        let mut j = DMatrix::zeros(self.components.len(), self.moved.len());
        let mut probe = q.to_vec();
        for (c, &i) in self.moved.iter().enumerate() {
            probe[i] = q[i] + STEP;
            let ahead = self.places(&probe)?;
            probe[i] = q[i] - STEP;
            let behind = self.places(&probe)?;
            probe[i] = q[i];
            j.set_column(c, &((ahead - behind) / (2.0 * STEP)));
        }
        Some(j)
    }

    /// Gauss–Newton on the moved coordinates towards `wanted`; records each point's distance
    /// left. Some when reached.
    fn solve(&mut self, q: &mut [f64], wanted: &DVector<f64>) -> Option<()> {
        let mut left = f64::INFINITY;
        for _ in 0..ITERATIONS {
            let residual = wanted - self.places(q)?;
            left = residual.amax();
            self.record_reach(&residual);
            if left <= REACHED {
                return Some(());
            }
            let step = damped_motion(&self.jacobian(q)?, &residual)?;
            for (k, &i) in self.moved.iter().enumerate() {
                q[i] += step[k];
            }
        }
        // Converged to rounding, short of the tolerance, still counts.
        (left <= 1e-9).then_some(())
    }

    /// Each point's distance from its reference in `residual` (stacked components).
    fn record_reach(&mut self, residual: &DVector<f64>) {
        self.reach.fill(0.0);
        let mut point = 0;
        for (k, (name, _, _)) in self.components.iter().enumerate() {
            if k > 0 && self.components[k - 1].0 != *name {
                point += 1;
            }
            self.reach[point] = self.reach[point].hypot(residual[k]);
        }
    }
}

/// A Gauss–Newton step damped by [`DAMPING`] (J⁺ = Jᵀ(JJᵀ + λI)⁻¹): it stays finite where
/// the mechanism is stretched out (J loses rank), and is the least-norm step elsewhere.
fn damped_motion(j: &DMatrix<f64>, b: &DVector<f64>) -> Option<DVector<f64>> {
    let rows = j.nrows();
    let y = (j * j.transpose() + DMatrix::identity(rows, rows) * DAMPING)
        .lu()
        .solve(b)?;
    let x = j.transpose() * y;
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// The least-norm solution of J·x = b (J with no more rows than columns, full row rank).
fn least_motion(j: &DMatrix<f64>, b: &DVector<f64>) -> Option<DVector<f64>> {
    let y = (j * j.transpose()).lu().solve(b)?;
    let x = j.transpose() * y;
    x.iter().all(|v| v.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use framework::{Actuator, Coordinate, EffortKind};

    /// A two-link arm hanging from the origin (links 0.3 and 0.25 m), its tip `tip`.
    struct Arm(Vec<Coordinate>);

    impl Dynamics for Arm {
        fn coordinates(&self) -> &[Coordinate] {
            &self.0
        }
        fn acceleration(
            &self,
            _: &[f64],
            _: &[f64],
            _: &[f64],
            _: &mut [f64],
        ) -> Result<(), String> {
            Ok(())
        }
        fn points(&self) -> Vec<String> {
            vec!["tip".into()]
        }
        fn point(&self, _: &str, q: &[f64]) -> Result<[f64; 2], String> {
            let (a, b) = (q[0], q[0] + q[1]);
            Ok([
                0.3 * a.sin() + 0.25 * b.sin(),
                -0.3 * a.cos() - 0.25 * b.cos(),
            ])
        }
    }

    fn plant() -> PlantInterface {
        let joint = |name: &str| Coordinate {
            joint: name.into(),
            kind: EffortKind::Torque,
        };
        let actuator = |name: &str| Actuator {
            joint: name.into(),
            kind: EffortKind::Torque,
            effort_limit: 10.0,
        };
        PlantInterface {
            machine: "generic".into(),
            signals: [
                "shoulder.position",
                "shoulder.velocity",
                "elbow.position",
                "elbow.velocity",
            ]
            .map(String::from)
            .into(),
            actuators: vec![actuator("shoulder"), actuator("elbow")],
            dynamics: Some(Arc::new(Arm(vec![joint("shoulder"), joint("elbow")]))),
            ..Default::default()
        }
    }

    #[test]
    fn the_joints_put_the_point_on_its_path_as_the_closed_form_inverse_kinematics_does() {
        let point: PointReference = toml::from_str(
            "x = { kind = \"ramp\", rate = 0.1 }\ny = { kind = \"constant\", value = -0.45 }",
        )
        .unwrap();
        let moved = ["shoulder", "elbow"].map(String::from);
        let mut follower =
            PointFollower::bind("joint-pid", &[("tip".into(), point)], &moved, &plant()).unwrap();
        // Start bent the negative way: the solution stays on that branch.
        let signals = [0.5, 0.0, -1.1, 0.0];
        for time in [0.0, 0.5, 1.0] {
            let targets = follower.targets(&Measurement {
                time,
                signals: &signals,
            });
            let (x, y, rate) = (0.1 * time, -0.45_f64, [0.1, 0.0]);
            // Closed form: the elbow from the law of cosines, the shoulder from the rest.
            let c = (x * x + y * y - 0.3f64.powi(2) - 0.25f64.powi(2)) / (2.0 * 0.3 * 0.25);
            let elbow = -c.acos();
            let shoulder = x.atan2(-y) - (0.25 * elbow.sin()).atan2(0.3 + 0.25 * elbow.cos());
            assert!(
                (targets[0][0] - shoulder).abs() < 1e-12,
                "{time}: {targets:?}"
            );
            assert!((targets[1][0] - elbow).abs() < 1e-12, "{time}: {targets:?}");
            // The rates move the tip at the path's rate: J·q̇ = ṗ.
            let q = [targets[0][0], targets[1][0]];
            let (a, b) = (q[0], q[0] + q[1]);
            let (w0, w1) = (targets[0][1], targets[1][1]);
            let vx = 0.3 * a.cos() * w0 + 0.25 * b.cos() * (w0 + w1);
            let vy = 0.3 * a.sin() * w0 + 0.25 * b.sin() * (w0 + w1);
            assert!(
                (vx - rate[0]).abs() < 1e-8 && (vy - rate[1]).abs() < 1e-8,
                "{vx} {vy}"
            );
            assert!(follower.reach[0] < 1e-12);
        }
        // Out of reach (0.6 m from the shoulder; the arm spans 0.55): the joints stay at the
        // last solution, and the distance left is said.
        let far: PointReference =
            toml::from_str("y = { kind = \"constant\", value = -0.6 }").unwrap();
        let mut follower =
            PointFollower::bind("joint-pid", &[("tip".into(), far)], &moved, &plant()).unwrap();
        let targets = follower.targets(&Measurement {
            time: 0.0,
            signals: &signals,
        });
        assert!(follower.reach[0] > 0.04, "{:?} {targets:?}", follower.reach);
    }

    #[test]
    fn the_accelerations_are_the_rates_own_derivative_along_the_path() {
        // A path that curves in joint space: the tip along a circle's arc at a varying speed.
        let point: PointReference = toml::from_str(
            "x = { kind = \"sine\", amplitude = 0.05, angular_frequency = 3.0 }\n\
             y = { kind = \"ramp\", rate = 0.02, initial = -0.45 }",
        )
        .unwrap();
        let moved = ["shoulder", "elbow"].map(String::from);
        let mut follower = PointFollower::bind(
            "computed-torque",
            &[("tip".into(), point)],
            &moved,
            &plant(),
        )
        .unwrap();
        let signals = [0.5, 0.0, -1.1, 0.0];
        let at = |follower: &mut PointFollower, time: f64| {
            follower.targets(&Measurement {
                time,
                signals: &signals,
            })
        };
        let (time, delta) = (0.7, 1e-4);
        at(&mut follower, 0.0);
        let before = at(&mut follower, time - delta);
        let after = at(&mut follower, time + delta);
        let now = at(&mut follower, time);
        let accelerations = follower.accelerations(time, &now);
        for k in 0..2 {
            let differenced = (after[k][1] - before[k][1]) / (2.0 * delta);
            assert!(
                (accelerations[k] - differenced).abs() < 1e-5 * differenced.abs().max(1.0),
                "joint {k}: {} against {differenced} rad/s²",
                accelerations[k]
            );
        }
    }
}
