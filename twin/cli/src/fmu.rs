//! `twin fmu`: a scenario packaged as an FMI 2.0 co-simulation FMU.

use crate::failure::Failure;
use crate::flags::SetFlag;
use framework::Registry;
use std::path::PathBuf;
use std::process::ExitCode;
use twin::{OutputFile, Overrides, Scenario};

/// `twin fmu` arguments.
#[derive(Debug, Clone, clap::Args)]
#[command(mut_arg("set", |arg| arg.help("Override a scenario value (as `twin run --set`); the FMU carries the scenario as set")))]
pub struct FmuArgs {
    /// A built-in scenario name or a scenario .toml file.
    pub scenario: String,
    #[command(flatten)]
    pub values: SetFlag,
    /// Embed this controller instead of the scenario's (its parameters start from defaults).
    #[arg(long, value_name = "NAME", conflicts_with = "no_controller")]
    pub controller: Option<String>,
    /// The plant alone: the host is the controller (inputs the actuators' efforts).
    #[arg(long)]
    pub no_controller: bool,
    /// The .fmu file to write.
    #[arg(long, required = true)]
    pub out: PathBuf,
    /// The built twin-fmu shared library; default: libtwin_fmu.so next to this executable
    /// (`cargo build --release -p twin-cli -p twin-fmu` puts both in target/release).
    #[arg(long)]
    pub library: Option<PathBuf>,
}

/// Runs `twin fmu`: the scenario's closed loop (or with --no-controller its plant) packed as
/// an .fmu beside the built shared library, and a line describing it.
pub fn run(args: &FmuArgs, registry: &Registry) -> Result<ExitCode, Failure> {
    let overrides = Overrides {
        controller: args.controller.clone(),
        set: args.values.set.clone(),
        ..Overrides::default()
    };
    let loaded = Scenario::open(&args.scenario)?
        .overrides(&overrides)?
        .build(registry)?;
    let library = match &args.library {
        Some(path) => path.clone(),
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
