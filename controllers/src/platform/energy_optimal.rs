//! `energy-optimal`: optimal control of the two-wheeled platform at the kinetic-energy performance
//! index (Kalinski et al. 2013, §2 and §4, Kaliński eqs (19)–(21)), through the two wheel torques.
//!
//! Model: `M* q̈ + L* q̇ = u` in wheel-rate coordinates q̇ = (φ̇_L, φ̇_R) (M* derived in
//! [`crate::platform::model`], L* = `wheel_damping`·I), state x = (q̇, q) as in Kaliński eq (1), so
//! `A = [[−M*⁻¹L*, 0], [I, 0]]`, `B = [M*⁻¹; 0]`.
//!
//! Index (Kaliński eq (20)): `J = ½ eᵀ Q₁ M* e + ½ uᵀ R u` with `e = q̇ − q̄̇ − q̂̇`, q̄̇ the wheel
//! rates of the path's velocities of H and q̂̇ those of the correcting velocities (Kaliński eq
//! (19)), both by inverse kinematics at the odometry heading.
//!
//! Law (Kaliński eq (21)): `u = −(R + Rᵀ)⁻¹ Γᵀ (M*ᵀQ₁ᵀ + Q₁M*) e` with Γ = T₁∫Φ B dτ over the
//! sampling interval Δt — read here as the effect on q̇ at the end of the interval of a command
//! held over it, `Γ = ∫₀^Δt e^{−M*⁻¹L* σ} dσ · M*⁻¹` (computed from the exponential of the block
//! matrix `[[−M*⁻¹L*, M*⁻¹], [0, 0]]·Δt`). Then each torque is clipped to U (Kaliński eq (10)).
//!
//! With Q₁ = q₁·I and R = ρ·I the gain is about q₁Δt/ρ·I: a proportional law on the wheel-rate
//! error, shaped by M* (its coupling term acts when L* ≠ 0 or Q₁ is not scalar).

use super::guidance::{wheel_actuators, Guide};
use super::model::PlatformModel;
use crate::check::{non_negative, positive};
use framework::{parse_params, Entry};
use framework::{Controller, ControllerError, Measurement, PlantInterface, SignalSpec, Unit};
use framework::{Event, EventKind};
use nalgebra::{Matrix2, Matrix4};
use serde::Deserialize;

const NAME: &str = "energy-optimal";

/// Parameters of `energy-optimal` (SI units).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct EnergyOptimalParams {
    /// The controller's model of the platform: wheels, track, point H, mass and inertias.
    pub model: PlatformModel,
    /// Q₁ = diag(q1_left, q1_right): dimensionless weights of the kinetic energy of the error.
    pub q1: [f64; 2],
    /// R = r·I, rad/(N·m): weight of the command.
    pub r: f64,
    /// k: scaling of the correction time k·Δt in Kaliński eq (19).
    pub k: f64,
    /// Δt, s: the sampling interval of Kaliński eqs (19) and (21); set it to the control period.
    pub sampling_interval: f64,
    /// L*: viscous friction of each wheel drive, N·m·s/rad.
    pub wheel_damping: f64,
    /// U of Kaliński eq (10), N·m (the drive's effort limit applies too).
    pub torque_limit: f64,
}

impl Default for EnergyOptimalParams {
    fn default() -> Self {
        Self {
            model: PlatformModel::default(),
            q1: [1.0, 1.0],
            r: 0.025,
            k: 60.0,
            sampling_interval: 0.005,
            wheel_damping: 2e-3,
            torque_limit: 1.0,
        }
    }
}

/// What [`design`] derives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnergyOptimalDesign {
    /// M*, kg·m².
    pub inertia: Matrix2<f64>,
    /// Γ = ∫ T₁ Φ B over Δt, s/(kg·m²).
    pub input_response: Matrix2<f64>,
    /// G with u = −G·e, N·m·s/rad.
    pub gain: Matrix2<f64>,
}

