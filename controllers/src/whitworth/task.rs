//! What the four Whitworth task-space controllers share: the task parameters, the reference, the
//! plant binding, the switching criterion and the Jacobian compensator. Each controller only
//! supplies its law `u = f(e, …)` on the slider (a [`TaskLaw`]); [`TaskController`] turns it into
//! crank torque `τ = ρ̂·u` (Perrusquía eqs (11), (33)) in the cutting stroke and applies the
//! open-loop return.
//!
//! **Which reference.** `reference = "profile"` builds the Algorithm 1 profile (Perrusquía eqs
//! (2)–(5)) from the linkage's stroke ends, `workpiece_length` and `cutting_velocity`, restarts it
//! at each cutting stroke and uses the switching criterion (the cutting task). `reference =
//! "scenario"` tracks the scenario's `reference`, `reference_rate`, `reference_acceleration`
//! signals in closed loop all the time, without stroke switching (the tracking task: the reference
//! stays inside the stroke). `reference = "auto"` (the default) picks "scenario" when the plant
//! measures a `reference` signal and "profile" otherwise, so a scenario's `[reference]` table
//! decides the task even when `--controller` resets the parameters to their defaults.
//!
//! **Signals.** Reads `crank_angle` (for ρ̂ and the model's gravity), `ram_position`,
//! `ram_velocity` and, when tracking, the reference; drives the `joint` actuator (`crank`).
//! Records `mode` (0 tracking, 1 cutting, 2 and 3 the return parts), `reference`,
//! `reference_rate`, `position_error`, `velocity_error`, `u`, `rho_hat`, `torque` (as commanded;
//! the twin clips it to the actuator's limit and reports saturation) and the law's own signals,
//! and raises an event at each mode switch.

use super::slider::SliderModel;
use super::switching::{Mode, ReturnPlan, StrokeSwitch};
use crate::check::positive;
use framework::Event;
use framework::{Controller, ControllerError, Measurement, PlantInterface, SignalSpec, Unit};
use models::velocity_profile::{ProfileError, ProfileParams, ProfileSample, VelocityProfile};
use models::whitworth::dynamics::{Dynamics, DynamicsError, LinkMasses};
use models::whitworth::{Geometry, GeometryError};
use serde::Deserialize;

/// Where the reference comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ReferenceChoice {
    /// The scenario's reference if the plant measures one, else the profile.
    #[default]
    Auto,
    /// Algorithm 1's constant-cutting-velocity profile, with the switching criterion.
    Profile,
    /// The scenario's reference signals, always in closed loop.
    Scenario,
}

/// The task, shared by the Whitworth controllers as their `[controller.params.task]` table.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct TaskParams {
    /// The actuated crank joint.
    pub joint: String,
    /// Where the reference comes from: Algorithm 1's profile, the scenario's, or `auto`.
    pub reference: ReferenceChoice,
    /// `L_d`, m (Algorithm 1).
    pub workpiece_length: f64,
    /// `v`, m/s, signed: the twin cuts downward, so v < 0.
    pub cutting_velocity: f64,
    /// `|T₁|`, N·m: the open-loop torque of return part 1, applied in the turning direction.
    pub return_drive_torque: f64,
    /// The model's acceleration of gravity (along −y), m/s².
    pub gravity: f64,
    /// The model's linkage dimensions.
    pub geometry: Geometry,
    /// The model's link masses.
    pub masses: LinkMasses,
}

impl Default for TaskParams {
    /// The paper's §6.2 task on the twin's linkage: L_d = 0.3 m, v = −1.25 m/s.
    fn default() -> Self {
        Self {
            joint: "crank".into(),
            reference: ReferenceChoice::Auto,
            workpiece_length: 0.3,
            cutting_velocity: -1.25,
            return_drive_torque: 80.0,
            gravity: 9.81,
            geometry: Geometry::default(),
            masses: LinkMasses::default(),
        }
    }
}

/// The model-based pieces every Whitworth controller designs from its [`TaskParams`].
#[derive(Debug, Clone, PartialEq)]
pub struct TaskDesign {
    /// The slider model of the linkage, with `K_ρ` and the nominal mass m̄.
    pub slider: SliderModel,
    /// Algorithm 1 over the cutting stroke (top to bottom).
    pub profile: VelocityProfile,
    /// The open-loop return stroke: its two torques and where part 2 starts.
    pub return_plan: ReturnPlan,
}

