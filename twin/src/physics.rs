//! The only module that knows Rapier: builds a world from a [`Mechanism`], applies joint efforts
//! and process loads, steps, and reports the [`MechanismState`].
//!
//! The URDF tree becomes Rapier multibodies (reduced coordinates), one per branch leaving the
//! fixed ground; each `<loop_joint>` closes its loop as an impulse joint. Multibody links start at zero joint
//! coordinates, so the URDF's pose is the initial pose.

use crate::mechanism::{JointMotion, Mechanism, Pose2};
use rapier2d_f64::prelude::*;

/// Joint coordinates and link motion after a step, in the URDF's conventions.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MechanismState {
    /// Per tree joint (as [`Mechanism::joints`]): rad or m, counted along the URDF axis; 0 for fixed.
    pub joint_positions: Vec<f64>,
    /// rad/s or m/s.
    pub joint_velocities: Vec<f64>,
    /// Per link (as [`Mechanism::links`]): the link frame in the world.
    pub link_poses: Vec<Pose2>,
    /// Per link: velocity of the link frame's origin, m/s.
    pub link_velocities: Vec<[f64; 2]>,
    /// Per link: angular velocity, rad/s.
    pub link_angular_velocities: Vec<f64>,
    /// Per loop joint: how far its two frames have drifted apart (m), the loop-closure error.
    pub loop_gaps: Vec<f64>,
}

/// An external force on a link (a process force: cutting, contact), in world coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Load {
    pub link: usize,
    pub force: [f64; 2],
    /// Where it acts, world coordinates.
    pub point: [f64; 2],
}

/// Solver settings a scenario may tune.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverSettings {
    pub dt: f64,
    pub gravity: [f64; 2],
    /// Rapier's velocity-solver iterations per step (its default is 4).
    pub iterations: usize,
}

pub struct Physics {
    world: PhysicsWorld,
    bodies: Vec<RigidBodyHandle>,
    /// Per tree joint: the child link's multibody and its id there.
    joint_links: Vec<MultibodyLinkId>,
    mechanism: Mechanism,
}

impl Physics {
    pub fn new(mechanism: &Mechanism, settings: SolverSettings) -> Self {
        let mut world = PhysicsWorld::new();
        world.gravity = Vector::new(settings.gravity[0], settings.gravity[1]);
        world.integration_parameters.dt = settings.dt;
        world.integration_parameters.num_solver_iterations = settings.iterations.max(1);

        let poses = mechanism.zero_pose();
        let bodies: Vec<RigidBodyHandle> = mechanism
            .links
            .iter()
            .zip(&poses)
            .map(|(link, pose)| {
                let builder = match link.inertial {
                    None => RigidBodyBuilder::fixed(),
                    Some(inertial) => RigidBodyBuilder::dynamic()
                        .can_sleep(false)
                        .additional_mass_properties(MassProperties::new(
                            Vector::new(inertial.centre_of_mass[0], inertial.centre_of_mass[1]),
                            inertial.mass,
                            inertial.izz,
                        )),
                };
                world.bodies.insert(builder.pose(to_rapier(pose)))
            })
            .collect();

        // Each branch leaving the ground gets its own fixed anchor, so each becomes its own
        // multibody: the same physics, but small mass matrices instead of one large one.
        let mut joint_links = Vec::with_capacity(mechanism.joints.len());
        for joint in &mechanism.joints {
            let parent = if joint.parent == 0 {
                world
                    .bodies
                    .insert(RigidBodyBuilder::fixed().pose(to_rapier(&poses[0])))
            } else {
                bodies[joint.parent]
            };
            let generic = tree_joint(joint.motion, &joint.origin, joint.limits);
            world
                .multibody_joints
                .insert(parent, bodies[joint.child], generic, true)
                .expect("a validated URDF tree inserts parent before child");
        }
        for joint in &mechanism.joints {
            let id = *world
                .multibody_joints
                .rigid_body_link(bodies[joint.child])
                .expect("inserted");
            joint_links.push(id);
        }
        for (joint, id) in mechanism.joints.iter().zip(&joint_links) {
            let mb = world
                .multibody_joints
                .get_multibody_mut(id.multibody)
                .expect("just built");
            // Rapier adds 0.1 damping per angular dof by default: only the URDF's damping stays.
            if joint.parent == 0 {
                mb.damping_mut().fill(0.0);
            }
            if joint.motion.is_movable() {
                let dof = mb.link(id.id).expect("link").assembly_id();
                mb.damping_mut()[dof] = joint.damping;
                mb.frictions_mut()[dof] = joint.friction;
            }
        }

        for closure in &mechanism.loops {
            let generic = loop_joint(closure.motion, &closure.frame1, &closure.frame2);
            world.impulse_joints.insert(
                bodies[closure.link1],
                bodies[closure.link2],
                generic,
                true,
            );
        }

        Self {
            world,
            bodies,
            joint_links,
            mechanism: mechanism.clone(),
        }
    }

