//! `output-feedback-force`: the parallel lathe's power loop (Sudhakara & Landers, ACC 2003) with
//! the drives it needs, all acting through joint efforts.
//!
//! Three loops, outermost first:
//! - **Power loop**, Sudhakara eqs (9), (18)–(20): f_ci = sat(f_ni − h_i (P − P_max)), 0 ≤ f_ci ≤
//!   f_max, on the measured spindle power P. H comes from [`output_feedback_design::design`]
//!   (Sudhakara eqs (12)–(14))
//!   for the time constants m_1, m_2, or is given directly.
//! - **Feed servos**, Sudhakara eq (2): slide i must follow the slide speed v_ci = f_ci · n (n the
//!   measured spindle speed in rev/s) as f_i/f_ci = 1/(τ_i s + 1). On a slide of mass m driven by a
//!   force,
//!   m v̇ = u − F_i, the law u = k_p (b v_c − v) + k_i ∫(v_c − v) dt + F_i (the measured cutting
//!   force fed forward) with k_p = m (1/τ + p), k_i = m p / τ and set-point weight b = 1/(1 + p τ)
//!   places the poles at −1/τ and −p and cancels −p with the zero of b k_p s + k_i, so that
//!   v/v_c = 1/(τ s + 1) exactly while the integrator removes what the feed-forward misses.
//! - **Spindle**: a PI on spindle speed at N_s (J ω̇ = T, poles of s² + 2ζω_n s + ω_n²:
//!   k_p = 2ζω_n J, k_i = ω_n² J) plus the cutting torque P/ω fed forward.
//!
//! The start: the slides wait until the spindle is within 1 % of N_s, then approach at the feeds
//! that make Sudhakara eq (1) give `initial_forces` (Sudhakara eq (6) inverted). Each tool meets
//! the part at that feed and so starts cutting at its initial force; once both tools cut the power
//! loop closes. The reduced model of Sudhakara eq (17) started at those forces is what the run is
//! compared with.

use super::output_feedback_design::{
    self, Consistency, DesignError, DesignSpec, GlobalStabilityCheck,
};
use crate::check::{finite, positive};
use framework::{parse_params, Entry};
use framework::{Controller, ControllerError, Measurement, PlantInterface, SignalSpec, Unit};
use framework::{Event, EventKind};
use models::lathe::{Lathe, LatheParams, TOOLS};
use serde::Deserialize;
use std::f64::consts::TAU;

const NAME: &str = "output-feedback-force";
const SLIDES: [&str; TOOLS] = ["slide_1", "slide_2"];
const SPINDLE: &str = "spindle";
/// A tool counts as cutting above this measured force, N.
const CUTTING_FORCE_THRESHOLD: f64 = 1.0;
/// The slides start once the spindle speed is within this fraction of N_s.
const AT_SPEED_TOLERANCE: f64 = 0.01;
/// Below this spindle speed (rad/s) the cutting torque is not fed forward (P/ω is undefined).
const FEED_FORWARD_MIN_SPEED: f64 = 1.0;

/// Parameters of `output-feedback-force` (SI units).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LatheForceParams {
    /// The controller's model of the lathe (Table 1 by default): cutting law, servo time
    /// constants τ_i, N_s, P_max and the feed limit f_max.
    pub lathe: LatheParams,
    /// m_1, m_2: design time constants of Sudhakara eq (12), s.
    pub time_constants: [f64; TOOLS],
    /// Theorem 1's consistency: `report` keeps the design when it fails (as Table 1's does).
    pub consistency: Consistency,
    /// H = (h_1, h_2), m/(rev·W) (1 mm/kW = 1e-6 m/(rev·W)); given, it replaces the design.
    pub power_gains: Option<[f64; TOOLS]>,
    /// Forces the tools meet the part with, N; default the reference forces of Sudhakara eq (5).
    pub initial_forces: Option<[f64; TOOLS]>,
    /// Slide masses the feed servos are designed for, as seen along the feed (carriage plus the
    /// drive's reflected rotor and screw), kg.
    pub slide_masses: [f64; TOOLS],
    /// p, the feed servos' cancelled fast pole, rad/s.
    pub servo_fast_pole: f64,
    /// Spindle inertia (chuck + part) the speed loop is designed for, kg·m².
    pub spindle_inertia: f64,
    /// ω_n of the spindle speed loop, rad/s.
    pub spindle_bandwidth: f64,
    /// ζ of the spindle speed loop.
    pub spindle_damping_ratio: f64,
}

