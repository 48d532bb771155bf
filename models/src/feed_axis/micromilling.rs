//! Micro-milling on a linear-motor feed axis, after Rubio, Ibeas & Luo ("P-PI and super twisting
//! sliding mode control schemes comparison for high-precision CNC machining"): the cutting force
//! that disturbs the axis (their §II.B, Rubio eqs (2)–(4)); the sine reference of their §V is a
//! [`Reference::Sine`](crate::reference::Reference::Sine).
//!
//! # Cutting force
//!
//! The paper takes the mechanistic model of Wu's micro-milling thesis (its ref. \[7]): per tooth, a
//! tangential force `F_t = K_t·h·w` and a normal force `F_n = K_n·h·w` (Rubio eq (2)), with `h` the
//! undeformed chip thickness and `w` the axial depth of cut (Rubio eq (3) integrated over a
//! straight flute, helix neglected as in the paper's 2-D orthogonal assumption), projected onto the
//! feed axis with Rubio eq (4): on the tool, `F_x = −F_t cos φ − F_n sin φ`, where φ is the tooth
//! angle measured from the axis normal to the feed, growing with the spindle's rotation (Altintas'
//! convention). The table carries the workpiece, so the force on the table is `−F_x`.
//!
//! The operation is a full slot: a tooth cuts wherever the feed has a positive component along its
//! radius, so each tooth is engaged for half a turn and leaves the cut by itself.
//!
//! **Chip thickness with run-out.** The tool axis sits `runout_offset` off the spindle axis, at
//! `runout_angle` ahead of tooth 0, so tooth `j` cuts at radius
//! `r_j = R + r_o·cos(γ + 2πj/N)`. Tooth `j` meets the surface left by the tooth `k` places before
//! it, displaced by `k` feeds per tooth, and removes what lies above the deepest of those surfaces:
//! `h_j(φ) = max(0, min_{k=1..N} (k·f_z·sin φ + r_j − r_{j−k}))`, the circular-path form of Bao &
//! Tansel's run-out chip (Int. J. Mach. Tools Manuf. 40 (2000) 2155–2173). When run-out exceeds
//! half the feed per tooth one tooth cuts for both, which is what makes micro-milling forces
//! repeat once per spindle turn instead of once per tooth.
//!
//! **What the force depends on.** The feed per tooth follows the table's own motion, taken
//! quasi-statically: `f_z = |v|·2π/(N·Ω)` with `v` the table velocity relative to the (axially
//! fixed) spindle, and the tool's feed into the workpiece is opposite to the table's motion. So
//! [`MicroMillingCut::force_on_axis`] takes the time (for the tool angle `Ω·t + φ₀`) and the table
//! velocity. With the paper's sine reference (peak 3 µm/s) the feed per tooth is at most 7.8 nm,
//! and averaged over a turn the cut acts as a viscous drag `(π/2)·K_n·w/Ω·v` ≈ 195 N·s/m on the
//! table, with a ripple at the tooth-passing (or, under run-out, the spindle) frequency on top.
//!
//! # Cutting coefficients
//!
//! The paper gives none. The defaults, `K_t` = 4,000 N/mm² and `K_n` = 3,000 N/mm² (4 and 3 GPa in
//! SI), are round values for the size-effect regime of micro end milling, where the specific
//! cutting pressure rises from the ≈10³ N/mm² of conventional milling of steels and aluminium
//! (Altintas, *Manufacturing Automation*, 2nd ed., 2012, ch. 2) to several 10³ N/mm² as the chip
//! thins towards the cutting-edge radius, and the normal (ploughing) share grows (Bao & Tansel
//! 2000; Malekian, Park & Jun, Int. J. Mach. Tools Manuf. 49 (2009) 586–598; Lai et al., Int. J.
//! Mach. Tools Manuf. 48 (2008) 1–14). They are representative orders of magnitude, not a fit to
//! one material; a scenario sets its own.

use serde::Deserialize;
use std::f64::consts::{PI, TAU};
use thiserror::Error;

/// The paper's spindle speed, rpm (converted to rad/s in [`MicroMillingParams::default`]).
const PAPER_SPINDLE_SPEED_RPM: f64 = 11_520.0;

