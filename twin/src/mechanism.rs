//! A planar mechanism as the twin understands it, independent of the physics engine and of the
//! recording: links with mass and shapes, a joint tree and the joints that close its loops, and
//! the [`Plane`] its URDF was laid onto.

mod plane;

pub use plane::Plane;

/// A rigid transform in the plane: rotation by `angle` (rad, counter-clockwise) then translation.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pose2 {
    /// Translation along the parent's x, m.
    pub x: f64,
    /// Translation along the parent's y, m.
    pub y: f64,
    /// Rotation, rad, counter-clockwise.
    pub angle: f64,
}

impl Pose2 {
    /// No rotation and no translation: the frame is its parent's.
    pub const IDENTITY: Pose2 = Pose2 {
        x: 0.0,
        y: 0.0,
        angle: 0.0,
    };

    /// The pose translated by (`x`, `y`) (m) after a rotation by `angle` (rad).
    pub fn new(x: f64, y: f64, angle: f64) -> Self {
        Self { x, y, angle }
    }

    /// `self ∘ other`: `other` expressed in the frame `self` maps to its parent.
    pub fn compose(&self, other: &Pose2) -> Pose2 {
        let [x, y] = self.apply(other.x, other.y);
        Pose2 {
            x,
            y,
            angle: self.angle + other.angle,
        }
    }

    /// Maps a point from this frame to its parent.
    pub fn apply(&self, x: f64, y: f64) -> [f64; 2] {
        let (s, c) = self.angle.sin_cos();
        [self.x + c * x - s * y, self.y + s * x + c * y]
    }

    /// Rotates a direction from this frame to its parent.
    pub fn rotate(&self, x: f64, y: f64) -> [f64; 2] {
        let (s, c) = self.angle.sin_cos();
        [c * x - s * y, s * x + c * y]
    }
}

/// The angle brought into (−π, π]; one already there (or not finite) is returned as it is.
pub fn wrap_angle(angle: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    if !angle.is_finite() || (-PI < angle && angle <= PI) {
        return angle;
    }
    let wrapped = angle.rem_euclid(TAU);
    if wrapped > PI {
        wrapped - TAU
    } else {
        wrapped
    }
}

/// The convex hull of `points`, counter-clockwise, without repeated or collinear points
/// (Andrew's monotone chain: no panic on any input, non-finite points are left out).
pub fn convex_hull(points: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut sorted: Vec<[f64; 2]> = points
        .iter()
        .copied()
        .filter(|p| p.iter().all(|v| v.is_finite()))
        .collect();
    sorted.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    sorted.dedup();
    if sorted.len() < 3 {
        return sorted;
    }
    let turns_left = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]) > 0.0
    };
    let mut hull: Vec<[f64; 2]> = Vec::with_capacity(2 * sorted.len());
    // The lower chain left to right, then the upper one back, each point kept only while the
    // chain turns left at it.
    let add = |hull: &mut Vec<[f64; 2]>, floor: usize, p: [f64; 2]| {
        while hull.len() >= floor && !turns_left(hull[hull.len() - 2], hull[hull.len() - 1], p) {
            hull.pop();
        }
        hull.push(p);
    };
    for &p in &sorted {
        add(&mut hull, 2, p);
    }
    let floor = hull.len() + 1;
    for &p in sorted.iter().rev().skip(1) {
        add(&mut hull, floor, p);
    }
    hull.pop();
    hull
}

/// A polygon's area (shoelace formula), positive when its points run counter-clockwise, m².
pub fn polygon_area(points: &[[f64; 2]]) -> f64 {
    let n = points.len();
    0.5 * (0..n)
        .map(|i| {
            let ([x0, y0], [x1, y1]) = (points[i], points[(i + 1) % n]);
            x0 * y1 - x1 * y0
        })
        .sum::<f64>()
}

/// A drawable or collision outline in a link's frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Shape {
    /// The outline's frame in the link's frame.
    pub origin: Pose2,
    /// Its geometry in its own frame.
    pub outline: Outline,
    /// RGBA in 0..1, from the URDF material when it has one.
    pub color: Option<[f32; 4]>,
}

impl Shape {
    /// Points bounding the outline, in the link's frame: a rectangle's corners, a circle's
    /// bounding square's.
    pub fn extent(&self) -> [[f64; 2]; 4] {
        let ([x0, y0], [x1, y1]) = match &self.outline {
            Outline::Rectangle { width, height } => {
                ([-width / 2.0, -height / 2.0], [width / 2.0, height / 2.0])
            }
            Outline::Circle { radius } => ([-radius, -radius], [*radius, *radius]),
            Outline::Polygon { points } => points.iter().fold(
                ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
                |([x0, y0], [x1, y1]), &[x, y]| ([x0.min(x), y0.min(y)], [x1.max(x), y1.max(y)]),
            ),
        };
        [[x0, y0], [x1, y0], [x1, y1], [x0, y1]].map(|[x, y]| self.origin.apply(x, y))
    }