    /// Applies one step's joint efforts (per tree joint, URDF sign; N·m or N) and loads, then
    /// advances by dt. Efforts and loads act for this step only.
    pub fn step(&mut self, joint_efforts: &[f64], loads: &[Load]) {
        for &handle in &self.bodies {
            let body = &mut self.world.bodies[handle];
            body.reset_forces(false);
            body.reset_torques(false);
        }
        for (joint, &effort) in self.mechanism.joints.iter().zip(joint_efforts) {
            if effort == 0.0 {
                continue;
            }
            let (parent, child) = (self.bodies[joint.parent], self.bodies[joint.child]);
            match joint.motion {
                JointMotion::Revolute { sign } => {
                    self.world.bodies[child].add_torque(sign * effort, false);
                    self.world.bodies[parent].add_torque(-sign * effort, false);
                }
                JointMotion::Prismatic { axis } => {
                    let parent_pose = from_rapier(self.world.bodies[parent].position());
                    let frame = parent_pose.compose(&joint.origin);
                    let [ax, ay] = frame.rotate(axis[0], axis[1]);
                    let point = self.world.bodies[child].position().translation;
                    let force = Vector::new(ax * effort, ay * effort);
                    self.world.bodies[child].add_force_at_point(force, point, false);
                    self.world.bodies[parent].add_force_at_point(-force, point, false);
                }
                JointMotion::Fixed => {}
            }
        }
        for load in loads {
            let force = Vector::new(load.force[0], load.force[1]);
            let point = Vector::new(load.point[0], load.point[1]);
            self.world.bodies[self.bodies[load.link]].add_force_at_point(force, point, false);
        }
        self.world.step();
    }

    /// Reads the state into `state`, reusing its buffers.
    pub fn read_state(&self, state: &mut MechanismState) {
        let joints = &self.mechanism.joints;
        state.joint_positions.resize(joints.len(), 0.0);
        state.joint_velocities.resize(joints.len(), 0.0);
        for (j, joint) in joints.iter().enumerate() {
            let id = self.joint_links[j];
            let mb = self
                .world
                .multibody_joints
                .get_multibody(id.multibody)
                .expect("built");
            let link = mb.link(id.id).expect("link");
            let (coordinate, sign) = match joint.motion {
                JointMotion::Revolute { sign } => (link.joint().coords()[2], sign),
                JointMotion::Prismatic { .. } => (link.joint().coords()[0], 1.0),
                JointMotion::Fixed => (0.0, 0.0),
            };
            let velocity = mb.joint_velocity(link);
            state.joint_positions[j] = sign * coordinate;
            state.joint_velocities[j] = if velocity.is_empty() {
                0.0
            } else {
                sign * velocity[0]
            };
        }
        state.link_poses.clear();
        state.link_velocities.clear();
        state.link_angular_velocities.clear();
        for &handle in &self.bodies {
            let body = &self.world.bodies[handle];
            let pose = from_rapier(body.position());
            let origin = Vector::new(pose.x, pose.y);
            let velocity = body.velocity_at_point(origin);
            state.link_poses.push(pose);
            state.link_velocities.push([velocity.x, velocity.y]);
            state.link_angular_velocities.push(body.angvel());
        }
        state.loop_gaps.clear();
        for closure in &self.mechanism.loops {
            let frame1 = state.link_poses[closure.link1].compose(&closure.frame1);
            let frame2 = state.link_poses[closure.link2].compose(&closure.frame2);
            let gap = [frame2.x - frame1.x, frame2.y - frame1.y];
            state.loop_gaps.push(match closure.motion {
                JointMotion::Prismatic { axis } => {
                    let [ax, ay] = frame1.rotate(axis[0], axis[1]);
                    (gap[1] * ax - gap[0] * ay).abs()
                }
                _ => gap[0].hypot(gap[1]),
            });
        }
    }
}

fn to_rapier(pose: &Pose2) -> Pose {
    Pose::new(Vector::new(pose.x, pose.y), pose.angle)
}

fn from_rapier(pose: &Pose) -> Pose2 {
    Pose2::new(
        pose.translation.x,
        pose.translation.y,
        pose.rotation.angle(),
    )
}

/// The rotation that turns a prismatic axis into the joint frame's x axis (Rapier slides along x).
fn axis_frame(motion: JointMotion) -> Pose2 {
    match motion {
        JointMotion::Prismatic { axis } => Pose2::new(0.0, 0.0, axis[1].atan2(axis[0])),
        _ => Pose2::IDENTITY,
    }
}

fn locked_axes(motion: JointMotion) -> JointAxesMask {
    match motion {
        JointMotion::Revolute { .. } => JointAxesMask::LOCKED_REVOLUTE_AXES,
        JointMotion::Prismatic { .. } => JointAxesMask::LOCKED_PRISMATIC_AXES,
        JointMotion::Fixed => JointAxesMask::LOCKED_FIXED_AXES,
    }
}

fn tree_joint(motion: JointMotion, origin: &Pose2, limits: Option<[f64; 2]>) -> GenericJoint {
    let align = axis_frame(motion);
    let mut builder = GenericJointBuilder::new(locked_axes(motion))
        .local_frame1(to_rapier(&origin.compose(&align)))
        .local_frame2(to_rapier(&align));
    if let Some([lower, upper]) = limits {
        builder = match motion {
            JointMotion::Revolute { sign } if sign > 0.0 => {
                builder.limits(JointAxis::AngX, [lower, upper])
            }
            JointMotion::Revolute { .. } => builder.limits(JointAxis::AngX, [-upper, -lower]),
            JointMotion::Prismatic { .. } => builder.limits(JointAxis::LinX, [lower, upper]),
            JointMotion::Fixed => builder,
        };
    }
    builder.build()
}

fn loop_joint(motion: JointMotion, frame1: &Pose2, frame2: &Pose2) -> GenericJoint {
    let align = axis_frame(motion);
    // For a prismatic loop the axis is given in frame1; frame2 coincides with frame1 when
    // assembled, so the same rotation aligns both.
    GenericJointBuilder::new(locked_axes(motion))
        .local_frame1(to_rapier(&frame1.compose(&align)))
        .local_frame2(to_rapier(&frame2.compose(&align)))
        .build()
}
