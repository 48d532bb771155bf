//! The recording as one observer among others: every `recording.every`-th step and the last one
//! to the `.rrd` file, every event as it happens.

use super::layout::SignalLayout;
use super::observer::{Findings, Observer, ObserverError, StepView};
use crate::mechanism::Shape;
use crate::recording::{LiveViewer, Recorder, RecordingLayout, SeriesGroup};
use std::path::PathBuf;

/// Records a run to a file (and a live viewer, if any).
pub struct RecordingObserver {
    path: PathBuf,
    /// The layout without the series groups, which come with the run's [`SignalLayout`].
    layout: RecordingLayout,
    recorder: Option<Recorder>,
    values: Vec<f64>,
}

impl RecordingObserver {
    pub fn new(
        path: PathBuf,
        app: String,
        scenario_toml: String,
        links: Vec<(String, Vec<Shape>)>,
        live: Option<LiveViewer>,
    ) -> Self {
        Self {
            path,
            layout: RecordingLayout {
                app,
                scenario_toml,
                links,
                series: Vec::new(),
                live,
            },
            recorder: None,
            values: Vec::new(),
        }
    }
}

fn group(path: &str, names: &[String]) -> SeriesGroup {
    SeriesGroup {
        path: path.into(),
        names: names.to_vec(),
    }
}

/// The recording's step index (the run's step counts stay far below i64's range).
fn step_index(step: usize) -> i64 {
    i64::try_from(step).unwrap_or(i64::MAX)
}

impl Observer for RecordingObserver {
    fn start(&mut self, layout: &SignalLayout) -> Result<(), ObserverError> {
        self.layout.series = vec![
            group("joints/position", &layout.joints),
            group("joints/velocity", &layout.joints),
            group("effort/commanded", &layout.actuators),
            group("effort/applied", &layout.actuators),
            group("task", layout.machine_signal_names()),
            group("measurement", &layout.signals),
            group("controller", &layout.internals),
            group("diagnostics", &layout.diagnostics),
        ];
        self.recorder = Some(Recorder::create(&self.path, &self.layout)?);
        Ok(())
    }

    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        let Some(recorder) = self.recorder.as_mut() else {
            return Ok(());
        };
        for event in view.events {
            recorder.event(step_index(view.step), view.time, event.level, &event.text)?;
        }
        if view.sampled {
            let movable = view.layout.movable_joints();
            let values = &mut self.values;
            values.clear();
            values.extend(movable.iter().map(|&j| view.state.joint_positions[j]));
            values.extend(movable.iter().map(|&j| view.state.joint_velocities[j]));
            values.extend_from_slice(view.commanded);
            values.extend_from_slice(view.applied);
            values.extend_from_slice(view.layout.machine_signals(view.signals));
            values.extend_from_slice(view.measured);
            values.extend_from_slice(view.internals);
            values.extend_from_slice(view.diagnostics);
            recorder.push(
                step_index(view.step),
                view.time,
                &view.state.link_poses,
                values,
            )?;
        }
        Ok(())
    }

    fn finish(&mut self) -> Result<Findings, ObserverError> {
        let Some(recorder) = self.recorder.take() else {
            return Ok(Findings::default());
        };
        let outcome = recorder.finish()?;
        Ok(Findings {
            metrics: Vec::new(),
            warnings: outcome.live_warning.into_iter().collect(),
        })
    }
}
