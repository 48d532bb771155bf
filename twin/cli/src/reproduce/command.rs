//! `twin reproduce <paper>`: its arguments, running the paper's module, and the report as a
//! file and a table.

use super::error::ReproduceError;
use super::papers::reproduction;
use super::report::{Report, Verdict};
use crate::flags::EngineFlag;
use crate::papers::PAPERS;
use framework::Registry;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use twin::Engine;

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
    let unknown = || ReproduceError::Unknown {
        name: paper.to_string(),
        known: PAPERS.iter().map(|p| p.name).collect::<Vec<_>>().join(", "),
    };
    let entry = PAPERS
        .iter()
        .find(|p| p.name == paper)
        .ok_or_else(unknown)?;
    let run = reproduction(paper).ok_or_else(unknown)?;
    if !entry.any_engine && engine.is_some_and(|e| e != Engine::Exact) {
        let paper = paper.to_string();
        return Err(ReproduceError::EngineFixed { paper });
    }
    std::fs::create_dir_all(out_dir).map_err(|e| ReproduceError::Output {
        path: out_dir.display().to_string(),
        reason: e.to_string(),
    })?;
    let report = run(out_dir, registry, engine)?;
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
