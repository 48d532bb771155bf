//! The equations of motion the twin integrates, in the tree's generalized coordinates q with the
//! loop joints as constraints φ(q) = 0:
//!
//! ```text
//! M(q)·q̈ + Gᵀ·λ = Q(q, q̇, t)        M = Σ mₖ·Jvₖᵀ·Jvₖ + Iₖ·Jωₖᵀ·Jωₖ
//!        G·q̈    = −γ(q, q̇)           G = ∂φ/∂q,  γ = Ġ·q̇
//! ```
//!
//! The link poses and body Jacobians (Jvₖ at the centre of mass, Jωₖ) come from Rapier's
//! multibodies ([`super::rapier_model`]); everything here works on that snapshot. Q holds the
//! joint efforts, springs and damping, gravity and process loads, and the velocity-product
//! (Coriolis and centripetal) forces −Σ Jᵀ·m·J̇·q̇. In the plane an angular velocity is linear in
//! q̇ with constant coefficients, so J̇ω·q̇ = 0 and only the linear parts need the recursion of
//! [`LinkMotion::update`].
//!
//! Coordinates are Rapier's: a revolute joint about −z counts its angle about +z (the caller
//! converts URDF signs at the door).

use super::dense::{dot, ldl_backward, ldl_factor, ldl_forward, ldl_solve, size, sized};
use crate::mechanism::{wrap_angle, JointMotion, Mechanism, Pose2};

/// Pivots below this share of the largest make a loop constraint count as redundant.
const DEPENDENT_PIVOT: f64 = 1e-12;

/// A link frame in the world, its rotation kept as cos and sin (as Rapier keeps it): the
/// equations transform many points and directions per evaluation and need no angle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Frame {
    pub origin: [f64; 2],
    pub cos: f64,
    pub sin: f64,
}

impl Frame {
    pub const IDENTITY: Frame = Frame {
        origin: [0.0; 2],
        cos: 1.0,
        sin: 0.0,
    };

    pub fn of(pose: &Pose2) -> Self {
        let (sin, cos) = pose.angle.sin_cos();
        Frame {
            origin: [pose.x, pose.y],
            cos,
            sin,
        }
    }

    pub fn pose(&self) -> Pose2 {
        Pose2::new(self.origin[0], self.origin[1], self.sin.atan2(self.cos))
    }

    /// A direction from this frame to the world.
    pub fn rotate(&self, d: [f64; 2]) -> [f64; 2] {
        [
            self.cos * d[0] - self.sin * d[1],
            self.sin * d[0] + self.cos * d[1],
        ]
    }

    /// A point from this frame to the world.
    pub fn apply(&self, p: [f64; 2]) -> [f64; 2] {
        let [x, y] = self.rotate(p);
        [self.origin[0] + x, self.origin[1] + y]
    }

    /// A world point into this frame.
    pub fn local(&self, p: [f64; 2]) -> [f64; 2] {
        let [dx, dy] = sub(p, self.origin);
        [
            self.cos * dx + self.sin * dy,
            -self.sin * dx + self.cos * dy,
        ]
    }
}

/// Link poses and body Jacobians at one configuration, over all `n` generalized coordinates.
#[derive(Debug, Clone, Default)]
pub(super) struct Kinematics {
    pub n: usize,
    /// Which posing this is (unique in the process; 0: never posed): what [`Dynamics`] keys
    /// the matrices it keeps between calls on.
    pub generation: u64,
    /// Per link: the link frame in the world.
    pub frames: Vec<Frame>,
    /// Per link: the centre of mass in the world.
    pub com: Vec<[f64; 2]>,
    /// Per link: ∂v_com/∂q̇, rows x then y, `2·n` values.
    pub jv: Vec<f64>,
    /// Per link: ∂ω/∂q̇, `n` values.
    pub jw: Vec<f64>,
}

/// Postings so far, process-wide, so that no two poses share a generation.
static POSINGS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

impl Kinematics {
    /// Marks these kinematics as a new configuration's.
    pub fn posed(&mut self) {
        self.generation = 1 + POSINGS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    }