impl Default for LatheForceParams {
    /// Table 1 with the paper's globally stable design m = 0.5 / 0.49 s (Figs 4, 6). Table 1's
    /// design fails Theorem 1's consistency, so reproducing the paper needs `report`.
    fn default() -> Self {
        Self {
            lathe: LatheParams::default(),
            time_constants: [0.5, 0.49],
            consistency: Consistency::Report,
            power_gains: None,
            initial_forces: None,
            slide_masses: [200.0, 200.0],
            servo_fast_pole: 100.0,
            spindle_inertia: 0.08,
            spindle_bandwidth: 50.0,
            spindle_damping_ratio: 1.0,
        }
    }
}

/// One feed servo's velocity-loop gains.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeedServoGains {
    /// N per m/s.
    pub kp: f64,
    /// N per m.
    pub ki: f64,
    /// Set-point weight b of the proportional term.
    pub setpoint_weight: f64,
}

/// Everything [`design`] works out before a run.
#[derive(Debug, Clone, PartialEq)]
pub struct LatheForceDesign {
    /// The controller's model of the lathe, built from [`LatheForceParams::lathe`].
    pub lathe: Lathe,
    /// H, m/(rev·W).
    pub power_gains: [f64; TOOLS],
    /// The output-feedback design behind H (None when H was given).
    pub output_feedback: Option<output_feedback_design::OutputFeedbackDesign>,
    /// Sudhakara eq (23) for H.
    pub global_stability: GlobalStabilityCheck,
    /// Approach feeds, m/rev.
    pub approach_feeds: [f64; TOOLS],
    /// Velocity-loop gains of each slide's feed servo.
    pub feed_servos: [FeedServoGains; TOOLS],
    /// Spindle PI: k_p = 2ζω_n J, N·m per rad/s.
    pub spindle_kp: f64,
    /// Spindle PI: k_i = ω_n² J, N·m per rad.
    pub spindle_ki: f64,
}

/// The lathe, H (Sudhakara eqs (12)–(14) or given), Sudhakara eq (23), the approach feeds and the
/// drive gains.
pub fn design(params: &LatheForceParams) -> Result<LatheForceDesign, ControllerError> {
    let lathe = Lathe::new(params.lathe).map_err(|e| {
        let message = e.to_string();
        let reason = message.strip_prefix("lathe: ").unwrap_or(&message);
        ControllerError::parameter_table(NAME, "lathe", reason)
    })?;
    let (power_gains, output_feedback) = match params.power_gains {
        Some(gains) => {
            for (i, h) in gains.iter().enumerate() {
                finite(NAME, &format!("power_gains.{i}"), *h)?;
            }
            (gains, None)
        }
        None => {
            let design = output_feedback(&lathe, params)?;
            (design.power_gains, Some(design))
        }
    };
    let approach_feeds = approach_feeds(&lathe, params.initial_forces)?;
    let p = positive(NAME, "servo_fast_pole", params.servo_fast_pole)?;
    let j = positive(NAME, "spindle_inertia", params.spindle_inertia)?;
    let wn = positive(NAME, "spindle_bandwidth", params.spindle_bandwidth)?;
    let zeta = positive(NAME, "spindle_damping_ratio", params.spindle_damping_ratio)?;
    let taus = lathe.feed_time_constants();
    let mut feed_servos = [FeedServoGains {
        kp: 0.0,
        ki: 0.0,
        setpoint_weight: 0.0,
    }; TOOLS];
    for i in 0..TOOLS {
        let m = positive(NAME, &format!("slide_masses.{i}"), params.slide_masses[i])?;
        let tau = taus[i];
        feed_servos[i] = FeedServoGains {
            kp: m * (1.0 / tau + p),
            ki: m * p / tau,
            setpoint_weight: 1.0 / (1.0 + p * tau),
        };
    }
    Ok(LatheForceDesign {
        global_stability: output_feedback_design::global_stability(&lathe, power_gains),
        lathe,
        power_gains,
        output_feedback,
        approach_feeds,
        feed_servos,
        spindle_kp: 2.0 * zeta * wn * j,
        spindle_ki: wn * wn * j,
    })
}

