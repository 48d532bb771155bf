//! `twin sweep merge`: shard folders joined into one study folder whose `results.csv` and
//! `report.json` equal a single machine's run of the same study, byte for byte (both are made
//! from the run records alone, in index order).

use super::error::StudyError;
use super::execute::{check_folder, difference, read_study_file, write_study_file, StudyFile};
use super::files;
use super::plots;
use super::results::{self, RunRecord};
use std::path::{Path, PathBuf};

/// What a merge found.
#[derive(Debug, Clone)]
pub struct Merged {
    pub report: serde_json::Value,
    pub runs: usize,
}

/// Joins the shard folders into `out`: one study, every run present exactly once.
pub fn merge(folders: &[PathBuf], out: &Path) -> Result<Merged, StudyError> {
    let files: Vec<StudyFile> = folders
        .iter()
        .map(|f| read_study_file(f))
        .collect::<Result<_, _>>()?;
    let Some(first) = files.first() else {
        return Err(StudyError::Input("merge: give the shard folders".into()));
    };
    let whole = StudyFile {
        shard: None,
        ..first.clone()
    };
    for (folder, file) in folders.iter().zip(&files) {
        let unsharded = StudyFile {
            shard: None,
            ..file.clone()
        };
        if let Some(reason) = difference(&unsharded, &whole)
            .or_else(|| (unsharded.specs != whole.specs).then(|| "other --spec".to_string()))
        {
            return Err(StudyError::Mismatch {
                folder: folder.clone(),
                reason: format!("{reason} than {}", folders[0].display()),
            });
        }
    }
    let mut records: Vec<Option<(RunRecord, PathBuf)>> = vec![None; whole.runs];
    for folder in folders {
        for record in results::read_runs(folder)? {
            let source = RunRecord::file(folder, record.index);
            let slot = records.get_mut(record.index).ok_or_else(|| {
                StudyError::Input(format!(
                    "{}: run {} is beyond the study's {} runs",
                    source.display(),
                    record.index,
                    whole.runs
                ))
            })?;
            match slot {
                Some((earlier, _))
                    if earlier.status != record.status || earlier.metrics != record.metrics =>
                {
                    return Err(StudyError::Input(format!(
                        "{}: run {} differs from the same run in another shard",
                        source.display(),
                        record.index
                    )))
                }
                Some(_) => {}
                None => *slot = Some((record, source)),
            }
        }
    }
    let missing: Vec<usize> = (0..whole.runs).filter(|&i| records[i].is_none()).collect();
    if !missing.is_empty() {
        let shown: Vec<String> = missing.iter().take(10).map(|i| i.to_string()).collect();
        return Err(StudyError::Input(format!(
            "merge: {} of {} runs are missing (first: {}); run the shards that hold them \
             (with --resume) and merge again",
            missing.len(),
            whole.runs,
            shown.join(", ")
        )));
    }
    write_merged(out, &whole, records.into_iter().flatten())
}

/// Copies the records (bytes as they are) and writes the study's files into `out`.
fn write_merged(
    out: &Path,
    whole: &StudyFile,
    records: impl Iterator<Item = (RunRecord, PathBuf)>,
) -> Result<Merged, StudyError> {
    check_folder(out, whole)?;
    write_study_file(out, whole)?;
    for (record, source) in records {
        let target = RunRecord::file(out, record.index);
        if target != source {
            let bytes = std::fs::read(&source).map_err(|e| StudyError::Io {
                path: source.clone(),
                reason: e.to_string(),
            })?;
            files::write_file(&target, &bytes)?;
        }
    }
    let (report, records) = results::write_results(out, &whole.keys, whole.runs, &whole.specs)?;
    plots::write_plots(out, &whole.keys, &records, &whole.specs, &report)?;
    Ok(Merged {
        report,
        runs: whole.runs,
    })
}
