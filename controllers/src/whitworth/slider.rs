//! The ram ("slider") as the task-space controllers see it: the paper's slider dynamics,
//! Perrusquía eqs (7)–(10), for the twin's linkage, and the Jacobian compensator of Perrusquía eq (33).
//!
//! **Effective mass (Perrusquía eqs (7)–(9)).** The paper writes `m·ẍ + G = (Σρ_i²)⁻¹·ρ_x·(τ −
//! ρ_x·F_x)`. The sum `Σρ_i²` is the generalised inertia `ρᵀ·M′·ρ` of its extended model taken with
//! a unit metric (every extended coordinate weighing the same); with the twin's link masses it is
//! `M(q) = Σ m_i|∂c_i/∂q|² + I_i(∂θ_i/∂q)²` ([`models::whitworth::dynamics`]). Differentiating
//! `y = y(q)` twice and using `M·q̈ + ½M′q̇² + ∂V/∂q = τ + ρ_y·f_y` gives, exactly,
//! `ÿ = (ρ_y/M)·τ + (ρ_y²/M)·f_y − (ρ_y/M)·∂V/∂q + (ρ_y′ − ρ_y·M′/2M)·q̇²`.
//! With the virtual-work map `τ = ρ_y·u` (Perrusquía eq (11)) this is Perrusquía eq (7) with the
//! ram's *effective* mass `m(q) = M(q)/ρ_y²` (the whole linkage reflected to the ram, infinite at
//! the stroke ends) and gravity `G(q) = (∂V/∂q)/ρ_y`. The paper's own twin-sized instance,
//! Perrusquía eq (34) with m₅ = 0.45 g, keeps only the ram's mass; that is not the twin's physics
//! and is not used.
//!
//! **Compensated input gain.** The controllers apply `τ = ρ̂·u` with the compensator
//! `ρ̂ = K_ρ·sign(ẋ/q̇)` (Perrusquía eq (33)), not `ρ_y·u`, so u reaches the ram with the gain
//! `b(q) = ρ_y·ρ̂/M(q) = K_ρ·|ρ_y|/M(q)` (Perrusquía eq (8)'s b): the compensator keeps the sign
//! right through the singular points, where the gain falls to zero instead of blowing up. `K_ρ =
//! max|ρ_y|` over the cutting stroke (the paper's choice). The linear designs (Perrusquía eq (10))
//! take `b = 1/m̄` with the nominal mass `m̄ = 1/max b(q)` over the cutting stroke: the lightest
//! the ram ever looks through the compensator, reached near the largest Jacobian. Everywhere else
//! `b(q) ≤ 1/m̄`, so a high-gain design for m̄ only gets slower, never faster, on the real linkage.
//!
//! **Sign of ẋ/q̇.** `sign(ẏ/q̇) = sign(ρ_y(q))`, taken from the model at the measured crank angle
//! (the paper's "off-line" sign), so it is defined when the crank stands still.

use models::whitworth::dynamics::{Dynamics, DynamicsError};
use models::whitworth::{Geometry, GeometryError, Stroke};
use nalgebra::DMatrix;

/// The slider model of one linkage, with the compensator and the nominal design mass.
#[derive(Debug, Clone, PartialEq)]
pub struct SliderModel {
    dynamics: Dynamics,
    stroke: Stroke,
    jacobian_gain: f64,
    /// Sign of ρ_y in the cutting stroke.
    cutting_sign: f64,
    nominal_angle: f64,
    nominal_mass: f64,
}

/// Samples over the cutting stroke before the golden-section refinement of a maximum.
const SAMPLES: usize = 720;
const GOLDEN_ITERATIONS: usize = 80;

