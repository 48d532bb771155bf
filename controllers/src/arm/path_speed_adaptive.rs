//! `path-speed-adaptive`: the nonlinear adaptive correction of the continuous path speed of
//! Ilyukhin, Poduraev & Tatarintseva (DAAAM 2014, §2) on the machining arm.
//!
//! Each period the motor currents `I_i` of the three arm drives and the spindle pass through the
//! lead-lag filters `W_Fi(s) = (T_K3 s + 1)/(T_K4 s + 1)`; a motor is overloaded,
//! `R_i`, when `|I_i,F| > I_tol`; `R` is the OR of all; the speed demand is `V_II = V0` when no
//! motor is overloaded and 0 otherwise; and the path speed is `V_K = W_F0(s)·V_II` with
//! `W_F0(s) = (T_K1 s + 1)/(T_K2 s + 1)`, `T_K2 = 1/ω_c` by default (ω_c the joint servos'
//! open-loop crossover, as the paper recommends). Where no drive is overloaded `V_K` settles at
//! `V0`; where the cut overloads one, `R` switches fast and `V_K` oscillates about the largest
//! speed the drives can carry. The filters are [`FirstOrderFilter`]s (Tustin, at the control
//! period). The joints follow the program at `V_K` through [`ArmServo`].
//!
//! Defaults: the paper's `V0` = 20 mm/s and `I_tol` = 18 A (its Figs. 2–3; converted to m/s
//! here); the paper prints no time constants, so `T_K1`, `T_K3`, `T_K4` are the twin's tuning
//! (notes in `twin/src/machines/arm.rs`).

use super::servo::{ArmServo, ServoParams};
use crate::check::positive;
use crate::filters::{FilterError, FilterParameter, FirstOrderFilter};
use framework::Event;
use framework::{parse_params, Entry};
use framework::{Controller, ControllerError, Measurement, PlantInterface, SignalSpec, Unit};
use serde::Deserialize;

const NAME: &str = "path-speed-adaptive";

/// The paper's largest path speed V0, mm/s (Fig. 3).
pub const PAPER_PATH_SPEED_MM_S: f64 = 20.0;
/// The paper's permissible motor current, A (Fig. 2: −18 A).
pub const PAPER_CURRENT_TOLERANCE: f64 = 18.0;
/// The motors whose currents are watched: the arm's drives and the spindle.
pub const MOTORS: [&str; 4] = ["shoulder", "elbow", "wrist", "spindle"];
/// How long `R` must stay off before the correction counts as released (for events), s.
const RELEASE_AFTER: f64 = 0.5;

/// Parameters of `path-speed-adaptive` (SI units).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct PathSpeedAdaptiveParams {
    /// Largest path speed V0, m/s.
    pub path_speed: f64,
    /// Permissible motor current I_tol, A, for every motor.
    pub current_tolerance: f64,
    /// T_K1 of W_F0, s.
    pub speed_filter_lead: f64,
    /// T_K2 of W_F0, s; absent: 1/ω_c.
    pub speed_filter_lag: Option<f64>,
    /// T_K3 of W_Fi, s.
    pub current_filter_lead: f64,
    /// T_K4 of W_Fi, s.
    pub current_filter_lag: f64,
    /// The robot program and the joint servos, `[controller.params.servo]`.
    pub servo: ServoParams,
}

impl Default for PathSpeedAdaptiveParams {
    fn default() -> Self {
        Self {
            path_speed: PAPER_PATH_SPEED_MM_S * 1e-3,
            current_tolerance: PAPER_CURRENT_TOLERANCE,
            speed_filter_lead: 0.002,
            speed_filter_lag: None,
            current_filter_lead: 0.02,
            current_filter_lag: 0.005,
            servo: ServoParams::default(),
        }
    }
}

