//! What a run reports ([`RunSummary`]), and how: a table for people, JSON for scripts, and the
//! table without its wall-clock rows in the recording (which holds only what the run computed).

use crate::output::{OutputError, OutputFile};
use serde_json::{json, Map, Value};
use std::fmt::Write as _;

/// Why a run stopped early: the first signal that left its bounds, or the first crash.
#[derive(Debug, Clone, PartialEq)]
pub struct Divergence {
    /// The physics step at which it was found.
    pub step: usize,
    /// Simulated time of that step, s.
    pub time: f64,
    /// The signal, or for a crash `collision <a>/<b>`.
    pub signal: String,
    /// The signal's value, or for a crash the depth of the overlap, m.
    pub value: f64,
    /// A signal out of bounds or a crash.
    pub kind: FailureKind,
}

/// What stopped a run early; either way `twin run` exits with 3.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FailureKind {
    /// A signal left its bounds: not finite, or a joint speed or loop gap beyond `[health]`.
    #[default]
    Diverged,
    /// Two links or bodies that may not touch did, and `health.stop_on_collision` is set.
    Collision,
}

impl std::fmt::Display for Divergence {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.kind {
            FailureKind::Diverged => write!(
                f,
                "run diverged at step {} (t = {:.6} s): {} = {}",
                self.step, self.time, self.signal, self.value
            ),
            FailureKind::Collision => write!(
                f,
                "run stopped at step {} (t = {:.6} s): {}, {} deep",
                self.step,
                self.time,
                self.signal,
                crate::physics::length(self.value)
            ),
        }
    }
}

/// A run stopped on request (SIGINT/SIGTERM in the CLI) before its end.
#[derive(Debug, Clone, PartialEq)]
pub struct Interruption {
    /// The signal number that asked for the stop (2: SIGINT, 15: SIGTERM).
    pub signal: usize,
    /// The last step simulated and recorded.
    pub step: usize,
    /// Simulated time of that step, s.
    pub time: f64,
}

impl std::fmt::Display for Interruption {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = match self.signal {
            2 => "SIGINT".to_string(),
            15 => "SIGTERM".to_string(),
            other => format!("signal {other}"),
        };
        write!(
            f,
            "interrupted by {name} at step {} (t = {:.6} s)",
            self.step, self.time
        )
    }
}

/// What a run reports.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSummary {
    /// The scenario's name.
    pub scenario: String,
    /// The controller's registry name.
    pub controller: String,
    /// Physics step, s.
    pub dt: f64,
    /// Index of the last physics step (steps taken after the initial one).
    pub steps: usize,
    /// Wall-clock time spent stepping, s.
    pub wall_s: f64,
    /// Physics steps per wall-clock second.
    pub steps_per_s: f64,
    /// Figures by name: the machine's, the observers' and the contacts' (SI unless the name
    /// says otherwise).
    pub metrics: Vec<(String, f64)>,
    /// Set when the run diverged or crashed before its end.
    pub failure: Option<Divergence>,
    /// Set when the run was stopped on request before its end.
    pub interrupted: Option<Interruption>,
    /// What went wrong beside the run without failing it (a live viewer that did not take it).
    pub warnings: Vec<String>,
    /// FNV-1a digest of every recorded sample's bits: equal digests, identical series.
    pub series_digest: u64,
}

impl RunSummary {
    /// A metric's value by name (the first one so named).
    pub fn metric(&self, name: &str) -> Option<f64> {
        self.metrics
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| *v)
    }
}

/// The summary as JSON: `scenario`, `controller`, `dt`, `steps`, `wall_s`, `steps_per_s`,
/// `metrics` (named numbers), `status` (`ok`, `failed` or `interrupted`), `failure` (the reason,
/// or null), `time_reached` (the simulated time of the last step, s) and `series_digest` (equal
/// digests: bit-identical recorded series).
pub fn to_json(summary: &RunSummary) -> Value {
    let metrics: Map<String, Value> = summary
        .metrics
        .iter()
        .map(|(name, value)| (name.clone(), json!(value)))
        .collect();
    json!({
        "scenario": summary.scenario,
        "controller": summary.controller,
        "dt": summary.dt,
        "steps": summary.steps,
        "wall_s": summary.wall_s,
        "steps_per_s": summary.steps_per_s,
        "metrics": metrics,
        "status": status(summary),
        "failure": summary.failure.as_ref().map(|f| f.to_string())
            .or_else(|| summary.interrupted.as_ref().map(|i| i.to_string())),
        "time_reached": summary.steps as f64 * summary.dt,
        "series_digest": format!("{:016x}", summary.series_digest),
    })
}

fn status(summary: &RunSummary) -> &'static str {
    match (&summary.failure, &summary.interrupted) {
        (Some(_), _) => "failed",
        (None, Some(_)) => "interrupted",
        (None, None) => "ok",
    }
}

/// Writes the JSON as the whole of `file` (created before the run, so a bad path fails early).
pub fn write_json(summary: &RunSummary, file: OutputFile) -> Result<(), OutputError> {
    let text = serde_json::to_string_pretty(&to_json(summary)).map_err(|e| OutputError {
        path: file.path().to_path_buf(),
        reason: e.to_string(),
    })?;
    file.commit((text + "\n").as_bytes())
}

/// The summary as an aligned text table.
pub fn to_table(summary: &RunSummary) -> String {
    table(summary, true)
}

/// The table a recording holds: without the wall time and steps/s, which differ from run to
/// run, so that the same inputs write the same recording.
pub(super) fn recorded_table(summary: &RunSummary) -> String {
    table(summary, false)
}

fn table(summary: &RunSummary, wall_clock: bool) -> String {
    let mut out = String::new();
    let status = match (&summary.failure, &summary.interrupted) {
        (Some(failure), _) => format!("FAILED: {failure}"),
        (None, Some(interrupted)) => format!("INTERRUPTED: {interrupted}"),
        (None, None) => "ok".to_string(),
    };
    let mut rows = vec![
        ("scenario", summary.scenario.clone()),
        ("controller", summary.controller.clone()),
        ("dt", format!("{} s", summary.dt)),
        ("steps", summary.steps.to_string()),
    ];
    if wall_clock {
        rows.push(("wall time", format!("{:.3} s", summary.wall_s)));
        rows.push(("steps/s", format!("{:.0}", summary.steps_per_s)));
    }
    rows.push(("status", status));
    let width = summary
        .metrics
        .iter()
        .map(|(n, _)| n.len())
        .chain(rows.iter().map(|(n, _)| n.len()))
        .max()
        .unwrap_or(0);
    for (name, value) in rows {
        let _ = writeln!(out, "{name:<width$}  {value}");
    }
    let _ = writeln!(out, "{:-<1$}", "", width + 16);
    for (name, value) in &summary.metrics {
        let _ = writeln!(out, "{name:<width$}  {value:.6e}");
    }
    out
}