impl SliderModel {
    /// Finds the stroke, `K_ρ` and `m̄` of the linkage described by `dynamics`.
    pub fn new(dynamics: Dynamics) -> Result<Self, DynamicsError> {
        let geometry = *dynamics.geometry();
        let stroke = geometry.stroke()?;
        let jacobian_gain = maximum(&stroke, |q| geometry.ram_jacobian(q).abs()).1;
        if jacobian_gain.is_nan() || jacobian_gain <= 0.0 {
            return Err(DynamicsError::Geometry(GeometryError::NonPositive(
                "ram Jacobian over the cutting stroke",
            )));
        }
        let (nominal_angle, largest_gain) = maximum(&stroke, |q| {
            jacobian_gain * geometry.ram_jacobian(q).abs() / dynamics.inertia(q)
        });
        let mid_cut = stroke.top_crank_angle - 0.5 * stroke.cutting_crank_travel();
        Ok(Self {
            dynamics,
            stroke,
            jacobian_gain,
            cutting_sign: geometry.ram_jacobian(mid_cut).signum(),
            nominal_angle,
            nominal_mass: 1.0 / largest_gain,
        })
    }

    /// The linkage's dynamics: generalised inertia M(q), gravity and energy.
    pub fn dynamics(&self) -> &Dynamics {
        &self.dynamics
    }

    /// The linkage's dimensions.
    pub fn geometry(&self) -> &Geometry {
        self.dynamics.geometry()
    }

    /// Singular crank angles and stroke ends.
    pub fn stroke(&self) -> &Stroke {
        &self.stroke
    }

    /// `K_ρ = max|ρ_y|` over the cutting stroke (Perrusquía eq (33)), m/rad.
    pub fn jacobian_gain(&self) -> f64 {
        self.jacobian_gain
    }

    /// `m̄`, kg: the mass of the linear slider model `ÿ = (1/m̄)·(u + d)` (Perrusquía eq (10)).
    pub fn nominal_mass(&self) -> f64 {
        self.nominal_mass
    }

    /// The crank angle where `b(q) = 1/m̄`, rad.
    pub fn nominal_angle(&self) -> f64 {
        self.nominal_angle
    }

    /// `m(q) = M(q)/ρ_y(q)²`, kg: Perrusquía eq (7)'s slider mass for the map `τ = ρ_y·u`
    /// (Perrusquía eq (11)).
    pub fn effective_mass(&self, q: f64) -> f64 {
        let rho = self.geometry().ram_jacobian(q);
        self.dynamics.inertia(q) / (rho * rho)
    }

    /// `ρ̂ = K_ρ·sign(ẏ/q̇)` (Perrusquía eq (33)), m/rad; the cutting stroke's sign exactly at a
    /// singular point.
    pub fn compensator(&self, q: f64) -> f64 {
        let rho = self.geometry().ram_jacobian(q);
        if rho == 0.0 {
            self.jacobian_gain * self.cutting_sign
        } else {
            self.jacobian_gain * rho.signum()
        }
    }

    /// Whether the crank angle q lies in the cutting stroke (ρ_y has its cutting-stroke sign).
    pub fn in_cutting_stroke(&self, q: f64) -> bool {
        self.compensator(q) * self.cutting_sign > 0.0
    }

    /// `b(q) = ρ_y·ρ̂/M(q)`, 1/kg: how u accelerates the ram through the compensator.
    pub fn input_gain(&self, q: f64) -> f64 {
        self.geometry().ram_jacobian(q) * self.compensator(q) / self.dynamics.inertia(q)
    }

    /// The gravity of Perrusquía eq (7), `G = (∂V/∂q)/ρ_y`, carried to u through the compensator:
    /// `u_g = (∂V/∂q)/ρ̂`, N, so that `ρ̂·u_g` is the torque that holds the linkage against its
    /// weight. Finite at the singular points, where `G` itself is not.
    pub fn gravity_input(&self, q: f64) -> f64 {
        self.dynamics.gravity_torque(q) / self.compensator(q)
    }

    /// The linear slider of Perrusquía eq (10) for `m̄`: `A = [[0, 1], [0, 0]]`, `B = [0, 1/m̄]ᵀ`.
    pub fn state_space(&self) -> (DMatrix<f64>, DMatrix<f64>) {
        (
            DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]),
            DMatrix::from_row_slice(2, 1, &[0.0, 1.0 / self.nominal_mass]),
        )
    }
}

