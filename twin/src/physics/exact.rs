//! The exact engine: Rapier holds the URDF tree as multibodies (reduced coordinates,
//! [`super::rapier_model`]); every stage and every end-of-step state is posed by the twin's own
//! recursion over the same tree ([`super::tree`], checked against Rapier's). The twin
//! builds the equations of motion from the link poses and body Jacobians, with each
//! `<loop_joint>` as a holonomic constraint ([`super::dynamics`]), and advances them itself:
//!
//! 1. one classical Runge–Kutta (RK4) step of the constrained equations per substep, efforts and
//!    loads held over the step — fourth order, so no numerical damping worth the name (or, as
//!    the scenario's `[solver] integrator` says, an explicit midpoint or a semi-implicit Euler
//!    step: two evaluations or one);
//! 2. joint limits as inelastic stops;
//! 3. the loop closures made exact: Gauss–Newton on φ(q) = 0, mass-weighted, to 1e-12 (after a
//!    semi-implicit Euler step, from its predicted drift corrected);
//! 4. dry joint friction as one impulse per substep, which sticks the joint when it can;
//! 5. the velocities projected on the constraints' tangent space, mass-weighted.
//!
//! Every velocity handed out is the end-of-step state: link velocities are J(q)·q̇ at the final q.

use super::dynamics::{Dynamics, HeldLoad, Inputs, Kinematics, Model};
use super::held_closure::held_correction;
use super::options::Integrator;
use super::rapier_model::RapierModel;
use super::state::{loop_gaps, Load, MechanismState};
use super::tree::Tree;
use crate::mechanism::{Inertial, Mechanism};

/// Largest loop-constraint residual (m, rad) the position projection leaves.
const CLOSURE_TOLERANCE: f64 = 1e-12;
/// Gauss–Newton iterations before giving up (the health check then sees the gap).
const CLOSURE_ITERATIONS: usize = 8;

/// What the exact engine needs of the solver settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct ExactSettings {
    pub dt: f64,
    pub gravity: [f64; 2],
    /// Substeps per step (efforts and loads are held over the whole step).
    pub substeps: usize,
    /// How a substep is advanced.
    pub integrator: Integrator,
}

#[derive(Clone)]
pub(super) struct ExactEngine {
    pub(super) model: Model,
    pub(super) rapier: RapierModel,
    /// The tree's kinematics: every stage's pose and the end-of-step one.
    tree: Tree,
    pub(super) dynamics: Dynamics,
    settings: ExactSettings,
    /// Generalized coordinates and velocities (Rapier's signs).
    pub(super) q: Vec<f64>,
    pub(super) v: Vec<f64>,
    /// Poses and Jacobians at `q`: the end-of-step state.
    pub(super) kin: Kinematics,
    stage: Stage,
    efforts: Vec<f64>,
    loads: Vec<HeldLoad>,
}

/// RK4 workspace.
#[derive(Clone)]
struct Stage {
    kin: Kinematics,
    q: Vec<f64>,
    v: [Vec<f64>; 3],
    a: [Vec<f64>; 4],
    column: Vec<f64>,
}

