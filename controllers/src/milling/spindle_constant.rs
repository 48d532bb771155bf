//! `spindle-constant`: the spindle held at one speed through its torque — the reference runs of
//! Kaliński & Galewski 2013 §3 (15,000 and 16,500 rpm).

use super::spindle_speed::{SpeedLoop, SpeedLoopParams};
use crate::check::positive;
use framework::{parse_params, Entry};
use framework::{Controller, ControllerError, Measurement, PlantInterface, SignalSpec};
use serde::Deserialize;

const NAME: &str = "spindle-constant";

/// Parameters of `spindle-constant` (SI units).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct SpindleConstantParams {
    /// Spindle speed to hold, rad/s.
    pub speed: f64,
    /// The spindle-speed loop, `[controller.params.speed_loop]`.
    pub speed_loop: SpeedLoopParams,
}

impl Default for SpindleConstantParams {
    fn default() -> Self {
        Self {
            speed: 15_000.0 * std::f64::consts::TAU / 60.0,
            speed_loop: SpeedLoopParams::default(),
        }
    }
}

/// The running `spindle-constant` controller: the speed loop at one fixed speed.
pub struct SpindleConstant {
    speed: f64,
    speed_loop: SpeedLoop,
}

impl SpindleConstant {
    /// Checks the speed and designs the speed loop; errors name the parameter at fault.
    pub fn new(params: SpindleConstantParams) -> Result<Self, ControllerError> {
        Ok(Self {
            speed: positive(NAME, "speed", params.speed)?,
            speed_loop: SpeedLoop::new(NAME, &params.speed_loop)?,
        })
    }
}

pub(crate) fn entry() -> Entry {
    Entry {
        name: NAME,
        machine: "milling",
        summary: "spindle held at a constant speed (speed PI through spindle torque)",
        build: |table| Ok(Box::new(SpindleConstant::new(parse_params(NAME, table)?)?)),
    }
}

impl Controller for SpindleConstant {
    fn name(&self) -> &str {
        NAME
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        self.speed_loop.reset(plant)
    }

    fn update(&mut self, measurement: &Measurement, period: f64, efforts: &mut [f64]) {
        self.speed_loop
            .update(measurement, (self.speed, 0.0), period, efforts);
    }

    fn internals(&self) -> Vec<SignalSpec> {
        super::spindle_speed::internals()
    }

    fn internal_values(&self, values: &mut [f64]) {
        let l = &self.speed_loop;
        values.copy_from_slice(&[self.speed, l.speed_error, l.torque]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_speeds_are_named_with_their_value() {
        let build = |text: &str| {
            framework::Registry::with([super::entry()])
                .build(NAME, "milling", &text.parse::<toml::Table>().unwrap())
                .err()
                .unwrap()
                .to_string()
        };
        assert_eq!(
            build("speed = -1"),
            "controller `spindle-constant`: params.speed = -1: must be > 0"
        );
        assert_eq!(
            build("speed_loop = { inertia = 0 }"),
            "controller `spindle-constant`: params.speed_loop.inertia = 0: must be > 0"
        );
    }
}