    pub fn resize(&mut self, links: usize, n: usize) {
        self.n = n;
        self.frames.resize(links, Frame::IDENTITY);
        self.com.resize(links, [0.0; 2]);
        self.jv.resize(links * 2 * n, 0.0);
        self.jw.resize(links * n, 0.0);
    }

    /// The coordinates, fixed at `N` where the caller knows them (see [`sized!`]).
    #[inline(always)]
    fn size<const N: usize>(&self) -> usize {
        size::<N>(self.n)
    }

    #[inline(always)]
    fn jv<const N: usize>(&self, link: usize) -> (&[f64], &[f64]) {
        let n = self.size::<N>();
        let rows = &self.jv[link * 2 * n..(link + 1) * 2 * n];
        rows.split_at(n)
    }

    #[inline(always)]
    fn jw<const N: usize>(&self, link: usize) -> &[f64] {
        let n = self.size::<N>();
        &self.jw[link * n..(link + 1) * n]
    }

    /// Velocity of a world point fixed on `link` and the link's angular velocity, [vx, vy, ω]:
    /// the centre of mass's J·q̇ plus ω × (point − com).
    pub fn point_velocity(&self, link: usize, point: [f64; 2], v: &[f64]) -> [f64; 3] {
        sized!(self.n, Self::point_velocity_of(self, link, point, v))
    }

    #[inline(always)]
    fn point_velocity_of<const N: usize>(
        &self,
        link: usize,
        point: [f64; 2],
        v: &[f64],
    ) -> [f64; 3] {
        let (jx, jy) = self.jv::<N>(link);
        let omega = dot(self.jw::<N>(link), v);
        let [rx, ry] = sub(point, self.com[link]);
        [dot(jx, v) - omega * ry, dot(jy, v) + omega * rx, omega]
    }
}

/// A joint spring (the `<spring>` extension), in Rapier coordinates: force −k·(q − reference).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct DofSpring {
    pub stiffness: f64,
    pub reference: f64,
}

/// The mechanism's dynamic data, indexed by generalized coordinate.
#[derive(Debug, Clone)]
pub(super) struct Model {
    pub mechanism: Mechanism,
    /// Per tree joint: its coordinate, if it moves.
    pub dof_of_joint: Vec<Option<usize>>,
    /// Per coordinate: +1, or −1 for a revolute joint about −z (URDF value = sign × coordinate).
    pub sign: Vec<f64>,
    pub damping: Vec<f64>,
    pub friction: Vec<f64>,
    pub spring: Vec<Option<DofSpring>>,
    /// Coordinate limits `[lower, upper]` in Rapier's sense.
    pub limits: Vec<Option<[f64; 2]>>,
    /// Rows of φ each loop joint adds.
    pub constraint_count: usize,
    /// Per tree joint: a prismatic axis in the parent's frame.
    pub slide_axes: Vec<Option<[f64; 2]>>,
    /// Per loop joint: its frames' origins in their links, the axis in link 1's frame, and
    /// the angle of frame 2 less that of frame 1 as seen from their links.
    pub loop_geometry: Vec<LoopGeometry>,
}

/// The constant part of a loop joint's geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct LoopGeometry {
    pub point1: [f64; 2],
    pub point2: [f64; 2],
    pub axis1: Option<[f64; 2]>,
    pub frame_angle: f64,
}

