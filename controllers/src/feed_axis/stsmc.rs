//! `stsmc`: super-twisting sliding-mode control of a linear-motor feed axis `m ẍ + b ẋ = F`, after
//! Rubio, Ibeas & Luo (their §IV; the paper numbers equations afresh in each section, so "IV.(n)"
//! below is eq (n) of §IV).
//!
//! **Surface.** The PID-type surface of IV.(6), `S = ė + μ e + λ ∫e` with `e = x_ref − x`, where
//! the velocity error uses the velocity ẋ̂ estimated from the measured position by a first-order
//! filtered derivative `s/(τ_v s + 1)` (the paper measures position only). On `S ≡ 0` the error
//! obeys `s² + μ s + λ = 0`, which is strictly Hurwitz exactly when μ > 0 and λ > 0.
//!
//! **Equivalent control.** Setting `Ṡ = 0` (IV.(7)–(8)) and substituting the plant (IV.(9)) with
//! the estimates m̂, b̂ gives `F_eq = m̂ (ẍ_ref + μ ė̂ + λ e) + b̂ ẋ̂`. With the paper's choice
//! μ = b̂/m̂ the velocity terms cancel and this is IV.(10), `m̂ ẍ_ref + b̂ ẋ_ref + m̂ λ e`, which
//! needs no velocity estimate; μ is that by default and may be set apart from it.
//!
//! **Switching.** IV.(11) adds the super-twisting term `Λ √|S| sign S + v` with `v̇ = W sign S`
//! (Levant, Int. J. Control 58 (1993) 1247–1263; Lyapunov gain conditions in Moreno & Osorio,
//! IEEE Trans. Autom. Control 57 (2012) 1035–1040). The paper prints `v(t) = sign(S)`, but its
//! Lyapunov derivative IV.(12) carries `S ∫ sign S dτ`, i.e. v is the integral of sign S with unit
//! gain; here the gain W is a parameter. With exact estimates the surface obeys
//! `m Ṡ = −Λ √|S| sign S − v − F_d`, the standard algorithm scaled by 1/m, so a disturbance whose
//! rate stays below W is rejected in finite time. v is frozen while the force is clipped.
//!
//! **Defaults.** m̂ = 11 kg and b̂ = 255 N·s/m are the paper's; it gives no λ, Λ or filter, and
//! its printed law implies W = 1 N/s. Here λ = 135 s⁻² places the sliding dynamics' poles
//! together near −11.6 rad/s with μ = b̂/m̂ = 23.2 s⁻¹. W = 1 N/s is kept: it exceeds the rate of
//! the slow part of the micro-milling load (its drag, a few mN/s at the paper's feed; see
//! `models::feed_axis::micromilling`) but not that of the 384 Hz tooth ripple (≈4 N/s), whose
//! effect on the 10 kg table is of order 10⁻¹¹ m. Λ = 10 N·(s/m)^½ was chosen on the test rig (10
//! kHz loop, τ_v = 1 ms): it settles the start from rest within a few milliseconds, whereas W ≥ 3
//! N/s or Λ ≥ 50 make the sampled loop, which sees the velocity through the filter, chatter.
use super::p_pi::{FeedAxis, FeedAxisSample};
use crate::check::{finite, non_negative, positive, require};
use crate::filters::{FilterParameter, FirstOrderFilter};
use framework::{parse_params, Entry};
use framework::{Controller, ControllerError, Measurement, PlantInterface, SignalSpec, Unit};
use serde::Deserialize;

/// Parameters of `stsmc` (SI units).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct StsmcParams {
    /// The actuated prismatic joint carrying the table.
    pub joint: String,
    /// m̂, kg.
    pub mass_estimate: f64,
    /// b̂, N·s/m.
    pub damping_estimate: f64,
    /// μ, s⁻¹; absent: b̂/m̂, the paper's choice that turns the equivalent control into IV.(10).
    pub surface_velocity_gain: Option<f64>,
    /// λ, s⁻².
    pub surface_integral_gain: f64,
    /// Λ, N·(s/m)^½: gain of `√|S| sign S`.
    pub proportional_switching_gain: f64,
    /// W, N/s: rate of the switching integral `v̇ = W sign S`.
    pub integral_switching_gain: f64,
    /// τ_v of the velocity estimate `s/(τ_v s + 1)`, s.
    pub velocity_filter_time_constant: f64,
}

impl Default for StsmcParams {
    fn default() -> Self {
        Self {
            joint: "table".into(),
            mass_estimate: 11.0,
            damping_estimate: 255.0,
            surface_velocity_gain: None,
            surface_integral_gain: 135.0,
            proportional_switching_gain: 10.0,
            integral_switching_gain: 1.0,
            velocity_filter_time_constant: 1e-3,
        }
    }
}

