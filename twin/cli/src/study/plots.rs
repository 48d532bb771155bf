//! The study's plots as plain data for `OUT/study.rrd`: histograms of the metrics the specs name
//! (else the first few), and each of those against each numeric parameter.

use super::error::StudyError;
use super::results::{report_table, RunRecord, Spec};
use std::path::Path;
use twin::recordings::{Histogram, Scatter, StudyPlots};

/// Metrics plotted when no spec names any.
const DEFAULT_METRICS: usize = 4;
const BINS: usize = 20;

pub fn study_plots(
    title: &str,
    keys: &[String],
    records: &[RunRecord],
    specs: &[Spec],
    report: &serde_json::Value,
) -> StudyPlots {
    let (candidates, most): (Vec<&String>, usize) = if specs.is_empty() {
        let names = records
            .iter()
            .flat_map(|r| r.metrics.iter().map(|(n, _)| n));
        (names.collect(), DEFAULT_METRICS)
    } else {
        (specs.iter().map(|s| &s.metric).collect(), specs.len())
    };
    let mut metrics: Vec<String> = Vec::new();
    for name in candidates {
        if metrics.len() == most {
            break;
        }
        if !metrics.contains(name) {
            metrics.push(name.clone());
        }
    }
    let value = |r: &RunRecord, name: &str| {
        r.metrics
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.0)
            .filter(|v| v.is_finite())
    };
    let parameter = |r: &RunRecord, key: &str| {
        r.parameters
            .iter()
            .find(|(k, _)| k == key)
            .and_then(|(_, v)| v.parse::<f64>().ok())
    };
    let histograms = metrics
        .iter()
        .map(|name| {
            let values: Vec<f64> = records
                .iter()
                .filter(|r| r.ok())
                .filter_map(|r| value(r, name))
                .collect();
            histogram(name, &values)
        })
        .collect();
    let mut scatters = Vec::new();
    for key in keys {
        if !records.iter().any(|r| parameter(r, key).is_some()) {
            continue;
        }
        for name in &metrics {
            scatters.push(Scatter {
                name: format!("{name} vs {key}"),
                x_label: key.clone(),
                y_label: name.clone(),
                points: records
                    .iter()
                    .filter(|r| r.ok())
                    .filter_map(|r| Some([parameter(r, key)?, value(r, name)?]))
                    .collect(),
                failed: records
                    .iter()
                    .filter(|r| !r.ok())
                    .filter_map(|r| parameter(r, key))
                    .collect(),
            });
        }
    }
    StudyPlots {
        title: title.into(),
        notes: report_table(report),
        histograms,
        scatters,
    }
}

/// Equal bins from the smallest to the largest value.
fn histogram(name: &str, values: &[f64]) -> Histogram {
    let low = values.iter().copied().fold(f64::INFINITY, f64::min);
    let high = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (low, width) = match (low.is_finite(), high > low) {
        (true, true) => (low, (high - low) / BINS as f64),
        (true, false) => (low - 0.5, 1.0 / BINS as f64),
        _ => (0.0, 1.0 / BINS as f64),
    };
    let mut counts = vec![0.0; BINS];
    for v in values {
        let bin = (((v - low) / width) as usize).min(BINS - 1);
        counts[bin] += 1.0;
    }
    Histogram {
        name: name.into(),
        left_edges: (0..BINS).map(|i| low + i as f64 * width).collect(),
        width,
        counts,
    }
}

/// Writes `OUT/study.rrd` from the study's records and report.
pub(super) fn write_plots(
    out: &Path,
    keys: &[String],
    records: &[RunRecord],
    specs: &[Spec],
    report: &serde_json::Value,
) -> Result<(), StudyError> {
    let title = format!("study {}", out.display());
    let plots = study_plots(&title, keys, records, specs, report);
    let path = out.join("study.rrd");
    twin::recordings::write_study_plots(&path, &plots).map_err(|e| StudyError::Io {
        path,
        reason: e.to_string(),
    })
}
