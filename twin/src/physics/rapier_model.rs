//! The Rapier side of the physics: the URDF tree as Rapier multibodies (reduced coordinates, one
//! per branch leaving the fixed ground), posed at given joint coordinates by Rapier's forward
//! kinematics and read back as link poses and body Jacobians. Nothing here integrates: the twin
//! advances the state itself ([`super::Physics`]).

use super::dynamics::{Frame, Kinematics};
use super::shapes::to_parry;
use crate::mechanism::{Inertial, JointMotion, Mechanism, Pose2};
use rapier2d_f64::prelude::*;

#[derive(Clone)]
pub(super) struct RapierModel {
    bodies: RigidBodySet,
    multibodies: MultibodyJointSet,
    /// Per generalized coordinate: the multibody link whose joint it is, and which of the joint's
    /// coordinates (0 = along x for a slider, 2 = the angle).
    dofs: Vec<(MultibodyLinkId, usize)>,
    /// Per mechanism link: its multibody link (`None` for the ground).
    links: Vec<Option<MultibodyLinkId>>,
    /// Each multibody once, with the generalized coordinate of each of its Jacobian columns.
    columns: Vec<(MultibodyIndex, Vec<usize>)>,
    ground: Pose2,
}

impl RapierModel {
    pub fn new(mechanism: &Mechanism) -> Self {
        let mut bodies = RigidBodySet::new();
        let poses = mechanism.zero_pose();
        let handles = insert_links(mechanism, &poses, &mut bodies);
        let mut multibodies = MultibodyJointSet::new();
        insert_tree(mechanism, &poses, &handles, &mut bodies, &mut multibodies);
        let mut links = vec![None; mechanism.links.len()];
        let mut dofs = Vec::new();
        let mut columns: Vec<(MultibodyIndex, Vec<usize>)> = Vec::new();
        for joint in &mechanism.joints {
            let id = *multibodies
                .rigid_body_link(handles[joint.child])
                .expect("inserted");
            links[joint.child] = Some(id);
            let mb = multibodies.get_multibody(id.multibody).expect("built");
            let entry = match columns.iter().position(|(m, _)| *m == id.multibody) {
                Some(i) => i,
                None => {
                    columns.push((id.multibody, vec![0; mb.ndofs()]));
                    columns.len() - 1
                }
            };
            let coordinate = match joint.motion {
                JointMotion::Fixed => continue,
                JointMotion::Prismatic { .. } => 0,
                JointMotion::Revolute { .. } => 2,
            };
            let column = mb.link(id.id).expect("link").assembly_id();
            columns[entry].1[column] = dofs.len();
            dofs.push((id, coordinate));
        }
        Self {
            bodies,
            multibodies,
            dofs,
            links,
            columns,
            ground: poses[0],
        }
    }

    /// Poses the multibodies at generalized coordinates `q` and fills `kin`.
    pub fn pose(&mut self, mechanism: &Mechanism, q: &[f64], kin: &mut Kinematics) {
        for (&(id, coordinate), &target) in self.dofs.iter().zip(q) {
            let mb = self
                .multibodies
                .get_multibody_mut(id.multibody)
                .expect("built");
            let joint = &mut mb.link_mut(id.id).expect("link").joint;
            let now = joint.coords()[coordinate];
            joint.apply_displacement(&[target - now]);
        }
        for (index, _) in &self.columns {
            let mb = self.multibodies.get_multibody_mut(*index).expect("built");
            mb.forward_kinematics(&self.bodies, false);
        }
        kin.resize(mechanism.links.len(), q.len());
        kin.posed();
        let n = q.len();
        kin.jv.fill(0.0);
        kin.jw.fill(0.0);
        for (l, link) in mechanism.links.iter().enumerate() {
            let Some(id) = self.links[l] else {
                kin.frames[l] = Frame::of(&self.ground);
                kin.com[l] = [self.ground.x, self.ground.y];
                continue;
            };
            let mb = self.multibodies.get_multibody(id.multibody).expect("built");
            let pose = mb.link(id.id).expect("link").local_to_world();
            let frame = Frame {
                origin: [pose.translation.x, pose.translation.y],
                cos: pose.rotation.re,
                sin: pose.rotation.im,
            };
            let com = link.inertial.map_or([0.0; 2], |i| i.centre_of_mass);
            kin.frames[l] = frame;
            kin.com[l] = frame.apply(com);
            let jacobian = mb.body_jacobian(id.id);
            let (_, map) = self
                .columns
                .iter()
                .find(|(m, _)| *m == id.multibody)
                .expect("mapped");
            for (column, &g) in map.iter().enumerate() {
                kin.jv[l * 2 * n + g] = jacobian[(0, column)];
                kin.jv[l * 2 * n + n + g] = jacobian[(1, column)];
                kin.jw[l * n + g] = jacobian[(2, column)];
            }
        }
    }

