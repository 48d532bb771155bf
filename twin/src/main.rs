//! The `twin` command line: list, run and benchmark the machines' twins.

use clap::{Parser, Subcommand};
use controllers::Registry;
use std::path::PathBuf;
use std::process::ExitCode;
use twin::recording::LiveViewer;
use twin::scenario::{self, Overrides};
use twin::{reproduce, summary, Twin};

#[derive(Parser)]
#[command(
    name = "twin",
    version,
    about = "Multibody digital twin of machining mechatronics"
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
    Analyze(twin::analysis::AnalyzeArgs),
}

#[derive(clap::Args)]
struct ReproduceArgs {
    /// The paper (see `twin list`).
    paper: String,
    /// Folder for the recordings and report.json.
    #[arg(long, default_value = "reproduce")]
    out_dir: PathBuf,
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
    /// Simulated time, s.
    #[arg(long, allow_negative_numbers = true)]
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
struct BenchArgs {
    /// Built-in scenario names or scenario .toml files; none: every built-in scenario.
    scenarios: Vec<String>,
    /// Simulated time per measurement, s.
    #[arg(long, default_value_t = 10.0)]
    duration: f64,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let registry = Registry::builtin();
    let outcome = match cli.command {
        Command::List => {
            list(&registry);
            Ok(ExitCode::SUCCESS)
        }
        Command::Run(args) => run(args, &registry),
        Command::Bench(args) => bench(args, &registry),
        Command::Reproduce(args) => reproduce(args, &registry),
        Command::Analyze(args) => twin::analysis::run(&args)
            .map(|summary| {
                print!("{summary}");
                ExitCode::SUCCESS
            })
            .map_err(|e| e.to_string()),
    };
    outcome.unwrap_or_else(|message| {
        eprintln!("error: {message}");
        ExitCode::from(1)
    })
}

fn list(registry: &Registry) {
    println!("scenarios:");
    for (name, text) in scenario::BUILTIN {
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

fn run(args: RunArgs, registry: &Registry) -> Result<ExitCode, String> {
    let overrides = Overrides {
        controller: args.controller,
        duration: args.duration,
        set: args.set,
    };
    let loaded = scenario::load(&args.scenario, &overrides).map_err(|e| e.to_string())?;
    let out = args
        .out
        .unwrap_or_else(|| PathBuf::from(format!("{}.rrd", loaded.scenario.name)));
    if let Some(path) = &args.summary {
        check_writable(path)?;
    }
    let mut twin = Twin::new(loaded, registry).map_err(|e| e.to_string())?;
    if let Some(url) = args.connect {
        twin = twin.with_live_viewer(LiveViewer::Connect(url));
    } else if args.spawn {
        twin = twin.with_live_viewer(LiveViewer::Spawn);
    }
    let result = twin.run(Some(&out)).map_err(|e| e.to_string())?;
    print!("{}", summary::to_table(&result));
    println!("recording: {}", out.display());
    if let Some(path) = &args.summary {
        summary::write_json(&result, path)
            .map_err(|e| format!("cannot write summary {}: {e}", path.display()))?;
    }
    Ok(match &result.failure {
        None => ExitCode::SUCCESS,
        Some(failure) => {
            eprintln!("error: {failure}");
            ExitCode::from(2)
        }
    })
}

/// Fails early, before a long run, when the summary's folder cannot take the file.
fn check_writable(path: &std::path::Path) -> Result<(), String> {
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => std::path::Path::new("."),
    };
    if folder.is_dir() {
        Ok(())
    } else {
        Err(format!(
            "cannot write summary {}: folder {} does not exist",
            path.display(),
            folder.display()
        ))
    }
}

fn bench(args: BenchArgs, registry: &Registry) -> Result<ExitCode, String> {
    let overrides = Overrides {
        duration: Some(args.duration),
        ..Default::default()
    };
    let folder = std::env::temp_dir().join(format!("twin-bench-{}", std::process::id()));
    std::fs::create_dir_all(&folder).map_err(|e| e.to_string())?;
    let out = folder.join("bench.rrd");
    let names: Vec<String> = if args.scenarios.is_empty() {
        scenario::BUILTIN
            .iter()
            .map(|(name, _)| name.to_string())
            .collect()
    } else {
        args.scenarios.clone()
    };
    println!(
        "{:<24} {:>9} {:>8} {:>8} {:>14} {:>14}",
        "scenario", "dt (s)", "substeps", "steps", "steps/s bare", "steps/s rec."
    );
    for name in &names {
        let mut rates = [0.0; 2];
        let mut shape = (0.0, 0, 0);
        for (rate, recording) in rates.iter_mut().zip([None, Some(out.as_path())]) {
            let loaded = scenario::load(name, &overrides).map_err(|e| e.to_string())?;
            shape = (loaded.scenario.dt, loaded.scenario.substeps, 0);
            let twin = Twin::new(loaded, registry).map_err(|e| e.to_string())?;
            let result = twin.run(recording).map_err(|e| e.to_string())?;
            shape.2 = result.steps;
            *rate = result.steps_per_s;
        }
        println!(
            "{:<24} {:>9} {:>8} {:>8} {:>14.0} {:>14.0}",
            name, shape.0, shape.1, shape.2, rates[0], rates[1]
        );
    }
    let _ = std::fs::remove_dir_all(&folder);
    if let Some(peak) = peak_memory_mb() {
        println!("peak memory (VmHWM): {peak:.1} MB");
    }
    Ok(ExitCode::SUCCESS)
}

fn reproduce(args: ReproduceArgs, registry: &Registry) -> Result<ExitCode, String> {
    let report =
        reproduce::reproduce(&args.paper, &args.out_dir, registry).map_err(|e| e.to_string())?;
    print!("{}", reproduce::to_table(&report));
    println!("recordings and report.json: {}", args.out_dir.display());
    Ok(ExitCode::SUCCESS)
}

/// Peak resident memory of this process, from /proc (Linux).
fn peak_memory_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}
