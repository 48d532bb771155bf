//! `twin shadow`'s arguments: the scenario, the machine's link or logged data, what is tracked
//! and how the anomalies are tested.

use crate::data_flags::DataFlags;
use crate::flags::{DurationFlag, OutputFlags, SetFlag};
use crate::opcua::Security;
use std::path::PathBuf;

/// `twin shadow` arguments.
#[derive(Debug, Clone, clap::Args)]
#[command(mut_arg("duration", |arg| arg.help("Stop after this many seconds of the machine's time (default: the data's end, or a signal)").allow_hyphen_values(false)))]
#[command(mut_arg("out", |arg| arg.help("Recording to write (default: `<scenario>-shadow.rrd`)")))]
#[command(mut_arg("connect", |arg| arg.help("Also stream to a Rerun viewer at this URL")))]
pub struct ShadowArgs {
    /// A built-in scenario name or a scenario .toml file (a calibrated one, best).
    pub scenario: String,
    /// The machine's OPC UA server (default: the map's `endpoint`).
    #[arg(long)]
    pub opcua: Option<String>,
    /// The map of the machine's nodes to the twin's columns, with their units (TOML).
    #[arg(long, conflicts_with = "data")]
    pub map: Option<PathBuf>,
    /// A logged run (CSV, Parquet or a twin .rrd) played in instead of a live machine.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Play --data in at the pace it was logged (times --rate) instead of at once.
    #[arg(long, requires = "data")]
    pub replay: bool,
    /// Real-time factor of --replay.
    #[arg(long, default_value_t = 1.0, requires = "replay")]
    pub rate: f64,
    /// How --data is read.
    #[command(flatten)]
    pub reading: DataFlags,
    /// The measured signals to watch (default: every one the data give that the model
    /// predicts).
    #[arg(long, value_delimiter = ',')]
    pub signals: Vec<String>,
    /// Track a parameter as a filter state: KEY or KEY=DRIFT (σ per √s, SI).
    #[arg(long = "track", value_name = "KEY[=DRIFT]")]
    pub track: Vec<String>,
    /// False alarms per hour of healthy operation, all tests together.
    #[arg(long, default_value_t = 0.1)]
    pub false_alarms: f64,
    /// Seconds at the start taken as healthy, to learn the innovations' statistics.
    #[arg(long, default_value_t = 5.0)]
    pub learn: f64,
    /// Seconds a sample may arrive behind the slowest live stream and still be taken in order.
    #[arg(long, default_value_t = 0.25)]
    pub latency: f64,
    /// A signal's measurement noise σ (SI): NAME=SIGMA.
    #[arg(long = "noise", value_name = "NAME=SIGMA")]
    pub noise: Vec<String>,
    /// The model's acceleration noise, as a share of the largest acceleration an actuator
    /// gives, per √s.
    #[arg(long, default_value_t = twin::shadowing::DEFAULT_PROCESS_NOISE)]
    pub process_noise: f64,
    /// Security of the connection to the machine: none, or Basic256Sha256 sign or
    /// sign-encrypt (with certificates; see the guide's Security section).
    #[arg(long, value_enum, default_value_t = Security::None)]
    pub security: Security,
    /// The shadow's PKI folder for sign or sign-encrypt (default
    /// `$XDG_DATA_HOME/twin/pki/shadow`, else `~/.local/share/twin/pki/shadow`).
    #[arg(long)]
    pub pki: Option<PathBuf>,
    /// The user to log in to the machine's server as; the password from --password-file or
    /// the environment variable TWIN_OPCUA_PASSWORD.
    #[arg(long)]
    pub user: Option<String>,
    /// A file whose first line is the --user's password.
    #[arg(long, requires = "user")]
    pub password_file: Option<PathBuf>,
    /// Seconds to wait for the machine's server to answer, at the start and at each
    /// reconnection attempt.
    #[arg(long, default_value_t = 5.0)]
    pub connect_timeout: f64,
    #[command(flatten)]
    pub length: DurationFlag,
    /// Publish the estimate, residuals and alarms on an OPC UA server here (loopback).
    #[arg(long)]
    pub publish: Option<String>,
    #[command(flatten)]
    pub values: SetFlag,
    #[command(flatten)]
    pub outputs: OutputFlags,
}
