//! The default viewer layout of a recording, written as Rerun blueprint entities. The Rust SDK's
//! blueprint builder (0.36) has no view properties, so this writes the containers, views and the
//! properties we need (the mechanism view's fixed bounds, legend corners) itself, with view ids
//! numbered in order: the same recording gets the same layout.

use rerun::external::re_log_types::{BlueprintActivationCommand, LogMsg, StoreId};
use rerun::external::re_sdk_types::blueprint::archetypes::{
    ContainerBlueprint, PanelBlueprint, PlotLegend, TimePanelBlueprint, ViewBlueprint,
    ViewContents, ViewportBlueprint, VisualBounds2D,
};
use rerun::external::re_sdk_types::blueprint::components::{
    ActiveTab, AutoLayout, AutoViews, ColumnShare, ContainerKind, Corner2D, GridColumns,
    IncludedContent, PanelState, QueryExpression, RootContainer, RowShare, ViewClass,
};
use rerun::external::re_sdk_types::components::Name;
use rerun::external::re_sdk_types::datatypes::{Bool, Float32, Range2D, UInt32};
use rerun::{AsComponents, RecordingStream, RecordingStreamBuilder};

use super::entities::{EVENTS, MECHANISM, SCENARIO, SIM_TIME, SUMMARY};
use super::layout::{PlotSpec, PlotTab};
use crate::scene::Bounds;

/// Up to this many plots are stacked in one column of a tab; more go into a two-column grid.
const MAX_STACKED_PLOTS: usize = 3;

