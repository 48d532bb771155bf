//! The `twin` command line: list, run and benchmark the machines' twins.

use clap::{Parser, Subcommand};
use controllers::Registry;
use std::path::PathBuf;
use std::process::ExitCode;
use twin::{
    same_file, summary, Engine, LiveViewer, OutputFile, Overrides, Scenario, StopFlag, Twin,
    BUILTIN_SCENARIOS,
};
use twin_cli::{analysis, frf, reproduce, study};

/// Exit codes, as documented in `--help` and the README.
const EXIT_ERROR: u8 = 1;
const EXIT_USAGE: u8 = 2;
const EXIT_DIVERGED: u8 = 3;

#[derive(Parser)]
#[command(
    name = "twin",
    version,
    arg_required_else_help = true,
    about = "Multibody digital twin of machining mechatronics",
    after_help = "Exit codes: 0 ok, 1 error, 2 usage error, 3 the run diverged, \
                  130/143 interrupted by SIGINT/SIGTERM (recording and summary finished)."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// List the built-in scenarios and the registered controllers.
    List,
    /// Run a scenario headless and record it to an .rrd file.
    Run(RunArgs),
    /// Measure steps/s of scenarios (every built-in one by default) with and without recording.
    Bench(BenchArgs),
    /// Run a seed paper's scenarios and put its claims next to the twin's figures.
    Reproduce(ReproduceArgs),
    /// Analyse a machine's reduced model (the lathe's phase plane): CSV files and a 2D .rrd.
    Analyze(analysis::AnalyzeArgs),
    /// Measure a frequency response (a tap test or shaker test on the twin): frf.csv and frf.rrd.
    Frf(frf::FrfArgs),
    /// Turn what a killed run left (X.rrd.<random>.part) into a complete recording.
    Salvage(SalvageArgs),
    /// Linearise a scenario's plant at an operating point: A, B, C, D, their zero-order hold at
    /// the control period and the poles, into OUT_DIR/linear.json.
    Linearize(LinearizeArgs),
    /// Run a study: a scenario over grid and random axes, in parallel, scored against specs
    /// (`twin sweep merge` joins shard folders).
    Sweep(SweepArgs),
    /// Package a scenario as an FMI 2.0 co-simulation FMU: its closed loop with the controller
    /// (inputs a setpoint on the reference and disturbances on the joints), or with
    /// --no-controller the plant alone (inputs the actuators' efforts); outputs the measured and
    /// true signals, parameters the scenario's numbers.
    Fmu(FmuArgs),
}

#[derive(clap::Args)]
struct FmuArgs {
    /// A built-in scenario name or a scenario .toml file.
    scenario: String,
    /// Override a scenario value (as `twin run --set`); the FMU carries the scenario as set.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Embed this controller instead of the scenario's (its parameters start from defaults).
    #[arg(long, value_name = "NAME", conflicts_with = "no_controller")]
    controller: Option<String>,
    /// The plant alone: the host is the controller (inputs the actuators' efforts).
    #[arg(long)]
    no_controller: bool,
    /// The .fmu file to write.
    #[arg(long, required = true)]
    out: PathBuf,
    /// The built twin-fmu shared library; default: libtwin_fmu.so next to this executable
    /// (`cargo build --release -p twin-cli -p twin-fmu` puts both in target/release).
    #[arg(long)]
    library: Option<PathBuf>,
}

