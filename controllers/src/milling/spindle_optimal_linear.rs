//! `spindle-optimal-linear`: the spindle-speed change δn of Kaliński & Galewski 2013,
//! Kaliński eqs (17)–(18), that lowers the energy index Kaliński eq (3), with the optimal-linear
//! fall-back:
//! once n reaches n_max it falls linearly back to n0, and the optimal law resumes.
//!
//! **The law.** A change δn of the speed changes the regenerative delay (τ ∝ 1/n) and so the
//! delayed part of the cutting force by `B_u·δn`, Kaliński eq (16):
//! `B_u = Σ_flutes in cut k_d·a_p·(t + μ·n)·(n·u̇(t − τ))·τ/n_s` (N per rad/s; t, n the flute's
//! tangential and radial directions as in `models::milling`, u̇(t − τ) the tool's velocity when
//! the flute ahead passed the same angle, n_s the speed). Minimising Kaliński eq (3) over one
//! control period h, `J = ½·u̇ᵀQ₁Mu̇ + ½·R·δn²` with `Δu̇ = M⁻¹B_u·δn·h`, gives
//! `δn = −(h·Q₁/R)·B_uᵀu̇` — Kaliński eq (18) with the state-transition integral taken over one
//! period (Φ ≈ I, the estimate used: the controller cannot measure Φ of the cut it does not model),
//! so Kaliński eq (18)'s potential-energy term (through T₂) vanishes at this order and the tool's
//! mass M cancels (Kaliński eq (18) as printed omits the M⁻¹ of Kaliński eq (1)'s input matrix,
//! which cancels the Mᵀ of the kinetic term). δn is clipped to ±U, Kaliński eq (10). The command n
//! accumulates δn, never below n0.
//!
//! **Measured:** the spindle's angle and speed and the tool tip's velocities (`tool_x.velocity`,
//! `tool_y.velocity`). The cut's parameters are the controller's model of the process.

use super::spindle_speed::{check_speeds, SpeedLoop, SpeedLoopParams};
use crate::check::{finite, positive};
use framework::{parse_params, Entry};
use framework::{Controller, ControllerError, Measurement, PlantInterface, SignalSpec, Unit};
use models::milling::{force_direction, MillingCutParams};
use serde::Deserialize;
use std::collections::VecDeque;
use std::f64::consts::TAU;

const NAME: &str = "spindle-optimal-linear";

/// Parameters of `spindle-optimal-linear` (SI units).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct OptimalLinearParams {
    /// n0, rad/s: the start and the floor of the command.
    pub nominal_speed: f64,
    /// n_max, rad/s: where the linear fall begins.
    pub maximum_speed: f64,
    /// Time of the linear fall from n_max to n0, s.
    pub fall_time: f64,
    /// Q₁ of Kaliński eq (3), dimensionless.
    pub kinetic_weight: f64,
    /// R of Kaliński eq (3), N·m·s³/rad² (makes δn rad/s).
    pub control_weight: f64,
    /// U of Kaliński eq (10): largest |δn| per control period, rad/s.
    pub speed_change_limit: f64,
    /// The controller's model of the cut (the keys of the machine's `[process.cut]`).
    pub cut: MillingCutParams,
    /// The tool tip's x and y joints, whose measured velocities u̇ (m/s) the law reads.
    pub tool_joints: [String; 2],
    /// The spindle-speed loop, `[controller.params.speed_loop]`.
    pub speed_loop: SpeedLoopParams,
}

impl Default for OptimalLinearParams {
    fn default() -> Self {
        Self {
            nominal_speed: 15_000.0 * TAU / 60.0,
            maximum_speed: 16_500.0 * TAU / 60.0,
            fall_time: 0.4,
            kinetic_weight: 1.0,
            control_weight: 5.0e-5,
            speed_change_limit: 0.5,
            cut: MillingCutParams::default(),
            tool_joints: ["tool_x".into(), "tool_y".into()],
            speed_loop: SpeedLoopParams::default(),
        }
    }
}

/// The law's gain and limit, from [`design`]: δn = −h·(Q₁/R)·B_uᵀu̇, clipped to ±U.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OptimalLinearGains {
    /// Q₁/R, rad²/(N·m·s³).
    pub gain_per_second: f64,
    /// U of Kaliński eq (10): largest |δn| per control period, rad/s.
    pub limit: f64,
}

