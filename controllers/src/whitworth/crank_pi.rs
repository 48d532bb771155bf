//! `crank-pi`: crank-speed PI through crank torque — the "reciprocating method" the Whitworth
//! paper starts from (its §1: a constant crank speed gives a roughly constant ram speed only over a
//! small part of the stroke).
//!
//! Design: the crank side is taken as an inertia `J` driven by the torque, `J·ω̇ = τ`; the PI
//! `τ = kp·e + ki·∫e` places both closed-loop poles at `s² + 2ζω_n s + ω_n² = 0`, so
//! `kp = 2ζω_n·J`, `ki = ω_n²·J`. The linkage's varying reflected inertia and gravity are
//! disturbances to it.

use crate::check::{finite, positive};
use framework::{parse_params, Entry};
use framework::{Controller, ControllerError, Measurement, PlantInterface, SignalSpec, Unit};
use serde::Deserialize;

const NAME: &str = "crank-pi";

/// Parameters of `crank-pi` (SI units).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct CrankPiParams {
    /// The actuated crank joint.
    pub joint: String,
    /// Crank speed to hold, rad/s (negative turns the crank clockwise).
    pub crank_speed: f64,
    /// Crank-side inertia the design assumes, kg·m².
    pub inertia: f64,
    /// Closed-loop natural frequency, rad/s.
    pub natural_frequency: f64,
    /// Closed-loop damping ratio.
    pub damping_ratio: f64,
}

impl Default for CrankPiParams {
    fn default() -> Self {
        Self {
            joint: "crank".into(),
            crank_speed: -2.0 * std::f64::consts::PI,
            inertia: 0.5,
            natural_frequency: 40.0,
            damping_ratio: 1.0,
        }
    }
}

/// PI gains produced by [`design`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PiGains {
    /// N·m per rad/s.
    pub kp: f64,
    /// N·m per rad.
    pub ki: f64,
}

/// Pole placement for `J·ω̇ = τ` under PI control.
///
/// # Example
///
/// ```
/// use controllers::whitworth::crank_pi::{design, CrankPiParams};
///
/// // J = 0.5 kg·m², ω_n = 40 rad/s, ζ = 1: K_p = 2ζω_n·J, K_i = ω_n²·J.
/// let gains = design(&CrankPiParams::default())?;
/// assert_eq!((gains.kp, gains.ki), (40.0, 800.0));
/// # Ok::<(), framework::ControllerError>(())
/// ```
pub fn design(params: &CrankPiParams) -> Result<PiGains, ControllerError> {
    let inertia = positive(NAME, "inertia", params.inertia)?;
    let wn = positive(NAME, "natural_frequency", params.natural_frequency)?;
    let zeta = positive(NAME, "damping_ratio", params.damping_ratio)?;
    finite(NAME, "crank_speed", params.crank_speed)?;
    let gains = PiGains {
        kp: 2.0 * zeta * wn * inertia,
        ki: wn * wn * inertia,
    };
    if !(gains.kp.is_finite() && gains.ki.is_finite()) {
        return Err(ControllerError::parameter(
            NAME,
            "natural_frequency",
            wn,
            "must be small enough that the gains ω_n²·inertia and 2·damping_ratio·ω_n·inertia \
             do not overflow",
        ));
    }
    Ok(gains)
}

/// The running law: PI on the crank-speed error, with the integrator frozen while the torque is
/// clipped (anti-windup).
pub struct CrankPi {
    params: CrankPiParams,
    gains: PiGains,
    speed_signal: usize,
    actuator: usize,
    effort_limit: f64,
    integral: f64,
    speed_error: f64,
    torque: f64,
}

impl CrankPi {
    /// Designs the PI gains; errors name the parameter at fault.
    pub fn new(params: CrankPiParams) -> Result<Self, ControllerError> {
        let gains = design(&params)?;
        Ok(Self {
            params,
            gains,
            speed_signal: 0,
            actuator: 0,
            effort_limit: f64::INFINITY,
            integral: 0.0,
            speed_error: 0.0,
            torque: 0.0,
        })
    }
}

pub(crate) fn entry() -> Entry {
    Entry {
        name: NAME,
        machine: "whitworth",
        summary: "crank-speed PI through crank torque (the reciprocating method)",
        build: |table| Ok(Box::new(CrankPi::new(parse_params(NAME, table)?)?)),
    }
}

impl Controller for CrankPi {
    fn name(&self) -> &str {
        NAME
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        self.speed_signal = plant.signal(&format!("{}.velocity", self.params.joint))?;
        self.actuator = plant.actuator(&self.params.joint)?;
        self.effort_limit = plant.actuators[self.actuator].effort_limit;
        self.integral = 0.0;
        self.speed_error = 0.0;
        self.torque = 0.0;
        Ok(())
    }

    fn update(&mut self, measurement: &Measurement, period: f64, efforts: &mut [f64]) {
        self.speed_error = self.params.crank_speed - measurement.get(self.speed_signal);
        let candidate = self.integral + self.speed_error * period;
        let unclipped = self.gains.kp * self.speed_error + self.gains.ki * candidate;
        if unclipped.abs() <= self.effort_limit {
            self.integral = candidate;
        }
        let torque = self.gains.kp * self.speed_error + self.gains.ki * self.integral;
        self.torque = torque.clamp(-self.effort_limit, self.effort_limit);
        efforts[self.actuator] = self.torque;
    }

