//! `path-speed-constant`: the machining arm follows its program at one programmed path speed,
//! whatever the motor currents — the baseline of Ilyukhin et al. (DAAAM 2014, §1): at the full
//! speed V0 a deep stretch of stock drives a motor into its current limit, it brakes, and the
//! joints lose their coordination; at a speed slow enough for the deepest stock (the "safe"
//! baseline, this controller with a lower `path_speed`) no drive saturates but the whole contour
//! is cut slowly.
//!
//! The speed starts from rest through the same filter `W_F0(s) = (T_K1 s + 1)/(T_K2 s + 1)` as
//! the adaptive controller's, with `V_II = path_speed` throughout.

use super::path_speed_adaptive::{lead_lag, PAPER_PATH_SPEED_MM_S};
use super::servo::{ArmServo, ServoParams};
use crate::check::positive;
use crate::filters::FirstOrderFilter;
use framework::Event;
use framework::{parse_params, Entry};
use framework::{Controller, ControllerError, Measurement, PlantInterface, SignalSpec, Unit};
use serde::Deserialize;

const NAME: &str = "path-speed-constant";

/// Parameters of `path-speed-constant` (SI units).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct PathSpeedConstantParams {
    /// The programmed path speed, m/s (default the paper's V0 = 20 mm/s).
    pub path_speed: f64,
    /// T_K1 of W_F0, s.
    pub speed_filter_lead: f64,
    /// T_K2 of W_F0, s; absent: 1/ω_c.
    pub speed_filter_lag: Option<f64>,
    /// The robot program and the joint servos, `[controller.params.servo]`.
    pub servo: ServoParams,
}

impl Default for PathSpeedConstantParams {
    fn default() -> Self {
        Self {
            path_speed: PAPER_PATH_SPEED_MM_S * 1e-3,
            speed_filter_lead: 0.002,
            speed_filter_lag: None,
            servo: ServoParams::default(),
        }
    }
}

/// The running `path-speed-constant` controller: the joint servos following the program at the
/// programmed path speed, brought up from rest through W_F0.
pub struct PathSpeedConstant {
    servo: ArmServo,
    speed: f64,
    speed_filter: FirstOrderFilter,
    path_speed: f64,
    events: Vec<Event>,
}

impl PathSpeedConstant {
    /// Designs the servo and W_F0; errors name the parameter at fault.
    pub fn new(params: PathSpeedConstantParams) -> Result<Self, ControllerError> {
        let servo = ArmServo::new(NAME, params.servo.clone())?;
        positive(NAME, "path_speed", params.path_speed)?;
        let speed_filter = lead_lag(
            NAME,
            ("speed_filter_lead", params.speed_filter_lead),
            (
                "speed_filter_lag",
                params
                    .speed_filter_lag
                    .unwrap_or(1.0 / servo.design().crossover),
            ),
        )?;
        Ok(Self {
            servo,
            speed: params.path_speed,
            speed_filter,
            path_speed: 0.0,
            events: Vec::new(),
        })
    }
}

pub(crate) fn entry() -> Entry {
    Entry {
        name: NAME,
        machine: "arm",
        summary: "arm at one programmed path speed, blind to the motor currents (baseline)",
        build: |table| {
            Ok(Box::new(PathSpeedConstant::new(parse_params(
                NAME, table,
            )?)?))
        },
    }
}

impl Controller for PathSpeedConstant {
    fn name(&self) -> &str {
        NAME
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        self.servo.reset(plant)?;
        self.speed_filter.reset();
        self.speed_filter.update(0.0, 0.0);
        self.path_speed = 0.0;
        self.events.clear();
        Ok(())
    }

    fn update(&mut self, measurement: &Measurement, period: f64, efforts: &mut [f64]) {
        if self.servo.machining() {
            self.path_speed = self.speed_filter.update(self.speed, period);
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
            SignalSpec::new("path_position", Unit::Millimetre, "path position"),
        ];
        specs.extend(super::servo::internals());
        specs
    }

    fn internal_values(&self, values: &mut [f64]) {
        values[..2].copy_from_slice(&[self.path_speed, self.servo.covered()]);
        values[2..5].copy_from_slice(&self.servo.errors);
        values[5..8].copy_from_slice(&self.servo.commands);
    }

    fn drain_events(&mut self, events: &mut Vec<Event>) {
        events.append(&mut self.events);
    }
}

#[cfg(test)]
mod tests {

    #[test]
    fn bad_speed_and_filter_are_named() {
        for key in ["path_speed", "speed_filter_lead", "speed_filter_lag"] {
            let mut table = toml::Table::new();
            table.insert(key.into(), toml::Value::Float(-0.01));
            let err = framework::Registry::with([super::entry()])
                .build("path-speed-constant", "arm", &table)
                .err()
                .unwrap();
            assert_eq!(
                err.to_string(),
                format!("controller `path-speed-constant`: params.{key} = -0.01: must be > 0")
            );
        }
    }
}