/// Sudhakara eqs (12)–(14) for the time constants m_1, m_2, with Theorem 1's consistency as asked.
fn output_feedback(
    lathe: &Lathe,
    params: &LatheForceParams,
) -> Result<output_feedback_design::OutputFeedbackDesign, ControllerError> {
    for (i, &m) in params.time_constants.iter().enumerate() {
        let key = format!("time_constants.{i}");
        if finite(NAME, &key, m)? <= 0.0 {
            let reason = format!("must be > 0 (m_{} of eq (12))", i + 1);
            return Err(ControllerError::parameter(NAME, key, m, reason));
        }
    }
    let spec = DesignSpec {
        time_constants: params.time_constants,
        consistency: params.consistency,
    };
    output_feedback_design::design(lathe, &spec).map_err(|e| match e {
        DesignError::NonPositiveTimeConstant { index, value } => ControllerError::parameter(
            NAME,
            format!("time_constants.{}", index - 1),
            value,
            "must be finite and > 0",
        ),
        DesignError::Inconsistent {
            residual,
            achieved_poles,
        } => ControllerError::parameter(
            NAME,
            "consistency",
            "\"require\"",
            format!(
                "must be \"report\" to keep the design for time_constants {:?}: K of eq (12) \
                 fails Theorem 1's consistency K C⁺ C = K (relative residual {residual:.3e}), so \
                 H = K C⁺ places the poles at {achieved_poles:?} instead of −1/m_i",
                params.time_constants
            ),
        ),
        DesignError::PseudoInverse(_) => {
            ControllerError::parameter_table(NAME, "lathe", e.to_string())
        }
    })
}

/// The feeds the tools approach the part with, m/rev: those that make Sudhakara eq (1) give
/// `initial_forces` (Sudhakara eq (6) inverted), by default the reference forces' nominal feeds.
fn approach_feeds(
    lathe: &Lathe,
    initial_forces: Option<[f64; TOOLS]>,
) -> Result<[f64; TOOLS], ControllerError> {
    let Some(forces) = initial_forces else {
        return Ok(lathe.nominal_feeds());
    };
    let max_feed = lathe.params().max_feed;
    let mut feeds = [0.0; TOOLS];
    for i in 0..TOOLS {
        let key = format!("initial_forces.{i}");
        let force = positive(NAME, &key, forces[i])?;
        let tool = lathe.params().tools[i];
        feeds[i] = tool.feed_for_force(lathe.cutting_speeds()[i], force);
        if feeds[i].is_nan() || feeds[i] > max_feed {
            return Err(ControllerError::parameter(
                NAME,
                key,
                force,
                format!(
                    "must be reachable within the {max_feed} m/rev feed limit (tool {} would \
                     need a feed of {:.4e} m/rev)",
                    i + 1,
                    feeds[i]
                ),
            ));
        }
    }
    Ok(feeds)
}

/// Where the run is: slides held, approaching the part, or cutting under the power loop.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    SpindleStart,
    Approach,
    PowerLoop,
}

/// Measured-signal and actuator indices, bound at reset.
#[derive(Debug, Clone, Copy, Default)]
struct Wiring {
    spindle_speed: usize,
    spindle_power: usize,
    slide_speeds: [usize; TOOLS],
    cutting_forces: [usize; TOOLS],
    spindle: usize,
    slides: [usize; TOOLS],
    spindle_limit: f64,
    slide_limits: [f64; TOOLS],
}

