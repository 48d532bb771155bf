//! A controller written outside the project's crates, run through the twin unchanged.
//!
//! `TwoSpeedCrank` is what a user might try on the shaper: turn the crank slowly while the ram
//! cuts (moving down) and fast while it returns, with a proportional speed loop on crank torque.
//! It implements `framework::Controller`, is handed to `Twin::with_controller`, and is also
//! registered by name so that a scenario could choose it.
//!
//! Run: `cargo run --release -p twin --example custom_controller`

use framework::Entry;
use framework::{Controller, ControllerError, Measurement, PlantInterface, SignalSpec, Unit};
use twin::{Overrides, Twin};

struct TwoSpeedCrank {
    cutting_speed: f64,
    return_speed: f64,
    gain: f64,
    crank_speed: usize,
    ram_velocity: usize,
    crank: usize,
    target: f64,
}

impl Controller for TwoSpeedCrank {
    fn name(&self) -> &str {
        "two-speed-crank"
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        self.crank_speed = plant.signal("crank.velocity")?;
        self.ram_velocity = plant.signal("ram_velocity")?;
        self.crank = plant.actuator("crank")?;
        Ok(())
    }

    fn update(&mut self, measurement: &Measurement, _period: f64, efforts: &mut [f64]) {
        // The ram moves down while cutting.
        let cutting = measurement.get(self.ram_velocity) < 0.0;
        self.target = if cutting {
            self.cutting_speed
        } else {
            self.return_speed
        };
        efforts[self.crank] = self.gain * (self.target - measurement.get(self.crank_speed));
    }

    fn internals(&self) -> Vec<SignalSpec> {
        // On the crank's speed plot: the target beside the speed it sets.
        vec![SignalSpec::new("target_speed", Unit::Rpm, "crank speed")]
    }

    fn internal_values(&self, values: &mut [f64]) {
        values[0] = self.target;
    }
}

fn two_speed_crank() -> TwoSpeedCrank {
    TwoSpeedCrank {
        cutting_speed: -4.0,
        return_speed: -9.0,
        gain: 40.0,
        crank_speed: 0,
        ram_velocity: 0,
        crank: 0,
        target: 0.0,
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // Either hand the controller over directly...
    let builtin = controllers::builtin();
    let scenario = twin::load_scenario("whitworth-crank-pi", &Overrides::default(), &builtin)?;
    let twin = Twin::with_controller(scenario, Box::new(two_speed_crank()))?;
    let summary = twin.run(Some(std::path::Path::new("two-speed-crank.rrd")))?;
    print!("{}", twin::summary::to_table(&summary));

    // ...or register it by name beside the built-in controllers.
    let mut registry = controllers::builtin();
    registry.register(Entry {
        name: "two-speed-crank",
        machine: "whitworth",
        summary: "slow crank while cutting, fast while returning",
        build: |_params| Ok(Box::new(two_speed_crank())),
    });
    let overrides = Overrides {
        controller: Some("two-speed-crank".into()),
        duration: Some(2.0),
        ..Default::default()
    };
    let scenario = twin::load_scenario("whitworth-crank-pi", &overrides, &registry)?;
    let summary = Twin::new(scenario)?.run(None)?;
    println!(
        "by name: {} turns in 2 s",
        summary.metric("crank_turns").unwrap_or(0.0)
    );
    Ok(())
}
