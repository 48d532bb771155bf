//! `twin compare`: a scenario replayed against a measured run (open loop on the run's logged
//! commands, or closed loop on its logged reference), with fit %, RMS and largest error and a
//! whiteness test per signal; into OUT_DIR the report (comparison.json) and a recording of the
//! overlays, residuals and their spectra (comparison.rrd).

use crate::data_flags::{plant_columns, DataFlags};
use crate::failure::Failure;
use crate::fit_figures::{residual_spectra, time_plot, BEFORE, MEASURED, RESIDUAL};
use framework::Registry;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use twin::calibration::{compare, Comparison, SignalFit};
use twin::data::DataRate;
use twin::recordings::write_figures;
use twin::{OutputFile, Overrides, Scenario};

/// `twin compare` arguments.
#[derive(Debug, Clone, clap::Args)]
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
    /// Override a scenario value (as `twin run --set`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Folder for comparison.json and comparison.rrd (created if missing).
    #[arg(long)]
    pub out_dir: Option<PathBuf>,
}

/// Runs `twin compare`: the table on stdout, the report and recording into the folder.
pub fn run(args: &CompareArgs, registry: &Registry) -> Result<ExitCode, Failure> {
    let overrides = Overrides {
        set: args.set.clone(),
        ..Overrides::default()
    };
    let builder = Scenario::open(&args.scenario)?.overrides(&overrides)?;
    let data = (args.reading).read(&args.data, &plant_columns(&builder, registry)?)?;
    let comparison = compare(&builder, registry, &data, args.closed_loop)?;
    if let Some(folder) = &args.out_dir {
        write_outputs(folder, &comparison)?;
    }
    print!("{}", table(&comparison.source, &comparison.signals, None));
    println!("{}", rate_line(&comparison.rate, comparison.period));
    Ok(ExitCode::SUCCESS)
}

/// The figures per signal as a table: fit %, RMS and largest error, whiteness; with `before`,
/// the fit % before beside it.
pub fn table(source: &str, signals: &[SignalFit], before: Option<&[SignalFit]>) -> String {
    let mut out = format!("{source}\n");
    let head = match before {
        Some(_) => "fit before %  fit after %",
        None => "fit %",
    };
    out += &format!(
        "  {:<28} {head:>12} {:>12} {:>12}  {:<8} unit\n",
        "signal", "rms error", "max error", "white"
    );
    for (k, fit) in signals.iter().enumerate() {
        let fits = match before {
            Some(before) => format!("{:>12.3}  {:>11.3}", before[k].fit_percent, fit.fit_percent),
            None => format!("{:>12.3}", fit.fit_percent),
        };
        out += &format!(
            "  {:<28} {fits} {:>12.4e} {:>12.4e}  {:<8} {}\n",
            fit.signal,
            fit.rms_error,
            fit.max_error,
            if fit.whiteness.white { "yes" } else { "no" },
            fit.unit
        );
    }
    out
}

/// The data's own sampling, and whether it was resampled onto the control period.
pub fn rate_line(rate: &DataRate, period: f64) -> String {
    let resampled = match rate.resampled {
        true => format!("resampled onto the control period, {period} s"),
        false => "on the control period already".to_string(),
    };
    format!(
        "data sampled every {:.6} s on average ({:.6}–{:.6} s): {resampled}",
        rate.mean_period, rate.min_period, rate.max_period
    )
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
        if comparison.closed_loop { "closed loop on the logged reference" } else { "open loop on the logged commands" },
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
