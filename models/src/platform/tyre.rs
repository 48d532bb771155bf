//! Tyre–floor contact of a small wheeled robot seen from above: slip → friction force, and the
//! static normal load of each wheel.
//!
//! **Slip.** At a contact the floor sees the wheel's rim speed `ω·r` along the wheel's rolling
//! direction and the contact point's velocity `(v_x, v_y)` (rolling direction, lateral). With the
//! reference speed `v_ref = max(|v|, |ω·r|, v_floor)` the slip is the vector
//!
//! ```text
//! κ = (ω·r − v_x)/v_ref     (longitudinal: > 0 when the wheel spins faster than it travels)
//! α = −v_y/v_ref            (lateral: > 0 when the contact slides to the right)
//! ```
//!
//! `v_floor` keeps slip finite at standstill; below it the contact behaves like a stiff viscous
//! bristle of slip velocity scale `σ₀·v_floor`.
//!
//! **Friction curve.** The force lies along the slip vector σ = (κ, α) (a friction circle: the
//! wheel cannot use more than μ·N in any direction) with the smooth, odd, monotonic curve
//!
//! ```text
//! |F| = μ·N · (|σ|/σ₀) / √(1 + (|σ|/σ₀)²)
//! ```
//!
//! linear for small slip (slip stiffness μ·N/σ₀), reaching μ·N/√2 at |σ| = σ₀ and saturating at
//! μ·N.

use serde::Deserialize;
use thiserror::Error;

/// Parameters of the friction curve.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TyreParams {
    /// σ₀: the slip at which the force reaches μ·N/√2.
    pub saturation_slip: f64,
    /// v_floor, m/s: the smallest reference speed of the slip.
    pub speed_floor: f64,
}

impl Default for TyreParams {
    fn default() -> Self {
        Self {
            saturation_slip: 0.1,
            speed_floor: 0.05,
        }
    }
}

/// Why the tyre parameters or the wheel contacts cannot carry the platform.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum TyreError {
    /// A [`TyreParams`] field is zero, negative or not finite.
    #[error("tyre {name} must be finite and > 0, got {value}")]
    NotPositive {
        /// `saturation_slip` or `speed_floor`.
        name: &'static str,
        /// The rejected value (a slip ratio, or m/s).
        value: f64,
    },
    /// The contact points lie on one line (or are fewer than three), so the loads are undetermined.
    #[error("the wheels' contact points are collinear: they cannot carry the platform")]
    Collinear,
    /// The centre of mass lies outside the support polygon: a contact would have to pull.
    #[error("the centre of mass lies outside the wheels' support: contact {contact} would carry {load:.3} N")]
    Unsupported {
        /// Index of the first such contact, in the order given.
        contact: usize,
        /// The normal load it would carry, N (≤ 0).
        load: f64,
    },
}

/// What one contact does during a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactForce {
    /// Slip (κ, α).
    pub slip: [f64; 2],
    /// Force on the wheel's link in (rolling direction, lateral), N.
    pub force: [f64; 2],
    /// ∂F_x/∂ω, N·s/rad: how the longitudinal force grows with the spin rate (for an implicit
    /// spin update).
    pub stiffness_per_spin: f64,
}

impl TyreParams {
    /// Checks that σ₀ and v_floor are finite and positive.
    pub fn validate(&self) -> Result<(), TyreError> {
        for (name, value) in [
            ("saturation_slip", self.saturation_slip),
            ("speed_floor", self.speed_floor),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(TyreError::NotPositive { name, value });
            }
        }
        Ok(())
    }

    /// Slip of a contact: spin `spin` (rad/s) of a wheel of radius `radius`, contact velocity
    /// `velocity` (rolling direction, lateral; m/s).
    pub fn slip(&self, spin: f64, radius: f64, velocity: [f64; 2]) -> [f64; 2] {
        let rim = spin * radius;
        let reference = velocity[0]
            .hypot(velocity[1])
            .max(rim.abs())
            .max(self.speed_floor);
        [(rim - velocity[0]) / reference, -velocity[1] / reference]
    }

    /// The friction force for a slip under normal load `normal` (N) with coefficient `mu`.
    pub fn force(&self, slip: [f64; 2], normal: f64, mu: f64) -> [f64; 2] {
        let ratio = slip[0].hypot(slip[1]) / self.saturation_slip;
        // |F|/|σ| = μN/σ₀ / √(1 + ratio²), finite at zero slip.
        let per_slip = mu * normal / self.saturation_slip / (1.0 + ratio * ratio).sqrt();
        [per_slip * slip[0], per_slip * slip[1]]
    }

    /// Slip, force and ∂F_x/∂ω of one contact.
    pub fn contact(
        &self,
        spin: f64,
        radius: f64,
        velocity: [f64; 2],
        normal: f64,
        mu: f64,
    ) -> ContactForce {
        let slip = self.slip(spin, radius, velocity);
        let force = self.force(slip, normal, mu);
        let h = 1e-6 * (1.0 + spin.abs());
        let ahead = self.force(self.slip(spin + h, radius, velocity), normal, mu)[0];
        let behind = self.force(self.slip(spin - h, radius, velocity), normal, mu)[0];
        ContactForce {
            slip,
            force,
            stiffness_per_spin: (ahead - behind) / (2.0 * h),
        }
    }
}

