//! A planar serial chain of revolute joints (a robot arm), its dynamics by the recursive
//! Newton–Euler algorithm and an RK4 integrator: a reference for the twin's engine that shares
//! none of its code or formulation (the engine assembles M = Σ Jᵀ·M·J from Rapier's body
//! Jacobians; this recurses forces link by link).
//!
//! Joint i turns link i about +z at the origin of its frame, placed by `origin` in link i−1's
//! frame (link −1 is the fixed base at the world origin). Inverse dynamics τ = M(q)·q̈ + h(q, q̇)
//! comes from one Newton–Euler pass; M column by column, h with q̈ = 0.

/// One link and the joint that carries it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChainLink {
    /// The joint frame in the previous link's frame: x, y (m), angle (rad).
    pub origin: [f64; 3],
    /// Link mass, kg.
    pub mass: f64,
    /// Centre of mass in the link frame, m.
    pub centre_of_mass: [f64; 2],
    /// Moment of inertia about z through the centre of mass, kg·m².
    pub izz: f64,
    /// Viscous joint damping, N·m·s/rad.
    pub damping: f64,
}

/// A planar serial chain under gravity.
#[derive(Debug, Clone, PartialEq)]
pub struct SerialChain {
    /// The links from the base outwards; joint i carries link i.
    pub links: Vec<ChainLink>,
    /// m/s².
    pub gravity: [f64; 2],
}

/// What a Newton–Euler pass's outward sweep leaves for its inward one, per link.
#[derive(Default)]
struct Sweep {
    /// Centre-of-mass accelerations, m/s².
    com_acc: Vec<[f64; 2]>,
    /// Angular accelerations, rad/s².
    alpha: Vec<f64>,
}

/// Per-link positions in the world for a configuration.
struct Frames {
    /// Joint (link frame origin) positions.
    joint: Vec<[f64; 2]>,
    /// Centres of mass.
    com: Vec<[f64; 2]>,
}

impl SerialChain {
    fn frames(&self, q: &[f64]) -> Frames {
        let mut angle = 0.0;
        let mut position = [0.0, 0.0];
        let mut frames = Frames {
            joint: Vec::with_capacity(q.len()),
            com: Vec::with_capacity(q.len()),
        };
        for (link, &qi) in self.links.iter().zip(q) {
            position = add(position, rotate(angle, [link.origin[0], link.origin[1]]));
            angle += link.origin[2] + qi;
            frames.joint.push(position);
            frames
                .com
                .push(add(position, rotate(angle, link.centre_of_mass)));
        }
        frames
    }

    /// Joint torques τ = M(q)·q̈ + C(q, q̇)·q̇ + g(q), with `gravity` scaling the gravity term
    /// (0 or 1): recursive Newton–Euler, outward for accelerations, inward for forces.
    fn inverse_dynamics(&self, q: &[f64], qd: &[f64], qdd: &[f64], gravity: f64) -> Vec<f64> {
        let mut torque = vec![0.0; self.links.len()];
        let sweep = &mut Sweep::default();
        self.newton_euler(&self.frames(q), (qd, qdd, gravity), sweep, &mut torque);
        torque
    }

