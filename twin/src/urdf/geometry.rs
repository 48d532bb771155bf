//! A URDF `<geometry>` turned by its `<origin>`'s rpy into an outline on the plane.
//!
//! The plane is the link frame's xy plane, seen from +z. A shape whose roll and pitch are zero is
//! read as before: a box is its x–y rectangle, a cylinder (axis along z) and a sphere are discs,
//! all turned by the yaw. A roll or pitch may stand a shape up, as long as its axes stay along z
//! or in the plane (within [`ALIGNMENT_TOLERANCE`]): a cylinder lying in the plane (a wheel seen
//! from above, a spindle seen from the side) is the rectangle of its length and diameter, a box
//! turned on its side the rectangle of the two sizes left in the plane. A mesh is its outline on
//! the plane: the convex hull of its vertices, scaled and turned by the full rpy, then projected.
//! Mesh files are STL (binary or ASCII) or OBJ, named by a path relative to the URDF's folder, an
//! absolute path, `file://…` or `package://<package>/<path>` (the package is the first folder of
//! that name at or above the URDF's folder, or a folder of that name beside one of them).

use crate::files::mesh_vertices;
use crate::mechanism::{convex_hull, polygon_area, Outline};
use std::path::{Path, PathBuf};

/// How far a shape's axis may be from the plane or from its normal (the sine of the angle): a
/// quarter turn written `1.5708` (3.7e-6 off) or `1.57` (8e-4 off) lays a cylinder down.
const ALIGNMENT_TOLERANCE: f64 = 1e-3;
/// The least area of a mesh's outline, m²: below, it is a line, not a shape.
const MIN_OUTLINE_AREA: f64 = 1e-12;

/// The outline of `geometry` turned by `rpy` and the angle of its frame in the link's plane; a
/// roll and pitch within `planar` of zero keep the shape flat (its angle is the yaw).
pub(super) fn outline(
    geometry: &urdf_rs::Geometry,
    rpy: [f64; 3],
    planar: f64,
    folder: Option<&Path>,
) -> Result<(Outline, f64), String> {
    let flat = rpy[0].abs() <= planar && rpy[1].abs() <= planar;
    let axes = Axes::of(rpy);
    match geometry {
        urdf_rs::Geometry::Box { size } => {
            let [x, y, z] = size.0;
            let sizes = [
                positive("box size x", x)?,
                positive("box size y", y)?,
                positive("box size z", z)?,
            ];
            if flat {
                return Ok((rectangle(sizes[0], sizes[1]), rpy[2]));
            }
            turned_box(&axes, sizes, rpy)
        }
        urdf_rs::Geometry::Cylinder { radius, length } => {
            let radius = positive("radius", *radius)?;
            let length = positive("length", *length)?;
            if flat {
                return Ok((Outline::Circle { radius }, rpy[2]));
            }
            match axes.kind(2) {
                Some(Lies::Upright) => Ok((Outline::Circle { radius }, axes.heading(0))),
                Some(Lies::InPlane) => Ok((rectangle(length, 2.0 * radius), axes.heading(2))),
                None => Err(format!(
                    "not planar: the cylinder's axis is neither along z nor in the plane (rpy {} {} {})",
                    rpy[0], rpy[1], rpy[2]
                )),
            }
        }
        urdf_rs::Geometry::Sphere { radius } => {
            let radius = positive("radius", *radius)?;
            let angle = if flat { rpy[2] } else { axes.heading(0) };
            Ok((Outline::Circle { radius }, angle))
        }
        urdf_rs::Geometry::Mesh { filename, scale } => {
            let scale = scale.as_ref().map_or([1.0; 3], |s| s.0);
            if !scale.iter().all(|s| s.is_finite() && *s != 0.0) {
                return Err(format!(
                    "mesh \"{filename}\": scale must be three finite non-zero numbers, got {scale:?}"
                ));
            }
            let points = mesh_outline(filename, scale, &axes, folder)
                .map_err(|reason| format!("mesh \"{filename}\": {reason}"))?;
            Ok((Outline::Polygon { points }, 0.0))
        }
        urdf_rs::Geometry::Capsule { .. } => {
            Err("unsupported geometry capsule (box, cylinder, sphere and mesh are)".into())
        }
    }
}

fn positive(name: &str, value: f64) -> Result<f64, String> {
    if value > 0.0 && value.is_finite() {
        Ok(value)
    } else {
        Err(format!("{name} must be > 0, got {value}"))
    }
}

fn rectangle(width: f64, height: f64) -> Outline {
    Outline::Rectangle { width, height }
}