#[derive(clap::Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
struct SweepArgs {
    #[command(subcommand)]
    merge: Option<SweepCommand>,
    /// A built-in scenario name or a scenario .toml file.
    #[arg(required = true)]
    scenario: Option<String>,
    /// Set a scenario value for every run (as `twin run --set`), before the axes.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// The engine of every run (as `twin run --engine`).
    #[arg(long, value_name = "exact|rapier", value_parser = parse_engine)]
    engine: Option<Engine>,
    /// A grid axis: KEY=lin(a,b,n) | log(a,b,n) | [v1, v2, …] | v1,v2,… (`controller=osmc,smc2`
    /// switches controllers); grid axes span a Cartesian product, the last varying fastest.
    #[arg(long = "grid", value_name = "KEY=VALUES")]
    grid: Vec<String>,
    /// A random axis: KEY=normal(m,sd[,lo,hi]) | uniform(a,b) | lognormal(mu,sigma[,lo,hi]);
    /// URDF values too (urdf.link.<link>.mass, urdf.joint.<joint>.damping, …).
    #[arg(long = "random", value_name = "KEY=DISTRIBUTION")]
    random: Vec<String>,
    /// Runs per grid point (random draws per point).
    #[arg(long, default_value_t = 1)]
    samples: usize,
    /// The study's seed: run i's sensor noise and draws come from (seed, i).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// A spec each run meets or not: METRIC<VALUE (or <=, >, >=); the report gives the share.
    #[arg(long = "spec", value_name = "SPEC")]
    spec: Vec<String>,
    /// Runs at once (threads); default: every core.
    #[arg(long)]
    jobs: Option<usize>,
    /// The study's folder.
    #[arg(long, default_value = "study")]
    out: PathBuf,
    /// Which runs keep their recording (OUT/recordings/<index>.rrd).
    #[arg(long, value_enum, default_value = "none")]
    record: study::RecordMode,
    /// Skip the runs whose result OUT already holds (a killed study goes on where it stopped).
    #[arg(long)]
    resume: bool,
    /// Run only run INDEX of the study (bit-identical to the same run inside the study).
    #[arg(long, value_name = "INDEX")]
    only: Option<usize>,
    /// Run only shard i of n (runs with index ≡ i mod n); `auto` reads SLURM_ARRAY_TASK_ID and
    /// SLURM_ARRAY_TASK_COUNT, or JOB_COMPLETION_INDEX (Kubernetes) with --shard-count.
    #[arg(long, value_name = "i/n|auto")]
    shard: Option<String>,
    /// The shard count for `--shard auto` when the scheduler does not give it.
    #[arg(long, value_name = "N")]
    shard_count: Option<usize>,
}

