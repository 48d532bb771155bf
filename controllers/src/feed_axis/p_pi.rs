//! `p-pi`: the P-PI position–velocity cascade with mass and damping feed-forward that Rubio, Ibeas
//! & Luo take as the CNC baseline for a linear-motor feed axis `m ẍ + b ẋ = F` (Rubio eq (1)).
//! The paper numbers its equations afresh in each section; "III.(n)" below is eq (n) of its §III.
//!
//! The law, every period:
//!
//! - β = K_v (x_ref − x̂) + (ẋ_ref − ẋ̂) — the velocity-loop error (III.(7)); x̂ is the measured
//!   table position, ẋ̂ the velocity estimated from it by a first-order filtered derivative
//!   `s/(τ_v s + 1)` (the paper's §IV: the position is measured and the velocity estimated);
//! - F̂_d = ∫ K_p K_i β dt — the integral of the velocity loop (III.(8), whose `dx` is read as
//!   `dt`);
//! - F_a = m̂ ẍ_ref + K_p β + F̂_d — acceleration feed-forward, proportional and integral action
//!   (III.(5));
//! - F_b = b̂ ẋ̂ — damping compensation (III.(6)), *added*: F_m = F_a + F_b (III.(4)), which
//!   cancels the guide-way damping `b ẋ` of Rubio eq (1) when b̂ = b.
//!
//! The external force enters the plant as F = F_d + F_m (III.(3)), so the integral that the paper
//! names F̂_d, being added to the command, converges to −F_d: it is the force that cancels the
//! disturbance, not an estimate of it.
//!
//! Design check: with b̂ = b and m̂ = m and a fast velocity filter, the tracking error obeys
//! `m s³ + K_p s² + K_p (K_v + K_i) s + K_p K_v K_i = 0`; the Routh condition
//! `K_p (K_v + K_i) > m̂ K_v K_i` must hold (the paper warns that some gain sets are unstable).
//! The paper's gains K_v = 30 s⁻¹, K_p = 50 N·s/m, K_i = 0.5 s⁻¹ with m̂ = 11 kg give a lightly
//! damped pair at 11.7 rad/s (ζ ≈ 0.17) and a slow real pole at 0.5 rad/s.

use crate::check::{non_negative, positive};
use crate::filters::{FilterParameter, FirstOrderFilter};
use framework::{parse_params, Entry};
use framework::{
    Controller, ControllerError, EffortKind, Measurement, PlantInterface, SignalSpec, Unit,
};
use serde::Deserialize;

const NAME: &str = "p-pi";

/// Measured reference signals the feed-axis controllers read, as the scenario names them.
/// This one: the table position reference x_ref, m.
pub const REFERENCE_SIGNAL: &str = "reference";
/// The reference's rate ẋ_ref, m/s.
pub const REFERENCE_RATE_SIGNAL: &str = "reference_rate";
/// The reference's acceleration ẍ_ref, m/s².
pub const REFERENCE_ACCELERATION_SIGNAL: &str = "reference_acceleration";

/// A linear-motor feed axis as the paper's controllers see it: the measured table position, the
/// scenario's reference and its two derivatives, and the force on the table's prismatic joint.
#[derive(Debug, Clone, PartialEq)]
pub struct FeedAxis {
    table_position: usize,
    reference: usize,
    reference_rate: usize,
    reference_acceleration: usize,
    actuator: usize,
    effort_limit: f64,
}

/// One period's reading of a [`FeedAxis`]: m, m, m/s, m/s².
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeedAxisSample {
    /// Measured table position x̂, m.
    pub table_position: f64,
    /// Position reference x_ref, m.
    pub reference: f64,
    /// Reference velocity ẋ_ref, m/s.
    pub reference_rate: f64,
    /// Reference acceleration ẍ_ref, m/s².
    pub reference_acceleration: f64,
}

