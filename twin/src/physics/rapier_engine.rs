//! The rapier engine: Rapier's own `PhysicsPipeline` steps the mechanism, so that links can touch
//! each other and the scenario's `[[bodies]]` (walls, clamps, free boxes) and Rapier resolves the
//! contacts.
//!
//! - The URDF tree is Rapier multibodies (reduced coordinates), one per branch leaving the ground,
//!   as in [`super::rapier_model`]; each `<loop_joint>` is an impulse joint between its two links
//!   (Rapier refuses a loop closed by a multibody joint).
//! - Link inertials are the URDF's (colliders carry no mass). Joint damping, dry friction,
//!   limits and `<spring>`s are Rapier's own per-coordinate terms: damping and springs implicit in
//!   the multibody's mass matrix, friction and limits as constraints of its solver. Rapier's
//!   default multibody damping (0.1 on every angular coordinate) is replaced by the URDF's.
//! - Joint efforts: Rapier has no generalized-force setter, so each effort is an equal and
//!   opposite torque (or force, at one point) on the joint's child and parent — exactly the
//!   effort on its own coordinate and nothing on the others — reset every substep.
//! - Each physics step is one pipeline step of `rapier_substeps` solver iterations (Rapier's
//!   substeps), each of `rapier_iterations` PGS iterations and `rapier_stabilization_iterations`
//!   stabilization iterations: on the Whitworth linkage 4 substeps, 2 PGS iterations and no
//!   stabilization close the loops to about 0.6 µm, and the gap falls as 1/substeps² (more PGS
//!   iterations alone stall near 10 µm; the guide, *The engines*). Rapier's integrator is first order:
//!   the energy it loses is the integrator's, not the closures'.
//! - A process [`Load`] is a force at its point. Its in-step damping and stiffness (∂F/∂v,
//!   ∂F/∂p), which Rapier cannot take, are re-evaluated from the point's motion since the step's
//!   start: a step with such a load is `rapier_substeps` pipeline steps of one solver iteration
//!   instead, the force renewed at the start of each (explicit, so the substep must be short
//!   beside mass/damping).
//!
//! Every velocity handed out is the end-of-step state from the generalized velocities: a
//! multibody link's `RigidBody::linvel`/`angvel` lag one substep behind them, so link velocities
//! are `body_jacobian(link) · generalized_velocity()`.
//!
//! Rapier disables a body whose state turns non-finite (its quarantine) instead of handing out
//! NaN; the engine then reports that body's joint (or the body) as NaN, so the run stops at that
//! step with the signal, as with the exact engine.

use super::contacts::{allowed_pairs, weld_groups};
use super::dynamics::{Frame, HeldLoad};
use super::exact::{ExactEngine, ExactSettings};
use super::options::{BodyKind, BodySpec, ContactOptions, Integrator, SolverSettings};
use super::rapier_model::{axis_frame, insert_links, insert_tree, locked_axes, mass_properties};
use super::shapes::{from_parry, parry_shape, to_parry};
use super::state::{loop_gaps, Load, MechanismState, NO_DAMPING, NO_STIFFNESS};
use crate::mechanism::{Inertial, JointMotion, Mechanism, Pose2, Shape};
use rapier2d_f64::prelude::*;

/// Rapier's world: its sets and pipeline, and the contact filter its narrow phase asks.
struct World {
    pipeline: PhysicsPipeline,
    params: IntegrationParameters,
    gravity: Vector,
    islands: IslandManager,
    broad_phase: BroadPhaseBvh,
    narrow_phase: NarrowPhase,
    bodies: RigidBodySet,
    colliders: ColliderSet,
    impulse_joints: ImpulseJointSet,
    multibodies: MultibodyJointSet,
    soft_bodies: SoftBodySet,
    ccd: CCDSolver,
    filter: ContactFilter,
}

impl World {
    /// One pipeline step; false when Rapier quarantined a body (its state turned non-finite).
    fn step(&mut self) -> bool {
        self.pipeline.step(
            self.gravity,
            &self.params,
            &mut self.islands,
            &mut self.broad_phase,
            &mut self.narrow_phase,
            &mut self.bodies,
            &mut self.colliders,
            &mut self.impulse_joints,
            &mut self.multibodies,
            &mut self.soft_bodies,
            &mut self.ccd,
            &self.filter,
            &(),
        );
        self.pipeline.quarantine().is_empty()
    }
}

