//! Static 2D plots (phase planes and the like) written to their own `.rrd`: named layers of
//! polylines or points, y up, plus a notes text. Callers hand over plain data; only this file
//! turns it into Rerun archetypes.
//!
//! Layout: `/plot` holds a static y-flip (2D views are y-down), `/plot/<layer>` each layer as
//! `LineStrips2D` or `Points2D`, `/notes` a plain-text document. The blueprint shows the plot
//! beside the notes.

use std::path::{Path, PathBuf};

use rerun::archetypes::{LineStrips2D, Points2D, TextDocument, Transform3D};
use rerun::blueprint::{Blueprint, Horizontal, Spatial2DView, TextDocumentView};
use rerun::components::{Color, MediaType, Radius};
use rerun::{EntityPath, RecordingStreamBuilder};

use super::{error_chain, RecordingError};

const PLOT: &str = "plot";
const NOTES: &str = "notes";

/// What a layer draws, in plot coordinates.
#[derive(Debug, Clone, PartialEq)]
pub enum PlotGeometry {
    /// Open polylines.
    Lines(Vec<Vec<[f64; 2]>>),
    Points(Vec<[f64; 2]>),
}

/// One named, coloured set of lines or points.
#[derive(Debug, Clone, PartialEq)]
pub struct PlotLayer {
    /// Entity name under `/plot` (may contain `/` for nesting).
    pub name: String,
    pub color: [u8; 3],
    /// Line width or point diameter, UI points.
    pub size: f32,
    pub geometry: PlotGeometry,
    /// One label per polyline or point, or none.
    pub labels: Vec<String>,
}

/// A 2D plot as plain data.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Plot2D {
    /// Application id / recording name.
    pub title: String,
    /// Free text shown beside the plot (what is drawn, units, key figures).
    pub notes: String,
    pub layers: Vec<PlotLayer>,
}

/// Writes `plot` to `path` (through `<path>.part`, renamed once complete).
pub fn write_plot(path: &Path, plot: &Plot2D) -> Result<(), RecordingError> {
    let mut partial = path.as_os_str().to_owned();
    partial.push(".part");
    let partial = PathBuf::from(partial);
    let create_error = |reason: String| RecordingError::Create {
        path: path.to_path_buf(),
        reason,
    };
    let write_error = |reason: String| RecordingError::Write {
        path: path.to_path_buf(),
        reason,
    };

    let blueprint = Blueprint::new(
        Horizontal::new([
            Spatial2DView::new(plot.title.as_str())
                .with_origin("/")
                .with_contents([format!("+ /{PLOT}/**")])
                .into(),
            TextDocumentView::new("notes")
                .with_origin(format!("/{NOTES}"))
                .into(),
        ])
        .with_column_shares([3.0, 1.0]),
    );
    let stream =
        RecordingStreamBuilder::new(rerun::ApplicationId::new_or_unknown(plot.title.clone()))
            .recording_name(plot.title.as_str())
            .enabled(true)
            .with_blueprint(blueprint)
            .save(&partial)
            .map_err(|err| create_error(error_chain(&err)))?;
    let log = |entity: EntityPath, archetype: &dyn rerun::AsComponents| {
        stream
            .log_static(entity, archetype)
            .map_err(|err| write_error(error_chain(&err)))
    };
    log(
        EntityPath::from(PLOT),
        &Transform3D::from_scale([1.0, -1.0, 1.0]),
    )?;
    log(
        EntityPath::from(NOTES),
        &TextDocument::new(plot.notes.as_str()).with_media_type(MediaType::plain_text()),
    )?;
    for layer in &plot.layers {
        let entity = EntityPath::from(format!("{PLOT}/{}", layer.name.trim_matches('/')));
        let [r, g, b] = layer.color;
        let color = Color::from_rgb(r, g, b);
        let radius = Radius::new_ui_points(0.5 * layer.size);
        let labels = layer.labels.iter().map(String::as_str);
        match &layer.geometry {
            PlotGeometry::Lines(lines) => {
                let strips = lines
                    .iter()
                    .map(|line| line.iter().map(|p| [p[0] as f32, p[1] as f32]).collect())
                    .collect::<Vec<Vec<[f32; 2]>>>();
                log(
                    entity,
                    &LineStrips2D::new(strips)
                        .with_colors([color])
                        .with_radii([radius])
                        .with_labels(labels),
                )?;
            }
            PlotGeometry::Points(points) => {
                log(
                    entity,
                    &Points2D::new(points.iter().map(|p| [p[0] as f32, p[1] as f32]))
                        .with_colors([color])
                        .with_radii([radius])
                        .with_labels(labels),
                )?;
            }
        }
    }
    let flushed = stream.flush_blocking().map_err(|err| error_chain(&err));
    drop(stream);
    flushed.map_err(write_error)?;
    std::fs::rename(&partial, path).map_err(|err| write_error(err.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plot_is_written_whole_and_a_bad_folder_is_an_error() {
        let dir = std::env::temp_dir().join(format!("twin-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("plot.rrd");
        let plot = Plot2D {
            title: "test plot".into(),
            notes: "two layers".into(),
            layers: vec![
                PlotLayer {
                    name: "curves/a".into(),
                    color: [200, 10, 10],
                    size: 1.0,
                    geometry: PlotGeometry::Lines(vec![vec![[0.0, 0.0], [1.0, 2.0]]]),
                    labels: vec!["a".into()],
                },
                PlotLayer {
                    name: "dots".into(),
                    color: [10, 200, 10],
                    size: 4.0,
                    geometry: PlotGeometry::Points(vec![[0.5, 0.5], [1.5, 0.5]]),
                    labels: Vec::new(),
                },
            ],
        };
        write_plot(&path, &plot).unwrap();
        assert!(std::fs::metadata(&path).unwrap().len() > 500);
        assert!(!dir.join("plot.rrd.part").exists());
        let missing = dir.join("no-such-folder").join("plot.rrd");
        assert!(write_plot(&missing, &plot).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