/// Gains produced by [`design`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StsmcGains {
    /// m̂, kg.
    pub mass: f64,
    /// b̂, N·s/m.
    pub damping: f64,
    /// μ, s⁻¹.
    pub surface_velocity_gain: f64,
    /// λ, s⁻².
    pub surface_integral_gain: f64,
    /// Λ, N·(s/m)^½.
    pub proportional_switching_gain: f64,
    /// W, N/s.
    pub integral_switching_gain: f64,
}

/// Checks the parameters (m̂ > 0, b̂ ≥ 0, a Hurwitz surface, positive switching gains) and returns
/// the gains.
pub fn design(params: &StsmcParams) -> Result<StsmcGains, ControllerError> {
    design_for("stsmc", params)
}

pub(crate) fn design_for(
    controller: &str,
    params: &StsmcParams,
) -> Result<StsmcGains, ControllerError> {
    let mass = positive(controller, "mass_estimate", params.mass_estimate)?;
    let damping = non_negative(controller, "damping_estimate", params.damping_estimate)?;
    let mu = match params.surface_velocity_gain {
        Some(mu) => hurwitz(controller, "surface_velocity_gain", mu)?,
        None if (damping / mass).is_finite() && damping / mass > 0.0 => damping / mass,
        None => {
            return Err(ControllerError::parameter(
                controller,
                "damping_estimate",
                damping,
                format!(
                    "must make μ = damping_estimate/mass_estimate = {} finite and > 0 when \
                     surface_velocity_gain is absent: the sliding surface s² + μ s + λ is not \
                     Hurwitz otherwise",
                    damping / mass
                ),
            ))
        }
    };
    let lambda = hurwitz(
        controller,
        "surface_integral_gain",
        params.surface_integral_gain,
    )?;
    let proportional = positive(
        controller,
        "proportional_switching_gain",
        params.proportional_switching_gain,
    )?;
    let integral = positive(
        controller,
        "integral_switching_gain",
        params.integral_switching_gain,
    )?;
    positive(
        controller,
        "velocity_filter_time_constant",
        params.velocity_filter_time_constant,
    )?;
    Ok(StsmcGains {
        mass,
        damping,
        surface_velocity_gain: mu,
        surface_integral_gain: lambda,
        proportional_switching_gain: proportional,
        integral_switching_gain: integral,
    })
}

/// A coefficient of the sliding surface's `s² + μ s + λ`: Hurwitz exactly when both are > 0.
fn hurwitz(controller: &str, key: &str, value: f64) -> Result<f64, ControllerError> {
    let value = finite(controller, key, value)?;
    require(
        controller,
        key,
        value,
        value > 0.0,
        "must be > 0: the sliding surface s² + μ s + λ is not Hurwitz otherwise",
    )
}

