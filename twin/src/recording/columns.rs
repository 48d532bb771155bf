//! The sampled columns a recording sends: link poses, marker positions and the two timelines, built
//! as Arrow arrays straight from the buffers.

use std::sync::Arc;

use rerun::archetypes::{Points2D, Transform3D};
use rerun::components::{Position2D, RotationAxisAngle, Translation3D};
use rerun::external::arrow::array::{ArrayRef, FixedSizeListArray, Float32Array, StructArray};
use rerun::external::arrow::datatypes::DataType;
use rerun::{
    EntityPath, Loggable, RecordingStream, SerializedComponentBatch, SerializedComponentColumn,
    TimeColumn,
};

use super::entities::{MAX_TRACE_POINTS, SIM_TIME, STEP};
use super::error::error_chain;
use super::ids::RunIds;
use framework::Unit;

/// A link's buffered world poses.
pub(super) struct LinkPoses {
    pub(super) entity: EntityPath,
    /// x, y, 0 per buffered sample.
    pub(super) translations: Vec<f32>,
    /// Rotation about z, wrapped to (-π, π], per buffered sample.
    pub(super) angles: Vec<f32>,
    /// Whether every buffered pose is finite (otherwise the non-finite ones are left out).
    pub(super) all_finite: bool,
}

/// A plot's buffered samples, in its display unit.
pub(super) struct Group {
    pub(super) entity: EntityPath,
    pub(super) unit: Unit,
    /// Index of each series' value in the pushed values.
    pub(super) indices: Vec<usize>,
    /// Row-major: one value per series and buffered sample.
    pub(super) values: Vec<f64>,
}

/// A scene marker's buffered positions and the trace it has drawn so far.
pub(super) struct MarkerBuffer {
    pub(super) entity: EntityPath,
    /// x, y per buffered sample (NaN when unknown; left out when sent).
    pub(super) positions: Vec<f32>,
    /// The trace's entity, when the marker leaves one.
    pub(super) trace: Option<EntityPath>,
    /// Every `stride`-th position of the run so far.
    pub(super) trace_points: Vec<[f32; 2]>,
    pub(super) stride: usize,
}

impl MarkerBuffer {
    /// Adds the `sample`-th position to the buffer and, every `stride` samples, to the trace;
    /// past [`MAX_TRACE_POINTS`] the trace keeps every other point and the stride doubles.
    pub(super) fn add(&mut self, sample: usize, [x, y]: [f64; 2]) {
        let point = [x as f32, y as f32];
        self.positions.extend_from_slice(&point);
        if self.trace.is_none()
            || !sample.is_multiple_of(self.stride)
            || !point.iter().all(|v| v.is_finite())
        {
            return;
        }
        self.trace_points.push(point);
        if self.trace_points.len() > MAX_TRACE_POINTS {
            let kept = self.trace_points.iter().copied().step_by(2).collect();
            self.trace_points = kept;
            self.stride *= 2;
        }
    }
}

/// Sends a marker's buffered positions as a `Points2D` position column, leaving out the
/// non-finite ones.
pub(super) fn send_marker(
    stream: &RecordingStream,
    ids: &mut RunIds,
    marker: &MarkerBuffer,
    steps: &[i64],
    times: &[f64],
) -> Result<(), String> {
    let kept: Vec<usize> = (0..steps.len())
        .filter(|&i| {
            marker.positions[2 * i..2 * i + 2]
                .iter()
                .all(|v| v.is_finite())
        })
        .collect();
    if kept.is_empty() {
        return Ok(());
    }
    let steps: Vec<i64> = kept.iter().map(|&i| steps[i]).collect();
    let times: Vec<f64> = kept.iter().map(|&i| times[i]).collect();
    let xy: Vec<f32> = kept
        .iter()
        .flat_map(|&i| marker.positions[2 * i..2 * i + 2].iter().copied())
        .collect();
    let column = position_column(xy).map_err(|e| error_chain(&*e))?;
    ids.send_columns(
        stream,
        marker.entity.clone(),
        timeline_columns(&steps, &times),
        [column],
    )
}

/// A `Points2D` positions column of one point per row from x, y pairs.
pub(super) fn position_column(xy: Vec<f32>) -> Result<SerializedComponentColumn, BoxedError> {
    let rows = xy.len() / 2;
    let DataType::FixedSizeList(item, 2) = Position2D::arrow_datatype() else {
        return Err("unexpected Position2D datatype".into());
    };
    let array: ArrayRef = Arc::new(FixedSizeListArray::try_new(
        item,
        2,
        Arc::new(Float32Array::from(xy)),
        None,
    )?);
    Ok(
        SerializedComponentBatch::new(array, Points2D::descriptor_positions())
            .partitioned(std::iter::repeat_n(1, rows))?,
    )
}

pub(super) fn timeline_columns(steps: &[i64], times: &[f64]) -> [TimeColumn; 2] {
    [
        TimeColumn::new_sequence(STEP, steps.iter().copied()),
        TimeColumn::new_duration_secs(SIM_TIME, times.iter().copied()),
    ]
}

/// Sends a link's buffered poses as `Transform3D` translation and rotation-axis-angle columns (one
/// row per sample, unless empty). The Arrow arrays are built directly from the buffers, with the
/// components' own datatypes: this is several times cheaper than serializing component structs.
pub(super) fn send_poses(
    stream: &RecordingStream,
    ids: &mut RunIds,
    link: &LinkPoses,
    timelines: [TimeColumn; 2],
) -> Result<(), String> {
    let rows = link.angles.len();
    if rows == 0 {
        return Ok(());
    }
    let columns = pose_columns(&link.translations, &link.angles).map_err(|e| error_chain(&*e))?;
    ids.send_columns(stream, link.entity.clone(), timelines, columns)
}

pub(super) type BoxedError = Box<dyn std::error::Error + Send + Sync>;

/// Translation (x, y, 0 triples) and rotation-about-z (angles) columns of unit batches.
pub(super) fn pose_columns(
    translations: &[f32],
    angles: &[f32],
) -> Result<[SerializedComponentColumn; 2], BoxedError> {
    let rows = angles.len();
    debug_assert_eq!(translations.len(), 3 * rows);
    let vec3 = |xyz: Vec<f32>, datatype: DataType| -> Result<ArrayRef, BoxedError> {
        let DataType::FixedSizeList(item, 3) = datatype else {
            return Err(format!("unexpected Vec3D datatype {datatype}").into());
        };
        Ok(Arc::new(FixedSizeListArray::try_new(
            item,
            3,
            Arc::new(Float32Array::from(xyz)),
            None,
        )?))
    };
    let translation = vec3(translations.to_vec(), Translation3D::arrow_datatype())?;
    let DataType::Struct(fields) = RotationAxisAngle::arrow_datatype() else {
        return Err("unexpected RotationAxisAngle datatype".into());
    };
    let axes = vec3([0.0, 0.0, 1.0].repeat(rows), fields[0].data_type().clone())?;
    let rotation: ArrayRef = Arc::new(StructArray::try_new(
        fields,
        vec![axes, Arc::new(Float32Array::from(angles.to_vec()))],
        None,
    )?);
    let unit = std::iter::repeat_n(1, rows);
    Ok([
        SerializedComponentBatch::new(translation, Transform3D::descriptor_translation())
            .partitioned(unit.clone())?,
        SerializedComponentBatch::new(rotation, Transform3D::descriptor_rotation_axis_angle())
            .partitioned(unit)?,
    ])
}
