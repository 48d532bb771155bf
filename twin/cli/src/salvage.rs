//! `twin salvage`: the temporary file a killed run left turned into a complete recording.

use crate::failure::Failure;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// `twin salvage` arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct SalvageArgs {
    /// The temporary recording a killed run left behind.
    pub part: PathBuf,
    /// The recording to write (default: the part's name up to `.rrd`; never an existing file).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Runs `twin salvage`: the part's whole messages into the recording, and what was kept.
pub fn run(args: &SalvageArgs) -> Result<ExitCode, Failure> {
    let out = match &args.out {
        Some(out) => out.clone(),
        None => {
            let out = salvaged_name(&args.part).ok_or_else(|| {
                Failure::usage(format!(
                    "{}: not a recording's temporary file (X.rrd.<random>.part); give --out",
                    args.part.display()
                ))
            })?;
            if out.exists() {
                // An error, not a usage one: the command line is fine, the file system is not.
                return Err(Failure::from(format!(
                    "{} exists; name another file with --out",
                    out.display()
                )));
            }
            out
        }
    };
    let report = twin::recordings::salvage(&args.part, &out)?;
    let time = report.last_sim_time.map_or("no samples".to_string(), |t| {
        format!("{t:.6} s of simulated time")
    });
    println!(
        "salvaged {time} (last step {}) in {} messages into {}; {} trailing bytes dropped",
        report.last_step.map_or("none".into(), |s| s.to_string()),
        report.messages,
        out.display(),
        report.dropped_bytes
    );
    Ok(ExitCode::SUCCESS)
}

/// `dir/X.rrd.ab12cd.part` → `dir/X.rrd`.
fn salvaged_name(part: &Path) -> Option<PathBuf> {
    let name = part.file_name()?.to_str()?.strip_suffix(".part")?;
    let (stem, _random) = name.rsplit_once('.')?;
    stem.ends_with(".rrd").then(|| part.with_file_name(stem))
}