    /// [`SerialChain::inverse_dynamics`] into `torque`, at the configuration whose `frames` are
    /// given, for (q̇, q̈, gravity's scale); `sweep` keeps the outward pass for the inward one.
    fn newton_euler(
        &self,
        frames: &Frames,
        (qd, qdd, gravity): (&[f64], &[f64], f64),
        sweep: &mut Sweep,
        torque: &mut [f64],
    ) {
        let n = self.links.len();
        let (mut omega, mut alpha) = (0.0, 0.0);
        // Gravity as an upward acceleration of the base.
        let mut joint_acc = [-gravity * self.gravity[0], -gravity * self.gravity[1]];
        let Sweep {
            com_acc,
            alpha: link_alpha,
        } = sweep;
        com_acc.resize(n, [0.0; 2]);
        link_alpha.resize(n, 0.0);
        for i in 0..n {
            if i > 0 {
                let r = sub(frames.joint[i], frames.joint[i - 1]);
                joint_acc = add(joint_acc, rigid_acceleration(alpha, omega, r));
            }
            omega += qd[i];
            alpha += qdd[i];
            let r = sub(frames.com[i], frames.joint[i]);
            com_acc[i] = add(joint_acc, rigid_acceleration(alpha, omega, r));
            link_alpha[i] = alpha;
        }
        let (mut force, mut moment) = ([0.0; 2], 0.0);
        let mut outer_joint = [0.0; 2];
        for i in (0..n).rev() {
            let link = &self.links[i];
            let inertial = [link.mass * com_acc[i][0], link.mass * com_acc[i][1]];
            // Moment about joint i: the child's force acts at joint i+1.
            let lever_child = sub(outer_joint, frames.joint[i]);
            moment = moment
                + cross(lever_child, force)
                + link.izz * link_alpha[i]
                + cross(sub(frames.com[i], frames.joint[i]), inertial);
            force = add(force, inertial);
            outer_joint = frames.joint[i];
            torque[i] = moment;
        }
    }

    /// The joint-space mass matrix M(q), row by row: column k is the torque for q̈ = e_k at rest
    /// without gravity. The configuration's frames, and the passes' buffers, are made once for
    /// all the columns.
    pub fn mass_matrix(&self, q: &[f64]) -> Vec<Vec<f64>> {
        let n = self.links.len();
        let frames = self.frames(q);
        let zero = vec![0.0; n];
        let mut mass = vec![vec![0.0; n]; n];
        let (mut unit, mut column) = (zero.clone(), zero.clone());
        let sweep = &mut Sweep::default();
        for k in 0..n {
            unit.fill(0.0);
            unit[k] = 1.0;
            self.newton_euler(&frames, (&zero, &unit, 0.0), sweep, &mut column);
            for (row, value) in mass.iter_mut().zip(&column) {
                row[k] = *value;
            }
        }
        mass
    }

    /// The leading `N`×`N` block of M(q) (the first `N` joints'), by the composite-rigid-body
    /// sum rather than Newton–Euler passes: joint i moves the centre of mass c_k of every link
    /// k ≥ i at ω × (c_k − p_i), so `M_ij = Σ_{k ≥ max(i, j)} m_k·(c_k − p_i)·(c_k − p_j) + I_k`.
    /// Equal to [`SerialChain::mass_matrix`] to rounding, with no allocation and one `sin_cos` a
    /// link: a controller evaluates it every period. `q` has one angle per link.
    pub fn mass_block<const N: usize>(&self, q: &[f64]) -> [[f64; N]; N] {
        // The lower triangle, then mirrored.
        let mut mass = [[0.0; N]; N];
        let mut joints = [[0.0; 2]; N];
        let (mut position, mut angle, mut turn) = ([0.0, 0.0], 0.0, (0.0, 1.0));
        for (k, (link, &qk)) in self.links.iter().zip(q).enumerate() {
            position = add(position, turned(turn, [link.origin[0], link.origin[1]]));
            angle += link.origin[2] + qk;
            turn = angle.sin_cos();
            let com = add(position, turned(turn, link.centre_of_mass));
            if k < N {
                joints[k] = position;
            }
            let reach = (k + 1).min(N);
            for i in 0..reach {
                let ri = sub(com, joints[i]);
                for j in 0..=i {
                    let rj = sub(com, joints[j]);
                    mass[i][j] += link.mass * (ri[0] * rj[0] + ri[1] * rj[1]) + link.izz;
                }
            }
        }
        std::array::from_fn(|i| std::array::from_fn(|j| mass[i.max(j)][i.min(j)]))
    }

    /// q̈ under joint torques `tau` (plus the joints' damping), solving M·q̈ = τ − h.
    pub fn acceleration(&self, q: &[f64], qd: &[f64], tau: &[f64]) -> Vec<f64> {
        let n = self.links.len();
        let bias = self.inverse_dynamics(q, qd, &vec![0.0; n], 1.0);
        let mass = self.mass_matrix(q);
        let rhs: Vec<f64> = (0..n)
            .map(|i| tau[i] - self.links[i].damping * qd[i] - bias[i])
            .collect();
        solve(mass, rhs)
    }

