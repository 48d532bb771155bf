//! Rigid-body dynamics of the twin's Whitworth linkage, reduced to the crank angle q.
//!
//! The linkage has one degree of freedom, so its whole motion follows from
//! `M(q)·q̈ + ½·M′(q)·q̇² + ∂V/∂q = τ + ρ_y(q)·f_y`, where
//! - `M(q) = Σ_i m_i·|∂c_i/∂q|² + I_i·(∂θ_i/∂q)²` is the generalised inertia, the sum running over
//!   the crank, the block, the slotted link, the coupler and the ram (c_i: centre of mass, θ_i:
//!   orientation of link i);
//! - `V(q) = g·Σ_i m_i·c_{i,y}(q)` is the potential energy, so `∂V/∂q = g·Σ_i m_i·∂c_{i,y}/∂q`;
//! - `τ` is the crank torque and `f_y` an external vertical force on the ram (a cutting force),
//!   which does the virtual work `f_y·δy = ρ_y·f_y·δq`.
//!
//! This is the paper's extended model (Perrusquía eq (6) and, in its Appendix B,
//! Perrusquía eq (B.4)) written with the twin's link masses instead of the paper's unprinted ones: `M(q) =
//! ρᵀ·M′·ρ`, with ρ the extended Jacobian of the centres of mass and link angles. Nothing here
//! reads the simulator; the masses default to the ones in `urdf/whitworth.urdf`.

use super::geometry::{Geometry, GeometryError};
use serde::Deserialize;
use thiserror::Error;

/// Mass properties of one link. Every centre of mass in the twin's URDF lies on its link's x axis,
/// so one distance places it.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkInertia {
    /// kg.
    pub mass: f64,
    /// Distance of the centre of mass along the link's x axis from the link frame, m.
    pub centre_of_mass: f64,
    /// Moment of inertia about the centre of mass, kg·m².
    pub izz: f64,
}

/// The five moving links, with the frames of `urdf/whitworth.urdf`: the crank from O2 along the
/// crank; the block on the crank pin A, turning with the slot; the slotted link from O3 along the
/// slot; the coupler from B towards C; the ram at C, not turning.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkMasses {
    /// Crank O2–A; frame at O2 along the crank.
    pub crank: LinkInertia,
    /// Sliding block; frame on the crank pin A, turning with the slot.
    pub block: LinkInertia,
    /// Slotted link; frame at O3 along the slot.
    pub slotted_link: LinkInertia,
    /// Coupler B–C; frame at B pointing towards C.
    pub coupler: LinkInertia,
    /// Ram; frame at C, sliding on its guide without turning.
    pub ram: LinkInertia,
}

impl Default for LinkMasses {
    /// The `<inertial>` elements of `urdf/whitworth.urdf`.
    fn default() -> Self {
        let link = |mass, centre_of_mass, izz| LinkInertia {
            mass,
            centre_of_mass,
            izz,
        };
        Self {
            crank: link(4.0, 0.25, 0.083333),
            block: link(0.5, 0.0, 0.0005),
            slotted_link: link(4.0, 0.325, 0.1875),
            coupler: link(1.0, 0.15, 0.0075),
            ram: link(5.0, 0.0, 0.05),
        }
    }
}

