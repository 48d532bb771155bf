//! A DC servo drive: permanent-magnet DC motor behind a gearbox, fed by an amplifier with a PI
//! current loop whose current command is clipped to the motor's protection limit — the drive
//! structure Ilyukhin, Poduraev & Tatarintseva (DAAAM 2014, §1) assume for every robot axis and
//! for the tool spindle.
//!
//! # Model (SI units)
//!
//! Motor side: `L·di/dt = u − R·i − k_e·ω_m`, torque `k_t·i`; gearbox of ratio `G` (motor turns
//! per joint turn), ideal (no losses, no backlash): `ω_m = G·ω_joint`, joint torque `G·k_t·i`. The
//! rotor's own inertia is not modelled here: it belongs to the link inertia of the mechanism
//! (for a direct-drive spindle it is part of the cutter link).
//!
//! Amplifier: the current command `i*` is clipped to `±current_limit`; a PI current loop sampled
//! every `current_loop_period` sets the winding voltage `u = K_p·(i* − i) + K_i·∫(i* − i)`,
//! clipped to the supply voltage (the integrator stops while clipped). The PI is designed by
//! pole–zero cancellation of the winding: `K_p = L·ω_c`, `K_i = R·ω_c`, giving the closed current
//! loop `1/(s/ω_c + 1)` when the voltage is not clipped. Between samples the voltage is held and
//! the winding's linear equation is solved exactly (the electrical time constant `L/R` is far
//! shorter than a physics step, so an explicit step would be unstable).

use serde::Deserialize;
use thiserror::Error;

/// One drive's data sheet (SI units: N·m/A, V·s/rad, Ω, H, V, A, rad/s, s).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DriveParams {
    /// Motor torque constant k_t, N·m/A.
    pub torque_constant: f64,
    /// Back-EMF constant k_e, V·s/rad (equal to k_t in SI for an ideal machine).
    pub back_emf_constant: f64,
    /// Winding resistance R, Ω.
    pub resistance: f64,
    /// Winding inductance L, H.
    pub inductance: f64,
    /// Gear ratio G, motor turns per joint turn (1 for a direct drive).
    pub gear_ratio: f64,
    /// Amplifier supply: largest |winding voltage|, V.
    pub supply_voltage: f64,
    /// Motor protection: the current command is clipped to ±this, A.
    pub current_limit: f64,
    /// Closed current-loop bandwidth ω_c, rad/s.
    pub current_bandwidth: f64,
    /// Sampling period of the current loop, s.
    pub current_loop_period: f64,
}

/// Why a drive's data sheet is rejected.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum DriveError {
    /// A [`DriveParams`] field is zero, negative or not finite.
    #[error("drive: {name} must be finite and > 0 (got {value})")]
    NotPositive {
        /// The field's name.
        name: &'static str,
        /// The rejected value, in the field's SI unit.
        value: f64,
    },
    /// The current-loop bandwidth reaches the Nyquist frequency π/T of the loop's sampling.
    #[error(
        "drive: the current loop's bandwidth ({bandwidth} rad/s) must be below the Nyquist \
         frequency of its sampling (π/{period} s)"
    )]
    BandwidthTooHigh {
        /// Closed current-loop bandwidth ω_c, rad/s.
        bandwidth: f64,
        /// Current-loop sampling period T, s.
        period: f64,
    },
}

impl DriveParams {
    /// Checks every field is positive and the current loop's bandwidth is below its Nyquist
    /// frequency.
    pub fn validate(&self) -> Result<(), DriveError> {
        for (name, value) in [
            ("torque_constant", self.torque_constant),
            ("back_emf_constant", self.back_emf_constant),
            ("resistance", self.resistance),
            ("inductance", self.inductance),
            ("gear_ratio", self.gear_ratio),
            ("supply_voltage", self.supply_voltage),
            ("current_limit", self.current_limit),
            ("current_bandwidth", self.current_bandwidth),
            ("current_loop_period", self.current_loop_period),
        ] {
            if !(value > 0.0 && value.is_finite()) {
                return Err(DriveError::NotPositive { name, value });
            }
        }
        if self.current_bandwidth * self.current_loop_period >= std::f64::consts::PI {
            return Err(DriveError::BandwidthTooHigh {
                bandwidth: self.current_bandwidth,
                period: self.current_loop_period,
            });
        }
        Ok(())
    }

