//! Static 2D plots (phase planes, lobe diagrams and the like) written to their own `.rrd`: named
//! layers of polylines or points inside a plot window with a frame, numeric ticks, a light grid
//! and axis titles, plus a notes text. Callers hand over plain data in plot units; only this
//! file turns it into Rerun archetypes.
//!
//! Layout: the window is drawn on a canvas of [`CANVAS_WIDTH`] × `aspect` · [`CANVAS_WIDTH`]
//! units, y down (about one UI point per unit at a usual view size). `/plot/axes` holds the frame,
//! grid, ticks and titles in canvas units; `/plot/data` a static transform from plot units to the
//! canvas, and `/plot/data/<layer>` each layer clipped to the window (`LineStrips2D` or
//! `Points2D`), with a curve's label at `/plot/data/<layer>/label`. `/notes` is a plain-text
//! document. The blueprint shows the plot (its visual bounds the window plus the tick labels)
//! beside the notes.

use std::path::{Path, PathBuf};

use rerun::archetypes::{LineStrips2D, Points2D, TextDocument, Transform3D};
use rerun::blueprint::components::ContainerKind;
use rerun::components::{Color, MediaType, Radius};
use rerun::external::re_sdk_types::blueprint::archetypes::VisualBounds2D;
use rerun::external::re_sdk_types::datatypes::Range2D;
use rerun::{AsComponents, EntityPath, RecordingStreamBuilder};

use super::blueprint::{self, Node};
use super::error::{error_chain, RecordingError};
use super::plot_data::{Plot2D, PlotGeometry, PlotLayer};

const PLOT: &str = "plot";
const NOTES: &str = "notes";
/// Where [`write_figures`] draws its plots: `figures/<i>`.
const FIGURES: &str = "figures";
/// Width of the drawn window, canvas units.
pub const CANVAS_WIDTH: f64 = 640.0;
/// Height / width of the window when a plot does not say.
const DEFAULT_ASPECT: f64 = 0.65;
/// Most tick intervals along an axis.
const MAX_INTERVALS: f64 = 8.0;
/// Tick length, and the gap between a tick and its label, canvas units.
const TICK: f64 = 6.0;
const GAP: f64 = 4.0;
/// Estimated width of a label character, and a label's height, canvas units (UI points).
const CHAR_WIDTH: f64 = 7.0;
const TEXT_HEIGHT: f64 = 16.0;
/// Room kept left of the window for the y tick labels, characters, however narrow they are.
const RESERVED_Y_LABEL_CHARS: usize = 7;
/// The viewer draws a point's label centred below it, its top this far down.
const LABEL_DROP: f64 = 5.0;
/// A curve's label sits this far along the curve's longest in-window piece.
const LABEL_AT: f64 = 0.85;
const FRAME: [u8; 3] = [190, 190, 190];
const GRID: [u8; 3] = [58, 58, 58];
const TEXT: [u8; 3] = [215, 215, 215];

/// A window in plot units: `[[x_low, y_low], [x_high, y_high]]`.
pub type Window = [[f64; 2]; 2];

pub(super) type Log<'a> = dyn Fn(EntityPath, &dyn AsComponents) -> Result<(), RecordingError> + 'a;

/// Writes `plot` to `path` (through `<path>.part`, renamed once complete).
pub fn write_plot(path: &Path, plot: &Plot2D) -> Result<(), RecordingError> {
    let layout = plot_layout(&plot.title, visual_bounds(plot));
    write_recording(path, (&plot.title, &plot.notes), layout, &[(PLOT, plot)])
}

/// Writes several plots into one recording at `path`, stacked in one column with `notes`
/// beside them (a Bode diagram: magnitude, phase, coherence), each in its own view framed by
/// its own axes.
pub fn write_figures(
    path: &Path,
    title: &str,
    notes: &str,
    figures: &[Plot2D],
) -> Result<(), RecordingError> {
    let roots: Vec<String> = (0..figures.len())
        .map(|i| format!("{FIGURES}/{i}"))
        .collect();
    let views = figures
        .iter()
        .zip(&roots)
        .map(|(plot, root)| figure_view(&plot.title, root, visual_bounds(plot)))
        .collect();
    let column = blueprint::container(ContainerKind::Vertical, "", views, vec![1.0; figures.len()]);
    let layout = blueprint::container(
        ContainerKind::Horizontal,
        "",
        vec![column, notes_view()],
        vec![3.0, 1.0],
    );
    let draws: Vec<(&str, &Plot2D)> = roots.iter().map(String::as_str).zip(figures).collect();
    write_recording(path, (title, notes), layout, &draws)
}

