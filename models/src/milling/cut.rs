//! The regenerative cut of a slender milling tool, after Kaliński & Galewski ("Mechatronic
//! surveillance…", 2013, §3): the force on each flute in the cut, Kaliński eqs (11)–(13),
//! with the chip left by the flute before it at the same angle.
//!
//! **Geometry** (seen along the tool axis, x the feed direction): flute j sits at
//! `φ_j = θ + 2πj/N`, θ the spindle angle, measured clockwise from +y (the sense the spindle
//! turns). `n(φ) = (sin φ, cos φ)` points from the tool axis into the material, `t(φ) =
//! (cos φ, −sin φ)` along the edge's motion. A flute cuts while `φ_j mod 2π` lies in
//! `[entry_angle, exit_angle]` (`[0, π]` full immersion) and its chip is positive (Kaliński eq
//! (11): the force vanishes when the edge leaves the material).
//!
//! **Chip and regeneration.** In the workpiece's frame the edge of flute j is, along n, at
//! `r_j = (u + v_f·t·e_x)·n(φ_j)`, u the tool's deflection and v_f the feed. The material there
//! is where the last flute to cut at that angle left it, `S`; the chip is `h_j = r_j − S`. The
//! flute before j passed φ_j when the spindle was one pitch back, `θ(t') = θ(t) − 2π/N`: t' is
//! found in the spindle's recorded angle, so the delay `τ = t − t'` follows the instantaneous
//! speed (Kaliński eq (16)'s integral of 1/n over one pitch), not a fixed τ. With no vibration this
//! is Kaliński eq (11)'s `h_D = f_z·sin φ` with `f_z = v_f·τ`; the paper's `Δh` is the deflection
//! away from the material, `Δh = −u·n`. A flute that leaves the material leaves the surface as it
//! was, so the next one cuts what it skipped (multiple regeneration).
//!
//! **Forces** (Kaliński eqs (11)–(13)): tangential `F_t = k_d·a_p·h`, radial `F_r = μ·F_t`, along
//! the tool axis none; on the tool `F = −F_t·t − F_r·n`, and about the spindle axis the drag
//! `F_t·R`.

use serde::{Deserialize, Serialize};
use std::collections::VecDeque;
use std::f64::consts::{PI, TAU};
use thiserror::Error;

/// Most flutes a tool may have.
pub const MAX_FLUTES: usize = 8;

/// Samples of the pass put into the history when the cut starts (one pitch of steady cutting).
const START_SAMPLES: usize = 64;

/// Why the cut's parameters are rejected.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum MillingError {
    /// A [`MillingCutParams`] field is out of its range.
    #[error("{name} must be {what}, got {value}")]
    Bad {
        /// The field's name.
        name: &'static str,
        /// The range it must lie in, in words.
        what: &'static str,
        /// The rejected value, in the field's SI unit (a count for `flutes`).
        value: f64,
    },
}

/// The cut's parameters, SI (a `[process.cut]` table).
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct MillingCutParams {
    /// Number of flutes N.
    pub flutes: usize,
    /// Radius of the cutting edge at the contact point R, m.
    pub tool_radius: f64,
    /// Average dynamic specific cutting pressure k_d, N/m² (Kaliński eq (11)).
    pub cutting_pressure: f64,
    /// Cutting force ratio μ = F_r/F_t (Kaliński eq (12)).
    pub force_ratio: f64,
    /// Axial depth of cut a_p, m.
    pub axial_depth: f64,
    /// Feed speed of the workpiece v_f, m/s.
    pub feed_speed: f64,
    /// Flute angle where the cut begins, rad (clockwise from +y).
    pub entry_angle: f64,
    /// Flute angle where the cut ends, rad.
    pub exit_angle: f64,
}

impl Default for MillingCutParams {
    /// Full-immersion slotting of aluminium with a two-flute Ø16 mm ball-end mill (the guide's
    /// milling chapter).
    fn default() -> Self {
        Self {
            flutes: 2,
            tool_radius: 0.008,
            cutting_pressure: 7.0e8,
            force_ratio: 0.3,
            axial_depth: 1.0e-3,
            feed_speed: 0.05,
            entry_angle: 0.0,
            exit_angle: PI,
        }
    }
}