impl FeedAxis {
    /// Resolves `<joint>.position`, the reference signals and the actuator on `joint`, which must
    /// take a force (a prismatic joint).
    pub fn bind(plant: &PlantInterface, joint: &str) -> Result<Self, ControllerError> {
        let actuator = plant.actuator_of_kind(joint, EffortKind::Force)?;
        Ok(Self {
            table_position: plant.signal(&format!("{joint}.position"))?,
            reference: plant.signal(REFERENCE_SIGNAL)?,
            reference_rate: plant.signal(REFERENCE_RATE_SIGNAL)?,
            reference_acceleration: plant.signal(REFERENCE_ACCELERATION_SIGNAL)?,
            actuator,
            effort_limit: plant.actuators[actuator].effort_limit,
        })
    }

    /// This period's table position and reference, read from `measurement`.
    pub fn sample(&self, measurement: &Measurement) -> FeedAxisSample {
        FeedAxisSample {
            table_position: measurement.get(self.table_position),
            reference: measurement.get(self.reference),
            reference_rate: measurement.get(self.reference_rate),
            reference_acceleration: measurement.get(self.reference_acceleration),
        }
    }

    /// Index of the table's actuator in the effort slice.
    pub fn actuator(&self) -> usize {
        self.actuator
    }

    /// Largest |force| the twin applies, N.
    pub fn effort_limit(&self) -> f64 {
        self.effort_limit
    }
}

/// Parameters of `p-pi` (SI units). Defaults: the paper's §V values; the velocity filter, which the
/// paper does not size, at 1 ms.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct PPiParams {
    /// The actuated prismatic joint carrying the table.
    pub joint: String,
    /// m̂, kg.
    pub mass_estimate: f64,
    /// b̂, N·s/m.
    pub damping_estimate: f64,
    /// K_v, position-loop gain, 1/s.
    pub position_gain: f64,
    /// K_p, velocity-loop gain, N·s/m.
    pub velocity_gain: f64,
    /// K_i, velocity-loop integral gain, 1/s.
    pub velocity_integral_gain: f64,
    /// τ_v of the velocity estimate `s/(τ_v s + 1)`, s.
    pub velocity_filter_time_constant: f64,
}

impl Default for PPiParams {
    fn default() -> Self {
        Self {
            joint: "table".into(),
            mass_estimate: 11.0,
            damping_estimate: 255.0,
            position_gain: 30.0,
            velocity_gain: 50.0,
            velocity_integral_gain: 0.5,
            velocity_filter_time_constant: 1e-3,
        }
    }
}

/// Gains produced by [`design`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PPiGains {
    /// m̂, N per m/s².
    pub mass_feedforward: f64,
    /// b̂, N per m/s.
    pub damping_feedforward: f64,
    /// K_v, 1/s.
    pub position_gain: f64,
    /// K_p, N per m/s.
    pub velocity_gain: f64,
    /// K_p·K_i, N per m (rate of F̂_d per unit β).
    pub integral_gain: f64,
}

/// Checks the parameters and the nominal loop's stability, and returns the gains.
pub fn design(params: &PPiParams) -> Result<PPiGains, ControllerError> {
    let mass = positive(NAME, "mass_estimate", params.mass_estimate)?;
    let kv = positive(NAME, "position_gain", params.position_gain)?;
    let kp = positive(NAME, "velocity_gain", params.velocity_gain)?;
    positive(
        NAME,
        "velocity_filter_time_constant",
        params.velocity_filter_time_constant,
    )?;
    let damping = non_negative(NAME, "damping_estimate", params.damping_estimate)?;
    let ki = non_negative(
        NAME,
        "velocity_integral_gain",
        params.velocity_integral_gain,
    )?;
    // All finite by now, so the comparison is decided.
    if kp * (kv + ki) <= mass * kv * ki {
        return Err(ControllerError::parameter(
            NAME,
            "velocity_gain",
            kp,
            format!(
                "must be large enough that velocity_gain·(position_gain + velocity_integral_gain) \
                 = {} exceeds mass_estimate·position_gain·velocity_integral_gain = {} for a \
                 stable loop",
                kp * (kv + ki),
                mass * kv * ki
            ),
        ));
    }
    Ok(PPiGains {
        mass_feedforward: mass,
        damping_feedforward: damping,
        position_gain: kv,
        velocity_gain: kp,
        integral_gain: kp * ki,
    })
}

