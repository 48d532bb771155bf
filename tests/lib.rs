//! Helpers shared by the end-to-end tests.

use std::path::PathBuf;
use twin::{LoadedScenario, RunSummary, Scenario, ScenarioBuilder, ScenarioValue, Twin};

/// A built-in scenario to change with typed values; panics with the error (a test's typo).
pub fn builtin(name: &str) -> ScenarioBuilder {
    Scenario::builtin(name).unwrap_or_else(|e| panic!("{e}"))
}

/// The builder's fallible steps for tests that configure a run: a failure is the test's own
/// mistake, so it panics with the message instead of being handled.
pub trait Configure: Sized {
    /// `set`, panicking with the error.
    fn with(self, key: &str, value: impl Into<ScenarioValue>) -> Self;
    /// `build`, panicking with the error.
    fn loaded(self) -> LoadedScenario;
}

impl Configure for ScenarioBuilder {
    fn with(self, key: &str, value: impl Into<ScenarioValue>) -> Self {
        self.set(key, value).unwrap_or_else(|e| panic!("{e}"))
    }

    fn loaded(self) -> LoadedScenario {
        self.build(&controllers::builtin())
            .unwrap_or_else(|e| panic!("{e}"))
    }
}

/// Runs a loaded scenario with the built-in controllers, optionally recording.
pub fn run(loaded: LoadedScenario, recording: Option<&std::path::Path>) -> RunSummary {
    Twin::new(loaded)
        .and_then(|t| t.run(recording))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// What refuses `builder` as `twin run` would: building the scenario (a bad key, a bad
/// controller parameter) or binding its twin (a mismatch with the plant); `None` when neither does.
pub fn refusal(builder: ScenarioBuilder) -> Option<String> {
    match builder.build(&controllers::builtin()).map(Twin::new) {
        Ok(Ok(_)) => None,
        Ok(Err(error)) => Some(error.to_string()),
        Err(error) => Some(error.to_string()),
    }
}

/// A fresh, empty folder under the system's temp dir for one test.
pub fn scratch(test: &str) -> Scratch {
    let dir = std::env::temp_dir().join(format!("twin-tests-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    Scratch(dir)
}

/// A test's folder: removed when it goes out of scope on a passing test, kept when the test
/// fails (it is panicking then) so that what the run wrote can be read.
pub struct Scratch(PathBuf);

impl Drop for Scratch {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

impl std::ops::Deref for Scratch {
    type Target = std::path::Path;
    fn deref(&self) -> &std::path::Path {
        &self.0
    }
}

impl AsRef<std::path::Path> for Scratch {
    fn as_ref(&self) -> &std::path::Path {
        &self.0
    }
}

/// A source of uniform draws in [0, 1).
pub type Uniform<'a> = dyn FnMut() -> f64 + 'a;

/// A run's CSV as a logger would write it: the `time` column and `columns` (names without
/// their units) of `from`, each with Gaussian noise of its σ in `noise` (Box–Muller on the
/// draws of `uniform`, in [0, 1)), the rows `keep` keeps (given the row, the row count and the
/// same draws, asked before the row's noise is drawn).
pub fn logged_csv(
    from: &std::path::Path,
    columns: &[&str],
    noise: &[(&str, f64)],
    uniform: &mut Uniform,
    keep: &dyn Fn(usize, usize, &mut Uniform) -> bool,
) -> String {
    let text = std::fs::read_to_string(from).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let name = |h: &str| h.split(" [").next().unwrap().to_string();
    let kept: Vec<usize> = (0..header.len())
        .filter(|&c| c == 0 || columns.contains(&name(header[c]).as_str()))
        .collect();
    let sigma: Vec<f64> = (kept.iter())
        .map(|&c| (noise.iter().find(|(n, _)| *n == name(header[c]))).map_or(0.0, |(_, s)| *s))
        .collect();
    let rows: Vec<&str> = lines.collect();
    let mut out = kept
        .iter()
        .map(|&c| header[c])
        .collect::<Vec<_>>()
        .join(",")
        + "\n";
    for (r, row) in rows.iter().enumerate() {
        let keeping = keep(r, rows.len(), uniform);
        let cells: Vec<f64> = row.split(',').map(|v| v.parse().unwrap()).collect();
        let values: Vec<String> = (kept.iter().zip(&sigma))
            .map(|(&c, &s)| {
                let (u1, u2) = (uniform().max(f64::MIN_POSITIVE), uniform());
                let normal = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
                (cells[c] + s * normal).to_string()
            })
            .collect();
        if keeping {
            out += &(values.join(",") + "\n");
        }
    }
    out
}
