//! How a run is reported: a table for people, JSON for scripts.

use crate::run::RunSummary;
use serde_json::{json, Map, Value};
use std::fmt::Write as _;
use std::path::Path;

/// The summary as JSON: `scenario`, `controller`, `dt`, `steps`, `wall_s`, `steps_per_s`,
/// `metrics` (named numbers), `status` (`ok` or `failed`), `failure` (the reason, or null) and
/// `series_digest` (equal digests: bit-identical recorded series).
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
        "status": if summary.failure.is_some() { "failed" } else { "ok" },
        "failure": summary.failure.as_ref().map(|f| f.to_string()),
        "series_digest": format!("{:016x}", summary.series_digest),
    })
}

/// Writes the JSON next to its final path first, then moves it into place.
pub fn write_json(summary: &RunSummary, path: &Path) -> std::io::Result<()> {
    let text = serde_json::to_string_pretty(&to_json(summary))?;
    let mut partial = path.as_os_str().to_owned();
    partial.push(".part");
    std::fs::write(&partial, text + "\n")?;
    std::fs::rename(&partial, path)
}

/// The summary as an aligned text table.
pub fn to_table(summary: &RunSummary) -> String {
    let mut out = String::new();
    let status = match &summary.failure {
        None => "ok".to_string(),
        Some(failure) => format!("FAILED: {failure}"),
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