impl TaskDesign {
    /// Builds the slider model, the profile and the return plan; every error names `controller`
    /// and the entry of `[controller.params.task]` at fault.
    pub fn new(controller: &str, params: &TaskParams) -> Result<Self, ControllerError> {
        let dynamics = Dynamics::new(params.geometry, params.masses, params.gravity)
            .map_err(|e| dynamics_error(controller, params, e))?;
        let slider =
            SliderModel::new(dynamics).map_err(|e| dynamics_error(controller, params, e))?;
        let stroke = *slider.stroke();
        let profile = VelocityProfile::new(&ProfileParams {
            x_min: stroke.top,
            x_max: stroke.bottom,
            workpiece_length: params.workpiece_length,
            velocity: params.cutting_velocity,
        })
        .map_err(|e| profile_error(controller, params, e))?;
        let drive = positive(
            controller,
            "task.return_drive_torque",
            params.return_drive_torque,
        )?;
        // With the drive torque checked, only the linkage can make the plan fail.
        let return_plan = ReturnPlan::design(&slider, &profile, drive)
            .map_err(|e| ControllerError::parameter_table(controller, "task.geometry", e.0))?;
        Ok(Self {
            slider,
            profile,
            return_plan,
        })
    }
}

/// A model error of the linkage, named by the entry of `task` that causes it.
fn dynamics_error(controller: &str, params: &TaskParams, error: DynamicsError) -> ControllerError {
    let parameter = |key: String, value: f64, reason: String| {
        ControllerError::parameter(controller, key, value, reason)
    };
    let geometry = &params.geometry;
    match error {
        DynamicsError::Geometry(GeometryError::NonPositive(what)) => {
            ControllerError::parameter_table(
                controller,
                "task.geometry",
                format!("{what} must be > 0"),
            )
        }
        DynamicsError::Geometry(GeometryError::CrankCannotTurn { distance, crank }) => {
            ControllerError::parameter(
                controller,
                "task.geometry.slot_pivot",
                format!("{:?}", geometry.slot_pivot),
                format!(
                    "must lie closer to the crank pivot than crank_length = {crank} m for the \
                     crank to turn fully (it is {distance} m away)"
                ),
            )
        }
        DynamicsError::Geometry(GeometryError::CouplerTooShort { coupler, needed }) => parameter(
            "task.geometry.coupler_length".into(),
            coupler,
            format!("must be > {needed} m to reach the guide at every slot angle"),
        ),
        DynamicsError::BadInertia { link, what, value } => parameter(
            format!("task.masses.{link}.{what}"),
            value,
            "must be finite and ≥ 0".into(),
        ),
        DynamicsError::BadCentre { link, value } => parameter(
            format!("task.masses.{link}.centre_of_mass"),
            value,
            "must be a finite number".into(),
        ),
        DynamicsError::Massless => ControllerError::parameter_table(
            controller,
            "task.masses",
            "must give the linkage some inertia (every mass and izz is 0)",
        ),
        DynamicsError::BadGravity(gravity) => parameter(
            "task.gravity".into(),
            gravity,
            "must be a finite number".into(),
        ),
    }
}

/// An Algorithm 1 error, named by the entry of `task` that causes it.
fn profile_error(controller: &str, params: &TaskParams, error: ProfileError) -> ControllerError {
    let (length, velocity) = (params.workpiece_length, params.cutting_velocity);
    let parameter = |key: &str, value: f64, reason: String| {
        ControllerError::parameter(controller, key, value, reason)
    };
    match error {
        ProfileError::NonPositiveWorkpiece { .. } => {
            parameter("task.workpiece_length", length, "must be > 0".into())
        }
        ProfileError::WorkpieceTooLong { stroke, .. } => parameter(
            "task.workpiece_length",
            length,
            format!("must be shorter than the stroke L_c = {stroke} m"),
        ),
        ProfileError::ZeroVelocity => {
            parameter("task.cutting_velocity", velocity, "must be non-zero".into())
        }
        ProfileError::WrongDirection { direction, .. } => parameter(
            "task.cutting_velocity",
            velocity,
            format!("must point along the cutting stroke, which runs {direction}"),
        ),
        ProfileError::DegenerateBlend {
            t_a, acceleration, ..
        } => parameter(
            "task.cutting_velocity",
            velocity,
            format!(
                "must leave a usable blend (t_a = {t_a:e} s, blend acceleration \
                 {acceleration:e} m/s²)"
            ),
        ),
        ProfileError::NonFinite {
            name: "workpiece_length",
            value,
        } => parameter(
            "task.workpiece_length",
            value,
            "must be a finite number".into(),
        ),
        ProfileError::NonFinite {
            name: "velocity",
            value,
        } => parameter(
            "task.cutting_velocity",
            value,
            "must be a finite number".into(),
        ),
        // The stroke ends, which the linkage sets.
        ProfileError::NonFinite { .. } | ProfileError::ZeroStroke { .. } => {
            ControllerError::parameter_table(controller, "task.geometry", error.to_string())
        }
    }
}