/// The running P-PI law, with the integral frozen while the force is clipped (anti-windup).
pub struct PPi {
    params: PPiParams,
    gains: PPiGains,
    axis: Option<FeedAxis>,
    velocity_estimate: FirstOrderFilter,
    position_error: f64,
    beta: f64,
    disturbance_compensation: f64,
    damping_compensation: f64,
    force_command: f64,
}

impl PPi {
    /// Designs the gains and the velocity estimate; errors name the parameter at fault.
    pub fn new(params: PPiParams) -> Result<Self, ControllerError> {
        let gains = design(&params)?;
        let velocity_estimate = FirstOrderFilter::derivative(params.velocity_filter_time_constant)
            .map_err(|e| e.for_parameter(NAME, "velocity_filter_time_constant"))?;
        Ok(Self {
            params,
            gains,
            axis: None,
            velocity_estimate,
            position_error: 0.0,
            beta: 0.0,
            disturbance_compensation: 0.0,
            damping_compensation: 0.0,
            force_command: 0.0,
        })
    }
}

pub(crate) fn entry() -> Entry {
    Entry {
        name: NAME,
        machine: "feed_axis",
        summary: "P-PI position-velocity cascade with mass and damping feed-forward (linear-motor feed axis)",
        build: |table| Ok(Box::new(PPi::new(parse_params(NAME, table)?)?)),
    }
}

impl Controller for PPi {
    fn name(&self) -> &str {
        NAME
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        self.axis = Some(FeedAxis::bind(plant, &self.params.joint)?);
        self.velocity_estimate.reset();
        self.position_error = 0.0;
        self.beta = 0.0;
        self.disturbance_compensation = 0.0;
        self.damping_compensation = 0.0;
        self.force_command = 0.0;
        Ok(())
    }

    fn update(&mut self, measurement: &Measurement, period: f64, efforts: &mut [f64]) {
        let Some(axis) = &self.axis else {
            return;
        };
        let sample = axis.sample(measurement);
        let g = self.gains;
        let table_velocity = self.velocity_estimate.update(sample.table_position, period);
        self.position_error = sample.reference - sample.table_position;
        self.beta =
            g.position_gain * self.position_error + (sample.reference_rate - table_velocity);
        self.damping_compensation = g.damping_feedforward * table_velocity;
        let force = |integral: f64| {
            g.mass_feedforward * sample.reference_acceleration
                + g.velocity_gain * self.beta
                + integral
                + self.damping_compensation
        };
        let candidate = self.disturbance_compensation + g.integral_gain * self.beta * period;
        let limit = axis.effort_limit();
        if force(candidate).abs() <= limit {
            self.disturbance_compensation = candidate;
        }
        self.force_command = force(self.disturbance_compensation).clamp(-limit, limit);
        efforts[axis.actuator()] = self.force_command;
    }

    fn internals(&self) -> Vec<SignalSpec> {
        vec![
            SignalSpec::new("position_error", Unit::Micrometre, "table position error"),
            SignalSpec::new(
                "velocity_estimate",
                Unit::MicrometrePerSecond,
                "table velocity",
            ),
            SignalSpec::new("beta", Unit::MicrometrePerSecond, "table velocity"),
            SignalSpec::new("disturbance_compensation", Unit::Newton, "force terms"),
            SignalSpec::new("damping_compensation", Unit::Newton, "force terms"),
            SignalSpec::new("force_command", Unit::Newton, "force terms"),
        ]
    }

    fn internal_values(&self, values: &mut [f64]) {
        values.copy_from_slice(&[
            self.position_error,
            self.velocity_estimate.output(),
            self.beta,
            self.disturbance_compensation,
            self.damping_compensation,
            self.force_command,
        ]);
    }
}

