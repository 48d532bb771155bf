//! What the engines hand out and take in, in the URDF's conventions: the mechanism's state after
//! a step ([`MechanismState`]), the loads on its links ([`Load`]), and the loop gaps read the
//! same way by both engines ([`loop_gaps`]).

use crate::mechanism::{JointMotion, Mechanism, Pose2};

/// Joint coordinates and link motion after a step, in the URDF's conventions.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MechanismState {
    /// Per tree joint (as [`Mechanism::joints`]): rad or m, counted along the URDF axis; 0 for
    /// fixed.
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
    /// Per scenario `[[bodies]]` entry: its frame in the world. Static bodies stay where the
    /// scenario puts them; free ones move as the rapier engine's contacts push them (the exact
    /// engine has no contacts and leaves them where they are put).
    pub body_poses: Vec<Pose2>,
}

/// An external force on a link (a process force: cutting, contact), in world coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Load {
    pub link: usize,
    /// The force at the start of the step, N.
    pub force: [f64; 2],
    /// Where it acts, world coordinates (at the start of the step; it moves with the link).
    pub point: [f64; 2],
    /// How the force changes with the point's velocity, ∂F/∂v (N·s/m, rows x and y): over the
    /// step the force is `force + damping·(v − v_start)`, so a stiff velocity-dependent process
    /// (a cut is a damper of thousands of N·s/m) is integrated with the motion, not frozen.
    pub damping: [[f64; 2]; 2],
    /// How the force changes with the point's displacement, ∂F/∂p (N/m, rows x and y): over the
    /// step the force adds `stiffness·(p − p_start)`, so a cut whose chip follows the tool's
    /// deflection pushes back within the step, not one step late (a lag that acts as damping).
    pub stiffness: [[f64; 2]; 2],
}

/// A load that does not depend on velocity.
pub const NO_DAMPING: [[f64; 2]; 2] = [[0.0; 2]; 2];
/// A load that does not depend on where its point is.
pub const NO_STIFFNESS: [[f64; 2]; 2] = [[0.0; 2]; 2];

/// Per loop joint, how far its two frames have drifted apart at the link poses (m), into
/// `gaps`: across the slide for a prismatic loop joint, the distance for a revolute one.
pub(super) fn loop_gaps(mechanism: &Mechanism, link_poses: &[Pose2], gaps: &mut Vec<f64>) {
    gaps.clear();
    for closure in &mechanism.loops {
        let frame1 = link_poses[closure.link1].compose(&closure.frame1);
        let frame2 = link_poses[closure.link2].compose(&closure.frame2);
        let gap = [frame2.x - frame1.x, frame2.y - frame1.y];
        gaps.push(match closure.motion {
            JointMotion::Prismatic { axis } => {
                let [ax, ay] = frame1.rotate(axis[0], axis[1]);
                (gap[1] * ax - gap[0] * ay).abs()
            }
            _ => gap[0].hypot(gap[1]),
        });
    }
}