/// A container or a view of the layout.
pub(super) enum Node {
    Container {
        kind: ContainerKind,
        name: String,
        children: Vec<Node>,
        shares: Vec<f32>,
    },
    View {
        class: &'static str,
        name: String,
        origin: String,
        contents: Vec<String>,
        properties: Vec<(&'static str, Box<dyn AsComponents>)>,
    },
}

/// A 2D figure of the layout: its entity, title and the canvas area its view shows.
pub(super) struct FigureView {
    pub entity: String,
    pub title: String,
    /// `[[left, top], [right, bottom]]`, canvas units.
    pub bounds: [[f64; 2]; 2],
}

/// The layout: on the left the mechanism (fixed to `bounds`, in machine coordinates) above tabs
/// with the events, the run's summary and the scenario; on the right the `spectrum` tab with the
/// run's figures (first and open, when there are any: the chatter frequency is what a machinist
/// looks for first), then one tab per kind of plot (tracking first), each plot one unit.
fn layout(
    title: &str,
    bounds: Option<Bounds>,
    plots: &[(String, &PlotSpec)],
    figures: &[FigureView],
) -> Node {
    let mut mechanism_properties: Vec<(&'static str, Box<dyn AsComponents>)> = Vec::new();
    if let Some(b) = bounds {
        // The view is y-down; `/mechanism` flips y, so the machine's y range is negated here.
        let range = Range2D {
            x_range: b.x.into(),
            y_range: [-b.y[1], -b.y[0]].into(),
        };
        mechanism_properties.push(("VisualBounds2D", Box::new(VisualBounds2D::new(range))));
    }
    let mechanism = view(
        "2D",
        title,
        "/",
        vec![format!("+ /{MECHANISM}/**")],
        mechanism_properties,
    );
    let text =
        |class, name: &str, entity: &str| view(class, name, &format!("/{entity}"), vec![], vec![]);
    let left = container(
        ContainerKind::Vertical,
        "",
        vec![
            mechanism,
            container(
                ContainerKind::Tabs,
                "",
                vec![
                    text("TextLog", "events", EVENTS),
                    text("TextDocument", "summary", SUMMARY),
                    text("TextDocument", "scenario", SCENARIO),
                ],
                vec![],
            ),
        ],
        vec![3.0, 1.0],
    );
    let tabs: Vec<Node> = figure_tab(figures)
        .into_iter()
        .chain(PlotTab::ALL.iter().filter_map(|tab| plot_tab(*tab, plots)))
        .collect();
    if tabs.is_empty() {
        return left;
    }
    container(
        ContainerKind::Horizontal,
        "",
        vec![left, container(ContainerKind::Tabs, "", tabs, vec![])],
        vec![1.0, 1.3],
    )
}

/// The figures stacked in the `spectrum` tab, or `None` when there are none.
fn figure_tab(figures: &[FigureView]) -> Option<Node> {
    let views: Vec<Node> = figures
        .iter()
        .map(|figure| {
            let [[left, top], [right, bottom]] = figure.bounds;
            let range = Range2D {
                x_range: [left, right].into(),
                y_range: [top, bottom].into(),
            };
            view(
                "2D",
                &figure.title,
                "/",
                vec![format!("+ /{}/**", figure.entity)],
                vec![("VisualBounds2D", Box::new(VisualBounds2D::new(range)))],
            )
        })
        .collect();
    (!views.is_empty()).then(|| container(ContainerKind::Vertical, "spectrum", views, vec![]))
}

/// The plots of one tab, stacked or in a two-column grid, or `None` when it has none.
fn plot_tab(tab: PlotTab, plots: &[(String, &PlotSpec)]) -> Option<Node> {
    let views: Vec<Node> = plots
        .iter()
        .filter(|(_, plot)| plot.tab == tab)
        .map(|(entity, plot)| {
            // One series: the title names it, and a legend would only cover data.
            let legend = PlotLegend::new()
                .with_corner(Corner2D::LeftTop)
                .with_visible(plot.series.len() > 1);
            view(
                "TimeSeries",
                &plot.title(),
                &format!("/{entity}"),
                vec![],
                vec![("PlotLegend", Box::new(legend))],
            )
        })
        .collect();
    if views.is_empty() {
        return None;
    }
    let kind = if views.len() <= MAX_STACKED_PLOTS {
        ContainerKind::Vertical
    } else {
        ContainerKind::Grid
    };
    Some(container(kind, tab.label(), views, vec![]))
}

pub(super) fn container(
    kind: ContainerKind,
    name: &str,
    children: Vec<Node>,
    shares: Vec<f32>,
) -> Node {
    Node::Container {
        kind,
        name: name.to_owned(),
        children,
        shares,
    }
}

/// A view of class `class` (`2D`, `TimeSeries`, `TextLog`, `TextDocument`) showing `contents`
/// (query expressions; empty: everything under its origin) with view properties by archetype name.
pub(super) fn view(
    class: &'static str,
    name: &str,
    origin: &str,
    contents: Vec<String>,
    properties: Vec<(&'static str, Box<dyn AsComponents>)>,
) -> Node {
    let contents = if contents.is_empty() {
        vec!["$origin/**".to_owned()]
    } else {
        contents
    };
    Node::View {
        class,
        name: name.to_owned(),
        origin: origin.to_owned(),
        contents,
        properties,
    }
}

/// Numbers the layout's containers and views in order (deterministic ids).
struct Writer<'a> {
    stream: &'a RecordingStream,
    next_id: u128,
}

impl Writer<'_> {
    /// Logs `node` and its children; returns its blueprint path.
    fn write(&mut self, node: &Node) -> rerun::RecordingStreamResult<String> {
        self.next_id += 1;
        let id = uuid_text(self.next_id);
        match node {
            Node::Container {
                kind,
                name,
                children,
                shares,
            } => {
                let mut paths = Vec::with_capacity(children.len());
                for child in children {
                    paths.push(self.write(child)?);
                }
                let path = format!("container/{id}");
                let mut arch = ContainerBlueprint::new(*kind)
                    .with_contents(paths.iter().map(|p| IncludedContent(p.as_str().into())));
                if !name.is_empty() {
                    arch = arch.with_display_name(Name(name.as_str().into()));
                }
                arch = match kind {
                    ContainerKind::Horizontal if !shares.is_empty() => {
                        arch.with_col_shares(shares.iter().map(|&s| ColumnShare(Float32(s))))
                    }
                    ContainerKind::Vertical if !shares.is_empty() => {
                        arch.with_row_shares(shares.iter().map(|&s| RowShare(Float32(s))))
                    }
                    ContainerKind::Grid => arch.with_grid_columns(GridColumns(UInt32(2))),
                    ContainerKind::Tabs if !paths.is_empty() => {
                        arch.with_active_tab(ActiveTab(paths[0].as_str().into()))
                    }
                    _ => arch,
                };
                self.stream.log(path.as_str(), &arch)?;
                Ok(path)
            }
            Node::View {
                class,
                name,
                origin,
                contents,
                properties,
            } => {
                let path = format!("view/{id}");
                self.stream.log(
                    format!("{path}/ViewContents"),
                    &ViewContents::new(contents.iter().map(|q| QueryExpression(q.as_str().into()))),
                )?;
                let arch = ViewBlueprint::new(ViewClass((*class).into()))
                    .with_display_name(Name(name.as_str().into()))
                    .with_space_origin(origin.as_str());
                self.stream.log(path.as_str(), &arch)?;
                for (property, archetype) in properties {
                    self.stream
                        .log(format!("{path}/{property}"), archetype.as_ref())?;
                }
                Ok(path)
            }
        }
    }
}

/// A UUID's text form for the layout's `n`-th element.
fn uuid_text(n: u128) -> String {
    let hex = format!("{n:032x}");
    format!(
        "{}-{}-{}-{}-{}",
        &hex[0..8],
        &hex[8..12],
        &hex[12..16],
        &hex[16..20],
        &hex[20..32]
    )
}

/// Sends the default layout of a run's recording to `stream`: the mechanism framed on `bounds`
/// beside the plots, the time panel on `sim_time`.
pub(super) fn send_default(
    stream: &RecordingStream,
    app: &rerun::ApplicationId,
    title: &str,
    bounds: Option<Bounds>,
    plots: &[(String, &PlotSpec)],
    figures: &[FigureView],
) -> Result<(), String> {
    send(
        stream,
        app,
        layout(title, bounds, plots, figures),
        Some(SIM_TIME),
    )
}

/// Sends the layout `root` to `stream`, made active and default for its application, with the
/// side panels folded away and, given a timeline, the time panel on it (folded); without one, the
/// time panel is hidden.
pub(super) fn send(
    stream: &RecordingStream,
    app: &rerun::ApplicationId,
    root: Node,
    timeline: Option<&str>,
) -> Result<(), String> {
    let error = |err: rerun::RecordingStreamError| super::error::error_chain(&err);
    let (blueprint, storage) = RecordingStreamBuilder::new(app.clone())
        .recording_id(format!("{app}-blueprint"))
        .blueprint()
        .memory()
        .map_err(error)?;
    // The viewer identifies blueprint data by this timeline; no wall-clock `log_time` beside it,
    // so that the same layout writes the same bytes.
    blueprint.set_log_time_enabled(false);
    blueprint.set_time_sequence("blueprint", 0);
    let root = match root {
        Node::View { .. } => container(ContainerKind::Tabs, "", vec![root], vec![]),
        container => container,
    };
    let root_path = Writer {
        stream: &blueprint,
        next_id: 0,
    }
    .write(&root)
    .map_err(error)?;
    // The root is numbered first.
    debug_assert_eq!(root_path, format!("container/{}", uuid_text(1)));
    let root_uuid = rerun::external::re_sdk_types::datatypes::Uuid::from(1_u128.to_be_bytes());
    blueprint
        .log(
            "viewport",
            &ViewportBlueprint::new()
                .with_root_container(RootContainer(root_uuid))
                .with_auto_layout(AutoLayout(Bool(false)))
                .with_auto_views(AutoViews(Bool(false))),
        )
        .map_err(error)?;
    log_panels(&blueprint, timeline).map_err(error)?;
    blueprint
        .flush_blocking()
        .map_err(|err| super::error::error_chain(&err))?;
    let messages: Vec<LogMsg> = storage.take();
    let Some(blueprint_id) = messages.first().map(|m| m.store_id().clone()) else {
        return Err("the layout produced no messages".to_owned());
    };
    // Rerun forwards these messages on another channel than the stream's chunks; flushing on
    // both sides puts them in one place in the file, the same on every run.
    let flush = |stream: &RecordingStream| {
        stream
            .flush_blocking()
            .map_err(|err| super::error::error_chain(&err))
    };
    flush(stream)?;
    stream.send_blueprint(
        messages,
        BlueprintActivationCommand {
            blueprint_id: blueprint_id as StoreId,
            make_active: true,
            make_default: true,
        },
    );
    flush(stream)
}

/// The side panels folded away (the views get the window); the time panel folded on
/// `timeline`, or hidden without one.
fn log_panels(
    blueprint: &RecordingStream,
    timeline: Option<&str>,
) -> rerun::RecordingStreamResult<()> {
    for panel in ["blueprint_panel", "selection_panel"] {
        blueprint.log(
            panel,
            &PanelBlueprint::new().with_state(PanelState::Collapsed),
        )?;
    }
    let time_panel = match timeline {
        Some(timeline) => TimePanelBlueprint::new()
            .with_state(PanelState::Collapsed)
            .with_timeline(
                rerun::external::re_sdk_types::blueprint::components::TimelineName(timeline.into()),
            ),
        None => TimePanelBlueprint::new().with_state(PanelState::Hidden),
    };
    blueprint.log("time_panel", &time_panel)
}