/// Turns the parameters into the gain of Kaliński eq (21).
pub fn design(params: &EnergyOptimalParams) -> Result<EnergyOptimalDesign, ControllerError> {
    params.model.validate(NAME)?;
    positive(NAME, "q1.0", params.q1[0])?;
    positive(NAME, "q1.1", params.q1[1])?;
    let r = positive(NAME, "r", params.r)?;
    positive(NAME, "k", params.k)?;
    let dt = positive(NAME, "sampling_interval", params.sampling_interval)?;
    positive(NAME, "torque_limit", params.torque_limit)?;
    let wheel_damping = non_negative(NAME, "wheel_damping", params.wheel_damping)?;
    let m = params.model.inertia_matrix();
    let inertia = Matrix2::new(m[0][0], m[0][1], m[1][0], m[1][1]);
    let inverse = inertia.try_inverse().ok_or_else(|| {
        ControllerError::parameter_table(NAME, "model", "must give a regular M* (it is singular)")
    })?;
    let damping = Matrix2::identity() * wheel_damping;
    let mut block = Matrix4::zeros();
    block
        .fixed_view_mut::<2, 2>(0, 0)
        .copy_from(&(-inverse * damping * dt));
    block
        .fixed_view_mut::<2, 2>(0, 2)
        .copy_from(&(inverse * dt));
    let input_response: Matrix2<f64> = block.exp().fixed_view::<2, 2>(0, 2).into();
    let q1 = Matrix2::from_diagonal(&nalgebra::Vector2::new(params.q1[0], params.q1[1]));
    let weight = Matrix2::identity() * r;
    let gain = (weight + weight.transpose())
        .try_inverse()
        .ok_or_else(|| ControllerError::parameter(NAME, "r", r, "must give a regular R + Rᵀ"))?
        * input_response.transpose()
        * (inertia.transpose() * q1.transpose() + q1 * inertia);
    if !(input_response
        .iter()
        .chain(gain.iter())
        .all(|v| v.is_finite()))
    {
        return Err(ControllerError::parameter(
            NAME,
            "sampling_interval",
            dt,
            "must be small enough, with q1 small and r large enough, that the gain of eq (21) \
             does not overflow",
        ));
    }
    Ok(EnergyOptimalDesign {
        inertia,
        input_response,
        gain,
    })
}

/// The running law.
pub struct EnergyOptimal {
    params: EnergyOptimalParams,
    design: EnergyOptimalDesign,
    guide: Guide,
    actuators: [usize; 2],
    limit: f64,
    error: [f64; 2],
    torque: [f64; 2],
    index: f64,
    saturated: bool,
    events: Vec<Event>,
}

impl EnergyOptimal {
    /// Designs the gain of Kaliński eq (21) and the guide; errors name the parameter at fault.
    pub fn new(params: EnergyOptimalParams) -> Result<Self, ControllerError> {
        let design = design(&params)?;
        let guide = Guide::new(params.model, params.k * params.sampling_interval);
        Ok(Self {
            params,
            design,
            guide,
            actuators: [0, 1],
            limit: f64::INFINITY,
            error: [0.0; 2],
            torque: [0.0; 2],
            index: 0.0,
            saturated: false,
            events: Vec::new(),
        })
    }
}

pub(crate) fn entry() -> Entry {
    Entry {
        name: NAME,
        machine: "platform",
        summary: "optimal control at the kinetic-energy index (eqs 19–21) through wheel torques",
        build: |table| Ok(Box::new(EnergyOptimal::new(parse_params(NAME, table)?)?)),
    }
}

impl Controller for EnergyOptimal {
    fn name(&self) -> &str {
        NAME
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        self.guide.reset(plant)?;
        (self.actuators, self.limit) = wheel_actuators(plant, self.params.torque_limit)?;
        self.error = [0.0; 2];
        self.torque = [0.0; 2];
        self.index = 0.0;
        self.saturated = false;
        self.events.clear();
        Ok(())
    }