/// The running `output-feedback-force` controller: spindle speed loop, feed servos and, once
/// both tools cut, the power loop.
pub struct LatheForce {
    design: LatheForceDesign,
    wiring: Wiring,
    phase: Phase,
    spindle_integral: f64,
    slide_integrals: [f64; TOOLS],
    commanded_feeds: [f64; TOOLS],
    /// Which limit of Sudhakara eq (20) each commanded feed sits on, if any.
    feed_limits: [Option<&'static str>; TOOLS],
    slide_speed_commands: [f64; TOOLS],
    power_error: f64,
    spindle_speed_error: f64,
    events: Vec<Event>,
}

impl LatheForce {
    /// Designs H, the approach feeds and the drive gains; errors name the parameter at fault.
    pub fn new(params: LatheForceParams) -> Result<Self, ControllerError> {
        Ok(Self {
            design: design(&params)?,
            wiring: Wiring::default(),
            phase: Phase::SpindleStart,
            spindle_integral: 0.0,
            slide_integrals: [0.0; TOOLS],
            commanded_feeds: [0.0; TOOLS],
            feed_limits: [None; TOOLS],
            slide_speed_commands: [0.0; TOOLS],
            power_error: 0.0,
            spindle_speed_error: 0.0,
            events: Vec::new(),
        })
    }

    /// What the controller worked out before the run.
    pub fn design(&self) -> &LatheForceDesign {
        &self.design
    }

    /// The events a reset raises: how H came about and whether Sudhakara eq (23) holds.
    fn design_events(&self) -> Vec<Event> {
        let mut events = Vec::new();
        let [h1, h2] = self.design.power_gains;
        if let Some(design) = &self.design.output_feedback {
            let [m1, m2] = design.spec.time_constants;
            let [a, b] = design.output_feedback_poles;
            events.push(Event::info(
                EventKind::Design,
                format!(
                    "power gains from m = {m1} / {m2} s: h = {h1:.6e}, {h2:.6e} m/(rev·W); \
                 Theorem 1 residual {:.3}, closed-loop poles {:.3}{:+.3}i, {:.3}{:+.3}i 1/s",
                    design.consistency_residual, a.re, a.im, b.re, b.im
                ),
            ));
        }
        let check = &self.design.global_stability;
        if !check.satisfied {
            for i in 0..TOOLS {
                if check.power_gains[i] < check.lower_bounds[i] {
                    let line = check.zero_feed_powers[i].unwrap_or(f64::NAN);
                    let (tool, gain, bound) = (i + 1, check.power_gains[i], check.lower_bounds[i]);
                    events.push(Event::warning(
                        EventKind::Design,
                        format!(
                            "eq (23) not met: h_{tool} = {gain:.6e} < −f_n{tool}/P_max = \
                         {bound:.6e} m/(rev·W); tool {tool}'s zero-feed line (eq (21)) crosses \
                         the positive forces at P = {line:.1} W, so low initial forces may not \
                         reach P_max"
                        ),
                    ));
                }
            }
        }
        events
    }

    fn spindle_torque(&mut self, speed: f64, power: f64, period: f64) -> f64 {
        let target = self.design.lathe.params().spindle_speed;
        let limit = self.wiring.spindle_limit;
        self.spindle_speed_error = target - speed;
        let feed_forward = if speed > FEED_FORWARD_MIN_SPEED {
            power / speed
        } else {
            0.0
        };
        let (kp, ki) = (self.design.spindle_kp, self.design.spindle_ki);
        let candidate = self.spindle_integral + self.spindle_speed_error * period;
        let unclipped = kp * self.spindle_speed_error + ki * candidate + feed_forward;
        if unclipped.abs() <= limit {
            self.spindle_integral = candidate;
        }
        (kp * self.spindle_speed_error + ki * self.spindle_integral + feed_forward)
            .clamp(-limit, limit)
    }