    /// Advances (q, q̇) by `dt` with classical RK4, torques held.
    pub fn rk4_step(&self, q: &mut [f64], qd: &mut [f64], tau: &[f64], dt: f64) {
        let n = q.len();
        let shifted = |base: &[f64], rate: &[f64], h: f64| -> Vec<f64> {
            (0..n).map(|i| base[i] + h * rate[i]).collect()
        };
        let a1 = self.acceleration(q, qd, tau);
        let (q2, v2) = (shifted(q, qd, dt / 2.0), shifted(qd, &a1, dt / 2.0));
        let a2 = self.acceleration(&q2, &v2, tau);
        let (q3, v3) = (shifted(q, &v2, dt / 2.0), shifted(qd, &a2, dt / 2.0));
        let a3 = self.acceleration(&q3, &v3, tau);
        let (q4, v4) = (shifted(q, &v3, dt), shifted(qd, &a3, dt));
        let a4 = self.acceleration(&q4, &v4, tau);
        for i in 0..n {
            q[i] += dt / 6.0 * (qd[i] + 2.0 * v2[i] + 2.0 * v3[i] + v4[i]);
            qd[i] += dt / 6.0 * (a1[i] + 2.0 * a2[i] + 2.0 * a3[i] + a4[i]);
        }
    }

    /// Kinetic plus gravitational potential energy, J.
    pub fn energy(&self, q: &[f64], qd: &[f64]) -> f64 {
        let frames = self.frames(q);
        let mut omega = 0.0;
        let mut joint_velocity = [0.0; 2];
        let mut energy = 0.0;
        for (i, link) in self.links.iter().enumerate() {
            if i > 0 {
                let r = sub(frames.joint[i], frames.joint[i - 1]);
                joint_velocity = add(joint_velocity, [-omega * r[1], omega * r[0]]);
            }
            omega += qd[i];
            let r = sub(frames.com[i], frames.joint[i]);
            let v = add(joint_velocity, [-omega * r[1], omega * r[0]]);
            energy += 0.5 * link.mass * (v[0] * v[0] + v[1] * v[1])
                + 0.5 * link.izz * omega * omega
                - link.mass
                    * (self.gravity[0] * frames.com[i][0] + self.gravity[1] * frames.com[i][1]);
        }
        energy
    }
}

/// Acceleration of a point at `r` from a body's reference point, velocity products and α included.
fn rigid_acceleration(alpha: f64, omega: f64, r: [f64; 2]) -> [f64; 2] {
    [
        -alpha * r[1] - omega * omega * r[0],
        alpha * r[0] - omega * omega * r[1],
    ]
}

fn rotate(angle: f64, v: [f64; 2]) -> [f64; 2] {
    turned(angle.sin_cos(), v)
}

/// `v` turned by the angle whose (sine, cosine) is given.
fn turned((s, c): (f64, f64), v: [f64; 2]) -> [f64; 2] {
    [c * v[0] - s * v[1], s * v[0] + c * v[1]]
}

fn add(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] + b[0], a[1] + b[1]]
}

fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// Solves the small non-singular system `a·x = b` by Gaussian elimination with partial pivoting.
pub fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let mut x = vec![0.0; b.len()];
    solve_in_place(&mut a, &mut b, &mut x);
    x
}

