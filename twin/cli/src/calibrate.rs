//! `twin calibrate`: scenario parameters fitted to measured runs (the command line's options on
//! top of the scenario's `[calibration]` table), checked before the solve; into OUT_DIR the
//! report (calibration.json), the calibrated scenario (calibrated.toml) and a recording of the
//! fits before and after, the cost per iteration and the intervals (calibration.rrd).

use crate::data_flags::{plant_columns, read_run, DataFlags};
use crate::failure::Failure;
use crate::fit_figures::{cost_plot, interval_plot, time_plot, AFTER, BEFORE, MEASURED};
use crate::fit_options::{noise_levels, number};
use crate::fit_tables::{rate_line, table_judged};
use crate::flags::SetFlag;
use framework::Registry;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use twin::calibration::{calibrate, Calibration, CalibrationOptions, FitParameter, StartStates};
use twin::data::{ReadOptions, RunData};
use twin::recordings::write_figures;
use twin::{CalibrationSpec, OutputFile, Overrides, Scenario};

/// `twin calibrate` arguments.
#[derive(Debug, Clone, clap::Args)]
#[command(mut_arg("set", |arg| arg.help("Override a scenario value (as `twin run --set`) before the fit")))]
pub struct CalibrateArgs {
    /// A built-in scenario name or a scenario .toml file (its `[calibration]` table, if any,
    /// gives defaults for everything below).
    pub scenario: String,
    /// A measured run to fit (.csv, .parquet or twin .rrd); repeat for several runs sharing the
    /// parameters.
    #[arg(long = "data", value_name = "RUN")]
    pub data: Vec<PathBuf>,
    /// A scenario key to fit, with its start (`KEY` or `KEY=START`), e.g.
    /// `urdf.link.ram.mass=5`; repeat for each parameter.
    #[arg(long = "fit", value_name = "KEY[=START]")]
    pub fit: Vec<String>,
    /// Bounds of a fitted key (`KEY=LO,HI`); default ≥ 0 for a damping, friction, stiffness or
    /// delay and > 0 for a mass or an inertia.
    #[arg(long = "bounds", value_name = "KEY=LO,HI", allow_hyphen_values = true)]
    pub bounds: Vec<String>,
    /// Fit this key once per run instead of once for all (a workpiece mass changing between
    /// runs).
    #[arg(long = "per-run", value_name = "KEY")]
    pub per_run: Vec<String>,
    /// A run replayed with the fitted values and never fitted: its fit % says how well the
    /// calibration predicts.
    #[arg(long = "validate", value_name = "RUN")]
    pub validate: Vec<PathBuf>,
    /// A measured signal to fit (default: every signal the runs log, but the reference).
    #[arg(long = "signal", value_name = "NAME")]
    pub signals: Vec<String>,
    /// A signal's noise σ in SI (`NAME=SIGMA`), instead of the estimate from its data.
    #[arg(long = "noise", value_name = "NAME=SIGMA")]
    pub noise: Vec<String>,
    /// Split the runs into segments of this many seconds, each simulated from its own fitted
    /// start state (multiple shooting), so that a replay never drifts far from its run; 0:
    /// whole runs [default: the scenario's `[calibration]` segment, else 1 s (shorter where the
    /// model drifts faster) where the logged positions place the mechanism, else whole runs].
    #[arg(long, value_name = "SECONDS")]
    pub segment: Option<f64>,
    /// Start states fitted per segment, in the mechanism's independent coordinates: `auto`
    /// (those the logged positions place), `none` (as the data place them), or joints
    /// separated by commas.
    #[arg(long, value_name = "auto|none|JOINTS")]
    pub states: Option<String>,
    /// Replay the runs with the scenario's controller on the logged reference (to fit a
    /// controller's gains) instead of with the logged commands.
    #[arg(long)]
    pub closed_loop: bool,
    /// Solve from this many starts: the given one, then seeded draws within the bounds.
    #[arg(long, value_name = "N")]
    pub starts: Option<usize>,
    /// Most Levenberg–Marquardt iterations per start.
    #[arg(long, default_value_t = 50)]
    pub max_iterations: usize,
    /// Threads for the rollouts (0: every core).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// How the runs are read (after the scenario's `[calibration.rename]`).
    #[command(flatten)]
    pub reading: DataFlags,
    #[command(flatten)]
    pub values: SetFlag,
    /// Folder for calibration.json, calibrated.toml and calibration.rrd (created if missing).
    #[arg(long)]
    pub out_dir: Option<PathBuf>,
}

