//! Reading back what a recording shows without a viewer: the mechanism view's bounds in its
//! layout, its time-series views, its entities and its events. For checks of a written file.

use std::collections::{BTreeMap, BTreeSet};
use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use rerun::archetypes::{LineStrips2D, Points2D, TextLog};
use rerun::components::{LineStrip2D, Name, Position2D, Text};
use rerun::external::re_log_encoding::DecoderApp;
use rerun::external::re_sdk_types::blueprint::archetypes::{ViewBlueprint, VisualBounds2D};
use rerun::external::re_sdk_types::blueprint::components::{ViewClass, VisualBounds2D as Bounds2D};
use rerun::log::{Chunk, LogMsg};
use rerun::StoreKind;

use super::error::RecordingError;

/// What a recording shows, as read back from its file.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RecordingContents {
    /// Every `VisualBounds2D` set in the layout: x min, x max, y min, y max (view coordinates).
    pub visual_bounds: Vec<[f32; 4]>,
    /// The names of the layout's time-series views.
    pub time_series_views: Vec<String>,
    /// The names of the layout's 2D views (the mechanism and the run's figures).
    pub views_2d: Vec<String>,
    /// Every layer drawn in the run's figures (`figures/<name>/data/<layer>`, and their labels
    /// at `…/label`), by entity path, in plot units.
    pub figure_layers: BTreeMap<String, FigureLayer>,
    /// The recording's entity paths.
    pub entities: BTreeSet<String>,
    /// The text of every event, in the order written.
    pub events: Vec<String>,
}

/// A figure layer as read back: its polylines or points and its labels.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FigureLayer {
    /// Its line strips, each a list of [x, y] in plot units.
    pub lines: Vec<Vec<[f32; 2]>>,
    /// Its points' positions [x, y], in plot units.
    pub points: Vec<[f32; 2]>,
    /// Its points' labels, in the order written.
    pub labels: Vec<String>,
}

/// Reads `path` and collects what it shows.
pub fn inspect(path: &Path) -> Result<RecordingContents, RecordingError> {
    let error = |reason: String| RecordingError::Read {
        path: path.to_path_buf(),
        reason,
    };
    let file = File::open(path).map_err(|e| error(e.to_string()))?;
    let mut contents = RecordingContents::default();
    for message in DecoderApp::decode_lazy(BufReader::new(file)) {
        let message = message.map_err(|e| error(e.to_string()))?;
        let LogMsg::ArrowMsg(store, arrow) = message else {
            continue;
        };
        let chunk = Chunk::from_arrow_msg(&arrow).map_err(|e| error(e.to_string()))?;
        match store.kind() {
            StoreKind::Blueprint => note_layout(&chunk, &mut contents),
            StoreKind::Recording => note_data(&chunk, &mut contents),
        }
    }
    Ok(contents)
}

fn note_layout(chunk: &Chunk, contents: &mut RecordingContents) {
    for bounds in chunk.iter_component::<Bounds2D>(VisualBounds2D::descriptor_range().component) {
        for b in bounds.iter() {
            let (x, y) = (b.0.x_range.0, b.0.y_range.0);
            contents
                .visual_bounds
                .push([x[0] as f32, x[1] as f32, y[0] as f32, y[1] as f32]);
        }
    }
    let classes: Vec<String> = chunk
        .iter_component::<ViewClass>(ViewBlueprint::descriptor_class_identifier().component)
        .flat_map(|c| c.iter().map(|c| c.0.to_string()).collect::<Vec<_>>())
        .collect();
    let names: Vec<String> = chunk
        .iter_component::<Name>(ViewBlueprint::descriptor_display_name().component)
        .flat_map(|n| n.iter().map(|n| n.0.to_string()).collect::<Vec<_>>())
        .collect();
    for (class, name) in classes.iter().zip(&names) {
        match class.as_str() {
            "TimeSeries" => contents.time_series_views.push(name.clone()),
            "2D" => contents.views_2d.push(name.clone()),
            _ => {}
        }
    }
}

fn note_data(chunk: &Chunk, contents: &mut RecordingContents) {
    let entity = chunk.entity_path().to_string();
    if entity.starts_with("/figures/") && entity.contains("/data/") {
        note_figure(
            chunk,
            contents.figure_layers.entry(entity.clone()).or_default(),
        );
    }
    contents.entities.insert(entity);
    for texts in chunk.iter_component::<Text>(TextLog::descriptor_text().component) {
        contents
            .events
            .extend(texts.iter().map(|t| t.0.to_string()));
    }
}

fn note_figure(chunk: &Chunk, layer: &mut FigureLayer) {
    let strips = LineStrips2D::descriptor_strips().component;
    for batch in chunk.iter_component::<LineStrip2D>(strips) {
        let lines = batch
            .iter()
            .map(|s| s.0.iter().map(|p| [p.x(), p.y()]).collect());
        layer.lines.extend(lines);
    }
    let positions = Points2D::descriptor_positions().component;
    for batch in chunk.iter_component::<Position2D>(positions) {
        layer.points.extend(batch.iter().map(|p| [p.x(), p.y()]));
    }
    let labels = Points2D::descriptor_labels().component;
    for batch in chunk.iter_component::<Text>(labels) {
        layer.labels.extend(batch.iter().map(|t| t.0.to_string()));
    }
}
