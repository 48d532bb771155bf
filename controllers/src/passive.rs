//! `passive`: no effort at all — the machine moves freely under gravity and its own momentum.
//! The baseline for energy checks and for watching a mechanism fall.

use framework::{parse_params, Entry, ANY_MACHINE};
use framework::{Controller, ControllerError, Measurement, PlantInterface};
use serde::Deserialize;

/// `passive` takes no parameters; the empty struct makes any given key an error.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PassiveParams {}

/// The running `passive` controller: leaves every effort at zero.
pub struct Passive;

pub(crate) fn entry() -> Entry {
    Entry {
        name: "passive",
        machine: ANY_MACHINE,
        summary: "zero effort on every actuator (free motion)",
        build: |table| {
            let _: PassiveParams = parse_params("passive", table)?;
            Ok(Box::new(Passive))
        },
    }
}

impl Controller for Passive {
    fn name(&self) -> &str {
        "passive"
    }

    fn reset(&mut self, _plant: &PlantInterface) -> Result<(), ControllerError> {
        Ok(())
    }

    fn update(&mut self, _measurement: &Measurement, _period: f64, _efforts: &mut [f64]) {}
}