    fn update(&mut self, measurement: &Measurement, period: f64, efforts: &mut [f64]) {
        let guidance = self.guide.update(measurement, period);
        let e = nalgebra::Vector2::new(
            guidance.wheel_rates[0] - guidance.wheel_rates_wanted[0],
            guidance.wheel_rates[1] - guidance.wheel_rates_wanted[1],
        );
        let u = -self.design.gain * e;
        let saturated = u.iter().any(|v| v.abs() > self.limit);
        if saturated != self.saturated {
            let subject = "wheel_torque".to_string();
            self.events.push(if saturated {
                Event::warning(
                    EventKind::SaturationStart { subject },
                    "energy-optimal: wheel torque limited (eq 10)",
                )
            } else {
                Event::info(
                    EventKind::SaturationEnd { subject },
                    "energy-optimal: wheel torques within U",
                )
            });
            self.saturated = saturated;
        }
        self.torque = [u[0], u[1]].map(|v| v.clamp(-self.limit, self.limit));
        let q1 = self.params.q1;
        let m_e = self.design.inertia * e;
        self.index = 0.5 * (e[0] * q1[0] * m_e[0] + e[1] * q1[1] * m_e[1])
            + 0.5 * self.params.r * (self.torque[0].powi(2) + self.torque[1].powi(2));
        self.error = [e[0], e[1]];
        efforts[self.actuators[0]] = self.torque[0];
        efforts[self.actuators[1]] = self.torque[1];
    }

    fn internals(&self) -> Vec<SignalSpec> {
        let mut specs = Guide::internals();
        specs.extend([
            SignalSpec::new("wheel_rate_error.left", Unit::Rpm, "wheel rate errors"),
            SignalSpec::new("wheel_rate_error.right", Unit::Rpm, "wheel rate errors"),
            SignalSpec::new("torque.left", Unit::NewtonMetre, "wheel torque commands"),
            SignalSpec::new("torque.right", Unit::NewtonMetre, "wheel torque commands"),
            SignalSpec::new("performance_index", Unit::Joule, "performance index"),
        ]);
        specs
    }

    fn internal_values(&self, values: &mut [f64]) {
        values[..6].copy_from_slice(&self.guide.values());
        values[6..].copy_from_slice(&[
            self.error[0],
            self.error[1],
            self.torque[0],
            self.torque[1],
            self.index,
        ]);
    }

    fn drain_events(&mut self, events: &mut Vec<Event>) {
        events.append(&mut self.events);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scalar_weights_give_q1_dt_over_r() {
        let params = EnergyOptimalParams {
            wheel_damping: 0.0,
            ..Default::default()
        };
        let d = design(&params).unwrap();
        let expected = params.q1[0] * params.sampling_interval / params.r;
        assert!((d.gain - Matrix2::identity() * expected).abs().max() < 1e-12);
        assert!(
            (d.input_response * d.inertia - Matrix2::identity() * 0.005)
                .abs()
                .max()
                < 1e-15
        );
    }

    #[test]
    fn damping_shrinks_the_input_response() {
        let lossless = design(&EnergyOptimalParams {
            wheel_damping: 0.0,
            ..Default::default()
        })
        .unwrap();
        let lossy = design(&EnergyOptimalParams {
            wheel_damping: 0.05,
            ..Default::default()
        })
        .unwrap();
        assert!(lossy.gain[(0, 0)] < lossless.gain[(0, 0)]);
        assert!(lossy.gain[(0, 1)].abs() > 0.0);
    }

    #[test]
    fn rejects_bad_parameters() {
        let build = |text: &str| {
            framework::Registry::with([super::entry()])
                .build(NAME, "platform", &text.parse::<toml::Table>().unwrap())
                .err()
                .unwrap()
        };
        for (text, key, value) in [
            ("r = 0.0", "r", "0"),
            ("k = -1.0", "k", "-1"),
            ("sampling_interval = 0.0", "sampling_interval", "0"),
            ("q1 = [1.0, -2.0]", "q1.1", "-2"),
            ("wheel_damping = -0.5", "wheel_damping", "-0.5"),
            ("model = { half_track = 0.0 }", "model.half_track", "0"),
        ] {
            let err = build(text);
            assert!(
                matches!(
                    &err,
                    ControllerError::BadParameter { key: k, value: Some(v), .. }
                        if k == key && v == value
                ),
                "{text}: {err}"
            );
        }
        assert_eq!(
            build("model = { mass = -1.0 }").to_string(),
            "controller `energy-optimal`: params.model.mass = -1: must be > 0"
        );
    }
}
