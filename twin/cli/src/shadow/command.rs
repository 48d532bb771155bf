//! `twin shadow`'s command: the scenario and its tracked parameters checked, the feed opened,
//! the shadow run over it, and its report.

use super::args::ShadowArgs;
use super::feed::Feed;
use super::{publish, report};
use crate::failure::Failure;
use crate::signals::stop_on_signals;
use framework::Registry;
use std::path::PathBuf;
use std::process::ExitCode;
use twin::shadowing::{Shadow, ShadowOptions, ShadowRecording, TrackedParameter};
use twin::{LiveViewer, Overrides, Scenario};

/// Runs `twin shadow` until the data end, the --duration is reached or a signal stops it.
pub fn shadow(args: &ShadowArgs, registry: &Registry) -> Result<ExitCode, Failure> {
    check_numbers(args)?;
    let overrides = Overrides {
        controller: None,
        duration: None,
        set: args.values.set.clone(),
    };
    let builder = Scenario::open(&args.scenario)?.overrides(&overrides)?;
    let mut feed = Feed::open(args)?;
    let signals = if args.signals.is_empty() {
        default_signals(&builder, &feed, registry)?
    } else {
        args.signals.clone()
    };
    let options = ShadowOptions {
        signals,
        parameters: args
            .track
            .iter()
            .map(|t| tracked(t))
            .collect::<Result<_, _>>()?,
        false_alarms_per_hour: args.false_alarms,
        learn: args.learn,
        latency: args.latency,
        noise: noise(&args.noise)?,
        process_noise: args.process_noise,
    };
    let mut shadow = Shadow::new(builder.build(registry)?, &options)?;
    feed.bind(&shadow, args)?;
    let out = args
        .outputs
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("{}-shadow.rrd", shadow.scenario_name())));
    let summary_file = crate::run_report::summary_file(args.outputs.summary.as_deref(), &out)?;
    let live = args.outputs.connect.clone().map(LiveViewer::Connect);
    let id = format!("{}-shadow-{}", shadow.scenario_name(), feed.digest());
    // The server is bound before the recording is made: a refused --publish leaves no file.
    let publisher = publish::Publisher::start(args.publish.as_deref(), &shadow)?;
    let mut recording = ShadowRecording::create(&out, &shadow, &id, live)?;
    let stop = stop_on_signals()?;
    let outcome = feed.run(&mut shadow, &mut recording, publisher, args, &stop);
    let outcome = match outcome {
        Ok(outcome) => outcome,
        Err(failure) => {
            // The recording keeps what was processed before the failure.
            let _ = recording.finish(&failure.message);
            return Err(failure);
        }
    };
    report::finish(&shadow, recording, &outcome, &out, summary_file)
}

/// The signals watched without --signals: those the source gives, the model predicts and the
/// scenario gives a sensor (whose noise the filter then knows).
fn default_signals(
    builder: &twin::ScenarioBuilder,
    feed: &Feed,
    registry: &Registry,
) -> Result<Vec<String>, Failure> {
    let loaded = builder.clone().build(registry)?;
    let sensed: Vec<String> = loaded.scenario.sensors.keys().cloned().collect();
    let given = feed.measured_columns(&Shadow::watchable(loaded)?);
    let chosen: Vec<String> = given
        .iter()
        .filter(|s| sensed.contains(s))
        .cloned()
        .collect();
    if given.is_empty() {
        return Err(Failure::usage(format!(
            "the machine gives none of the signals the scenario's model predicts ({}): check its \
             columns' or nodes' names against the scenario's signals",
            Shadow::watchable(builder.clone().build(registry)?)?.join(", ")
        )));
    }
    if chosen.is_empty() {
        return Err(Failure::usage(format!(
            "no signal to watch by default (those the machine gives and the model predicts with a \
             sensor in the scenario); give --signals, e.g. from: {}",
            given.join(", ")
        )));
    }
    Ok(chosen)
}

/// Refuses numbers out of range.
fn check_numbers(args: &ShadowArgs) -> Result<(), Failure> {
    if !(args.rate.is_finite() && args.rate > 0.0) {
        return Err(Failure::usage(format!(
            "--rate {}: must be a positive number",
            args.rate
        )));
    }
    if let Some(duration) = args
        .length
        .duration
        .filter(|d| !(d.is_finite() && *d > 0.0))
    {
        return Err(Failure::usage(format!(
            "--duration {duration}: must be a positive number of seconds"
        )));
    }
    if let Some(duration) = args.length.duration.filter(|d| *d <= args.learn) {
        return Err(Failure::usage(format!(
            "--duration {duration}: no longer than --learn {} s (taken as healthy to set the \
             tests): nothing would be tested",
            args.learn
        )));
    }
    if !(args.connect_timeout.is_finite() && args.connect_timeout > 0.0) {
        return Err(Failure::usage(format!(
            "--connect-timeout {}: must be a positive number of seconds",
            args.connect_timeout
        )));
    }
    if args.data.is_none() && args.map.is_none() {
        return Err(Failure::usage(
            "give the machine: --map MAP.toml (live, over OPC UA) or --data RUN (a logged run)",
        ));
    }
    Ok(())
}

/// `--track KEY[=DRIFT]`.
fn tracked(text: &str) -> Result<TrackedParameter, Failure> {
    let (key, drift) = match text.split_once('=') {
        Some((key, drift)) => {
            let value: f64 = drift.trim().parse().map_err(|_| {
                Failure::usage(format!(
                    "--track {text}: DRIFT must be a number (σ per √s, SI)"
                ))
            })?;
            if !(value.is_finite() && value > 0.0) {
                return Err(Failure::usage(format!(
                    "--track {text}: DRIFT must be a positive number"
                )));
            }
            (key.trim(), Some(value))
        }
        None => (text.trim(), None),
    };
    Ok(TrackedParameter {
        key: key.to_string(),
        drift,
    })
}

/// `--noise NAME=SIGMA` entries.
fn noise(entries: &[String]) -> Result<Vec<(String, f64)>, Failure> {
    entries
        .iter()
        .map(|entry| {
            let refuse = || Failure::usage(format!("--noise {entry}: give NAME=SIGMA (SI)"));
            let (name, sigma) = entry.split_once('=').ok_or_else(refuse)?;
            let sigma: f64 = sigma.trim().parse().map_err(|_| refuse())?;
            Ok((name.trim().to_string(), sigma))
        })
        .collect()
}
