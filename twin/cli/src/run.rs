//! `twin run`: one scenario run headless into an .rrd recording, with its summary and, when
//! asked, its commands and signals as a CSV or Parquet data file.

use crate::failure::Failure;
use crate::flags::{DurationFlag, EngineFlag, OutputFlags, SetFlag};
use crate::run_report::finish;
use crate::signals::stop_on_signals;
use framework::Registry;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use twin::RunTable;
use twin::{same_file, summary, LiveViewer, OutputFile, Overrides, Scenario, Twin};

/// `twin run` arguments.
#[derive(Debug, Clone, clap::Args)]
#[command(mut_arg("set", |arg| arg.help("Override a scenario value: a dotted key into the TOML, e.g. controller.params.crank_speed=-3")))]
#[command(mut_arg("connect", |arg| arg.conflicts_with("spawn")))]
pub struct RunArgs {
    /// A built-in scenario name or a scenario .toml file.
    pub scenario: String,
    /// Use this controller instead of the scenario's (its parameters start from defaults).
    #[arg(long)]
    pub controller: Option<String>,
    #[command(flatten)]
    pub values: SetFlag,
    #[command(flatten)]
    pub solver: EngineFlag,
    #[command(flatten)]
    pub length: DurationFlag,
    #[command(flatten)]
    pub outputs: OutputFlags,
    /// Also write the run as a CSV data file: `time [s]`, each actuator's `effort.<actuator>`,
    /// each plant signal as measured (`<signal>`) and true (`true.<signal>`), SI, one row per
    /// control update (written on a divergence or an interruption too).
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Also write the run as a Parquet data file: the CSV's columns, as Float64.
    #[arg(long, value_name = "FILE")]
    pub parquet: Option<PathBuf>,
    /// Also stream the run to a Rerun viewer started from the `rerun` executable on PATH.
    #[arg(long)]
    pub spawn: bool,
}

/// Runs `twin run`: the recording, the summary table on stdout (and as JSON when asked), and
/// the exit code of a diverged or interrupted run.
pub fn run(args: &RunArgs, registry: &Registry) -> Result<ExitCode, Failure> {
    let overrides = Overrides {
        controller: args.controller.clone(),
        duration: args.length.duration,
        set: args.solver.before(&args.values),
    };
    let loaded = Scenario::open(&args.scenario)?
        .overrides(&overrides)?
        .build(registry)?;
    let out = args
        .outputs
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("{}.rrd", loaded.scenario.name)));
    check_outputs(args, &out)?;
    // Created now, so that an unwritable summary path fails before the run, not after it.
    let summary_file = args
        .outputs
        .summary
        .as_deref()
        .map(OutputFile::create)
        .transpose()?;
    let urdf = loaded.urdf_source.clone();
    let mut twin = Twin::new(loaded)?.with_stop_flag(stop_on_signals()?);
    for note in twin.urdf_notes() {
        eprintln!("note: {urdf}: {note}");
    }
    if let Some(url) = &args.outputs.connect {
        twin = twin.with_live_viewer(LiveViewer::Connect(url.clone()));
    } else if args.spawn {
        twin = twin.with_live_viewer(LiveViewer::Spawn);
    }
    let result = if args.csv.is_some() || args.parquet.is_some() {
        let mut table = RunTable::new(args.csv.clone(), args.parquet.clone());
        twin.run_with(Some(&out), &mut [&mut table])?
    } else {
        twin.run(Some(&out))?
    };
    print!("{}", summary::to_table(&result));
    println!("recording: {}", out.display());
    for data in [&args.csv, &args.parquet].into_iter().flatten() {
        println!("data: {}", data.display());
    }
    finish(&result, summary_file)
}

/// Refuses two outputs at one path, and an unwritable data file before the run.
fn check_outputs(args: &RunArgs, out: &Path) -> Result<(), Failure> {
    let outputs = [
        ("--out", Some(out)),
        ("--summary", args.outputs.summary.as_deref()),
        ("--csv", args.csv.as_deref()),
        ("--parquet", args.parquet.as_deref()),
    ];
    for (i, (flag, path)) in outputs.iter().enumerate() {
        let Some(path) = path else { continue };
        let earlier = outputs[..i]
            .iter()
            .find(|(_, p)| p.is_some_and(|p| same_file(p, path)));
        if let Some((other, _)) = earlier {
            let what = if *other == "--out" {
                "the recording's path".to_owned()
            } else {
                format!("{other}'s path")
            };
            return Err(Failure::usage(format!(
                "{flag} {} is {what} too; give them different files",
                path.display()
            )));
        }
    }
    for path in [&args.csv, &args.parquet].into_iter().flatten() {
        // Created and dropped: the folder is checked now, not after the run.
        drop(OutputFile::create(path)?);
    }
    Ok(())
}
