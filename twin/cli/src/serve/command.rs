//! `twin serve`'s command: its arguments, the scenario's twin bound to the OPC UA server, the
//! run paced or in lockstep, and its summary.

use super::address_space::Commanding;
use super::controller::{ClientCommands, ScenarioController};
use super::pacing::Pacing;
use super::publisher::{Pace, Publisher};
use super::server::{OpcUaServer, ServerSecurity};
use super::shared::Shared;
use crate::failure::Failure;
use crate::flags::{DurationFlag, OutputFlags, SetFlag};
use crate::opcua::security::{Security, SecurityError};
use crate::signals::stop_on_signals;
use framework::Registry;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;
use twin::{summary, LiveViewer, LoadedScenario, Overrides, Scenario, Twin, TwinError};

/// How long the server stays up after the run, so that a client's last call gets its answer.
const LINGER: Duration = Duration::from_millis(300);

/// `twin serve` arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct ServeArgs {
    /// A built-in scenario name or a scenario .toml file.
    pub scenario: String,
    /// Where the OPC UA server listens: opc.tcp://HOST:PORT, HOST a loopback address (127.0.0.1,
    /// ::1 or localhost), or any address (0.0.0.0) with --security sign or sign-encrypt and
    /// --user.
    #[arg(long, default_value = "opc.tcp://127.0.0.1:4840")]
    pub opcua: String,
    /// OPC UA security: none (no certificates; loopback only), sign or sign-encrypt
    /// (Basic256Sha256; clients' certificates must be in the PKI folder's trusted/).
    #[arg(long, value_enum, default_value_t = Security::None)]
    pub security: Security,
    /// The server's PKI folder with sign or sign-encrypt: its certificate (own/cert.der, made
    /// on first use), private key, trusted/ and rejected/ client certificates
    /// [default: $XDG_DATA_HOME/twin/pki/serve, else ~/.local/share/twin/pki/serve].
    #[arg(long, value_name = "DIR")]
    pub pki: Option<PathBuf>,
    /// Require this user name (and its password) of every session; anonymous sessions are
    /// then refused.
    #[arg(long, value_name = "NAME")]
    pub user: Option<String>,
    /// The --user's password: the first line of this file (else the TWIN_OPCUA_PASSWORD
    /// environment variable; never on the command line).
    #[arg(long, value_name = "FILE")]
    pub password_file: Option<PathBuf>,
    #[command(flatten)]
    pub values: SetFlag,
    #[command(flatten)]
    pub length: DurationFlag,
    /// Real-time factor: simulated seconds per wall-clock second.
    #[arg(long, default_value_t = 1.0, conflicts_with = "lockstep")]
    pub rate: f64,
    /// Run a control period only when the client grants it, with the machine's `Advance(periods)`
    /// method, instead of pacing to the wall clock.
    #[arg(long)]
    pub lockstep: bool,
    /// Keep the scenario's controller in the loop: the client writes offsets on the scenario's
    /// reference (setpoint.reference, setpoint.reference_rate, setpoint.reference_acceleration)
    /// instead of the efforts, which it reads.
    #[arg(long)]
    pub with_controller: bool,
    #[command(flatten)]
    pub outputs: OutputFlags,
}