impl LinkMasses {
    fn all(&self) -> [(&'static str, LinkInertia); 5] {
        [
            ("crank", self.crank),
            ("block", self.block),
            ("slotted_link", self.slotted_link),
            ("coupler", self.coupler),
            ("ram", self.ram),
        ]
    }
}

/// Why a [`Dynamics`] cannot be built.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum DynamicsError {
    /// The linkage dimensions are rejected.
    #[error(transparent)]
    Geometry(#[from] GeometryError),
    /// A link's mass or moment of inertia is negative, infinite or NaN.
    #[error("whitworth dynamics: {link} {what} must be finite and ≥ 0 (got {value})")]
    BadInertia {
        /// The link, named as its [`LinkMasses`] field.
        link: &'static str,
        /// `"mass"` or `"izz"`.
        what: &'static str,
        /// The rejected value, kg or kg·m².
        value: f64,
    },
    /// A link's centre-of-mass distance is infinite or NaN.
    #[error("whitworth dynamics: {link} centre_of_mass must be finite (got {value})")]
    BadCentre {
        /// The link, named as its [`LinkMasses`] field.
        link: &'static str,
        /// The rejected distance, m.
        value: f64,
    },
    /// Every link has zero mass and zero moment of inertia, so M(q) would vanish.
    #[error("whitworth dynamics: the linkage has no inertia")]
    Massless,
    /// Gravity is infinite or NaN; holds the value given, m/s².
    #[error("whitworth dynamics: gravity must be finite (got {0} m/s²)")]
    BadGravity(f64),
}

/// Velocity coefficients of one link at q: `∂c/∂q` and `∂θ/∂q`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct LinkRates {
    centre: [f64; 2],
    centre_velocity: [f64; 2],
    angle_rate: f64,
}

/// The reduced model `M(q)·q̈ + ½·M′(q)·q̇² + ∂V/∂q = τ + ρ_y·f_y`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dynamics {
    geometry: Geometry,
    masses: LinkMasses,
    /// Acceleration of gravity along −y, m/s².
    gravity: f64,
}

/// Step of the central difference behind `M′(q)`, rad.
const SLOPE_STEP: f64 = 1e-6;

impl Dynamics {
    /// `gravity` acts along −y (9.81 for the twin's scenarios).
    pub fn new(
        geometry: Geometry,
        masses: LinkMasses,
        gravity: f64,
    ) -> Result<Self, DynamicsError> {
        geometry.validate()?;
        for (link, inertia) in masses.all() {
            for (what, value) in [("mass", inertia.mass), ("izz", inertia.izz)] {
                if !(value.is_finite() && value >= 0.0) {
                    return Err(DynamicsError::BadInertia { link, what, value });
                }
            }
            if !inertia.centre_of_mass.is_finite() {
                return Err(DynamicsError::BadCentre {
                    link,
                    value: inertia.centre_of_mass,
                });
            }
        }
        if masses
            .all()
            .iter()
            .all(|(_, l)| l.mass == 0.0 && l.izz == 0.0)
        {
            return Err(DynamicsError::Massless);
        }
        if !gravity.is_finite() {
            return Err(DynamicsError::BadGravity(gravity));
        }
        Ok(Self {
            geometry,
            masses,
            gravity,
        })
    }

    /// Linkage dimensions the model was built with.
    pub fn geometry(&self) -> &Geometry {
        &self.geometry
    }

    /// Link mass properties the model was built with.
    pub fn masses(&self) -> &LinkMasses {
        &self.masses
    }

