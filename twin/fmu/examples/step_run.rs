//! The twin's own run of a step input, for comparing an FMU's simulation with: the scenario run
//! through `Twin::run_with` with a controller that commands `EFFORT` on every actuator from
//! `STEP_AT` s on (0 before), writing `time` and every measured signal at each control update
//! as CSV (17 significant digits).
//!
//! `cargo run --release -p twin-fmu --example step_run -- SCENARIO DURATION STEP_AT EFFORT OUT.csv`

use controllers::{Controller, ControllerError, Measurement, PlantInterface, Registry};
use std::fmt::Write as _;
use twin::{Observer, ObserverError, Overrides, SignalLayout, StepView, Twin};

struct Step {
    at: f64,
    effort: f64,
}

impl Controller for Step {
    fn name(&self) -> &str {
        "step-input"
    }
    fn reset(&mut self, _plant: &PlantInterface) -> Result<(), ControllerError> {
        Ok(())
    }
    fn update(&mut self, m: &Measurement, _period: f64, efforts: &mut [f64]) {
        efforts.fill(if m.time >= self.at { self.effort } else { 0.0 });
    }
}

#[derive(Default)]
struct Csv(String);

impl Observer for Csv {
    fn start(&mut self, layout: &SignalLayout) -> Result<(), ObserverError> {
        self.0 = std::iter::once("time".to_string())
            .chain(layout.signals.iter().map(|s| format!("measured.{s}")))
            .collect::<Vec<_>>()
            .join(",");
        self.0.push('\n');
        Ok(())
    }
    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        if view.control_update {
            write!(self.0, "{:.17e}", view.time)?;
            for value in view.measured {
                write!(self.0, ",{value:.17e}")?;
            }
            self.0.push('\n');
        }
        Ok(())
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [scenario, duration, at, effort, out] = &args[..] else {
        return Err("usage: step_run SCENARIO DURATION STEP_AT EFFORT OUT.csv".into());
    };
    let overrides = Overrides {
        set: vec![format!("duration={duration}")],
        ..Overrides::default()
    };
    let loaded = twin::load_scenario(scenario, &overrides, &Registry::builtin())?;
    let step = Step {
        at: at.parse()?,
        effort: effort.parse()?,
    };
    let mut csv = Csv::default();
    let summary = Twin::with_controller(loaded, Box::new(step))?.run_with(None, &mut [&mut csv])?;
    if let Some(failure) = summary.failure {
        return Err(failure.to_string().into());
    }
    std::fs::write(out, csv.0)?;
    Ok(())
}