/// [`solve`] on rows of any kind (fixed arrays need no allocation): `a` and `b` are overwritten
/// by the elimination, the solution written to `x`.
pub fn solve_in_place<R: AsRef<[f64]> + AsMut<[f64]>>(a: &mut [R], b: &mut [f64], x: &mut [f64]) {
    let n = b.len();
    for col in 0..n {
        let pivot = (col..n)
            .max_by(|&i, &j| {
                a[i].as_ref()[col]
                    .abs()
                    .total_cmp(&a[j].as_ref()[col].abs())
            })
            .unwrap_or(col);
        a.swap(col, pivot);
        b.swap(col, pivot);
        let (upper, lower) = a.split_at_mut(col + 1);
        let pivot_row = upper[col].as_ref();
        for (offset, row) in lower.iter_mut().enumerate() {
            let row = row.as_mut();
            let factor = row[col] / pivot_row[col];
            for (x, p) in row[col..].iter_mut().zip(&pivot_row[col..]) {
                *x -= factor * p;
            }
            b[col + 1 + offset] -= factor * b[col];
        }
    }
    for row in (0..n).rev() {
        let tail: f64 = (row + 1..n).map(|k| a[row].as_ref()[k] * x[k]).sum();
        x[row] = (b[row] - tail) / a[row].as_ref()[row];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pendulum(length: f64, mass: f64) -> SerialChain {
        SerialChain {
            links: vec![ChainLink {
                origin: [0.0, 0.0, 0.0],
                mass,
                centre_of_mass: [length, 0.0],
                izz: 0.0,
                damping: 0.0,
            }],
            gravity: [0.0, -9.81],
        }
    }

    #[test]
    fn a_point_pendulum_obeys_g_over_l() {
        let chain = pendulum(0.5, 2.0);
        // Horizontal, at rest: θ̈ = −(g/l)·cos θ = −19.62 rad/s².
        let a = chain.acceleration(&[0.0], &[0.0], &[0.0]);
        assert!((a[0] + 9.81 / 0.5).abs() < 1e-12, "{a:?}");
        // Spinning at ω, hanging down: no angular acceleration, torque-free.
        let a = chain.acceleration(&[-std::f64::consts::FRAC_PI_2], &[3.0], &[0.0]);
        assert!(a[0].abs() < 1e-12, "{a:?}");
    }

    #[test]
    fn the_mass_block_is_newton_eulers_mass_matrix() {
        let link = |x: f64, angle: f64, mass: f64| ChainLink {
            origin: [x, 0.05, angle],
            mass,
            centre_of_mass: [0.12, -0.03],
            izz: 0.02 * mass,
            damping: 0.0,
        };
        let chain = SerialChain {
            links: vec![
                link(0.1, 0.2, 3.0),
                link(0.4, -0.1, 2.0),
                link(0.3, 0.0, 1.0),
                link(0.1, 0.3, 0.5),
            ],
            gravity: [0.0, -9.81],
        };
        for q in [[0.0; 4], [0.3, -1.2, 0.4, 0.0], [2.5, 1.1, -2.9, 0.7]] {
            let full = chain.mass_matrix(&q);
            let block: [[f64; 3]; 3] = chain.mass_block(&q);
            for i in 0..3 {
                for j in 0..3 {
                    let scale = full[i][i].abs().max(full[j][j].abs());
                    assert!(
                        (block[i][j] - full[i][j]).abs() <= 1e-14 * scale,
                        "{q:?} ({i}, {j}): {} vs {}",
                        block[i][j],
                        full[i][j]
                    );
                }
            }
        }
    }

    #[test]
    fn a_double_pendulum_keeps_its_energy_under_rk4() {
        let link = ChainLink {
            origin: [0.0, 0.0, 0.0],
            mass: 1.0,
            centre_of_mass: [0.2, 0.0],
            izz: 0.01,
            damping: 0.0,
        };
        let chain = SerialChain {
            links: vec![
                link,
                ChainLink {
                    origin: [0.4, 0.0, 0.0],
                    ..link
                },
            ],
            gravity: [0.0, -9.81],
        };
        let (mut q, mut qd) = (vec![0.3, -0.2], vec![0.0, 0.0]);
        let start = chain.energy(&q, &qd);
        for _ in 0..20_000 {
            chain.rk4_step(&mut q, &mut qd, &[0.0, 0.0], 1e-4);
        }
        let end = chain.energy(&q, &qd);
        assert!((end - start).abs() < 1e-9, "{start} → {end}");
    }
}