/// A linear-motor feed axis integrated inside the tests: the paper's plant (m = 10 kg,
/// b = 250 N·s/m), its sine reference, optionally the micro-milling cut, run under a controller.
#[cfg(test)]
pub(crate) mod test_rig {
    use framework::{Actuator, Controller, EffortKind, Measurement, PlantInterface};
    use models::feed_axis::micromilling::MicroMillingCut;
    use models::reference::Reference;

    const TABLE_MASS: f64 = 10.0;
    const GUIDE_DAMPING: f64 = 250.0;
    const SUBSTEPS: usize = 10;

    pub(crate) struct Rig {
        pub reference: Reference,
        pub cut: Option<MicroMillingCut>,
        /// A further force on the table, N, against time.
        pub load: fn(f64) -> f64,
        /// Encoder resolution, m; 0 for an exact position.
        pub resolution: f64,
        pub period: f64,
        pub duration: f64,
        pub effort_limit: f64,
    }

    impl Default for Rig {
        /// The paper's §V run: 1 µm at 3 rad/s for two reference periods, 10 kHz control.
        fn default() -> Self {
            Self {
                reference: Reference::Sine {
                    offset: 0.0,
                    amplitude: 1e-6,
                    angular_frequency: 3.0,
                    phase: 0.0,
                },
                cut: None,
                load: |_| 0.0,
                resolution: 0.0,
                period: 1e-4,
                duration: 4.0 * std::f64::consts::PI / 3.0,
                effort_limit: 200.0,
            }
        }
    }

    /// Table I's columns (m, m/s), the steady state over the last reference period and the
    /// position error at every period.
    #[derive(Debug, Clone)]
    pub(crate) struct Tracking {
        pub position_max: f64,
        pub position_sigma: f64,
        pub velocity_max: f64,
        pub velocity_sigma: f64,
        pub late_position_max: f64,
        pub force_max: f64,
        pub period: f64,
        pub position_errors: Vec<f64>,
    }

    impl Tracking {
        /// Largest |position error| from `time` on, m.
        pub(crate) fn position_max_after(&self, time: f64) -> f64 {
            let first = (time / self.period).ceil() as usize;
            self.position_errors
                .iter()
                .skip(first)
                .fold(0.0, |m, e| m.max(e.abs()))
        }
    }

