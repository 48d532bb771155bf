//! A study's results: one JSON file per run (`runs/<index>.json`), then `results.csv` (a row per
//! run) and `report.json` (per-metric statistics, failure rate, spec shares) made from those
//! files alone, in index order — so a merged study's files equal a single machine's, byte for
//! byte. Wall times live only in the per-run files.

use super::error::StudyError;
use super::files::{write_file, write_json};
use serde::{Deserialize, Serialize};
use serde_json::{json, Map, Value};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// One run's outcome as written to `runs/<index>.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    pub index: usize,
    pub seed: u64,
    /// Axis key and value, in axis order (a value as TOML text: `5.25`, `"osmc"`).
    pub parameters: Vec<(String, String)>,
    /// `ok` or `failed`.
    pub status: String,
    pub failure: Option<String>,
    /// The run's summary metrics, in the summary's order; a non-finite value as `NaN`/`inf`.
    pub metrics: Vec<(String, Number)>,
    /// The run's summary JSON (wall time, digest, …), when it ran.
    pub summary: Option<Value>,
}

/// A metric value that JSON can hold even when it is not finite.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Number(pub f64);

impl Serialize for Number {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if self.0.is_finite() {
            s.serialize_f64(self.0)
        } else {
            s.serialize_str(&self.0.to_string())
        }
    }
}

impl<'de> Deserialize<'de> for Number {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        match Value::deserialize(d)? {
            Value::Number(n) => Ok(Self(n.as_f64().unwrap_or(f64::NAN))),
            Value::String(s) => s.parse().map(Self).map_err(serde::de::Error::custom),
            other => Err(serde::de::Error::custom(format!("not a number: {other}"))),
        }
    }
}

impl RunRecord {
    pub fn file(folder: &Path, index: usize) -> PathBuf {
        folder.join("runs").join(format!("{index}.json"))
    }

    /// Writes the record whole or not at all.
    pub fn write(&self, folder: &Path) -> Result<(), StudyError> {
        write_json(&Self::file(folder, self.index), self)
    }

    pub fn read(path: &Path) -> Result<Self, StudyError> {
        let io = |reason: String| StudyError::Io {
            path: path.to_path_buf(),
            reason,
        };
        let text = std::fs::read_to_string(path).map_err(|e| io(e.to_string()))?;
        serde_json::from_str(&text).map_err(|e| io(format!("not a run record: {e}")))
    }

    pub fn ok(&self) -> bool {
        self.status == "ok"
    }
}

/// A spec a run meets or not: `metric<value`, `<=`, `>`, `>=`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Spec {
    pub metric: String,
    pub operator: String,
    pub threshold: f64,
}

impl Spec {
    pub fn parse(text: &str) -> Result<Self, String> {
        let bad = || format!("--spec {text}: expected metric<value (or <=, >, >=)");
        let at = text.find(['<', '>']).ok_or_else(bad)?;
        let (metric, rest) = text.split_at(at);
        let operator = if rest[1..].starts_with('=') {
            &rest[..2]
        } else {
            &rest[..1]
        };
        let threshold: f64 = rest[operator.len()..].trim().parse().map_err(|_| bad())?;
        let metric = metric.trim();
        if metric.is_empty() || !threshold.is_finite() {
            return Err(bad());
        }
        Ok(Self {
            metric: metric.into(),
            operator: operator.into(),
            threshold,
        })
    }

    /// Whether a run meets the spec; a failed run or a missing metric does not.
    pub fn met_by(&self, run: &RunRecord) -> bool {
        let Some(Number(value)) = run.ok().then(|| metric(run, &self.metric)).flatten() else {
            return false;
        };
        match self.operator.as_str() {
            "<" => value < self.threshold,
            "<=" => value <= self.threshold,
            ">" => value > self.threshold,
            _ => value >= self.threshold,
        }
    }
}

impl std::fmt::Display for Spec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}{}{}", self.metric, self.operator, self.threshold)
    }
}

fn metric(run: &RunRecord, name: &str) -> Option<Number> {
    run.metrics.iter().find(|(n, _)| n == name).map(|(_, v)| *v)
}

/// The run records of `folder`, by index.
pub fn read_runs(folder: &Path) -> Result<Vec<RunRecord>, StudyError> {
    let runs = folder.join("runs");
    let entries = std::fs::read_dir(&runs).map_err(|e| StudyError::Io {
        path: runs.clone(),
        reason: e.to_string(),
    })?;
    let mut records = Vec::new();
    for entry in entries.flatten() {
        let path = entry.path();
        let is_record = path.extension().is_some_and(|e| e == "json")
            && path
                .file_stem()
                .and_then(|s| s.to_str())
                .is_some_and(|s| s.parse::<usize>().is_ok());
        if is_record {
            // The summary (wall time, digest) is not in the results: not kept for thousands of runs.
            let record = RunRecord::read(&path)?;
            records.push(RunRecord {
                summary: None,
                ..record
            });
        }
    }
    records.sort_by_key(|r| r.index);
    Ok(records)
}

