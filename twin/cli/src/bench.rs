//! `twin bench`: steps per second of scenarios, with and without recording.

use crate::failure::Failure;
use crate::flags::{EngineFlag, SetFlag};
use framework::Registry;
use std::process::ExitCode;
use twin::{Engine, Scenario, Twin, BUILTIN_SCENARIOS};

/// `twin bench` arguments.
#[derive(Debug, Clone, clap::Args)]
#[command(mut_arg("engine", |arg| arg.help("The engine of every measurement (as `twin run --engine`); default: each scenario's own")))]
#[command(mut_arg("set", |arg| arg.help("Override a value of every scenario measured (as `twin run --set`), e.g. solver.integrator=midpoint")))]
pub struct BenchArgs {
    /// Built-in scenario names or scenario .toml files; none: every built-in scenario.
    pub scenarios: Vec<String>,
    /// Simulated time per measurement, s.
    #[arg(long, default_value_t = 10.0, allow_hyphen_values = true)]
    pub duration: f64,
    #[command(flatten)]
    pub solver: EngineFlag,
    #[command(flatten)]
    pub values: SetFlag,
}

/// Runs `twin bench`: a table of each scenario measured bare and recording to a scratch
/// folder (removed after), then the process's peak memory.
pub fn run(args: &BenchArgs, registry: &Registry) -> Result<ExitCode, Failure> {
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
        "{:<24} {:>6} {:>19} {:>9} {:>8} {:>8} {:>14} {:>14}",
        "scenario",
        "engine",
        "integrator",
        "dt (s)",
        "substeps",
        "steps",
        "steps/s bare",
        "steps/s rec."
    );
    let set = args.solver.before(&args.values);
    for name in &names {
        let mut rates = [0.0; 2];
        let mut shape = (Engine::Exact, "", 0.0, 0, 0);
        for (rate, recording) in rates.iter_mut().zip([None, Some(out.as_path())]) {
            let loaded = Scenario::open(name)
                .and_then(|builder| (set.iter()).try_fold(builder, |b, value| b.assign(value)))
                .and_then(|builder| builder.duration(args.duration).build(registry))
                .map_err(|e| e.to_string())?;
            let solver = &loaded.scenario.solver;
            let (substeps, integrator) = match solver.engine {
                Engine::Exact => (loaded.scenario.substeps, solver.integrator.name()),
                Engine::Rapier => (solver.rapier_substeps, "–"),
            };
            shape = (solver.engine, integrator, loaded.scenario.dt, substeps, 0);
            let twin = Twin::new(loaded).map_err(|e| e.to_string())?;
            let result = twin.run(recording).map_err(|e| e.to_string())?;
            shape.4 = result.steps;
            *rate = result.steps_per_s;
        }
        println!(
            "{:<24} {:>6} {:>19} {:>9} {:>8} {:>8} {:>14.0} {:>14.0}",
            name,
            shape.0.name(),
            shape.1,
            shape.2,
            shape.3,
            shape.4,
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

/// Peak resident memory of this process, from /proc (Linux).
fn peak_memory_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}