fn sign(value: f64) -> f64 {
    if value > 0.0 {
        1.0
    } else if value < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// The super-twisting law IV.(6)–(11) with its state; `stsmc` runs it alone, `stsmc-dob` adds a
/// disturbance observer's compensation.
pub(crate) struct SuperTwistingLaw {
    gains: StsmcGains,
    velocity_estimate: FirstOrderFilter,
    error_integral: f64,
    switching_integral: f64,
    position_error: f64,
    surface: f64,
    equivalent_force: f64,
    twisting_force: f64,
    force_command: f64,
}

impl SuperTwistingLaw {
    /// The law's internals, in the order of [`SuperTwistingLaw::internal_values`].
    pub(crate) fn internals() -> Vec<SignalSpec> {
        vec![
            SignalSpec::new("position_error", Unit::Micrometre, "table position error"),
            SignalSpec::new(
                "velocity_estimate",
                Unit::MicrometrePerSecond,
                "table velocity",
            ),
            SignalSpec::new("surface", Unit::MicrometrePerSecond, "sliding surface"),
            SignalSpec::new("equivalent_force", Unit::Newton, "force terms"),
            SignalSpec::new("twisting_force", Unit::Newton, "force terms"),
            SignalSpec::new("switching_integral", Unit::Newton, "force terms"),
            SignalSpec::new("force_command", Unit::Newton, "force terms"),
        ]
    }

    pub(crate) fn new(controller: &str, params: &StsmcParams) -> Result<Self, ControllerError> {
        let gains = design_for(controller, params)?;
        let velocity_estimate = FirstOrderFilter::derivative(params.velocity_filter_time_constant)
            .map_err(|e| e.for_parameter(controller, "velocity_filter_time_constant"))?;
        Ok(Self {
            gains,
            velocity_estimate,
            error_integral: 0.0,
            switching_integral: 0.0,
            position_error: 0.0,
            surface: 0.0,
            equivalent_force: 0.0,
            twisting_force: 0.0,
            force_command: 0.0,
        })
    }

    pub(crate) fn reset(&mut self) {
        self.velocity_estimate.reset();
        self.error_integral = 0.0;
        self.switching_integral = 0.0;
        self.position_error = 0.0;
        self.surface = 0.0;
        self.equivalent_force = 0.0;
        self.twisting_force = 0.0;
        self.force_command = 0.0;
    }

    /// One period: returns the force command, `F_eq + Λ√|S| sign S + v + compensation`, clipped
    /// to ±`effort_limit`; v integrates only while the command is not clipped.
    pub(crate) fn update(
        &mut self,
        sample: &FeedAxisSample,
        period: f64,
        compensation: f64,
        effort_limit: f64,
    ) -> f64 {
        let g = self.gains;
        let table_velocity = self.velocity_estimate.update(sample.table_position, period);
        self.position_error = sample.reference - sample.table_position;
        self.error_integral += self.position_error * period;
        let velocity_error = sample.reference_rate - table_velocity;
        self.surface = velocity_error
            + g.surface_velocity_gain * self.position_error
            + g.surface_integral_gain * self.error_integral;
        self.equivalent_force = g.mass
            * (sample.reference_acceleration
                + g.surface_velocity_gain * sample.reference_rate
                + g.surface_integral_gain * self.position_error)
            + (g.damping - g.mass * g.surface_velocity_gain) * table_velocity;
        let direction = sign(self.surface);
        self.twisting_force = g.proportional_switching_gain * self.surface.abs().sqrt() * direction;
        let force = |switching_integral: f64| {
            self.equivalent_force + self.twisting_force + switching_integral + compensation
        };
        let candidate = self.switching_integral + g.integral_switching_gain * direction * period;
        if force(candidate).abs() <= effort_limit {
            self.switching_integral = candidate;
        }
        self.force_command = force(self.switching_integral).clamp(-effort_limit, effort_limit);
        self.force_command
    }

    pub(crate) fn internal_values(&self) -> [f64; 7] {
        [
            self.position_error,
            self.velocity_estimate.output(),
            self.surface,
            self.equivalent_force,
            self.twisting_force,
            self.switching_integral,
            self.force_command,
        ]
    }
}

/// The running `stsmc` controller.
pub struct Stsmc {
    params: StsmcParams,
    law: SuperTwistingLaw,
    axis: Option<FeedAxis>,
}

impl Stsmc {
    /// Designs the sliding law and its velocity estimate; errors name the parameter at fault.
    pub fn new(params: StsmcParams) -> Result<Self, ControllerError> {
        let law = SuperTwistingLaw::new("stsmc", &params)?;
        Ok(Self {
            params,
            law,
            axis: None,
        })
    }
}

pub(crate) fn entry() -> Entry {
    Entry {
        name: "stsmc",
        machine: "feed_axis",
        summary: "super-twisting sliding-mode control on a PID surface (linear-motor feed axis)",
        build: |table| Ok(Box::new(Stsmc::new(parse_params("stsmc", table)?)?)),
    }
}

impl Controller for Stsmc {
    fn name(&self) -> &str {
        "stsmc"
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        self.axis = Some(FeedAxis::bind(plant, &self.params.joint)?);
        self.law.reset();
        Ok(())
    }

    fn update(&mut self, measurement: &Measurement, period: f64, efforts: &mut [f64]) {
        let Some(axis) = &self.axis else {
            return;
        };
        let sample = axis.sample(measurement);
        efforts[axis.actuator()] = self.law.update(&sample, period, 0.0, axis.effort_limit());
    }

    fn internals(&self) -> Vec<SignalSpec> {
        SuperTwistingLaw::internals()
    }

    fn internal_values(&self, values: &mut [f64]) {
        values.copy_from_slice(&self.law.internal_values());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::feed_axis::p_pi::test_rig::{plant, run, Rig};
    use crate::feed_axis::p_pi::{PPi, PPiParams};
    use models::feed_axis::micromilling::{MicroMillingCut, MicroMillingParams};

    #[test]
    fn default_surface_is_the_papers() {
        let gains = design(&StsmcParams::default()).unwrap();
        assert_eq!(gains.surface_velocity_gain, 255.0 / 11.0);
        // With μ = b̂/m̂ the equivalent control does not use the velocity estimate (IV.(10)).
        let mut law = SuperTwistingLaw::new("stsmc", &StsmcParams::default()).unwrap();
        let sample = |position: f64| FeedAxisSample {
            table_position: position,
            reference: 1e-6,
            reference_rate: 2e-6,
            reference_acceleration: -3e-6,
        };
        law.update(&sample(0.0), 1e-4, 0.0, 100.0);
        law.update(&sample(1e-7), 1e-4, 0.0, 100.0);
        let values = law.internal_values();
        assert!(values[1].abs() > 1e-5, "the table moved: {}", values[1]);
        let expected = 11.0 * -3e-6 + 255.0 * 2e-6 + 11.0 * 135.0 * (1e-6 - 1e-7);
        assert!(
            (values[3] - expected).abs() < 1e-12,
            "{} vs {expected}",
            values[3]
        );
    }

    #[test]
    fn tracks_the_paper_sine() {
        let mut controller = Stsmc::new(StsmcParams::default()).unwrap();
        let tracking = run(&Rig::default(), &mut controller);
        println!("stsmc without cut: {tracking}");
        assert!(tracking.position_max < 0.03e-6, "{tracking}");
        assert!(tracking.late_position_max < 0.005e-6, "{tracking}");
        assert!(tracking.velocity_sigma < 0.2e-6, "{tracking}");
    }

    #[test]
    fn outperforms_p_pi_under_the_micromilling_cut() {
        let rig = Rig {
            cut: Some(MicroMillingCut::new(MicroMillingParams::default()).unwrap()),
            ..Default::default()
        };
        let mut controller = Stsmc::new(StsmcParams::default()).unwrap();
        let sliding = run(&rig, &mut controller);
        let mut baseline = PPi::new(PPiParams::default()).unwrap();
        let p_pi = run(&rig, &mut baseline);
        println!("stsmc with cut: {sliding}");
        assert!(sliding.position_max < 0.03e-6, "{sliding}");
        assert!(sliding.late_position_max < 0.01e-6, "{sliding}");
        assert!(
            sliding.position_sigma < 0.2 * p_pi.position_sigma,
            "{sliding} vs {p_pi}"
        );
    }

    #[test]
    fn runs_on_a_quantised_encoder() {
        let mut controller = Stsmc::new(StsmcParams::default()).unwrap();
        let rig = Rig {
            resolution: 1e-9,
            cut: Some(MicroMillingCut::new(MicroMillingParams::default()).unwrap()),
            ..Default::default()
        };
        let tracking = run(&rig, &mut controller);
        println!("stsmc with cut, 1 nm encoder: {tracking}");
        assert!(tracking.late_position_max < 0.02e-6, "{tracking}");
    }

    #[test]
    fn clips_without_winding_up() {
        let mut controller = Stsmc::new(StsmcParams::default()).unwrap();
        controller.reset(&plant(1e-3)).unwrap();
        let mut effort = [0.0];
        let signals = [0.0, 1e-3, 0.0, 0.0];
        for _ in 0..100 {
            controller.update(
                &Measurement {
                    time: 0.0,
                    signals: &signals,
                },
                1e-4,
                &mut effort,
            );
        }
        assert_eq!(effort[0], 1e-3);
        let mut values = [0.0; 7];
        controller.internal_values(&mut values);
        assert_eq!(values[5], 0.0, "v must not wind up while clipped");
    }

    #[test]
    fn rejects_bad_parameters() {
        let build = |key: &str, value: f64| {
            let mut table = toml::Table::new();
            table.insert(key.into(), toml::Value::Float(value));
            framework::Registry::with([super::entry()])
                .build("stsmc", "feed_axis", &table)
                .err()
                .unwrap()
        };
        for (key, value, shown, reason) in [
            ("mass_estimate", 0.0, "0", "must be > 0"),
            ("damping_estimate", -1.0, "-1", "must be ≥ 0"),
            ("proportional_switching_gain", 0.0, "0", "must be > 0"),
            ("integral_switching_gain", -1.0, "-1", "must be > 0"),
            (
                "surface_velocity_gain",
                -2.0,
                "-2",
                "must be > 0: the sliding surface s² + μ s + λ is not Hurwitz",
            ),
            (
                "surface_integral_gain",
                0.0,
                "0",
                "must be > 0: the sliding surface s² + μ s + λ is not Hurwitz",
            ),
            (
                "velocity_filter_time_constant",
                f64::NAN,
                "NaN",
                "must be a finite number",
            ),
        ] {
            let err = build(key, value);
            assert!(
                matches!(
                    &err,
                    ControllerError::BadParameter { key: k, value: Some(v), reason: r, .. }
                        if k == key && v == shown && r.starts_with(reason)
                ),
                "{key}: {err}"
            );
        }
        // No damping estimate and no explicit μ: μ = b̂/m̂ = 0, not Hurwitz.
        let err = build("damping_estimate", 0.0);
        assert!(
            matches!(
                &err,
                ControllerError::BadParameter { key, reason, .. }
                    if key == "damping_estimate" && reason.contains("Hurwitz")
            ),
            "{err}"
        );
        let err = build("lambda", 1.0);
        assert!(
            matches!(&err, ControllerError::BadParameter { key, .. } if key == "lambda"),
            "{err}"
        );
    }
}
