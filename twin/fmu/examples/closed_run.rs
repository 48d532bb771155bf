//! The twin's own run of a scenario with its controller, for comparing a closed-loop FMU's
//! simulation with: `Twin::run_with` (not the FMU's `Simulator`), writing at each control update
//! the time, every measured and true signal, the efforts commanded and the controller's
//! internals as CSV (17 significant digits). `--set` and `--controller` as for `twin run`;
//! `--load JOINT FROM EFFORT` adds an effort from outside on a joint from FROM s on
//! (`Twin::with_joint_effort`).
//!
//! `cargo run --release -p twin-fmu --example closed_run -- SCENARIO DURATION OUT.csv [--set K=V]
//! [--controller NAME] [--load JOINT FROM EFFORT]`

use controllers::Registry;
use std::fmt::Write as _;
use twin::{Observer, ObserverError, Overrides, SignalLayout, StepView, Twin};

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
fn options(args: &[String]) -> Result<(Overrides, Option<Load>), String> {
    let mut overrides = Overrides::default();
    let mut load = None;
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
                let from = value()?.parse().map_err(|e| format!("--load FROM: {e}"))?;
                let effort = value()?
                    .parse()
                    .map_err(|e| format!("--load EFFORT: {e}"))?;
                load = Some((joint, from, effort));
            }
            other => return Err(format!("unknown option {other}")),
        }
    }
    Ok((overrides, load))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: closed_run SCENARIO DURATION OUT.csv [--set K=V] [--controller NAME] \
                 [--load JOINT FROM EFFORT]";
    let [scenario, duration, out, rest @ ..] = &args[..] else {
        return Err(usage.into());
    };
    let (mut overrides, load) = options(rest)?;
    overrides.set.insert(0, format!("duration={duration}"));
    let loaded = twin::load_scenario(scenario, &overrides, &Registry::builtin())?;
    let scenario = loaded.scenario.clone();
    let mut twin = Twin::new(loaded)?;
    if let Some((joint, from, effort)) = load {
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
