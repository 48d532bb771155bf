//! The switching criterion of the paper's Fig. 4 and the open-loop return stroke (§3, §6.2).
//!
//! **Stroke recognition.** The ram moves one way in the cutting stroke and the other way in the
//! return stroke; the cutting direction is known off-line (the twin's crank turns clockwise, q
//! falling, and cuts on the way down, ẏ < 0). Comparing the sign of the measured ram velocity
//! with it tells the strokes apart (Perrusquía eq (1) holds, task-space control is allowed, exactly
//! while they agree). Here the comparison is made with a small dead band and, to keep sensor ripple
//! at the stroke ends from toggling the mode, the ram must also be on the matching half of the
//! stroke: the cutting stroke is left only past mid-stroke on the cutting side, the return stroke
//! only past mid-stroke on the return side. While the ram stands still (at the start of a run) the
//! stroke is read from the crank angle: where `ρ_y` has the cutting sign, the cut is under way.
//!
//! **Return torques.** The paper returns the crank open loop with +8.65 N·m and, from mid-stroke,
//! −8 N·m, for a prototype whose inertia it does not publish, so the numbers cannot be scaled.
//! Here the return keeps the same two parts, sized for the twin's linkage by an energy balance on
//! [`Dynamics`]: part 1 applies the drive torque `T₁` (a parameter) in the turning direction from
//! the bottom singular point until the ram passes mid-stroke; part 2 applies the `T₂` that makes
//! the crank arrive at the top singular point with the speed the profile's first blend asks for,
//! `ω = √(|ẍ_blend|/|y″(q_top)|)` (at a singular point `ÿ = y″(q)·q̇²`), starting from the speed
//! the last blend leaves at the bottom. The twin's return must lift the linkage by 76.7 J and
//! speed the crank up from 5.9 to 10.1 rad/s (65 J more), 142 J over 2.64 rad of crank travel,
//! so T₂ holds back (the paper's sign pattern) only for `T₁ ≳ 114 N·m`; with the default
//! `T₁ = 80 N·m` it still drives, at 30 N·m. A larger T₁ shortens the return but enlarges the
//! torque step at the bottom switch. Friction is not modelled; the closed loop absorbs the
//! remainder at the hand-over.
//!
//! [`Dynamics`]: models::whitworth::dynamics::Dynamics

use super::slider::SliderModel;
use models::velocity_profile::VelocityProfile;
use std::f64::consts::TAU;

/// What drives the crank.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Closed loop on the scenario's reference (no stroke switching).
    Tracking,
    /// Cutting stroke: the task-space law, between the singular points.
    Cutting,
    /// Return stroke, part 1: open-loop drive torque.
    ReturnPart1,
    /// Return stroke, part 2 (from mid-stroke): open-loop torque landing the crank at the top.
    ReturnPart2,
}

impl Mode {
    /// The number recorded for the mode: 0 tracking, 1 cutting, 2 return part 1, 3 return part 2.
    pub fn number(self) -> f64 {
        match self {
            Mode::Tracking => 0.0,
            Mode::Cutting => 1.0,
            Mode::ReturnPart1 => 2.0,
            Mode::ReturnPart2 => 3.0,
        }
    }

    /// The mode's identifier in [`framework::EventKind::ModeSwitch`] events.
    pub fn identifier(self) -> &'static str {
        match self {
            Mode::Tracking => "tracking",
            Mode::Cutting => "cutting_stroke",
            Mode::ReturnPart1 => "return_stroke_1",
            Mode::ReturnPart2 => "return_stroke_2",
        }
    }
}

/// Dead band on the ram speed for the sign comparison, m/s.
pub const SPEED_DEAD_BAND: f64 = 0.01;

/// The open-loop return stroke designed for one linkage and profile.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReturnPlan {
    /// Part-1 torque, N·m, signed in the joint's convention (negative turns the crank clockwise).
    pub part1_torque: f64,
    /// Part-2 torque, N·m, signed likewise.
    pub part2_torque: f64,
    /// Mid-stroke ram height where part 2 starts, m.
    pub mid_stroke: f64,
    /// Crank speed the last blend leaves at the bottom singular point, rad/s (signed).
    pub bottom_speed: f64,
    /// Crank speed the first blend asks for at the top singular point, rad/s (signed).
    pub top_speed: f64,
}

/// Why a return stroke cannot be planned.
#[derive(Debug, Clone, PartialEq)]
pub struct ReturnPlanError(pub String);

