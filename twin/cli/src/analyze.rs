//! `twin analyze <machine>`: analyses of a machine's reduced model (in [`crate::analysis`]),
//! written as CSV files and a 2D `.rrd` plot: the lathe's power loop and its phase plane, and a
//! milling scenario's stability lobes.

use crate::analysis::error::AnalysisError;
use crate::analysis::{lathe, milling};
use crate::flags::SetFlag;
use std::path::{Path, PathBuf};

/// Largest `--grid` (points per axis): 10,000 trajectories.
pub const MAX_GRID: usize = 100;

/// Machines `twin analyze` knows.
pub const ANALYSES: &[&str] = &["lathe", "milling"];

/// `twin analyze` arguments.
#[derive(Debug, Clone, clap::Args)]
#[command(mut_arg("set", |arg| arg.help("milling: set a scenario value (as `twin run --set`)")))]
pub struct AnalyzeArgs {
    /// What to analyse: `lathe` (the parallel lathe's power loop, Table 1 of the paper) or
    /// `milling` (stability lobes of a milling scenario, checked by time-domain runs).
    pub machine: String,
    /// milling: the scenario (built-in name or .toml file) whose tool and cut are analysed.
    #[arg(default_value = "milling-constant-15000")]
    pub scenario: String,
    #[command(flatten)]
    pub values: SetFlag,
    /// milling: the diagram's speed range, rpm.
    #[arg(long, num_args = 2, value_names = ["FROM", "TO"], default_values_t = [10_000.0, 25_000.0])]
    pub rpm: Vec<f64>,
    /// milling: speeds in the diagram.
    #[arg(long, default_value_t = 151)]
    pub speeds: usize,
    /// milling: largest depth searched, m.
    #[arg(long, default_value_t = 3.0e-3)]
    pub max_depth: f64,
    /// milling: time-domain check grid, speeds and depths (0 0: no check).
    #[arg(long, num_args = 2, value_names = ["SPEEDS", "DEPTHS"], default_values_t = [12, 8])]
    pub check: Vec<usize>,
    /// milling: simulated time of each check run, s.
    #[arg(long, default_value_t = 0.6)]
    pub check_duration: f64,
    /// milling: the tool's x frequency response (a `twin frf` frf.csv, m/N): the lobes use the
    /// modes fitted to --frf-x and --frf-y instead of the scenario's, and are compared with its.
    #[arg(long, requires = "frf_y", value_name = "FILE")]
    pub frf_x: Option<PathBuf>,
    /// milling: the tool's y frequency response (see --frf-x).
    #[arg(long, requires = "frf_x", value_name = "FILE")]
    pub frf_y: Option<PathBuf>,
    /// Design time constant m_1 of Sudhakara eq (12), s.
    #[arg(
        long,
        default_value_t = 0.5,
        allow_hyphen_values = true,
        conflicts_with_all = ["h1", "h2"]
    )]
    pub m1: f64,
    /// Design time constant m_2 of Sudhakara eq (12), s.
    #[arg(
        long,
        default_value_t = 0.49,
        allow_hyphen_values = true,
        conflicts_with_all = ["h1", "h2"]
    )]
    pub m2: f64,
    /// Power gain h_1 in m/(rev·W) (the paper's mm/kW times 1e-6); with --h2 it replaces the
    /// design. Write a negative value with `=`: --h1=-1.3052e-8.
    #[arg(long, requires = "h2", allow_hyphen_values = true)]
    pub h1: Option<f64>,
    /// Power gain h_2 in m/(rev·W).
    #[arg(long, requires = "h1", allow_hyphen_values = true)]
    pub h2: Option<f64>,
    /// Initial forces of the portrait grid go up to this for both tools, N.
    #[arg(long, default_value_t = 5000.0, allow_hyphen_values = true)]
    pub max_force: f64,
    /// Grid points per axis of the portrait.
    #[arg(long, default_value_t = 12, allow_hyphen_values = true)]
    pub grid: usize,
    /// Simulated time per trajectory, s.
    #[arg(long, default_value_t = 20.0, allow_hyphen_values = true)]
    pub duration: f64,
    /// Folder for the CSV files and the .rrd plot (default: lathe-phase, milling-lobes).
    #[arg(long)]
    pub out_dir: Option<PathBuf>,
}

