//! Writing a study's files whole or not at all.

use super::error::StudyError;
use serde::Serialize;
use std::path::Path;
use twin::OutputFile;

/// Writes `bytes` as the whole of `path`, or nothing (see [`OutputFile`]).
pub(super) fn write_file(path: &Path, bytes: &[u8]) -> Result<(), StudyError> {
    OutputFile::create(path)
        .and_then(|file| file.commit(bytes))
        .map_err(|e| StudyError::Io {
            path: path.to_path_buf(),
            reason: e.reason,
        })
}

/// Writes `value` as pretty JSON ending in a newline, whole or not at all.
pub(super) fn write_json(path: &Path, value: &impl Serialize) -> Result<(), StudyError> {
    let text = serde_json::to_string_pretty(value).map_err(|e| StudyError::Io {
        path: path.to_path_buf(),
        reason: e.to_string(),
    })?;
    write_file(path, (text + "\n").as_bytes())
}