    /// Sudhakara eq (20) on the measured power, with an event when a feed reaches or leaves a
    /// limit.
    fn power_loop(&mut self, time: f64, power: f64) {
        let lathe = &self.design.lathe;
        let max_feed = lathe.params().max_feed;
        self.power_error = power - lathe.params().max_spindle_power;
        for (i, nominal) in lathe.nominal_feeds().into_iter().enumerate() {
            let law = nominal - self.design.power_gains[i] * self.power_error;
            self.commanded_feeds[i] = law.clamp(0.0, max_feed);
            let limit = if law <= 0.0 {
                Some("zero feed")
            } else if law >= max_feed {
                Some("the feed limit")
            } else {
                None
            };
            if limit != self.feed_limits[i] {
                let subject = format!("feed_{}", i + 1);
                self.events.push(match limit {
                    Some(which) => Event::info(
                        EventKind::SaturationStart { subject },
                        format!(
                            "tool {} commanded feed saturated at {which} (eq (20)) at t = {time:.3} s",
                            i + 1
                        ),
                    ),
                    None => Event::info(
                        EventKind::SaturationEnd { subject },
                        format!(
                            "tool {} commanded feed back within eq (20)'s limits at t = {time:.3} s",
                            i + 1
                        ),
                    ),
                });
                self.feed_limits[i] = limit;
            }
        }
    }

    /// The feed servo of slide `i`: speed PI with set-point weight, cutting force fed forward.
    fn slide_force(&mut self, i: usize, speed: f64, cutting_force: f64, period: f64) -> f64 {
        let gains = self.design.feed_servos[i];
        let limit = self.wiring.slide_limits[i];
        let command = self.slide_speed_commands[i];
        let proportional = gains.kp * (gains.setpoint_weight * command - speed);
        let candidate = self.slide_integrals[i] + (command - speed) * period;
        if (proportional + gains.ki * candidate + cutting_force).abs() <= limit {
            self.slide_integrals[i] = candidate;
        }
        (proportional + gains.ki * self.slide_integrals[i] + cutting_force).clamp(-limit, limit)
    }
}

pub(crate) fn entry() -> Entry {
    Entry {
        name: NAME,
        machine: "lathe",
        summary: "parallel-turning power loop (output feedback, eqs 9–20) with feed servos and \
                  spindle speed PI",
        build: |table| Ok(Box::new(LatheForce::new(parse_params(NAME, table)?)?)),
    }
}

impl Controller for LatheForce {
    fn name(&self) -> &str {
        NAME
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        let mut wiring = Wiring {
            spindle_speed: plant.signal(&format!("{SPINDLE}.velocity"))?,
            spindle_power: plant.signal("spindle_power")?,
            spindle: plant.actuator(SPINDLE)?,
            ..Wiring::default()
        };
        wiring.spindle_limit = plant.actuators[wiring.spindle].effort_limit;
        for (i, slide) in SLIDES.into_iter().enumerate() {
            wiring.slide_speeds[i] = plant.signal(&format!("{slide}.velocity"))?;
            wiring.cutting_forces[i] = plant.signal(&format!("cutting_force_{}", i + 1))?;
            wiring.slides[i] = plant.actuator(slide)?;
            wiring.slide_limits[i] = plant.actuators[wiring.slides[i]].effort_limit;
        }
        self.wiring = wiring;
        self.phase = Phase::SpindleStart;
        self.spindle_integral = 0.0;
        self.slide_integrals = [0.0; TOOLS];
        self.commanded_feeds = [0.0; TOOLS];
        self.feed_limits = [None; TOOLS];
        self.slide_speed_commands = [0.0; TOOLS];
        self.power_error = 0.0;
        self.spindle_speed_error = 0.0;
        self.events = self.design_events();
        Ok(())
    }

