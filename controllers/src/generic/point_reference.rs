//! A point's reference for `joint-pid` (`[controller.params.points.<name>] x = …, y = …`, each
//! any [`Reference`], m): the joints it moves are given the positions that put the scenario's
//! point `[points.<name>]` there, by the twin's own kinematics (loops closed), and the rates
//! that move it at the reference's rate.
//!
//! Each update solves p(q) = p_r(t) for the moved joints by Gauss–Newton from the last
//! solution (the first from the measured positions, so the mechanism keeps the branch it is
//! on), the other independent coordinates held where they are measured; the Jacobian is taken
//! by central differences of the engine's point. More joints than components take the least
//! motion (J⁺ = Jᵀ(JJᵀ)⁻¹). The rates are q̇_r = J⁺·ṗ_r. A point out of reach takes the joints
//! as near as the steps get it, at rest, and the law says so in `<point>.reach`: the distance
//! still to go, m. The path may not start where the mechanism is stretched out straight (or at
//! any place where J loses rank): there the angles cannot say which way to bend.

use super::model::coordinate_signals;
use framework::{ControllerError, Dynamics, Measurement, PlantInterface};
use models::reference::Reference;
use nalgebra::{DMatrix, DVector};
use serde::Deserialize;
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

/// Newton iterations per update at most, and the distance counted as reached, m.
const ITERATIONS: usize = 30;
const REACHED: f64 = 1e-12;
/// λ of the damped Gauss–Newton steps, m² (rad² or m² per m² of the point's motion).
const DAMPING: f64 = 1e-8;
/// The step of the central differences, rad or m.
const STEP: f64 = 1e-6;

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
        let mut q = self.solution.clone().unwrap_or_else(|| measured.clone());
        for (i, value) in measured.iter().enumerate() {
            if !self.moved.contains(&i) {
                q[i] = *value;
            }
        }
        let samples: Vec<_> = (self.components.iter())
            .map(|(_, _, r)| r.sample(measurement.time))
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
}
