//! The exact engine's equations of motion as a first-order system ẋ = f(x, u) on a minimal set
//! of coordinates, evaluated at any state without stepping time: what a linearisation
//! differentiates.
//!
//! With loop joints the tree's n coordinates q are bound by φ(q) = 0 (m independent rows). The
//! constraint Jacobian G = ∂φ/∂q at the operating point is reduced by Gaussian elimination with
//! pivoting: its m pivot columns are the *dependent* coordinates q_d, the n − m others the
//! *independent* ones q_i (an actuated joint is kept independent where possible, so the
//! Whitworth linkage is described by its crank). The state is x = (q_i, q̇_i): for a given x the
//! dependent coordinates are found by Newton on φ(q_i, q_d) = 0 and their rates from
//! G_d·q̇_d = −G_i·q̇_i; q̈ then comes from the constrained equations of [`super::dynamics`], of
//! which the independent rows are f. So A carries no constraint modes.
//!
//! Left out, as not differentiable: joint limits (stops), dry friction. Process loads enter with
//! the slopes the machine declares (`Load::damping` ∂F/∂v and `Load::stiffness` ∂F/∂p), measured
//! from the operating point, as the engine integrates them over a step.

use super::dynamics::{HeldLoad, Inputs};
use super::exact::{ExactEngine, ExactSettings};
use super::options::Integrator;
use super::state::{Load, MechanismState};
use crate::mechanism::{Inertial, JointMotion, Mechanism};
use nalgebra::{DMatrix, DVector};

/// Newton iterations that bring the dependent coordinates onto the loops.
const CLOSURE_ITERATIONS: usize = 20;
/// Largest constraint residual (m, rad) accepted, for coordinates up to 1 in size; a crank
/// turned many times has angles whose sines are only known to their size × ε, and the
/// tolerance grows with them.
const CLOSURE_TOLERANCE: f64 = 1e-13;
/// Largest step of a coordinate (rad or m) between two closure solves of a continuation.
const CONTINUATION_STEP: f64 = 0.05;
/// Pivots below this share of G's largest entry make a constraint row redundant.
const REDUNDANT_PIVOT: f64 = 1e-9;

/// The mechanism at an operating point, reduced to its independent coordinates.
#[derive(Clone)]
pub struct ReducedDynamics {
    engine: ExactEngine,
    gravity: [f64; 2],
    /// The operating point's coordinates (Rapier's signs): every Newton solve starts there.
    q0: Vec<f64>,
    /// Generalized coordinates kept as states, and those the loops determine.
    independent: Vec<usize>,
    dependent: Vec<usize>,
    /// Rows of φ that are not redundant.
    rows: Vec<usize>,
    /// The process loads of the operating point, as the engine holds them over a step.
    loads: Vec<HeldLoad>,
    efforts: Vec<f64>,
    acceleration: Vec<f64>,
}

/// Why a state cannot be evaluated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ReducedError {
    #[error("the loop closures do not converge at this state (residual {residual:e})")]
    Closure { residual: f64 },
}