    /// Joint torque per ampere of winding current, `G·k_t`, N·m/A.
    pub fn torque_per_ampere(&self) -> f64 {
        self.gear_ratio * self.torque_constant
    }

    /// Largest joint torque the drive delivers, at the current limit, N·m.
    pub fn peak_torque(&self) -> f64 {
        self.torque_per_ampere() * self.current_limit
    }
}

/// A running drive: winding current and the current loop's integrator.
#[derive(Debug, Clone, PartialEq)]
pub struct Drive {
    params: DriveParams,
    current: f64,
    /// ∫(i* − i) dt, A·s.
    integral: f64,
    /// The last current command after the protection clip, A.
    command: f64,
    /// Whether the last command was clipped.
    limited: bool,
    /// The current loop over the last step length while unclipped, made once per length.
    span: Option<LinearSpan>,
}

/// One step of the sampled current loop while no sample's voltage reaches the supply: the loop
/// and the winding are then linear in z = (i₀, ∫₀, i*, k_e·G·ω) (the command and the back-EMF
/// held over the step), so each sample's voltage, the end state and the step's charge ∫i dt are
/// fixed rows of coefficients on z. Stepping by them gives the sampled loop's result to rounding,
/// with no sample waiting on the one before.
#[derive(Debug, Clone, PartialEq)]
struct LinearSpan {
    /// The step length the rows are for, s.
    dt: f64,
    /// Each sample's winding voltage, V.
    voltages: Vec<[f64; 4]>,
    /// The current (A), integral (A·s) and charge (A·s) at the step's end.
    current: [f64; 4],
    integral: [f64; 4],
    charge: [f64; 4],
}

/// Above this many samples a step the sampled loop is stepped sample by sample.
const LINEAR_SPAN_SAMPLES: f64 = 64.0;

impl LinearSpan {
    /// The rows for `samples` intervals of `h`, from the drive's data sheet.
    fn new(p: &DriveParams, dt: f64, samples: usize, h: f64) -> Self {
        let Sampling {
            kp,
            ki,
            decay,
            mean_of_transient,
        } = Sampling::of(p, h);
        let combine = |a: [f64; 4], x: f64, b: [f64; 4], y: f64| -> [f64; 4] {
            std::array::from_fn(|n| a[n] * x + b[n] * y)
        };
        let (command, back_emf) = ([0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]);
        let (mut current, mut integral) = ([1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]);
        let mut charge = [0.0; 4];
        let mut voltages = Vec::with_capacity(samples);
        for _ in 0..samples {
            // u = (K_p + K_i·h)·(i* − i) + K_i·∫, the integral taking this sample's error.
            let error = combine(command, 1.0, current, -1.0);
            let voltage = combine(error, kp + ki * h, integral, ki);
            voltages.push(voltage);
            let steady = combine(voltage, 1.0 / p.resistance, back_emf, -1.0 / p.resistance);
            let transient = combine(current, 1.0, steady, -1.0);
            let mean = combine(steady, 1.0, transient, mean_of_transient);
            charge = combine(charge, 1.0, mean, h);
            integral = combine(integral, 1.0, error, h);
            current = combine(steady, 1.0, transient, decay);
        }
        Self {
            dt,
            voltages,
            current,
            integral,
            charge,
        }
    }
}