/// Runs `twin analyze`: the analysis, its files, and a summary for the terminal.
pub fn run(args: &AnalyzeArgs, registry: &framework::Registry) -> Result<String, AnalysisError> {
    if args.machine == "milling" {
        return run_milling(args, registry);
    }
    if args.machine != "lathe" {
        return Err(AnalysisError::Unknown {
            name: args.machine.clone(),
            known: ANALYSES.join(", "),
        });
    }
    if !(1..=MAX_GRID).contains(&args.grid) {
        return Err(AnalysisError::Argument {
            flag: "--grid",
            reason: format!("must be 1 to {MAX_GRID} points per axis, got {}", args.grid),
        });
    }
    let gains = match (args.h1, args.h2) {
        (Some(h1), Some(h2)) => lathe::Gains::Given([h1, h2]),
        _ => lathe::Gains::Design {
            time_constants: [args.m1, args.m2],
        },
    };
    let plane = lathe::analyze(&lathe::PhasePlaneRequest {
        gains,
        max_forces: [args.max_force; 2],
        points_per_axis: args.grid,
        duration: args.duration,
        ..Default::default()
    })?;
    let files = plane.write(args.out_dir.as_deref().unwrap_or(Path::new("lathe-phase")))?;
    let mut out = plane.summary();
    for file in files {
        out.push_str(&format!("wrote {}\n", file.display()));
    }
    Ok(out)
}

/// `twin analyze milling`: lobes, the time-domain check and their files.
fn run_milling(
    args: &AnalyzeArgs,
    registry: &framework::Registry,
) -> Result<String, AnalysisError> {
    let argument = |flag: &'static str, reason: String| AnalysisError::Argument { flag, reason };
    let rpm = |v: f64| v * std::f64::consts::TAU / 60.0;
    let [from, to] = [args.rpm[0], args.rpm[1]];
    if !(from.is_finite() && to.is_finite() && 0.0 < from && from < to) {
        return Err(argument(
            "--rpm",
            format!("must be FROM TO with 0 < FROM < TO, got {from} {to}"),
        ));
    }
    if !(2..=2000).contains(&args.speeds) {
        return Err(argument(
            "--speeds",
            format!("must be 2 to 2000, got {}", args.speeds),
        ));
    }
    if !(args.max_depth.is_finite() && args.max_depth > 0.0) {
        return Err(argument(
            "--max-depth",
            format!("must be > 0 m, got {}", args.max_depth),
        ));
    }
    if args.check.iter().any(|&n| n > MAX_GRID) {
        return Err(argument(
            "--check",
            format!("at most {MAX_GRID} speeds and depths"),
        ));
    }
    if !(args.check_duration.is_finite() && args.check_duration > 0.0) {
        return Err(argument(
            "--check-duration",
            format!("must be > 0 s, got {}", args.check_duration),
        ));
    }
    let mut scenario =
        twin::Scenario::open(&args.scenario).map_err(|e| argument("scenario", e.to_string()))?;
    for assignment in &args.values.set {
        scenario = scenario
            .assign(assignment)
            .map_err(|e| argument("--set", e.to_string()))?;
    }
    let analysis = milling::analyze(
        &milling::LobeRequest {
            scenario,
            speeds: [rpm(from), rpm(to)],
            speed_count: args.speeds,
            max_depth: args.max_depth,
            check: [args.check[0], args.check[1]],
            check_duration: args.check_duration,
            frf: args
                .frf_x
                .clone()
                .zip(args.frf_y.clone())
                .map(|(x, y)| [x, y]),
        },
        registry,
    )?;
    let files = analysis.write(
        args.out_dir
            .as_deref()
            .unwrap_or(Path::new("milling-lobes")),
    )?;
    let mut out = analysis.summary();
    for file in files {
        out.push_str(&format!("wrote {}\n", file.display()));
    }
    Ok(out)
}
