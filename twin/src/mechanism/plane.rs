//! The plane a URDF's mechanism moves in, whatever its direction, and the turn that lays the
//! URDF's frames onto the twin's xy plane.
//!
//! A planar mechanism's revolute axes are all parallel; the twin's own URDFs turn about z, but
//! Drake's `Acrobot.urdf` turns about y and a z-up CAD export about x or y. The first revolute
//! (or continuous) joint's axis is the plane's normal n. One rotation R, the same for every
//! frame, re-expresses the whole URDF so that n becomes ±z: the plane's first axis is the URDF's
//! x (or y, when n is x) and its second, the one drawn upwards, is the URDF's z (y when n is z).
//! So a z-up model hangs down the screen as it hangs in the world, and a model already about z
//! is read exactly as before (R is the identity and nothing is touched).
//!
//! Every frame of the URDF (links, joints, inertials, loop-joint ends, wheels) is re-expressed as
//! R·T·Rᵀ, so a joint's rotation about n becomes a yaw; an axis becomes R·a; a geometry keeps
//! its shape axes (R·T), so a cylinder along the URDF's z lies in the plane; the inertia about
//! the plane's normal is the link's about n. The gravity and the points a scenario gives in the
//! URDF's frame are turned by the same R ([`Plane::vector`]).

/// A 3×3 rotation, rows first.
type Matrix = [[f64; 3]; 3];

/// The turn from the URDF's frame to the twin's plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    /// Rows: the plane's x, its y (up) and its normal, in the URDF's frame.
    rotation: Matrix,
}

impl Default for Plane {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Plane {
    /// The twin's own plane: the URDF's xy, seen from +z.
    pub const IDENTITY: Plane = Plane {
        rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    };

    /// The plane normal to `normal` (a unit vector, either sign), laid as the module says.
    pub fn normal_to(normal: [f64; 3]) -> Plane {
        if normal[0].abs() < 1e-12 && normal[1].abs() < 1e-12 {
            return Plane::IDENTITY;
        }
        let x_hint = if (normal[0].abs() - 1.0).abs() < 1e-12 {
            [0.0, 1.0, 0.0]
        } else {
            [1.0, 0.0, 0.0]
        };
        let x = unit(reject(x_hint, normal));
        let up = if (normal[2].abs() - 1.0).abs() < 1e-12 {
            [0.0, 1.0, 0.0]
        } else {
            [0.0, 0.0, 1.0]
        };
        let y = unit(reject(reject(up, normal), x));
        Plane {
            rotation: [x, y, cross(x, y)],
        }
    }

    /// Whether the URDF is already in the twin's plane (nothing to turn).
    pub fn is_identity(&self) -> bool {
        *self == Plane::IDENTITY
    }

    /// The plane's normal in the URDF's frame.
    pub fn normal(&self) -> [f64; 3] {
        self.rotation[2]
    }

    /// A vector of the URDF's frame in the plane's: R·v.
    pub fn vector(&self, v: [f64; 3]) -> [f64; 3] {
        let r = &self.rotation;
        [dot(r[0], v), dot(r[1], v), dot(r[2], v)]
    }

    /// A vector of the plane's frame in the URDF's: Rᵀ·v.
    pub fn in_urdf(&self, v: [f64; 3]) -> [f64; 3] {
        let r = &self.rotation;
        let column = |k: usize| r[0][k] * v[0] + r[1][k] * v[1] + r[2][k] * v[2];
        [column(0), column(1), column(2)]
    }

    /// A frame of the URDF (its origin's xyz and rpy) re-expressed: R·T·Rᵀ.
    pub fn frame(&self, xyz: [f64; 3], rpy: [f64; 3]) -> ([f64; 3], [f64; 3]) {
        let turned = multiply(
            &multiply(&self.rotation, &from_rpy(rpy)),
            &transpose(&self.rotation),
        );
        (self.vector(xyz), to_rpy(&turned))
    }

    /// A shape's frame re-expressed with its own axes kept: R·T, so the shape keeps its sizes.
    pub fn shape_frame(&self, xyz: [f64; 3], rpy: [f64; 3]) -> ([f64; 3], [f64; 3]) {
        (
            self.vector(xyz),
            to_rpy(&multiply(&self.rotation, &from_rpy(rpy))),
        )
    }