impl Model {
    pub fn new(mechanism: &Mechanism) -> Self {
        let mut model = Self {
            mechanism: mechanism.clone(),
            dof_of_joint: Vec::with_capacity(mechanism.joints.len()),
            sign: Vec::new(),
            damping: Vec::new(),
            friction: Vec::new(),
            spring: Vec::new(),
            limits: Vec::new(),
            constraint_count: 2 * mechanism.loops.len(),
            slide_axes: mechanism
                .joints
                .iter()
                .map(|j| match j.motion {
                    JointMotion::Prismatic { axis } => Some(j.origin.rotate(axis[0], axis[1])),
                    _ => None,
                })
                .collect(),
            loop_geometry: mechanism
                .loops
                .iter()
                .map(|l| LoopGeometry {
                    point1: [l.frame1.x, l.frame1.y],
                    point2: [l.frame2.x, l.frame2.y],
                    axis1: match l.motion {
                        JointMotion::Prismatic { axis } => Some(l.frame1.rotate(axis[0], axis[1])),
                        _ => None,
                    },
                    frame_angle: l.frame2.angle - l.frame1.angle,
                })
                .collect(),
        };
        for joint in &mechanism.joints {
            let sign = match joint.motion {
                JointMotion::Fixed => {
                    model.dof_of_joint.push(None);
                    continue;
                }
                JointMotion::Revolute { sign } => sign,
                JointMotion::Prismatic { .. } => 1.0,
            };
            model.dof_of_joint.push(Some(model.sign.len()));
            model.sign.push(sign);
            model.damping.push(joint.damping);
            model.friction.push(joint.friction);
            model.spring.push(joint.spring.map(|s| DofSpring {
                stiffness: s.stiffness,
                reference: sign * s.reference,
            }));
            model.limits.push(joint.limits.map(|[lower, upper]| {
                if sign > 0.0 {
                    [lower, upper]
                } else {
                    [-upper, -lower]
                }
            }));
        }
        model
    }

    pub fn dofs(&self) -> usize {
        self.sign.len()
    }
}

/// A process load over a step: a world force at a point fixed on a link, varying with the
/// point's motion as `force + damping·(v − start_velocity) + stiffness·(p − start_point)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct HeldLoad {
    pub link: usize,
    pub force: [f64; 2],
    /// The point in the link's frame.
    pub local_point: [f64; 2],
    pub damping: [[f64; 2]; 2],
    pub start_velocity: [f64; 2],
    pub stiffness: [[f64; 2]; 2],
    /// The point in the world at the step's start.
    pub start_point: [f64; 2],
}

impl HeldLoad {
    /// A load held over a step from its start: its point in `frame` (the link's), and the
    /// point's velocity then.
    pub fn new(load: &super::state::Load, frame: &Frame, start_velocity: [f64; 2]) -> Self {
        Self {
            link: load.link,
            force: load.force,
            local_point: frame.local(load.point),
            damping: load.damping,
            start_velocity,
            stiffness: load.stiffness,
            start_point: load.point,
        }
    }
}

/// What acts on the mechanism over a step: generalized joint efforts, process loads, gravity.
#[derive(Debug, Clone, Copy)]
pub(super) struct Inputs<'a> {
    pub efforts: &'a [f64],
    pub loads: &'a [HeldLoad],
    pub gravity: [f64; 2],
}

/// Workspace of the equations of motion: no allocation once sized.
#[derive(Debug, Clone, Default)]
pub(super) struct Dynamics {
    motion: LinkMotion,
    /// Generalized forces, then accelerations.
    force: Vec<f64>,
    /// Mass matrix, then its L·D·Lᵀ factors.
    mass: Vec<f64>,
    /// Constraint Jacobian G, m × n.
    pub g: Vec<f64>,
    /// Constraint values φ (positions) or γ (velocity products).
    pub phi: Vec<f64>,
    gamma: Vec<f64>,
    /// M⁻¹·Gᵀ, n × m (column-major: column r is `y[r*n..]`).
    y: Vec<f64>,
    /// G·M⁻¹·Gᵀ, then its factors.
    s: Vec<f64>,
    lambda: Vec<f64>,
    /// 1/D of M's factors (0 for a dependent pivot).
    scaled: Vec<f64>,
    /// The generations of the kinematics that `mass` (factored), `g` and `phi`, and `y` and
    /// `s` (factored) were made at: within a step the same configuration is asked for them
    /// several times (the closure's last pose, the velocity projection, the next step's first
    /// stage), and they are made once.
    mass_at: Option<u64>,
    rows_at: Option<u64>,
    schur_at: Option<u64>,
}

