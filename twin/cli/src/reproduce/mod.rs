//! `twin reproduce <paper>`: each seed paper's claims next to the twin's own figures.
//!
//! A paper's module runs its scenarios (every recording into one folder) and returns a
//! [`Report`]: one row per claim with the paper's figure, the twin's figure and a verdict.

mod arm;
mod feed_axis;
pub mod lathe;
mod milling;
mod platform;
mod whitworth;

use crate::flags::EngineFlag;
use framework::Registry;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use twin::{Engine, Scenario, ScenarioBuilder, ScenarioError, TwinError};

/// Whether the twin bears a claim out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    Reproduced,
    Partly,
    NotReproduced,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Claim {
    /// The claim in a few words.
    pub claim: String,
    /// What the paper reports.
    pub paper: String,
    /// What the twin measured.
    pub twin: String,
    pub verdict: Verdict,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    pub paper: String,
    pub claims: Vec<Claim>,
    /// Each run: scenario, controller, recording file and its metrics.
    pub runs: Vec<serde_json::Value>,
}

/// A paper `twin reproduce` knows.
pub struct Paper {
    pub name: &'static str,
    pub summary: &'static str,
    /// Runs the paper's scenarios (on the engine given, else each scenario's own), recordings
    /// into the folder, and compares.
    pub run: fn(&Path, &Registry, Option<Engine>) -> Result<Report, ReproduceError>,
    /// Whether `--engine` can choose its engine (not when an analysis builds its scenarios).
    pub any_engine: bool,
}

/// Every paper, in the order `twin list` shows them.
pub const PAPERS: &[Paper] = &[
    Paper {
        name: "whitworth",
        summary: "Perrusquía et al. 2022: task-space OSMC for constant-velocity cutting on a Whitworth shaper",
        run: whitworth::run,
        any_engine: true,
    },
    Paper {
        name: "arm",
        summary: "Ilyukhin et al. 2014: machining robot, path speed corrected from motor currents",
        run: arm::run,
        any_engine: true,
    },
    Paper {
        name: "lathe",
        summary: "Sudhakara & Landers 2003: parallel turning power loop, its equilibria and region of attraction",
        run: lathe::run,
        any_engine: false,
    },
    Paper {
        name: "feed-axis",
        summary: "Rubio, Ibeas & Luo: P-PI vs super-twisting SMC on a linear-motor feed axis under micro-milling (Table I)",
        run: feed_axis::run,
        any_engine: true,
    },
    Paper {
        name: "platform",
        summary: "Kalinski et al. 2013: two-wheeled platform, optimal control at the energy index vs two PIDs",
        run: platform::run,
        any_engine: true,
    },
    Paper {
        name: "milling",
        summary: "Kaliński & Galewski 2013 §3: slender ball-end milling chatter reduced by spindle-speed programmes",
        run: milling::run,
        any_engine: true,
    },
];

#[derive(Debug, thiserror::Error)]
pub enum ReproduceError {
    #[error("unknown paper `{name}` (known: {known})")]
    Unknown { name: String, known: String },
    #[error(transparent)]
    Twin(#[from] TwinError),
    #[error("cannot write {path}: {reason}")]
    Output { path: String, reason: String },
    /// A search over runs (the arm's safe path speed) found no answer.
    #[error("{0}")]
    Search(String),
    /// `--engine` on a paper whose runs go through an analysis that builds its own scenarios.
    #[error("twin reproduce {paper} runs the exact engine only (through `twin analyze {paper}`); leave out --engine")]
    EngineFixed { paper: String },
}

/// A built-in scenario on the engine given (its own when none).
fn builtin(name: &str, engine: Option<Engine>) -> Result<ScenarioBuilder, ScenarioError> {
    let builder = Scenario::builtin(name)?;
    match engine {
        Some(engine) => builder.set("solver.engine", engine.name()),
        None => Ok(builder),
    }
}

/// `twin reproduce` arguments.
#[derive(Debug, Clone, clap::Args)]
#[command(mut_arg("engine", |arg| arg.help("The engine of every run (as `twin run --engine`); default: each scenario's own")))]
pub struct ReproduceArgs {
    /// The paper (see `twin list`).
    pub paper: String,
    /// Folder for the recordings and report.json.
    #[arg(long, default_value = "reproduce")]
    pub out_dir: PathBuf,
    #[command(flatten)]
    pub solver: EngineFlag,
}

/// Runs `twin reproduce`: the paper's runs and report, and for the terminal its claims as a
/// table and where the files went.
pub fn run(args: &ReproduceArgs, registry: &Registry) -> Result<String, ReproduceError> {
    let report = reproduce(&args.paper, &args.out_dir, registry, args.solver.engine)?;
    let folder = args.out_dir.display();
    Ok(format!(
        "{}recordings and report.json: {folder}\n",
        to_table(&report)
    ))
}

/// Runs every scenario of `paper` (on `engine` when given), writing recordings and
/// `report.json` into `out_dir`.
pub fn reproduce(
    paper: &str,
    out_dir: &Path,
    registry: &Registry,
    engine: Option<Engine>,
) -> Result<Report, ReproduceError> {
    let entry = PAPERS
        .iter()
        .find(|p| p.name == paper)
        .ok_or_else(|| ReproduceError::Unknown {
            name: paper.to_string(),
            known: PAPERS.iter().map(|p| p.name).collect::<Vec<_>>().join(", "),
        })?;
    if !entry.any_engine && engine.is_some_and(|e| e != Engine::Exact) {
        let paper = paper.to_string();
        return Err(ReproduceError::EngineFixed { paper });
    }
    std::fs::create_dir_all(out_dir).map_err(|e| ReproduceError::Output {
        path: out_dir.display().to_string(),
        reason: e.to_string(),
    })?;
    let report = (entry.run)(out_dir, registry, engine)?;
    write_report(&report, out_dir)?;
    Ok(report)
}

fn write_report(report: &Report, out_dir: &Path) -> Result<(), ReproduceError> {
    let path = out_dir.join("report.json");
    let text = serde_json::to_string_pretty(report).map_err(|e| ReproduceError::Output {
        path: path.display().to_string(),
        reason: e.to_string(),
    })?;
    twin::OutputFile::create(&path)
        .and_then(|file| file.commit((text + "\n").as_bytes()))
        .map_err(|e| ReproduceError::Output {
            path: e.path.display().to_string(),
            reason: e.reason,
        })
}

/// The claims as an aligned text table.
pub fn to_table(report: &Report) -> String {
    let widths = report.claims.iter().fold([5, 5, 4], |w, c| {
        [
            w[0].max(c.claim.chars().count()),
            w[1].max(c.paper.chars().count()),
            w[2].max(c.twin.chars().count()),
        ]
    });
    let mut out = String::new();
    let _ = writeln!(out, "paper: {}", report.paper);
    let _ = writeln!(
        out,
        "{:<a$}  {:<b$}  {:<c$}  verdict",
        "claim",
        "paper",
        "twin",
        a = widths[0],
        b = widths[1],
        c = widths[2]
    );
    for claim in &report.claims {
        let verdict = match claim.verdict {
            Verdict::Reproduced => "reproduced",
            Verdict::Partly => "partly",
            Verdict::NotReproduced => "NOT reproduced",
        };
        let _ = writeln!(
            out,
            "{:<a$}  {:<b$}  {:<c$}  {verdict}",
            claim.claim,
            claim.paper,
            claim.twin,
            a = widths[0],
            b = widths[1],
            c = widths[2]
        );
    }
    out
}
