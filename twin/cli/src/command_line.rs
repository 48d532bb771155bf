//! The `twin` command line: clap's definition of every command, the dispatch to each command's
//! module, and the reference page generated from the definition.

use crate::analyze;
use crate::bench;
use crate::calibrate;
use crate::compare;
use crate::failure::{Failure, EXIT_DIVERGED, EXIT_ERROR};
use crate::fmu;
use crate::frf;
use crate::linearize;
use crate::list;
use crate::reference;
use crate::reproduce;
use crate::run;
use crate::salvage;
use crate::serve;
use crate::shadow;
use crate::sweep;
use clap::{CommandFactory, Parser, Subcommand};
use std::process::ExitCode;

/// The parsed command line of `twin`.
#[derive(Debug, Parser)]
#[command(
    name = "twin",
    version,
    arg_required_else_help = true,
    about = "Multibody digital twin of machining mechatronics",
    after_help = "Exit codes: 0 ok, 1 error, 2 usage error, 3 the run diverged, \
                  130/143 interrupted by SIGINT/SIGTERM (recording and summary finished)."
)]
pub struct Cli {
    /// The command to run.
    #[command(subcommand)]
    pub command: Command,
}

/// The commands of `twin`, each with its arguments; the doc comments are their `--help`.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// List the built-in scenarios and the registered controllers.
    List,
    /// Run a scenario headless and record it to an .rrd file.
    Run(run::RunArgs),
    /// Measure steps/s of scenarios (every built-in one by default) with and without recording.
    Bench(bench::BenchArgs),
    /// Run a seed paper's scenarios and put its claims next to the twin's figures.
    Reproduce(reproduce::ReproduceArgs),
    /// Analyse a machine's reduced model (the lathe's phase plane): CSV files and a 2D .rrd.
    Analyze(analyze::AnalyzeArgs),
    /// Measure a frequency response (a tap test or shaker test on the twin): frf.csv and frf.rrd.
    Frf(frf::FrfArgs),
    /// Turn what a killed run left (`X.rrd.<random>.part`) into a complete recording.
    Salvage(salvage::SalvageArgs),
    /// Replay a measured run (.csv, .parquet, .rrd) on a scenario and say how far apart they
    /// are: fit %, RMS and largest error, residual whiteness per signal.
    Compare(compare::CompareArgs),
    /// Fit scenario parameters (masses, inertias, damping, friction, sensor gain/bias/delay,
    /// any numeric key) to measured runs: checked first, then weighted least squares, with
    /// standard errors, 95 % intervals and a calibrated scenario.
    Calibrate(calibrate::CalibrateArgs),
    /// Linearise a scenario's plant at an operating point: A, B, C, D, their zero-order hold at
    /// the control period and the poles, into OUT_DIR/linear.json.
    Linearize(linearize::LinearizeArgs),
    /// Run a study: a scenario over grid and random axes, in parallel, scored against specs
    /// (`twin sweep merge` joins shard folders).
    Sweep(sweep::SweepArgs),
    /// Package a scenario as an FMI 2.0 co-simulation FMU: its closed loop with the controller
    /// (inputs a setpoint on the reference and disturbances on the joints), or with
    /// --no-controller the plant alone (inputs the actuators' efforts); outputs the measured and
    /// true signals, parameters the scenario's numbers.
    Fmu(fmu::FmuArgs),
    /// Serve a scenario's run as a virtual machine over OPC UA: the client writes the
    /// actuators' commands and reads the measured signals, paced to the wall clock (--rate) or
    /// advanced in lockstep (--lockstep).
    Serve(serve::ServeArgs),
    /// Watch a running machine (over OPC UA with --map, or a logged run with --data): the twin
    /// estimates its state and tracked parameters with an extended Kalman filter, tests the
    /// innovations, reports anomalies and the parameter that explains each.
    Shadow(shadow::ShadowArgs),
}

/// Runs the command `cli` names, with the built-in controllers: the exit code it ends with, or
/// why it failed (for the caller to print).
pub fn dispatch(cli: Cli) -> Result<ExitCode, Failure> {
    let registry = controllers::builtin();
    match &cli.command {
        Command::List => {
            list::run(&registry);
            Ok(ExitCode::SUCCESS)
        }
        Command::Run(args) => run::run(args, &registry),
        Command::Serve(args) => serve::serve(args, &registry),
        Command::Shadow(args) => shadow::shadow(args, &registry),
        Command::Bench(args) => bench::run(args, &registry),
        Command::Reproduce(args) => printed(reproduce::run(args, &registry)),
        Command::Salvage(args) => salvage::run(args),
        Command::Sweep(args) => sweep::run(args, &registry),
        Command::Linearize(args) => linearize::run(args, &registry),
        Command::Compare(args) => compare::run(args, &registry),
        Command::Calibrate(args) => calibrate::run(args, &registry),
        Command::Fmu(args) => fmu::run(args, &registry),
        Command::Analyze(args) => printed(analyze::run(args, &registry)),
        Command::Frf(args) => printed(frf::run(args, &registry).map_err(frf_failure)),
    }
}

/// A command that returns its summary rather than printing it: the summary on stdout.
fn printed(outcome: Result<String, impl Into<Failure>>) -> Result<ExitCode, Failure> {
    print!("{}", outcome.map_err(Into::into)?);
    Ok(ExitCode::SUCCESS)
}

/// `twin frf`'s failure: a diverged run exits as `twin run`'s does.
fn frf_failure(error: frf::FrfError) -> Failure {
    Failure {
        code: match error {
            frf::FrfError::Diverged(_) => EXIT_DIVERGED,
            _ => EXIT_ERROR,
        },
        message: error.to_string(),
    }
}

/// Every command of `twin` (subcommands included) as Markdown: the generated part of
/// `docs/src/cli.md`.
pub fn reference_markdown() -> String {
    reference::markdown(&mut Cli::command())
}
