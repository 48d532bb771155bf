//! A study's plots (`OUT/study.rrd`): a histogram per metric (bar charts over bins of the metric)
//! and a scatter per swept parameter and metric (each run a point, failed runs as red marks under
//! the x axis), plus the report as text. Callers hand over plain data.
//!
//! A scatter is drawn in a unit box (parameter and metric scales differ by orders of magnitude,
//! and a 2D view keeps x and y alike) with its range written at the ends of each axis.

use std::path::{Path, PathBuf};

use rerun::archetypes::{BarChart, LineStrips2D, Points2D, TextDocument, Transform3D};
use rerun::blueprint::{
    BarChartView, Blueprint, ContainerLike, Grid, Spatial2DView, TextDocumentView,
};
use rerun::components::{Color, MediaType, Radius};
use rerun::RecordingStreamBuilder;

use super::error::{error_chain, RecordingError};

/// How many runs fell in each bin of one metric.
#[derive(Debug, Clone, PartialEq)]
pub struct Histogram {
    /// Title, with the unit if known.
    pub name: String,
    /// Left edge of each bin, in the metric's unit.
    pub left_edges: Vec<f64>,
    /// The bins' common width, in the metric's unit.
    pub width: f64,
    /// Runs in each bin (whole numbers, as the bar chart takes them).
    pub counts: Vec<f64>,
}

/// One metric against one parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct Scatter {
    /// The view's title.
    pub name: String,
    /// The parameter's name, written under the x axis.
    pub x_label: String,
    /// The metric's name, written beside the y axis.
    pub y_label: String,
    /// (parameter, metric) of each successful run.
    pub points: Vec<[f64; 2]>,
    /// Parameter values of the failed runs.
    pub failed: Vec<f64>,
}

/// The study's plots as plain data.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StudyPlots {
    /// The recording's name and application id.
    pub title: String,
    /// The study's report, shown as text beside the plots.
    pub notes: String,
    /// One per metric.
    pub histograms: Vec<Histogram>,
    /// One per swept parameter and metric.
    pub scatters: Vec<Scatter>,
}

const OK_BLUE: [u8; 3] = [31, 119, 180];
const FAILED_RED: [u8; 3] = [214, 39, 40];
const FRAME_GREY: [u8; 3] = [150, 150, 150];

/// Writes the plots to `path` (through `<path>.part`, renamed once complete).
pub fn write_study_plots(path: &Path, plots: &StudyPlots) -> Result<(), RecordingError> {
    let mut partial = path.as_os_str().to_owned();
    partial.push(".part");
    let partial = PathBuf::from(partial);
    let write_error = |reason: String| RecordingError::Write {
        path: path.to_path_buf(),
        reason,
    };
    let mut views: Vec<ContainerLike> = vec![TextDocumentView::new("report")
        .with_origin("/report")
        .into()];
    views.extend(plots.histograms.iter().enumerate().map(|(i, h)| {
        BarChartView::new(format!("histogram: {}", h.name))
            .with_origin(format!("/histogram/{i}"))
            .into()
    }));
    views.extend(plots.scatters.iter().enumerate().map(|(i, s)| {
        Spatial2DView::new(s.name.as_str())
            .with_origin(format!("/scatter/{i}"))
            .into()
    }));
    let stream =
        RecordingStreamBuilder::new(rerun::ApplicationId::new_or_unknown(plots.title.clone()))
            .recording_name(plots.title.as_str())
            .enabled(true)
            .with_blueprint(Blueprint::new(Grid::new(views)))
            .save(&partial)
            .map_err(|err| RecordingError::Create {
                path: path.to_path_buf(),
                reason: error_chain(&err),
            })?;
    let log = |entity: String, archetype: &dyn rerun::AsComponents| {
        stream
            .log_static(entity, archetype)
            .map_err(|err| write_error(error_chain(&err)))
    };
    log(
        "report".into(),
        &TextDocument::new(plots.notes.as_str()).with_media_type(MediaType::plain_text()),
    )?;
    for (i, histogram) in plots.histograms.iter().enumerate() {
        let chart = BarChart::new(histogram.counts.clone())
            .with_abscissa(histogram.left_edges.clone())
            .with_widths(vec![histogram.width as f32; histogram.counts.len()])
            .with_color(Color::from_rgb(OK_BLUE[0], OK_BLUE[1], OK_BLUE[2]));
        log(format!("histogram/{i}"), &chart)?;
    }
    for (i, scatter) in plots.scatters.iter().enumerate() {
        for (name, archetype) in scatter_layers(scatter) {
            log(format!("scatter/{i}/{name}"), archetype.as_ref())?;
        }
        log(
            format!("scatter/{i}"),
            &Transform3D::from_scale([1.0, -1.0, 1.0]),
        )?;
    }
    let flushed = stream.flush_blocking().map_err(|err| error_chain(&err));
    drop(stream);
    flushed.map_err(write_error)?;
    std::fs::rename(&partial, path).map_err(|err| write_error(err.to_string()))
}

/// The frame, the axis ranges as labels, the runs and the failed runs of one scatter.
fn scatter_layers(scatter: &Scatter) -> Vec<(&'static str, Box<dyn rerun::AsComponents>)> {
    let range = |values: &mut dyn Iterator<Item = f64>| {
        let (low, high) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
            (l.min(v), h.max(v))
        });
        if low.is_finite() && high > low {
            (low, high)
        } else if low.is_finite() {
            (low - 0.5, low + 0.5)
        } else {
            (0.0, 1.0)
        }
    };
    let (x0, x1) = range(
        &mut scatter
            .points
            .iter()
            .map(|p| p[0])
            .chain(scatter.failed.iter().copied()),
    );
    let (y0, y1) = range(&mut scatter.points.iter().map(|p| p[1]));
    let unit = |v: f64, (a, b): (f64, f64)| ((v - a) / (b - a)) as f32;
    let color = |[r, g, b]: [u8; 3]| Color::from_rgb(r, g, b);
    let frame = LineStrips2D::new([[
        [0.0f32, 0.0],
        [1.0, 0.0],
        [1.0, 1.0],
        [0.0, 1.0],
        [0.0, 0.0],
    ]])
    .with_colors([color(FRAME_GREY)])
    .with_radii([Radius::new_ui_points(0.5)]);
    let ticks = Points2D::new([
        [0.0f32, -0.04],
        [1.0, -0.04],
        [-0.04, 0.0],
        [-0.04, 1.0],
        [0.5, -0.12],
        [-0.12, 0.5],
    ])
    .with_colors([color(FRAME_GREY)])
    .with_radii([Radius::new_ui_points(0.1)])
    .with_labels([
        format!("{x0:.4e}"),
        format!("{x1:.4e}"),
        format!("{y0:.4e}"),
        format!("{y1:.4e}"),
        scatter.x_label.clone(),
        scatter.y_label.clone(),
    ]);
    let runs = Points2D::new(
        scatter
            .points
            .iter()
            .map(|p| [unit(p[0], (x0, x1)), unit(p[1], (y0, y1))]),
    )
    .with_colors([color(OK_BLUE)])
    .with_radii([Radius::new_ui_points(2.5)]);
    let failed = Points2D::new(scatter.failed.iter().map(|x| [unit(*x, (x0, x1)), -0.08]))
        .with_colors([color(FAILED_RED)])
        .with_radii([Radius::new_ui_points(3.0)]);
    vec![
        ("frame", Box::new(frame)),
        ("axes", Box::new(ticks)),
        ("runs", Box::new(runs)),
        ("failed", Box::new(failed)),
    ]
}