/// A static recording of `draws` (each plot under its root) with its notes and `layout`,
/// through `<path>.part`, renamed once complete.
fn write_recording(
    path: &Path,
    (title, notes): (&str, &str),
    layout: Node,
    draws: &[(&str, &Plot2D)],
) -> Result<(), RecordingError> {
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
    let app = rerun::ApplicationId::new_or_unknown(title.to_owned());
    let stream = RecordingStreamBuilder::new(app.clone())
        .recording_name(title)
        .enabled(true)
        .save(&partial)
        .map_err(|err| create_error(error_chain(&err)))?;
    blueprint::send(&stream, &app, layout, None).map_err(create_error)?;
    let log = |entity: EntityPath, archetype: &dyn AsComponents| {
        stream
            .log_static(entity, archetype)
            .map_err(|err| write_error(error_chain(&err)))
    };
    log(
        EntityPath::from(NOTES),
        &TextDocument::new(notes).with_media_type(MediaType::plain_text()),
    )?;
    for (root, plot) in draws {
        draw(&log, root, plot)?;
    }
    let flushed = stream.flush_blocking().map_err(|err| error_chain(&err));
    drop(stream);
    flushed.map_err(write_error)?;
    std::fs::rename(&partial, path).map_err(|err| write_error(err.to_string()))
}

/// Draws `plot` under `root` (static): its axes under `<root>/axes`, its layers under
/// `<root>/data`, in canvas units; [`visual_bounds`] frames it.
pub(super) fn draw(log: &Log<'_>, root: &str, plot: &Plot2D) -> Result<(), RecordingError> {
    let canvas = Canvas::new(plot);
    let axes = Axes::new(&canvas);
    write_axes(log, root, &canvas, &axes, plot)?;
    log(
        EntityPath::from(format!("{root}/data")),
        &canvas.transform(),
    )?;
    for layer in &plot.layers {
        write_layer(log, root, &canvas, layer)?;
    }
    Ok(())
}

/// The canvas area a 2D view shows for `plot`: the window, its tick labels and titles. It
/// depends on the x axis, the aspect and the y labels' width, which is taken as at least
/// [`RESERVED_Y_LABEL_CHARS`] characters, so that a frame whose y range is not known yet (a
/// spectrum's amplitudes, before the run) gets the bounds its drawing will fit.
pub(super) fn visual_bounds(plot: &Plot2D) -> Window {
    let canvas = Canvas::new(plot);
    Axes::new(&canvas).bounds(&canvas)
}

/// The plot window on the canvas: plot units ↔ canvas units (y down, origin top left).
#[derive(Debug, Clone, Copy)]
struct Canvas {
    window: Window,
    width: f64,
    height: f64,
}

impl Canvas {
    fn new(plot: &Plot2D) -> Self {
        let [x0, x1] = sane_range(plot.x.range);
        let [y0, y1] = sane_range(plot.y.range);
        let aspect = plot
            .aspect
            .filter(|a| a.is_finite() && *a > 0.0)
            .unwrap_or(DEFAULT_ASPECT)
            .clamp(0.2, 5.0);
        Self {
            window: [[x0, y0], [x1, y1]],
            width: CANVAS_WIDTH,
            height: CANVAS_WIDTH * aspect,
        }
    }

    /// Canvas units per plot unit, x and y.
    fn scale(&self) -> [f64; 2] {
        let [[x0, y0], [x1, y1]] = self.window;
        [self.width / (x1 - x0), self.height / (y1 - y0)]
    }

    fn on_canvas(&self, [x, y]: [f64; 2]) -> [f64; 2] {
        let [sx, sy] = self.scale();
        let [x0, y0] = self.window[0];
        [(x - x0) * sx, self.height - (y - y0) * sy]
    }

    fn in_plot(&self, [x, y]: [f64; 2]) -> [f64; 2] {
        let [sx, sy] = self.scale();
        let [x0, y0] = self.window[0];
        [x0 + x / sx, y0 + (self.height - y) / sy]
    }

