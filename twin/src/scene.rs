//! What a machine's mechanism view shows besides its links: a fixed frame (so the view does not
//! re-frame itself as the machine moves), what is being machined, and points the run places or
//! traces (a tool tip, a planned and an estimated path). Plain data in machine coordinates (m,
//! y up); only `recording` turns it into Rerun archetypes.

/// A rectangle of the machine's plane, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    pub x: [f64; 2],
    pub y: [f64; 2],
}

impl Bounds {
    /// The smallest rectangle around `points`, grown by `margin` (a fraction of its larger side)
    /// on every side; `None` without a finite point.
    pub fn around(points: impl IntoIterator<Item = [f64; 2]>, margin: f64) -> Option<Bounds> {
        let mut bounds: Option<Bounds> = None;
        for [x, y] in points {
            if !(x.is_finite() && y.is_finite()) {
                continue;
            }
            let b = bounds.get_or_insert(Bounds {
                x: [x, x],
                y: [y, y],
            });
            b.x = [b.x[0].min(x), b.x[1].max(x)];
            b.y = [b.y[0].min(y), b.y[1].max(y)];
        }
        bounds.map(|b| {
            let pad = margin * b.width().max(b.height()).max(1e-9);
            Bounds {
                x: [b.x[0] - pad, b.x[1] + pad],
                y: [b.y[0] - pad, b.y[1] + pad],
            }
        })
    }

    /// The smallest rectangle holding both.
    pub fn union(&self, other: &Bounds) -> Bounds {
        Bounds {
            x: [self.x[0].min(other.x[0]), self.x[1].max(other.x[1])],
            y: [self.y[0].min(other.y[0]), self.y[1].max(other.y[1])],
        }
    }

    pub fn width(&self) -> f64 {
        self.x[1] - self.x[0]
    }

    pub fn height(&self) -> f64 {
        self.y[1] - self.y[0]
    }
}

/// Static lines in machine coordinates: a workpiece, a contour, a planned path.
#[derive(Debug, Clone, PartialEq)]
pub struct Drawing {
    /// Entity name under the mechanism (e.g. `workpiece`).
    pub name: String,
    pub color: [u8; 3],
    /// Open polylines; close one by repeating its first point.
    pub lines: Vec<Vec<[f64; 2]>>,
    /// Shown beside the drawing.
    pub label: String,
}

/// Where a marker is, every recorded sample: at `origin + scale·(x, y)`, where `x` and `y` are
/// recorded signals (SI, by name: the plant's, the machine's diagnostics or the controller's
/// internals) or 0 when absent. A scale above 1 magnifies a motion too small to see.
#[derive(Debug, Clone, PartialEq)]
pub struct MarkerSource {
    pub x: Option<String>,
    pub y: Option<String>,
    pub scale: f64,
    pub origin: [f64; 2],
}

impl MarkerSource {
    /// A point at the recorded signals (x, y), unscaled.
    pub fn at(x: &str, y: &str) -> Self {
        MarkerSource {
            x: Some(x.into()),
            y: Some(y.into()),
            scale: 1.0,
            origin: [0.0, 0.0],
        }
    }
}

/// A point that moves with the run, drawn at its current position and, when `trace` is set,
/// with the path it has covered so far.
#[derive(Debug, Clone, PartialEq)]
pub struct Marker {
    pub name: String,
    pub color: [u8; 3],
    pub label: String,
    pub source: MarkerSource,
    pub trace: bool,
}

/// The mechanism view of a machine.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// The view's title: what it shows (and any magnification).
    pub title: String,
    /// The fixed frame of the view, margins included; the twin widens it to hold the links at
    /// their URDF pose and the drawings.
    pub bounds: Bounds,
    /// Static lines drawn with the links: what is being machined, contours, planned paths.
    pub drawings: Vec<Drawing>,
    /// Points that move with the run, each at recorded signals.
    pub markers: Vec<Marker>,
}

/// Colours of scene elements by role, fixed across machines.
pub mod colors {
    /// What is being machined (stock, part, workpiece).
    pub const WORKPIECE: [u8; 3] = [190, 190, 190];
    /// The target: a contour, a planned path, a reference.
    pub const TARGET: [u8; 3] = [240, 228, 66];
    /// The tool and its trace.
    pub const TOOL: [u8; 3] = [213, 94, 0];
    /// An estimate (odometry).
    pub const ESTIMATE: [u8; 3] = [0, 158, 115];
    /// The true position of a tracked point.
    pub const TRUE: [u8; 3] = [86, 180, 233];
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_cover_the_points_with_margins_and_skip_non_finite_ones() {
        let b = Bounds::around([[0.0, 0.0], [2.0, 1.0], [f64::NAN, 9.0]], 0.1).unwrap();
        assert_eq!(b.x, [-0.2, 2.2]);
        assert_eq!(b.y, [-0.2, 1.2]);
        assert!(Bounds::around([[f64::INFINITY, 0.0]], 0.1).is_none());
    }
}
