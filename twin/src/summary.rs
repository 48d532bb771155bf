//! How a run is reported: a table for people, JSON for scripts.

use crate::output::{OutputError, OutputFile};
use crate::run::RunSummary;
use serde_json::{json, Map, Value};
use std::fmt::Write as _;

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
    let mut out = String::new();
    let status = match (&summary.failure, &summary.interrupted) {
        (Some(failure), _) => format!("FAILED: {failure}"),
        (None, Some(interrupted)) => format!("INTERRUPTED: {interrupted}"),
        (None, None) => "ok".to_string(),
    };
    let rows = [
        ("scenario", summary.scenario.clone()),
        ("controller", summary.controller.clone()),
        ("dt", format!("{} s", summary.dt)),
        ("steps", summary.steps.to_string()),
        ("wall time", format!("{:.3} s", summary.wall_s)),
        ("steps/s", format!("{:.0}", summary.steps_per_s)),
        ("status", status),
    ];
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
