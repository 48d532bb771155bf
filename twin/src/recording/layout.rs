//! What a recording contains, fixed before the run starts: the links, scene and bodies drawn, and
//! the plots, each a tab's series of one display unit.

use super::entities::{FIGURES, SIGNALS};
use super::live::LiveViewer;
use super::plot_data::Plot2D;
use crate::mechanism::Shape;
use crate::scene::Scene;
use framework::Unit;

/// What a recording contains, fixed before the run starts.
#[derive(Debug, Clone, Default)]
pub struct RecordingLayout {
    /// Application id / recording name (the scenario name).
    pub app: String,
    /// The recording's id: the same for the same inputs (two such files are byte-identical).
    pub recording_id: String,
    /// The scenario TOML, stored as a static text document (provenance).
    pub scenario_toml: String,
    /// Links to draw: name and shapes in the link frame (drawn as 2D line strips).
    pub links: Vec<(String, Vec<Shape>)>,
    /// The scenario's bodies, drawn like links: name and shapes in the body's frame.
    pub bodies: Vec<(String, Vec<Shape>)>,
    /// Draw the bodies unlabelled (a second pose of the links beside them, whose labels would
    /// cover the links').
    pub unlabelled_bodies: bool,
    /// The mechanism view's frame, drawings and markers; the positions of its markers are passed
    /// to [`Recorder::push`] in the order of `scene.markers`.
    pub scene: Option<Scene>,
    /// The plots. Their series pick, by index, from the values passed to [`Recorder::push`].
    pub plots: Vec<PlotSpec>,
    /// The run's figures (its spectra, a lobe diagram), drawn when it ends
    /// ([`Recorder::figure`]): each a name (its entity is `figures/<name>`) and its frame
    /// (title, axes, aspect), from which the layout frames its view before the run. The y range
    /// of a frame may be a guess; its x range and aspect must be those of the drawing.
    pub figures: Vec<(String, Plot2D)>,
    /// Also stream the run to a live viewer while it is written to the file.
    pub live: Option<LiveViewer>,
}

/// `figures/<name>`, with the name made path-safe.
pub(super) fn figure_entity(name: &str) -> String {
    let slug: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    format!("{FIGURES}/{slug}")
}

/// Which tab of the layout a plot is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PlotTab {
    /// What a watch is about, first and open: the tests against their thresholds and the
    /// tracked parameters (a shadow's recording).
    Watch,
    /// A reference or a command on the plot of what it commands.
    Tracking,
    /// The machine's own signals.
    Process,
    /// Per actuator, the effort commanded and applied.
    Efforts,
    /// The joints' positions and velocities.
    Joints,
    /// The controller's internal signals.
    Controller,
    /// Model checks.
    Diagnostics,
}

impl PlotTab {
    /// The tabs in the order the layout shows them.
    pub const ALL: [PlotTab; 7] = [
        PlotTab::Watch,
        PlotTab::Tracking,
        PlotTab::Process,
        PlotTab::Efforts,
        PlotTab::Joints,
        PlotTab::Controller,
        PlotTab::Diagnostics,
    ];

    /// The tab's name in the layout, lower case: `tracking`, `process`, ….
    pub fn label(self) -> &'static str {
        match self {
            PlotTab::Watch => "watch",
            PlotTab::Tracking => "tracking",
            PlotTab::Process => "process",
            PlotTab::Efforts => "efforts",
            PlotTab::Joints => "joints",
            PlotTab::Controller => "controller",
            PlotTab::Diagnostics => "diagnostics",
        }
    }
}

/// What a series is to its plot; it sets the series' colour, the same in every plot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SeriesRole {
    /// What the machine should follow: the scenario's reference or the controller's.
    Reference,
    /// The simulated (true) value.
    True,
    /// What the controller measures (through a sensor).
    Measured,
    /// An effort or set-point the controller commands.
    Commanded,
    /// The effort the joint receives.
    Applied,
    /// Anything else (a controller internal, a diagnostic): a colour from the palette.
    Other,
}

/// One series of a plot.
#[derive(Debug, Clone, PartialEq)]
pub struct SeriesSpec {
    /// Its name without the unit (the plot adds it).
    pub name: String,
    /// What it is to the plot, which sets its colour.
    pub role: SeriesRole,
    /// Index of its SI value in the values passed to `Recorder::push`.
    pub value: usize,
    /// The run's column it carries, for reading the recording back as data
    /// ([`RunData::read`](crate::data::RunData::read)); `None` for what is not one (an applied
    /// effort, a controller internal, a check, a joint the controller does not measure).
    pub column: Option<SeriesColumn>,
}

/// What a value of a measured run is: an actuator's command, a plant signal as measured, or as
/// it truly is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ColumnRole {
    /// The effort (or current) the controller commands an actuator, held over a control period:
    /// the column `effort.<actuator>`.
    Command,
    /// A plant signal as the controller reads it (through its sensor): the column `<signal>`.
    Measured,
    /// A plant signal's true value (before any sensor): the column `true.<signal>`.
    True,
}

impl ColumnRole {
    /// The role's word in a recording's column annotation.
    pub(super) fn word(self) -> &'static str {
        match self {
            ColumnRole::Command => "command",
            ColumnRole::Measured => "measured",
            ColumnRole::True => "true",
        }
    }

    /// The role a word of [`ColumnRole::word`] names.
    pub(super) fn from_word(word: &str) -> Option<Self> {
        [ColumnRole::Command, ColumnRole::Measured, ColumnRole::True]
            .into_iter()
            .find(|role| role.word() == word)
    }
}

/// The run's column a plotted series carries: the actuator or plant signal it is of, and its
/// roles. A signal without a sensor or sensor fault has one series for both its true and its
/// measured value: at each control update the controller reads the true value.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SeriesColumn {
    /// The actuator's joint (for a command) or the plant signal's name.
    pub name: String,
    /// What the series' values are: one role, or `True` and `Measured` together.
    pub roles: Vec<ColumnRole>,
}

/// A plot: series of one display unit, on one tab.
#[derive(Debug, Clone, PartialEq)]
pub struct PlotSpec {
    /// The tab it is shown on.
    pub tab: PlotTab,
    /// What is plotted, without the unit.
    pub name: String,
    /// The display unit of every series on it (values are pushed in SI and converted).
    pub unit: Unit,
    /// Its series, in the order drawn.
    pub series: Vec<SeriesSpec>,
}

impl PlotSpec {
    /// The plot's title: its name and unit, e.g. `ram position [mm]`.
    pub fn title(&self) -> String {
        format!("{} [{}]", self.name, self.unit.label())
    }

    /// A series' name as shown: with the plot's unit.
    pub fn series_label(&self, series: &SeriesSpec) -> String {
        format!("{} [{}]", series.name, self.unit.label())
    }

    /// The plot's entity under `signals/`: its tab and a path-safe form of its title.
    pub fn entity(&self) -> String {
        let slug: String = format!("{}_{}", self.name, unit_slug(self.unit))
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
            .collect();
        format!("{SIGNALS}/{}/{slug}", self.tab.label())
    }
}

/// An ASCII form of a unit for entity paths.
pub(super) fn unit_slug(unit: Unit) -> String {
    unit.label()
        .replace('µ', "u")
        .replace('°', "deg")
        .replace('²', "2")
        .replace('·', "")
        .replace('/', "_per_")
}
