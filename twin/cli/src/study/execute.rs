//! Running a study: the folder checked and claimed, the runs spread over a thread pool (one run
//! per thread), each run's record written as it ends, then the results made from the records.

use super::definition::{RunPlan, Study, StudyDefinition};
use super::error::StudyError;
use super::files;
use super::plots;
use super::results::{self, RunRecord, Spec};
use framework::Registry;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use twin::{summary, StopFlag, Twin};

/// Which runs keep their recording (`OUT/recordings/<index>.rrd`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum RecordMode {
    #[default]
    None,
    Failed,
    All,
}

/// A share of a study's runs: those with index ≡ `index` (mod `count`) — round robin, so each
/// shard gets runs from every part of the grid and about the same work.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl Shard {
    /// `i/n`, or `auto`: Slurm's `SLURM_ARRAY_TASK_ID`/`SLURM_ARRAY_TASK_COUNT`, else
    /// Kubernetes' `JOB_COMPLETION_INDEX` with n from `count` (`--shard-count`).
    pub fn parse(text: &str, count: Option<usize>) -> Result<Self, String> {
        let var = |name: &str| std::env::var(name).ok();
        let (index, total) = if text == "auto" {
            match (var("SLURM_ARRAY_TASK_ID"), var("JOB_COMPLETION_INDEX")) {
                (Some(id), _) => (
                    id,
                    var("SLURM_ARRAY_TASK_COUNT").or(count.map(|c| c.to_string())),
                ),
                (None, Some(id)) => (id, count.map(|c| c.to_string())),
                (None, None) => {
                    return Err("--shard auto: neither SLURM_ARRAY_TASK_ID nor \
                                JOB_COMPLETION_INDEX is set; give --shard i/n"
                        .into())
                }
            }
        } else {
            let (i, n) = text
                .split_once('/')
                .ok_or_else(|| format!("--shard {text}: expected i/n or auto"))?;
            (i.to_string(), Some(n.to_string()))
        };
        let total =
            total.ok_or("--shard auto: the shard count is unknown; give --shard-count n")?;
        let (index, count): (usize, usize) = match (index.trim().parse(), total.trim().parse()) {
            (Ok(i), Ok(n)) => (i, n),
            _ => return Err(format!("--shard {index}/{total}: not whole numbers")),
        };
        if count == 0 || index >= count {
            return Err(format!("--shard {index}/{count}: out of range (0 ≤ i < n)"));
        }
        Ok(Self { index, count })
    }

    fn holds(&self, run: usize) -> bool {
        run % self.count == self.index
    }
}

/// How to run a study.
#[derive(Debug, Clone)]
pub struct StudyOptions {
    pub out: PathBuf,
    pub jobs: usize,
    pub record: RecordMode,
    pub resume: bool,
    pub only: Option<usize>,
    pub shard: Option<Shard>,
    pub specs: Vec<Spec>,
}

/// `OUT/study.json`: the definition, the specs and which shard the folder holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(super) struct StudyFile {
    pub definition: StudyDefinition,
    pub keys: Vec<String>,
    pub runs: usize,
    pub specs: Vec<Spec>,
    pub shard: Option<Shard>,
}

/// How a study went.
#[derive(Debug, Clone)]
pub struct StudyOutcome {
    pub report: serde_json::Value,
    /// Runs done now (not those found from before with `--resume`).
    pub ran: usize,
    pub skipped: usize,
    /// Set when a signal stopped the study; `--resume` finishes it.
    pub interrupted: Option<usize>,
    pub wall_s: f64,
}