    /// The transform of `/plot/data`: plot units to canvas units.
    fn transform(&self) -> Transform3D {
        let [sx, sy] = self.scale();
        let [x0, y0] = self.window[0];
        Transform3D::from_translation_scale(
            [(-x0 * sx) as f32, (self.height + y0 * sy) as f32, 0.0],
            [sx as f32, -sy as f32, 1.0],
        )
    }
}

/// `range` ordered, finite and of non-zero length.
fn sane_range([a, b]: [f64; 2]) -> [f64; 2] {
    if !(a.is_finite() && b.is_finite()) {
        return [0.0, 1.0];
    }
    let (low, high) = (a.min(b), a.max(b));
    if high - low > 1e-12 * low.abs().max(high.abs()) {
        [low, high]
    } else {
        let pad = 0.5 * low.abs().max(1.0);
        [low - pad, high + pad]
    }
}

/// The smallest of 1, 2, 5 × 10^k that splits `span` into at most `max_intervals` intervals.
pub fn nice_step(span: f64, max_intervals: f64) -> f64 {
    let raw = span.abs() / max_intervals.max(1.0);
    if !(raw.is_finite() && raw > 0.0) {
        return 1.0;
    }
    let magnitude = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * magnitude)
        .find(|step| *step >= raw * (1.0 - 1e-9))
        .unwrap_or(10.0 * magnitude)
}

/// The multiples of a nice step inside `[low, high]`, each with its label.
fn ticks([low, high]: [f64; 2], max_intervals: f64) -> Vec<(f64, String)> {
    let step = nice_step(high - low, max_intervals);
    let decimals = (-(step.log10() + 1e-9).floor()).max(0.0) as usize;
    let slack = 1e-9 * (high - low);
    let first = ((low - slack) / step).ceil() as i64;
    let last = ((high + slack) / step).floor() as i64;
    (first..=last)
        .map(|k| {
            let value = k as f64 * step;
            (value, format!("{:.*}", decimals, value + 0.0))
        })
        .collect()
}

/// Liang–Barsky: the part of the segment `a`–`b` inside `window`, if any.
fn clip_segment(a: [f64; 2], b: [f64; 2], window: &Window) -> Option<[[f64; 2]; 2]> {
    if !a.iter().chain(&b).all(|v| v.is_finite()) {
        return None;
    }
    let d = [b[0] - a[0], b[1] - a[1]];
    let (mut enter, mut leave) = (0.0_f64, 1.0_f64);
    for axis in 0..2 {
        let sides = [
            (-d[axis], a[axis] - window[0][axis]),
            (d[axis], window[1][axis] - a[axis]),
        ];
        for (p, q) in sides {
            if p == 0.0 {
                if q < 0.0 {
                    return None;
                }
            } else if p < 0.0 {
                enter = enter.max(q / p);
            } else {
                leave = leave.min(q / p);
            }
        }
    }
    if enter > leave {
        return None;
    }
    let at = |t: f64| [a[0] + t * d[0], a[1] + t * d[1]];
    Some([
        if enter > 0.0 { at(enter) } else { a },
        if leave < 1.0 { at(leave) } else { b },
    ])
}

/// The pieces of a polyline inside `window` (a line leaving and re-entering gives several).
fn clip_polyline(line: &[[f64; 2]], window: &Window) -> Vec<Vec<[f64; 2]>> {
    let mut pieces: Vec<Vec<[f64; 2]>> = Vec::new();
    let mut open = false;
    for segment in line.windows(2) {
        let clipped = clip_segment(segment[0], segment[1], window);
        match (clipped, pieces.last_mut()) {
            (Some([_, end]), Some(piece)) if open => piece.push(end),
            (Some([start, end]), _) => pieces.push(vec![start, end]),
            (None, _) => {}
        }
        // The piece goes on only when this segment ended inside, unclipped.
        open = matches!(clipped, Some([_, end]) if end == segment[1]);
    }
    pieces
}

fn contains(window: &Window, p: [f64; 2]) -> bool {
    (0..2).all(|axis| p[axis] >= window[0][axis] && p[axis] <= window[1][axis])
}

fn f32s([x, y]: [f64; 2]) -> [f32; 2] {
    [x as f32, y as f32]
}

fn text_width(text: &str) -> f64 {
    text.chars().count() as f64 * CHAR_WIDTH
}

