//! What a shadow tells at its end: its summary (anomalies, parameters, intake, timing) on
//! stdout, in the recording and as JSON.

use super::feed::Outcome;
use crate::failure::Failure;
use serde_json::json;
use std::path::Path;
use std::process::ExitCode;
use twin::shadowing::{Anomaly, Shadow, ShadowRecording};
use twin::OutputFile;

/// The p-th quantile (0–1) of `values`, s → µs.
fn quantile_us(values: &[f64], p: f64) -> Option<f64> {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let index = ((sorted.len() as f64 - 1.0) * p).round() as usize;
    sorted.get(index).map(|v| v * 1e6)
}

/// The summary as JSON.
fn summary_json(shadow: &Shadow, outcome: &Outcome) -> serde_json::Value {
    let parameters: Vec<_> = (shadow.parameters().iter())
        .zip(shadow.estimates())
        .map(|(key, (estimate, sigma))| {
            json!({"key": key, "estimate": estimate, "sigma": sigma,
                   "interval": [estimate - 1.96 * sigma, estimate + 1.96 * sigma]})
        })
        .collect();
    let gaps: Vec<_> = (outcome.gaps.iter())
        .map(|(lost, restored)| json!({"lost": lost, "restored": restored}))
        .collect();
    let behind: Vec<_> = (outcome.behind.iter())
        .map(|(from, to)| json!({"from": from, "to": to}))
        .collect();
    json!({
        "scenario": shadow.scenario_name(),
        "signals": shadow.watched(),
        "origin": shadow.origin(),
        "anomalies": shadow.anomalies(),
        "parameters": parameters,
        "intake": shadow.counts(),
        "thresholds": shadow.thresholds().map(|[cusum, nis, drift]| {
            json!({"cusum_h": cusum, "nis_sigmas": nis, "drift_sigmas": drift})
        }),
        "cost_us": {"p50": quantile_us(&outcome.costs, 0.5), "p99": quantile_us(&outcome.costs, 0.99)},
        "latency_us": {"p50": quantile_us(&outcome.latencies, 0.5),
                       "p99": quantile_us(&outcome.latencies, 0.99)},
        "clock_offset_s": outcome.clock_offset,
        "slow_sampling": outcome.slow_sampling.iter()
            .map(|(node, interval)| json!({"node": node, "granted_s": interval}))
            .collect::<Vec<_>>(),
        "behind": {"spans": behind, "most_s": outcome.most_behind},
        "connection_gaps": gaps,
        "sample_gaps": shadow.gaps(),
        "interrupted_by_signal": outcome.interrupted,
    })
}

/// One anomaly as a table line.
fn anomaly_line(anomaly: &Anomaly) -> String {
    let end = anomaly.end.map_or("open".into(), |e| format!("{e:.3} s"));
    let cause = anomaly
        .attribution
        .as_ref()
        .map_or("unexplained".into(), |a| {
            format!(
                "{} {:.6} → {:.6} [{:.6}, {:.6}]",
                a.parameter, a.before, a.estimate, a.interval[0], a.interval[1]
            )
        });
    format!(
        "  {:.3} s (detected {:.3} s) – {end}: {}; size {:.1} σ; {cause}",
        anomaly.start,
        anomaly.detected,
        anomaly.signals.join(", "),
        anomaly.size
    )
}

/// Prints the summary, completes the recording and writes the JSON.
pub fn finish(
    shadow: &Shadow,
    recording: ShadowRecording,
    outcome: &Outcome,
    out: &Path,
    summary_file: Option<OutputFile>,
) -> Result<ExitCode, Failure> {
    let counts = shadow.counts();
    let mut text = format!(
        "shadow of {}: {} samples ({} late, {} repeated, {} reordered)\n",
        shadow.scenario_name(),
        counts.processed,
        counts.late,
        counts.duplicate,
        counts.reordered
    );
    let anomalies = shadow.anomalies();
    text.push_str(&format!("anomalies: {}\n", anomalies.len()));
    for anomaly in &anomalies {
        text.push_str(&anomaly_line(anomaly));
        text.push('\n');
    }
    for (key, (estimate, sigma)) in shadow.parameters().iter().zip(shadow.estimates()) {
        text.push_str(&format!(
            "{key}: {estimate:.6} ± {:.6} (95 %)\n",
            1.96 * sigma
        ));
    }
    text.push_str(&live_lines(shadow, outcome));
    // The cost is this computer's, not the data's: on stderr (and in the JSON's `cost_us`), so
    // that the same data print the same report and write the same recording.
    let cost = quantile_us(&outcome.costs, 0.5).map_or(String::new(), |p50| {
        format!("estimator + detector: {p50:.0} µs per update (median; an update takes the values measured at one time)\n")
    });
    recording.finish(&text)?;
    print!("{text}");
    eprint!("{cost}");
    println!("recording: {}", out.display());
    if let Some(file) = summary_file {
        let bytes = serde_json::to_vec_pretty(&summary_json(shadow, outcome))?;
        file.commit(&bytes)?;
    }
    // As `twin run` ends on a signal: 128 + its number, the files complete.
    Ok(match outcome.interrupted {
        Some(signal) => {
            eprintln!("stopped by signal {signal}: recording and summary are complete up to there");
            ExitCode::from(128 + signal.min(127) as u8)
        }
        None => ExitCode::SUCCESS,
    })
}

/// Live: the clocks' offset, the latency net of it, how far behind the shadow fell and what it
/// did with commands that came too late.
fn live_lines(shadow: &Shadow, outcome: &Outcome) -> String {
    let mut text = String::new();
    if let Some(offset) = outcome.clock_offset {
        text.push_str(&format!(
            "machine clock: {offset:.6} s behind this computer's (offset and fastest transport); \
             latency beyond it {:.0} µs median, {:.0} µs p99\n",
            quantile_us(&outcome.latencies, 0.5).unwrap_or(0.0),
            quantile_us(&outcome.latencies, 0.99).unwrap_or(0.0)
        ));
        text.push_str(&format!(
            "behind the machine: at most {:.2} s, {} times more than {:.0} s; nothing dropped for it\n",
            outcome.most_behind,
            outcome.behind.len(),
            super::feed::BEHIND
        ));
    }
    let late = shadow.counts().late_commands;
    if late > 0 {
        text.push_str(&format!(
            "{late} commands came too late to be used: each time the state was taken up again \
             with the parameters held and the tests paused\n"
        ));
    }
    text
}