/// Parameters of the cut (SI units: m, rad/s, N/m², rad).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MicroMillingParams {
    /// Spindle speed Ω, rad/s. Default: the paper's 11,520 rpm = 1,206.4 rad/s.
    pub spindle_speed: f64,
    /// Number of teeth N. Default 2 (tooth passing at 384 Hz with the default speed).
    pub teeth: u32,
    /// Cutter diameter, m. Default 0.09 mm.
    pub cutter_diameter: f64,
    /// Axial depth of cut w, m. Default 0.05 mm.
    pub axial_depth: f64,
    /// Tangential cutting coefficient K_t, N/m². Default 4,000 N/mm² (see the module doc).
    pub tangential_coefficient: f64,
    /// Normal (radial) cutting coefficient K_n, N/m². Default 3,000 N/mm².
    pub normal_coefficient: f64,
    /// Offset r_o of the tool axis from the spindle axis, m. Default 1 µm, the order measured on
    /// collet-held micro end mills (e.g. Attanasio, Micromachines 8 (2017) 221).
    pub runout_offset: f64,
    /// Angle γ from tooth 0 to the run-out offset, rad, counted with the rotation. Default 0.
    pub runout_angle: f64,
    /// Angle φ₀ of tooth 0 at t = 0, rad. Default 0.
    pub initial_angle: f64,
}

impl Default for MicroMillingParams {
    /// The paper's cutting conditions (§V) with the coefficients of the module doc.
    fn default() -> Self {
        Self {
            spindle_speed: PAPER_SPINDLE_SPEED_RPM * TAU / 60.0,
            teeth: 2,
            cutter_diameter: 0.09e-3,
            axial_depth: 0.05e-3,
            tangential_coefficient: 4_000.0e6,
            normal_coefficient: 3_000.0e6,
            runout_offset: 1.0e-6,
            runout_angle: 0.0,
            initial_angle: 0.0,
        }
    }
}