/// A link's rigid body and, but for the ground, its multibody link.
#[derive(Debug, Clone, Copy)]
struct LinkBody {
    body: RigidBodyHandle,
    link: Option<MultibodyLinkId>,
}

/// A moving tree joint: its coordinate in Rapier and how efforts reach it.
#[derive(Debug, Clone, Copy)]
struct Dof {
    /// The child's multibody link, whose joint this is.
    link: MultibodyLinkId,
    /// Which of the joint's spatial coordinates moves: 0 along x (slider), 2 the angle.
    coordinate: usize,
    /// +1, or −1 for a revolute joint about −z (URDF value = sign × Rapier coordinate).
    sign: f64,
    parent: usize,
    child: usize,
    /// A slider's axis in the parent link's frame; `None` for a revolute joint.
    slide: Option<[f64; 2]>,
}

pub(super) struct RapierEngine {
    world: World,
    /// The mechanism as the plant now is (faults change inertials, damping, friction).
    mechanism: Mechanism,
    links: Vec<LinkBody>,
    /// Each multibody once.
    multibodies: Vec<MultibodyIndex>,
    dofs: Vec<Dof>,
    dof_of_joint: Vec<Option<usize>>,
    /// Per scenario body, its rigid body.
    bodies: Vec<RigidBodyHandle>,
    ground: Pose2,
    settings: ExactSettings,
    substeps: usize,
    /// Per coordinate, this step's effort in Rapier's sense.
    efforts: Vec<f64>,
    loads: Vec<HeldLoad>,
    /// Links and bodies (owners: links, then bodies) Rapier found non-finite and disabled.
    failed: Vec<usize>,
}

impl RapierEngine {
    pub fn new(mechanism: &Mechanism, settings: &SolverSettings) -> Self {
        let substeps = settings.solver.rapier_substeps.max(1);
        let params = IntegrationParameters {
            dt: settings.dt,
            num_solver_iterations: substeps,
            num_internal_pgs_iterations: settings.solver.rapier_iterations.max(1),
            num_internal_stabilization_iterations: settings.solver.rapier_stabilization_iterations,
            ..IntegrationParameters::default()
        };
        let poses = mechanism.zero_pose();
        let mut bodies = RigidBodySet::new();
        let handles = insert_links(mechanism, &poses, &mut bodies);
        let mut multibodies = MultibodyJointSet::new();
        let indices = insert_tree(mechanism, &poses, &handles, &mut bodies, &mut multibodies);
        let links = handles
            .iter()
            .map(|&body| LinkBody {
                body,
                link: multibodies.rigid_body_link(body).copied(),
            })
            .collect();
        let mut impulse_joints = ImpulseJointSet::new();
        for closure in &mechanism.loops {
            let align = axis_frame(closure.motion);
            let joint = GenericJointBuilder::new(locked_axes(closure.motion))
                .local_frame1(to_parry(&closure.frame1.compose(&align)))
                .local_frame2(to_parry(&closure.frame2.compose(&align)))
                .contacts_enabled(false)
                .build();
            impulse_joints.insert(handles[closure.link1], handles[closure.link2], joint, true);
        }
        let mut colliders = ColliderSet::new();
        let scene = Scene {
            mechanism,
            bodies: &settings.bodies,
            contact: &settings.contact,
        };
        let filter = ContactFilter::new(mechanism, settings);
        let body_handles = scene.insert_colliders(&filter, &handles, &mut bodies, &mut colliders);
        let mut engine = Self {
            world: World {
                pipeline: PhysicsPipeline::new(),
                params,
                gravity: Vector::new(settings.gravity[0], settings.gravity[1]),
                islands: IslandManager::new(),
                broad_phase: BroadPhaseBvh::new(),
                narrow_phase: NarrowPhase::new(),
                bodies,
                colliders,
                impulse_joints,
                multibodies,
                soft_bodies: SoftBodySet::new(),
                ccd: CCDSolver::new(),
                filter,
            },
            dofs: Vec::new(),
            dof_of_joint: Vec::new(),
            mechanism: mechanism.clone(),
            links,
            multibodies: indices,
            bodies: body_handles,
            ground: poses[0],
            settings: ExactSettings {
                dt: settings.dt,
                gravity: settings.gravity,
                substeps: 1,
                integrator: Integrator::Rk4,
            },
            substeps,
            efforts: Vec::new(),
            loads: Vec::new(),
            failed: Vec::new(),
        };
        engine.map_dofs();
        engine.set_joint_terms();
        // The URDF pose is assembled to 1 µm (the loader checks): start exactly closed, as the
        // exact engine does.
        engine.set_joint_states(&[]);
        engine
    }