/// A box turned by a roll or pitch: one of its axes must stand along z, the two others then lie
/// in the plane, the first of them giving the rectangle's width and angle.
fn turned_box(axes: &Axes, sizes: [f64; 3], rpy: [f64; 3]) -> Result<(Outline, f64), String> {
    let kinds = [axes.kind(0), axes.kind(1), axes.kind(2)];
    let upright = kinds.iter().filter(|k| **k == Some(Lies::Upright)).count();
    let in_plane: Vec<usize> = (0..3)
        .filter(|&k| kinds[k] == Some(Lies::InPlane))
        .collect();
    match (upright, in_plane.as_slice()) {
        (1, &[a, b]) => Ok((rectangle(sizes[a], sizes[b]), axes.heading(a))),
        _ => Err(format!(
            "not planar: the box is tilted out of the plane (rpy {} {} {}); its axes must lie along z or in the plane",
            rpy[0], rpy[1], rpy[2]
        )),
    }
}

/// The convex hull of the mesh's vertices on the plane, in the shape's frame turned by `axes`.
fn mesh_outline(
    filename: &str,
    scale: [f64; 3],
    axes: &Axes,
    folder: Option<&Path>,
) -> Result<Vec<[f64; 2]>, String> {
    let path = resolve(filename, folder)?;
    let vertices =
        mesh_vertices(&path).map_err(|reason| format!("{}: {reason}", path.display()))?;
    let projected: Vec<[f64; 2]> = vertices
        .iter()
        .map(|v| axes.project([v[0] * scale[0], v[1] * scale[1], v[2] * scale[2]]))
        .collect();
    let hull = convex_hull(&projected);
    if hull.len() < 3 || polygon_area(&hull) < MIN_OUTLINE_AREA {
        return Err(format!(
            "{}: its outline on the plane has no area (every vertex projects onto a line or a point)",
            path.display()
        ));
    }
    Ok(hull)
}

/// Where a mesh's `filename` is: `package://`, `file://`, absolute, or relative to the URDF's
/// folder (the working folder for URDF text that is not a file).
fn resolve(filename: &str, folder: Option<&Path>) -> Result<PathBuf, String> {
    let folder = folder.unwrap_or(Path::new("."));
    if let Some(rest) = filename.strip_prefix("package://") {
        let (package, inside) = rest.split_once('/').unwrap_or((rest, ""));
        if package.is_empty() || inside.is_empty() {
            return Err("a package:// path names a package and a file in it".into());
        }
        let absolute = std::path::absolute(folder).unwrap_or_else(|_| folder.to_path_buf());
        return absolute
            .ancestors()
            .flat_map(|dir| {
                let own = dir.file_name().is_some_and(|n| n == package);
                [
                    own.then(|| dir.join(inside)),
                    Some(dir.join(package).join(inside)),
                ]
            })
            .flatten()
            .find(|candidate| candidate.is_file())
            .ok_or_else(|| {
                format!(
                    "package `{package}` with `{inside}` not found at or above {}",
                    folder.display()
                )
            });
    }
    let path = Path::new(filename.strip_prefix("file://").unwrap_or(filename));
    Ok(folder.join(path))
}

/// How a shape's axis lies in the link frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Lies {
    /// Along ±z: seen from above, it is a point.
    Upright,
    /// In the xy plane.
    InPlane,
}

/// The images of a shape's x, y and z axes in the link frame under URDF's fixed-axis rpy
/// (R = Rz(yaw)·Ry(pitch)·Rx(roll)): `columns[k]` is axis k.
struct Axes {
    columns: [[f64; 3]; 3],
}

impl Axes {
    fn of([roll, pitch, yaw]: [f64; 3]) -> Self {
        let (sr, cr) = roll.sin_cos();
        let (sp, cp) = pitch.sin_cos();
        let (sy, cy) = yaw.sin_cos();
        Self {
            columns: [
                [cy * cp, sy * cp, -sp],
                [cy * sp * sr - sy * cr, sy * sp * sr + cy * cr, cp * sr],
                [cy * sp * cr + sy * sr, sy * sp * cr - cy * sr, cp * cr],
            ],
        }
    }

    fn kind(&self, axis: usize) -> Option<Lies> {
        let z = self.columns[axis][2].abs();
        if z >= 1.0 - ALIGNMENT_TOLERANCE {
            Some(Lies::Upright)
        } else if z <= ALIGNMENT_TOLERANCE {
            Some(Lies::InPlane)
        } else {
            None
        }
    }

    /// The angle of an axis's direction in the plane (0 for an upright one).
    fn heading(&self, axis: usize) -> f64 {
        let [x, y, _] = self.columns[axis];
        y.atan2(x)
    }

    /// A point of the shape's frame turned into the link frame and seen from above.
    fn project(&self, p: [f64; 3]) -> [f64; 2] {
        let c = &self.columns;
        [
            c[0][0] * p[0] + c[1][0] * p[1] + c[2][0] * p[2],
            c[0][1] * p[0] + c[1][1] * p[1] + c[2][1] * p[2],
        ]
    }
}