/// Why [`MicroMillingParams`] are rejected.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum MicroMillingError {
    /// The spindle speed or the cutter diameter is zero, negative or not finite; holds its name.
    #[error("micro-milling: {0} must be finite and > 0")]
    NotPositive(&'static str),
    /// The axial depth, a cutting coefficient or the run-out offset is negative or not finite;
    /// holds its name.
    #[error("micro-milling: {0} must be finite and ≥ 0")]
    Negative(&'static str),
    /// The run-out angle or the initial tooth angle is infinite or NaN; holds its name.
    #[error("micro-milling: {0} must be finite")]
    NotFinite(&'static str),
    /// The cutter has no teeth.
    #[error("micro-milling: teeth must be at least 1")]
    NoTeeth,
    /// The run-out offset reaches the cutter radius, which would leave a tooth no cutting radius.
    #[error("micro-milling: runout_offset ({offset} m) must be smaller than the cutter radius ({radius} m)")]
    RunoutTooLarge {
        /// Run-out offset r_o, m.
        offset: f64,
        /// Cutter radius R, m.
        radius: f64,
    },
}

/// A validated cut: evaluates the force the cut puts on the feed axis.
#[derive(Debug, Clone, PartialEq)]
pub struct MicroMillingCut {
    params: MicroMillingParams,
    /// Cutting radius of each tooth under run-out, m.
    tooth_radii: Vec<f64>,
}

impl MicroMillingCut {
    /// Checks the parameters and works out each tooth's cutting radius under run-out.
    pub fn new(params: MicroMillingParams) -> Result<Self, MicroMillingError> {
        let positive = [
            ("spindle_speed", params.spindle_speed),
            ("cutter_diameter", params.cutter_diameter),
        ];
        for (name, value) in positive {
            if !(value > 0.0 && value.is_finite()) {
                return Err(MicroMillingError::NotPositive(name));
            }
        }
        let non_negative = [
            ("axial_depth", params.axial_depth),
            ("tangential_coefficient", params.tangential_coefficient),
            ("normal_coefficient", params.normal_coefficient),
            ("runout_offset", params.runout_offset),
        ];
        for (name, value) in non_negative {
            if !(value >= 0.0 && value.is_finite()) {
                return Err(MicroMillingError::Negative(name));
            }
        }
        for (name, value) in [
            ("runout_angle", params.runout_angle),
            ("initial_angle", params.initial_angle),
        ] {
            if !value.is_finite() {
                return Err(MicroMillingError::NotFinite(name));
            }
        }
        if params.teeth == 0 {
            return Err(MicroMillingError::NoTeeth);
        }
        let radius = params.cutter_diameter / 2.0;
        if params.runout_offset >= radius {
            return Err(MicroMillingError::RunoutTooLarge {
                offset: params.runout_offset,
                radius,
            });
        }
        let pitch = TAU / f64::from(params.teeth);
        let tooth_radii = (0..params.teeth)
            .map(|j| {
                radius + params.runout_offset * (params.runout_angle + pitch * f64::from(j)).cos()
            })
            .collect();
        Ok(Self {
            params,
            tooth_radii,
        })
    }

    /// The parameters the cut was built from.
    pub fn params(&self) -> &MicroMillingParams {
        &self.params
    }

    /// Teeth passing a point per second, Hz (`N·Ω/2π`; 384 Hz for the paper's cut).
    pub fn tooth_passing_frequency(&self) -> f64 {
        f64::from(self.params.teeth) * self.params.spindle_speed / TAU
    }

    /// Feed per tooth f_z, m, when the table moves at `table_velocity` (m/s).
    pub fn feed_per_tooth(&self, table_velocity: f64) -> f64 {
        table_velocity.abs() * TAU / (f64::from(self.params.teeth) * self.params.spindle_speed)
    }

    /// Angle φ of `tooth` at `time`, rad (not wrapped).
    fn tooth_angle(&self, tooth: usize, time: f64) -> f64 {
        let pitch = TAU / f64::from(self.params.teeth);
        self.params.initial_angle + self.params.spindle_speed * time - pitch * tooth as f64
    }

    /// Undeformed chip thickness h of `tooth` (0-based) at `time`, m, with the table moving at
    /// `table_velocity` (m/s); `None` for a tooth the cutter does not have.
    pub fn chip_thickness(&self, tooth: usize, time: f64, table_velocity: f64) -> Option<f64> {
        let radius = *self.tooth_radii.get(tooth)?;
        let teeth = self.tooth_radii.len();
        // The tool feeds into the workpiece against the table's motion: along the table axis its
        // feed per tooth is −sign(v)·f_z, whose component along the tooth's radius is that times
        // sin φ.
        let feed_along_radius = -table_velocity.signum()
            * self.feed_per_tooth(table_velocity)
            * self.tooth_angle(tooth, time).sin();
        let deepest = (1..=teeth)
            .map(|back| {
                let earlier = self.tooth_radii[(tooth + teeth - back % teeth) % teeth];
                back as f64 * feed_along_radius + radius - earlier
            })
            .fold(f64::INFINITY, f64::min);
        Some(deepest.max(0.0))
    }

    /// Force of one tooth's cut on the table along its axis, N (positive along +x of the table
    /// axis); `None` for a tooth the cutter does not have.
    pub fn tooth_force_on_axis(&self, tooth: usize, time: f64, table_velocity: f64) -> Option<f64> {
        let chip = self.chip_thickness(tooth, time, table_velocity)?;
        let (sin, cos) = self.tooth_angle(tooth, time).sin_cos();
        let tangential = self.params.tangential_coefficient * chip * self.params.axial_depth;
        let normal = self.params.normal_coefficient * chip * self.params.axial_depth;
        // Rubio eq (4) gives the force on the tool; the workpiece, and so the table, takes the
        // reaction.
        Some(tangential * cos + normal * sin)
    }

    /// The cutting force on the table along its axis, N, at `time` (s) with the table moving at
    /// `table_velocity` (m/s): the sum over the teeth of
    /// [`tooth_force_on_axis`](Self::tooth_force_on_axis). Zero when the table stands still.
    pub fn force_on_axis(&self, time: f64, table_velocity: f64) -> f64 {
        (0..self.tooth_radii.len())
            .filter_map(|tooth| self.tooth_force_on_axis(tooth, time, table_velocity))
            .sum()
    }

    /// The viscous drag the cut exerts on the table averaged over a spindle turn without run-out,
    /// N·s/m: `(π/2)·K_n·w/Ω` (independent of the number of teeth).
    pub fn mean_drag_coefficient(&self) -> f64 {
        PI / 2.0 * self.params.normal_coefficient * self.params.axial_depth
            / self.params.spindle_speed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cut(runout_offset: f64) -> MicroMillingCut {
        MicroMillingCut::new(MicroMillingParams {
            runout_offset,
            ..Default::default()
        })
        .unwrap()
    }

    /// Table velocity giving a feed per tooth of `feed` (m) with the paper's spindle and teeth.
    fn velocity_for_feed(feed: f64) -> f64 {
        let p = MicroMillingParams::default();
        feed * f64::from(p.teeth) * p.spindle_speed / TAU
    }

    #[test]
    fn paper_conditions_convert_to_si() {
        let cut = cut(0.0);
        assert!((cut.params().spindle_speed - 1206.371).abs() < 1e-3);
        assert!((cut.tooth_passing_frequency() - 384.0).abs() < 1e-9);
        // The sine reference's peak feed, 3 µm/s, is 7.8 nm per tooth.
        assert!((cut.feed_per_tooth(-3e-6) - 3e-6 / 384.0).abs() < 1e-18);
    }

    #[test]
    fn force_repeats_every_tooth_without_runout() {
        let cut = cut(0.0);
        let velocity = velocity_for_feed(1e-6);
        let tooth_period = 1.0 / cut.tooth_passing_frequency();
        let mut largest: f64 = 0.0;
        for i in 0..200 {
            let t = 0.013 + i as f64 * tooth_period / 200.0;
            let now = cut.force_on_axis(t, velocity);
            let later = cut.force_on_axis(t + 3.0 * tooth_period, velocity);
            assert!(
                (now - later).abs() < 1e-9 * (1.0 + now.abs()),
                "t = {t}: {now} vs {later}"
            );
            largest = largest.max(now.abs());
        }
        assert!(largest > 0.01, "the cut must load the axis: {largest}");
    }

    #[test]
    fn runout_repeats_per_turn_not_per_tooth() {
        let cut = cut(0.3e-6);
        let velocity = velocity_for_feed(1e-6);
        let tooth_period = 1.0 / cut.tooth_passing_frequency();
        let turn = 2.0 * tooth_period;
        let mut per_tooth_difference: f64 = 0.0;
        for i in 0..200 {
            let t = i as f64 * turn / 200.0;
            let now = cut.force_on_axis(t, velocity);
            assert!((now - cut.force_on_axis(t + turn, velocity)).abs() < 1e-9);
            per_tooth_difference = per_tooth_difference
                .max((now - cut.force_on_axis(t + tooth_period, velocity)).abs());
        }
        assert!(per_tooth_difference > 0.01, "{per_tooth_difference}");
    }

    #[test]
    fn runout_loads_the_teeth_unequally() {
        // 0.3 µm of run-out at 1 µm per tooth: the long tooth takes 1 + 2·0.3 µm at the slot
        // centre, the short one 1 − 2·0.3 µm.
        let cut = cut(0.3e-6);
        let velocity = velocity_for_feed(1e-6);
        let turn = TAU / cut.params().spindle_speed;
        let peak = |tooth: usize| {
            (0..2000)
                .map(|i| {
                    cut.chip_thickness(tooth, i as f64 * turn / 2000.0, velocity)
                        .unwrap()
                })
                .fold(0.0, f64::max)
        };
        assert!((peak(0) - 1.6e-6).abs() < 1e-9, "{}", peak(0));
        assert!((peak(1) - 0.4e-6).abs() < 1e-9, "{}", peak(1));
        // Run-out larger than half the feed: the short tooth cuts nothing, the long one cuts both
        // teeth's share.
        let heavy = MicroMillingCut::new(MicroMillingParams::default()).unwrap();
        let creep = -3e-6;
        let peak_force = |tooth: usize| {
            (0..2000)
                .map(|i| {
                    heavy
                        .tooth_force_on_axis(tooth, i as f64 * turn / 2000.0, creep)
                        .unwrap()
                        .abs()
                })
                .fold(0.0, f64::max)
        };
        assert_eq!(peak_force(1), 0.0);
        assert!(peak_force(0) > 0.0);
    }

    #[test]
    fn no_force_off_the_cut() {
        let cut = cut(0.0);
        let velocity = velocity_for_feed(1e-6);
        // Table still: nothing is fed, so nothing is cut, run-out or not.
        for t in [0.0, 1e-4, 7.3e-4] {
            assert_eq!(cut.force_on_axis(t, 0.0), 0.0);
            assert_eq!(self::cut(1e-6).force_on_axis(t, 0.0), 0.0);
        }
        // The table moving +x feeds the tool towards −x: tooth 0 cuts for sin φ < 0 only.
        let turn = TAU / cut.params().spindle_speed;
        for i in 0..100 {
            let t = i as f64 * turn / 200.0; // φ₀ in [0, π): tooth 0 faces away from the feed
            assert_eq!(cut.tooth_force_on_axis(0, t, velocity).unwrap(), 0.0);
            assert!(
                cut.chip_thickness(0, t + turn / 2.0 + 1e-7, velocity)
                    .unwrap()
                    > 0.0
            );
        }
        // No flute in the cut.
        let shallow = MicroMillingCut::new(MicroMillingParams {
            axial_depth: 0.0,
            ..Default::default()
        })
        .unwrap();
        assert_eq!(shallow.force_on_axis(1e-3, velocity), 0.0);
        assert_eq!(cut.tooth_force_on_axis(2, 0.0, velocity), None);
    }

    #[test]
    fn force_magnitude_and_mean_drag() {
        let cut = cut(0.0);
        // 1 µm per tooth, a usual micro-milling feed: peak tangential load K_t·f_z·w = 0.2 N,
        // the order of forces measured on sub-0.1 mm end mills.
        let velocity = velocity_for_feed(1e-6);
        let turn = TAU / cut.params().spindle_speed;
        let samples: Vec<f64> = (0..4000)
            .map(|i| cut.force_on_axis(i as f64 * turn / 4000.0, velocity))
            .collect();
        let peak = samples.iter().fold(0.0_f64, |m, f| m.max(f.abs()));
        assert!(peak > 0.1 && peak < 0.5, "peak {peak} N");
        // The mean opposes the table's motion, as the viscous drag (π/2)·K_n·w/Ω.
        let mean = samples.iter().sum::<f64>() / samples.len() as f64;
        let drag = cut.mean_drag_coefficient();
        assert!((drag - 195.3).abs() < 0.1, "{drag}");
        assert!(
            (mean + drag * velocity).abs() < 1e-3 * drag * velocity,
            "{mean}"
        );
        // The paper's sine: milli-newtons at its 3 µm/s peak.
        let creep = (0..4000)
            .map(|i| cut.force_on_axis(i as f64 * turn / 4000.0, 3e-6).abs())
            .fold(0.0, f64::max);
        assert!(creep > 5e-4 && creep < 5e-3, "{creep}");
    }

    #[test]
    fn reversing_the_feed_mirrors_the_force() {
        let cut = cut(0.0);
        let velocity = velocity_for_feed(0.5e-6);
        let half_turn = PI / cut.params().spindle_speed;
        for i in 0..50 {
            let t = i as f64 * 1.7e-5;
            let forward = cut.force_on_axis(t, velocity);
            let back = cut.force_on_axis(t + half_turn, -velocity);
            assert!((forward + back).abs() < 1e-12, "{forward} vs {back}");
        }
    }

    #[test]
    fn rejects_bad_cuts() {
        let bad =
            |params: MicroMillingParams| MicroMillingCut::new(params).unwrap_err().to_string();
        let d = MicroMillingParams::default();
        assert!(bad(MicroMillingParams {
            spindle_speed: 0.0,
            ..d
        })
        .contains("spindle_speed"));
        assert!(bad(MicroMillingParams { teeth: 0, ..d }).contains("teeth"));
        assert!(bad(MicroMillingParams {
            axial_depth: -1e-6,
            ..d
        })
        .contains("axial_depth"));
        assert!(bad(MicroMillingParams {
            normal_coefficient: f64::NAN,
            ..d
        })
        .contains("normal"));
        assert!(bad(MicroMillingParams {
            runout_offset: 0.05e-3,
            ..d
        })
        .contains("runout_offset"));
        assert!(bad(MicroMillingParams {
            initial_angle: f64::INFINITY,
            ..d
        })
        .contains("initial"));
    }
}