    fn update(&mut self, measurement: &Measurement, period: f64, efforts: &mut [f64]) {
        let w = self.wiring;
        let speed = measurement.get(w.spindle_speed);
        let power = measurement.get(w.spindle_power);
        let forces = w.cutting_forces.map(|index| measurement.get(index));
        efforts[w.spindle] = self.spindle_torque(speed, power, period);

        let target = self.design.lathe.params().spindle_speed;
        if self.phase == Phase::SpindleStart
            && self.spindle_speed_error.abs() <= AT_SPEED_TOLERANCE * target
        {
            self.phase = Phase::Approach;
            self.commanded_feeds = self.design.approach_feeds;
            self.events.push(Event::mode(
                "approach",
                format!(
                "spindle at speed ({speed:.2} rad/s) at t = {:.3} s: slides approach at {:.4e}, \
                 {:.4e} m/rev",
                measurement.time, self.commanded_feeds[0], self.commanded_feeds[1]
            ),
            ));
        }
        if self.phase == Phase::Approach && forces.iter().all(|f| *f > CUTTING_FORCE_THRESHOLD) {
            self.phase = Phase::PowerLoop;
            self.events.push(Event::mode(
                "power_loop",
                format!(
                "both tools cutting at t = {:.3} s (F = {:.1}, {:.1} N, P = {power:.1} W): power \
                 loop closed",
                measurement.time, forces[0], forces[1]
            ),
            ));
        }
        if self.phase == Phase::PowerLoop {
            self.power_loop(measurement.time, power);
        }

        let revolutions_per_second = speed / TAU;
        for i in 0..TOOLS {
            self.slide_speed_commands[i] = self.commanded_feeds[i] * revolutions_per_second;
            let slide_speed = measurement.get(w.slide_speeds[i]);
            efforts[w.slides[i]] = self.slide_force(i, slide_speed, forces[i], period);
        }
    }

    fn internals(&self) -> Vec<SignalSpec> {
        vec![
            SignalSpec::new("phase", Unit::Dimensionless, "phase"),
            SignalSpec::new("power_limit", Unit::Kilowatt, "spindle power"),
            SignalSpec::new("power_error", Unit::Kilowatt, "power error"),
            SignalSpec::new("commanded_feed_1", Unit::MillimetrePerRev, "tool 1 feed"),
            SignalSpec::new("commanded_feed_2", Unit::MillimetrePerRev, "tool 2 feed"),
            SignalSpec::new(
                "slide_speed_command_1",
                Unit::MillimetrePerSecond,
                "slide speed commands",
            ),
            SignalSpec::new(
                "slide_speed_command_2",
                Unit::MillimetrePerSecond,
                "slide speed commands",
            ),
            SignalSpec::new("spindle_speed_error", Unit::Rpm, "spindle speed error"),
        ]
    }

    fn internal_values(&self, values: &mut [f64]) {
        let phase = match self.phase {
            Phase::SpindleStart => 0.0,
            Phase::Approach => 1.0,
            Phase::PowerLoop => 2.0,
        };
        values.copy_from_slice(&[
            phase,
            self.design.lathe.params().max_spindle_power,
            self.power_error,
            self.commanded_feeds[0],
            self.commanded_feeds[1],
            self.slide_speed_commands[0],
            self.slide_speed_commands[1],
            self.spindle_speed_error,
        ]);
    }