impl ReturnPlan {
    /// Plans the return for a part-1 drive torque of magnitude `drive` N·m.
    pub fn design(
        slider: &SliderModel,
        profile: &VelocityProfile,
        drive: f64,
    ) -> Result<Self, ReturnPlanError> {
        if !(drive.is_finite() && drive > 0.0) {
            return Err(ReturnPlanError(format!(
                "return_drive_torque must be > 0 and finite, got {drive}"
            )));
        }
        let geometry = slider.geometry();
        let dynamics = slider.dynamics();
        let stroke = slider.stroke();
        // The crank turns clockwise: from the bottom, the return runs over q ∈ (q_b − travel, q_b).
        let q_bottom = stroke.bottom_crank_angle;
        let q_top = q_bottom - (TAU - stroke.cutting_crank_travel());
        let mid_stroke = 0.5 * (stroke.top + stroke.bottom);
        let q_mid = bisect(q_top, q_bottom, |q| geometry.ram_position(q) - mid_stroke);
        let acceleration = profile.blend_acceleration().abs();
        let speed_at = |q: f64| {
            let h = 1e-6;
            let curvature =
                (geometry.ram_jacobian(q + h) - geometry.ram_jacobian(q - h)) / (2.0 * h);
            (acceleration / curvature.abs()).sqrt()
        };
        let (top_speed, bottom_speed) = (-speed_at(q_top), -speed_at(q_bottom));
        if !(top_speed.is_finite() && bottom_speed.is_finite()) {
            return Err(ReturnPlanError(
                "the ram does not turn smoothly at the stroke ends (y″ = 0)".into(),
            ));
        }
        let energy_change =
            dynamics.energy(q_top, top_speed) - dynamics.energy(q_bottom, bottom_speed);
        let part1_torque = -drive;
        let part2_torque = (energy_change - part1_torque * (q_mid - q_bottom)) / (q_top - q_mid);
        Ok(Self {
            part1_torque,
            part2_torque,
            mid_stroke,
            bottom_speed,
            top_speed,
        })
    }
}

/// The root of `f` on `[low, high]`, where `f(low)` and `f(high)` differ in sign.
fn bisect(mut low: f64, mut high: f64, f: impl Fn(f64) -> f64) -> f64 {
    let low_sign = f(low).signum();
    for _ in 0..100 {
        let mid = 0.5 * (low + high);
        if f(mid).signum() == low_sign {
            low = mid;
        } else {
            high = mid;
        }
    }
    0.5 * (low + high)
}

/// The Fig. 4 criterion as a small state machine over the cutting and return-stroke modes.
#[derive(Debug, Clone, PartialEq)]
pub struct StrokeSwitch {
    mid_stroke: f64,
    /// Sign of ẏ while cutting (−1: the twin cuts downward).
    cutting_sign: f64,
    mode: Option<Mode>,
}

impl StrokeSwitch {
    /// The criterion for `slider`'s stroke, with the return's part 2 from `mid_stroke` (ram
    /// height, m); no mode until the first update.
    pub fn new(slider: &SliderModel, mid_stroke: f64) -> Self {
        let stroke = slider.stroke();
        Self {
            mid_stroke,
            cutting_sign: (stroke.bottom - stroke.top).signum(),
            mode: None,
        }
    }

    /// Forgets the mode; the next update reads it afresh.
    pub fn reset(&mut self) {
        self.mode = None;
    }

    /// The current mode, or `None` before the first update.
    pub fn mode(&self) -> Option<Mode> {
        self.mode
    }

    /// Reads the stroke from the crank angle q, ram height y and ram velocity ẏ; returns the new
    /// mode when it changes (and on the first call).
    pub fn update(
        &mut self,
        slider: &SliderModel,
        q: f64,
        y: f64,
        ram_velocity: f64,
    ) -> Option<Mode> {
        // > 0: the ram moves the cutting way; < 0: the return way.
        let along_cut = ram_velocity * self.cutting_sign;
        // > 0: the ram is on the cutting-end half of the stroke.
        let past_mid = (y - self.mid_stroke) * self.cutting_sign;
        let next = match self.mode {
            None if along_cut > SPEED_DEAD_BAND => Mode::Cutting,
            None if along_cut < -SPEED_DEAD_BAND => Self::return_part(past_mid),
            None if slider.in_cutting_stroke(q) => Mode::Cutting,
            None => Self::return_part(past_mid),
            Some(Mode::Cutting) if along_cut < -SPEED_DEAD_BAND && past_mid > 0.0 => {
                Mode::ReturnPart1
            }
            Some(Mode::ReturnPart1) if past_mid < 0.0 => Mode::ReturnPart2,
            Some(Mode::ReturnPart2) if along_cut > SPEED_DEAD_BAND => Mode::Cutting,
            Some(mode) => mode,
        };
        let changed = self.mode != Some(next);
        self.mode = Some(next);
        changed.then_some(next)
    }

