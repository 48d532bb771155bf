//! How a recorded run ends, as `twin run`, `twin serve` and `twin shadow` report it: the
//! `--summary` file opened before the run (refused at the recording's own path), then the run's
//! warnings, its summary JSON and the exit code of a diverged or interrupted run.

use crate::failure::{Failure, EXIT_DIVERGED};
use std::path::Path;
use std::process::ExitCode;
use twin::{same_file, summary, OutputFile, RunSummary};

/// The `--summary` file of a command that also records to `out`, opened to be written at the
/// end; refused when it is the recording's own path.
pub fn summary_file(summary: Option<&Path>, out: &Path) -> Result<Option<OutputFile>, Failure> {
    if let Some(path) = summary.filter(|p| same_file(p, out)) {
        return Err(Failure::usage(format!(
            "--summary {} is the recording's path too; give them different files",
            path.display()
        )));
    }
    Ok(summary.map(OutputFile::create).transpose()?)
}

/// The end of a run as `twin run` and `twin serve` report it: its warnings on stderr, the
/// summary JSON (when asked), and the exit code of a diverged or interrupted run.
pub fn finish(result: &RunSummary, summary_file: Option<OutputFile>) -> Result<ExitCode, Failure> {
    for warning in &result.warnings {
        eprintln!("warning: {warning}");
    }
    if let Some(file) = summary_file {
        summary::write_json(result, file)?;
    }
    Ok(match (&result.failure, &result.interrupted) {
        (Some(failure), _) => {
            eprintln!("error: {failure}");
            ExitCode::from(EXIT_DIVERGED)
        }
        (None, Some(interrupted)) => {
            eprintln!("{interrupted}: recording and summary are complete up to there");
            ExitCode::from(128 + interrupted.signal.min(127) as u8)
        }
        (None, None) => ExitCode::SUCCESS,
    })
}