#[derive(Subcommand)]
enum SweepCommand {
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

#[derive(clap::Args)]
struct SalvageArgs {
    /// The temporary recording a killed run left behind.
    part: PathBuf,
    /// The recording to write (default: the part's name up to `.rrd`; never an existing file).
    #[arg(long)]
    out: Option<PathBuf>,
}

#[derive(clap::Args)]
struct ReproduceArgs {
    /// The paper (see `twin list`).
    paper: String,
    /// Folder for the recordings and report.json.
    #[arg(long, default_value = "reproduce")]
    out_dir: PathBuf,
    /// The engine of every run (as `twin run --engine`); default: each scenario's own.
    #[arg(long, value_name = "exact|rapier", value_parser = parse_engine)]
    engine: Option<Engine>,
}

#[derive(clap::Args)]
struct RunArgs {
    /// A built-in scenario name or a scenario .toml file.
    scenario: String,
    /// Use this controller instead of the scenario's (its parameters start from defaults).
    #[arg(long)]
    controller: Option<String>,
    /// Override a scenario value: a dotted key into the TOML, e.g. controller.params.crank_speed=-3.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// The engine that steps the mechanism: exact (RK4, loops closed to 1e-12 m) or rapier
    /// (Rapier's pipeline, with contacts); the same as --set solver.engine=…, given before the
    /// --set values.
    #[arg(long, value_name = "exact|rapier", value_parser = parse_engine)]
    engine: Option<Engine>,
    /// Simulated time, s.
    #[arg(long, allow_hyphen_values = true)]
    duration: Option<f64>,
    /// Recording to write (default: <scenario>.rrd in the current folder).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Also write the summary as JSON to this file.
    #[arg(long)]
    summary: Option<PathBuf>,
    /// Also stream the run to a Rerun viewer listening at this URL
    /// (e.g. rerun+http://127.0.0.1:9876/proxy).
    #[arg(long, conflicts_with = "spawn")]
    connect: Option<String>,
    /// Also stream the run to a Rerun viewer started from the `rerun` executable on PATH.
    #[arg(long)]
    spawn: bool,
}

#[derive(clap::Args)]
struct LinearizeArgs {
    /// A built-in scenario name or a scenario .toml file.
    scenario: String,
    /// The operating time, s: the scenario runs with its controller to it, then the efforts are
    /// held there (0: the initial state).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    at: f64,
    /// Override a scenario value (as `twin run --set`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// The engine that runs to the operating time (as `twin run --engine`); the linear model is
    /// always the exact engine's equations of motion.
    #[arg(long, value_name = "exact|rapier", value_parser = parse_engine)]
    engine: Option<Engine>,
    /// Folder for linear.json (created if missing).
    #[arg(long, required = true)]
    out_dir: PathBuf,
}

#[derive(clap::Args)]
struct BenchArgs {
    /// Built-in scenario names or scenario .toml files; none: every built-in scenario.
    scenarios: Vec<String>,
    /// Simulated time per measurement, s.
    #[arg(long, default_value_t = 10.0, allow_hyphen_values = true)]
    duration: f64,
    /// The engine of every measurement (as `twin run --engine`); default: each scenario's own.
    #[arg(long, value_name = "exact|rapier", value_parser = parse_engine)]
    engine: Option<Engine>,
}

/// `--engine`: a name a scenario's `solver.engine` takes.
fn parse_engine(name: &str) -> Result<Engine, String> {
    [Engine::Exact, Engine::Rapier]
        .into_iter()
        .find(|engine| engine.name() == name)
        .ok_or_else(|| format!("unknown engine `{name}`; choose exact or rapier"))
}

/// Why the command failed: the exit code and a one-line message.
struct Failure {
    code: u8,
    message: String,
}

impl Failure {
    fn usage(message: impl Into<String>) -> Self {
        Self {
            code: EXIT_USAGE,
            message: message.into(),
        }
    }
}

impl<E: std::fmt::Display> From<E> for Failure {
    fn from(error: E) -> Self {
        Self {
            code: EXIT_ERROR,
            message: error.to_string(),
        }
    }
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(error) => return usage_error(&error),
    };
    let registry = Registry::builtin();
    let outcome = match cli.command {
        Command::List => {
            list(&registry);
            Ok(ExitCode::SUCCESS)
        }
        Command::Run(args) => run(args, &registry),
        Command::Bench(args) => bench(args, &registry),
        Command::Reproduce(args) => reproduce(args, &registry),
        Command::Salvage(args) => salvage(args),
        Command::Sweep(args) => sweep(args, &registry),
        Command::Linearize(args) => linearize(args, &registry),
        Command::Fmu(args) => fmu(args, &registry),
        Command::Analyze(args) => analysis::run(&args, &registry)
            .map(|summary| {
                print!("{summary}");
                ExitCode::SUCCESS
            })
            .map_err(Failure::from),
        Command::Frf(args) => frf::run(&args, &registry)
            .map(|summary| {
                print!("{summary}");
                ExitCode::SUCCESS
            })
            .map_err(|error| Failure {
                code: match error {
                    frf::FrfError::Diverged(_) => EXIT_DIVERGED,
                    _ => EXIT_ERROR,
                },
                message: error.to_string(),
            }),
    };
    outcome.unwrap_or_else(|failure| {
        eprintln!("error: {}", failure.message);
        ExitCode::from(failure.code)
    })
}

/// Help and version go to stdout (exit 0); `twin` alone lists the commands (exit 2); a usage
/// error is one line naming what is wrong (the missing `<SCENARIO>`, the `--h2` that `--h1`
/// needs, the argument that is not UTF-8) and a hint (exit 2).
fn usage_error(error: &clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    match error.kind() {
        ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
            print!("{error}");
            return ExitCode::SUCCESS;
        }
        ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            eprint!("{error}");
            return ExitCode::from(EXIT_USAGE);
        }
        _ => {}
    }
    let message = match (error.kind(), non_utf8_argument()) {
        (ErrorKind::InvalidUtf8, Some(argument)) => {
            format!("error: {argument} is not UTF-8 text; give it in UTF-8")
        }
        _ => first_paragraph(&error.render().to_string()),
    };
    eprintln!("{message}");
    eprintln!("hint: twin --help, or twin <command> --help");
    ExitCode::from(EXIT_USAGE)
}