/// Points drawn only as their labels (the viewer puts a label centred below its point).
fn text_points(
    at: impl IntoIterator<Item = [f64; 2]>,
    labels: impl IntoIterator<Item = String>,
    [r, g, b]: [u8; 3],
) -> Points2D {
    Points2D::new(at.into_iter().map(f32s))
        .with_labels(labels)
        .with_colors([Color::from_rgb(r, g, b)])
        .with_radii([Radius::new_ui_points(0.0)])
        .with_show_labels(true)
}

fn strips(
    lines: impl IntoIterator<Item = [[f64; 2]; 2]>,
    [r, g, b]: [u8; 3],
    width: f32,
) -> LineStrips2D {
    let lines: Vec<Vec<[f32; 2]>> = lines
        .into_iter()
        .map(|[a, b]| vec![f32s(a), f32s(b)])
        .collect();
    LineStrips2D::new(lines)
        .with_colors([Color::from_rgb(r, g, b)])
        .with_radii([Radius::new_ui_points(0.5 * width)])
}

/// The ticks of both axes.
struct Axes {
    x: Vec<(f64, String)>,
    y: Vec<(f64, String)>,
}

impl Axes {
    fn new(canvas: &Canvas) -> Self {
        let [[x0, y0], [x1, y1]] = canvas.window;
        // As many as along x, while the labels stay 2.5 rows apart.
        let y_intervals = (canvas.height / (2.5 * TEXT_HEIGHT))
            .floor()
            .clamp(3.0, MAX_INTERVALS);
        Self {
            x: ticks([x0, x1], MAX_INTERVALS),
            y: ticks([y0, y1], y_intervals),
        }
    }

    /// Room left of the frame for the ticks and their labels, canvas units.
    fn y_label_room(&self) -> f64 {
        let widest = self
            .y
            .iter()
            .map(|(_, l)| text_width(l))
            .fold(RESERVED_Y_LABEL_CHARS as f64 * CHAR_WIDTH, f64::max);
        TICK + GAP + widest
    }

    /// Top of the x axis's tick labels and of its title, canvas units below the frame.
    fn x_label_rows() -> [f64; 2] {
        [TICK + GAP, TICK + 3.0 * GAP + TEXT_HEIGHT]
    }

    /// The view's visual bounds: the window and the labels around it, `[[left, top], [right,
    /// bottom]]` in canvas units.
    fn bounds(&self, canvas: &Canvas) -> Window {
        let last = self.x.last().map_or(0.0, |(_, l)| 0.5 * text_width(l));
        let bottom = Self::x_label_rows()[1] + TEXT_HEIGHT;
        [
            [-self.y_label_room() - 3.0 * GAP, -TEXT_HEIGHT - 5.0 * GAP],
            [
                canvas.width + last.max(GAP) + 3.0 * GAP,
                canvas.height + bottom + 3.0 * GAP,
            ],
        ]
    }
}