impl Dynamics {
    pub fn new(model: &Model) -> Self {
        let (n, m, links) = (
            model.dofs(),
            model.constraint_count,
            model.mechanism.links.len(),
        );
        Self {
            motion: LinkMotion {
                omega: vec![0.0; links],
                origin_vp: vec![[0.0; 2]; links],
            },
            force: vec![0.0; n],
            mass: vec![0.0; n * n],
            g: vec![0.0; m * n],
            phi: vec![0.0; m],
            gamma: vec![0.0; m],
            y: vec![0.0; n * m],
            s: vec![0.0; m * m],
            lambda: vec![0.0; m],
            scaled: vec![0.0; n],
            mass_at: None,
            rows_at: None,
            schur_at: None,
        }
    }

    /// Forgets the matrices kept (the model's masses changed).
    pub fn forget(&mut self) {
        (self.mass_at, self.rows_at, self.schur_at) = (None, None, None);
    }

    /// q̈ for the state (q, q̇) posed in `kin` under `inputs`, into `acceleration`. Solves the
    /// constrained system above by its Schur complement.
    pub fn acceleration(
        &mut self,
        model: &Model,
        kin: &Kinematics,
        state: (&[f64], &[f64]),
        inputs: &Inputs,
        acceleration: &mut [f64],
    ) {
        sized!(
            kin.n,
            Dynamics::acceleration_of(self, model, kin, state, inputs, acceleration)
        )
    }

    /// [`Self::acceleration`] for `N` coordinates (0: any).
    #[inline(always)]
    fn acceleration_of<const N: usize>(
        &mut self,
        model: &Model,
        kin: &Kinematics,
        (q, v): (&[f64], &[f64]),
        inputs: &Inputs,
        acceleration: &mut [f64],
    ) {
        self.motion.update::<N>(model, kin, v);
        self.generalized_forces::<N>(model, kin, (q, v), inputs);
        self.factor_mass_matrix::<N>(model, kin);
        let n = kin.size::<N>();
        acceleration.copy_from_slice(&self.force);
        ldl_solve(&self.mass, n, acceleration);
        if model.constraint_count > 0 {
            self.constraints_of::<N>(model, kin, Some(v));
            // G·q̈ = −γ: λ from S·λ = G·q̈_free + γ, then q̈ = q̈_free − M⁻¹·Gᵀ·λ.
            for r in 0..model.constraint_count {
                self.lambda[r] = dot(&self.g[r * n..(r + 1) * n], acceleration) + self.gamma[r];
            }
            self.solve_constrained::<N>(kin, model.constraint_count, acceleration);
        }
    }

    /// Removes from `delta` (n values, a velocity or a displacement) the part that the
    /// constraint rows `rhs` (in `self.lambda`) ask for, mass-weighted: `delta −= M⁻¹·Gᵀ·S⁻¹·rhs`.
    /// Needs `self.mass` factored and `self.g` filled at `kin`.
    #[inline(always)]
    fn solve_constrained<const N: usize>(&mut self, kin: &Kinematics, m: usize, delta: &mut [f64]) {
        let n = kin.size::<N>();
        if self.schur_at != Some(kin.generation) {
            self.factor_schur::<N>(n, m);
            self.schur_at = Some(kin.generation);
        }
        ldl_solve(&self.s, m, &mut self.lambda);
        let correction = &mut self.force;
        correction.fill(0.0);
        for r in 0..m {
            for (c, z) in correction.iter_mut().zip(&self.y[r * n..(r + 1) * n]) {
                *c += z * self.lambda[r];
            }
        }
        ldl_backward(&self.mass, n, correction);
        for (d, c) in delta.iter_mut().zip(correction.iter()) {
            *d -= c;
        }
    }

