//! Reading back what a recording shows without a viewer: the mechanism view's bounds in its
//! layout, its time-series views, its entities and its events. For checks of a written file.

use std::collections::BTreeSet;
use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use rerun::archetypes::TextLog;
use rerun::components::{Name, Text};
use rerun::external::re_log_encoding::DecoderApp;
use rerun::external::re_sdk_types::blueprint::archetypes::{ViewBlueprint, VisualBounds2D};
use rerun::external::re_sdk_types::blueprint::components::{ViewClass, VisualBounds2D as Bounds2D};
use rerun::log::{Chunk, LogMsg};
use rerun::StoreKind;

use super::RecordingError;

/// What a recording shows, as read back from its file.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RecordingContents {
    /// Every `VisualBounds2D` set in the layout: x min, x max, y min, y max (view coordinates).
    pub visual_bounds: Vec<[f32; 4]>,
    /// The names of the layout's time-series views.
    pub time_series_views: Vec<String>,
    /// The recording's entity paths.
    pub entities: BTreeSet<String>,
    /// The text of every event, in the order written.
    pub events: Vec<String>,
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
        if class == "TimeSeries" {
            contents.time_series_views.push(name.clone());
        }
    }
}

fn note_data(chunk: &Chunk, contents: &mut RecordingContents) {
    contents.entities.insert(chunk.entity_path().to_string());
    for texts in chunk.iter_component::<Text>(TextLog::descriptor_text().component) {
        contents
            .events
            .extend(texts.iter().map(|t| t.0.to_string()));
    }
}