/// The filters and figures produced by [`design`].
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedCorrection {
    /// Largest path speed V0, m/s: the speed demand while no motor is overloaded.
    pub path_speed: f64,
    /// Permissible motor current I_tol, A.
    pub tolerance: f64,
    /// W_F0, from the speed demand V_II to the path speed V_K.
    pub speed_filter: FirstOrderFilter,
    /// W_Fi, applied to each motor current before the comparison with I_tol.
    pub current_filter: FirstOrderFilter,
}

/// Checks the parameters and builds W_F0 and W_Fi; T_K2 defaults to `1/crossover`.
pub fn design(
    params: &PathSpeedAdaptiveParams,
    crossover: f64,
) -> Result<SpeedCorrection, ControllerError> {
    positive(NAME, "path_speed", params.path_speed)?;
    positive(NAME, "current_tolerance", params.current_tolerance)?;
    let speed_filter = lead_lag(
        NAME,
        ("speed_filter_lead", params.speed_filter_lead),
        (
            "speed_filter_lag",
            params.speed_filter_lag.unwrap_or(1.0 / crossover),
        ),
    )?;
    let current_filter = lead_lag(
        NAME,
        ("current_filter_lead", params.current_filter_lead),
        ("current_filter_lag", params.current_filter_lag),
    )?;
    Ok(SpeedCorrection {
        path_speed: params.path_speed,
        tolerance: params.current_tolerance,
        speed_filter,
        current_filter,
    })
}

/// The lead-lag `(T_a s + 1)/(T_b s + 1)` of W_F0 or W_Fi from `controller`'s entries `lead_key`
/// (T_a) and `lag_key` (T_b), both > 0.
pub(crate) fn lead_lag(
    controller: &str,
    (lead_key, lead): (&str, f64),
    (lag_key, lag): (&str, f64),
) -> Result<FirstOrderFilter, ControllerError> {
    positive(controller, lead_key, lead)?;
    positive(controller, lag_key, lag)?;
    FirstOrderFilter::lead_lag(lead, lag).map_err(|e| match e {
        FilterError::Negative { .. } => e.for_parameter(controller, lead_key),
        FilterError::NotPositive { .. } => e.for_parameter(controller, lag_key),
    })
}

/// The running `path-speed-adaptive` controller: the joint servos following the program at the
/// path speed V_K that the filtered motor currents allow.
pub struct PathSpeedAdaptive {
    servo: ArmServo,
    correction: SpeedCorrection,
    current_signals: [usize; 4],
    current_filters: [FirstOrderFilter; 4],
    speed_filter: FirstOrderFilter,
    filtered: [f64; 4],
    overloaded: bool,
    demand: f64,
    path_speed: f64,
    /// Time of the last overload, and whether the correction is engaged (for events).
    last_overload: f64,
    engaged: bool,
    events: Vec<Event>,
}

impl PathSpeedAdaptive {
    /// Designs the servo and the speed correction; errors name the parameter at fault.
    pub fn new(params: PathSpeedAdaptiveParams) -> Result<Self, ControllerError> {
        let servo = ArmServo::new(NAME, params.servo.clone())?;
        let correction = design(&params, servo.design().crossover)?;
        Ok(Self {
            servo,
            current_signals: [0; 4],
            current_filters: std::array::from_fn(|_| correction.current_filter.clone()),
            speed_filter: correction.speed_filter.clone(),
            correction,
            filtered: [0.0; 4],
            overloaded: false,
            demand: 0.0,
            path_speed: 0.0,
            last_overload: f64::NEG_INFINITY,
            engaged: false,
            events: Vec::new(),
        })
    }
}

pub(crate) fn entry() -> Entry {
    Entry {
        name: NAME,
        machine: "arm",
        summary: "arm path speed corrected from the motor currents (Ilyukhin et al. 2014)",
        build: |table| {
            Ok(Box::new(PathSpeedAdaptive::new(parse_params(
                NAME, table,
            )?)?))
        },
    }
}