    /// The same shape placed in the frame `pose` maps to its parent (a body's shape in the world).
    pub fn placed(&self, pose: &Pose2) -> Shape {
        Shape {
            origin: pose.compose(&self.origin),
            ..self.clone()
        }
    }
}

/// The geometry of a [`Shape`] in the plane, sizes in m, centred on the shape's origin.
#[derive(Debug, Clone, PartialEq)]
pub enum Outline {
    /// A URDF box seen from above, or a cylinder lying in the plane: full sizes along the
    /// shape's x and y.
    Rectangle {
        /// Full size along the shape's x, m.
        width: f64,
        /// Full size along the shape's y, m.
        height: f64,
    },
    /// A URDF cylinder (axis along z) or sphere.
    Circle {
        /// Radius, m.
        radius: f64,
    },
    /// A convex polygon, counter-clockwise, in the shape's frame: a mesh's outline on the plane
    /// (the convex hull of its vertices) or a scenario body's `points`.
    Polygon {
        /// Vertices [x, y], m, counter-clockwise.
        points: Vec<[f64; 2]>,
    },
}

/// Mass properties about the centre of mass, in the link's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inertial {
    pub mass: f64,
    pub centre_of_mass: [f64; 2],
    /// Moment of inertia about z through the centre of mass, kg·m².
    pub izz: f64,
}

impl Inertial {
    /// The same body with another mass: izz scales with it (same shape, other density).
    pub fn with_mass(self, mass: f64) -> Self {
        Self {
            mass,
            izz: self.izz * mass / self.mass,
            ..self
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    pub name: String,
    /// `None` only for the fixed root (the ground).
    pub inertial: Option<Inertial>,
    pub visuals: Vec<Shape>,
    pub collisions: Vec<Shape>,
}

/// What a joint lets its child do relative to its parent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum JointMotion {
    /// Rotation about ±z. `sign` is +1 for axis +z, −1 for −z: the joint coordinate and its effort
    /// are counted about the URDF's axis.
    Revolute {
        /// +1 or −1: the URDF axis's z component.
        sign: f64,
    },
    /// Translation along a unit axis in the joint frame's xy plane.
    Prismatic {
        /// Unit direction of positive travel, in the joint frame.
        axis: [f64; 2],
    },
    /// No relative motion: the child is welded to the parent.
    Fixed,
}

impl JointMotion {
    /// Whether the joint has a coordinate (revolute or prismatic), not fixed.
    pub fn is_movable(&self) -> bool {
        !matches!(self, JointMotion::Fixed)
    }
}

/// A joint of the spanning tree.
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    pub name: String,
    pub motion: JointMotion,
    /// Index into [`Mechanism::links`].
    pub parent: usize,
    pub child: usize,
    /// The joint frame in the parent's frame; the child's frame coincides with it at zero
    /// coordinate.
    pub origin: Pose2,
    /// Coordinate limits `[lower, upper]` in the URDF's sense (rad or m), when the joint has them.
    pub limits: Option<[f64; 2]>,
    /// Largest |effort| (N·m or N); `Some` marks the joint as actuated.
    pub effort_limit: Option<f64>,
    /// Largest |velocity| the URDF declares (rad/s or m/s), when it declares one above zero.
    pub velocity_limit: Option<f64>,
    /// Viscous damping, N·m·s/rad or N·s/m.
    pub damping: f64,
    /// Dry friction, N·m or N.
    pub friction: f64,
    /// A spring between parent and child (the `<spring>` extension), when the joint has one.
    pub spring: Option<JointSpring>,
    /// A transmission's mechanical reduction: the joint's effort is this times its actuator's
    /// (1 without a `<transmission>`).
    pub reduction: f64,
}

/// A linear joint spring: effort −stiffness·(coordinate − reference), in the joint's URDF sense.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointSpring {
    /// N·m/rad or N/m.
    pub stiffness: f64,
    /// The coordinate at which the spring is relaxed, rad or m.
    pub reference: f64,
}

/// A joint that closes a kinematic loop (the `<loop_joint>` extension).
#[derive(Debug, Clone, PartialEq)]
pub struct LoopJoint {
    pub name: String,
    /// Revolute (sign ignored) or prismatic; the axis is in `frame1`.
    pub motion: JointMotion,
    pub link1: usize,
    pub link2: usize,
    /// The joint frame in link1's frame and in link2's frame; they coincide in the assembled pose.
    pub frame1: Pose2,
    pub frame2: Pose2,
}