    fn return_part(past_mid: f64) -> Mode {
        if past_mid > 0.0 {
            Mode::ReturnPart1
        } else {
            Mode::ReturnPart2
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use models::velocity_profile::ProfileParams;
    use models::whitworth::dynamics::{Dynamics, LinkMasses};
    use models::whitworth::Geometry;

    fn twin() -> (SliderModel, VelocityProfile) {
        let slider = SliderModel::new(
            Dynamics::new(Geometry::default(), LinkMasses::default(), 9.81).unwrap(),
        )
        .unwrap();
        let stroke = *slider.stroke();
        let profile = VelocityProfile::new(&ProfileParams {
            x_min: stroke.top,
            x_max: stroke.bottom,
            workpiece_length: 0.3,
            velocity: -1.25,
        })
        .unwrap();
        (slider, profile)
    }

    #[test]
    fn planned_return_lands_on_the_hand_over_speed() {
        let (slider, profile) = twin();
        let plan = ReturnPlan::design(&slider, &profile, 80.0).unwrap();
        assert_eq!(plan.part1_torque, -80.0);
        assert!((plan.mid_stroke - (0.05428 - 0.41242) / 2.0).abs() < 1e-9);
        // At a singular point ÿ = y″·q̇², which must equal the blend's |ẍ| = 9.373 m/s².
        assert!((plan.top_speed + 10.09).abs() < 0.01, "{}", plan.top_speed);
        assert!(
            (plan.bottom_speed + 5.94).abs() < 0.01,
            "{}",
            plan.bottom_speed
        );
        // Integrate the return open loop from the bottom; the crank reaches the top at top_speed.
        let d = slider.dynamics();
        let top =
            slider.stroke().bottom_crank_angle - (TAU - slider.stroke().cutting_crank_travel());
        let (mut q, mut w, dt) = (slider.stroke().bottom_crank_angle, plan.bottom_speed, 1e-5);
        while q > top {
            let past_mid = d.geometry().ram_position(q) > plan.mid_stroke;
            let torque = if past_mid {
                plan.part2_torque
            } else {
                plan.part1_torque
            };
            let a = d.crank_acceleration(q, w, torque, 0.0);
            w += a * dt;
            q += w * dt;
        }
        assert!((w - plan.top_speed).abs() < 0.02, "arrives at {w} rad/s");
    }

    #[test]
    fn bad_drive_torque_is_rejected() {
        let (slider, profile) = twin();
        for drive in [0.0, -5.0, f64::NAN] {
            let err = ReturnPlan::design(&slider, &profile, drive).unwrap_err();
            assert!(err.0.contains("return_drive_torque"), "{}", err.0);
        }
    }

    #[test]
    fn strokes_follow_the_ram_velocity() {
        let (slider, _) = twin();
        let stroke = *slider.stroke();
        let mid = 0.5 * (stroke.top + stroke.bottom);
        let mut switch = StrokeSwitch::new(&slider, mid);
        // At rest just past the top: the crank is in the cutting half.
        let q_start = stroke.top_crank_angle - 0.2;
        assert_eq!(
            switch.update(&slider, q_start, 0.05, 0.0),
            Some(Mode::Cutting)
        );
        assert_eq!(switch.update(&slider, q_start, 0.0, -1.2), None);
        // Ripple of the ram speed near the bottom does not end the cut before mid-stroke …
        assert_eq!(switch.update(&slider, 0.0, -0.1, 0.5), None);
        // … past it, the ram turning back does.
        assert_eq!(
            switch.update(&slider, -1.9, -0.41, 0.2),
            Some(Mode::ReturnPart1)
        );
        assert_eq!(switch.update(&slider, -2.5, -0.3, 2.0), None);
        assert_eq!(
            switch.update(&slider, -3.3, -0.1, 3.0),
            Some(Mode::ReturnPart2)
        );
        assert_eq!(switch.update(&slider, -4.4, 0.054, 0.005), None);
        assert_eq!(
            switch.update(&slider, -4.5, 0.054, -0.05),
            Some(Mode::Cutting)
        );
        assert_eq!(switch.mode(), Some(Mode::Cutting));
        switch.reset();
        assert_eq!(switch.mode(), None);
        // At rest in the return half, below mid-stroke: part 1.
        assert_eq!(
            switch.update(&slider, -2.2, -0.38, 0.0),
            Some(Mode::ReturnPart1)
        );
    }

    #[test]
    fn modes_are_numbered() {
        let numbers = [
            Mode::Tracking,
            Mode::Cutting,
            Mode::ReturnPart1,
            Mode::ReturnPart2,
        ]
        .map(Mode::number);
        assert_eq!(numbers, [0.0, 1.0, 2.0, 3.0]);
    }
}
