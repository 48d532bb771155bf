//! The scenarios and URDF files shipped with the twin, and where a scenario's URDF is found.

use super::error::ScenarioError;
use crate::files::read_text;
use std::path::{Path, PathBuf};

/// The scenarios shipped with the twin: (name, TOML).
pub const BUILTIN: &[(&str, &str)] = &[
    (
        "whitworth-crank-pi",
        include_str!("../../scenarios/whitworth-crank-pi.toml"),
    ),
    (
        "whitworth-tracking",
        include_str!("../../scenarios/whitworth-tracking.toml"),
    ),
    (
        "whitworth-cutting",
        include_str!("../../scenarios/whitworth-cutting.toml"),
    ),
    (
        "arm-milling",
        include_str!("../../scenarios/arm-milling.toml"),
    ),
    ("arm-crash", include_str!("../../scenarios/arm-crash.toml")),
    (
        "platform-path",
        include_str!("../../scenarios/platform-path.toml"),
    ),
    (
        "platform-path-s",
        include_str!("../../scenarios/platform-path-s.toml"),
    ),
    (
        "platform-obstacle",
        include_str!("../../scenarios/platform-obstacle.toml"),
    ),
    (
        "feed-axis-micromilling",
        include_str!("../../scenarios/feed-axis-micromilling.toml"),
    ),
    (
        "lathe-turning",
        include_str!("../../scenarios/lathe-turning.toml"),
    ),
    (
        "milling-constant-15000",
        include_str!("../../scenarios/milling-constant-15000.toml"),
    ),
    (
        "milling-constant-16500",
        include_str!("../../scenarios/milling-constant-16500.toml"),
    ),
    (
        "milling-z04",
        include_str!("../../scenarios/milling-z04.toml"),
    ),
    (
        "milling-z05",
        include_str!("../../scenarios/milling-z05.toml"),
    ),
    (
        "milling-optimal-linear",
        include_str!("../../scenarios/milling-optimal-linear.toml"),
    ),
];

/// The URDF files shipped with the twin, by the path scenarios name them with.
const BUILTIN_URDF: &[(&str, &str)] = &[
    (
        "urdf/platform.urdf",
        include_str!("../../../urdf/platform.urdf"),
    ),
    (
        "urdf/whitworth.urdf",
        include_str!("../../../urdf/whitworth.urdf"),
    ),
    ("urdf/arm.urdf", include_str!("../../../urdf/arm.urdf")),
    (
        "urdf/feed_axis.urdf",
        include_str!("../../../urdf/feed_axis.urdf"),
    ),
    (
        "urdf/milling.urdf",
        include_str!("../../../urdf/milling.urdf"),
    ),
    ("urdf/lathe.urdf", include_str!("../../../urdf/lathe.urdf")),
];

pub(super) fn unknown(name: &str) -> ScenarioError {
    ScenarioError::Unknown {
        name: name.into(),
        known: BUILTIN
            .iter()
            .map(|(n, _)| *n)
            .collect::<Vec<_>>()
            .join(", "),
    }
}

type UrdfLookup = (Result<String, String>, String);

/// The URDF beside a scenario file, else a built-in one of that path; for a built-in scenario,
/// a built-in URDF, else a file of that path (absolute or from the working folder).
pub(super) fn find_urdf(path: &str, folder: Option<&Path>) -> Option<UrdfLookup> {
    let file = |candidate: PathBuf| {
        candidate.exists().then(|| {
            let text = read_text(&candidate);
            (text, candidate.display().to_string())
        })
    };
    let builtin = || {
        BUILTIN_URDF
            .iter()
            .find(|(name, _)| *name == path)
            .map(|(name, text)| (Ok(text.to_string()), format!("built-in {name}")))
    };
    match folder {
        Some(folder) => file(folder.join(path)).or_else(builtin),
        None => builtin().or_else(|| file(PathBuf::from(path))),
    }
}