impl MillingCutParams {
    /// Checks every field, naming the bad one.
    pub fn validate(&self) -> Result<(), MillingError> {
        let bad = |name, what, value| Err(MillingError::Bad { name, what, value });
        if !(1..=MAX_FLUTES).contains(&self.flutes) {
            return bad("flutes", "a whole number from 1 to 8", self.flutes as f64);
        }
        for (name, value) in [
            ("tool_radius", self.tool_radius),
            ("cutting_pressure", self.cutting_pressure),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return bad(name, "finite and > 0", value);
            }
        }
        for (name, value) in [
            ("force_ratio", self.force_ratio),
            ("axial_depth", self.axial_depth),
            ("feed_speed", self.feed_speed),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return bad(name, "finite and ≥ 0", value);
            }
        }
        if !(self.entry_angle.is_finite() && (0.0..TAU).contains(&self.entry_angle)) {
            return bad("entry_angle", "in [0, 2π) rad", self.entry_angle);
        }
        if !(self.exit_angle.is_finite()
            && self.exit_angle > self.entry_angle
            && self.exit_angle <= self.entry_angle + TAU)
        {
            return bad(
                "exit_angle",
                "finite, > entry_angle and ≤ entry_angle + 2π rad",
                self.exit_angle,
            );
        }
        Ok(())
    }

    /// Angle between flutes, rad.
    pub fn pitch(&self) -> f64 {
        TAU / self.flutes as f64
    }

    /// Whether a flute at angle `phi` (rad) is inside the immersion.
    pub fn engaged(&self, phi: f64) -> bool {
        let from_entry = (phi - self.entry_angle).rem_euclid(TAU);
        from_entry <= self.exit_angle - self.entry_angle
    }

    /// Feed per tooth at spindle speed `speed` (rad/s), m.
    pub fn feed_per_tooth(&self, speed: f64) -> f64 {
        self.feed_speed * self.pitch() / speed
    }
}

/// Direction of `t + μ·n` at flute angle `phi`: the force on the tool is `−F_t` times it, and a
/// chip change δh changes it by `−k_d·a_p·δh` times it.
pub fn force_direction(phi: f64, force_ratio: f64) -> [f64; 2] {
    let (s, c) = phi.sin_cos();
    [c + force_ratio * s, -s + force_ratio * c]
}

/// The cut at one instant.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CutForces {
    /// On the tool, world x and y, N.
    pub force: [f64; 2],
    /// ∂force/∂deflection, N/m (rows x and y): the chip follows the tool's own motion.
    pub stiffness: [[f64; 2]; 2],
    /// Tangential force on each flute, N (0 out of the cut).
    pub tangential: [f64; MAX_FLUTES],
    /// Thickest chip being cut, m.
    pub chip: f64,
    /// Flutes in the material.
    pub flutes_cutting: usize,
}

impl CutForces {
    /// Drag torque on the spindle about its axis, against its rotation, N·m.
    pub fn spindle_torque(&self, tool_radius: f64) -> f64 {
        tool_radius * self.tangential.iter().sum::<f64>()
    }
}

/// One instant of the spindle's rotation and the surface each flute left there.
#[derive(Debug, Clone, Copy)]
struct PassSample {
    time: f64,
    angle: f64,
    /// Per flute: the material's position along n(φ_j), workpiece frame, m.
    surface: [f64; MAX_FLUTES],
}

/// The regenerative cut: forces from the tool's deflection and the surface the earlier flutes
/// left, remembering one pitch of the spindle's rotation.
#[derive(Debug, Clone)]
pub struct MillingCut {
    params: MillingCutParams,
    /// Angle and surface samples, angles increasing, reaching one pitch back.
    history: VecDeque<PassSample>,
    /// Factor on the forces (a process fault: 0 a broken tool).
    factor: f64,
}

