//! `replay`: the efforts of a logged run played open loop, for any mechanism.
//!
//! The run is a table in the twin's run format (what `twin run --csv` writes and `twin
//! calibrate` reads: `time [s]`, `effort.<joint> [N·m or N]`, …), `file` relative to the
//! scenario; the engine reads it at reset, converting units to SI and holding each row onto the
//! control period's grid. At a control update at time t the law applies the row in force at t
//! (zero-order hold); before the run's first row and after its last it applies none, and says
//! so once. Replayed on the scenario that logged it (the same engine and dt), a run's efforts
//! reproduce it bit for bit: nothing is measured, so nothing the sensors do enters.

use crate::check::finite;
use framework::{parse_params, Entry, Event, EventKind, EventLevel, ANY_MACHINE};
use framework::{Controller, ControllerError, LoggedEfforts, Measurement, PlantInterface};
use serde::Deserialize;

const NAME: &str = "replay";

/// Rows are at most this share of a period early and still in force (the update times and the
/// run's rows are sums of the same step, rounded apart).
const ON_ROW: f64 = 1e-6;

/// Parameters of `replay`.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ReplayParams {
    /// The run's table (CSV, Parquet or a twin `.rrd`), relative to the scenario's file.
    pub file: String,
    /// Added to the run's times, s: 0 plays its first row at its own time.
    pub shift: f64,
}

/// The checked parameters: which file, and where its rows fall on the run's clock.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayPlan {
    /// The run's table, as the scenario names it.
    pub file: String,
    /// Added to the run's times, s.
    pub shift: f64,
}

/// Checks the parameters (the shift is finite); a file must be named to run, which binding to
/// the plant checks, so that the defaults build.
pub fn design(params: &ReplayParams) -> Result<ReplayPlan, ControllerError> {
    Ok(ReplayPlan {
        file: params.file.clone(),
        shift: finite(NAME, "shift", params.shift)?,
    })
}

/// The running law.
pub struct Replay {
    plan: ReplayPlan,
    run: Option<LoggedEfforts>,
    /// Whether the end (or the not-yet-started) of the run has been said.
    outside_said: bool,
    events: Vec<Event>,
}

impl Replay {
    /// Checks the parameters; the run is read when bound to the plant.
    pub fn new(params: ReplayParams) -> Result<Self, ControllerError> {
        Ok(Self {
            plan: design(&params)?,
            run: None,
            outside_said: false,
            events: Vec::new(),
        })
    }
}

pub(crate) fn entry() -> Entry {
    Entry {
        name: NAME,
        machine: ANY_MACHINE,
        summary: "the efforts of a logged run (twin run --csv) played open loop",
        build: |table| Ok(Box::new(Replay::new(parse_params(NAME, table)?)?)),
    }
}

impl Controller for Replay {
    fn name(&self) -> &str {
        NAME
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        if self.plan.file.trim().is_empty() {
            return Err(ControllerError::parameter_table(
                NAME,
                "file",
                "name the run to replay: file = \"run.csv\" (relative to the scenario)",
            ));
        }
        let run = (plant.files(NAME)?.efforts(&self.plan.file))
            .map_err(|reason| ControllerError::parameter(NAME, "file", &self.plan.file, reason))?;
        if run.efforts.len() != plant.actuators.len()
            || run.efforts.iter().any(|e| e.len() != run.efforts[0].len())
        {
            return Err(ControllerError::parameter(
                NAME,
                "file",
                &self.plan.file,
                "the run's effort columns do not match the plant's actuators",
            ));
        }
        self.run = Some(run);
        self.outside_said = false;
        self.events.clear();
        Ok(())
    }

    fn update(&mut self, measurement: &Measurement, _period: f64, efforts: &mut [f64]) {
        let Some(run) = &self.run else {
            return;
        };
        let rows = run.efforts.first().map_or(0, Vec::len);
        let place = (measurement.time - self.plan.shift - run.start_time) / run.period + ON_ROW;
        let row = place.floor();
        if row >= 0.0 && row < rows as f64 {
            for (effort, column) in efforts.iter_mut().zip(&run.efforts) {
                *effort = column[row as usize];
            }
        } else if !self.outside_said {
            self.outside_said = true;
            self.events.push(Event {
                kind: EventKind::Note,
                level: EventLevel::Warning,
                text: format!(
                    "replay: {} has no row at t = {:.6} s; no effort until it has",
                    run.source, measurement.time
                ),
            });
        }
    }

    fn drain_events(&mut self, events: &mut Vec<Event>) {
        events.append(&mut self.events);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use framework::{Actuator, EffortKind, ScenarioFiles};
    use std::sync::Arc;

    struct Logged;

    impl ScenarioFiles for Logged {
        fn efforts(&self, file: &str) -> Result<LoggedEfforts, String> {
            match file {
                "run.csv" => Ok(LoggedEfforts {
                    source: "dir/run.csv".into(),
                    start_time: 0.0,
                    period: 0.01,
                    efforts: vec![vec![1.0, 2.0, 3.0]],
                }),
                _ => Err(format!("cannot read {file}: No such file")),
            }
        }

        fn positions(&self, _file: &str, _unit: &str) -> Result<Vec<[f64; 2]>, String> {
            Err("no tables here".into())
        }
    }

    fn plant() -> PlantInterface {
        PlantInterface {
            machine: "generic".into(),
            actuators: vec![Actuator {
                joint: "a".into(),
                kind: EffortKind::Torque,
                effort_limit: 10.0,
            }],
            files: Some(Arc::new(Logged)),
            ..Default::default()
        }
    }

    fn at(replay: &mut Replay, time: f64) -> f64 {
        let mut efforts = [0.0];
        let measurement = Measurement { time, signals: &[] };
        replay.update(&measurement, 0.01, &mut efforts);
        efforts[0]
    }

    #[test]
    fn each_row_holds_over_its_period_and_none_is_applied_past_the_end() {
        let params: ReplayParams = toml::from_str("file = \"run.csv\"").unwrap();
        let mut replay = Replay::new(params).unwrap();
        replay.reset(&plant()).unwrap();
        // 3·0.01 summed as a run's clock sums it lands a hair below the row.
        let clock = 0.01 + 0.01 + 0.01 - 1e-12;
        let played: Vec<f64> = [0.0, 0.005, 0.01, 0.02, clock - 0.01, clock]
            .iter()
            .map(|&t| at(&mut replay, t))
            .collect();
        assert_eq!(played, [1.0, 1.0, 2.0, 3.0, 3.0, 0.0]);
        let mut events = Vec::new();
        replay.drain_events(&mut events);
        assert_eq!(events.len(), 1);
        assert!(events[0].text.contains("dir/run.csv"), "{}", events[0].text);
    }

    #[test]
    fn a_missing_file_or_plant_without_files_is_named() {
        let params: ReplayParams = toml::from_str("file = \"other.csv\"").unwrap();
        let mut replay = Replay::new(params).unwrap();
        let error = replay.reset(&plant()).unwrap_err().to_string();
        assert!(
            error.contains("params.file = other.csv: cannot read other.csv"),
            "{error}"
        );
        let bare = PlantInterface {
            files: None,
            ..plant()
        };
        let error = replay.reset(&bare).unwrap_err().to_string();
        assert!(error.contains("data files"), "{error}");
        let mut unnamed = Replay::new(ReplayParams::default()).unwrap();
        let error = unnamed.reset(&plant()).unwrap_err().to_string();
        assert!(error.contains("params.file: name the run"), "{error}");
    }
}