/// Static normal loads (N) of the contacts at `contacts` (m, in any frame of the floor) carrying
/// `mass` (kg) whose centre of mass is at `centre_of_mass`, under gravity `g` (m/s²): force and
/// moment balance, `Σ N = m·g`, `Σ N·x = m·g·x_c`, `Σ N·y = m·g·y_c`. Three contacts not on one
/// line give the unique answer; more give the least-squares-smallest loads.
pub fn static_normal_loads(
    mass: f64,
    centre_of_mass: [f64; 2],
    contacts: &[[f64; 2]],
    g: f64,
) -> Result<Vec<f64>, TyreError> {
    // N = Aᵀ (A Aᵀ)⁻¹ b with A = [1; x; y] (3 × n), b = m g [1, x_c, y_c].
    let rows = |c: &[f64; 2]| [1.0, c[0], c[1]];
    let mut gram = [[0.0; 3]; 3];
    for c in contacts {
        let a = rows(c);
        for i in 0..3 {
            for j in 0..3 {
                gram[i][j] += a[i] * a[j];
            }
        }
    }
    let weight = mass * g;
    let b = [
        weight,
        weight * centre_of_mass[0],
        weight * centre_of_mass[1],
    ];
    let lambda = solve3(gram, b).ok_or(TyreError::Collinear)?;
    let loads: Vec<f64> = contacts
        .iter()
        .map(|c| {
            let a = rows(c);
            a[0] * lambda[0] + a[1] * lambda[1] + a[2] * lambda[2]
        })
        .collect();
    if let Some((contact, &load)) = loads.iter().enumerate().find(|(_, &n)| n <= 0.0) {
        return Err(TyreError::Unsupported { contact, load });
    }
    Ok(loads)
}

/// Solves a 3×3 system by Cramer's rule; `None` when (nearly) singular.
fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    let scale = a.iter().flatten().map(|v| v.abs()).fold(0.0, f64::max);
    if d.is_nan() || d.abs() <= 1e-12 * scale.powi(3) {
        return None;
    }
    let mut x = [0.0; 3];
    for (k, value) in x.iter_mut().enumerate() {
        let mut m = a;
        for i in 0..3 {
            m[i][k] = b[i];
        }
        *value = det(m) / d;
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn force_is_linear_then_saturates() {
        let tyre = TyreParams::default();
        let small = tyre.force([1e-4, 0.0], 10.0, 0.8);
        assert!((small[0] - 0.8 * 10.0 / 0.1 * 1e-4).abs() < 1e-7);
        let at_knee = tyre.force([0.0, 0.1], 10.0, 0.8);
        assert!((at_knee[1] - 8.0 / 2f64.sqrt()).abs() < 1e-12);
        let huge = tyre.force([30.0, 40.0], 10.0, 0.8);
        assert!((huge[0].hypot(huge[1]) - 8.0).abs() < 1e-3);
        assert!(huge[0].hypot(huge[1]) < 8.0);
        assert!(
            (huge[1] / huge[0] - 4.0 / 3.0).abs() < 1e-12,
            "along the slip"
        );
    }

    #[test]
    fn slip_of_rolling_spinning_and_sliding_wheels() {
        let tyre = TyreParams::default();
        assert_eq!(tyre.slip(10.0, 0.04, [0.4, 0.0]), [0.0, 0.0]);
        let spinning = tyre.slip(10.0, 0.04, [0.2, 0.0]);
        assert!((spinning[0] - 0.5).abs() < 1e-12);
        let sliding = tyre.slip(0.0, 0.04, [0.0, 0.1]);
        assert!((sliding[1] + 1.0).abs() < 1e-12);
        assert!(tyre.slip(0.0, 0.04, [0.0, 0.0]).iter().all(|s| *s == 0.0));
        let c = tyre.contact(10.0, 0.04, [0.2, 0.0], 10.0, 0.8);
        assert!(c.stiffness_per_spin > 0.0 && c.force[0] > 0.0);
    }

    #[test]
    fn normal_loads_balance_the_weight() {
        let contacts = [[0.0, 0.1], [0.0, -0.1], [-0.2, 0.0]];
        let loads = static_normal_loads(3.0, [-0.05, 0.0], &contacts, 9.81).unwrap();
        let total: f64 = loads.iter().sum();
        assert!((total - 3.0 * 9.81).abs() < 1e-9);
        assert!((loads[2] - 3.0 * 9.81 * 0.25).abs() < 1e-9);
        assert!((loads[0] - loads[1]).abs() < 1e-9);
        assert!(static_normal_loads(3.0, [0.1, 0.0], &contacts, 9.81)
            .unwrap_err()
            .to_string()
            .contains("outside"));
        assert_eq!(
            static_normal_loads(1.0, [0.0, 0.0], &[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]], 9.81),
            Err(TyreError::Collinear)
        );
        assert!(TyreParams {
            saturation_slip: 0.0,
            ..Default::default()
        }
        .validate()
        .is_err());
    }
}