    /// Z = L⁻¹·Gᵀ into `y` and S = Zᵀ·D⁻¹·Z factored into `s`.
    #[inline(always)]
    fn factor_schur<const N: usize>(&mut self, n: usize, m: usize) {
        let n = size::<N>(n);
        // With M = L·D·Lᵀ and Z = L⁻¹·Gᵀ: S = G·M⁻¹·Gᵀ = Zᵀ·D⁻¹·Z and M⁻¹·Gᵀ·λ = L⁻ᵀ·D⁻¹·Z·λ.
        for r in 0..m {
            let column = &mut self.y[r * n..(r + 1) * n];
            column.copy_from_slice(&self.g[r * n..(r + 1) * n]);
            ldl_forward(&self.mass, n, column);
        }
        // D⁻¹·Z once (a dependent pivot, D = 0, takes no share), then S by dot products.
        for (k, scaled) in self.scaled.iter_mut().enumerate().take(n) {
            let d = self.mass[k * n + k];
            *scaled = if d == 0.0 { 0.0 } else { 1.0 / d };
        }
        for r in 0..m {
            let zr = &self.y[r * n..(r + 1) * n];
            for c in 0..=r {
                let zc = &self.y[c * n..(c + 1) * n];
                let value: f64 = (zr.iter().zip(zc).zip(&self.scaled[..n]))
                    .map(|((a, b), w)| a * b * w)
                    .sum();
                self.s[r * m + c] = value;
                self.s[c * m + r] = value;
            }
        }
        ldl_factor(&mut self.s, m, DEPENDENT_PIVOT);
    }

    /// The mass-weighted least correction of q that brings φ(q) (in `self.phi`, from
    /// [`Self::constraints`]) to zero to first order: one Gauss–Newton step, into `dq`.
    pub fn position_correction(&mut self, model: &Model, kin: &Kinematics, dq: &mut [f64]) {
        sized!(
            kin.n,
            Dynamics::position_correction_of(self, model, kin, dq)
        )
    }

    #[inline(always)]
    fn position_correction_of<const N: usize>(
        &mut self,
        model: &Model,
        kin: &Kinematics,
        dq: &mut [f64],
    ) {
        self.factor_mass_matrix::<N>(model, kin);
        dq.fill(0.0);
        self.lambda.copy_from_slice(&self.phi);
        self.solve_constrained::<N>(kin, model.constraint_count, dq);
    }

    /// The mass-weighted least correction of q for the drift φ ≈ −½·h²·γ that a step of `h`
    /// at constant q̈ makes off the loops from a state on them (G·q̇ = 0, G·q̈ = −γ): the
    /// configuration the last [`Self::acceleration`] was of, its factors and γ reused, so it costs
    /// no factorisation. Into `dq`. A start for the closure's Gauss–Newton iterations, which
    /// then need one fewer.
    pub fn drift_correction(&mut self, model: &Model, kin: &Kinematics, h: f64, dq: &mut [f64]) {
        sized!(
            kin.n,
            Dynamics::drift_correction_of(self, model, kin, h, dq)
        )
    }

    #[inline(always)]
    fn drift_correction_of<const N: usize>(
        &mut self,
        model: &Model,
        kin: &Kinematics,
        h: f64,
        dq: &mut [f64],
    ) {
        dq.fill(0.0);
        let m = model.constraint_count;
        for (lambda, gamma) in self.lambda.iter_mut().zip(&self.gamma).take(m) {
            *lambda = -0.5 * h * h * gamma;
        }
        self.solve_constrained::<N>(kin, m, dq);
    }

    /// Projects v onto the constraints' tangent space, G·v = 0, mass-weighted (the kinetic
    /// energy removed is least, so no momentum is invented).
    pub fn project_velocity(&mut self, model: &Model, kin: &Kinematics, v: &mut [f64]) {
        sized!(kin.n, Dynamics::project_velocity_of(self, model, kin, v))
    }

    #[inline(always)]
    fn project_velocity_of<const N: usize>(
        &mut self,
        model: &Model,
        kin: &Kinematics,
        v: &mut [f64],
    ) {
        self.constraints_of::<N>(model, kin, None);
        self.factor_mass_matrix::<N>(model, kin);
        let n = kin.size::<N>();
        for r in 0..model.constraint_count {
            self.lambda[r] = dot(&self.g[r * n..(r + 1) * n], v);
        }
        self.solve_constrained::<N>(kin, model.constraint_count, v);
    }

