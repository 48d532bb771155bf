//! `twin compare`: a scenario replayed against a measured run (open loop on the run's logged
//! commands, or closed loop on its logged reference), with fit %, RMS and largest error and a
//! whiteness test per signal; into OUT_DIR the report (comparison.json) and a recording of the
//! overlays, residuals and their spectra (comparison.rrd).

use crate::data_flags::{plant_columns, DataFlags};
use crate::failure::Failure;
use crate::fit_figures::{residual_spectra, time_plot, BEFORE, MEASURED, RESIDUAL};
use crate::fit_options::noise_levels;
use crate::fit_tables::{rate_line, segment_table, table};
use crate::flags::SetFlag;
use framework::Registry;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use twin::calibration::{compare, CalibrationOptions, Comparison, StartStates};
use twin::recordings::write_figures;
use twin::{OutputFile, Overrides, Scenario};

/// `twin compare` arguments.
#[derive(Debug, Clone, clap::Args)]
#[command(mut_arg("set", |arg| arg.help("Override a scenario value (as `twin run --set`)")))]
pub struct CompareArgs {
    /// A built-in scenario name or a scenario .toml file.
    pub scenario: String,
    /// The measured run: a .csv, .parquet or twin .rrd file whose columns are `time [s]`, the
    /// actuators' commands `effort.<joint> [unit]` and measured signals `<signal> [unit]`.
    #[arg(long, required = true)]
    pub data: PathBuf,
    /// How the data are read.
    #[command(flatten)]
    pub reading: DataFlags,
    /// Run the scenario's controller on the logged reference instead of replaying the logged
    /// commands.
    #[arg(long)]
    pub closed_loop: bool,
    /// Replay in segments of this many seconds, each from the start state its data give (as
    /// `twin calibrate` does); 0: one replay of the whole run [default: calibrate's, 1 s where
    /// the logged positions place the mechanism, else the whole run].
    #[arg(long, value_name = "SECONDS")]
    pub segment: Option<f64>,
    /// Start states fitted to their segment before comparing: `auto`, `none` (as the data
    /// place them), or joints separated by commas.
    #[arg(long, value_name = "auto|none|JOINTS")]
    pub states: Option<String>,
    /// A signal's noise σ in SI (`NAME=SIGMA`), weighting the start states' fit, instead of
    /// the estimate from its data.
    #[arg(long = "noise", value_name = "NAME=SIGMA")]
    pub noise: Vec<String>,
    #[command(flatten)]
    pub values: SetFlag,
    /// Folder for comparison.json and comparison.rrd (created if missing).
    #[arg(long)]
    pub out_dir: Option<PathBuf>,
}

/// Runs `twin compare`: the table on stdout, the report and recording into the folder.
pub fn run(args: &CompareArgs, registry: &Registry) -> Result<ExitCode, Failure> {
    let overrides = Overrides {
        set: args.values.set.clone(),
        ..Overrides::default()
    };
    let builder = Scenario::open(&args.scenario)?.overrides(&overrides)?;
    let data = (args.reading).read(&args.data, &plant_columns(&builder, registry)?)?;
    let spec = (builder.clone().build(registry)?.scenario.calibration).unwrap_or_default();
    let options = CalibrationOptions {
        segment: args.segment,
        states: StartStates::parse(args.states.as_deref().unwrap_or("auto")),
        closed_loop: args.closed_loop,
        noise: noise_levels(&args.noise, &spec)?,
        ..CalibrationOptions::default()
    };
    let comparison = compare(&builder, registry, &data, &options)?;
    if let Some(folder) = &args.out_dir {
        write_outputs(folder, &comparison)?;
    }
    for note in &comparison.notes {
        eprintln!("note: {note}");
    }
    println!("{}", comparison.replays());
    print!("{}", table(&comparison.source, &comparison.signals, None));
    print!("{}", segment_table(&comparison.segments));
    println!("{}", rate_line(&comparison.rate, comparison.period));
    Ok(ExitCode::SUCCESS)
}

/// comparison.json and comparison.rrd into `folder`, each written whole or not at all.
fn write_outputs(folder: &Path, comparison: &Comparison) -> Result<(), Failure> {
    std::fs::create_dir_all(folder).map_err(|e| format!("--out-dir {}: {e}", folder.display()))?;
    let json = serde_json::to_string_pretty(&comparison.to_json()).map_err(|e| e.to_string())?;
    OutputFile::create(&folder.join("comparison.json"))?.commit(json.as_bytes())?;
    let (start, period) = (comparison.start_time, comparison.period);
    let mut figures = Vec::new();
    let mut residuals = Vec::new();
    for overlay in &comparison.overlays {
        let residual: Vec<f64> = (overlay.measured.iter().zip(&overlay.simulated))
            .map(|(y, s)| y - s)
            .collect();
        figures.push(time_plot(
            &overlay.signal,
            &overlay.unit,
            start,
            period,
            &[
                ("measured", MEASURED, &overlay.measured),
                ("twin", BEFORE, &overlay.simulated),
            ],
        ));
        let title = format!("{} residual", overlay.signal);
        figures.push(time_plot(
            &title,
            &overlay.unit,
            start,
            period,
            &[("residual", RESIDUAL, &residual)],
        ));
        residuals.push((overlay.signal.as_str(), residual));
    }
    figures.push(residual_spectra(period, &residuals));
    let notes = format!(
        "Twin against {} ({}): measured and replayed signals, the residuals (measured − twin) and their spectra.\n\n{}",
        comparison.source,
        comparison.replays(),
        table(&comparison.source, &comparison.signals, None)
    );
    write_figures(
        &folder.join("comparison.rrd"),
        "twin compare",
        &notes,
        &figures,
    )?;
    Ok(())
}
