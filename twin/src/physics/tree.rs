//! The tree's forward kinematics as the exact engine's stages need it: link frames, centres of
//! mass and body Jacobians at a configuration q, by one pass down the tree Rapier holds (parents
//! before children) and one over each link's ancestors. Rapier's multibodies answer the same
//! question ([`super::rapier_model`]) with the generality of 3-D joints; the engine asks it
//! several times a step, so it uses this plain planar recursion for every stage and the
//! end-of-step state, and Rapier's for the linearisation. Both are checked against each other on
//! every machine.

use super::dynamics::{Frame, Kinematics};
use crate::mechanism::{JointMotion, Mechanism};

/// One tree joint: where it sits on its parent and how it moves.
#[derive(Debug, Clone, Copy)]
struct TreeJoint {
    parent: usize,
    child: usize,
    /// The joint frame in the parent's frame.
    origin: Frame,
    motion: Motion,
}

/// How a joint moves its child, with its generalized coordinate.
#[derive(Debug, Clone, Copy)]
enum Motion {
    /// About +z by q (Rapier's sense).
    Revolute(usize),
    /// Along the axis (in the joint frame) by q.
    Prismatic(usize, [f64; 2]),
    Fixed,
}

/// The mechanism's tree, ready to be posed.
#[derive(Debug, Clone)]
pub(super) struct Tree {
    joints: Vec<TreeJoint>,
    /// Per link: the joints between it and the ground (indices into `joints`).
    ancestors: Vec<Vec<usize>>,
    /// Per link: its centre of mass in its frame.
    com: Vec<[f64; 2]>,
    ground: Frame,
    /// Per joint: the joint frame in the world at the last pose (scratch).
    anchors: Vec<Frame>,
}

impl Tree {
    pub fn new(mechanism: &Mechanism) -> Self {
        let mut dof = 0;
        let joints: Vec<TreeJoint> = (mechanism.joints.iter())
            .map(|joint| {
                let motion = match joint.motion {
                    JointMotion::Fixed => Motion::Fixed,
                    JointMotion::Revolute { .. } => Motion::Revolute(dof),
                    JointMotion::Prismatic { axis } => Motion::Prismatic(dof, axis),
                };
                dof += usize::from(!matches!(motion, Motion::Fixed));
                TreeJoint {
                    parent: joint.parent,
                    child: joint.child,
                    origin: Frame::of(&joint.origin),
                    motion,
                }
            })
            .collect();
        let mut ancestors = vec![Vec::new(); mechanism.links.len()];
        // Parents come before their children in a validated tree.
        for (j, joint) in joints.iter().enumerate() {
            let mut chain = ancestors[joint.parent].clone();
            chain.push(j);
            ancestors[joint.child] = chain;
        }
        let mut tree = Self {
            anchors: vec![Frame::IDENTITY; joints.len()],
            joints,
            ancestors,
            com: Vec::new(),
            ground: Frame::of(&mechanism.zero_pose()[0]),
        };
        tree.take_centres_of_mass(mechanism);
        tree
    }

    /// Takes the links' centres of mass anew (a plant fault changed one).
    pub fn take_centres_of_mass(&mut self, mechanism: &Mechanism) {
        self.com = (mechanism.links.iter())
            .map(|link| link.inertial.map_or([0.0; 2], |i| i.centre_of_mass))
            .collect();
    }