/// Grid, ticks, frame, tick labels and axis titles under `/plot/axes`, in canvas units.
fn write_axes(
    log: &Log<'_>,
    root: &str,
    canvas: &Canvas,
    axes: &Axes,
    plot: &Plot2D,
) -> Result<(), RecordingError> {
    let entity = |name: &str| EntityPath::from(format!("{root}/axes/{name}"));
    let (w, h) = (canvas.width, canvas.height);
    let xs: Vec<f64> = axes
        .x
        .iter()
        .map(|(v, _)| canvas.on_canvas([*v, 0.0])[0])
        .collect();
    let ys: Vec<f64> = axes
        .y
        .iter()
        .map(|(v, _)| canvas.on_canvas([0.0, *v])[1])
        .collect();
    let grid = xs.iter().map(|&x| [[x, 0.0], [x, h]]);
    let grid = grid.chain(ys.iter().map(|&y| [[0.0, y], [w, y]]));
    log(
        entity("grid"),
        &strips(grid, GRID, 1.0).with_draw_order(1.0),
    )?;
    let marks = xs.iter().map(|&x| [[x, h], [x, h + TICK]]);
    let marks = marks.chain(ys.iter().map(|&y| [[0.0, y], [-TICK, y]]));
    log(entity("ticks"), &strips(marks, FRAME, 1.0))?;
    let corners = [[0.0, 0.0], [w, 0.0], [w, h], [0.0, h], [0.0, 0.0]];
    let frame = corners.windows(2).map(|c| [c[0], c[1]]);
    log(
        entity("frame"),
        &strips(frame, FRAME, 1.5).with_draw_order(25.0),
    )?;
    let [label_row, title_row] = Axes::x_label_rows().map(|row| h + row - LABEL_DROP);
    let x_labels = axes.x.iter().map(|(_, l)| l.clone());
    log(
        entity("x_labels"),
        &text_points(xs.iter().map(|&x| [x, label_row]), x_labels, TEXT),
    )?;
    let y_at = |(y, label): (&f64, &String)| {
        let x = -TICK - GAP - 0.5 * text_width(label);
        [x, y - 0.5 * TEXT_HEIGHT - LABEL_DROP]
    };
    let y_labels = axes.y.iter().map(|(_, l)| l.clone());
    let y_spots = ys.iter().zip(axes.y.iter().map(|(_, l)| l)).map(y_at);
    log(entity("y_labels"), &text_points(y_spots, y_labels, TEXT))?;
    let y_title = [
        -axes.y_label_room() + 0.5 * text_width(&plot.y.title),
        -2.0 * GAP - TEXT_HEIGHT - LABEL_DROP,
    ];
    let titles = [
        ([0.5 * w, title_row], &plot.x.title),
        (y_title, &plot.y.title),
    ];
    let titles = titles.into_iter().filter(|(_, t)| !t.is_empty());
    let (spots, texts): (Vec<[f64; 2]>, Vec<String>) =
        titles.map(|(at, t)| (at, t.clone())).unzip();
    log(entity("titles"), &text_points(spots, texts, TEXT))
}

/// One layer under `/plot/data`, clipped to the window, with its curve labels.
fn write_layer(
    log: &Log<'_>,
    root: &str,
    canvas: &Canvas,
    layer: &PlotLayer,
) -> Result<(), RecordingError> {
    let name = format!("{root}/data/{}", layer.name.trim_matches('/'));
    let [r, g, b] = layer.color;
    let color = Color::from_rgb(r, g, b);
    let radius = Radius::new_ui_points(0.5 * layer.size);
    match &layer.geometry {
        PlotGeometry::Lines(lines) => {
            let clipped: Vec<Vec<Vec<[f64; 2]>>> = lines
                .iter()
                .map(|line| clip_polyline(line, &canvas.window))
                .collect();
            let pieces = clipped.iter().flatten();
            let strips: Vec<Vec<[f32; 2]>> = pieces
                .map(|piece| piece.iter().copied().map(f32s).collect())
                .collect();
            log(
                EntityPath::from(name.as_str()),
                &LineStrips2D::new(strips)
                    .with_colors([color])
                    .with_radii([radius]),
            )?;
            let labels = curve_labels(canvas, &clipped, &layer.labels);
            if labels.is_empty() {
                return Ok(());
            }
            let (spots, texts): (Vec<[f64; 2]>, Vec<String>) = labels.into_iter().unzip();
            log(
                EntityPath::from(format!("{name}/label")),
                &text_points(spots, texts, layer.color),
            )
        }
        PlotGeometry::Points(points) => {
            let inside = |p: &[f64; 2]| contains(&canvas.window, *p);
            let kept = points.iter().filter(|p| inside(p)).copied().map(f32s);
            let labels: Vec<&str> = if layer.labels.len() == points.len() {
                let pairs = points.iter().zip(&layer.labels);
                pairs
                    .filter(|(p, _)| inside(p))
                    .map(|(_, l)| l.as_str())
                    .collect()
            } else {
                layer.labels.iter().map(String::as_str).collect()
            };
            log(
                EntityPath::from(name),
                &Points2D::new(kept)
                    .with_colors([color])
                    .with_radii([radius])
                    .with_labels(labels),
            )
        }
    }
}