/// Runs `twin calibrate`: progress on stderr, the estimates and fits on stdout, the files into
/// the folder.
pub fn run(args: &CalibrateArgs, registry: &Registry) -> Result<ExitCode, Failure> {
    let overrides = Overrides {
        set: args.values.set.clone(),
        ..Overrides::default()
    };
    let builder = Scenario::open(&args.scenario)?.overrides(&overrides)?;
    let spec = (builder.clone().build(registry)?.scenario.calibration).unwrap_or_default();
    let folder = scenario_folder(&args.scenario);
    let (options, reading) = options(args, &spec)?;
    let plant = plant_columns(&builder, registry)?;
    let read = |paths: &[PathBuf]| -> Result<Vec<RunData>, Failure> {
        paths
            .iter()
            .map(|p| read_run(p, &reading, &plant))
            .collect()
    };
    let data = read(&merged_paths(&args.data, &spec.data, &folder))?;
    let validate = read(&merged_paths(&args.validate, &spec.validate, &folder))?;
    if data.is_empty() {
        return Err(Failure::usage(
            "give a measured run: --data RUN (or [calibration] data)",
        ));
    }
    if let Some(out) = &args.out_dir {
        // Before the fit: a folder that cannot be made is refused now, not after minutes.
        std::fs::create_dir_all(out).map_err(|e| format!("--out-dir {}: {e}", out.display()))?;
    }
    let mut progress = |step: &twin::calibration::Iteration| {
        eprintln!(
            "start {} iteration {:>3}: cost {:.6e}, step {:.2e}, damping {:.1e}",
            step.start, step.iteration, step.cost, step.step, step.damping
        );
    };
    let result = calibrate(
        &builder,
        registry,
        &data,
        &validate,
        &options,
        &mut progress,
    )?;
    if let Some(out) = &args.out_dir {
        write_outputs(out, &result)?;
    }
    print!("{}", report(&result));
    Ok(ExitCode::SUCCESS)
}

/// The folder a scenario file is in (its `[calibration]` paths are relative to it).
fn scenario_folder(scenario: &str) -> PathBuf {
    let path = Path::new(scenario);
    match path.parent() {
        Some(parent) if path.is_file() => parent.to_path_buf(),
        _ => PathBuf::new(),
    }
}

/// The command line's runs, else the table's (relative to the scenario's folder).
fn merged_paths(given: &[PathBuf], table: &[String], folder: &Path) -> Vec<PathBuf> {
    if !given.is_empty() {
        return given.to_vec();
    }
    table.iter().map(|p| folder.join(p)).collect()
}

/// The options: the table's, with the command line's on top.
fn options(
    args: &CalibrateArgs,
    spec: &CalibrationSpec,
) -> Result<(CalibrationOptions, ReadOptions), Failure> {
    let mut parameters: Vec<FitParameter> = FitParameter::from_table(spec);
    for fit in &args.fit {
        let (key, start) = match fit.split_once('=') {
            Some((key, start)) => (key, Some(number(&format!("--fit {fit}"), start)?)),
            None => (fit.as_str(), None),
        };
        parameters.retain(|p| p.key != key);
        parameters.push(FitParameter {
            key: key.to_string(),
            start,
            bounds: None,
            per_run: false,
        });
    }
    for bound in &args.bounds {
        let context = format!("--bounds {bound}");
        let (key, range) = bound
            .split_once('=')
            .ok_or_else(|| Failure::usage(format!("{context}: expected KEY=LO,HI")))?;
        let (lo, hi) = range
            .split_once(',')
            .ok_or_else(|| Failure::usage(format!("{context}: expected KEY=LO,HI")))?;
        let parameter = fitted(&mut parameters, key, &context)?;
        parameter.bounds = Some([number(&context, lo)?, number(&context, hi)?]);
    }
    for key in &args.per_run {
        fitted(&mut parameters, key, &format!("--per-run {key}"))?.per_run = true;
    }
    if parameters.is_empty() {
        return Err(Failure::usage(
            "give a parameter to fit: --fit KEY[=START] (or [calibration.fit])",
        ));
    }
    let noise = noise_levels(&args.noise, spec)?;
    let states = args
        .states
        .as_deref()
        .or(spec.states.as_deref())
        .unwrap_or("auto");
    let options = CalibrationOptions {
        parameters,
        signals: if args.signals.is_empty() {
            spec.signals.clone()
        } else {
            args.signals.clone()
        },
        noise,
        segment: args.segment.or(spec.segment),
        states: StartStates::parse(states),
        closed_loop: args.closed_loop || spec.closed_loop,
        starts: match args.starts.or(spec.starts).unwrap_or(1) {
            0 => return Err(Failure::usage("--starts 0: give at least 1 start")),
            n => n,
        },
        max_iterations: args.max_iterations,
        threads: args.threads,
    };
    Ok((options, args.reading.options(&spec.rename)?))
}