/// What a law sees each control period in closed loop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LawInput {
    /// s.
    pub time: f64,
    /// Control period, s.
    pub period: f64,
    /// `e = z_d − z = [y_d − y, ẏ_d − ẏ]` (Perrusquía eq (12)), m and m/s.
    pub error: [f64; 2],
    /// The reference `y_d`, `ẏ_d`, `ÿ_d` at this period: m, m/s, m/s².
    pub reference: ProfileSample,
    /// The model's gravity carried to u ([`SliderModel::gravity_input`]), N.
    pub gravity: f64,
    /// Largest |u| the actuator can deliver through the compensator, N.
    pub force_limit: f64,
}

/// A task-space law on the slider of Perrusquía eq (10).
pub trait TaskLaw: Send {
    /// The name used in mode events, e.g. `OSMC`.
    fn label(&self) -> &'static str;
    /// Clears all state before a run.
    fn reset(&mut self);
    /// Closed-loop control (re)starts at `time` with error `error` (each cutting stroke).
    fn restart(&mut self, time: f64, error: [f64; 2]);
    /// The slider force u, N.
    fn force(&mut self, input: &LawInput) -> f64;
    /// The law's own recorded signals, after the shared ones of the task controller.
    fn internals(&self) -> Vec<SignalSpec>;
    /// The law's signals after the last [`force`](Self::force), in the order of
    /// [`internals`](Self::internals).
    fn internal_values(&self, values: &mut [f64]);
}

/// The plant indices a Whitworth controller reads.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Signals {
    crank_angle: usize,
    ram_position: usize,
    ram_velocity: usize,
    /// `reference`, `reference_rate`, `reference_acceleration`, when tracking them.
    reference: Option<[usize; 3]>,
}

/// A [`TaskLaw`] with the compensator, the reference and the switching criterion around it.
pub struct TaskController<L> {
    name: &'static str,
    params: TaskParams,
    design: TaskDesign,
    law: L,
    signals: Signals,
    actuator: usize,
    effort_limit: f64,
    switch: StrokeSwitch,
    mode: Option<Mode>,
    /// When the current cutting stroke started, s.
    cut_start: f64,
    reference: ProfileSample,
    error: [f64; 2],
    force: f64,
    rho_hat: f64,
    torque: f64,
    events: Vec<Event>,
}

/// The controller-independent internal signals, in order.
/// How many of a task controller's internals are [`shared_internals`].
const SHARED_INTERNAL_COUNT: usize = 8;

/// The internals every Whitworth task controller records before its law's: the mode, the
/// reference it tracks (on the ram's plots), the errors, the slider force u, the estimated lever
/// ρ̂ (crank torque per slider force) and the crank torque.
fn shared_internals() -> Vec<SignalSpec> {
    vec![
        SignalSpec::new("mode", Unit::Dimensionless, "mode"),
        SignalSpec::new("reference", Unit::Millimetre, "ram position"),
        SignalSpec::new("reference_rate", Unit::MetrePerSecond, "ram velocity"),
        SignalSpec::new("position_error", Unit::Micrometre, "ram position error"),
        SignalSpec::new(
            "velocity_error",
            Unit::MillimetrePerSecond,
            "ram velocity error",
        ),
        SignalSpec::new("u", Unit::Newton, "slider force"),
        SignalSpec::new("rho_hat", Unit::Millimetre, "lever estimate"),
        SignalSpec::new("torque", Unit::NewtonMetre, "crank torque"),
    ]
}

impl<L: TaskLaw> TaskController<L> {
    /// The controller called `name` running `law` on the task `params`, designed as `design`.
    pub fn new(name: &'static str, params: TaskParams, design: TaskDesign, law: L) -> Self {
        let switch = StrokeSwitch::new(&design.slider, design.return_plan.mid_stroke);
        Self {
            name,
            params,
            design,
            law,
            signals: Signals::default(),
            actuator: 0,
            effort_limit: f64::INFINITY,
            switch,
            mode: None,
            cut_start: 0.0,
            reference: ProfileSample {
                position: 0.0,
                velocity: 0.0,
                acceleration: 0.0,
            },
            error: [0.0; 2],
            force: 0.0,
            rho_hat: 0.0,
            torque: 0.0,
            events: Vec::new(),
        }
    }

    /// The slider model, profile and return plan the controller was built with.
    pub fn design(&self) -> &TaskDesign {
        &self.design
    }

    /// The task-space law it runs in closed loop.
    pub fn law(&self) -> &L {
        &self.law
    }

    fn enter(&mut self, mode: Mode) {
        let plan = &self.design.return_plan;
        let text = match mode {
            Mode::Tracking => format!("tracking the scenario reference: {}", self.law.label()),
            Mode::Cutting => format!("cutting stroke: {}", self.law.label()),
            Mode::ReturnPart1 => format!(
                "return stroke part 1: open loop, τ = {:+.2} N·m",
                plan.part1_torque
            ),
            Mode::ReturnPart2 => format!(
                "return stroke part 2: open loop, τ = {:+.2} N·m",
                plan.part2_torque
            ),
        };
        self.events.push(Event::mode(mode.identifier(), text));
        self.mode = Some(mode);
    }