    fn drain_events(&mut self, events: &mut Vec<Event>) {
        events.append(&mut self.events);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use framework::{Actuator, EffortKind, EventLevel};

    fn plant() -> PlantInterface {
        let actuator = |joint: &str, kind, limit| Actuator {
            joint: joint.into(),
            kind,
            effort_limit: limit,
        };
        PlantInterface {
            machine: "lathe".into(),
            signals: [
                "spindle.position",
                "spindle.velocity",
                "slide_1.position",
                "slide_1.velocity",
                "slide_2.position",
                "slide_2.velocity",
                "feed_1",
                "feed_2",
                "cutting_force_1",
                "cutting_force_2",
                "spindle_power",
            ]
            .map(String::from)
            .to_vec(),
            actuators: vec![
                actuator("spindle", EffortKind::Torque, 300.0),
                actuator("slide_1", EffortKind::Force, 1e4),
                actuator("slide_2", EffortKind::Force, 1e4),
            ],
            ..Default::default()
        }
    }

    fn signals(speed: f64, slide_speeds: [f64; 2], forces: [f64; 2], power: f64) -> [f64; 11] {
        [
            0.0,
            speed,
            0.0,
            slide_speeds[0],
            0.0,
            slide_speeds[1],
            0.0,
            0.0,
            forces[0],
            forces[1],
            power,
        ]
    }

    fn events(controller: &mut LatheForce) -> Vec<Event> {
        let mut events = Vec::new();
        controller.drain_events(&mut events);
        events
    }

    #[test]
    fn feed_servo_gains_give_a_first_order_loop_with_time_constant_tau() {
        let design = design(&LatheForceParams::default()).unwrap();
        for (i, tau) in [0.05, 0.049].into_iter().enumerate() {
            let g = design.feed_servos[i];
            // b k_p = m / τ: the step response starts with slope 1/τ, as 1/(τ s + 1) does.
            assert!((g.setpoint_weight * g.kp - 200.0 / tau).abs() < 1e-9);
            // The zero of b k_p s + k_i sits on the fast pole −p.
            assert!((g.ki / (g.setpoint_weight * g.kp) - 100.0).abs() < 1e-9);
        }
        assert_eq!(design.spindle_kp, 2.0 * 50.0 * 0.08);
        assert_eq!(design.spindle_ki, 2500.0 * 0.08);
    }

    /// A 200 kg slide under a constant 2 kN cutting force (fed forward as measured) follows a
    /// step in speed command as 1 − e^(−t/τ). Both tools "cut" at P = P_max from the start, so
    /// the power loop closes at once and commands the nominal feeds.
    #[test]
    fn a_slide_follows_its_speed_command_as_eq_2() {
        let mut controller = LatheForce::new(LatheForceParams::default()).unwrap();
        controller.reset(&plant()).unwrap();
        let target = LatheParams::default().spindle_speed;
        let dt = 1e-4;
        let (mut slide, mut efforts) = ([0.0; 2], [0.0; 3]);
        let mut worst = 0.0_f64;
        let command = controller.design.lathe.nominal_feeds()[0] * target / TAU;
        for step in 0..10_000 {
            let time = step as f64 * dt;
            let values = signals(target, slide, [2000.0, 1000.0], 20e3);
            controller.update(
                &Measurement {
                    time,
                    signals: &values,
                },
                dt,
                &mut efforts,
            );
            if step > 0 {
                let ideal = command * (1.0 - (-time / 0.05).exp());
                worst = worst.max((slide[0] - ideal).abs() / command);
            }
            slide[0] += dt * (efforts[1] - 2000.0) / 200.0;
            slide[1] += dt * (efforts[2] - 1000.0) / 200.0;
        }
        assert!(worst < 0.01, "worst deviation from 1 − e^(−t/τ): {worst}");
        assert!((slide[0] - command).abs() < 1e-6 * command);
    }

    #[test]
    fn power_loop_follows_eq_20_and_reports_saturation() {
        let mut controller = LatheForce::new(LatheForceParams {
            time_constants: [1.5, 1.49],
            ..Default::default()
        })
        .unwrap();
        controller.reset(&plant()).unwrap();
        let reset_events = events(&mut controller);
        assert!(
            reset_events.iter().any(|e| e.kind == EventKind::Design
                && e.level == EventLevel::Warning
                && e.text.contains("eq (23) not met: h_2")),
            "{reset_events:?}"
        );
        let step = |controller: &mut LatheForce, power: f64, forces: [f64; 2]| {
            let target = LatheParams::default().spindle_speed;
            let values = signals(target, [0.0; 2], forces, power);
            controller.update(
                &Measurement {
                    time: 0.0,
                    signals: &values,
                },
                1e-3,
                &mut [0.0; 3],
            );
        };
        // At speed: approach at the nominal feeds; both tools cutting: the loop closes.
        step(&mut controller, 0.0, [0.0; 2]);
        step(&mut controller, 5e3, [800.0, 200.0]);
        assert_eq!(controller.phase, Phase::PowerLoop);
        // 5 kW is below tool 2's zero-feed line (7.95 kW): its feed is clipped at zero.
        let h = controller.design.power_gains;
        let nominal = controller.design.lathe.nominal_feeds();
        assert_eq!(controller.commanded_feeds[1], 0.0);
        let expected = nominal[0] - h[0] * (5e3 - 20e3);
        assert!((controller.commanded_feeds[0] - expected).abs() < 1e-15);
        let saturated = events(&mut controller);
        assert!(
            saturated.iter().any(|e| e.kind
                == EventKind::SaturationStart {
                    subject: "feed_2".into()
                }
                && e.text.contains("at zero feed")),
            "{saturated:?}"
        );
        step(&mut controller, 20e3, [2546.0, 1273.0]);
        assert!((controller.commanded_feeds[1] - nominal[1]).abs() < 1e-15);
        assert!(events(&mut controller).iter().any(|e| e.kind
            == EventKind::SaturationEnd {
                subject: "feed_2".into()
            }));
    }

    #[test]
    fn gains_on_the_eq_23_bound_raise_no_warning() {
        let params = LatheForceParams::default();
        let lathe = Lathe::new(params.lathe).unwrap();
        let bounds = output_feedback_design::global_stability(&lathe, [0.0; 2]).lower_bounds;
        let mut controller = LatheForce::new(LatheForceParams {
            power_gains: Some(bounds),
            ..params
        })
        .unwrap();
        controller.reset(&plant()).unwrap();
        assert!(controller.design().output_feedback.is_none());
        assert!(events(&mut controller).is_empty());
    }

    #[test]
    fn bad_parameters_are_named() {
        let build = |toml_text: &str| {
            let table: toml::Table = toml::from_str(toml_text).unwrap();
            framework::Registry::with([super::entry()])
                .build(NAME, "lathe", &table)
                .err()
                .unwrap()
        };
        for (text, key, value, reason) in [
            (
                "time_constants = [0.0, 0.49]",
                "time_constants.0",
                Some("0"),
                "must be > 0 (m_1 of eq (12))",
            ),
            (
                "consistency = \"require\"",
                "consistency",
                Some("\"require\""),
                "Theorem 1",
            ),
            (
                "lathe = { max_spindle_power = 60e3 }",
                "lathe",
                None,
                "reaches only",
            ),
            (
                "initial_forces = [8000.0, 500.0]",
                "initial_forces.0",
                Some("8000"),
                "feed limit",
            ),
            (
                "initial_forces = [-1.0, 500.0]",
                "initial_forces.0",
                Some("-1"),
                "must be > 0",
            ),
            (
                "power_gains = [nan, 0.0]",
                "power_gains.0",
                Some("NaN"),
                "must be a finite number",
            ),
            (
                "slide_masses = [0.0, 10.0]",
                "slide_masses.0",
                Some("0"),
                "must be > 0",
            ),
            ("gain = 1.0", "gain", None, "unknown field"),
        ] {
            let err = build(text);
            assert!(
                matches!(
                    &err,
                    ControllerError::BadParameter { key: k, value: v, reason: r, .. }
                        if k == key && v.as_deref() == value && r.contains(reason)
                ),
                "{text}: {err}"
            );
        }
        assert_eq!(
            build("spindle_bandwidth = -50").to_string(),
            "controller `output-feedback-force`: params.spindle_bandwidth = -50: must be > 0"
        );
        assert!(build("lathe = { max_spindle_power = 60e3 }")
            .to_string()
            .starts_with("controller `output-feedback-force`: params.lathe: tool 1 must take"));
    }

    #[test]
    fn a_plant_without_power_measurement_is_refused() {
        let mut controller = LatheForce::new(LatheForceParams::default()).unwrap();
        let mut plant = plant();
        plant.signals.retain(|s| s != "spindle_power");
        let err = controller.reset(&plant).unwrap_err();
        assert!(err.to_string().contains("spindle_power"), "{err}");
    }
}
