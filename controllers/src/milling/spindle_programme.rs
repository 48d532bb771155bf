//! `spindle-programme`: a repeating triangular spindle-speed programme between the nominal speed
//! n0 and n_max — Kaliński & Galewski 2013 §3's Z04 (rise and fall 0.4 s) and Z05 (0.5 s), or any
//! other n0, n_max, rise and fall — followed through the spindle torque.

use super::spindle_speed::{check_speeds, SpeedLoop, SpeedLoopParams};
use crate::check::positive;
use framework::{parse_params, Entry};
use framework::{Controller, ControllerError, Measurement, PlantInterface, SignalSpec};
use serde::Deserialize;
use std::f64::consts::TAU;

const NAME: &str = "spindle-programme";

/// Parameters of `spindle-programme` (SI units).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct SpindleProgrammeParams {
    /// n0, rad/s: where each triangle starts and ends.
    pub nominal_speed: f64,
    /// n_max, rad/s: the triangle's top.
    pub maximum_speed: f64,
    /// Time from n0 to n_max, s.
    pub rise_time: f64,
    /// Time from n_max back to n0, s.
    pub fall_time: f64,
    /// The spindle-speed loop, `[controller.params.speed_loop]`.
    pub speed_loop: SpeedLoopParams,
}

impl Default for SpindleProgrammeParams {
    /// Z04 between 15,000 and 16,500 rpm.
    fn default() -> Self {
        Self {
            nominal_speed: 15_000.0 * TAU / 60.0,
            maximum_speed: 16_500.0 * TAU / 60.0,
            rise_time: 0.4,
            fall_time: 0.4,
            speed_loop: SpeedLoopParams::default(),
        }
    }
}

/// The triangle: speed (rad/s) and its rate (rad/s²) at `time`.
pub fn programme_speed(params: &SpindleProgrammeParams, time: f64) -> (f64, f64) {
    let (n0, n_max) = (params.nominal_speed, params.maximum_speed);
    let period = params.rise_time + params.fall_time;
    let phase = time.rem_euclid(period);
    if phase < params.rise_time {
        let rate = (n_max - n0) / params.rise_time;
        (n0 + rate * phase, rate)
    } else {
        let rate = (n0 - n_max) / params.fall_time;
        (n_max + rate * (phase - params.rise_time), rate)
    }
}

/// The running `spindle-programme` controller: the speed loop following the triangle.
pub struct SpindleProgramme {
    params: SpindleProgrammeParams,
    speed_loop: SpeedLoop,
    command: (f64, f64),
}

impl SpindleProgramme {
    /// Checks the programme and designs the speed loop; errors name the parameter at fault.
    pub fn new(params: SpindleProgrammeParams) -> Result<Self, ControllerError> {
        check_speeds(NAME, params.nominal_speed, params.maximum_speed)?;
        positive(NAME, "rise_time", params.rise_time)?;
        positive(NAME, "fall_time", params.fall_time)?;
        Ok(Self {
            speed_loop: SpeedLoop::new(NAME, &params.speed_loop)?,
            command: (params.nominal_speed, 0.0),
            params,
        })
    }
}

pub(crate) fn entry() -> Entry {
    Entry {
        name: NAME,
        machine: "milling",
        summary: "repeating triangular spindle-speed programme n0 → n_max → n0 (Z04, Z05)",
        build: |table| Ok(Box::new(SpindleProgramme::new(parse_params(NAME, table)?)?)),
    }
}

impl Controller for SpindleProgramme {
    fn name(&self) -> &str {
        NAME
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        self.command = (self.params.nominal_speed, 0.0);
        self.speed_loop.reset(plant)
    }

    fn update(&mut self, measurement: &Measurement, period: f64, efforts: &mut [f64]) {
        self.command = programme_speed(&self.params, measurement.time);
        self.speed_loop
            .update(measurement, self.command, period, efforts);
    }

    fn internals(&self) -> Vec<SignalSpec> {
        super::spindle_speed::internals()
    }

    fn internal_values(&self, values: &mut [f64]) {
        let l = &self.speed_loop;
        values.copy_from_slice(&[self.command.0, l.speed_error, l.torque]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_programme_is_a_repeating_triangle() {
        let p = SpindleProgrammeParams::default();
        let (n0, n_max) = (p.nominal_speed, p.maximum_speed);
        for (t, expected) in [
            (0.0, n0),
            (0.2, 0.5 * (n0 + n_max)),
            (0.4, n_max),
            (0.8, n0),
            (1.0, 0.5 * (n0 + n_max)),
        ] {
            let (speed, _) = programme_speed(&p, t);
            assert!(
                (speed - expected).abs() < 1e-9 * n_max,
                "t = {t}: {speed} vs {expected}"
            );
        }
        assert!(programme_speed(&p, 0.5).1 < 0.0 && programme_speed(&p, 0.1).1 > 0.0);
    }

    #[test]
    fn bad_programmes_are_refused_by_name() {
        for (field, params) in [
            (
                "params.maximum_speed = 1000: must be > nominal_speed",
                SpindleProgrammeParams {
                    maximum_speed: 1000.0,
                    ..Default::default()
                },
            ),
            (
                "params.rise_time = 0: must be > 0",
                SpindleProgrammeParams {
                    rise_time: 0.0,
                    ..Default::default()
                },
            ),
            (
                "params.nominal_speed = NaN: must be a finite number",
                SpindleProgrammeParams {
                    nominal_speed: f64::NAN,
                    ..Default::default()
                },
            ),
        ] {
            let error = SpindleProgramme::new(params).err().unwrap().to_string();
            assert!(error.contains(field), "{error}");
        }
    }
}