/// The current loop sampled every `h`: its PI gains and, over one interval with the voltage
/// held, the winding's decay and its transient's mean.
struct Sampling {
    /// K_p = L·ω_c, V/A.
    kp: f64,
    /// K_i = R·ω_c, V/(A·s).
    ki: f64,
    /// e^(−h·R/L).
    decay: f64,
    /// ∫ of s + (i₀ − s)·e^(−t·R/L) over one interval h, per unit h, of (i₀ − s).
    mean_of_transient: f64,
}

impl Sampling {
    fn of(p: &DriveParams, h: f64) -> Self {
        let decay = (-h * p.resistance / p.inductance).exp();
        Self {
            kp: p.inductance * p.current_bandwidth,
            ki: p.resistance * p.current_bandwidth,
            decay,
            mean_of_transient: (1.0 - decay) * p.inductance / (p.resistance * h),
        }
    }
}

fn dot(row: &[f64; 4], z: &[f64; 4]) -> f64 {
    row[0] * z[0] + row[1] * z[1] + row[2] * z[2] + row[3] * z[3]
}

impl Drive {
    /// Checks the data sheet; the drive starts with no current and an empty integrator.
    pub fn new(params: DriveParams) -> Result<Self, DriveError> {
        params.validate()?;
        Ok(Self {
            params,
            current: 0.0,
            integral: 0.0,
            command: 0.0,
            limited: false,
            span: None,
        })
    }

    /// The data sheet the drive was built from.
    pub fn params(&self) -> &DriveParams {
        &self.params
    }

    /// Winding current, A.
    pub fn current(&self) -> f64 {
        self.current
    }

    /// Joint torque the motor delivers now, N·m.
    pub fn torque(&self) -> f64 {
        self.params.torque_per_ampere() * self.current
    }

    /// The current command after the protection clip, A.
    pub fn command(&self) -> f64 {
        self.command
    }

    /// Whether the last command was clipped at the current limit.
    pub fn at_limit(&self) -> bool {
        self.limited
    }

    /// Advances the drive by `dt` (s) with the current command `command` (A, held over the step)
    /// and the joint turning at `joint_speed` (rad/s, held); returns the joint torque **averaged
    /// over the step**, N·m: `G·k_t·(1/dt)·∫i dt`, the exact impulse of the winding current (each
    /// current-loop interval solved in closed form). The physics holds this torque over the step,
    /// so it must be the step's mean: the end-of-step value [`Drive::torque`] would apply the
    /// current the loop reaches only at the step's end over all of it, dropping the current
    /// loop's lag — at a 1 ms step with the 2000 rad/s loop that triples the drive's gain at the
    /// control Nyquist frequency (0.76 instead of 0.24) and so amplified the arm servos' chatter
    /// at the stretched start pose (`arm-milling`, first 0.8 s; the servo's own margin there is
    /// a separate matter, see `controllers/src/arm/servo.rs`).
    ///
    /// While no sample's voltage reaches the supply the step's samples are taken together, by
    /// their linear span (its rows made once per step length); otherwise one by one.
    pub fn step(&mut self, dt: f64, command: f64, joint_speed: f64) -> f64 {
        let p = self.params;
        let limit = p.current_limit;
        self.command = if command.is_nan() {
            0.0
        } else {
            command.clamp(-limit, limit)
        };
        self.limited = command.abs() >= limit;
        if !(dt > 0.0 && dt.is_finite()) {
            return self.torque();
        }
        let samples = (dt / p.current_loop_period - 1e-9).ceil().max(1.0);
        let h = dt / samples;
        let back_emf = p.back_emf_constant * p.gear_ratio * joint_speed;
        let charge = match self.linear_step(dt, samples, h, back_emf) {
            Some(charge) => charge,
            None => self.sampled_step(samples as usize, h, back_emf),
        };
        p.torque_per_ampere() * charge / dt
    }