    /// Column `dof` of M⁻¹ at the posed configuration, into `column`: how every coordinate
    /// answers a unit impulse on one joint.
    pub fn inverse_mass_column(
        &mut self,
        model: &Model,
        kin: &Kinematics,
        dof: usize,
        column: &mut [f64],
    ) {
        self.factor_mass_matrix::<0>(model, kin);
        column.fill(0.0);
        column[dof] = 1.0;
        ldl_solve(&self.mass, kin.n, column);
    }

    /// Q: efforts, springs, damping, gravity and loads, less the velocity-product forces.
    #[inline(always)]
    fn generalized_forces<const N: usize>(
        &mut self,
        model: &Model,
        kin: &Kinematics,
        (q, v): (&[f64], &[f64]),
        inputs: &Inputs,
    ) {
        let gravity = inputs.gravity;
        for (g, f) in self.force.iter_mut().enumerate() {
            *f = inputs.efforts[g] - model.damping[g] * v[g];
            if let Some(spring) = model.spring[g] {
                *f -= spring.stiffness * (q[g] - spring.reference);
            }
        }
        for (l, link) in model.mechanism.links.iter().enumerate() {
            let Some(inertial) = link.inertial else {
                continue;
            };
            let a = self.motion.point_vp(kin, l, kin.com[l]);
            let f = [
                inertial.mass * (gravity[0] - a[0]),
                inertial.mass * (gravity[1] - a[1]),
            ];
            self.add_wrench::<N>(kin, l, f, 0.0);
        }
        for load in inputs.loads {
            let point = kin.frames[load.link].apply(load.local_point);
            let dv = sub(
                velocity_of(kin.point_velocity_of::<N>(load.link, point, v)),
                load.start_velocity,
            );
            let dp = sub(point, load.start_point);
            let [[cxx, cxy], [cyx, cyy]] = load.damping;
            let [[kxx, kxy], [kyx, kyy]] = load.stiffness;
            let force = [
                load.force[0] + cxx * dv[0] + cxy * dv[1] + kxx * dp[0] + kxy * dp[1],
                load.force[1] + cyx * dv[0] + cyy * dv[1] + kyx * dp[0] + kyy * dp[1],
            ];
            let r = sub(point, kin.com[load.link]);
            let torque = r[0] * force[1] - r[1] * force[0];
            self.add_wrench::<N>(kin, load.link, force, torque);
        }
    }

    /// Q += Jvᵀ·f + Jωᵀ·τ for a force at the centre of mass of `link` and a torque.
    #[inline(always)]
    fn add_wrench<const N: usize>(
        &mut self,
        kin: &Kinematics,
        link: usize,
        f: [f64; 2],
        torque: f64,
    ) {
        let (jx, jy) = kin.jv::<N>(link);
        let jw = kin.jw::<N>(link);
        for (((q, x), y), w) in self.force.iter_mut().zip(jx).zip(jy).zip(jw) {
            *q += x * f[0] + y * f[1] + w * torque;
        }
    }

    #[inline(always)]
    fn factor_mass_matrix<const N: usize>(&mut self, model: &Model, kin: &Kinematics) {
        if self.mass_at == Some(kin.generation) {
            return;
        }
        self.mass_at = Some(kin.generation);
        let n = kin.size::<N>();
        self.mass.fill(0.0);
        for (l, link) in model.mechanism.links.iter().enumerate() {
            let Some(inertial) = link.inertial else {
                continue;
            };
            let (jx, jy) = kin.jv::<N>(l);
            let jw = kin.jw::<N>(l);
            let (m, izz) = (inertial.mass, inertial.izz);
            for a in 0..n {
                let (xa, ya, wa) = (m * jx[a], m * jy[a], izz * jw[a]);
                if xa == 0.0 && ya == 0.0 && wa == 0.0 {
                    continue;
                }
                for b in 0..=a {
                    self.mass[a * n + b] += xa * jx[b] + ya * jy[b] + wa * jw[b];
                }
            }
        }
        for a in 0..n {
            for b in 0..a {
                self.mass[b * n + a] = self.mass[a * n + b];
            }
        }
        ldl_factor(&mut self.mass, n, 0.0);
    }