/// Checks the parameters and returns the gain and the limit of Kaliński eq (18) and
/// Kaliński eq (10).
pub fn design(params: &OptimalLinearParams) -> Result<OptimalLinearGains, ControllerError> {
    let p = params;
    check_speeds(NAME, p.nominal_speed, p.maximum_speed)?;
    positive(NAME, "fall_time", p.fall_time)?;
    let kinetic_weight = positive(NAME, "kinetic_weight", p.kinetic_weight)?;
    let control_weight = positive(NAME, "control_weight", p.control_weight)?;
    let limit = positive(NAME, "speed_change_limit", p.speed_change_limit)?;
    if !(1..=8).contains(&p.cut.flutes) {
        return Err(ControllerError::parameter(
            NAME,
            "cut.flutes",
            p.cut.flutes,
            "must be 1 to 8",
        ));
    }
    finite(NAME, "cut.force_ratio", p.cut.force_ratio)?;
    let entry = finite(NAME, "cut.entry_angle", p.cut.entry_angle)?;
    if finite(NAME, "cut.exit_angle", p.cut.exit_angle)? <= entry {
        return Err(ControllerError::parameter(
            NAME,
            "cut.exit_angle",
            p.cut.exit_angle,
            format!("must be > cut.entry_angle = {entry}"),
        ));
    }
    Ok(OptimalLinearGains {
        gain_per_second: kinetic_weight / control_weight,
        limit,
    })
}

/// ∂F/∂n of Kaliński eq (16): the delayed force's change per rad/s of spindle speed, N·s/rad.
pub fn speed_sensitivity(
    cut: &MillingCutParams,
    angle: f64,
    speed: f64,
    delayed_velocity: [f64; 2],
) -> [f64; 2] {
    let tau = cut.pitch() / speed;
    let mut b = [0.0; 2];
    for j in 0..cut.flutes {
        let phi = angle + j as f64 * cut.pitch();
        if !cut.engaged(phi) {
            continue;
        }
        let (s, c) = phi.sin_cos();
        let normal_rate = delayed_velocity[0] * s + delayed_velocity[1] * c;
        let scale = cut.cutting_pressure * cut.axial_depth * normal_rate * tau / speed;
        for (b, d) in b.iter_mut().zip(force_direction(phi, cut.force_ratio)) {
            *b += scale * d;
        }
    }
    b
}

/// Where the command is in the optimal-linear cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    Optimal,
    /// Falling linearly since this time.
    Falling {
        since: f64,
    },
}

/// The running `spindle-optimal-linear` controller: the speed command n raised by δn each period
/// until n_max, then the linear fall to n0, followed by the speed loop.
pub struct OptimalLinear {
    params: OptimalLinearParams,
    gains: OptimalLinearGains,
    speed_loop: SpeedLoop,
    tool_signals: [usize; 2],
    /// (spindle angle, tool velocity) at past updates, one pitch deep.
    history: VecDeque<(f64, [f64; 2])>,
    phase: Phase,
    command: f64,
    speed_change: f64,
}

impl OptimalLinear {
    /// Designs the law and the speed loop; errors name the parameter at fault.
    pub fn new(params: OptimalLinearParams) -> Result<Self, ControllerError> {
        Ok(Self {
            gains: design(&params)?,
            speed_loop: SpeedLoop::new(NAME, &params.speed_loop)?,
            tool_signals: [0, 0],
            history: VecDeque::new(),
            phase: Phase::Optimal,
            command: params.nominal_speed,
            speed_change: 0.0,
            params,
        })
    }

    /// The tool's velocity when the spindle was at `angle` (linear between updates).
    fn velocity_at(&self, angle: f64) -> Option<[f64; 2]> {
        let after = self.history.partition_point(|(a, _)| *a < angle);
        if after == 0 || after == self.history.len() {
            return None;
        }
        let ((a0, v0), (a1, v1)) = (self.history[after - 1], self.history[after]);
        let w = (angle - a0) / (a1 - a0);
        Some([v0[0] + w * (v1[0] - v0[0]), v0[1] + w * (v1[1] - v0[1])])
    }

