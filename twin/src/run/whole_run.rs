//! `Twin::run`, the one door in: a whole run, stepped by a session with the recording, the run's
//! statistics, the scenario's evaluators and the caller's observers watching, ending in its
//! summary.

use super::observer::Observer;
use super::session::Session;
use super::stats::RunStats;
use super::summary::RunSummary;
use super::twin::{observer_error, Twin, TwinError};
use std::path::Path;
use std::time::Instant;

impl Twin {
    /// Runs the scenario; with `recording`, writes the .rrd there (atomically: a partial file
    /// is renamed into place only once closed). A diverging run stops early and says so in the
    /// summary; its recording is kept, up to and including the failure.
    pub fn run(self, recording: Option<&Path>) -> Result<RunSummary, TwinError> {
        self.run_with(recording, &mut [])
    }

    /// [`Twin::run`] with `observers` watching every step besides the recording and the
    /// scenario's evaluators; the figures they find join the summary's metrics.
    pub fn run_with(
        mut self,
        recording: Option<&Path>,
        observers: &mut [&mut dyn Observer],
    ) -> Result<RunSummary, TwinError> {
        let mut recorder = recording.map(|path| self.recording_observer(path));
        // The recording finishes last, with the summary.
        let recorded = usize::from(recorder.is_some());
        let mut stats = RunStats::default();
        let mut evaluators = std::mem::take(&mut self.evaluators);
        let mut watching: Vec<&mut dyn Observer> = Vec::with_capacity(2 + observers.len());
        if let Some(recorder) = recorder.as_mut() {
            watching.push(recorder);
        }
        watching.push(&mut stats);
        watching.extend(evaluators.iter_mut().map(|e| e as &mut dyn Observer));
        watching.extend(observers.iter_mut().map(|o| shorten(&mut **o)));
        for observer in &mut watching {
            observer.start(&self.layout).map_err(observer_error)?;
        }
        let started = Instant::now();
        let ending = Session::new(&mut self).run(&mut watching)?;
        let wall_s = started.elapsed().as_secs_f64();
        let mut metrics = self.machine.metrics();
        let mut warnings = Vec::new();
        for observer in watching.iter_mut().skip(recorded) {
            let findings = observer.finish().map_err(observer_error)?;
            metrics.extend(findings.metrics);
            warnings.extend(findings.warnings);
        }
        drop(watching);
        if self.contacts.is_active() {
            let (figures, warning) = self.contacts.findings();
            metrics.extend(figures);
            warnings.extend(warning);
        }
        let scenario = &self.loaded.scenario;
        let mut summary = RunSummary {
            scenario: scenario.name.clone(),
            controller: self.loaded.controller.name().to_string(),
            dt: scenario.dt,
            steps: ending.steps,
            wall_s,
            steps_per_s: ending.steps as f64 / wall_s.max(1e-12),
            metrics,
            failure: ending.failure,
            interrupted: ending.interrupted,
            warnings,
            series_digest: ending.digest,
        };
        if let Some(recorder) = recorder.as_mut() {
            let findings = recorder.finish_with(&summary).map_err(observer_error)?;
            summary.warnings.extend(findings.warnings);
        }
        Ok(summary)
    }
}

/// A caller's observer, borrowed for as long as the run's own.
fn shorten<'x>(observer: &'x mut (dyn Observer + '_)) -> &'x mut (dyn Observer + 'x) {
    observer
}
