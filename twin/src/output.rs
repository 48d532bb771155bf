//! Output files written whole or not at all: a uniquely named temporary file in the target's own
//! folder, renamed onto the target only once complete, removed on every other path (errors,
//! panics). Two writers of one path never mix their bytes: the last to finish wins.

use std::io::Write;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// An output file could not be created, written or moved into place.
#[derive(Debug, Error)]
#[error("cannot write {}: {reason}", path.display())]
pub struct OutputError {
    /// The target file.
    pub path: PathBuf,
    /// What the file system said.
    pub reason: String,
}

/// A file being written; see the module doc.
#[derive(Debug)]
pub struct OutputFile {
    path: PathBuf,
    temporary: tempfile::NamedTempFile,
}

impl OutputFile {
    /// Checks that `path` can be written (see `temporary_beside`) by creating the temporary
    /// file now, before any long work.
    pub fn create(path: &Path) -> Result<Self, OutputError> {
        let temporary = temporary_beside(path).map_err(|reason| OutputError {
            path: path.to_path_buf(),
            reason,
        })?;
        Ok(Self {
            path: path.to_path_buf(),
            temporary,
        })
    }

    /// The target the file is renamed onto when committed.
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

/// Creates `<name>.<random>.part` in the folder of `path`: a unique name keeps concurrent writers
/// of one path apart, and a name derived from the final one lets a user find what a killed run
/// left. Fails, saying why, when `path` is a directory or its folder is missing or not writable.
pub fn temporary_beside(path: &Path) -> Result<tempfile::NamedTempFile, String> {
    if path.is_dir() {
        return Err("it is a directory".to_owned());
    }
    let name = path
        .file_name()
        .ok_or_else(|| "it does not name a file".to_owned())?;
    let folder = folder_of(path);
    match std::fs::metadata(folder) {
        Ok(meta) if meta.is_dir() => {}
        Ok(_) => return Err(format!("{} is not a folder", folder.display())),
        Err(err) if err.kind() == std::io::ErrorKind::NotFound => {
            return Err(format!("its folder {} does not exist", folder.display()));
        }
        Err(err) => return Err(format!("its folder {}: {err}", folder.display())),
    }
    let mut prefix = name.to_owned();
    prefix.push(".");
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".part").rand_bytes(6);
    // Like `File::create`: readable as the umask allows (tempfile's default is owner-only).
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
    builder
        .tempfile_in(folder)
        .map_err(|err| format!("cannot create a file in {}: {err}", folder.display()))
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

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("twin-output-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn a_file_appears_whole_only_on_commit() {
        let dir = scratch("commit");
        let path = dir.join("s.json");
        let file = OutputFile::create(&path).unwrap();
        let pending = entries(&dir);
        assert_eq!(pending.len(), 1);
        assert!(pending[0].starts_with("s.json.") && pending[0].ends_with(".part"));
        file.commit(b"{}\n").unwrap();
        assert_eq!(entries(&dir), ["s.json"]);
        assert_eq!(std::fs::read(&path).unwrap(), b"{}\n");
        // Readable by others as the umask allows, like any file the user writes.
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&path).unwrap().permissions().mode();
            assert_ne!(mode & 0o044, 0, "mode {mode:o}");
        }
        // Dropped without a commit (an error path): nothing is left.
        drop(OutputFile::create(&dir.join("t.json")).unwrap());
        assert_eq!(entries(&dir), ["s.json"]);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn bad_paths_fail_at_create_and_a_failed_commit_names_the_path() {
        let dir = scratch("bad");
        let reason = |path: &Path| OutputFile::create(path).unwrap_err().reason;
        assert!(reason(&dir).contains("directory"));
        assert!(reason(&dir.join("missing/s.json")).contains("does not exist"));
        let path = dir.join("gone/s.json");
        std::fs::create_dir(dir.join("gone")).unwrap();
        let file = OutputFile::create(&path).unwrap();
        std::fs::remove_dir_all(dir.join("gone")).unwrap();
        let error = file.commit(b"x").unwrap_err();
        assert_eq!(error.path, path);
        assert!(entries(&dir).is_empty());
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn same_file_sees_through_spellings() {
        let dir = scratch("same");
        assert!(same_file(&dir.join("a.rrd"), &dir.join("./a.rrd")));
        assert!(!same_file(&dir.join("a.rrd"), &dir.join("b.rrd")));
        std::fs::remove_dir_all(&dir).ok();
    }
}