    /// Poses the tree at generalized coordinates `q` into `kin`.
    pub fn pose(&mut self, q: &[f64], kin: &mut Kinematics) {
        let n = q.len();
        kin.resize(self.com.len(), n);
        kin.posed();
        kin.frames[0] = self.ground;
        for (j, joint) in self.joints.iter().enumerate() {
            let at = compose(&kin.frames[joint.parent], &joint.origin);
            self.anchors[j] = at;
            kin.frames[joint.child] = match joint.motion {
                Motion::Revolute(g) => {
                    let (sin, cos) = q[g].sin_cos();
                    compose(
                        &at,
                        &Frame {
                            origin: [0.0; 2],
                            cos,
                            sin,
                        },
                    )
                }
                Motion::Prismatic(g, [ux, uy]) => Frame {
                    origin: at.apply([q[g] * ux, q[g] * uy]),
                    ..at
                },
                Motion::Fixed => at,
            };
        }
        for (l, frame) in kin.frames.iter().enumerate() {
            kin.com[l] = frame.apply(self.com[l]);
        }
        kin.jv.fill(0.0);
        kin.jw.fill(0.0);
        for (l, chain) in self.ancestors.iter().enumerate() {
            let [cx, cy] = kin.com[l];
            for &j in chain {
                let anchor = &self.anchors[j];
                match self.joints[j].motion {
                    Motion::Revolute(g) => {
                        // v = ω·z × (com − anchor)
                        kin.jv[l * 2 * n + g] = anchor.origin[1] - cy;
                        kin.jv[l * 2 * n + n + g] = cx - anchor.origin[0];
                        kin.jw[l * n + g] = 1.0;
                    }
                    Motion::Prismatic(g, axis) => {
                        let [ux, uy] = anchor.rotate(axis);
                        kin.jv[l * 2 * n + g] = ux;
                        kin.jv[l * 2 * n + n + g] = uy;
                    }
                    Motion::Fixed => {}
                }
            }
        }
    }
}

/// The frame `b` given in frame `a`, in the world.
fn compose(a: &Frame, b: &Frame) -> Frame {
    Frame {
        origin: a.apply(b.origin),
        cos: a.cos * b.cos - a.sin * b.sin,
        sin: a.sin * b.cos + a.cos * b.sin,
    }
}

#[cfg(test)]
mod tests {
    use super::super::rapier_model::RapierModel;
    use super::*;
    use crate::urdf;

    /// Every machine's tree, posed at scattered configurations by the recursion and by Rapier:
    /// the frames, centres of mass and body Jacobians agree to rounding.
    #[test]
    fn the_recursion_poses_every_machine_as_rapier_does() {
        let machines = [
            (
                "whitworth.urdf",
                include_str!("../../../urdf/whitworth.urdf"),
            ),
            ("arm.urdf", include_str!("../../../urdf/arm.urdf")),
            ("platform.urdf", include_str!("../../../urdf/platform.urdf")),
            (
                "feed_axis.urdf",
                include_str!("../../../urdf/feed_axis.urdf"),
            ),
            ("lathe.urdf", include_str!("../../../urdf/lathe.urdf")),
            ("milling.urdf", include_str!("../../../urdf/milling.urdf")),
        ];
        for (name, text) in machines {
            let mechanism = urdf::load_str(text, name).expect("loads");
            let (mut tree, mut rapier) = (Tree::new(&mechanism), RapierModel::new(&mechanism));
            let n = tree
                .joints
                .iter()
                .filter(|j| !matches!(j.motion, Motion::Fixed))
                .count();
            let (mut ours, mut theirs) = (Kinematics::default(), Kinematics::default());
            for configuration in 0..7 {
                let q: Vec<f64> = (0..n)
                    .map(|g| 1.3 * ((configuration * n + g) as f64 * 0.77).sin())
                    .collect();
                tree.pose(&q, &mut ours);
                rapier.pose(&mechanism, &q, &mut theirs);
                let pairs = (ours.frames.iter().zip(&theirs.frames))
                    .flat_map(|(a, b)| [(a.origin[0], b.origin[0]), (a.origin[1], b.origin[1])])
                    .chain(
                        ours.frames
                            .iter()
                            .zip(&theirs.frames)
                            .flat_map(|(a, b)| [(a.cos, b.cos), (a.sin, b.sin)]),
                    )
                    .chain(
                        ours.com
                            .iter()
                            .zip(&theirs.com)
                            .flat_map(|(a, b)| [(a[0], b[0]), (a[1], b[1])]),
                    )
                    .chain(ours.jv.iter().copied().zip(theirs.jv.iter().copied()))
                    .chain(ours.jw.iter().copied().zip(theirs.jw.iter().copied()));
                for (k, (a, b)) in pairs.enumerate() {
                    assert!(
                        (a - b).abs() <= 1e-13 * (1.0 + b.abs()),
                        "{name} at {q:?}: value {k} is {a} by the recursion, {b} by Rapier"
                    );
                }
            }
        }
    }
}