    impl std::fmt::Display for Tracking {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            write!(
                f,
                "position error max {:.4} µm σ {:.4} µm | velocity error max {:.4} µm/s σ {:.4} µm/s \
                 | last period max {:.4} µm | |F| max {:.3e} N",
                self.position_max * 1e6,
                self.position_sigma * 1e6,
                self.velocity_max * 1e6,
                self.velocity_sigma * 1e6,
                self.late_position_max * 1e6,
                self.force_max
            )
        }
    }

    pub(crate) fn plant(effort_limit: f64) -> PlantInterface {
        PlantInterface {
            machine: "linear-motor-axis".into(),
            signals: [
                "table.position",
                "reference",
                "reference_rate",
                "reference_acceleration",
            ]
            .map(String::from)
            .to_vec(),
            actuators: vec![Actuator {
                joint: "table".into(),
                kind: EffortKind::Force,
                effort_limit,
            }],
            ..Default::default()
        }
    }

    fn sigma(values: &[f64]) -> f64 {
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / values.len() as f64).sqrt()
    }

    /// Runs `controller` on the rig from rest at x = 0 and reports the tracking.
    pub(crate) fn run(rig: &Rig, controller: &mut dyn Controller) -> Tracking {
        controller.reset(&plant(rig.effort_limit)).unwrap();
        let acceleration = |t: f64, velocity: f64, force: f64| {
            let cutting = rig
                .cut
                .as_ref()
                .map_or(0.0, |c| c.force_on_axis(t, velocity));
            (force + cutting + (rig.load)(t) - GUIDE_DAMPING * velocity) / TABLE_MASS
        };
        let (mut position, mut velocity) = (0.0_f64, 0.0_f64);
        let steps = (rig.duration / rig.period).round() as usize;
        let late_from = rig.duration
            - match rig.reference {
                Reference::Sine {
                    angular_frequency, ..
                } => std::f64::consts::TAU / angular_frequency,
                _ => rig.duration / 2.0,
            };
        let (mut position_errors, mut velocity_errors) = (Vec::new(), Vec::new());
        let (mut late_position_max, mut force_max) = (0.0_f64, 0.0_f64);
        let mut effort = [0.0];
        for step in 0..steps {
            let time = step as f64 * rig.period;
            let reference = rig.reference.sample(time);
            let measured = if rig.resolution > 0.0 {
                (position / rig.resolution).round() * rig.resolution
            } else {
                position
            };
            let signals = [
                measured,
                reference.position,
                reference.rate,
                reference.acceleration,
            ];
            effort[0] = 0.0;
            controller.update(
                &Measurement {
                    time,
                    signals: &signals,
                },
                rig.period,
                &mut effort,
            );
            let force = effort[0];
            force_max = force_max.max(force.abs());
            position_errors.push(reference.position - position);
            velocity_errors.push(reference.rate - velocity);
            if time >= late_from {
                late_position_max = late_position_max.max((reference.position - position).abs());
            }
            // Classical Runge–Kutta under the held force.
            let h = rig.period / SUBSTEPS as f64;
            for sub in 0..SUBSTEPS {
                let t = time + sub as f64 * h;
                let k1 = (velocity, acceleration(t, velocity, force));
                let v2 = velocity + 0.5 * h * k1.1;
                let k2 = (v2, acceleration(t + 0.5 * h, v2, force));
                let v3 = velocity + 0.5 * h * k2.1;
                let k3 = (v3, acceleration(t + 0.5 * h, v3, force));
                let v4 = velocity + h * k3.1;
                let k4 = (v4, acceleration(t + h, v4, force));
                position += h / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0);
                velocity += h / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1);
            }
        }
        let max_abs = |values: &[f64]| values.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        Tracking {
            position_max: max_abs(&position_errors),
            position_sigma: sigma(&position_errors),
            velocity_max: max_abs(&velocity_errors),
            velocity_sigma: sigma(&velocity_errors),
            late_position_max,
            force_max,
            period: rig.period,
            position_errors,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::test_rig::{plant, run, Rig};
    use super::*;
    use models::feed_axis::micromilling::{MicroMillingCut, MicroMillingParams};

    #[test]
    fn paper_gains_are_accepted_and_stable() {
        let gains = design(&PPiParams::default()).unwrap();
        assert_eq!(gains.integral_gain, 25.0);
    }

    #[test]
    fn tracks_the_paper_sine() {
        let mut controller = PPi::new(PPiParams::default()).unwrap();
        let tracking = run(&Rig::default(), &mut controller);
        println!("p-pi without cut: {tracking}");
        // Start from rest against a 3 µm/s reference rate: a lightly damped transient of a few
        // tenths of a micrometre, then tracking to within a few nanometres.
        assert!(tracking.position_max < 0.3e-6, "{tracking}");
        assert!(tracking.position_max > 0.05e-6, "{tracking}");
        assert!(tracking.late_position_max < 0.02e-6, "{tracking}");
        assert!((tracking.velocity_max - 3e-6).abs() < 1e-9, "{tracking}");
    }

    #[test]
    fn tracks_the_sine_under_the_micromilling_cut() {
        let mut controller = PPi::new(PPiParams::default()).unwrap();
        let rig = Rig {
            cut: Some(MicroMillingCut::new(MicroMillingParams::default()).unwrap()),
            ..Default::default()
        };
        let cut = run(&rig, &mut controller);
        let clean = run(&Rig::default(), &mut controller);
        println!("p-pi with cut: {cut}");
        // The cut's drag (~195 N·s/m) is uncompensated by the feed-forward: the slow P-PI loop
        // lets it through as a visible, bounded error.
        assert!(
            cut.position_sigma > clean.position_sigma,
            "{cut} vs {clean}"
        );
        assert!(cut.position_max < 0.6e-6, "{cut}");
        assert!(cut.late_position_max < 0.5e-6, "{cut}");
    }

    #[test]
    fn runs_on_a_quantised_encoder() {
        let mut controller = PPi::new(PPiParams::default()).unwrap();
        let rig = Rig {
            resolution: 1e-9,
            ..Default::default()
        };
        let tracking = run(&rig, &mut controller);
        println!("p-pi, 1 nm encoder: {tracking}");
        assert!(tracking.late_position_max < 0.03e-6, "{tracking}");
    }

    #[test]
    fn clips_without_winding_up() {
        let mut controller = PPi::new(PPiParams::default()).unwrap();
        controller.reset(&plant(1e-6)).unwrap();
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
        assert_eq!(effort[0], 1e-6);
        let mut values = [0.0; 6];
        controller.internal_values(&mut values);
        assert_eq!(values[3], 0.0, "integral must not wind up while clipped");
    }

    #[test]
    fn bad_parameters_are_named_with_their_value() {
        let build = |key: &str, value: f64| {
            let mut table = toml::Table::new();
            table.insert(key.into(), toml::Value::Float(value));
            framework::Registry::with([super::entry()])
                .build(NAME, "feed_axis", &table)
                .err()
                .unwrap()
        };
        for (key, value, shown, reason) in [
            ("mass_estimate", 0.0, "0", "must be > 0"),
            ("position_gain", -1.0, "-1", "must be > 0"),
            ("velocity_integral_gain", -0.1, "-0.1", "must be ≥ 0"),
            ("damping_estimate", -1.0, "-1", "must be ≥ 0"),
            ("velocity_filter_time_constant", 0.0, "0", "must be > 0"),
            ("velocity_gain", f64::NAN, "NaN", "must be a finite number"),
        ] {
            assert_eq!(
                build(key, value),
                ControllerError::BadParameter {
                    controller: NAME.into(),
                    key: key.into(),
                    value: Some(shown.into()),
                    reason: reason.into(),
                }
            );
        }
        assert_eq!(
            build("mass_estimate", -1.0).to_string(),
            "controller `p-pi`: params.mass_estimate = -1: must be > 0"
        );
        let err = build("gain", 1.0);
        assert!(
            matches!(&err, ControllerError::BadParameter { key, .. } if key == "gain"),
            "{err}"
        );
    }

    /// A slow velocity loop with a strong integral: unstable once m̂·K_v·K_i ≥ K_p(K_v + K_i).
    #[test]
    fn an_unstable_gain_set_names_the_velocity_gain() {
        let err = design(&PPiParams {
            velocity_gain: 5.0,
            velocity_integral_gain: 20.0,
            ..Default::default()
        })
        .unwrap_err();
        assert!(
            matches!(
                &err,
                ControllerError::BadParameter { key, value: Some(value), reason, .. }
                    if key == "velocity_gain" && value == "5" && reason.contains("stable loop")
            ),
            "{err}"
        );
    }

    #[test]
    fn needs_a_prismatic_table_and_the_references() {
        let mut controller = PPi::new(PPiParams::default()).unwrap();
        let mut interface = plant(10.0);
        interface.signals.retain(|s| s != "reference_rate");
        let err = controller.reset(&interface).unwrap_err();
        assert!(err.to_string().contains("reference_rate"), "{err}");
        let mut interface = plant(10.0);
        interface.actuators[0].kind = EffortKind::Torque;
        let err = controller.reset(&interface).unwrap_err();
        assert!(
            matches!(
                err,
                ControllerError::WrongEffort { ref joint, expected: EffortKind::Force, .. }
                    if joint == "table"
            ),
            "{err}"
        );
    }
}