impl MillingCut {
    /// Checks the parameters; the surface history starts at the first [`advance`](Self::advance).
    pub fn new(params: MillingCutParams) -> Result<Self, MillingError> {
        params.validate()?;
        Ok(Self {
            params,
            history: VecDeque::new(),
            factor: 1.0,
        })
    }

    /// The parameters the cut was built from.
    pub fn params(&self) -> &MillingCutParams {
        &self.params
    }

    /// Scales the forces from now on (0: a broken tool; k > 1: a hard spot).
    pub fn set_factor(&mut self, factor: f64) {
        self.factor = factor;
    }

    /// The cut at `time`, spindle at `angle` (rad, clockwise) turning at `speed` (rad/s), tool
    /// deflected by `deflection` (m); records the surface it leaves. Call once per step, time and
    /// angle not decreasing. A spindle that is not turning forward does not cut.
    pub fn advance(
        &mut self,
        time: f64,
        angle: f64,
        speed: f64,
        deflection: [f64; 2],
    ) -> CutForces {
        if self.history.is_empty() {
            self.start(time, angle, speed);
        }
        let p = &self.params;
        let turning = speed > 0.0 && self.history.back().is_some_and(|s| angle > s.angle);
        let mut cut = CutForces::default();
        let mut surface = [0.0; MAX_FLUTES];
        let previous = self.surface_one_pitch_back(angle);
        let gain = self.factor * p.cutting_pressure * p.axial_depth;
        for (j, left) in surface.iter_mut().enumerate().take(p.flutes) {
            let phi = angle + j as f64 * p.pitch();
            let (s, c) = phi.sin_cos();
            let edge = (deflection[0] + p.feed_speed * time) * s + deflection[1] * c;
            // The flute ahead of j (j + 1) passed this angle one pitch ago.
            let material = previous[(j + 1) % p.flutes];
            let chip = edge - material;
            let engaged = p.engaged(phi);
            *left = if engaged { edge.max(material) } else { edge };
            if !(turning && engaged && chip > 0.0) {
                continue;
            }
            let tangential = gain * chip;
            cut.tangential[j] = tangential;
            // F = −F_t·(t + μ·n); ∂F/∂u = −k_d·a_p·(t + μ·n)·nᵀ.
            let direction = force_direction(phi, p.force_ratio);
            for ((force, row), d) in cut.force.iter_mut().zip(&mut cut.stiffness).zip(direction) {
                *force -= tangential * d;
                row[0] -= gain * d * s;
                row[1] -= gain * d * c;
            }
            cut.chip = cut.chip.max(chip);
            cut.flutes_cutting += 1;
        }
        if turning {
            self.remember(time, angle, surface);
        }
        cut
    }

    /// The history as if the spindle had cut steadily, undeflected, at `speed` for one pitch
    /// before `time` (a spindle at rest: as if the last pass had just been made).
    fn start(&mut self, time: f64, angle: f64, speed: f64) {
        let p = self.params;
        let span = p.pitch() * (1.0 + 2.0 / START_SAMPLES as f64);
        for k in (1..=START_SAMPLES).rev() {
            let back = span * k as f64 / START_SAMPLES as f64;
            let t = if speed > 0.0 {
                time - back / speed
            } else {
                time
            };
            let mut surface = [0.0; MAX_FLUTES];
            for (j, s) in surface.iter_mut().enumerate().take(p.flutes) {
                let phi = angle - back + j as f64 * p.pitch();
                *s = p.feed_speed * t * phi.sin();
            }
            self.history.push_back(PassSample {
                time: t,
                angle: angle - back,
                surface,
            });
        }
    }

    /// Per flute, the surface it left one pitch before `angle` (linear in the angle).
    fn surface_one_pitch_back(&self, angle: f64) -> [f64; MAX_FLUTES] {
        let target = angle - self.params.pitch();
        let after = self.history.partition_point(|s| s.angle < target);
        let (a, b) = match after {
            0 => (self.history[0], self.history[0]),
            k if k == self.history.len() => (self.history[k - 1], self.history[k - 1]),
            k => (self.history[k - 1], self.history[k]),
        };
        let span = b.angle - a.angle;
        let w = if span > 0.0 {
            (target - a.angle) / span
        } else {
            0.0
        };
        std::array::from_fn(|j| a.surface[j] + w * (b.surface[j] - a.surface[j]))
    }

