//! `twin serve`: a scenario's run as a virtual machine over OPC UA. The client writes the
//! actuators' commands and reads the measured signals; the run is paced to the wall clock or
//! advanced in lockstep by the client.

mod address_space;
mod controller;
mod endpoint;
mod error;
mod pacing;
mod publisher;
mod server;
mod shared;

pub use error::ServeError;

use crate::failure::Failure;
use crate::signals::stop_on_signals;
use controller::ClientCommands;
use framework::Registry;
use pacing::Pacing;
use publisher::{Pace, Publisher};
use server::OpcUaServer;
use shared::Shared;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;
use twin::{same_file, summary, LiveViewer, OutputFile, Overrides, Scenario, Twin};

/// How long the server stays up after the run, so that a client's last call gets its answer.
const LINGER: Duration = Duration::from_millis(300);

/// `twin serve` arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct ServeArgs {
    /// A built-in scenario name or a scenario .toml file.
    pub scenario: String,
    /// Where the OPC UA server listens: opc.tcp://HOST:PORT, HOST a loopback address
    /// (127.0.0.1, ::1 or localhost; security policy None, anonymous, no certificates).
    #[arg(long, default_value = "opc.tcp://127.0.0.1:4840")]
    pub opcua: String,
    /// Override a scenario value: a dotted key into the TOML.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Simulated time, s.
    #[arg(long, allow_hyphen_values = true)]
    pub duration: Option<f64>,
    /// Real-time factor: simulated seconds per wall-clock second.
    #[arg(long, default_value_t = 1.0, conflicts_with = "lockstep")]
    pub rate: f64,
    /// Run a control period only when the client grants it, with the machine's `Advance(periods)`
    /// method, instead of pacing to the wall clock.
    #[arg(long)]
    pub lockstep: bool,
    /// Recording to write (default: `<scenario>.rrd` in the current folder).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Also write the summary as JSON to this file.
    #[arg(long)]
    pub summary: Option<PathBuf>,
    /// Also stream the run to a Rerun viewer listening at this URL
    /// (e.g. rerun+http://127.0.0.1:9876/proxy).
    #[arg(long)]
    pub connect: Option<String>,
}

/// Runs `twin serve`: serves the run until it ends, then prints its summary as `twin run` does.
pub fn serve(args: &ServeArgs, registry: &Registry) -> Result<ExitCode, Failure> {
    if !(args.rate.is_finite() && args.rate > 0.0) {
        return Err(Failure::usage(format!(
            "--rate {}: must be a positive number",
            args.rate
        )));
    }
    let endpoint = endpoint::parse(&args.opcua).map_err(|e| Failure::usage(e.to_string()))?;
    let overrides = Overrides {
        controller: None,
        duration: args.duration,
        set: args.set.clone(),
    };
    let loaded = Scenario::open(&args.scenario)?
        .overrides(&overrides)?
        .build(registry)?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("{}.rrd", loaded.scenario.name)));
    if let Some(path) = args.summary.as_deref().filter(|p| same_file(p, &out)) {
        return Err(Failure::usage(format!(
            "--summary {} is the recording's path too; give them different files",
            path.display()
        )));
    }
    let summary_file = args
        .summary
        .as_deref()
        .map(OutputFile::create)
        .transpose()?;
    let machine = loaded.scenario.machine.clone();
    let server = OpcUaServer::bind(endpoint)?;
    let stop = stop_on_signals()?;
    let shared = Arc::new(Shared::default());
    let mut twin = Twin::with_controller(loaded, Box::new(ClientCommands::new(shared.clone())))?
        .with_stop_flag(stop.clone());
    if let Some(url) = &args.connect {
        twin = twin.with_live_viewer(LiveViewer::Connect(url.clone()));
    }
    let pace = if args.lockstep {
        Pace::Lockstep
    } else {
        Pace::WallClock(Pacing::new(args.rate))
    };
    let mut publisher = Publisher::new(server, &machine, shared, pace, stop);
    let result = twin.run_with(Some(&out), &mut [&mut publisher]);
    let misses = publisher.deadline_misses();
    let result = result?;
    publisher.ended(&result).stop(LINGER)?;
    print!("{}", summary::to_table(&result));
    println!("recording: {}", out.display());
    if !args.lockstep {
        println!("deadline misses: {misses}");
    }
    crate::run::finish(&result, summary_file)
}
