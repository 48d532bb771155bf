//! The static parts of a recording: the mechanism's links and bodies as line strips, the scene, the
//! plots' series names and colours, and the entity paths they are logged at.

use rerun::archetypes::{LineStrips2D, Points2D, SeriesLines, TextDocument, Transform3D};
use rerun::components::{Color, MediaType, Radius};
use rerun::{EntityPath, EntityPathPart, RecordingStream};

use super::entities::{MECHANISM, SCENARIO};
use super::error::error_chain;
use super::layout::{PlotSpec, RecordingLayout, SeriesRole};
use super::signals::column_batches;
use super::style::{BODY_COLOR, CIRCLE_SEGMENTS, LINK_PALETTE};
use crate::mechanism::{Outline, Shape};
use crate::scene::{Marker, Scene};

/// `/mechanism/<link>`.
pub(super) fn link_entity(name: &str) -> EntityPath {
    EntityPath::new(vec![
        EntityPathPart::new(MECHANISM),
        EntityPathPart::new(name),
    ])
}

/// `/mechanism/bodies/<body>`.
pub(super) fn body_entity(name: &str) -> EntityPath {
    scene_entity("bodies", name)
}

/// `/mechanism/<kind>/<name>`.
pub(super) fn scene_entity(kind: &str, name: &str) -> EntityPath {
    EntityPath::new(vec![
        EntityPathPart::new(MECHANISM),
        EntityPathPart::new(kind),
        EntityPathPart::new(name),
    ])
}

/// Logs the static parts of the recording: the y-up root transform, the links (coloured and
/// labelled), the scene, the scenario text and the plots' series names and colours.
pub(super) fn log_layout(stream: &RecordingStream, layout: &RecordingLayout) -> Result<(), String> {
    let log_static = |entity: EntityPath, archetype: &dyn rerun::AsComponents| {
        stream
            .log_static(entity, archetype)
            .map_err(|err| error_chain(&err))
    };
    log_static(
        EntityPath::from(MECHANISM),
        &Transform3D::from_scale([1.0, -1.0, 1.0]),
    )?;
    for (index, (name, shapes)) in layout.links.iter().enumerate() {
        let color = LINK_PALETTE[index % LINK_PALETTE.len()];
        if let Some(strips) = link_strips(shapes, color) {
            log_static(link_entity(name), &strips.with_labels([name.as_str()]))?;
        }
    }
    for (name, shapes) in &layout.bodies {
        if let Some(strips) = link_strips(shapes, BODY_COLOR) {
            let strips = match layout.unlabelled_bodies {
                true => strips,
                false => strips.with_labels([name.as_str()]),
            };
            log_static(body_entity(name), &strips)?;
        }
    }
    if let Some(scene) = &layout.scene {
        log_scene(&log_static, scene)?;
    }
    log_static(
        EntityPath::from(SCENARIO),
        &TextDocument::new(layout.scenario_toml.as_str()).with_media_type(MediaType::plain_text()),
    )?;
    for plot in layout.plots.iter().filter(|p| !p.series.is_empty()) {
        let colors = series_colors(plot);
        let lines = SeriesLines::new()
            .with_names(plot.series.iter().map(|s| plot.series_label(s)))
            .with_colors(colors.iter().map(|&[r, g, b]| Color::from_rgb(r, g, b)));
        // One log, so one chunk: two static logs of one entity may reach the file in either
        // order, and the same run must write the same bytes.
        let columns = column_batches(plot);
        log_static(
            EntityPath::from(plot.entity()),
            &[&lines as &dyn rerun::AsComponents, &columns],
        )?;
    }
    Ok(())
}

/// The scene's drawings and the markers' and traces' colours and labels.
pub(super) fn log_scene(
    log_static: &dyn Fn(EntityPath, &dyn rerun::AsComponents) -> Result<(), String>,
    scene: &Scene,
) -> Result<(), String> {
    for drawing in &scene.drawings {
        let strips = drawing.lines.iter().map(|line| {
            line.iter()
                .map(|&[x, y]| [x as f32, y as f32])
                .collect::<Vec<_>>()
        });
        let [r, g, b] = drawing.color;
        log_static(
            scene_entity("scene", &drawing.name),
            &LineStrips2D::new(strips)
                .with_colors([Color::from_rgb(r, g, b)])
                .with_labels([drawing.label.as_str()]),
        )?;
    }
    for marker in &scene.markers {
        log_marker_style(log_static, marker)?;
    }
    Ok(())
}