/// Runs the study's runs (those of the shard, or only one) into `options.out`.
pub fn run_study(
    study: &Study,
    options: &StudyOptions,
    registry: &Registry,
    stop: &StopFlag,
) -> Result<StudyOutcome, StudyError> {
    let started = std::time::Instant::now();
    if options.jobs == 0 {
        return Err(StudyError::Input("--jobs must be ≥ 1".into()));
    }
    if let Some(only) = options.only.filter(|&i| i >= study.runs()) {
        return Err(StudyError::Input(format!(
            "--only {only}: the study has runs 0 to {}",
            study.runs() - 1
        )));
    }
    let file = StudyFile {
        definition: study.definition.clone(),
        keys: study.keys(),
        runs: study.runs(),
        specs: options.specs.clone(),
        shard: options.shard,
    };
    check_folder(&options.out, &file)?;
    let mut todo: Vec<usize> = (0..study.runs())
        .filter(|&i| options.only.is_none_or(|only| only == i))
        .filter(|&i| options.shard.is_none_or(|s| s.holds(i)))
        .collect();
    let planned = todo.len();
    if options.resume {
        todo.retain(|&i| !RunRecord::file(&options.out, i).exists());
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(options.jobs)
        .build()
        .map_err(|e| StudyError::Input(format!("--jobs {}: {e}", options.jobs)))?;
    pool.install(|| check_runs(study, &todo, registry))?;
    write_study_file(&options.out, &file)?;
    let progress = Progress::new(todo.len() as u64);
    let first_error = Mutex::new(None);
    pool.install(|| {
        todo.par_iter().for_each(|&index| {
            if stop.load(Ordering::Relaxed) != 0 {
                return;
            }
            let outcome = run_one(study, index, registry, options, stop).and_then(|record| {
                record
                    .map(|r| r.write(&options.out).map(|()| r))
                    .transpose()
            });
            match outcome {
                Ok(Some(record)) => progress.done(&record),
                Ok(None) => {}
                Err(error) => {
                    if let Ok(mut first) = first_error.lock() {
                        first.get_or_insert(error);
                    }
                    stop.store(usize::MAX, Ordering::Relaxed);
                }
            }
        })
    });
    progress.finish();
    if let Some(error) = first_error.into_inner().ok().flatten() {
        return Err(error);
    }
    let (report, records) =
        results::write_results(&options.out, &file.keys, planned, &options.specs)?;
    plots::write_plots(&options.out, &file.keys, &records, &options.specs, &report)?;
    let interrupted = Some(stop.load(Ordering::Relaxed)).filter(|&s| s != 0);
    Ok(StudyOutcome {
        report,
        ran: progress.count.load(Ordering::Relaxed),
        skipped: planned - todo.len(),
        interrupted,
        wall_s: started.elapsed().as_secs_f64(),
    })
}

/// Checks that a `study.json` already in `out` is this study's.
pub(super) fn check_folder(out: &Path, file: &StudyFile) -> Result<(), StudyError> {
    if out.join("study.json").exists() {
        if let Some(reason) = difference(&read_study_file(out)?, file) {
            return Err(StudyError::Mismatch {
                folder: out.to_path_buf(),
                reason,
            });
        }
    }
    Ok(())
}

/// The `study.json` of a study folder.
pub(super) fn read_study_file(folder: &Path) -> Result<StudyFile, StudyError> {
    let path = folder.join("study.json");
    let text = std::fs::read_to_string(&path).map_err(|e| StudyError::Io {
        path: path.clone(),
        reason: format!("{e} (not a study folder?)"),
    })?;
    serde_json::from_str(&text).map_err(|e| StudyError::Io {
        path,
        reason: format!("not a study file: {e}"),
    })
}

/// Creates the folder and its `runs/`, and writes `study.json`.
pub(super) fn write_study_file(out: &Path, file: &StudyFile) -> Result<(), StudyError> {
    std::fs::create_dir_all(out.join("runs")).map_err(|e| StudyError::Io {
        path: out.to_path_buf(),
        reason: e.to_string(),
    })?;
    files::write_json(&out.join("study.json"), file)
}

/// What makes two study files different studies (specs may change between resumes).
pub(super) fn difference(a: &StudyFile, b: &StudyFile) -> Option<String> {
    let (x, y) = (&a.definition, &b.definition);
    let differs = [
        (x.scenario != y.scenario, "scenario"),
        (x.base_toml != y.base_toml, "the scenario's contents"),
        (x.set != y.set, "--set"),
        (x.grid != y.grid, "--grid"),
        (x.random != y.random, "--random"),
        (x.samples != y.samples, "--samples"),
        (x.seed != y.seed, "--seed"),
        (a.shard != b.shard, "--shard"),
    ];
    differs
        .iter()
        .find(|(d, _)| *d)
        .map(|(_, what)| format!("another {what}"))
}

/// Builds every run's scenario before any run starts, so that a bad key or parameter — the
/// base's or an axis value's — stops the study naming the first run it breaks (a run whose draw
/// fails is recorded as failed instead). The first run's twin is bound too: a scenario that does
/// not fit the plant breaks every run alike.
fn check_runs(study: &Study, todo: &[usize], registry: &Registry) -> Result<(), StudyError> {
    let refused: Vec<(usize, String)> = todo
        .par_iter()
        .filter_map(|&index| {
            let plan = study.plan(index).ok()?;
            let built = study.scenario(&plan).and_then(|b| b.build(registry));
            built.err().map(|error| (index, error.to_string()))
        })
        .collect();
    if let Some((index, reason)) = refused.first() {
        return Err(StudyError::Refused {
            index: *index,
            more: refused.len() - 1,
            reason: reason.clone(),
        });
    }
    let Some(&first) = todo.first() else {
        return Ok(());
    };
    let refuse = |reason: String| StudyError::Refused {
        index: first,
        more: 0,
        reason,
    };
    let plan = study.plan(first).map_err(refuse)?;
    let loaded = study
        .scenario(&plan)
        .and_then(|b| b.build(registry))
        .map_err(|e| refuse(e.to_string()))?;
    Twin::new(loaded).map_err(|e| refuse(e.to_string()))?;
    Ok(())
}

/// One run: its record, or `None` when a signal stopped it (a resume runs it again).
fn run_one(
    study: &Study,
    index: usize,
    registry: &Registry,
    options: &StudyOptions,
    stop: &StopFlag,
) -> Result<Option<RunRecord>, StudyError> {
    let plan = match study.plan(index) {
        Ok(plan) => plan,
        Err(reason) => {
            let plan = RunPlan {
                index,
                seed: super::axis::run_seed(study.definition.seed, index),
                parameters: Vec::new(),
            };
            return Ok(Some(failed(&plan, reason)));
        }
    };
    let twin = study
        .scenario(&plan)
        .and_then(|b| b.build(registry))
        .map_err(|e| e.to_string())
        .and_then(|loaded| Twin::new(loaded).map_err(|e| e.to_string()));
    let twin = match twin {
        Ok(twin) => twin.with_stop_flag(stop.clone()),
        Err(reason) => return Ok(Some(failed(&plan, reason))),
    };
    let recording = recording_path(&options.out, index, options.record)?;
    let summary = match twin.run(recording.as_deref()) {
        Ok(summary) => summary,
        Err(error) => return Ok(Some(failed(&plan, error.to_string()))),
    };
    if summary.interrupted.is_some() {
        if let Some(path) = &recording {
            let _ = std::fs::remove_file(path);
        }
        return Ok(None);
    }
    if let (Some(path), None, RecordMode::Failed) = (&recording, &summary.failure, options.record) {
        let _ = std::fs::remove_file(path);
    }
    Ok(Some(RunRecord {
        index,
        seed: plan.seed,
        parameters: parameters(&plan),
        status: if summary.failure.is_some() {
            "failed"
        } else {
            "ok"
        }
        .into(),
        failure: summary.failure.as_ref().map(|f| f.to_string()),
        metrics: summary
            .metrics
            .iter()
            .map(|(n, v)| (n.clone(), results::Number(*v)))
            .collect(),
        summary: Some(summary::to_json(&summary)),
    }))
}

fn parameters(plan: &RunPlan) -> Vec<(String, String)> {
    plan.parameters
        .iter()
        .map(|(k, v)| (k.clone(), v.to_string()))
        .collect()
}

fn failed(plan: &RunPlan, reason: String) -> RunRecord {
    RunRecord {
        index: plan.index,
        seed: plan.seed,
        parameters: parameters(plan),
        status: "failed".into(),
        failure: Some(reason),
        metrics: Vec::new(),
        summary: None,
    }
}

fn recording_path(
    out: &Path,
    index: usize,
    mode: RecordMode,
) -> Result<Option<PathBuf>, StudyError> {
    if mode == RecordMode::None {
        return Ok(None);
    }
    let folder = out.join("recordings");
    std::fs::create_dir_all(&folder).map_err(|e| StudyError::Io {
        path: folder.clone(),
        reason: e.to_string(),
    })?;
    Ok(Some(folder.join(format!("{index}.rrd"))))
}

/// Done/total, failures so far and ETA: a bar on a terminal, else a line per 5 % and per
/// failure.
struct Progress {
    bar: Option<ProgressBar>,
    total: u64,
    count: AtomicUsize,
    failures: AtomicUsize,
}

impl Progress {
    fn new(total: u64) -> Self {
        let bar = std::io::stdout().is_terminal().then(|| {
            let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stdout());
            let style =
                ProgressStyle::with_template("{bar:40} {pos}/{len} runs, {msg} failed, ETA {eta}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar());
            bar.set_style(style);
            bar.set_message("0");
            bar
        });
        Self {
            bar,
            total,
            count: AtomicUsize::new(0),
            failures: AtomicUsize::new(0),
        }
    }

    fn done(&self, record: &RunRecord) {
        let count = self.count.fetch_add(1, Ordering::Relaxed) as u64 + 1;
        let failed = usize::from(!record.ok());
        let failures = self.failures.fetch_add(failed, Ordering::Relaxed) + failed;
        match &self.bar {
            Some(bar) => {
                bar.set_message(failures.to_string());
                bar.inc(1);
            }
            None => {
                let step = (self.total / 20).max(1);
                if !record.ok() {
                    let reason = record.failure.as_deref().unwrap_or("");
                    println!("run {} failed: {reason}", record.index);
                }
                if count.is_multiple_of(step) || count == self.total {
                    println!("{count}/{} runs done, {failures} failed", self.total);
                }
            }
        }
    }

    fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish();
        }
    }
}
