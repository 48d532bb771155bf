//! Output files written whole or not at all: a uniquely named temporary file in the target's own
//! folder, renamed onto the target only once complete, removed on every other path (errors,
//! panics). Two writers of one path never mix their bytes: the last to finish wins.

use std::io::Write;
use std::path::{Path, PathBuf};
use thiserror::Error;

#[derive(Debug, Error)]
#[error("cannot write {}: {reason}", path.display())]
pub struct OutputError {
    pub path: PathBuf,
    pub reason: String,
}

/// A file being written; see the module doc.
#[derive(Debug)]
pub struct OutputFile {
    path: PathBuf,
    temporary: tempfile::NamedTempFile,
}

impl OutputFile {
    /// Checks that `path` can be written (not a directory, its folder exists and takes a file)
    /// by creating the temporary file now, before any long work.
    pub fn create(path: &Path) -> Result<Self, OutputError> {
        let error = |reason: String| OutputError {
            path: path.to_path_buf(),
            reason,
        };
        if path.is_dir() {
            return Err(error("it is a directory; name a file".into()));
        }
        let folder = folder_of(path);
        if !folder.is_dir() {
            return Err(error(format!("folder {} does not exist", folder.display())));
        }
        let name = path
            .file_name()
            .ok_or_else(|| error("no file name".into()))?;
        let temporary = tempfile::Builder::new()
            .prefix(&format!("{}.", name.to_string_lossy()))
            .suffix(".part")
            .tempfile_in(folder)
            .map_err(|e| error(e.to_string()))?;
        Ok(Self {
            path: path.to_path_buf(),
            temporary,
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes `bytes` as the whole file, then moves it into place.
    pub fn commit(mut self, bytes: &[u8]) -> Result<(), OutputError> {
        let error = |reason: String| OutputError {
            path: self.path.clone(),
            reason,
        };
        let file = self.temporary.as_file_mut();
        file.write_all(bytes)
            .and_then(|()| file.sync_all())
            .map_err(|e| error(e.to_string()))?;
        let path = self.path.clone();
        self.temporary
            .persist(&path)
            .map(drop)
            .map_err(|e| error(e.error.to_string()))
    }
}

/// The folder a relative or absolute file path lies in (`.` for a bare name).
pub fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    }
}

/// Whether two paths name the same file, whether or not it exists yet.
pub fn same_file(a: &Path, b: &Path) -> bool {
    let resolve = |p: &Path| {
        let folder = folder_of(p).canonicalize().ok()?;
        Some(folder.join(p.file_name()?))
    };
    match (resolve(a), resolve(b)) {
        (Some(a), Some(b)) => a == b,
        _ => a == b,
    }
}