impl ReducedDynamics {
    /// The mechanism at `state` (joint positions and velocities), with the process `loads` acting
    /// there; `actuated` tree joints are preferred as independent coordinates.
    pub fn new(
        mechanism: &Mechanism,
        gravity: [f64; 2],
        state: &MechanismState,
        loads: &[Load],
        actuated: &[usize],
    ) -> Self {
        let settings = ExactSettings {
            dt: 0.0,
            gravity,
            substeps: 1,
            integrator: Integrator::Rk4,
        };
        let mut engine = ExactEngine::new(mechanism, settings);
        let model = &engine.model;
        for (j, dof) in model.dof_of_joint.iter().enumerate() {
            if let Some(g) = *dof {
                engine.q[g] = model.sign[g] * state.joint_positions[j];
                engine.v[g] = model.sign[g] * state.joint_velocities[j];
            }
        }
        let preferred: Vec<usize> = actuated
            .iter()
            .filter_map(|&j| model.dof_of_joint.get(j).copied().flatten())
            .collect();
        let n = model.dofs();
        engine
            .rapier
            .pose(&model.mechanism, &engine.q, &mut engine.kin);
        let (rows, dependent) = if model.constraint_count > 0 {
            engine.dynamics.constraints(model, &engine.kin, None);
            pivots(&engine.dynamics.g, model.constraint_count, n, &preferred)
        } else {
            (Vec::new(), Vec::new())
        };
        let independent = (0..n).filter(|g| !dependent.contains(g)).collect();
        let loads = loads
            .iter()
            .map(|load| {
                let [vx, vy, _] = engine.kin.point_velocity(load.link, load.point, &engine.v);
                HeldLoad::new(load, &engine.kin.frames[load.link], [vx, vy])
            })
            .collect();
        Self {
            q0: engine.q.clone(),
            gravity,
            independent,
            dependent,
            rows,
            loads,
            efforts: vec![0.0; n],
            acceleration: vec![0.0; n],
            engine,
        }
    }

    /// The tree joint of each independent coordinate: the state is their positions, then their
    /// velocities (URDF sense).
    pub fn coordinates(&self) -> Vec<usize> {
        let model = &self.engine.model;
        self.independent
            .iter()
            .filter_map(|&g| model.dof_of_joint.iter().position(|&d| d == Some(g)))
            .collect()
    }

    /// x at the operating point: positions, then velocities of the independent coordinates.
    pub fn operating_state(&self) -> Vec<f64> {
        let model = &self.engine.model;
        let positions = self.independent.iter().map(|&g| model.sign[g] * self.q0[g]);
        let velocities = self
            .independent
            .iter()
            .map(|&g| model.sign[g] * self.engine.v[g]);
        let x: Vec<f64> = positions.collect();
        x.into_iter()
            .chain(velocities.collect::<Vec<_>>())
            .collect()
    }

    /// ẋ = f(x, u) into `rates`: `joint_efforts` per tree joint (URDF sign, N·m or N).
    pub fn rates(
        &mut self,
        x: &[f64],
        joint_efforts: &[f64],
        rates: &mut [f64],
    ) -> Result<(), ReducedError> {
        self.place(x)?;
        let ExactEngine {
            model,
            dynamics,
            q,
            v,
            kin,
            ..
        } = &mut self.engine;
        for (j, &effort) in joint_efforts.iter().enumerate() {
            if let Some(g) = model.dof_of_joint[j] {
                self.efforts[g] = model.sign[g] * effort;
            }
        }
        let inputs = Inputs {
            efforts: &self.efforts,
            loads: &self.loads,
            gravity: self.gravity,
        };
        dynamics.acceleration(model, kin, (q, v), &inputs, &mut self.acceleration);
        let k = self.independent.len();
        for (i, &g) in self.independent.iter().enumerate() {
            rates[i] = model.sign[g] * v[g];
            rates[k + i] = model.sign[g] * self.acceleration[g];
        }
        Ok(())
    }

    /// Holds `loads` as they act at x, in place of the operating point's: a model that moves
    /// through its process (a shadow following a machine) renews them each step, as the engine
    /// holds a step's process loads.
    pub fn hold_loads(&mut self, x: &[f64], loads: &[Load]) -> Result<(), ReducedError> {
        self.place(x)?;
        let engine = &self.engine;
        self.loads = loads
            .iter()
            .map(|load| {
                let [vx, vy, _] = engine.kin.point_velocity(load.link, load.point, &engine.v);
                HeldLoad::new(load, &engine.kin.frames[load.link], [vx, vy])
            })
            .collect();
        Ok(())
    }

    /// Starts the Newton solves of later states from x's coordinates: a model that moves far
    /// from its operating point (a crank turning) keeps the loops' branch it is on.
    pub fn recenter(&mut self, x: &[f64]) -> Result<(), ReducedError> {
        self.place(x)?;
        self.q0.clone_from(&self.engine.q);
        Ok(())
    }