    /// Per moving tree joint, its coordinate in Rapier and the bodies its effort acts on.
    fn map_dofs(&mut self) {
        for joint in &self.mechanism.joints {
            let (coordinate, sign, slide) = match joint.motion {
                JointMotion::Fixed => {
                    self.dof_of_joint.push(None);
                    continue;
                }
                JointMotion::Revolute { sign } => (2, sign, None),
                JointMotion::Prismatic { axis } => {
                    (0, 1.0, Some(joint.origin.rotate(axis[0], axis[1])))
                }
            };
            let Some(link) = self.links[joint.child].link else {
                self.dof_of_joint.push(None);
                continue;
            };
            self.dof_of_joint.push(Some(self.dofs.len()));
            self.dofs.push(Dof {
                link,
                coordinate,
                sign,
                parent: joint.parent,
                child: joint.child,
                slide,
            });
        }
        self.efforts = vec![0.0; self.dofs.len()];
    }

    /// Damping, dry friction, springs and limits of every tree joint as Rapier's own terms.
    fn set_joint_terms(&mut self) {
        let multibodies = &mut self.world.multibodies;
        for (joint, dof) in self.mechanism.joints.iter().zip(&self.dof_of_joint) {
            let Some(dof) = dof.map(|g| self.dofs[g]) else {
                continue;
            };
            let Some(mb) = multibodies.get_multibody_mut(dof.link.multibody) else {
                continue;
            };
            let Some(at) = mb.link(dof.link.id).map(|l| l.assembly_id()) else {
                continue;
            };
            mb.damping_mut()[at] = joint.damping;
            mb.frictions_mut()[at] = joint.friction;
            let Some(link) = mb.link_mut(dof.link.id) else {
                continue;
            };
            if let Some(spring) = joint.spring {
                let rest = dof.sign * spring.reference;
                link.joint
                    .set_spring(dof.coordinate, spring.stiffness, rest);
            }
            if let Some([lower, upper]) = joint.limits {
                let limits = if dof.sign > 0.0 {
                    [lower, upper]
                } else {
                    [-upper, -lower]
                };
                let axis = match dof.coordinate {
                    0 => JointAxis::LinX,
                    _ => JointAxis::AngX,
                };
                link.joint.data.set_limits(axis, limits);
            }
        }
    }

    /// Changes a link's mass properties from the next step on (a plant fault).
    pub fn set_link_inertial(&mut self, link: usize, inertial: Inertial) {
        let Some(slot) = self.mechanism.links.get_mut(link) else {
            return;
        };
        slot.inertial = Some(inertial);
        let World {
            bodies, colliders, ..
        } = &mut self.world;
        if let Some(body) = bodies.get_mut(self.links[link].body) {
            body.set_additional_mass_properties(mass_properties(&inertial), true);
            body.recompute_mass_properties_from_colliders(colliders);
        }
    }

    /// Changes a tree joint's viscous damping and dry friction from the next step on.
    pub fn set_joint_dynamics(&mut self, joint: usize, damping: f64, friction: f64) {
        let Some(slot) = self.mechanism.joints.get_mut(joint) else {
            return;
        };
        (slot.damping, slot.friction) = (damping, friction);
        let Some(dof) = self.dof_of_joint[joint].map(|g| self.dofs[g]) else {
            return;
        };
        if let Some(mb) = self.world.multibodies.get_multibody_mut(dof.link.multibody) {
            if let Some(at) = mb.link(dof.link.id).map(|l| l.assembly_id()) {
                mb.damping_mut()[at] = damping;
                mb.frictions_mut()[at] = friction;
            }
        }
    }