/// Each curve label with its point (plot units): the text just above the curve, near the end
/// of the longest in-window piece of its polyline (of all, for a layer's single label), inside
/// the window.
fn curve_labels(
    canvas: &Canvas,
    clipped: &[Vec<Vec<[f64; 2]>>],
    labels: &[String],
) -> Vec<([f64; 2], String)> {
    let groups: Vec<(Vec<&Vec<[f64; 2]>>, &String)> = match labels {
        [one] => vec![(clipped.iter().flatten().collect(), one)],
        _ => clipped
            .iter()
            .zip(labels)
            .map(|(pieces, label)| (pieces.iter().collect(), label))
            .collect(),
    };
    let drawn = |piece: &Vec<[f64; 2]>| -> Vec<[f64; 2]> {
        piece.iter().map(|p| canvas.on_canvas(*p)).collect()
    };
    groups
        .into_iter()
        .filter(|(_, label)| !label.is_empty())
        .filter_map(|(pieces, label)| {
            let longest = pieces
                .into_iter()
                .map(drawn)
                .max_by(|a, b| length(a).total_cmp(&length(b)))?;
            let anchor = along(&longest, LABEL_AT)?;
            let spot = label_spot(canvas, anchor, label);
            Some((canvas.in_plot(spot), label.clone()))
        })
        .collect()
}

fn distance(a: [f64; 2], b: [f64; 2]) -> f64 {
    (b[0] - a[0]).hypot(b[1] - a[1])
}

fn length(points: &[[f64; 2]]) -> f64 {
    points.windows(2).map(|s| distance(s[0], s[1])).sum()
}

/// The point `fraction` of the way along a polyline (by length).
fn along(points: &[[f64; 2]], fraction: f64) -> Option<[f64; 2]> {
    let mut left = fraction * length(points);
    for s in points.windows(2) {
        let d = distance(s[0], s[1]);
        if d > 0.0 && d >= left {
            let t = left / d;
            return Some([
                s[0][0] + t * (s[1][0] - s[0][0]),
                s[0][1] + t * (s[1][1] - s[0][1]),
            ]);
        }
        left -= d;
    }
    points.last().copied()
}

/// Where a label's point goes (canvas units) for its text to sit just above `anchor`, inside
/// the window.
fn label_spot(canvas: &Canvas, [x, y]: [f64; 2], label: &str) -> [f64; 2] {
    let half = 0.5 * text_width(label) + GAP;
    let x = if canvas.width > 2.0 * half {
        x.clamp(half, canvas.width - half)
    } else {
        0.5 * canvas.width
    };
    let rise = LABEL_DROP + TEXT_HEIGHT + GAP;
    let y = (y - rise).clamp(GAP - LABEL_DROP, (canvas.height - rise).max(GAP));
    [x, y]
}

/// The layout: the plot (its visual bounds `bounds`, canvas units) beside the notes.
fn plot_layout(title: &str, bounds: Window) -> Node {
    blueprint::container(
        ContainerKind::Horizontal,
        "",
        vec![figure_view(title, PLOT, bounds), notes_view()],
        vec![3.0, 1.0],
    )
}

/// A 2D view of the plot drawn under `root`, framed to `bounds`.
fn figure_view(title: &str, root: &str, [[left, top], [right, bottom]]: Window) -> Node {
    let bounds = Range2D {
        x_range: [left, right].into(),
        y_range: [top, bottom].into(),
    };
    blueprint::view(
        "2D",
        title,
        "/",
        vec![format!("+ /{root}/**")],
        vec![("VisualBounds2D", Box::new(VisualBounds2D::new(bounds)))],
    )
}