impl Controller for PathSpeedAdaptive {
    fn name(&self) -> &str {
        NAME
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        self.servo.reset(plant)?;
        for (signal, motor) in self.current_signals.iter_mut().zip(MOTORS) {
            *signal = plant.signal(&format!("{motor}_current"))?;
        }
        for filter in &mut self.current_filters {
            filter.reset();
        }
        self.speed_filter.reset();
        // The tool starts from rest: W_F0 primed at zero speed.
        self.speed_filter.update(0.0, 0.0);
        self.filtered = [0.0; 4];
        self.overloaded = false;
        self.demand = 0.0;
        self.path_speed = 0.0;
        self.last_overload = f64::NEG_INFINITY;
        self.engaged = false;
        self.events.clear();
        Ok(())
    }

    fn update(&mut self, measurement: &Measurement, period: f64, efforts: &mut [f64]) {
        let tolerance = self.correction.tolerance;
        let mut first_over = None;
        for (m, filter) in self.current_filters.iter_mut().enumerate() {
            self.filtered[m] = filter.update(measurement.get(self.current_signals[m]), period);
            if self.filtered[m].abs() > tolerance && first_over.is_none() {
                first_over = Some(m);
            }
        }
        self.overloaded = first_over.is_some();
        if self.servo.machining() {
            self.demand = if self.overloaded {
                0.0
            } else {
                self.correction.path_speed
            };
            self.path_speed = self.speed_filter.update(self.demand, period);
            if let Some(m) = first_over {
                self.last_overload = measurement.time;
                if !self.engaged {
                    self.engaged = true;
                    self.events.push(Event::mode(
                        "correction_engaged",
                        format!(
                            "path speed correction engaged: {} current over {tolerance} A",
                            MOTORS[m]
                        ),
                    ));
                }
            } else if self.engaged && measurement.time - self.last_overload >= RELEASE_AFTER {
                self.engaged = false;
                self.events.push(Event::mode(
                    "correction_released",
                    "path speed correction released: no motor overloaded",
                ));
            }
        } else {
            self.demand = 0.0;
            self.path_speed = 0.0;
        }
        if let Some(event) =
            self.servo
                .update(measurement, period, self.path_speed.max(0.0), efforts)
        {
            self.events.push(event);
        }
    }

    fn internals(&self) -> Vec<SignalSpec> {
        let mut specs = vec![
            SignalSpec::new("path_speed", Unit::MillimetrePerSecond, "path speed"),
            SignalSpec::new("speed_demand", Unit::MillimetrePerSecond, "path speed"),
            SignalSpec::new("overload", Unit::Dimensionless, "overload"),
            SignalSpec::new("path_position", Unit::Millimetre, "path position"),
        ];
        specs.extend(MOTORS.iter().map(|m| {
            SignalSpec::new(
                format!("{m}_current_filtered"),
                Unit::Ampere,
                format!("{m} current"),
            )
        }));
        specs.extend(super::servo::internals());
        specs
    }

    fn internal_values(&self, values: &mut [f64]) {
        values[..4].copy_from_slice(&[
            self.path_speed,
            self.demand,
            f64::from(u8::from(self.overloaded)),
            self.servo.covered(),
        ]);
        values[4..8].copy_from_slice(&self.filtered);
        values[8..11].copy_from_slice(&self.servo.errors);
        values[11..14].copy_from_slice(&self.servo.commands);
    }