    /// Puts tree joints (index, position, velocity; URDF sense) in a starting state with the
    /// loops closed and the velocities consistent with them: the exact engine computes that
    /// state (Gauss–Newton closure, mass-weighted projection), Rapier takes it over. Returns
    /// whether the joints given were held.
    pub fn set_joint_states(&mut self, states: &[(usize, f64, f64)]) -> bool {
        let mut exact = ExactEngine::new(&self.mechanism, self.settings);
        let held = exact.set_joint_states(states);
        let mut state = MechanismState::default();
        exact.read_state(&mut state);
        let multibodies = &mut self.world.multibodies;
        for (j, dof) in self.dof_of_joint.iter().enumerate() {
            let Some(dof) = dof.map(|g| self.dofs[g]) else {
                continue;
            };
            let Some(mb) = multibodies.get_multibody_mut(dof.link.multibody) else {
                continue;
            };
            let Some(link) = mb.link_mut(dof.link.id) else {
                continue;
            };
            let now = link.joint.coords()[dof.coordinate];
            link.joint
                .apply_displacement(&[dof.sign * state.joint_positions[j] - now]);
            let at = link.assembly_id();
            mb.generalized_velocity_mut()[at] = dof.sign * state.joint_velocities[j];
        }
        for &index in &self.multibodies {
            if let Some(mb) = multibodies.get_multibody_mut(index) {
                mb.forward_kinematics(&self.world.bodies, false);
                mb.update_rigid_bodies(&mut self.world.bodies, true);
            }
        }
        held
    }

    /// Applies one step's joint efforts (per tree joint, URDF sign; N·m or N) and loads, then
    /// advances by dt in `rapier_substeps` substeps (one pipeline step of that many solver
    /// iterations, or that many pipeline steps with an in-step load). Efforts and loads act for
    /// this step only.
    pub fn step(&mut self, joint_efforts: &[f64], loads: &[Load]) {
        if !self.failed.is_empty() {
            return;
        }
        for (j, &effort) in joint_efforts.iter().enumerate() {
            if let Some(g) = self.dof_of_joint.get(j).copied().flatten() {
                self.efforts[g] = self.dofs[g].sign * effort;
            }
        }
        self.loads.clear();
        for load in loads {
            let (frame, velocity) = self.link_motion(load.link, load.point);
            let held = HeldLoad::new(load, &Frame::of(&frame), velocity);
            self.loads.push(held);
        }
        // Rapier's solver iterations are its substeps: one pipeline step of `substeps` of them
        // is the same integration as `substeps` pipeline steps of one (bit for bit, measured)
        // and a third faster. A load that changes with the motion within the step needs the
        // pipeline steps, to be re-evaluated at the start of each.
        let in_step = self
            .loads
            .iter()
            .any(|l| l.damping != NO_DAMPING || l.stiffness != NO_STIFFNESS);
        let (steps, iterations) = match in_step {
            true => (self.substeps, 1),
            false => (1, self.substeps),
        };
        self.world.params.dt = self.settings.dt / steps as f64;
        self.world.params.num_solver_iterations = iterations;
        for _ in 0..steps {
            self.apply_forces();
            if !self.world.step() {
                self.note_quarantine();
                return;
            }
        }
    }