/// The parameter of `key` among those fitted, or a usage error naming the option.
fn fitted<'a>(
    parameters: &'a mut [FitParameter],
    key: &str,
    context: &str,
) -> Result<&'a mut FitParameter, Failure> {
    parameters
        .iter_mut()
        .find(|p| p.key == key)
        .ok_or_else(|| Failure::usage(format!("{context}: `{key}` is not fitted; add --fit {key}")))
}

/// The estimates, the warnings and the fits as text.
fn report(result: &Calibration) -> String {
    let mut out = format!("{}\n", result.verdict.line());
    for reason in &result.verdict.reasons {
        out += &format!("  because {reason}\n");
    }
    if !result.verdict.fits {
        out += "  the intervals below are widened by the residuals' autocorrelation and marked; they are not to be trusted: the model does not explain the data\n";
        for advice in &result.verdict.advice {
            out += &format!("  try: {advice}\n");
        }
    }
    for note in &result.notes {
        out += &format!("note: {note}\n");
    }
    out += "parameter                                   start         estimate      std error     95 % interval\n";
    for e in &result.estimates {
        let name = match &e.run {
            Some(run) => format!("{} ({run})", e.key),
            None => e.key.clone(),
        };
        out += &format!(
            "{name:<42} {:>12.6e} {:>14.8e} {:>12.3e}  [{:.6e}, {:.6e}]{}{}\n",
            e.start,
            e.estimate,
            e.standard_error,
            e.interval[0],
            e.interval[1],
            if e.at_bound { "  at bound" } else { "" },
            if e.widened {
                "  widened, not trusted"
            } else {
                ""
            }
        );
    }
    let segments = match (result.segment, result.segments) {
        (0.0, 1) => "1 whole run".to_string(),
        (0.0, n) => format!("{n} whole runs"),
        (s, n) => format!("{n} segments of {s} s"),
    };
    let states = match result.start_states {
        0 => "no start state fitted".to_string(),
        n => format!(
            "{n} start states fitted, in {}",
            result.coordinates.join(", ")
        ),
    };
    out += &format!(
        "{} iterations, {} rollouts, {segments} ({states}), σ̂² = {:.4}, solver {}\n",
        result.iterations.len().saturating_sub(1),
        result.rollouts,
        result.residual_variance,
        if result.converged {
            "converged"
        } else {
            "not converged"
        }
    );
    for warning in &result.warnings {
        out += &format!("warning: {warning}\n");
    }
    let judged = &result.verdict.signals;
    for run in &result.runs {
        out += &table_judged(&run.source, &run.after, Some(&run.before), judged);
        out += &format!("  {}\n", rate_line(&run.rate, run.period));
    }
    for run in &result.validation {
        out += &format!(
            "validation: {}",
            table_judged(&run.source, &run.after, Some(&run.before), &[])
        );
    }
    out
}

/// calibration.json, calibrated.toml and calibration.rrd into `folder`, each whole or not at
/// all.
fn write_outputs(folder: &Path, result: &Calibration) -> Result<(), Failure> {
    std::fs::create_dir_all(folder).map_err(|e| format!("--out-dir {}: {e}", folder.display()))?;
    let json = serde_json::to_string_pretty(&result.to_json()).map_err(|e| e.to_string())?;
    OutputFile::create(&folder.join("calibration.json"))?.commit(json.as_bytes())?;
    OutputFile::create(&folder.join("calibrated.toml"))?
        .commit(result.calibrated_toml.as_bytes())?;
    let mut figures = Vec::new();
    for run in result.runs.iter().chain(&result.validation) {
        for (signal, unit, [measured, before, after]) in &run.overlays {
            let title = format!("{signal} ({})", file_name(&run.source));
            let curves = [
                ("measured", MEASURED, &measured[..]),
                ("before", BEFORE, &before[..]),
                ("after", AFTER, &after[..]),
            ];
            figures.push(time_plot(&title, unit, run.start_time, run.period, &curves));
        }
    }
    let costs: Vec<f64> = (result.iterations.iter())
        .filter(|i| i.start == result.best_start)
        .map(|i| i.cost)
        .collect();
    figures.push(cost_plot(&costs));
    let intervals: Vec<(String, f64, [f64; 2], f64)> = (result.estimates.iter())
        .map(|e| (e.key.clone(), e.estimate, e.interval, e.start))
        .collect();
    figures.push(interval_plot(&intervals));
    let notes = format!("Calibration: the runs before (orange) and after (green) the fit, the cost per accepted step and each parameter against its start.\n\n{}", report(result));
    write_figures(
        &folder.join("calibration.rrd"),
        "twin calibrate",
        &notes,
        &figures,
    )?;
    Ok(())
}

fn file_name(path: &str) -> &str {
    Path::new(path)
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or(path)
}