    fn drain_events(&mut self, events: &mut Vec<Event>) {
        events.append(&mut self.events);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn build(key: &str, value: toml::Value) -> Result<Box<dyn Controller>, ControllerError> {
        let mut table = toml::Table::new();
        table.insert(key.into(), value);
        framework::Registry::with([super::entry()]).build(NAME, "arm", &table)
    }

    #[test]
    fn bad_tolerance_and_time_constants_are_named() {
        for key in [
            "current_tolerance",
            "speed_filter_lead",
            "speed_filter_lag",
            "current_filter_lead",
            "current_filter_lag",
            "path_speed",
        ] {
            for (value, shown) in [(0.0, "0"), (-1.0, "-1")] {
                let err = build(key, toml::Value::Float(value)).err().unwrap();
                assert_eq!(
                    err.to_string(),
                    format!("controller `{NAME}`: params.{key} = {shown}: must be > 0")
                );
            }
        }
        let err = build("gain", toml::Value::Float(1.0)).err().unwrap();
        assert!(
            matches!(&err, ControllerError::BadParameter { key, .. } if key == "gain"),
            "{err}"
        );
        let servo = toml::Value::Table("bandwidth = -5.0".parse().unwrap());
        let err = build("servo", servo).err().unwrap();
        assert_eq!(
            err.to_string(),
            format!("controller `{NAME}`: params.servo.bandwidth = -5: must be > 0")
        );
    }

    #[test]
    fn lag_defaults_to_the_servo_crossover() {
        let params = PathSpeedAdaptiveParams::default();
        let with_default = design(&params, 200.0).unwrap();
        let explicit = design(
            &PathSpeedAdaptiveParams {
                speed_filter_lag: Some(1.0 / 200.0),
                ..params
            },
            200.0,
        )
        .unwrap();
        assert_eq!(with_default.speed_filter, explicit.speed_filter);
        assert_eq!(with_default.path_speed, 0.02);
    }

    /// A test plant: every signal the controller needs, joints at the program's start.
    fn plant() -> PlantInterface {
        let mut signals = Vec::new();
        for joint in crate::arm::servo::JOINTS {
            signals.push(format!("{joint}.position"));
            signals.push(format!("{joint}.velocity"));
        }
        signals.extend(MOTORS.iter().map(|m| format!("{m}_current")));
        PlantInterface {
            machine: "arm".into(),
            signals,
            actuators: crate::arm::servo::JOINTS
                .iter()
                .zip([84.0, 60.0, 20.0])
                .map(|(j, limit)| framework::Actuator {
                    joint: j.to_string(),
                    kind: framework::EffortKind::Torque,
                    effort_limit: limit,
                })
                .collect(),
            ..Default::default()
        }
    }

    #[test]
    fn overload_stops_the_path_and_its_absence_reaches_v0() {
        let mut controller = PathSpeedAdaptive::new(PathSpeedAdaptiveParams::default()).unwrap();
        let plant = plant();
        controller.reset(&plant).unwrap();
        let start = controller.servo.design().program.points()[0];
        let mut signals = vec![0.0; plant.signals.len()];
        for i in 0..3 {
            signals[2 * i] = start[i];
        }
        let mut efforts = [0.0; 3];
        let mut values = vec![0.0; controller.internals().len()];
        let mut run =
            |controller: &mut PathSpeedAdaptive, from: f64, seconds: f64, current: f64| {
                for k in 0..(seconds * 1e3) as usize {
                    signals[6] = current;
                    let m = Measurement {
                        time: from + k as f64 * 1e-3,
                        signals: &signals,
                    };
                    controller.update(&m, 1e-3, &mut efforts);
                }
                controller.internal_values(&mut values);
                values.clone()
            };
        // Approach and settle (2.5 s) with the arm already at the start, then 1 s unloaded.
        let after = run(&mut controller, 0.0, 3.5, 5.0);
        assert!((after[0] - 0.02).abs() < 1e-6, "V_K = {}", after[0]);
        assert_eq!(after[2], 0.0);
        // The shoulder current above the tolerance: R = 1, the demand drops and V_K follows.
        let after = run(&mut controller, 3.5, 0.5, -19.0);
        assert_eq!(after[2], 1.0);
        assert_eq!(after[1], 0.0);
        assert!(after[0] < 1e-4, "V_K = {}", after[0]);
        let mut events = Vec::new();
        controller.drain_events(&mut events);
        assert!(
            events
                .iter()
                .any(|e| e.mode_entered() == Some("correction_engaged")
                    && e.text.contains("shoulder current over 18")),
            "{events:?}"
        );
    }
}