    /// Fills φ(q) and G for the posed configuration (unless they are of it already), and with
    /// `v` the velocity products γ.
    pub fn constraints(&mut self, model: &Model, kin: &Kinematics, v: Option<&[f64]>) {
        self.constraints_of::<0>(model, kin, v);
    }

    /// [`Self::constraints`] for `N` coordinates (0: any).
    #[inline(always)]
    fn constraints_of<const N: usize>(
        &mut self,
        model: &Model,
        kin: &Kinematics,
        v: Option<&[f64]>,
    ) {
        let n = kin.size::<N>();
        let fill = self.rows_at != Some(kin.generation);
        if !fill && v.is_none() {
            return;
        }
        if fill {
            self.g.fill(0.0);
        }
        for (l, closure) in model.mechanism.loops.iter().enumerate() {
            let rows = &mut self.g[2 * l * n..(2 * l + 2) * n];
            let rows = fill.then(|| rows.split_at_mut(n));
            let ends = (closure.link1, closure.link2);
            let geometry = &model.loop_geometry[l];
            let velocity = v.map(|v| (v, &self.motion));
            let (phi, gamma) = loop_rows::<N>(kin, ends, geometry, rows, velocity);
            if fill {
                self.phi[2 * l..2 * l + 2].copy_from_slice(&phi);
            }
            self.gamma[2 * l..2 * l + 2].copy_from_slice(&gamma);
        }
        self.rows_at = Some(kin.generation);
    }
}

/// Per link ω and the velocity-product acceleration (the J̇·q̇ part) of its frame origin.
#[derive(Debug, Clone, Default)]
struct LinkMotion {
    omega: Vec<f64>,
    origin_vp: Vec<[f64; 2]>,
}

impl LinkMotion {
    /// Parents first: a point fixed on a body accelerates by −ω²·r about the body's origin, and
    /// a prismatic slider adds the Coriolis term 2·ω_parent × ṡ·u.
    #[inline(always)]
    fn update<const N: usize>(&mut self, model: &Model, kin: &Kinematics, v: &[f64]) {
        for (l, w) in self.omega.iter_mut().enumerate() {
            *w = dot(kin.jw::<N>(l), v);
        }
        self.origin_vp[0] = [0.0; 2];
        for (j, joint) in model.mechanism.joints.iter().enumerate() {
            let (p, c) = (joint.parent, joint.child);
            let wp = self.omega[p];
            let mut a = self.point_vp(kin, p, kin.frames[c].origin);
            if let (Some(axis), Some(g)) = (model.slide_axes[j], model.dof_of_joint[j]) {
                let [ux, uy] = kin.frames[p].rotate(axis);
                a[0] -= 2.0 * wp * v[g] * uy;
                a[1] += 2.0 * wp * v[g] * ux;
            }
            self.origin_vp[c] = a;
        }
    }

    /// Velocity-product acceleration of a world point fixed on `link`.
    fn point_vp(&self, kin: &Kinematics, link: usize, point: [f64; 2]) -> [f64; 2] {
        let w2 = self.omega[link] * self.omega[link];
        let r = sub(point, kin.frames[link].origin);
        [
            self.origin_vp[link][0] - w2 * r[0],
            self.origin_vp[link][1] - w2 * r[1],
        ]
    }
}