    /// Recenters on `to` by way of `from` (a state the solves are centred near), in steps of at
    /// most [`CONTINUATION_STEP`] in any coordinate, so that a large move (a filter's first
    /// correction) follows the loops' branch instead of jumping to another assembly.
    ///
    /// A coordinate that turns freely (an unlimited revolute joint) is walked the shorter way to
    /// the angle `to` gives, modulo a turn, and set to `to` from there: the loops close the same
    /// every turn, so a crank a million turns on costs no more than one a degree on.
    pub fn recenter_along(&mut self, from: &[f64], to: &[f64]) -> Result<(), ReducedError> {
        let k = self.independent.len();
        let via: Vec<f64> = (0..k)
            .map(|i| match self.turns_freely(i) {
                true => {
                    let d = to[i] - from[i];
                    from[i] + (d - std::f64::consts::TAU * (d / std::f64::consts::TAU).round())
                }
                false => to[i],
            })
            .collect();
        let largest = (0..k).fold(0.0_f64, |m, i| m.max((via[i] - from[i]).abs()));
        let steps = (largest / CONTINUATION_STEP).ceil().max(1.0) as usize;
        let mut x = to.to_vec();
        for step in 1..=steps {
            let share = step as f64 / steps as f64;
            for i in 0..k {
                x[i] = from[i] + share * (via[i] - from[i]);
            }
            self.recenter(&x)?;
        }
        if via[..] != to[..k] {
            self.recenter(to)?;
        }
        Ok(())
    }

    /// Whether independent coordinate `i` is an unlimited revolute joint's.
    fn turns_freely(&self, i: usize) -> bool {
        let model = &self.engine.model;
        let g = self.independent[i];
        let joint = model.dof_of_joint.iter().position(|d| *d == Some(g));
        let revolute = joint.is_some_and(|j| {
            matches!(
                model.mechanism.joints[j].motion,
                JointMotion::Revolute { .. }
            )
        });
        revolute && model.limits[g].is_none()
    }

    /// Starts later loop-closure solves from `positions` (per tree joint, URDF sense): an
    /// assembly known to lie on the branch wanted, such as a configuration tracked along a run.
    pub fn anchor(&mut self, positions: &[f64]) {
        let model = &self.engine.model;
        for (j, dof) in model.dof_of_joint.iter().enumerate() {
            if let (Some(g), Some(&position)) = (*dof, positions.get(j)) {
                self.q0[g] = model.sign[g] * position;
            }
        }
    }

    /// Changes a link's mass properties for later evaluations.
    pub fn set_link_inertial(&mut self, link: usize, inertial: Inertial) {
        self.engine.set_link_inertial(link, inertial);
    }

    /// Changes a tree joint's viscous damping for later evaluations (dry friction is not in f).
    pub fn set_joint_damping(&mut self, joint: usize, damping: f64) {
        self.engine.set_joint_dynamics(joint, damping, 0.0);
    }

    /// The whole mechanism's state at x (every joint, link poses and velocities), for the
    /// machine's measured signals.
    pub fn read_state(
        &mut self,
        x: &[f64],
        state: &mut MechanismState,
    ) -> Result<(), ReducedError> {
        self.place(x)?;
        self.engine.read_state(state);
        Ok(())
    }