pub(super) fn log_marker_style(
    log_static: &dyn Fn(EntityPath, &dyn rerun::AsComponents) -> Result<(), String>,
    marker: &Marker,
) -> Result<(), String> {
    let [r, g, b] = marker.color;
    let color = Color::from_rgb(r, g, b);
    log_static(
        scene_entity("markers", &marker.name),
        &Points2D::update_fields()
            .with_colors([color])
            .with_radii([Radius::new_ui_points(4.0)])
            .with_labels([marker.label.as_str()]),
    )?;
    if marker.trace {
        log_static(
            scene_entity("traces", &marker.name),
            &LineStrips2D::update_fields().with_colors([color]),
        )?;
    }
    Ok(())
}

/// Colours of a plot's series: each role's own colour, or, when that is taken in the plot, the
/// next free one of the palette, so that the series of a plot are always told apart.
pub(super) fn series_colors(plot: &PlotSpec) -> Vec<[u8; 3]> {
    const PALETTE: [[u8; 3]; 10] = [
        [204, 121, 167],
        [0, 114, 178],
        [148, 103, 189],
        [240, 228, 66],
        [140, 86, 75],
        [127, 127, 127],
        [23, 190, 207],
        [188, 189, 34],
        [255, 152, 150],
        [197, 176, 213],
    ];
    let mut used: Vec<[u8; 3]> = Vec::with_capacity(plot.series.len());
    for series in &plot.series {
        let own = match series.role {
            SeriesRole::Reference => Some([220, 220, 220]),
            SeriesRole::True => Some([86, 180, 233]),
            SeriesRole::Measured => Some([230, 159, 0]),
            SeriesRole::Commanded => Some([0, 158, 115]),
            SeriesRole::Applied => Some([213, 94, 0]),
            SeriesRole::Other => None,
        };
        let color = own
            .filter(|c| !used.contains(c))
            .or_else(|| PALETTE.iter().copied().find(|c| !used.contains(c)))
            .unwrap_or(PALETTE[used.len() % PALETTE.len()]);
        used.push(color);
    }
    used
}

/// The link's shapes as closed line strips in the link frame (a circle also gets a radius, so that
/// its rotation shows), or `None` when it has none.
pub(super) fn link_strips(shapes: &[Shape], default_color: [u8; 3]) -> Option<LineStrips2D> {
    let mut strips: Vec<Vec<[f32; 2]>> = Vec::new();
    let mut colors: Vec<Color> = Vec::new();
    for shape in shapes {
        let color = match shape.color {
            Some(rgba) => {
                let [r, g, b, a] = rgba.map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8);
                Color::from_unmultiplied_rgba(r, g, b, a)
            }
            None => Color::from_rgb(default_color[0], default_color[1], default_color[2]),
        };
        let point = |x: f64, y: f64| {
            let [px, py] = shape.origin.apply(x, y);
            [px as f32, py as f32]
        };
        match &shape.outline {
            &Outline::Rectangle { width, height } => {
                let (hx, hy) = (width / 2.0, height / 2.0);
                strips.push(vec![
                    point(-hx, -hy),
                    point(hx, -hy),
                    point(hx, hy),
                    point(-hx, hy),
                    point(-hx, -hy),
                ]);
                colors.push(color);
            }
            &Outline::Circle { radius } => {
                strips.push(
                    (0..=CIRCLE_SEGMENTS)
                        .map(|i| {
                            let a = std::f64::consts::TAU * i as f64 / CIRCLE_SEGMENTS as f64;
                            point(radius * a.cos(), radius * a.sin())
                        })
                        .collect(),
                );
                strips.push(vec![point(0.0, 0.0), point(radius, 0.0)]);
                colors.extend([color, color]);
            }
            Outline::Polygon { points } => {
                let closed = points.iter().chain(points.first());
                strips.push(closed.map(|&[x, y]| point(x, y)).collect());
                colors.push(color);
            }
        }
    }
    (!strips.is_empty()).then(|| LineStrips2D::new(strips).with_colors(colors))
}
