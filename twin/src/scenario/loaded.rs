//! A scenario ready to run: checked, its controller built, with the texts it came from.

use super::spec::Scenario;
use framework::Controller;

/// A scenario ready to run: parsed, checked, its controller built from its checked parameters,
/// with its text (for provenance) and its URDF text.
pub struct LoadedScenario {
    /// The scenario, checked.
    pub scenario: Scenario,
    /// The TOML as run: the text as written, or re-serialised after changes (`set`, `--set`).
    pub toml: String,
    /// Where the scenario came from, for messages.
    pub source: String,
    /// The URDF's text, as read from its file or the built-in copy.
    pub urdf_text: String,
    /// The URDF's path or built-in name, for messages.
    pub urdf_source: String,
    /// The scenario's controller, designed from its parameters; bound to the plant by the twin.
    pub(crate) controller: Box<dyn Controller>,
    /// The scenario file's folder, where the data files its controller names are found (none for
    /// a built-in or text scenario: the working folder).
    pub(crate) folder: Option<std::path::PathBuf>,
}

impl std::fmt::Debug for LoadedScenario {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LoadedScenario")
            .field("scenario", &self.scenario)
            .field("source", &self.source)
            .field("urdf_source", &self.urdf_source)
            .field("controller", &self.controller.name())
            .finish_non_exhaustive()
    }
}
