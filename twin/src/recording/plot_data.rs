//! A static 2D plot as plain data in plot units: its axes, its layers of lines or points, its
//! notes. [`super::plots`] draws it; a recording's layout carries its figures as these.

/// What a layer draws, in plot coordinates.
#[derive(Debug, Clone, PartialEq)]
pub enum PlotGeometry {
    /// Open polylines.
    Lines(Vec<Vec<[f64; 2]>>),
    /// Separate points [x, y].
    Points(Vec<[f64; 2]>),
}

/// One named, coloured set of lines or points.
#[derive(Debug, Clone, PartialEq)]
pub struct PlotLayer {
    /// Entity name under `/plot/data` (may contain `/` for nesting).
    pub name: String,
    /// RGB, 0–255.
    pub color: [u8; 3],
    /// Line width or point diameter, UI points.
    pub size: f32,
    /// The lines or points it draws, plot units.
    pub geometry: PlotGeometry,
    /// Points: one label per point (drawn below it), or one for the layer, or none.
    /// Lines: one label per polyline, or one for the layer (empty: none), drawn on the plot, in
    /// the layer's colour, above the curve near the end of its longest piece inside the window.
    pub labels: Vec<String>,
}

impl PlotLayer {
    /// A layer from its parts (see the fields).
    pub fn new(
        name: &str,
        color: [u8; 3],
        size: f32,
        geometry: PlotGeometry,
        labels: Vec<String>,
    ) -> Self {
        Self {
            name: name.into(),
            color,
            size,
            geometry,
            labels,
        }
    }
}

/// One axis of a plot: its title and the window along it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PlotAxis {
    /// Title with the unit, e.g. `spindle speed [rpm]`.
    pub title: String,
    /// The window along this axis, plot units (low, high); layers are clipped to it.
    pub range: [f64; 2],
}

/// A 2D plot as plain data.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Plot2D {
    /// Application id / recording name.
    pub title: String,
    /// Free text shown beside the plot (what is drawn, units, key figures).
    pub notes: String,
    /// The horizontal axis.
    pub x: PlotAxis,
    /// The vertical axis.
    pub y: PlotAxis,
    /// Height / width of the drawn window (None: 0.65).
    pub aspect: Option<f64>,
    /// What is drawn, in the order drawn (later layers on top).
    pub layers: Vec<PlotLayer>,
}