    fn internals(&self) -> Vec<SignalSpec> {
        vec![
            SignalSpec::new("speed_error", Unit::Rpm, "crank speed error"),
            SignalSpec::new("integral", Unit::Degree, "crank angle error integral"),
            SignalSpec::new("torque", Unit::NewtonMetre, "crank torque"),
        ]
    }

    fn internal_values(&self, values: &mut [f64]) {
        values.copy_from_slice(&[self.speed_error, self.integral, self.torque]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use framework::{Actuator, EffortKind};

    fn plant(limit: f64) -> PlantInterface {
        PlantInterface {
            machine: "test".into(),
            signals: vec!["crank.position".into(), "crank.velocity".into()],
            actuators: vec![Actuator {
                joint: "crank".into(),
                kind: EffortKind::Torque,
                effort_limit: limit,
            }],
            ..Default::default()
        }
    }

    #[test]
    fn design_places_both_poles() {
        let params = CrankPiParams {
            inertia: 2.0,
            natural_frequency: 10.0,
            damping_ratio: 0.5,
            ..Default::default()
        };
        let gains = design(&params).unwrap();
        // Characteristic polynomial J s² + kp s + ki = J (s² + 2ζω s + ω²).
        assert_eq!(gains.kp, 2.0 * 0.5 * 10.0 * 2.0);
        assert_eq!(gains.ki, 100.0 * 2.0);
    }

    #[test]
    fn holds_speed_on_a_pure_inertia() {
        let params = CrankPiParams {
            crank_speed: 3.0,
            inertia: 0.5,
            ..Default::default()
        };
        let mut pi = CrankPi::new(params).unwrap();
        pi.reset(&plant(1e3)).unwrap();
        let (mut omega, dt, inertia, load) = (0.0, 1e-3, 0.5, -2.0);
        let mut effort = [0.0];
        for step in 0..2000 {
            let signals = [0.0, omega];
            let m = Measurement {
                time: step as f64 * dt,
                signals: &signals,
            };
            pi.update(&m, dt, &mut effort);
            omega += (effort[0] + load) / inertia * dt;
        }
        // The integrator rejects the constant load torque.
        assert!((omega - 3.0).abs() < 1e-3, "omega = {omega}");
    }

    #[test]
    fn clips_to_the_limit_without_winding_up() {
        let mut pi = CrankPi::new(CrankPiParams::default()).unwrap();
        pi.reset(&plant(1.0)).unwrap();
        let mut effort = [0.0];
        let signals = [0.0, 0.0];
        for _ in 0..100 {
            pi.update(
                &Measurement {
                    time: 0.0,
                    signals: &signals,
                },
                1e-3,
                &mut effort,
            );
        }
        assert_eq!(effort[0].abs(), 1.0);
        let mut values = [0.0; 3];
        pi.internal_values(&mut values);
        assert_eq!(values[1], 0.0, "integrator must not wind up while clipped");
    }

    #[test]
    fn bad_parameters_are_named_with_their_value() {
        let build = |text: &str| {
            framework::Registry::with([super::entry()])
                .build(NAME, "whitworth", &text.parse::<toml::Table>().unwrap())
                .err()
                .unwrap()
        };
        let err = build("natural_frequency = -1");
        assert_eq!(
            err,
            ControllerError::BadParameter {
                controller: "crank-pi".into(),
                key: "natural_frequency".into(),
                value: Some("-1".into()),
                reason: "must be > 0".into(),
            }
        );
        assert_eq!(
            err.to_string(),
            "controller `crank-pi`: params.natural_frequency = -1: must be > 0"
        );
        let huge = "1e200";
        for (text, key, value) in [
            ("inertia = 0.0", "inertia", "0"),
            ("damping_ratio = -0.5", "damping_ratio", "-0.5"),
            ("natural_frequency = 1e200", "natural_frequency", huge),
        ] {
            assert!(
                matches!(build(text), ControllerError::BadParameter { key: k, value: Some(v), .. }
                    if k == key && v == value),
                "{text}: {}",
                build(text)
            );
        }
        let err = build("gain = 1.0");
        assert!(
            matches!(&err, ControllerError::BadParameter { key, .. } if key == "gain"),
            "{err}"
        );
        let err = design(&CrankPiParams {
            crank_speed: f64::INFINITY,
            ..Default::default()
        })
        .unwrap_err();
        assert_eq!(
            err.to_string(),
            "controller `crank-pi`: params.crank_speed = inf: must be a finite number"
        );
    }

    #[test]
    fn missing_signal_is_named() {
        let mut pi = CrankPi::new(CrankPiParams {
            joint: "spindle".into(),
            ..Default::default()
        })
        .unwrap();
        let err = pi.reset(&plant(1.0)).unwrap_err();
        assert!(err.to_string().contains("spindle.velocity"), "{err}");
    }
}