/// A rolling wheel on a link (the `<wheel>` extension): it spins about an axis in the plane, which
/// a planar world cannot rotate about, so it is not a body of the tree but a spin state the machine
/// integrates, touching the floor at its frame's origin.
#[derive(Debug, Clone, PartialEq)]
pub struct Wheel {
    pub name: String,
    /// Index into [`Mechanism::links`]: the link carrying the axle.
    pub link: usize,
    /// The wheel centre (and, seen from above, its contact point) in the link's frame.
    pub origin: Pose2,
    /// Unit spin axis in the wheel's frame (`origin`), in the plane; a positive spin rolls the
    /// wheel towards `axis × z`.
    pub axis: [f64; 2],
    /// Rolling radius, m.
    pub radius: f64,
    /// Tread width, m (drawn).
    pub width: f64,
    /// Moment of inertia about the spin axis, kg·m².
    pub spin_inertia: f64,
    /// Tyre–floor friction coefficient μ.
    pub friction: f64,
    /// Largest |drive torque| at the wheel, N·m; `Some` marks a driven wheel (an actuator).
    pub effort_limit: Option<f64>,
}

impl Wheel {
    /// Rolling direction (for a positive spin) in the wheel's frame: `axis × z`.
    pub fn heading(&self) -> [f64; 2] {
        [self.axis[1], -self.axis[0]]
    }
}

/// A planar mechanism: links in tree order (the root, the ground, first; every parent before its
/// children), the tree's joints in the same order (joint `i` has child link `i + 1`), the loop
/// joints and the rolling wheels.
#[derive(Debug, Clone, PartialEq)]
pub struct Mechanism {
    /// The URDF robot's name.
    pub name: String,
    /// Where it came from (a file path or `<string>`), for error messages.
    pub source: String,
    /// Rigid bodies in tree order, the ground first.
    pub links: Vec<Link>,
    /// Spanning-tree joints: joint `i` carries link `i + 1`.
    pub joints: Vec<Joint>,
    /// Joints that close the tree's kinematic loops.
    pub loops: Vec<LoopJoint>,
    /// Rolling wheels: spin states integrated by the machine, not tree bodies.
    pub wheels: Vec<Wheel>,
    /// The turn from the URDF's frame to the plane the mechanism is described in (the identity
    /// for a URDF about z).
    pub plane: Plane,
    /// What the URDF holds that the twin leaves out (a `<frame>`, a transmission's interface),
    /// one line each, for the user.
    pub notes: Vec<String>,
}

impl Mechanism {
    /// Mass of `link` and every link below it in the tree, kg.
    pub fn carried_mass(&self, link: usize) -> f64 {
        let own = self.links[link].inertial.map_or(0.0, |i| i.mass);
        let below = self.joints.iter().filter(|j| j.parent == link);
        own + below.map(|j| self.carried_mass(j.child)).sum::<f64>()
    }

    /// Index into [`Mechanism::links`] of the link called `name`.
    pub fn link_index(&self, name: &str) -> Option<usize> {
        self.links.iter().position(|l| l.name == name)
    }

    /// Index into [`Mechanism::joints`] of the tree joint called `name`.
    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }

    /// World pose of every link with all tree joints at zero coordinate (the URDF's pose).
    pub fn zero_pose(&self) -> Vec<Pose2> {
        let mut poses = vec![Pose2::IDENTITY; self.links.len()];
        for joint in &self.joints {
            poses[joint.child] = poses[joint.parent].compose(&joint.origin);
        }
        poses
    }

    /// Index into [`Mechanism::wheels`] of the wheel called `name`.
    pub fn wheel_index(&self, name: &str) -> Option<usize> {
        self.wheels.iter().position(|w| w.name == name)
    }

    /// Indices of the actuated joints (those with an effort limit), in tree order.
    pub fn actuated_joints(&self) -> Vec<usize> {
        (0..self.joints.len())
            .filter(|&j| self.joints[j].effort_limit.is_some())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compose_maps_like_applying_twice() {
        let a = Pose2::new(0.3, -0.2, 0.7);
        let b = Pose2::new(-1.0, 0.5, -2.1);
        let ab = a.compose(&b);
        assert!((ab.angle - (0.7 - 2.1)).abs() < 1e-15);
        let inner = b.apply(0.1, 0.2);
        let p = ab.apply(0.1, 0.2);
        let q = a.apply(inner[0], inner[1]);
        assert!((p[0] - q[0]).abs() < 1e-15 && (p[1] - q[1]).abs() < 1e-15);
        let [dx, dy] = ab.rotate(1.0, 0.0);
        assert!((dx - ab.angle.cos()).abs() < 1e-15 && (dy - ab.angle.sin()).abs() < 1e-15);
    }

    #[test]
    fn the_hull_keeps_the_corners_counter_clockwise() {
        let points = [
            [0.0, 0.0],
            [2.0, 0.0],
            [1.0, 0.5],
            [2.0, 1.0],
            [1.0, 0.0],
            [0.0, 1.0],
            [0.0, 1.0],
            [f64::NAN, 3.0],
        ];
        let hull = convex_hull(&points);
        assert_eq!(hull, vec![[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]]);
        assert_eq!(polygon_area(&hull), 2.0);
        let line = convex_hull(&[[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]);
        assert_eq!(line, vec![[0.0, 0.0], [2.0, 2.0]]);
        assert!(convex_hull(&[]).is_empty());
    }
}
