//! The twin's own run of a scenario with its controller, for comparing a closed-loop FMU's
//! simulation with: `Twin::run_with` (not the FMU's `Simulator`), writing at each control update
//! the time, every measured and true signal, the efforts commanded and the controller's
//! internals as CSV (17 significant digits). `--set` and `--controller` as for `twin run`;
//! `--load JOINT FROM EFFORT` adds an effort from outside on a joint from FROM s on
//! (`Twin::with_joint_effort`); `--step-input AT EFFORT` replaces the controller by a step input,
//! `EFFORT` on every actuator from `AT` s on (0 before), to compare a plant FMU's run with.
//!
//! `cargo run --release -p twin-fmu --example closed_run -- SCENARIO DURATION OUT.csv [--set K=V]
//! [--controller NAME] [--load JOINT FROM EFFORT] [--step-input AT EFFORT]`

use framework::{Controller, ControllerError, Measurement, PlantInterface};
use std::fmt::Write as _;
use twin::{Observer, ObserverError, Overrides, SignalLayout, StepView, Twin};

/// The controller of `--step-input`: `effort` on every actuator from `at` s on.
struct StepInput {
    at: f64,
    effort: f64,
}

impl Controller for StepInput {
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
        let columns = (layout.signals.iter().map(|s| format!("measured.{s}")))
            .chain(layout.signals.iter().map(|s| format!("true.{s}")))
            .chain(layout.actuators.iter().map(|a| format!("effort.{a}")))
            .chain(layout.internals.iter().map(|i| format!("controller.{i}")));
        self.0 = std::iter::once("time".to_string())
            .chain(columns)
            .collect::<Vec<_>>()
            .join(",");
        self.0.push('\n');
        Ok(())
    }

    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        if view.control_update {
            write!(self.0, "{:.17e}", view.time)?;
            let values = (view.measured.iter().chain(view.signals))
                .chain(view.commanded)
                .chain(view.internals);
            for value in values {
                write!(self.0, ",{value:.17e}")?;
            }
            self.0.push('\n');
        }
        Ok(())
    }
}

/// `--load JOINT FROM EFFORT`: the joint, from when (s), how much (N or N·m).
type Load = (String, f64, f64);

/// The options after the three positional arguments.
struct Options {
    overrides: Overrides,
    load: Option<Load>,
    step_input: Option<StepInput>,
}

fn options(args: &[String]) -> Result<Options, String> {
    let mut overrides = Overrides::default();
    let (mut load, mut step_input) = (None, None);
    let number = |text: String, what: &str| text.parse().map_err(|e| format!("{what}: {e}"));
    let mut rest = args.iter();
    while let Some(option) = rest.next() {
        let mut value = || {
            rest.next()
                .cloned()
                .ok_or(format!("{option} needs a value"))
        };
        match option.as_str() {
            "--set" => overrides.set.push(value()?),
            "--controller" => overrides.controller = Some(value()?),
            "--load" => {
                let joint = value()?;
                let from = number(value()?, "--load FROM")?;
                load = Some((joint, from, number(value()?, "--load EFFORT")?));
            }
            "--step-input" => {
                let at = number(value()?, "--step-input AT")?;
                let effort = number(value()?, "--step-input EFFORT")?;
                step_input = Some(StepInput { at, effort });
            }
            other => return Err(format!("unknown option {other}")),
        }
    }
    Ok(Options {
        overrides,
        load,
        step_input,
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: closed_run SCENARIO DURATION OUT.csv [--set K=V] [--controller NAME] \
                 [--load JOINT FROM EFFORT] [--step-input AT EFFORT]";
    let [scenario, duration, out, rest @ ..] = &args[..] else {
        return Err(usage.into());
    };
    let mut options = options(rest)?;
    (options.overrides.set).insert(0, format!("duration={duration}"));
    let loaded = twin::load_scenario(scenario, &options.overrides, &controllers::builtin())?;
    let scenario = loaded.scenario.clone();
    let mut twin = match options.step_input {
        Some(step_input) => Twin::with_controller(loaded, Box::new(step_input))?,
        None => Twin::new(loaded)?,
    };
    if let Some((joint, from, effort)) = options.load {
        let every = scenario.control_every();
        // From the first control update at or after FROM, as a host's input arrives.
        let first = (from / scenario.control_period() - 1e-9).ceil() as usize * every;
        let efforts = (0..scenario.steps())
            .map(|k| if k >= first { effort } else { 0.0 })
            .collect();
        twin = twin.with_joint_effort(&joint, efforts)?;
    }
    let mut csv = Csv::default();
    let summary = twin.run_with(None, &mut [&mut csv])?;
    if let Some(failure) = summary.failure {
        return Err(failure.to_string().into());
    }
    std::fs::write(out, csv.0)?;
    Ok(())
}
