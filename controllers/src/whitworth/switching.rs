//! The switching criterion of the paper's Fig. 4 and the open-loop return stroke (§3, §6.2).
//!
//! **Stroke recognition.** The ram moves one way in the cutting stroke and the other way in the
//! return stroke; the cutting direction is known off-line (the twin's crank turns clockwise, q
//! falling, and cuts on the way down, ẏ < 0). Comparing the sign of the measured ram velocity
//! with it tells the strokes apart (eq 1 holds, task-space control is allowed, exactly while they
//! agree). Here the comparison is made with a small dead band and, to keep sensor ripple at the
//! stroke ends from toggling the mode, the ram must also be on the matching half of the stroke:
//! the cutting stroke is left only past mid-stroke on the cutting side, the return stroke only
//! past mid-stroke on the return side. While the ram stands still (at the start of a run) the
//! stroke is read from the crank angle: where `ρ_y` has the cutting sign, the cut is under way.
//!
//! **Return torques.** The paper returns the crank open loop with +8.65 N·m and, from mid-stroke,
//! −8 N·m, for its unpublished prototype inertia; those numbers do not carry over. Here the return
//! keeps the same two-part shape, drive then hold back, sized for the twin's linkage by an
//! energy balance on [`Dynamics`]: part 1 applies the drive torque `T₁` (a parameter) in the
//! turning direction from the bottom singular point until the ram passes mid-stroke; part 2
//! applies the `T₂` that makes the crank arrive at the top singular point with the speed the
//! profile's first blend asks for, `ω = √(|ẍ_blend|/|y″(q_top)|)` (at a singular point
//! `ÿ = y″(q)·q̇²`), starting from the speed the last blend leaves at the bottom. Friction is not
//! modelled; the closed loop absorbs the remainder at the hand-over.
//!
//! [`Dynamics`]: models::whitworth_dynamics::Dynamics

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
    ReturnDrive,
    /// Return stroke, part 2 (from mid-stroke): open-loop hold-back torque.
    ReturnHold,
}

impl Mode {
    /// The number recorded for the mode: 0 tracking, 1 cutting, 2 return part 1, 3 return part 2.
    pub fn number(self) -> f64 {
        match self {
            Mode::Tracking => 0.0,
            Mode::Cutting => 1.0,
            Mode::ReturnDrive => 2.0,
            Mode::ReturnHold => 3.0,
        }
    }
}

/// Dead band on the ram speed for the sign comparison, m/s.
pub const SPEED_DEAD_BAND: f64 = 0.01;

/// The open-loop return stroke designed for one linkage and profile.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReturnPlan {
    /// Part-1 torque, N·m, signed in the joint's convention (negative turns the crank clockwise).
    pub drive_torque: f64,
    /// Part-2 torque, N·m, signed likewise.
    pub hold_torque: f64,
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
        let drive_torque = -drive;
        let hold_torque = (energy_change - drive_torque * (q_mid - q_bottom)) / (q_top - q_mid);
        Ok(Self {
            drive_torque,
            hold_torque,
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
                Mode::ReturnDrive
            }
            Some(Mode::ReturnDrive) if past_mid < 0.0 => Mode::ReturnHold,
            Some(Mode::ReturnHold) if along_cut > SPEED_DEAD_BAND => Mode::Cutting,
            Some(mode) => mode,
        };
        let changed = self.mode != Some(next);
        self.mode = Some(next);
        changed.then_some(next)
    }

    fn return_part(past_mid: f64) -> Mode {
        if past_mid > 0.0 {
            Mode::ReturnDrive
        } else {
            Mode::ReturnHold
        }
    }
}