    /// This substep's forces: the joint efforts as equal and opposite pairs, the loads at their
    /// points with their damping and stiffness on the motion since the step's start.
    fn apply_forces(&mut self) {
        let bodies = &mut self.world.bodies;
        for link in &self.links {
            if let Some(body) = bodies.get_mut(link.body) {
                body.reset_forces(false);
                body.reset_torques(false);
            }
        }
        for (dof, &effort) in self.dofs.iter().zip(&self.efforts) {
            let (parent, child) = (self.links[dof.parent].body, self.links[dof.child].body);
            match dof.slide {
                None => {
                    add(bodies, child, |b| b.add_torque(effort, false));
                    add(bodies, parent, |b| b.add_torque(-effort, false));
                }
                Some(slide) => {
                    let Some(frame) = bodies.get(parent).map(|b| *b.position()) else {
                        continue;
                    };
                    let force = frame.rotation * Vector::new(slide[0], slide[1]) * effort;
                    let Some(at) = bodies.get(child).map(|b| b.center_of_mass()) else {
                        continue;
                    };
                    // At one point on both, so that the pair does no work on the coordinates
                    // above the joint.
                    add(bodies, child, |b| b.add_force(force, false));
                    add(bodies, parent, |b| b.add_force_at_point(-force, at, false));
                }
            }
        }
        for k in 0..self.loads.len() {
            let load = self.loads[k];
            let frame = self.link_frame(load.link);
            let point = frame.apply(load.local_point[0], load.local_point[1]);
            let (_, velocity) = self.link_motion(load.link, point);
            let dv = [
                velocity[0] - load.start_velocity[0],
                velocity[1] - load.start_velocity[1],
            ];
            let dp = [
                point[0] - load.start_point[0],
                point[1] - load.start_point[1],
            ];
            let [[cxx, cxy], [cyx, cyy]] = load.damping;
            let [[kxx, kxy], [kyx, kyy]] = load.stiffness;
            let force = Vector::new(
                load.force[0] + cxx * dv[0] + cxy * dv[1] + kxx * dp[0] + kxy * dp[1],
                load.force[1] + cyx * dv[0] + cyy * dv[1] + kyx * dp[0] + kyy * dp[1],
            );
            let at = Vector::new(point[0], point[1]);
            let body = self.links[load.link].body;
            add(&mut self.world.bodies, body, |b| {
                b.add_force_at_point(force, at, false)
            });
        }
    }

    /// Records which links and bodies Rapier disabled for non-finite state.
    fn note_quarantine(&mut self) {
        let quarantined = self.world.pipeline.quarantine().bodies();
        let owners = self
            .links
            .iter()
            .map(|l| l.body)
            .chain(self.bodies.iter().copied());
        self.failed = owners
            .enumerate()
            .filter(|(_, handle)| quarantined.contains(handle))
            .map(|(owner, _)| owner)
            .collect();
    }

    /// A link's frame in the world.
    fn link_frame(&self, link: usize) -> Pose2 {
        let Some(id) = self.links.get(link).and_then(|l| l.link) else {
            return self.ground;
        };
        self.world
            .multibodies
            .get_multibody(id.multibody)
            .and_then(|mb| mb.link(id.id))
            .map_or(self.ground, |l| from_parry(l.local_to_world()))
    }

    /// A link's frame and the velocity of a world point fixed on it: the centre of mass's
    /// `body_jacobian · generalized_velocity` (not the lagging `RigidBody::linvel`) plus ω × r.
    fn link_motion(&self, link: usize, point: [f64; 2]) -> (Pose2, [f64; 2]) {
        let frame = self.link_frame(link);
        let [vx, vy, omega] = self.centre_velocity(link);
        let com = self.mechanism.links[link]
            .inertial
            .map_or([0.0; 2], |i| i.centre_of_mass);
        let [cx, cy] = frame.apply(com[0], com[1]);
        let (rx, ry) = (point[0] - cx, point[1] - cy);
        (frame, [vx - omega * ry, vy + omega * rx])
    }

    /// [vx, vy, ω] of a link's centre of mass from the generalized velocities.
    fn centre_velocity(&self, link: usize) -> [f64; 3] {
        let Some(id) = self.links.get(link).and_then(|l| l.link) else {
            return [0.0; 3];
        };
        let Some(mb) = self.world.multibodies.get_multibody(id.multibody) else {
            return [0.0; 3];
        };
        let v = mb.body_jacobian(id.id) * mb.generalized_velocity();
        [v[0], v[1], v[2]]
    }

