//! `twin linearize`: a scenario's plant linearised at an operating point, into linear.json.

use crate::failure::Failure;
use crate::flags::{EngineFlag, SetFlag};
use framework::Registry;
use std::path::PathBuf;
use std::process::ExitCode;
use twin::{OutputFile, Overrides, Scenario, Twin};

/// `twin linearize` arguments.
#[derive(Debug, Clone, clap::Args)]
#[command(mut_arg("set", |arg| arg.help("Override a scenario value (as `twin run --set`)")))]
#[command(mut_arg("engine", |arg| arg.help("The engine that runs to the operating time (as `twin run --engine`); the linear model is always the exact engine's equations of motion")))]
pub struct LinearizeArgs {
    /// A built-in scenario name or a scenario .toml file.
    pub scenario: String,
    /// The operating time, s: the scenario runs with its controller to it, then the efforts are
    /// held there (0: the initial state).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub at: f64,
    #[command(flatten)]
    pub values: SetFlag,
    #[command(flatten)]
    pub solver: EngineFlag,
    /// Folder for linear.json (created if missing).
    #[arg(long, required = true)]
    pub out_dir: PathBuf,
}

/// Runs `twin linearize`: the linear model into OUT_DIR/linear.json and its table on stdout.
/// The folder is made and its file opened before the run, so an unwritable one fails first.
pub fn run(args: &LinearizeArgs, registry: &Registry) -> Result<ExitCode, Failure> {
    let overrides = Overrides {
        set: args.solver.before(&args.values),
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