    /// The step by the [`LinearSpan`] of its length, if no sample's voltage reaches the supply;
    /// returns the step's charge ∫i dt (A·s).
    fn linear_step(&mut self, dt: f64, samples: f64, h: f64, back_emf: f64) -> Option<f64> {
        if samples > LINEAR_SPAN_SAMPLES {
            return None;
        }
        let params = self.params;
        let span = match &mut self.span {
            Some(span) if span.dt == dt => span,
            slot => slot.insert(LinearSpan::new(&params, dt, samples as usize, h)),
        };
        let z = [self.current, self.integral, self.command, back_emf];
        let supply = params.supply_voltage;
        if !span.voltages.iter().all(|row| dot(row, &z).abs() <= supply) {
            return None;
        }
        self.current = dot(&span.current, &z);
        self.integral = dot(&span.integral, &z);
        Some(dot(&span.charge, &z))
    }

    /// The step sample by sample, the voltage clipped to the supply and the integrator stopped
    /// while it is; returns the step's charge ∫i dt (A·s).
    fn sampled_step(&mut self, samples: usize, h: f64, back_emf: f64) -> f64 {
        let p = self.params;
        let Sampling {
            kp,
            ki,
            decay,
            mean_of_transient,
        } = Sampling::of(&p, h);
        let mut charge = 0.0;
        for _ in 0..samples {
            let error = self.command - self.current;
            let candidate = self.integral + error * h;
            let unclipped = kp * error + ki * candidate;
            if unclipped.abs() <= p.supply_voltage {
                self.integral = candidate;
            }
            let voltage =
                (kp * error + ki * self.integral).clamp(-p.supply_voltage, p.supply_voltage);
            let steady = (voltage - back_emf) / p.resistance;
            charge += (steady + (self.current - steady) * mean_of_transient) * h;
            self.current = steady + (self.current - steady) * decay;
        }
        charge
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> DriveParams {
        DriveParams {
            torque_constant: 0.035,
            back_emf_constant: 0.035,
            resistance: 0.3,
            inductance: 0.5e-3,
            gear_ratio: 120.0,
            supply_voltage: 48.0,
            current_limit: 20.0,
            current_bandwidth: 2000.0,
            current_loop_period: 1e-4,
        }
    }

    #[test]
    fn current_loop_follows_a_step_at_its_bandwidth() {
        let mut drive = Drive::new(params()).unwrap();
        // One time constant 1/ω_c = 0.5 ms after a 10 A step: 1 − e⁻¹ of it.
        for _ in 0..5 {
            drive.step(1e-4, 10.0, 0.0);
        }
        let expected = 10.0 * (1.0 - (-1.0f64).exp());
        // Within the sampled loop's accuracy (ω_c·T = 0.2).
        assert!(
            (drive.current() - expected).abs() < 0.6,
            "{}",
            drive.current()
        );
        for _ in 0..200 {
            drive.step(1e-3, 10.0, 0.0);
        }
        assert!((drive.current() - 10.0).abs() < 1e-9);
        assert!((drive.torque() - 10.0 * 120.0 * 0.035).abs() < 1e-6);
    }

    #[test]
    fn step_returns_the_mean_torque_over_the_step() {
        // From rest, a 10 A step over one 1 ms step: the current ends near 10 A, but the torque
        // the physics holds over the step is its mean (the impulse / dt), well below the end value.
        let mut drive = Drive::new(params()).unwrap();
        let mean = drive.step(1e-3, 10.0, 0.0);
        assert!(mean < 0.8 * drive.torque(), "{mean} vs {}", drive.torque());
        // The same step cut into its ten current-loop periods: the mean of their torques.
        let mut fine = Drive::new(params()).unwrap();
        let pieces: f64 = (0..10).map(|_| fine.step(1e-4, 10.0, 0.0)).sum::<f64>() / 10.0;
        assert!((mean - pieces).abs() < 1e-9 * mean, "{mean} vs {pieces}");
        // In steady state the mean is the end value.
        for _ in 0..100 {
            drive.step(1e-3, 10.0, 0.0);
        }
        assert!((drive.step(1e-3, 10.0, 0.0) - drive.torque()).abs() < 1e-9);
    }

    /// Steps taken together by the linear span give the sample-by-sample loop's current,
    /// integral and torque to rounding, through commands that reach the supply (where the span
    /// steps aside) and ones that do not.
    #[test]
    fn the_linear_span_is_the_sampled_loop() {
        let mut spanned = Drive::new(params()).unwrap();
        let mut sampled = spanned.clone();
        let close = |a: f64, b: f64, scale: f64| (a - b).abs() <= 1e-12 * b.abs().max(scale);
        let mut together = 0;
        for k in 0..400 {
            let t = k as f64 * 1e-3;
            let command = 12.0 * (7.0 * t).sin() + if k % 50 < 3 { 30.0 } else { 0.0 };
            let speed = 10.5 * (2.0 * t).cos();
            let back_emf = 0.035 * 120.0 * speed;
            let start = [
                spanned.current,
                spanned.integral,
                command.clamp(-20.0, 20.0),
                back_emf,
            ];
            together += usize::from(spanned.span.as_ref().is_some_and(|span| {
                span.voltages
                    .iter()
                    .all(|row| dot(row, &start).abs() <= 48.0)
            }));
            let torque = spanned.step(1e-3, command, speed);
            sampled.command = command.clamp(-20.0, 20.0);
            let reference = 0.035 * 120.0 * sampled.sampled_step(10, 1e-4, back_emf) / 1e-3;
            assert!(
                close(torque, reference, 1.0),
                "{k}: {torque} vs {reference}"
            );
            assert!(close(spanned.current, sampled.current, 1.0), "{k}");
            assert!(close(spanned.integral, sampled.integral, 1e-3), "{k}");
        }
        // Most steps were taken together, and some (the 30 A bursts) one by one.
        assert!((300..399).contains(&together), "{together}");
    }

    #[test]
    fn integral_rejects_the_back_emf() {
        let mut drive = Drive::new(params()).unwrap();
        // 2 rad/s at the joint: 240 rad/s at the motor, 8.4 V of back-EMF.
        for _ in 0..300 {
            drive.step(1e-3, 5.0, 2.0);
        }
        assert!((drive.current() - 5.0).abs() < 1e-6, "{}", drive.current());
    }

    #[test]
    fn protection_clips_the_command() {
        let mut drive = Drive::new(params()).unwrap();
        for _ in 0..100 {
            drive.step(1e-3, -35.0, 0.0);
        }
        assert!(drive.at_limit());
        assert_eq!(drive.command(), -20.0);
        assert!((drive.current() + 20.0).abs() < 1e-6);
        assert!((drive.torque() + params().peak_torque()).abs() < 1e-4);
        drive.step(1e-3, 3.0, 0.0);
        assert!(!drive.at_limit());
    }

    #[test]
    fn supply_voltage_caps_the_speed() {
        // Against a back-EMF above the supply the current cannot be pushed the commanded way.
        let mut drive = Drive::new(params()).unwrap();
        let too_fast = 60.0 / (0.035 * 120.0); // 60 V of back-EMF
        for _ in 0..100 {
            drive.step(1e-3, 10.0, too_fast);
        }
        assert!(drive.current() < 0.0, "{}", drive.current());
    }

    #[test]
    fn rejects_bad_data() {
        let bad = |p: DriveParams| Drive::new(p).unwrap_err().to_string();
        assert!(bad(DriveParams {
            resistance: 0.0,
            ..params()
        })
        .contains("resistance"));
        assert!(bad(DriveParams {
            current_limit: -1.0,
            ..params()
        })
        .contains("current_limit"));
        assert!(bad(DriveParams {
            current_bandwidth: 40_000.0,
            ..params()
        })
        .contains("Nyquist"));
    }
}