/// Clap's message up to its usage line, on one line: "the following required arguments were not
/// provided:" keeps the arguments clap lists below it.
fn first_paragraph(rendered: &str) -> String {
    let lines: Vec<&str> = rendered
        .lines()
        .take_while(|line| !line.trim().is_empty() && !line.starts_with("Usage:"))
        .map(str::trim)
        .collect();
    match lines.join(" ").trim() {
        "" => "error: usage error".to_string(),
        line => line.to_string(),
    }
}

/// The first command-line argument that is not UTF-8, by position (and the option it follows),
/// shown with its bad bytes replaced.
fn non_utf8_argument() -> Option<String> {
    let arguments: Vec<std::ffi::OsString> = std::env::args_os().collect();
    let index = arguments.iter().position(|a| a.to_str().is_none())?;
    let shown = arguments[index].to_string_lossy().into_owned();
    let after = arguments[..index]
        .last()
        .and_then(|a| a.to_str())
        .filter(|a| a.starts_with('-'))
        .map(|option| format!(" (the value of {option})"))
        .unwrap_or_default();
    Some(format!("argument {index} `{shown}`{after}"))
}

fn list(registry: &Registry) {
    println!("scenarios:");
    for (name, text) in BUILTIN_SCENARIOS {
        let description = text
            .parse::<toml::Table>()
            .ok()
            .and_then(|t| {
                t.get("description")
                    .and_then(|d| d.as_str())
                    .map(String::from)
            })
            .unwrap_or_default();
        println!("  {name:<28} {description}");
    }
    println!("papers (twin reproduce):");
    for paper in reproduce::PAPERS {
        println!("  {:<28} {}", paper.name, paper.summary);
    }
    println!("controllers:");
    for entry in registry.entries() {
        println!("  {:<28} [{}] {}", entry.name, entry.machine, entry.summary);
    }
}

