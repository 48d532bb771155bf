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
use twin::calibration::{
    compare, CalibrationOptions, Comparison, SegmentFit, SignalFit, SignalVerdict, StartStates,
};
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
    let spec = (builder.clone().build(registry)?.scenario.calibration).unwrap_or_default();
    let options = CalibrationOptions {
        segment: args.segment,
        states: StartStates::parse(args.states.as_deref().unwrap_or("auto")),
        closed_loop: args.closed_loop,
        noise: crate::calibrate::noise_levels(&args.noise, &spec)?,
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

/// Segments listed in full up to this many; beyond, the worst of them.
const SEGMENTS_LISTED: usize = 12;

/// Per segment, its times and its worst-fitting signal (the worst segments, where there are
/// many); every segment's figures are in comparison.json.
pub fn segment_table(segments: &[SegmentFit]) -> String {
    if segments.len() < 2 {
        return String::new();
    }
    let worst = |s: &SegmentFit| -> Option<SignalFit> {
        (s.signals.iter())
            .min_by(|a, b| a.fit_percent.total_cmp(&b.fit_percent))
            .cloned()
    };
    let score = |s: &SegmentFit| worst(s).map_or(f64::INFINITY, |f| f.fit_percent);
    let mut listed: Vec<&SegmentFit> = segments.iter().collect();
    let mut out = format!(
        "  per segment, the signal that fits worst ({} segments):\n",
        segments.len()
    );
    if listed.len() > SEGMENTS_LISTED {
        listed.sort_by(|a, b| score(a).total_cmp(&score(b)));
        listed.truncate(SEGMENTS_LISTED);
        listed.sort_by(|a, b| a.start_time.total_cmp(&b.start_time));
        out = format!(
            "  the {SEGMENTS_LISTED} segments of {} that fit worst, and their worst signal:\n",
            segments.len()
        );
    }
    for segment in listed {
        if let Some(fit) = worst(segment) {
            out += &format!(
                "    {:>16}  {:<28} {:>9.3} %\n",
                format!("{:.3}–{:.3} s", segment.start_time, segment.end_time),
                fit.signal,
                fit.fit_percent
            );
        }
    }
    out
}

/// The figures per signal as a table: fit %, RMS and largest error, whiteness; with `before`,
/// the fit % before beside it.
pub fn table(source: &str, signals: &[SignalFit], before: Option<&[SignalFit]>) -> String {
    table_judged(source, signals, before, &[])
}

/// [`table`], the whiteness column as a calibration's verdict reads it: a residual that is its
/// signal's quantisation, or at the data's precision, counts as white.
pub fn table_judged(
    source: &str,
    signals: &[SignalFit],
    before: Option<&[SignalFit]>,
    judged: &[SignalVerdict],
) -> String {
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
            white_word(fit, judged.iter().find(|j| j.signal == fit.signal)),
            fit.unit
        );
    }
    out
}

/// The whiteness column: `yes`, `no`, or why a residual that is not white still counts.
fn white_word(fit: &SignalFit, judged: Option<&SignalVerdict>) -> &'static str {
    match (fit.whiteness.white, judged) {
        (true, _) => "yes",
        (false, Some(j)) if j.white && j.quantum.is_some() => "quantised",
        (false, Some(j)) if j.white => "exact",
        (false, _) => "no",
    }
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
