//! The default viewer layout of a recording.

use rerun::blueprint::{
    Blueprint, ContainerLike, Grid, Horizontal, Spatial2DView, Tabs, TextDocumentView, TextLogView,
    TimePanel, TimeSeriesView, Vertical,
};
use rerun::EntityPath;

use super::{EVENTS, MECHANISM, SCENARIO, SIM_TIME};

/// Up to this many time-series views are stacked in one column; more go into a two-column grid.
const MAX_STACKED_PLOTS: usize = 4;

/// The layout: on the left the mechanism (a 2D view over `/mechanism`, whose y-up transform sits on
/// `/mechanism` itself, hence the view's origin at `/`) above tabs with the event log and the
/// scenario; on the right one time-series plot per series group. The time panel starts on
/// `sim_time`.
pub(super) fn default_blueprint(series: &[(EntityPath, String)]) -> Blueprint {
    let mechanism = Spatial2DView::new("mechanism")
        .with_origin("/")
        .with_contents([format!("+ /{MECHANISM}/**")]);
    let events = TextLogView::new("events").with_origin(format!("/{EVENTS}"));
    let scenario = TextDocumentView::new("scenario").with_origin(format!("/{SCENARIO}"));
    let left = Vertical::new([
        mechanism.into(),
        Tabs::new([events.into(), scenario.into()]).into(),
    ])
    .with_row_shares([3.0, 1.0]);

    let plots: Vec<ContainerLike> = series
        .iter()
        .map(|(path, title)| {
            TimeSeriesView::new(title.clone())
                .with_origin(path.clone())
                .into()
        })
        .collect();
    let root: ContainerLike = match plots.len() {
        0 => left.into(),
        n => {
            let right: ContainerLike = if n <= MAX_STACKED_PLOTS {
                Vertical::new(plots).into()
            } else {
                Grid::new(plots).with_grid_columns(2).into()
            };
            Horizontal::new([left.into(), right])
                .with_column_shares([1.0, 1.0])
                .into()
        }
    };

    Blueprint::new(root).with_time_panel(TimePanel::new().with_timeline(SIM_TIME))
}