fn run(args: RunArgs, registry: &Registry) -> Result<ExitCode, Failure> {
    let overrides = Overrides {
        controller: args.controller,
        duration: args.duration,
        set: [reproduce::engine_override(args.engine), args.set].concat(),
    };
    let loaded = Scenario::open(&args.scenario)?
        .overrides(&overrides)?
        .build(registry)?;
    let out = args
        .out
        .unwrap_or_else(|| PathBuf::from(format!("{}.rrd", loaded.scenario.name)));
    if args.summary.as_deref().is_some_and(|s| same_file(s, &out)) {
        return Err(Failure::usage(format!(
            "--summary {} is the recording's path too; give them different files",
            out.display()
        )));
    }
    // Created now, so that an unwritable summary path fails before the run, not after it.
    let summary_file = args
        .summary
        .as_deref()
        .map(OutputFile::create)
        .transpose()?;
    let mut twin = Twin::new(loaded)?.with_stop_flag(stop_on_signals()?);
    if let Some(url) = args.connect {
        twin = twin.with_live_viewer(LiveViewer::Connect(url));
    } else if args.spawn {
        twin = twin.with_live_viewer(LiveViewer::Spawn);
    }
    let result = twin.run(Some(&out))?;
    print!("{}", summary::to_table(&result));
    println!("recording: {}", out.display());
    for warning in &result.warnings {
        eprintln!("warning: {warning}");
    }
    if let Some(file) = summary_file {
        summary::write_json(&result, file)?;
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

/// `twin fmu`: the scenario's closed loop (or with --no-controller its plant) packed as an .fmu
/// beside the built shared library.
fn fmu(args: FmuArgs, registry: &Registry) -> Result<ExitCode, Failure> {
    let overrides = Overrides {
        controller: args.controller,
        set: args.set,
        ..Overrides::default()
    };
    let loaded = Scenario::open(&args.scenario)?
        .overrides(&overrides)?
        .build(registry)?;
    let library = match args.library {
        Some(path) => path,
        None => std::env::current_exe()
            .map_err(|e| format!("the twin executable's folder: {e}; give --library"))?
            .with_file_name("libtwin_fmu.so"),
    };
    let file = OutputFile::create(&args.out).map_err(|e| format!("--out: {e}"))?;
    let controlled = !args.no_controller;
    let (bytes, packed) = twin_fmu::package(loaded, controlled, registry, &library)?;
    file.commit(&bytes).map_err(|e| format!("--out: {e}"))?;
    println!(
        "{}: FMI 2.0 co-simulation of the {}, model identifier {}, GUID {}, {:.1} MB",
        args.out.display(),
        packed.controller.map_or("plant alone".into(), |c| format!(
            "closed loop with controller {c}"
        )),
        packed.model_identifier,
        packed.guid,
        packed.bytes as f64 / 1e6
    );
    Ok(ExitCode::SUCCESS)
}

/// `twin linearize`: the linear model into OUT_DIR/linear.json and its table on stdout. The
/// folder is made and its file opened before the run, so an unwritable one fails first.
fn linearize(args: LinearizeArgs, registry: &Registry) -> Result<ExitCode, Failure> {
    let overrides = Overrides {
        set: [reproduce::engine_override(args.engine), args.set].concat(),
        ..Overrides::default()
    };
    let loaded = Scenario::open(&args.scenario)?
        .overrides(&overrides)?
        .build(registry)?;
    let path = args.out_dir.join("linear.json");
    let created = !args.out_dir.exists();
    std::fs::create_dir_all(&args.out_dir)
        .map_err(|e| format!("--out-dir {}: {e}", args.out_dir.display()))?;
    let written = OutputFile::create(&path)
        .map_err(|e| Failure::from(format!("--out-dir: {e}")))
        .and_then(|file| {
            let model = Twin::new(loaded)?
                .linearize(args.at)
                .map_err(|error| match error {
                    twin::LinearizeError::At { .. } => format!("--at {error}"),
                    other => other.to_string(),
                })?;
            let text = serde_json::to_string_pretty(&model.to_json()).map_err(|e| e.to_string())?;
            file.commit(text.as_bytes())?;
            Ok(model)
        });
    let model = written.inspect_err(|_| {
        if created {
            // Only the folder this command made, and only while empty.
            let _ = std::fs::remove_dir(&args.out_dir);
        }
    })?;
    print!("{}", model.to_table());
    println!("linear model: {}", path.display());
    Ok(ExitCode::SUCCESS)
}

/// SIGINT and SIGTERM ask the run to stop (it finishes its files); a second one ends the
/// process at once. SIGXFSZ is caught too, so that a file-size limit fails a write with its
/// error instead of killing the process.
fn stop_on_signals() -> Result<StopFlag, Failure> {
    use signal_hook::consts::{SIGINT, SIGTERM, SIGXFSZ};
    use signal_hook::flag;
    let stop = StopFlag::default();
    let requested = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let install = || -> std::io::Result<()> {
        for signal in [SIGINT, SIGTERM] {
            flag::register_conditional_shutdown(signal, 128 + signal, requested.clone())?;
            flag::register(signal, requested.clone())?;
            flag::register_usize(signal, stop.clone(), signal as usize)?;
        }
        flag::register(SIGXFSZ, std::sync::Arc::new(Default::default()))?;
        Ok(())
    };
    install().map_err(|e| format!("cannot install the signal handlers: {e}"))?;
    Ok(stop)
}

fn bench(args: BenchArgs, registry: &Registry) -> Result<ExitCode, Failure> {
    let folder = std::env::temp_dir().join(format!("twin-bench-{}", std::process::id()));
    std::fs::create_dir_all(&folder).map_err(|e| e.to_string())?;
    let out = folder.join("bench.rrd");
    let names: Vec<String> = if args.scenarios.is_empty() {
        BUILTIN_SCENARIOS
            .iter()
            .map(|(name, _)| name.to_string())
            .collect()
    } else {
        args.scenarios.clone()
    };
    println!(
        "{:<24} {:>6} {:>9} {:>8} {:>8} {:>14} {:>14}",
        "scenario", "engine", "dt (s)", "substeps", "steps", "steps/s bare", "steps/s rec."
    );
    for name in &names {
        let mut rates = [0.0; 2];
        let mut shape = (Engine::Exact, 0.0, 0, 0);
        for (rate, recording) in rates.iter_mut().zip([None, Some(out.as_path())]) {
            let loaded = Scenario::open(name)
                .and_then(|builder| match args.engine {
                    Some(engine) => builder.set("solver.engine", engine.name()),
                    None => Ok(builder),
                })
                .and_then(|builder| builder.duration(args.duration).build(registry))
                .map_err(|e| e.to_string())?;
            let solver = &loaded.scenario.solver;
            let substeps = match solver.engine {
                Engine::Exact => loaded.scenario.substeps,
                Engine::Rapier => solver.rapier_substeps,
            };
            shape = (solver.engine, loaded.scenario.dt, substeps, 0);
            let twin = Twin::new(loaded).map_err(|e| e.to_string())?;
            let result = twin.run(recording).map_err(|e| e.to_string())?;
            shape.3 = result.steps;
            *rate = result.steps_per_s;
        }
        println!(
            "{:<24} {:>6} {:>9} {:>8} {:>8} {:>14.0} {:>14.0}",
            name,
            shape.0.name(),
            shape.1,
            shape.2,
            shape.3,
            rates[0],
            rates[1]
        );
    }
    let _ = std::fs::remove_dir_all(&folder);
    if let Some(peak) = peak_memory_mb() {
        println!("peak memory (VmHWM): {peak:.1} MB");
    }
    Ok(ExitCode::SUCCESS)
}

fn reproduce(args: ReproduceArgs, registry: &Registry) -> Result<ExitCode, Failure> {
    let report = reproduce::reproduce(&args.paper, &args.out_dir, registry, args.engine)?;
    print!("{}", reproduce::to_table(&report));
    println!("recordings and report.json: {}", args.out_dir.display());
    Ok(ExitCode::SUCCESS)
}

fn sweep(args: SweepArgs, registry: &Registry) -> Result<ExitCode, Failure> {
    use study::{Shard, Study, StudyOptions};
    if let Some(SweepCommand::Merge { folders, out }) = args.merge {
        let merged = study::merge(&folders, &out)?;
        print!("{}", study::report_table(&merged.report));
        println!("merged {} runs into {}", merged.runs, out.display());
        return Ok(ExitCode::SUCCESS);
    }
    let scenario = args.scenario.unwrap_or_default();
    let specs = args
        .spec
        .iter()
        .map(|s| study::Spec::parse(s))
        .collect::<Result<Vec<_>, _>>()
        .map_err(Failure::usage)?;
    let shard = args
        .shard
        .as_deref()
        .map(|s| Shard::parse(s, args.shard_count))
        .transpose()
        .map_err(Failure::usage)?;
    let set = [reproduce::engine_override(args.engine), args.set].concat();
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

fn salvage(args: SalvageArgs) -> Result<ExitCode, Failure> {
    let out = match args.out {
        Some(out) => out,
        None => {
            let out = salvaged_name(&args.part).ok_or_else(|| {
                Failure::usage(format!(
                    "{}: not a recording's temporary file (X.rrd.<random>.part); give --out",
                    args.part.display()
                ))
            })?;
            if out.exists() {
                return Err(Failure::usage(format!(
                    "{} exists; name another file with --out",
                    out.display()
                )));
            }
            out
        }
    };
    let report = twin::recordings::salvage(&args.part, &out)?;
    let time = report.last_sim_time.map_or("no samples".to_string(), |t| {
        format!("{t:.6} s of simulated time")
    });
    println!(
        "salvaged {time} (last step {}) in {} messages into {}; {} trailing bytes dropped",
        report.last_step.map_or("none".into(), |s| s.to_string()),
        report.messages,
        out.display(),
        report.dropped_bytes
    );
    Ok(ExitCode::SUCCESS)
}

/// `dir/X.rrd.ab12cd.part` → `dir/X.rrd`.
fn salvaged_name(part: &std::path::Path) -> Option<PathBuf> {
    let name = part.file_name()?.to_str()?.strip_suffix(".part")?;
    let (stem, _random) = name.rsplit_once('.')?;
    stem.ends_with(".rrd").then(|| part.with_file_name(stem))
}

/// Peak resident memory of this process, from /proc (Linux).
fn peak_memory_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}