    fn reference_at(&self, measurement: &Measurement) -> ProfileSample {
        match self.signals.reference {
            Some([r, rate, acceleration]) => ProfileSample {
                position: measurement.get(r),
                velocity: measurement.get(rate),
                acceleration: measurement.get(acceleration),
            },
            None => self
                .design
                .profile
                .sample(measurement.time - self.cut_start),
        }
    }
}

impl<L: TaskLaw> Controller for TaskController<L> {
    fn name(&self) -> &str {
        self.name
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        self.actuator = plant.actuator(&self.params.joint)?;
        self.effort_limit = plant.actuators[self.actuator].effort_limit;
        let tracking = match self.params.reference {
            ReferenceChoice::Auto => plant.signal("reference").is_ok(),
            ReferenceChoice::Profile => false,
            ReferenceChoice::Scenario => true,
        };
        self.signals = Signals {
            crank_angle: plant.signal("crank_angle")?,
            ram_position: plant.signal("ram_position")?,
            ram_velocity: plant.signal("ram_velocity")?,
            reference: if tracking {
                Some([
                    plant.signal("reference")?,
                    plant.signal("reference_rate")?,
                    plant.signal("reference_acceleration")?,
                ])
            } else {
                None
            },
        };
        if !tracking {
            let plan = self.design.return_plan;
            for (part, torque) in [(1, plan.part1_torque), (2, plan.part2_torque)] {
                if torque.abs() > self.effort_limit {
                    return Err(ControllerError::parameter(
                        self.name,
                        "task.return_drive_torque",
                        self.params.return_drive_torque,
                        format!(
                            "must be lower: return stroke part {part} needs {torque:+.1} N·m, \
                             beyond the {} N·m limit of joint `{}`",
                            self.effort_limit, self.params.joint
                        ),
                    ));
                }
            }
        }
        self.law.reset();
        self.switch.reset();
        self.mode = None;
        self.cut_start = 0.0;
        self.error = [0.0; 2];
        self.force = 0.0;
        self.rho_hat = 0.0;
        self.torque = 0.0;
        self.events.clear();
        Ok(())
    }

    fn update(&mut self, measurement: &Measurement, period: f64, efforts: &mut [f64]) {
        let time = measurement.time;
        let q = measurement.get(self.signals.crank_angle);
        let y = measurement.get(self.signals.ram_position);
        let ram_velocity = measurement.get(self.signals.ram_velocity);
        let slider = &self.design.slider;
        let entered = if self.signals.reference.is_some() {
            self.mode.is_none().then_some(Mode::Tracking)
        } else {
            self.switch.update(slider, q, y, ram_velocity)
        };
        if let Some(mode) = entered {
            self.enter(mode);
            if matches!(mode, Mode::Cutting | Mode::Tracking) {
                self.cut_start = time;
                let start = self.reference_at(measurement);
                self.law
                    .restart(time, [start.position - y, start.velocity - ram_velocity]);
            }
        }
        let slider = &self.design.slider;
        self.rho_hat = slider.compensator(q);
        let torque = match self.mode {
            Some(Mode::ReturnPart1) => {
                self.force = 0.0;
                self.design.return_plan.part1_torque
            }
            Some(Mode::ReturnPart2) => {
                self.force = 0.0;
                self.design.return_plan.part2_torque
            }
            _ => {
                self.reference = self.reference_at(measurement);
                self.error = [
                    self.reference.position - y,
                    self.reference.velocity - ram_velocity,
                ];
                let input = LawInput {
                    time,
                    period,
                    error: self.error,
                    reference: self.reference,
                    gravity: slider.gravity_input(q),
                    force_limit: self.effort_limit / self.rho_hat.abs(),
                };
                self.force = self.law.force(&input);
                self.rho_hat * self.force
            }
        };
        // Clipping to the actuator limit is the twin's (it reports saturation).
        self.torque = torque;
        efforts[self.actuator] = torque;
    }

    fn internals(&self) -> Vec<SignalSpec> {
        let mut specs = shared_internals();
        specs.extend(self.law.internals());
        specs
    }

    fn internal_values(&self, values: &mut [f64]) {
        let (shared, own) = values.split_at_mut(SHARED_INTERNAL_COUNT);
        shared.copy_from_slice(&[
            self.mode.map_or(-1.0, Mode::number),
            self.reference.position,
            self.reference.velocity,
            self.error[0],
            self.error[1],
            self.force,
            self.rho_hat,
            self.torque,
        ]);
        self.law.internal_values(own);
    }

    fn drain_events(&mut self, events: &mut Vec<Event>) {
        events.append(&mut self.events);
    }
}