/// `results.csv`: index, seed, the parameters, status, failure, then every metric any run
/// reports (in the order they first appear). Numbers in Rust's shortest round-trip form.
pub fn results_csv(keys: &[String], runs: &[RunRecord]) -> String {
    let names = metric_names(runs);
    let mut out = String::new();
    let header: Vec<String> = ["index", "seed"]
        .iter()
        .map(|s| s.to_string())
        .chain(keys.iter().cloned())
        .chain(["status".into(), "failure".into()])
        .chain(names.iter().cloned())
        .map(|s| csv_field(&s))
        .collect();
    let _ = writeln!(out, "{}", header.join(","));
    for run in runs {
        let mut row = vec![run.index.to_string(), run.seed.to_string()];
        row.extend(keys.iter().map(|key| {
            let value = run.parameters.iter().find(|(k, _)| k == key);
            csv_field(value.map_or("", |(_, v)| v.trim_matches('"')))
        }));
        row.push(run.status.clone());
        row.push(csv_field(run.failure.as_deref().unwrap_or("")));
        row.extend(
            names
                .iter()
                .map(|name| metric(run, name).map_or(String::new(), |v| number(v.0))),
        );
        let _ = writeln!(out, "{}", row.join(","));
    }
    out
}

/// A number in its shortest round-trip form, in scientific notation when very small or large.
fn number(v: f64) -> String {
    if v == 0.0 || (1e-3..1e6).contains(&v.abs()) || !v.is_finite() {
        v.to_string()
    } else {
        format!("{v:e}")
    }
}

fn metric_names(runs: &[RunRecord]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for (name, _) in runs.iter().flat_map(|r| &r.metrics) {
        if !names.contains(name) {
            names.push(name.clone());
        }
    }
    names
}