    /// Puts the mechanism at x: the independent coordinates as given, the dependent ones closing
    /// the loops, their rates from G·q̇ = 0.
    fn place(&mut self, x: &[f64]) -> Result<(), ReducedError> {
        let k = self.independent.len();
        let engine = &mut self.engine;
        engine.q.copy_from_slice(&self.q0);
        for (i, &g) in self.independent.iter().enumerate() {
            let sign = engine.model.sign[g];
            engine.q[g] = sign * x[i];
            engine.v[g] = sign * x[k + i];
        }
        let model = &engine.model;
        engine
            .rapier
            .pose(&model.mechanism, &engine.q, &mut engine.kin);
        if self.dependent.is_empty() {
            return Ok(());
        }
        let size = engine.q.iter().fold(1.0_f64, |m, q| m.max(q.abs()));
        let tolerance = CLOSURE_TOLERANCE * size;
        let mut residual = f64::INFINITY;
        for _ in 0..CLOSURE_ITERATIONS {
            engine.dynamics.constraints(model, &engine.kin, None);
            let phi = DVector::from_iterator(
                self.rows.len(),
                self.rows.iter().map(|&r| engine.dynamics.phi[r]),
            );
            residual = phi.amax();
            if residual <= tolerance {
                break;
            }
            let step = block(
                &engine.dynamics.g,
                model.dofs(),
                &self.rows,
                &self.dependent,
            )
            .lu()
            .solve(&phi);
            let Some(step) = step.filter(|s| s.iter().all(|d| d.is_finite())) else {
                return Err(ReducedError::Closure { residual });
            };
            for (&g, d) in self.dependent.iter().zip(step.iter()) {
                engine.q[g] -= d;
            }
            engine
                .rapier
                .pose(&model.mechanism, &engine.q, &mut engine.kin);
        }
        if residual > tolerance {
            return Err(ReducedError::Closure { residual });
        }
        engine.dynamics.constraints(model, &engine.kin, None);
        let n = model.dofs();
        let g = &engine.dynamics.g;
        let driven = DVector::from_iterator(
            self.rows.len(),
            self.rows.iter().map(|&r| {
                -self
                    .independent
                    .iter()
                    .map(|&c| g[r * n + c] * engine.v[c])
                    .sum::<f64>()
            }),
        );
        let rates = block(g, n, &self.rows, &self.dependent).lu().solve(&driven);
        let rates = rates.ok_or(ReducedError::Closure { residual })?;
        for (&c, rate) in self.dependent.iter().zip(rates.iter()) {
            engine.v[c] = *rate;
        }
        Ok(())
    }
}

/// G (m × n, row-major) restricted to `rows` and the `dependent` columns (square).
fn block(g: &[f64], n: usize, rows: &[usize], dependent: &[usize]) -> DMatrix<f64> {
    DMatrix::from_fn(rows.len(), dependent.len(), |r, c| {
        g[rows[r] * n + dependent[c]]
    })
}

/// Gaussian elimination with pivoting on G (m × n): the rows that are not redundant and, per
/// row, the pivot column (a dependent coordinate). Columns outside `preferred` are chosen first,
/// so that the actuated joints stay independent when the loops allow it.
fn pivots(g: &[f64], m: usize, n: usize, preferred: &[usize]) -> (Vec<usize>, Vec<usize>) {
    let mut a = DMatrix::from_row_slice(m, n, &g[..m * n]);
    let tiny = REDUNDANT_PIVOT * a.amax();
    let (mut rows, mut columns) = (Vec::new(), Vec::new());
    let mut free_rows: Vec<usize> = (0..m).collect();
    for pass in [false, true] {
        loop {
            let candidates =
                (0..n).filter(|c| !columns.contains(c) && preferred.contains(c) == pass);
            let best = candidates
                .flat_map(|c| free_rows.iter().map(move |&r| (r, c)))
                .max_by(|&(r1, c1), &(r2, c2)| a[(r1, c1)].abs().total_cmp(&a[(r2, c2)].abs()));
            let Some((r, c)) = best.filter(|&(r, c)| a[(r, c)].abs() > tiny) else {
                break;
            };
            for other in free_rows.iter().copied().filter(|&o| o != r) {
                let factor = a[(other, c)] / a[(r, c)];
                for k in 0..n {
                    a[(other, k)] -= factor * a[(r, k)];
                }
            }
            free_rows.retain(|&o| o != r);
            rows.push(r);
            columns.push(c);
        }
    }
    (rows, columns)
}