    /// Kaliński eq (18) over one period, clipped by Kaliński eq (10): δn, rad/s.
    fn optimal_change(&mut self, angle: f64, speed: f64, velocity: [f64; 2], period: f64) -> f64 {
        let pitch = self.params.cut.pitch();
        if self.history.back().is_none_or(|(a, _)| angle > *a) {
            self.history.push_back((angle, velocity));
        }
        while self.history.len() > 2 && self.history[1].0 <= angle - pitch {
            self.history.pop_front();
        }
        let Some(delayed) = self.velocity_at(angle - pitch).filter(|_| speed > 0.0) else {
            return 0.0;
        };
        let b = speed_sensitivity(&self.params.cut, angle, speed, delayed);
        let power_rate = b[0] * velocity[0] + b[1] * velocity[1];
        let limit = self.gains.limit;
        (-period * self.gains.gain_per_second * power_rate).clamp(-limit, limit)
    }
}

pub(crate) fn entry() -> Entry {
    Entry {
        name: NAME,
        machine: "milling",
        summary: "optimal spindle-speed change at the energy index (eq 18) with the linear fall from n_max",
        build: |table| Ok(Box::new(OptimalLinear::new(parse_params(NAME, table)?)?)),
    }
}

impl Controller for OptimalLinear {
    fn name(&self) -> &str {
        NAME
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        for (slot, joint) in self.tool_signals.iter_mut().zip(&self.params.tool_joints) {
            *slot = plant.signal(&format!("{joint}.velocity"))?;
        }
        self.history.clear();
        self.phase = Phase::Optimal;
        self.command = self.params.nominal_speed;
        self.speed_change = 0.0;
        self.speed_loop.reset(plant)
    }

    fn update(&mut self, measurement: &Measurement, period: f64, efforts: &mut [f64]) {
        let p = &self.params;
        let (n0, n_max) = (p.nominal_speed, p.maximum_speed);
        let fall_rate = (n_max - n0) / p.fall_time;
        let angle = self.speed_loop.angle(measurement);
        let speed = self.speed_loop.speed(measurement);
        let velocity = self.tool_signals.map(|s| measurement.get(s));
        let change = self.optimal_change(angle, speed, velocity, period);
        let rate = match self.phase {
            Phase::Optimal => {
                self.speed_change = change;
                self.command = (self.command + change).max(n0);
                if self.command >= n_max {
                    self.phase = Phase::Falling {
                        since: measurement.time,
                    };
                }
                change / period
            }
            Phase::Falling { since } => {
                self.speed_change = 0.0;
                self.command = n_max - fall_rate * (measurement.time - since);
                if self.command <= n0 {
                    (self.command, self.phase) = (n0, Phase::Optimal);
                }
                -fall_rate
            }
        };
        self.speed_loop
            .update(measurement, (self.command, rate), period, efforts);
    }

    fn internals(&self) -> Vec<SignalSpec> {
        let mut specs = super::spindle_speed::internals();
        specs.insert(
            1,
            SignalSpec::new("speed_change", Unit::Rpm, "spindle speed change"),
        );
        specs
    }

    fn internal_values(&self, values: &mut [f64]) {
        let l = &self.speed_loop;
        values.copy_from_slice(&[self.command, self.speed_change, l.speed_error, l.torque]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_parameters_are_named_with_their_value() {
        let build = |text: &str| {
            framework::Registry::with([super::entry()])
                .build(NAME, "milling", &text.parse::<toml::Table>().unwrap())
                .err()
                .unwrap()
                .to_string()
        };
        let prefix = "controller `spindle-optimal-linear`: params.";
        for (text, message) in [
            ("control_weight = 0", "control_weight = 0: must be > 0"),
            (
                "maximum_speed = 1000",
                "maximum_speed = 1000: must be > nominal_speed = 1570.79",
            ),
            ("cut = { flutes = 9 }", "cut.flutes = 9: must be 1 to 8"),
            (
                "speed_loop = { damping_ratio = -1 }",
                "speed_loop.damping_ratio = -1: must be > 0",
            ),
        ] {
            let error = build(text);
            assert!(
                error.starts_with(&format!("{prefix}{message}")),
                "{text}: {error}"
            );
        }
    }
}
