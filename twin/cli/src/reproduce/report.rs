//! What `twin reproduce` reports: each claim of a paper beside the twin's figure, with a
//! verdict.

use serde::Serialize;

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