    /// Centres of mass and their rates for the five links, in [`LinkMasses`] order.
    fn link_rates(&self, q: f64) -> [LinkRates; 5] {
        let g = &self.geometry;
        let pose = g.pose(q);
        let jac = g.jacobian(q);
        let (s2, c2) = q.sin_cos();
        let (s3, c3) = pose.slot_angle.sin_cos();
        let (s4, c4) = pose.coupler_angle.sin_cos();
        let m = &self.masses;
        let [o3x, o3y] = g.slot_pivot;
        let crank = LinkRates {
            centre: [m.crank.centre_of_mass * c2, m.crank.centre_of_mass * s2],
            centre_velocity: [-m.crank.centre_of_mass * s2, m.crank.centre_of_mass * c2],
            angle_rate: 1.0,
        };
        // The block's frame sits on the crank pin and turns with the slot.
        let block = LinkRates {
            centre: [
                pose.crank_pin[0] + m.block.centre_of_mass * c3,
                pose.crank_pin[1] + m.block.centre_of_mass * s3,
            ],
            centre_velocity: [
                -g.crank_length * s2 - m.block.centre_of_mass * s3 * jac.slot_angle,
                g.crank_length * c2 + m.block.centre_of_mass * c3 * jac.slot_angle,
            ],
            angle_rate: jac.slot_angle,
        };
        let slotted_link = LinkRates {
            centre: [
                o3x + m.slotted_link.centre_of_mass * c3,
                o3y + m.slotted_link.centre_of_mass * s3,
            ],
            centre_velocity: [
                -m.slotted_link.centre_of_mass * s3 * jac.slot_angle,
                m.slotted_link.centre_of_mass * c3 * jac.slot_angle,
            ],
            angle_rate: jac.slot_angle,
        };
        let pin_velocity = [
            -g.coupler_pin_radius * s3 * jac.slot_angle,
            g.coupler_pin_radius * c3 * jac.slot_angle,
        ];
        let coupler = LinkRates {
            centre: [
                pose.coupler_pin[0] + m.coupler.centre_of_mass * c4,
                pose.coupler_pin[1] + m.coupler.centre_of_mass * s4,
            ],
            centre_velocity: [
                pin_velocity[0] - m.coupler.centre_of_mass * s4 * jac.coupler_angle,
                pin_velocity[1] + m.coupler.centre_of_mass * c4 * jac.coupler_angle,
            ],
            angle_rate: jac.coupler_angle,
        };
        // The ram slides on its guide without turning; its frame is the ram pin C.
        let ram = LinkRates {
            centre: [pose.ram_pin[0] + m.ram.centre_of_mass, pose.ram_pin[1]],
            centre_velocity: [0.0, jac.ram],
            angle_rate: 0.0,
        };
        [crank, block, slotted_link, coupler, ram]
    }

    /// `M(q)`, kg·m²: the kinetic energy is `½·M(q)·q̇²`.
    pub fn inertia(&self, q: f64) -> f64 {
        self.link_rates(q)
            .iter()
            .zip(self.masses.all())
            .map(|(rates, (_, link))| {
                let [vx, vy] = rates.centre_velocity;
                link.mass * (vx * vx + vy * vy) + link.izz * rates.angle_rate * rates.angle_rate
            })
            .sum()
    }

    /// `M′(q) = dM/dq`, kg·m²/rad (central difference of the closed form).
    pub fn inertia_slope(&self, q: f64) -> f64 {
        (self.inertia(q + SLOPE_STEP) - self.inertia(q - SLOPE_STEP)) / (2.0 * SLOPE_STEP)
    }

    /// `V(q)`, J, zero at the height y = 0.
    pub fn potential_energy(&self, q: f64) -> f64 {
        self.gravity
            * self
                .link_rates(q)
                .iter()
                .zip(self.masses.all())
                .map(|(rates, (_, link))| link.mass * rates.centre[1])
                .sum::<f64>()
    }

    /// `∂V/∂q`, N·m: the crank torque that holds the linkage still at q.
    pub fn gravity_torque(&self, q: f64) -> f64 {
        self.gravity
            * self
                .link_rates(q)
                .iter()
                .zip(self.masses.all())
                .map(|(rates, (_, link))| link.mass * rates.centre_velocity[1])
                .sum::<f64>()
    }

    /// `½·M(q)·q̇² + V(q)`, J.
    pub fn energy(&self, q: f64, crank_speed: f64) -> f64 {
        0.5 * self.inertia(q) * crank_speed * crank_speed + self.potential_energy(q)
    }

    /// q̈ from the equation of motion under crank torque `torque` (N·m) and a vertical force
    /// `ram_force` on the ram (N, + up).
    pub fn crank_acceleration(&self, q: f64, crank_speed: f64, torque: f64, ram_force: f64) -> f64 {
        let generalised =
            torque + self.geometry.ram_jacobian(q) * ram_force - self.gravity_torque(q);
        (generalised - 0.5 * self.inertia_slope(q) * crank_speed * crank_speed) / self.inertia(q)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, TAU};

    fn twin() -> Dynamics {
        Dynamics::new(Geometry::default(), LinkMasses::default(), 9.81).unwrap()
    }