    /// Reads the state into `state`, reusing its buffers.
    pub fn read_state(&self, state: &mut MechanismState) {
        let joints = self.mechanism.joints.len();
        state.joint_positions.resize(joints, 0.0);
        state.joint_velocities.resize(joints, 0.0);
        for (j, dof) in self.dof_of_joint.iter().enumerate() {
            let (q, v) = dof.map_or((0.0, 0.0), |g| self.coordinate(&self.dofs[g]));
            state.joint_positions[j] = q;
            state.joint_velocities[j] = v;
        }
        state.link_poses.clear();
        state.link_velocities.clear();
        state.link_angular_velocities.clear();
        for l in 0..self.links.len() {
            let frame = self.link_frame(l);
            let (_, velocity) = self.link_motion(l, [frame.x, frame.y]);
            state.link_poses.push(frame);
            state.link_velocities.push(velocity);
            state
                .link_angular_velocities
                .push(self.centre_velocity(l)[2]);
        }
        loop_gaps(&self.mechanism, &state.link_poses, &mut state.loop_gaps);
        state.body_poses.clear();
        state.body_poses.extend(self.bodies.iter().map(|&handle| {
            self.world
                .bodies
                .get(handle)
                .map_or(Pose2::new(f64::NAN, f64::NAN, f64::NAN), |b| {
                    from_parry(b.position())
                })
        }));
        self.mark_failed(state);
    }

    /// A coordinate's position and velocity in the URDF's sense.
    fn coordinate(&self, dof: &Dof) -> (f64, f64) {
        let Some(mb) = self.world.multibodies.get_multibody(dof.link.multibody) else {
            return (f64::NAN, f64::NAN);
        };
        let Some(link) = mb.link(dof.link.id) else {
            return (f64::NAN, f64::NAN);
        };
        let q = link.joint.coords()[dof.coordinate];
        let v = mb.generalized_velocity()[link.assembly_id()];
        (dof.sign * q, dof.sign * v)
    }

    /// What Rapier disabled reads as NaN: a link's joint position (joint i moves link i + 1), a
    /// body's pose.
    fn mark_failed(&self, state: &mut MechanismState) {
        let links = self.links.len();
        for &owner in &self.failed {
            match owner.checked_sub(links) {
                None => {
                    if let Some(q) = owner
                        .checked_sub(1)
                        .and_then(|j| state.joint_positions.get_mut(j))
                    {
                        *q = f64::NAN;
                    }
                }
                Some(body) => {
                    if let Some(pose) = state.body_poses.get_mut(body) {
                        *pose = Pose2::new(f64::NAN, f64::NAN, f64::NAN);
                    }
                }
            }
        }
    }
}

/// Calls `apply` on a body if it is in the set (a fixed body ignores forces).
fn add(bodies: &mut RigidBodySet, handle: RigidBodyHandle, apply: impl FnOnce(&mut RigidBody)) {
    if let Some(body) = bodies.get_mut(handle) {
        apply(body);
    }
}

/// What the colliders are made of: the links' collision shapes and the scenario's bodies.
struct Scene<'a> {
    mechanism: &'a Mechanism,
    bodies: &'a [BodySpec],
    contact: &'a ContactOptions,
}