/// The two rows of one loop joint: with `rows`, φ and its Jacobian rows (into `row_a`,
/// `row_b`, zeroed; without, φ's angle is left 0) and, given q̇ and the velocity products, γ.
///
/// Revolute: the two frame origins coincide, φ = p₂ − p₁. Prismatic (axis u in frame 1,
/// normal n = z × u): φ_a = n·(p₂ − p₁), the offset across the slide, and φ_b = θ₂ − θ₁, the
/// frames stay aligned.
#[inline(always)]
fn loop_rows<const N: usize>(
    kin: &Kinematics,
    (l1, l2): (usize, usize),
    geometry: &LoopGeometry,
    rows: Option<(&mut [f64], &mut [f64])>,
    velocity: Option<(&[f64], &LinkMotion)>,
) -> ([f64; 2], [f64; 2]) {
    let (f1, f2) = (&kin.frames[l1], &kin.frames[l2]);
    let (p1, p2) = (f1.apply(geometry.point1), f2.apply(geometry.point2));
    let d = sub(p2, p1);
    let mut gamma = [0.0; 2];
    match geometry.axis1 {
        Some(axis) => {
            let u = f1.rotate(axis);
            let normal = [-u[1], u[0]];
            let z_cross_n = [-normal[1], normal[0]];
            // φ is of the configuration: made with the rows, not again for each γ.
            let fill = rows.is_some();
            if let Some((row_a, row_b)) = rows {
                // Jacobian of n·(p₂ − p₁): n·(J_p₂ − J_p₁) + ((z × n)·d)·Jω₁, as ṅ = ω₁ z × n.
                point_rows::<N>(kin, l2, p2, 1.0, normal, row_a);
                point_rows::<N>(kin, l1, p1, -1.0, normal, row_a);
                let lever = z_cross_n[0] * d[0] + z_cross_n[1] * d[1];
                let jw1 = kin.jw::<N>(l1);
                let jw2 = kin.jw::<N>(l2);
                for g in 0..kin.size::<N>() {
                    row_a[g] += lever * jw1[g];
                    row_b[g] = jw2[g] - jw1[g];
                }
            }
            // θ₂ − θ₁ of the links from their relative rotation R₁ᵀ·R₂, less the frames' offset.
            let relative = fill.then(|| {
                (f1.cos * f2.sin - f1.sin * f2.cos).atan2(f1.cos * f2.cos + f1.sin * f2.sin)
            });
            let phi = [
                normal[0] * d[0] + normal[1] * d[1],
                relative.map_or(0.0, |r| wrap_angle(r + geometry.frame_angle)),
            ];
            if let Some((v, motion)) = velocity {
                let w1 = motion.omega[l1];
                let a = sub(motion.point_vp(kin, l2, p2), motion.point_vp(kin, l1, p1));
                let d_rate = sub(
                    velocity_of(kin.point_velocity_of::<N>(l2, p2, v)),
                    velocity_of(kin.point_velocity_of::<N>(l1, p1, v)),
                );
                gamma[0] = normal[0] * a[0]
                    + normal[1] * a[1]
                    + 2.0 * w1 * (z_cross_n[0] * d_rate[0] + z_cross_n[1] * d_rate[1])
                    - w1 * w1 * (normal[0] * d[0] + normal[1] * d[1]);
            }
            (phi, gamma)
        }
        None => {
            if let Some((row_a, row_b)) = rows {
                point_rows::<N>(kin, l2, p2, 1.0, [1.0, 0.0], row_a);
                point_rows::<N>(kin, l1, p1, -1.0, [1.0, 0.0], row_a);
                point_rows::<N>(kin, l2, p2, 1.0, [0.0, 1.0], row_b);
                point_rows::<N>(kin, l1, p1, -1.0, [0.0, 1.0], row_b);
            }
            if let Some((_, motion)) = velocity {
                gamma = sub(motion.point_vp(kin, l2, p2), motion.point_vp(kin, l1, p1));
            }
            (d, gamma)
        }
    }
}

/// row += scale × direction·J_point for a world point fixed on `link`.
#[inline(always)]
fn point_rows<const N: usize>(
    kin: &Kinematics,
    link: usize,
    point: [f64; 2],
    scale: f64,
    direction: [f64; 2],
    row: &mut [f64],
) {
    let (jx, jy) = kin.jv::<N>(link);
    let jw = kin.jw::<N>(link);
    let [rx, ry] = sub(point, kin.com[link]);
    let [dx, dy] = [scale * direction[0], scale * direction[1]];
    for (((r, x), y), w) in row.iter_mut().zip(jx).zip(jy).zip(jw) {
        *r += dx * (x - ry * w) + dy * (y + rx * w);
    }
}

fn velocity_of([vx, vy, _]: [f64; 3]) -> [f64; 2] {
    [vx, vy]
}

fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}
