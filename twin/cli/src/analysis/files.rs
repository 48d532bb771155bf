//! Writing an analysis' files: its folder, and each file whole or not at all.

use super::error::AnalysisError;
use std::path::Path;
use twin::OutputFile;

/// Creates `dir` (and its parents) for an analysis' files.
pub(crate) fn create_dir(dir: &Path) -> Result<(), AnalysisError> {
    std::fs::create_dir_all(dir).map_err(|e| AnalysisError::Output {
        path: dir.to_path_buf(),
        reason: e.to_string(),
    })
}

/// Writes `text` as the whole of `path` (see [`twin::OutputFile`]: never a half-written file).
pub(crate) fn write_text(path: &Path, text: &str) -> Result<(), AnalysisError> {
    let output_error = |e: twin::OutputError| AnalysisError::Output {
        path: e.path,
        reason: e.reason,
    };
    OutputFile::create(path)
        .and_then(|file| file.commit(text.as_bytes()))
        .map_err(output_error)
}