impl Scene<'_> {
    /// A body per scenario body (static: fixed; free: dynamic, its mass spread over its shapes'
    /// area) and colliders for the shapes of the links and bodies that can touch something
    /// (links' colliders are massless: the URDF's inertials rule). A mechanism whose shapes can
    /// touch nothing (the Whitworth's ram alone, no bodies) gets no colliders, so Rapier's
    /// collision pipeline has nothing to do. Returns the bodies' handles.
    fn insert_colliders(
        &self,
        filter: &ContactFilter,
        links: &[RigidBodyHandle],
        bodies: &mut RigidBodySet,
        colliders: &mut ColliderSet,
    ) -> Vec<RigidBodyHandle> {
        let shaped: Vec<bool> = self
            .mechanism
            .links
            .iter()
            .map(|l| !self.shapes(&l.collisions).is_empty())
            .chain(
                self.bodies
                    .iter()
                    .map(|b| !self.shapes(&b.outlines()).is_empty()),
            )
            .collect();
        let touches = |owner: usize| {
            (0..shaped.len()).any(|other| shaped[other] && filter.solves(owner, other))
        };
        for (owner, (link, &handle)) in self.mechanism.links.iter().zip(links).enumerate() {
            if !touches(owner) {
                continue;
            }
            for (shape, _) in self.shapes(&link.collisions) {
                let collider = self.collider(shape, owner).density(0.0);
                colliders.insert_with_parent(collider, handle, bodies);
            }
        }
        let first = self.mechanism.links.len();
        let mut handles = Vec::with_capacity(self.bodies.len());
        for (index, spec) in self.bodies.iter().enumerate() {
            let builder = match spec.kind {
                BodyKind::Static => RigidBodyBuilder::fixed(),
                BodyKind::Free => RigidBodyBuilder::dynamic().can_sleep(false),
            };
            let handle = bodies.insert(builder.pose(to_parry(&spec.placement())));
            let outlines = spec.outlines();
            let shapes = self.shapes(&outlines);
            let area: f64 = shapes.iter().map(|(_, area)| area).sum();
            let density = spec.mass.map_or(0.0, |m| m / area.max(f64::MIN_POSITIVE));
            // A free body's colliders carry its mass, whether or not anything can touch it.
            let shapes = match spec.kind == BodyKind::Free || touches(first + index) {
                true => shapes,
                false => Vec::new(),
            };
            for (shape, _) in shapes {
                let collider = self.collider(shape, first + index).density(density);
                colliders.insert_with_parent(collider, handle, bodies);
            }
            handles.push(handle);
        }
        handles
    }

    /// Parry's shapes (placed in their owner's frame) with their areas; an outline parry cannot
    /// make (refused before any run) is left out.
    fn shapes(&self, outlines: &[Shape]) -> Vec<(ColliderBuilder, f64)> {
        outlines
            .iter()
            .filter_map(parry_shape)
            .map(|(shape, pose)| {
                let area = shape.mass_properties(1.0).mass();
                (ColliderBuilder::new(shape).position(pose), area)
            })
            .collect()
    }

    /// A collider of `owner` (links, then bodies) with the scenario's friction and restitution,
    /// filtered by [`ContactFilter`].
    fn collider(&self, builder: ColliderBuilder, owner: usize) -> ColliderBuilder {
        builder
            .friction(self.contact.friction)
            .restitution(self.contact.restitution)
            .user_data(owner as u128)
            .active_hooks(ActiveHooks::FILTER_CONTACT_PAIRS)
    }
}

/// Which owners (links, then bodies) Rapier lets touch: not adjacent links (joined by a tree or
/// loop joint, or welded), not the `[[allowed_contacts]]` pairs (they touch by design: a cut
/// is the process model's), not two that never move.
struct ContactFilter {
    owners: usize,
    /// Row-major: allowed to overlap, so no contact is solved.
    allowed: Vec<bool>,
    /// Per owner: it never moves (welded to the ground, or a static body).
    fixed: Vec<bool>,
}

impl ContactFilter {
    fn new(mechanism: &Mechanism, settings: &SolverSettings) -> Self {
        let group = weld_groups(mechanism);
        let names: Vec<String> = mechanism
            .links
            .iter()
            .map(|l| l.name.clone())
            .chain(settings.bodies.iter().map(|b| b.name.clone()))
            .collect();
        let entries: Vec<(&str, &str)> = settings
            .allowed_contacts
            .iter()
            .map(|c| (c.a.as_str(), c.b.as_str()))
            .collect();
        // The twin refuses unknown names before a run is built; without them, only the
        // adjacent links are left out.
        let allowed = allowed_pairs(mechanism, &group, &names, &entries)
            .or_else(|_| allowed_pairs(mechanism, &group, &names, &[]))
            .unwrap_or_default();
        let fixed = (0..names.len())
            .map(|o| match o.checked_sub(mechanism.links.len()) {
                None => group[o] == 0,
                Some(b) => settings.bodies[b].kind == BodyKind::Static,
            })
            .collect();
        Self {
            owners: names.len(),
            allowed,
            fixed,
        }
    }

    /// Whether Rapier solves contacts between two owners.
    fn solves(&self, a: usize, b: usize) -> bool {
        let fixed = |o: usize| self.fixed.get(o).copied().unwrap_or(true);
        let allowed = self.allowed.get(a * self.owners + b).copied();
        a != b && !(fixed(a) && fixed(b)) && allowed == Some(false)
    }
}

impl PhysicsHooks for ContactFilter {
    fn filter_contact_pair(&self, context: &PairFilterContext) -> Option<SolverFlags> {
        let owner = |c| context.colliders.get(c).map(|c| c.user_data as usize);
        let (a, b) = (owner(context.collider1)?, owner(context.collider2)?);
        self.solves(a, b)
            .then_some(SolverFlags::COMPUTE_RIGID_IMPULSES)
    }
}