fn notes_view() -> Node {
    blueprint::view(
        "TextDocument",
        "notes",
        &format!("/{NOTES}"),
        vec![],
        vec![],
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recording::plot_data::PlotAxis;

    const UNIT: Window = [[0.0, 0.0], [1.0, 1.0]];

    fn close(a: [f64; 2], b: [f64; 2]) -> bool {
        distance(a, b) < 1e-12
    }

    #[test]
    fn a_segment_crossing_the_window_is_cut_at_the_frame() {
        let [a, b] = clip_segment([-1.0, 0.5], [2.0, 0.5], &UNIT).unwrap();
        assert!(close(a, [0.0, 0.5]) && close(b, [1.0, 0.5]));
        // Diagonal, entering through the left side and leaving through the top.
        let [a, b] = clip_segment([-0.5, 0.0], [1.0, 1.5], &UNIT).unwrap();
        assert!(close(a, [0.0, 0.5]) && close(b, [0.5, 1.0]), "{a:?} {b:?}");
        // Inside: unchanged; outside (even when its line crosses the window): nothing.
        assert_eq!(
            clip_segment([0.2, 0.3], [0.4, 0.9], &UNIT),
            Some([[0.2, 0.3], [0.4, 0.9]])
        );
        assert_eq!(clip_segment([1.5, 0.0], [2.0, 1.0], &UNIT), None);
        assert_eq!(clip_segment([-1.0, 0.5], [0.5, 2.5], &UNIT), None);
        assert_eq!(clip_segment([f64::NAN, 0.5], [0.5, 0.5], &UNIT), None);
    }

    #[test]
    fn a_polyline_leaving_and_reentering_splits_into_pieces() {
        let line = [[0.5, 0.5], [0.5, 1.5], [0.8, 1.5], [0.8, 0.5], [0.9, 0.5]];
        let pieces = clip_polyline(&line, &UNIT);
        assert_eq!(pieces.len(), 2);
        assert!(close(pieces[0][0], [0.5, 0.5]) && close(pieces[0][1], [0.5, 1.0]));
        assert_eq!(pieces[1].len(), 3);
        assert!(close(pieces[1][0], [0.8, 1.0]) && close(pieces[1][2], [0.9, 0.5]));
        assert!(clip_polyline(&[[2.0, 2.0], [3.0, 3.0]], &UNIT).is_empty());
    }

    #[test]
    fn ticks_fall_on_nice_steps() {
        assert!((nice_step(0.37, 8.0) - 0.05).abs() < 1e-15);
        assert_eq!(nice_step(15000.0, 8.0), 2000.0);
        assert_eq!(nice_step(15000.0, 5.0), 5000.0);
        assert_eq!(nice_step(5000.0, 8.0), 1000.0);
        assert_eq!(nice_step(1.0, 5.0), 0.2);
        let labels = |range, intervals| -> Vec<String> {
            ticks(range, intervals)
                .into_iter()
                .map(|(_, l)| l)
                .collect()
        };
        assert_eq!(
            labels([0.0, 0.37], 8.0),
            ["0.00", "0.05", "0.10", "0.15", "0.20", "0.25", "0.30", "0.35"]
        );
        assert_eq!(
            labels([10000.0, 25000.0], 8.0),
            ["10000", "12000", "14000", "16000", "18000", "20000", "22000", "24000"]
        );
        assert_eq!(
            labels([-1.0, 1.0], 4.0),
            ["-1.0", "-0.5", "0.0", "0.5", "1.0"]
        );
    }

    #[test]
    fn a_curve_label_stays_inside_the_window() {
        let plot = Plot2D {
            x: PlotAxis {
                title: "x [m]".into(),
                range: [0.0, 10.0],
            },
            y: PlotAxis {
                title: "y [m]".into(),
                range: [0.0, 1.0],
            },
            ..Plot2D::default()
        };
        let canvas = Canvas::new(&plot);
        // Runs out through the bottom right corner; the label is drawn above its end inside.
        let clipped = vec![clip_polyline(&[[0.0, 1.0], [20.0, -1.0]], &canvas.window)];
        let labels = curve_labels(&canvas, &clipped, &["a long label for a curve".into()]);
        assert_eq!(labels.len(), 1);
        let spot = canvas.on_canvas(labels[0].0);
        let half = 0.5 * text_width(&labels[0].1);
        assert!(
            spot[0] - half >= 0.0 && spot[0] + half <= canvas.width,
            "{spot:?}"
        );
        let text = [spot[1] + LABEL_DROP, spot[1] + LABEL_DROP + TEXT_HEIGHT];
        assert!(text[0] >= 0.0 && text[1] <= canvas.height, "{spot:?}");
        assert!(distance(canvas.in_plot(canvas.on_canvas([3.0, 0.25])), [3.0, 0.25]) < 1e-12);
    }

    #[test]
    fn a_plot_is_written_whole_and_a_bad_folder_is_an_error() {
        let dir = std::env::temp_dir().join(format!("twin-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("plot.rrd");
        let plot = Plot2D {
            title: "test plot".into(),
            notes: "two layers".into(),
            x: PlotAxis {
                title: "speed [rpm]".into(),
                range: [0.0, 2.0],
            },
            y: PlotAxis {
                title: "depth [mm]".into(),
                range: [0.0, 1.0],
            },
            aspect: None,
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
                    geometry: PlotGeometry::Points(vec![[0.5, 0.5], [1.5, 0.5], [3.0, 0.5]]),
                    labels: vec!["in".into(), "in".into(), "out".into()],
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