/// The largest value of `f` over the cutting stroke (crank clockwise from the top singular angle)
/// and where it is: a dense scan, then golden-section search around the best sample.
fn maximum(stroke: &Stroke, f: impl Fn(f64) -> f64) -> (f64, f64) {
    let travel = stroke.cutting_crank_travel();
    let angle = |i: usize| stroke.top_crank_angle - travel * i as f64 / SAMPLES as f64;
    let best = (1..SAMPLES)
        .max_by(|&a, &b| f(angle(a)).total_cmp(&f(angle(b))))
        .unwrap_or(SAMPLES / 2);
    // Golden section on [angle(best + 1), angle(best − 1)] (angles fall with i).
    let (mut low, mut high) = (angle(best + 1), angle(best - 1));
    let ratio = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..GOLDEN_ITERATIONS {
        let a = high - ratio * (high - low);
        let b = low + ratio * (high - low);
        if f(a) >= f(b) {
            high = b;
        } else {
            low = a;
        }
    }
    let q = 0.5 * (low + high);
    (q, f(q))
}

#[cfg(test)]
mod tests {
    use super::*;
    use models::whitworth::dynamics::LinkMasses;

    fn twin() -> SliderModel {
        SliderModel::new(Dynamics::new(Geometry::default(), LinkMasses::default(), 9.81).unwrap())
            .unwrap()
    }

    #[test]
    fn jacobian_gain_is_the_largest_ram_jacobian() {
        let s = twin();
        let g = Geometry::default();
        let travel = s.stroke().cutting_crank_travel();
        let scanned = (0..=100_000)
            .map(|i| {
                g.ram_jacobian(s.stroke().top_crank_angle - travel * i as f64 / 1e5)
                    .abs()
            })
            .fold(0.0, f64::max);
        assert!(
            (s.jacobian_gain() - scanned).abs() < 1e-9,
            "{}",
            s.jacobian_gain()
        );
        // The twin's linkage: K_ρ ≈ 0.2326 m/rad near y = −0.19 m.
        assert!((s.jacobian_gain() - 0.23255).abs() < 1e-4);
    }

    #[test]
    fn nominal_mass_bounds_the_input_gain() {
        let s = twin();
        let travel = s.stroke().cutting_crank_travel();
        for i in 1..200 {
            let q = s.stroke().top_crank_angle - travel * i as f64 / 200.0;
            assert!(
                s.input_gain(q) > 0.0,
                "compensated gain keeps its sign at q = {q}"
            );
            assert!(s.input_gain(q) <= 1.0 / s.nominal_mass() * (1.0 + 1e-9));
        }
        // Where the Jacobian is largest ρ̂ = ρ_y, so m̄ is close to the effective mass M/ρ_y².
        let q = s.nominal_angle();
        assert!((s.effective_mass(q) - s.nominal_mass()).abs() < 0.02 * s.nominal_mass());
        assert!(
            (15.0..30.0).contains(&s.nominal_mass()),
            "m̄ = {}",
            s.nominal_mass()
        );
    }

    #[test]
    fn compensator_follows_the_sign_of_the_jacobian() {
        let s = twin();
        let stroke = *s.stroke();
        let mid_cut = stroke.top_crank_angle - 0.5 * stroke.cutting_crank_travel();
        assert_eq!(s.compensator(mid_cut), s.jacobian_gain());
        assert_eq!(
            s.compensator(mid_cut + std::f64::consts::PI),
            -s.jacobian_gain()
        );
        // The gravity torque is reproduced through the compensator wherever ρ̂ is defined.
        for q in [mid_cut, mid_cut + 3.0, stroke.top_crank_angle] {
            let torque = s.compensator(q) * s.gravity_input(q);
            assert!((torque - s.dynamics().gravity_torque(q)).abs() < 1e-12);
        }
    }

    #[test]
    fn state_space_is_the_slider_of_eq_10() {
        let s = twin();
        let (a, b) = s.state_space();
        assert_eq!(a, DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]));
        assert_eq!(b[(1, 0)], 1.0 / s.nominal_mass());
    }
}