impl ExactEngine {
    pub fn new(mechanism: &Mechanism, settings: ExactSettings) -> Self {
        let model = Model::new(mechanism);
        let n = model.dofs();
        let mut physics = Self {
            rapier: RapierModel::new(mechanism),
            tree: Tree::new(mechanism),
            dynamics: Dynamics::new(&model),
            settings: ExactSettings {
                substeps: settings.substeps.max(1),
                ..settings
            },
            q: vec![0.0; n],
            v: vec![0.0; n],
            kin: Kinematics::default(),
            stage: Stage {
                kin: Kinematics::default(),
                q: vec![0.0; n],
                v: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
                a: [vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]],
                column: vec![0.0; n],
            },
            efforts: vec![0.0; n],
            loads: Vec::new(),
            model,
        };
        // The URDF pose is assembled to 1 µm (the loader checks): start exactly closed.
        physics.close_loops();
        physics
    }

    /// Changes a link's mass properties from the next step on (a plant fault).
    pub fn set_link_inertial(&mut self, link: usize, inertial: Inertial) {
        if let Some(slot) = self.model.mechanism.links.get_mut(link) {
            slot.inertial = Some(inertial);
            self.dynamics.forget();
            self.tree.take_centres_of_mass(&self.model.mechanism);
        }
    }

    /// Changes a tree joint's viscous damping and dry friction from the next step on.
    pub fn set_joint_dynamics(&mut self, joint: usize, damping: f64, friction: f64) {
        if let Some(g) = self.model.dof_of_joint.get(joint).copied().flatten() {
            self.model.damping[g] = damping;
            self.model.friction[g] = friction;
        }
    }

    /// Puts tree joints (index, position, velocity; URDF sense) in a starting state, then closes
    /// the loops and makes the velocities consistent with them.
    /// The coordinates given are held where the others can close the loops alone (a five-bar
    /// given both crank angles starts at them); otherwise every coordinate moves, mass-weighted.
    /// Returns whether the coordinates given were held (true with no loop or none given).
    pub fn set_joint_states(&mut self, states: &[(usize, f64, f64)]) -> bool {
        let mut held = vec![false; self.q.len()];
        for &(joint, position, velocity) in states {
            if let Some(g) = self.model.dof_of_joint.get(joint).copied().flatten() {
                self.q[g] = self.model.sign[g] * position;
                self.v[g] = self.model.sign[g] * velocity;
                held[g] = true;
            }
        }
        let held_closed = match self.model.constraint_count > 0 && held.contains(&true) {
            true => self.close_loops_holding(&held),
            false => true,
        };
        self.close_loops();
        if self.model.constraint_count > 0 {
            self.dynamics
                .project_velocity(&self.model, &self.kin, &mut self.v);
        }
        held_closed
    }

    /// Gauss–Newton on the coordinates not `held` until the loops close; leaves q as it was if
    /// they cannot (the held ones fix the loop, or the iteration does not converge), and says
    /// whether they closed.
    fn close_loops_holding(&mut self, held: &[bool]) -> bool {
        let n = self.q.len();
        let start = self.q.clone();
        let mut dq = vec![0.0; n];
        for _ in 0..4 * CLOSURE_ITERATIONS {
            self.tree.pose(&self.q, &mut self.kin);
            self.dynamics.constraints(&self.model, &self.kin, None);
            let residual = (self.dynamics.phi.iter()).fold(0.0, |m: f64, p| m.max(p.abs()));
            if residual <= CLOSURE_TOLERANCE {
                self.hold_velocities(held);
                return true;
            }
            let (phi, g) = (&self.dynamics.phi, &self.dynamics.g);
            if !residual.is_finite() || !held_correction(phi, g, n, held, &mut dq) {
                break;
            }
            for (q, d) in self.q.iter_mut().zip(&dq) {
                *q += d;
            }
        }
        self.q = start;
        false
    }

    /// Makes the free velocities consistent with the loops, the held ones kept: v_F −=
    /// G_Fᵀ (G_F G_Fᵀ)⁻¹ G v, at the closed configuration.
    fn hold_velocities(&mut self, held: &[bool]) {
        let n = self.v.len();
        let g = &self.dynamics.g;
        let rates: Vec<f64> = (0..self.model.constraint_count)
            .map(|r| {
                (g[r * n..(r + 1) * n].iter().zip(&self.v))
                    .map(|(a, b)| a * b)
                    .sum()
            })
            .collect();
        let mut dv = vec![0.0; n];
        if held_correction(&rates, g, n, held, &mut dv) {
            for (v, d) in self.v.iter_mut().zip(&dv) {
                *v += d;
            }
        }
    }

    /// Applies one step's joint efforts (per tree joint, URDF sign; N·m or N) and loads, then
    /// advances by dt. Efforts and loads act for this step only.
    pub fn step(&mut self, joint_efforts: &[f64], loads: &[Load]) {
        for (j, &effort) in joint_efforts.iter().enumerate() {
            if let Some(g) = self.model.dof_of_joint[j] {
                self.efforts[g] = self.model.sign[g] * effort;
            }
        }
        self.loads.clear();
        self.loads.extend(loads.iter().map(|load| {
            let [vx, vy, _] = self.kin.point_velocity(load.link, load.point, &self.v);
            HeldLoad::new(load, &self.kin.frames[load.link], [vx, vy])
        }));
        let h = self.settings.dt / self.settings.substeps as f64;
        for _ in 0..self.settings.substeps {
            self.integrate(h);
            self.stop_at_limits();
            self.close_loops();
            if self.apply_friction(h) {
                self.close_loops();
            }
            if self.model.constraint_count > 0 {
                self.dynamics
                    .project_velocity(&self.model, &self.kin, &mut self.v);
            }
        }
    }

    /// One step of (q, q̇) by `h` with the scenario's integrator; leaves `self.q`, `self.v`
    /// advanced (not yet projected).
    fn integrate(&mut self, h: f64) {
        let Self {
            model,
            tree,
            dynamics,
            settings,
            q,
            v,
            kin,
            stage,
            efforts,
            loads,
            ..
        } = self;
        let inputs = Inputs {
            efforts,
            loads,
            gravity: settings.gravity,
        };
        let mut accelerate = |kin: &Kinematics, state: (&[f64], &[f64]), out: &mut [f64]| {
            dynamics.acceleration(model, kin, state, &inputs, out)
        };
        // The first stage is at the step's start, posed by the last step.
        accelerate(kin, (q, v), &mut stage.a[0]);
        match settings.integrator {
            Integrator::Rk4 => runge_kutta(h, (q, v), stage, tree, &mut accelerate),
            Integrator::Midpoint => midpoint(h, (q, v), stage, tree, &mut accelerate),
            Integrator::SemiImplicitEuler => {
                for g in 0..q.len() {
                    v[g] += h * stage.a[0][g];
                    q[g] += h * v[g];
                }
                // The step leaves the loops by ½·h²·γ to first order: start the closure from
                // there corrected, so that one Gauss–Newton iteration closes them.
                if model.constraint_count > 0 {
                    let dq = &mut stage.column[..q.len()];
                    dynamics.drift_correction(model, kin, h, dq);
                    for (q, d) in q.iter_mut().zip(dq.iter()) {
                        *q += *d;
                    }
                }
            }
        }
    }

    /// Joint limits as inelastic stops: a joint past a limit is put back on it and loses the
    /// velocity that carried it there.
    fn stop_at_limits(&mut self) {
        for (g, limits) in self.model.limits.iter().enumerate() {
            let Some([lower, upper]) = *limits else {
                continue;
            };
            if self.q[g] < lower {
                self.q[g] = lower;
                self.v[g] = self.v[g].max(0.0);
            } else if self.q[g] > upper {
                self.q[g] = upper;
                self.v[g] = self.v[g].min(0.0);
            }
        }
    }

    /// Poses the mechanism at `q` by the tree's recursion, first bringing the loop constraints to
    /// zero by Gauss–Newton (the mass-weighted least correction each iteration).
    fn close_loops(&mut self) {
        let n = self.q.len();
        self.tree.pose(&self.q, &mut self.kin);
        if self.model.constraint_count == 0 {
            return;
        }
        for _ in 0..CLOSURE_ITERATIONS {
            self.dynamics.constraints(&self.model, &self.kin, None);
            let residual = self
                .dynamics
                .phi
                .iter()
                .fold(0.0, |m: f64, p| m.max(p.abs()));
            if residual <= CLOSURE_TOLERANCE || !residual.is_finite() {
                return;
            }
            let dq = &mut self.stage.column[..n];
            self.dynamics
                .position_correction(&self.model, &self.kin, dq);
            for (q, d) in self.q.iter_mut().zip(dq.iter()) {
                *q += *d;
            }
            self.tree.pose(&self.q, &mut self.kin);
        }
    }

    /// Dry friction (URDF `<dynamics friction>`): per joint, the impulse of at most F·h that
    /// would stop the joint alone, applied through M⁻¹ (one Gauss–Seidel pass over the joints).
    /// The position takes h/2 of the velocity change, as a force held over the step would move
    /// it, so a stuck joint does not creep. Returns whether anything changed.
    fn apply_friction(&mut self, h: f64) -> bool {
        let mut changed = false;
        for g in 0..self.q.len() {
            let friction = self.model.friction[g];
            if friction == 0.0 {
                continue;
            }
            let column = &mut self.stage.column;
            self.dynamics
                .inverse_mass_column(&self.model, &self.kin, g, column);
            let stopping = -self.v[g] / column[g];
            let impulse = stopping.clamp(-friction * h, friction * h);
            for ((v, q), c) in self.v.iter_mut().zip(self.q.iter_mut()).zip(column.iter()) {
                *v += c * impulse;
                *q += 0.5 * h * c * impulse;
            }
            changed |= impulse != 0.0;
        }
        changed
    }

    /// Reads the state into `state`, reusing its buffers.
    pub fn read_state(&self, state: &mut MechanismState) {
        let mechanism = &self.model.mechanism;
        let joints = mechanism.joints.len();
        state.joint_positions.resize(joints, 0.0);
        state.joint_velocities.resize(joints, 0.0);
        for (j, dof) in self.model.dof_of_joint.iter().enumerate() {
            let (q, v) = dof.map_or((0.0, 0.0), |g| {
                let sign = self.model.sign[g];
                (sign * self.q[g], sign * self.v[g])
            });
            state.joint_positions[j] = q;
            state.joint_velocities[j] = v;
        }
        state.link_poses.clear();
        state.link_velocities.clear();
        state.link_angular_velocities.clear();
        for (l, frame) in self.kin.frames.iter().enumerate() {
            let [vx, vy, omega] = self.kin.point_velocity(l, frame.origin, &self.v);
            state.link_poses.push(frame.pose());
            state.link_velocities.push([vx, vy]);
            state.link_angular_velocities.push(omega);
        }
        loop_gaps(mechanism, &state.link_poses, &mut state.loop_gaps);
    }
}