/// Runs `twin serve`: serves the run until it ends, then prints its summary as `twin run` does.
pub fn serve(args: &ServeArgs, registry: &Registry) -> Result<ExitCode, Failure> {
    if !(args.rate.is_finite() && args.rate > 0.0) {
        return Err(Failure::usage(format!(
            "--rate {}: must be a positive number",
            args.rate
        )));
    }
    let security = server_security(args)?;
    let endpoint = crate::opcua::endpoint::parse_served(
        &args.opcua,
        security.security.is_secure(),
        security.user.is_some(),
    )
    .map_err(|e| Failure::usage(e.to_string()))?;
    let overrides = Overrides {
        controller: None,
        duration: args.length.duration,
        set: args.values.set.clone(),
    };
    let loaded = Scenario::open(&args.scenario)?
        .overrides(&overrides)?
        .build(registry)?;
    let out = args
        .outputs
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("{}.rrd", loaded.scenario.name)));
    let summary_file = crate::run_report::summary_file(args.outputs.summary.as_deref(), &out)?;
    let machine = loaded.scenario.machine.clone();
    // The period the run updates its controller at: whole physics steps.
    let control_period = loaded.scenario.control_every() as f64 * loaded.scenario.dt;
    let server = OpcUaServer::bind(endpoint, security)?;
    if let Some(line) = server.describe() {
        eprintln!("{line}");
    }
    let stop = stop_on_signals()?;
    let shared = Arc::new(Shared::default());
    let (twin, commanding) = served_twin(loaded, &shared, args, registry)?;
    let mut twin = twin.with_stop_flag(stop.clone());
    if let Some(url) = &args.outputs.connect {
        twin = twin.with_live_viewer(LiveViewer::Connect(url.clone()));
    }
    let pace = if args.lockstep {
        Pace::Lockstep
    } else {
        Pace::WallClock(Pacing::new(args.rate))
    };
    let mut publisher = Publisher::new(
        server,
        &machine,
        shared,
        pace,
        control_period,
        stop,
        commanding,
    );
    let result = twin.run_with(Some(&out), &mut [&mut publisher]);
    let misses = publisher.deadline_misses();
    let result = result?;
    publisher.ended(&result).stop(LINGER)?;
    print!("{}", summary::to_table(&result));
    println!("recording: {}", out.display());
    if !args.lockstep {
        println!("deadline misses: {misses}");
    }
    crate::run_report::finish(&result, summary_file)
}

/// The twin served: the client's commands in place of the scenario's controller, or
/// (`--with-controller`) the scenario's controller with the client's setpoint offsets, refused in
/// one line where the scenario has no reference an offset can reach.
fn served_twin(
    loaded: LoadedScenario,
    shared: &Arc<Shared>,
    args: &ServeArgs,
    registry: &Registry,
) -> Result<(Twin, Commanding), Failure> {
    if !args.with_controller {
        let client = Box::new(ClientCommands::new(shared.clone()));
        return Ok((Twin::with_controller(loaded, client)?, Commanding::Client));
    }
    // The scenario's controller as its build made it (which succeeded on these very inputs).
    let spec = &loaded.scenario.controller;
    let own =
        (registry.build(&spec.name, &loaded.scenario.machine, &spec.params)).map_err(|source| {
            TwinError::Controller {
                context: loaded.source.clone(),
                source,
            }
        })?;
    let controller = Box::new(ScenarioController::new(own, shared.clone()));
    let twin = Twin::with_controller(loaded, controller)?
        .with_setpoints(shared.clone())
        .map_err(|e| Failure::usage(format!("--with-controller: {e}")))?;
    Ok((twin, Commanding::Controller))
}

/// The security flags checked and the password read: `--pki` only with sign or sign-encrypt,
/// `--password-file` only with `--user`.
fn server_security(args: &ServeArgs) -> Result<ServerSecurity, Failure> {
    if let (Some(dir), Security::None) = (&args.pki, args.security) {
        return Err(Failure::usage(format!(
            "--pki {}: used only with --security sign or sign-encrypt",
            dir.display()
        )));
    }
    let user = match (&args.user, &args.password_file) {
        (Some(user), file) => {
            if user.is_empty() {
                return Err(Failure::usage("--user: the user name is empty"));
            }
            let password = crate::opcua::security::read_password(user, file.as_deref()).map_err(
                |e| match e {
                    SecurityError::Credentials(message) => Failure::usage(message),
                    other => Failure::from(other),
                },
            )?;
            Some((user.clone(), password))
        }
        (None, Some(file)) => {
            return Err(Failure::usage(format!(
                "--password-file {}: give the user name with --user NAME too",
                file.display()
            )))
        }
        (None, None) => None,
    };
    Ok(ServerSecurity {
        security: args.security,
        pki: args.pki.clone(),
        user,
    })
}
