//! `twin sweep`: a study run from the command line, and `twin sweep merge` joining its shards.

use crate::failure::Failure;
use crate::flags::{EngineFlag, SetFlag};
use crate::signals::stop_on_signals;
use crate::study::{self, RecordMode, Shard, Spec, Study, StudyOptions};
use framework::Registry;
use std::path::PathBuf;
use std::process::ExitCode;

/// `twin sweep` arguments: a study, or the `merge` subcommand.
#[derive(Debug, Clone, clap::Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
#[command(mut_arg("set", |arg| arg.help("Set a scenario value for every run (as `twin run --set`), before the axes")))]
#[command(mut_arg("engine", |arg| arg.help("The engine of every run (as `twin run --engine`)")))]
pub struct SweepArgs {
    /// `twin sweep merge`, instead of running a study.
    #[command(subcommand)]
    pub merge: Option<SweepCommand>,
    /// A built-in scenario name or a scenario .toml file.
    #[arg(required = true)]
    pub scenario: Option<String>,
    #[command(flatten)]
    pub values: SetFlag,
    #[command(flatten)]
    pub solver: EngineFlag,
    /// A grid axis: KEY=lin(a,b,n) | log(a,b,n) | [v1, v2, …] | v1,v2,… (`controller=osmc,smc2`
    /// switches controllers); grid axes span a Cartesian product, the last varying fastest.
    #[arg(long = "grid", value_name = "KEY=VALUES")]
    pub grid: Vec<String>,
    /// A random axis: `KEY=normal(m,sd[,lo,hi])` | `uniform(a,b)` | `lognormal(mu,sigma[,lo,hi])`;
    /// URDF values too (`urdf.link.<link>.mass`, `urdf.joint.<joint>.damping`, …).
    #[arg(long = "random", value_name = "KEY=DISTRIBUTION")]
    pub random: Vec<String>,
    /// Runs per grid point (random draws per point).
    #[arg(long, default_value_t = 1)]
    pub samples: usize,
    /// The study's seed: run i's sensor noise and draws come from (seed, i).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// A spec each run meets or not: METRIC<VALUE (or <=, >, >=); the report gives the share.
    #[arg(long = "spec", value_name = "SPEC")]
    pub spec: Vec<String>,
    /// Runs at once (threads); default: every core.
    #[arg(long)]
    pub jobs: Option<usize>,
    /// The study's folder.
    #[arg(long, default_value = "study")]
    pub out: PathBuf,
    /// Which runs keep their recording (`OUT/recordings/<index>.rrd`).
    #[arg(long, value_enum, default_value = "none")]
    pub record: RecordMode,
    /// Skip the runs whose result OUT already holds (a killed study goes on where it stopped).
    #[arg(long)]
    pub resume: bool,
    /// Run only run INDEX of the study (bit-identical to the same run inside the study).
    #[arg(long, value_name = "INDEX")]
    pub only: Option<usize>,
    /// Run only shard i of n (runs with index ≡ i mod n); `auto` reads SLURM_ARRAY_TASK_ID and
    /// SLURM_ARRAY_TASK_COUNT, or JOB_COMPLETION_INDEX (Kubernetes) with --shard-count.
    #[arg(long, value_name = "i/n|auto")]
    pub shard: Option<String>,
    /// The shard count for `--shard auto` when the scheduler does not give it.
    #[arg(long, value_name = "N")]
    pub shard_count: Option<usize>,
}

/// The subcommands of `twin sweep`.
#[derive(Debug, Clone, clap::Subcommand)]
pub enum SweepCommand {
    /// Join shard folders into one study folder (results.csv and report.json byte-identical to
    /// a single machine's run of the study).
    Merge {
        /// The shard folders.
        #[arg(required = true)]
        folders: Vec<PathBuf>,
        /// The merged study's folder.
        #[arg(long)]
        out: PathBuf,
    },
}

/// Runs `twin sweep`: the merge when asked, else the study, its report table and a line of
/// throughput; an interrupted study exits 128 + the signal and says how to resume it.
pub fn run(args: &SweepArgs, registry: &Registry) -> Result<ExitCode, Failure> {
    if let Some(SweepCommand::Merge { folders, out }) = &args.merge {
        return merge(folders, out);
    }
    let scenario = args.scenario.clone().unwrap_or_default();
    let specs = args
        .spec
        .iter()
        .map(|s| Spec::parse(s))
        .collect::<Result<Vec<_>, _>>()
        .map_err(Failure::usage)?;
    let shard = args
        .shard
        .as_deref()
        .map(|s| Shard::parse(s, args.shard_count))
        .transpose()
        .map_err(Failure::usage)?;
    let set = args.solver.before(&args.values);
    let study = Study::new(
        &scenario,
        &set,
        &args.grid,
        &args.random,
        args.samples,
        args.seed,
        registry,
    )?;
    let jobs = args.jobs.unwrap_or_else(|| {
        std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
    });
    let options = StudyOptions {
        out: args.out.clone(),
        jobs,
        record: args.record,
        resume: args.resume,
        only: args.only,
        shard,
        specs,
    };
    let stop = stop_on_signals()?;
    let outcome = study::run_study(&study, &options, registry, &stop)?;
    print!("{}", study::report_table(&outcome.report));
    println!(
        "{} runs now, {} from before, {:.1} s ({:.2} runs/s on {jobs} jobs); results in {}",
        outcome.ran,
        outcome.skipped,
        outcome.wall_s,
        outcome.ran as f64 / outcome.wall_s.max(1e-9),
        args.out.display()
    );
    if let Some(signal) = outcome.interrupted {
        eprintln!("interrupted: finish the study with the same command and --resume");
        return Ok(ExitCode::from(128 + signal.min(127) as u8));
    }
    Ok(ExitCode::SUCCESS)
}

/// `twin sweep merge`: the shard folders joined into `out`, and the merged report.
fn merge(folders: &[PathBuf], out: &std::path::Path) -> Result<ExitCode, Failure> {
    let merged = study::merge(folders, out)?;
    print!("{}", study::report_table(&merged.report));
    println!("merged {} runs into {}", merged.runs, out.display());
    Ok(ExitCode::SUCCESS)
}