/// The equations of motion at a stage: its pose, (q, q̇), and the accelerations written out.
type Accelerate<'a> = dyn FnMut(&Kinematics, (&[f64], &[f64]), &mut [f64]) + 'a;

/// One classical RK4 step of (q, q̇) by `h`, the first stage's accelerations in `stage.a[0]`.
fn runge_kutta(
    h: f64,
    (q, v): (&mut [f64], &mut [f64]),
    stage: &mut Stage,
    tree: &mut Tree,
    accelerate: &mut Accelerate,
) {
    let n = q.len();
    // Stage k starts from the previous stage's rates: (q + c·h·v_k, v + c·h·a_k).
    for (k, step) in [h / 2.0, h / 2.0, h].into_iter().enumerate() {
        for g in 0..n {
            let rate = if k == 0 { v[g] } else { stage.v[k - 1][g] };
            stage.q[g] = q[g] + step * rate;
            stage.v[k][g] = v[g] + step * stage.a[k][g];
        }
        tree.pose(&stage.q, &mut stage.kin);
        accelerate(&stage.kin, (&stage.q, &stage.v[k]), &mut stage.a[k + 1]);
    }
    let ([v2, v3, v4], [a1, a2, a3, a4]) = (&stage.v, &stage.a);
    for g in 0..n {
        q[g] += h / 6.0 * (v[g] + 2.0 * v2[g] + 2.0 * v3[g] + v4[g]);
        v[g] += h / 6.0 * (a1[g] + 2.0 * a2[g] + 2.0 * a3[g] + a4[g]);
    }
}

/// One explicit midpoint step of (q, q̇) by `h`: the rates at the half step, reached with the
/// first stage's (in `stage.a[0]`).
fn midpoint(
    h: f64,
    (q, v): (&mut [f64], &mut [f64]),
    stage: &mut Stage,
    tree: &mut Tree,
    accelerate: &mut Accelerate,
) {
    let n = q.len();
    for g in 0..n {
        stage.q[g] = q[g] + 0.5 * h * v[g];
        stage.v[0][g] = v[g] + 0.5 * h * stage.a[0][g];
    }
    tree.pose(&stage.q, &mut stage.kin);
    accelerate(&stage.kin, (&stage.q, &stage.v[0]), &mut stage.a[1]);
    for g in 0..n {
        q[g] += h * stage.v[0][g];
        v[g] += h * stage.a[1][g];
    }
}