    /// The moment of inertia about the plane's normal of a tensor given in an inertial frame
    /// turned by `rpy` from its link: nᵀ·(Q·I·Qᵀ)·n.
    pub fn moment_about_normal(&self, inertia: Matrix, rpy: [f64; 3]) -> f64 {
        let q = from_rpy(rpy);
        let in_link = multiply(&multiply(&q, &inertia), &transpose(&q));
        let n = self.normal();
        let turned = [dot(in_link[0], n), dot(in_link[1], n), dot(in_link[2], n)];
        dot(n, turned)
    }
}

/// URDF's rpy as a rotation: Rz(yaw)·Ry(pitch)·Rx(roll).
fn from_rpy([roll, pitch, yaw]: [f64; 3]) -> Matrix {
    let (sr, cr) = roll.sin_cos();
    let (sp, cp) = pitch.sin_cos();
    let (sy, cy) = yaw.sin_cos();
    [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
}

/// A rotation's rpy (pitch in [−π/2, π/2]).
fn to_rpy(m: &Matrix) -> [f64; 3] {
    let pitch = (-m[2][0]).clamp(-1.0, 1.0).asin();
    if m[2][0].abs() < 1.0 - 1e-12 {
        [m[2][1].atan2(m[2][2]), pitch, m[1][0].atan2(m[0][0])]
    } else {
        // Gimbal lock: the roll is folded into the yaw.
        [0.0, pitch, (-m[0][1]).atan2(m[1][1])]
    }
}

fn multiply(a: &Matrix, b: &Matrix) -> Matrix {
    let mut out = [[0.0; 3]; 3];
    for (i, row) in out.iter_mut().enumerate() {
        for (j, value) in row.iter_mut().enumerate() {
            *value = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    out
}

fn transpose(m: &Matrix) -> Matrix {
    let mut out = [[0.0; 3]; 3];
    for (i, row) in m.iter().enumerate() {
        for (j, value) in row.iter().enumerate() {
            out[j][i] = *value;
        }
    }
    out
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `v` less its part along the unit vector `n`.
fn reject(v: [f64; 3], n: [f64; 3]) -> [f64; 3] {
    let along = dot(v, n);
    [
        v[0] - along * n[0],
        v[1] - along * n[1],
        v[2] - along * n[2],
    ]
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let norm = dot(v, v).sqrt();
    [v[0] / norm, v[1] / norm, v[2] / norm]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        (0..3).all(|i| (a[i] - b[i]).abs() < 1e-12)
    }

    #[test]
    fn a_y_normal_lays_x_and_z_on_the_plane_z_up() {
        let plane = Plane::normal_to([0.0, 1.0, 0.0]);
        assert!(close(plane.vector([1.0, 0.0, 0.0]), [1.0, 0.0, 0.0]));
        assert!(close(plane.vector([0.0, 0.0, 1.0]), [0.0, 1.0, 0.0]));
        assert!(close(plane.vector([0.0, 1.0, 0.0]), [0.0, 0.0, -1.0]));
        assert!(close(plane.vector([0.0, 0.0, -9.81]), [0.0, -9.81, 0.0]));
    }

    #[test]
    fn an_x_normal_lays_y_and_z_on_the_plane() {
        let plane = Plane::normal_to([-1.0, 0.0, 0.0]);
        assert!(close(plane.vector([0.0, 1.0, 0.0]), [1.0, 0.0, 0.0]));
        assert!(close(plane.vector([0.0, 0.0, 1.0]), [0.0, 1.0, 0.0]));
    }

    #[test]
    fn a_z_normal_is_the_identity_and_a_turn_about_the_normal_becomes_a_yaw() {
        assert!(Plane::normal_to([0.0, 0.0, -1.0]).is_identity());
        let plane = Plane::normal_to([0.0, 1.0, 0.0]);
        let (_, rpy) = plane.frame([0.0; 3], [0.0, 0.3, 0.0]);
        assert!(rpy[0].abs() < 1e-12 && rpy[1].abs() < 1e-12, "{rpy:?}");
        assert!((rpy[2] + 0.3).abs() < 1e-12, "{rpy:?}");
    }

    #[test]
    fn rpy_round_trips_and_the_moment_is_the_one_about_the_normal() {
        let rpy = [0.2, -0.4, 1.1];
        let back = to_rpy(&from_rpy(rpy));
        assert!(close(back, rpy), "{back:?}");
        let inertia = [[1.0, 0.0, 0.0], [0.0, 0.083, 0.0], [0.0, 0.0, 1.0]];
        let plane = Plane::normal_to([0.0, 1.0, 0.0]);
        assert!((plane.moment_about_normal(inertia, [0.0; 3]) - 0.083).abs() < 1e-15);
    }
}