    /// Time at which the spindle was at `angle`, from the history (the regenerative delay is
    /// `now − time_at(angle − pitch)`).
    pub fn time_at(&self, angle: f64) -> Option<f64> {
        let after = self.history.partition_point(|s| s.angle < angle);
        if after == 0 || after == self.history.len() {
            return None;
        }
        let (a, b) = (self.history[after - 1], self.history[after]);
        let w = (angle - a.angle) / (b.angle - a.angle);
        Some(a.time + w * (b.time - a.time))
    }

    /// Appends this instant and forgets what lies more than one pitch back.
    fn remember(&mut self, time: f64, angle: f64, surface: [f64; MAX_FLUTES]) {
        self.history.push_back(PassSample {
            time,
            angle,
            surface,
        });
        let oldest_needed = angle - self.params.pitch();
        while self.history.len() > 2 && self.history[1].angle <= oldest_needed {
            self.history.pop_front();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn slotting() -> MillingCutParams {
        MillingCutParams::default()
    }

    /// Mean force over whole turns of a rigid tool at constant speed.
    fn mean_force(params: MillingCutParams, speed: f64, turns: usize) -> ([f64; 2], f64) {
        let mut cut = MillingCut::new(params).unwrap();
        let steps_per_turn = 3600;
        let dt = TAU / speed / steps_per_turn as f64;
        let (mut sum, mut torque) = ([0.0; 2], 0.0);
        let n = steps_per_turn * turns;
        for k in 0..n {
            let t = k as f64 * dt;
            let f = cut.advance(t, speed * t, speed, [0.0; 2]);
            sum[0] += f.force[0];
            sum[1] += f.force[1];
            torque += f.spindle_torque(params.tool_radius);
        }
        ([sum[0] / n as f64, sum[1] / n as f64], torque / n as f64)
    }

    #[test]
    fn rigid_slotting_gives_the_closed_form_mean_forces() {
        // Over a turn, chip f_z·sin φ on [0, π]: F̄_x = −N·k·a·f_z·μ/4, F̄_y = N·k·a·f_z/4, and
        // the mean drag torque R·N·k·a·f_z/π.
        let p = slotting();
        let speed = 1500.0;
        let (force, torque) = mean_force(p, speed, 4);
        let fz = p.feed_per_tooth(speed);
        let scale = p.flutes as f64 * p.cutting_pressure * p.axial_depth * fz;
        let expected = [-scale * p.force_ratio / 4.0, scale / 4.0];
        for axis in 0..2 {
            let error = (force[axis] - expected[axis]).abs();
            assert!(
                error < 2e-3 * scale,
                "axis {axis}: {force:?} vs {expected:?}"
            );
        }
        let expected_torque = p.tool_radius * scale / PI;
        assert!((torque - expected_torque).abs() < 2e-3 * expected_torque);
    }

    #[test]
    fn the_chip_follows_the_instantaneous_delay_when_the_speed_changes() {
        // Spindle accelerating: the feed per tooth is v_f times the true time since the flute
        // ahead passed the same angle, found from the recorded rotation.
        let p = MillingCutParams {
            flutes: 1,
            ..slotting()
        };
        let mut cut = MillingCut::new(p).unwrap();
        let (w0, alpha, dt) = (1000.0, 4000.0, 1e-6);
        let angle = |t: f64| w0 * t + 0.5 * alpha * t * t;
        let mut last = CutForces::default();
        let mut t = 0.0;
        while angle(t) < TAU + PI / 2.0 {
            last = cut.advance(t, angle(t), w0 + alpha * t, [0.0; 2]);
            t += dt;
        }
        let t = t - dt;
        let earlier = cut.time_at(angle(t) - TAU).unwrap();
        // The flute at φ ≈ π/2 (sin φ ≈ 1): chip = v_f·(t − t').
        let phi = angle(t).rem_euclid(TAU);
        let expected = p.feed_speed * (t - earlier) * phi.sin();
        assert!(
            (last.chip - expected).abs() < 1e-10,
            "{} vs {expected}",
            last.chip
        );
        // And t' solves θ(t') = θ(t) − 2π for the accelerating spindle.
        let exact = (-w0 + (w0 * w0 + 2.0 * alpha * (angle(t) - TAU)).sqrt()) / alpha;
        assert!((earlier - exact).abs() < 1e-9, "{earlier} vs {exact}");
    }

    #[test]
    fn a_deflection_into_the_material_thickens_the_chip_and_the_stiffness_says_by_how_much() {
        let p = slotting();
        let speed = 1500.0;
        let mut a = MillingCut::new(p).unwrap();
        let mut b = MillingCut::new(p).unwrap();
        let t = 0.3 / speed; // flute 0 at 0.3 rad, in the cut
        let du = [1e-7, -2e-7];
        let fa = a.advance(t, speed * t, speed, [0.0; 2]);
        let fb = b.advance(t, speed * t, speed, du);
        for row in 0..2 {
            let predicted = fa.stiffness[row][0] * du[0] + fa.stiffness[row][1] * du[1];
            let actual = fb.force[row] - fa.force[row];
            assert!((predicted - actual).abs() < 1e-9 * actual.abs().max(1.0));
        }
        assert!(fa.flutes_cutting == 1 && fa.chip > 0.0);
    }

    #[test]
    fn a_flute_thrown_out_of_the_cut_leaves_the_surface_for_the_next() {
        // Pull the tool far out of the material for one pass: no force; the next flute then
        // takes two feeds' worth of chip at the same angle.
        let p = MillingCutParams {
            flutes: 1,
            ..slotting()
        };
        let speed = 1000.0;
        let mut cut = MillingCut::new(p).unwrap();
        let dt = 1e-6;
        let mut chips = Vec::new();
        let mut k = 0usize;
        loop {
            let t = k as f64 * dt;
            let angle = speed * t;
            if angle > TAU + PI / 2.0 {
                break;
            }
            let pulled = if angle < TAU { [-1e-3, 0.0] } else { [0.0; 2] };
            let f = cut.advance(t, angle, speed, pulled);
            chips.push((angle, f.chip, f.flutes_cutting));
            k += 1;
        }
        assert!(chips
            .iter()
            .filter(|(a, _, _)| *a > 0.1 && *a < PI - 0.1)
            .all(|&(_, _, n)| n == 0));
        let fz = p.feed_per_tooth(speed);
        let (_, chip, _) = chips.last().copied().unwrap();
        assert!(
            (chip - 2.0 * fz).abs() < 1e-3 * fz,
            "{chip} vs {}",
            2.0 * fz
        );
    }

    #[test]
    fn every_bad_parameter_is_named() {
        let cases: [(&str, MillingCutParams); 6] = [
            (
                "flutes",
                MillingCutParams {
                    flutes: 0,
                    ..slotting()
                },
            ),
            (
                "flutes",
                MillingCutParams {
                    flutes: 9,
                    ..slotting()
                },
            ),
            (
                "tool_radius",
                MillingCutParams {
                    tool_radius: -1.0,
                    ..slotting()
                },
            ),
            (
                "cutting_pressure",
                MillingCutParams {
                    cutting_pressure: f64::NAN,
                    ..slotting()
                },
            ),
            (
                "axial_depth",
                MillingCutParams {
                    axial_depth: -1e-3,
                    ..slotting()
                },
            ),
            (
                "exit_angle",
                MillingCutParams {
                    exit_angle: 0.0,
                    ..slotting()
                },
            ),
        ];
        for (name, params) in cases {
            let error = MillingCut::new(params).unwrap_err().to_string();
            assert!(error.starts_with(name), "{error}");
        }
    }
}