    #[test]
    fn frames_agree_with_the_urdf_pose() {
        // urdf/whitworth.urdf is drawn at q0 = π/2: slotted link at 1.252270264276987 rad, the
        // coupler turned by −3.069134097035354 rad from it, the ram at y = 0.051578684648199 m.
        let pose = Geometry::default().pose(FRAC_PI_2);
        assert!((pose.slot_angle - 1.252270264276987).abs() < 1e-12);
        assert!((pose.coupler_angle - (1.252270264276987 - 3.069134097035354)).abs() < 1e-12);
        assert!((pose.ram_position - 0.051578684648199).abs() < 1e-12);
    }

    #[test]
    fn inertia_at_a_crank_angle_by_hand() {
        // With only the crank massive, M = m·l² + I; with only the ram, M = m·ρ_y².
        let zero = LinkInertia {
            mass: 0.0,
            centre_of_mass: 0.0,
            izz: 0.0,
        };
        let only = |crank, ram| LinkMasses {
            crank,
            block: zero,
            slotted_link: zero,
            coupler: zero,
            ram,
        };
        let crank = Dynamics::new(
            Geometry::default(),
            only(LinkMasses::default().crank, zero),
            9.81,
        )
        .unwrap();
        assert!((crank.inertia(0.3) - (4.0 * 0.0625 + 0.083333)).abs() < 1e-12);
        let ram = Dynamics::new(
            Geometry::default(),
            only(zero, LinkMasses::default().ram),
            9.81,
        )
        .unwrap();
        let rho = Geometry::default().ram_jacobian(0.3);
        assert!((ram.inertia(0.3) - 5.0 * rho * rho).abs() < 1e-12);
        // The ram's weight: ∂V/∂q = m·g·ρ_y.
        assert!((ram.gravity_torque(0.3) - 5.0 * 9.81 * rho).abs() < 1e-12);
    }

    #[test]
    fn gravity_torque_is_the_slope_of_the_potential() {
        let d = twin();
        let h = 1e-6;
        for i in 0..36 {
            let q = i as f64 * TAU / 36.0 + 0.05;
            let slope = (d.potential_energy(q + h) - d.potential_energy(q - h)) / (2.0 * h);
            assert!((slope - d.gravity_torque(q)).abs() < 1e-6, "q = {q}");
            assert!(d.inertia(q) > 0.0);
        }
    }

    #[test]
    fn free_motion_conserves_energy() {
        // RK4 over two free crank turns: energy is kept to the integrator's accuracy only if M′ and
        // ∂V/∂q belong to the same M and V.
        let d = twin();
        let (mut q, mut w) = (FRAC_PI_2, -12.0);
        let e0 = d.energy(q, w);
        let dt = 1e-4;
        let f = |q: f64, w: f64| (w, d.crank_acceleration(q, w, 0.0, 0.0));
        for _ in 0..10_000 {
            let k1 = f(q, w);
            let k2 = f(q + 0.5 * dt * k1.0, w + 0.5 * dt * k1.1);
            let k3 = f(q + 0.5 * dt * k2.0, w + 0.5 * dt * k2.1);
            let k4 = f(q + dt * k3.0, w + dt * k3.1);
            q += dt / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0);
            w += dt / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1);
        }
        assert!(
            q < FRAC_PI_2 - TAU,
            "the crank kept turning clockwise: q = {q}"
        );
        assert!(
            (d.energy(q, w) - e0).abs() < 1e-6 * e0.abs(),
            "{} vs {e0}",
            d.energy(q, w)
        );
    }

    #[test]
    fn bad_inputs_are_rejected() {
        let mut masses = LinkMasses::default();
        masses.coupler.mass = -1.0;
        assert!(matches!(
            Dynamics::new(Geometry::default(), masses, 9.81),
            Err(DynamicsError::BadInertia {
                link: "coupler",
                what: "mass",
                ..
            })
        ));
        assert!(matches!(
            Dynamics::new(Geometry::default(), LinkMasses::default(), f64::NAN),
            Err(DynamicsError::BadGravity(_))
        ));
        let geometry = Geometry {
            crank_length: 0.1,
            ..Geometry::default()
        };
        assert!(matches!(
            Dynamics::new(geometry, LinkMasses::default(), 9.81),
            Err(DynamicsError::Geometry(_))
        ));
    }
}