/// A CSV field, quoted when it holds a comma, quote or line break.
fn csv_field(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

/// Mean, σ (population), min, p5, p50, p95, max of the finite values of the successful runs.
/// Percentiles interpolate linearly between order statistics (NumPy's default, "type 7").
fn statistics(values: &mut [f64]) -> Value {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n == 0 {
        return json!({ "count": 0 });
    }
    let mean = values.iter().sum::<f64>() / n as f64;
    let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64;
    let percentile = |p: f64| {
        let rank = p * (n - 1) as f64;
        let (low, high) = (rank.floor() as usize, rank.ceil() as usize);
        values[low] + (rank - low as f64) * (values[high] - values[low])
    };
    json!({
        "count": n,
        "mean": mean,
        "std": variance.sqrt(),
        "min": values[0],
        "p5": percentile(0.05),
        "p50": percentile(0.5),
        "p95": percentile(0.95),
        "max": values[n - 1],
    })
}

/// `report.json`: the runs present and planned, failures, per-metric statistics and the share
/// of runs meeting each spec and all of them.
pub fn report(runs: &[RunRecord], planned: usize, specs: &[Spec]) -> Result<Value, StudyError> {
    let ok: Vec<&RunRecord> = runs.iter().filter(|r| r.ok()).collect();
    let failed = runs.len() - ok.len();
    let names = metric_names(runs);
    for spec in specs {
        if !runs.is_empty() && !names.contains(&spec.metric) {
            return Err(StudyError::Input(format!(
                "--spec {spec}: no run reports a metric `{}` (known: {})",
                spec.metric,
                names.join(", ")
            )));
        }
    }
    let mut metrics = Map::new();
    for name in &names {
        let mut values: Vec<f64> = ok
            .iter()
            .filter_map(|r| metric(r, name))
            .map(|v| v.0)
            .filter(|v| v.is_finite())
            .collect();
        metrics.insert(name.clone(), statistics(&mut values));
    }
    let share = |count: usize| match runs.len() {
        0 => 0.0,
        n => count as f64 / n as f64,
    };
    let spec_rows: Vec<Value> = specs
        .iter()
        .map(|spec| {
            let met = runs.iter().filter(|r| spec.met_by(r)).count();
            json!({ "spec": spec.to_string(), "met": met, "share": share(met) })
        })
        .collect();
    let all_met = runs
        .iter()
        .filter(|r| specs.iter().all(|s| s.met_by(r)))
        .count();
    Ok(json!({
        "runs_planned": planned,
        "runs": runs.len(),
        "ok": ok.len(),
        "failed": failed,
        "failure_rate": share(failed),
        "metrics": metrics,
        "specs": spec_rows,
        "all_specs_met": if specs.is_empty() { Value::Null } else { json!(all_met) },
        "all_specs_share": if specs.is_empty() { Value::Null } else { json!(share(all_met)) },
    }))
}

/// The report as text for people: failures, specs, then a line per metric.
pub fn report_table(report: &Value) -> String {
    let mut out = String::new();
    let field = |key: &str| report.get(key).cloned().unwrap_or(Value::Null);
    let _ = writeln!(
        out,
        "runs {} of {} planned: {} ok, {} failed (failure rate {:.1} %)",
        field("runs"),
        field("runs_planned"),
        field("ok"),
        field("failed"),
        100.0 * field("failure_rate").as_f64().unwrap_or(0.0)
    );
    for spec in field("specs").as_array().into_iter().flatten() {
        let _ = writeln!(
            out,
            "spec {:<32} met by {} runs ({:.1} %)",
            spec["spec"].as_str().unwrap_or(""),
            spec["met"],
            100.0 * spec["share"].as_f64().unwrap_or(0.0)
        );
    }
    if let Some(share) = field("all_specs_share").as_f64() {
        let _ = writeln!(out, "all specs met by {:.1} % of runs", 100.0 * share);
    }
    let _ = writeln!(
        out,
        "{:<40} {:>12} {:>12} {:>12} {:>12} {:>12} {:>12} {:>12}",
        "metric", "mean", "std", "min", "p5", "p50", "p95", "max"
    );
    for (name, stats) in field("metrics").as_object().into_iter().flatten() {
        let cell = |k: &str| {
            stats
                .get(k)
                .and_then(Value::as_f64)
                .map_or("-".into(), |v| format!("{v:.4e}"))
        };
        let _ = writeln!(
            out,
            "{name:<40} {:>12} {:>12} {:>12} {:>12} {:>12} {:>12} {:>12}",
            cell("mean"),
            cell("std"),
            cell("min"),
            cell("p5"),
            cell("p50"),
            cell("p95"),
            cell("max")
        );
    }
    out
}

/// Writes `results.csv` and `report.json` for the runs in `folder`; returns the report.
pub fn write_results(
    folder: &Path,
    keys: &[String],
    planned: usize,
    specs: &[Spec],
) -> Result<(Value, Vec<RunRecord>), StudyError> {
    let runs = read_runs(folder)?;
    let report = report(&runs, planned, specs)?;
    write_file(
        &folder.join("results.csv"),
        results_csv(keys, &runs).as_bytes(),
    )?;
    write_json(&folder.join("report.json"), &report)?;
    Ok((report, runs))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(index: usize, status: &str, mse: f64) -> RunRecord {
        RunRecord {
            index,
            seed: 1,
            parameters: vec![("k".into(), format!("{index}"))],
            status: status.into(),
            failure: (status != "ok").then(|| "diverged, at step 3".into()),
            metrics: vec![("mse".into(), Number(mse))],
            summary: None,
        }
    }

    #[test]
    fn statistics_match_a_hand_computation() {
        let runs: Vec<RunRecord> = (0..5).map(|i| record(i, "ok", i as f64)).collect();
        let report = report(&runs, 5, &[Spec::parse("mse<2").unwrap()]).unwrap();
        let mse = &report["metrics"]["mse"];
        assert_eq!(mse["mean"], 2.0);
        assert_eq!(mse["std"], 2f64.sqrt());
        assert_eq!(mse["p5"], 0.2);
        assert_eq!(mse["p50"], 2.0);
        assert_eq!(mse["p95"], 3.8);
        assert_eq!(report["specs"][0]["met"], 2);
        assert_eq!(report["all_specs_share"], 0.4);
    }

    #[test]
    fn failed_runs_count_as_failures_and_miss_every_spec() {
        let runs = vec![record(0, "ok", 1.0), record(1, "failed", 0.5)];
        let report = report(&runs, 2, &[Spec::parse("mse<=1").unwrap()]).unwrap();
        assert_eq!(report["failure_rate"], 0.5);
        assert_eq!(report["metrics"]["mse"]["count"], 1);
        assert_eq!(report["specs"][0]["met"], 1);
        let csv = results_csv(&["k".into()], &runs);
        assert_eq!(
            csv,
            "index,seed,k,status,failure,mse\n0,1,0,ok,,1\n1,1,1,failed,\"diverged, at step 3\",0.5\n"
        );
    }

    #[test]
    fn specs_parse_and_refuse() {
        let spec = Spec::parse("tracking_mse>=1e-4").unwrap();
        assert_eq!((spec.operator.as_str(), spec.threshold), (">=", 1e-4));
        assert!(Spec::parse("tracking_mse=1").is_err());
        assert!(Spec::parse("<1").is_err());
        assert!(Spec::parse("a<b").is_err());
        let runs = vec![record(0, "ok", 1.0)];
        let err = report(&runs, 1, &[Spec::parse("bogus<1").unwrap()]).unwrap_err();
        assert!(err.to_string().contains("known: mse"), "{err}");
    }
}