    /// Rapier's own mass matrix of each multibody at the last pose, as (M⁻¹)ᵢᵢ per generalized
    /// coordinate: the cross-check of the twin's M = Σ Jᵀ·M_link·J.
    #[cfg(test)]
    pub fn rapier_inverse_mass_diagonal(&mut self, n: usize) -> Vec<f64> {
        let mut diagonal = vec![0.0; n];
        for (index, map) in &self.columns {
            let mb = self.multibodies.get_multibody_mut(*index).expect("built");
            let inverse = mb.dof_inverse_inertia(&self.bodies);
            for (column, &g) in map.iter().enumerate() {
                diagonal[g] = inverse[column];
            }
        }
        diagonal
    }
}

/// One rigid body per link at the URDF's pose: fixed for the ground, dynamic with the URDF's mass
/// properties for the rest, never asleep (a machine at rest is still being driven).
pub(super) fn insert_links(
    mechanism: &Mechanism,
    poses: &[Pose2],
    bodies: &mut RigidBodySet,
) -> Vec<RigidBodyHandle> {
    mechanism
        .links
        .iter()
        .zip(poses)
        .map(|(link, pose)| {
            let builder = match link.inertial {
                None => RigidBodyBuilder::fixed(),
                Some(inertial) => RigidBodyBuilder::dynamic()
                    .additional_mass_properties(mass_properties(&inertial))
                    .can_sleep(false),
            };
            let mut body = builder.pose(to_parry(pose)).build();
            // The first forward kinematics needs the centre of mass before any pipeline step.
            body.recompute_mass_properties_from_colliders(&ColliderSet::new());
            bodies.insert(body)
        })
        .collect()
}

/// The tree joints as multibody joints (for the exact engine's kinematics and the rapier engine
/// alike), each branch leaving the ground on its own fixed anchor
/// (its own multibody: small mass matrices), contacts between the joined links off. Returns
/// each multibody once.
pub(super) fn insert_tree(
    mechanism: &Mechanism,
    poses: &[Pose2],
    handles: &[RigidBodyHandle],
    bodies: &mut RigidBodySet,
    multibodies: &mut MultibodyJointSet,
) -> Vec<MultibodyIndex> {
    for joint in &mechanism.joints {
        let parent = if joint.parent == 0 {
            bodies.insert(RigidBodyBuilder::fixed().pose(to_parry(&poses[0])))
        } else {
            handles[joint.parent]
        };
        let align = axis_frame(joint.motion);
        let data = GenericJointBuilder::new(locked_axes(joint.motion))
            .local_frame1(to_parry(&joint.origin.compose(&align)))
            .local_frame2(to_parry(&align))
            .contacts_enabled(false)
            .build();
        // A validated URDF tree inserts every parent before its children, so this cannot fail;
        // a joint it refused would stay out of the mechanism's coordinates (`link_ids`).
        let _ = multibodies.insert(parent, handles[joint.child], data, false);
    }
    let mut indices: Vec<MultibodyIndex> = Vec::new();
    for joint in &mechanism.joints {
        if let Some(id) = multibodies.rigid_body_link(handles[joint.child]) {
            if !indices.contains(&id.multibody) {
                indices.push(id.multibody);
            }
        }
    }
    for &index in &indices {
        let Some(mb) = multibodies.get_multibody_mut(index) else {
            continue;
        };
        // A new multibody's root is a free joint until forward kinematics sees the fixed
        // anchor: only then are its dof count and assembly ids final.
        mb.forward_kinematics(bodies, true);
        // Rapier's default multibody damping (0.1 per angular coordinate) is no part of the
        // plant: the URDF's own damping replaces it (`set_joint_terms`).
        mb.damping_mut().fill(0.0);
    }
    indices
}

pub(super) fn mass_properties(inertial: &Inertial) -> MassProperties {
    let [x, y] = inertial.centre_of_mass;
    MassProperties::new(Vector::new(x, y), inertial.mass, inertial.izz)
}

/// The rotation that turns a prismatic axis into the joint frame's x axis (Rapier slides along x).
pub(super) fn axis_frame(motion: JointMotion) -> Pose2 {
    match motion {
        JointMotion::Prismatic { axis } => Pose2::new(0.0, 0.0, axis[1].atan2(axis[0])),
        _ => Pose2::IDENTITY,
    }
}

pub(super) fn locked_axes(motion: JointMotion) -> JointAxesMask {
    match motion {
        JointMotion::Revolute { .. } => JointAxesMask::LOCKED_REVOLUTE_AXES,
        JointMotion::Prismatic { .. } => JointAxesMask::LOCKED_PRISMATIC_AXES,
        JointMotion::Fixed => JointAxesMask::LOCKED_FIXED_AXES,
    }
}
