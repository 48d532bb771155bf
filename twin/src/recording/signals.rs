//! A run's signals read back from its recording, as data: which plotted series carry the run's
//! commands, measurements and true signals is written beside each plot (a static annotation of
//! one entry per series), and read back with the plot's samples, converted back to SI.
//!
//! The annotation is four static components on each `/signals/…` plot entity, one instance per
//! series in the plot's order: `twin.columns:column` (`""`, or the roles and the name, e.g.
//! `true,measured:crank.position` or `command:crank`), `twin.columns:si_unit` (the SI unit's
//! label), `twin.columns:scale` (displayed units per SI unit) and `twin.columns:wrapped`
//! (whether the displayed value is an angle wrapped to a half turn either side of zero).

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use rerun::archetypes::Scalars;
use rerun::external::arrow::array::{Array, ArrayRef, BooleanArray, Float64Array, StringArray};
use rerun::external::re_log_encoding::DecoderApp;
use rerun::log::{Chunk, LogMsg};
use rerun::{ComponentDescriptor, SerializedComponentBatch, StoreKind, TimelineName};

use super::entities::{SIGNALS, SIM_TIME, STEP};
use super::error::RecordingError;
use super::layout::{ColumnRole, PlotSpec};
use framework::Unit;

const ARCHETYPE: &str = "twin.columns";
const COLUMN: &str = "twin.columns:column";
const SI_UNIT: &str = "twin.columns:si_unit";
const SCALE: &str = "twin.columns:scale";
const WRAPPED: &str = "twin.columns:wrapped";

/// A run's signals as a recording holds them, in SI units. Values are the recorded `f64`s
/// converted back from their display unit (mm, µm, °, rpm, …) by one division, so they equal
/// the run's own to within a rounding or two; a wrapped angle is unwrapped by continuity, which
/// is exact while it moves less than half a turn between samples.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RecordedSignals {
    /// Simulated time of each sample, s (the recording keeps it to the nanosecond).
    pub time: Vec<f64>,
    /// The series that carry a run's column, in the order of the plots.
    pub series: Vec<RecordedSeries>,
}

/// One series of [`RecordedSignals`].
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedSeries {
    /// The actuator's joint or the plant signal's name.
    pub name: String,
    /// What the values are: a command, a measurement, a true value, or both of the last.
    pub roles: Vec<ColumnRole>,
    /// The SI unit of the values (`m`, `rad/s`, `N·m`, …).
    pub unit: String,
    /// One value per sample, SI.
    pub values: Vec<f64>,
}

/// The annotation of a plot's series; none when no series carries a run's column.
pub(super) fn column_batches(plot: &PlotSpec) -> Vec<SerializedComponentBatch> {
    if plot.series.iter().all(|s| s.column.is_none()) {
        return Vec::new();
    }
    let columns: Vec<String> = plot
        .series
        .iter()
        .map(|s| match &s.column {
            Some(column) => {
                let roles: Vec<&str> = column.roles.iter().map(|r| r.word()).collect();
                format!("{}:{}", roles.join(","), column.name)
            }
            None => String::new(),
        })
        .collect();
    let count = plot.series.len();
    let unit = plot.unit;
    let arrays: [(&str, ArrayRef); 4] = [
        (COLUMN, Arc::new(StringArray::from(columns))),
        (
            SI_UNIT,
            Arc::new(StringArray::from(vec![unit.si_label(); count])),
        ),
        (
            SCALE,
            Arc::new(Float64Array::from(vec![unit.from_si(1.0); count])),
        ),
        (
            WRAPPED,
            Arc::new(BooleanArray::from(vec![unit == Unit::DegreeWrapped; count])),
        ),
    ];
    arrays
        .into_iter()
        .map(|(field, array)| {
            let descriptor = ComponentDescriptor::partial(field).with_archetype(ARCHETYPE.into());
            SerializedComponentBatch::new(array, descriptor)
        })
        .collect()
}

/// One plot's annotation as read back, per series.
#[derive(Debug, Default)]
struct Annotation {
    columns: Vec<String>,
    units: Vec<String>,
    scales: Vec<f64>,
    wrapped: Vec<bool>,
}

/// One plot's samples: step, time (ns) and one value per series.
type Samples = Vec<(i64, i64, Vec<f64>)>;

/// Reads the run's signals from `bytes`, the contents of the recording `path` (named in errors).
/// Fails on bytes that do not decode as a Rerun recording, and on a recording that holds no
/// annotated series (one that `twin run` did not write).
pub fn read_signals(path: &Path, bytes: &[u8]) -> Result<RecordedSignals, RecordingError> {
    let error = |reason: String| RecordingError::Read {
        path: path.to_path_buf(),
        reason,
    };
    let mut annotations: BTreeMap<String, Annotation> = BTreeMap::new();
    let mut samples: BTreeMap<String, Samples> = BTreeMap::new();
    let mut order: Vec<String> = Vec::new();
    for message in DecoderApp::decode_lazy(bytes) {
        let message = message.map_err(|e| error(e.to_string()))?;
        let LogMsg::ArrowMsg(store, arrow) = message else {
            continue;
        };
        if store.kind() != StoreKind::Recording {
            continue;
        }
        let chunk = Chunk::from_arrow_msg(&arrow).map_err(|e| error(e.to_string()))?;
        let entity = chunk.entity_path().to_string();
        if !entity.starts_with(&format!("/{SIGNALS}/")) {
            continue;
        }
        if chunk.is_static() {
            if let Some(annotation) = annotation(&chunk) {
                order.push(entity.clone());
                annotations.insert(entity, annotation);
            }
        } else {
            read_samples(&chunk, samples.entry(entity).or_default());
        }
    }
    if annotations.is_empty() {
        return Err(error(
            "it holds no run signals to read (written by `twin run` of an older version, or \
             not by the twin)"
                .into(),
        ));
    }
    assemble(&order, &annotations, samples).map_err(error)
}

/// The annotation in a static chunk, if it holds a whole one.
fn annotation(chunk: &Chunk) -> Option<Annotation> {
    let last = |field: &'static str| -> Option<ArrayRef> {
        let list = chunk.components().get_array(field.into())?;
        (0..list.len())
            .rev()
            .find(|&i| list.is_valid(i))
            .map(|i| list.value(i))
    };
    let strings = |array: ArrayRef| -> Option<Vec<String>> {
        let array = array.as_any().downcast_ref::<StringArray>()?;
        Some(
            (0..array.len())
                .map(|i| array.value(i).to_owned())
                .collect(),
        )
    };
    let columns = strings(last(COLUMN)?)?;
    let units = strings(last(SI_UNIT)?)?;
    let scales = last(SCALE)?;
    let scales = scales
        .as_any()
        .downcast_ref::<Float64Array>()?
        .values()
        .to_vec();
    let wrapped = last(WRAPPED)?;
    let wrapped = wrapped.as_any().downcast_ref::<BooleanArray>()?;
    let wrapped = (0..wrapped.len()).map(|i| wrapped.value(i)).collect();
    Some(Annotation {
        columns,
        units,
        scales,
        wrapped,
    })
}

/// Appends a temporal chunk's rows of scalars (those with both timelines) to `samples`.
fn read_samples(chunk: &Chunk, samples: &mut Samples) {
    let timelines = chunk.timelines();
    let (Some(steps), Some(times)) = (
        timelines.get(&TimelineName::from_static_str(STEP)),
        timelines.get(&TimelineName::from_static_str(SIM_TIME)),
    ) else {
        return;
    };
    let Some(list) = chunk
        .components()
        .get_array(Scalars::descriptor_scalars().component)
    else {
        return;
    };
    let Some(values) = list.values().as_any().downcast_ref::<Float64Array>() else {
        return;
    };
    let (steps, times) = (steps.times_raw(), times.times_raw());
    let rows = list.len().min(steps.len()).min(times.len());
    for row in (0..rows).filter(|&row| list.is_valid(row)) {
        let offsets = list.value_offsets();
        let (start, end) = (offsets[row] as usize, offsets[row + 1] as usize);
        let Some(slice) = values.values().get(start..end) else {
            continue;
        };
        samples.push((steps[row], times[row], slice.to_vec()));
    }
}

/// The annotated series, on the samples of the first annotated plot; every annotated plot must
/// have the same steps.
fn assemble(
    order: &[String],
    annotations: &BTreeMap<String, Annotation>,
    mut samples: BTreeMap<String, Samples>,
) -> Result<RecordedSignals, String> {
    let mut signals = RecordedSignals::default();
    let mut steps: Option<Vec<i64>> = None;
    for entity in order {
        let (Some(annotation), Some(mut rows)) = (annotations.get(entity), samples.remove(entity))
        else {
            continue;
        };
        rows.sort_by_key(|(step, _, _)| *step);
        rows.dedup_by_key(|(step, _, _)| *step);
        let these: Vec<i64> = rows.iter().map(|(step, _, _)| *step).collect();
        match &steps {
            None => {
                signals.time = rows.iter().map(|(_, ns, _)| *ns as f64 * 1e-9).collect();
                steps = Some(these);
            }
            Some(first) if *first != these => {
                return Err(format!(
                    "its plot {entity} is sampled at other steps than the first plot"
                ));
            }
            Some(_) => {}
        }
        add_series(&mut signals, entity, annotation, &rows)?;
    }
    if signals.series.is_empty() {
        return Err("it holds no samples of its run signals".into());
    }
    Ok(signals)
}

/// The annotated series of one plot, converted to SI.
fn add_series(
    signals: &mut RecordedSignals,
    entity: &str,
    annotation: &Annotation,
    rows: &Samples,
) -> Result<(), String> {
    let count = annotation.columns.len();
    let consistent = [
        annotation.units.len(),
        annotation.scales.len(),
        annotation.wrapped.len(),
    ]
    .iter()
    .all(|&n| n == count)
        && rows.iter().all(|(_, _, values)| values.len() == count);
    if !consistent {
        return Err(format!(
            "its plot {entity} has samples or annotations of another width than its series"
        ));
    }
    for (i, column) in annotation.columns.iter().enumerate() {
        let Some((roles, name)) = column.split_once(':') else {
            continue;
        };
        let roles: Option<Vec<ColumnRole>> = roles.split(',').map(ColumnRole::from_word).collect();
        let scale = annotation.scales[i];
        let (Some(roles), true) = (roles, scale.is_finite() && scale != 0.0) else {
            return Err(format!(
                "its plot {entity} has a malformed annotation `{column}`"
            ));
        };
        let mut values: Vec<f64> = rows.iter().map(|(_, _, v)| v[i] / scale).collect();
        if annotation.wrapped[i] {
            unwrap(&mut values);
        }
        signals.series.push(RecordedSeries {
            name: name.to_owned(),
            roles,
            unit: annotation.units[i].clone(),
            values,
        });
    }
    Ok(())
}

/// Unwraps angles wrapped to (−π, π] by continuity: each step taken as less than half a turn.
fn unwrap(values: &mut [f64]) {
    use std::f64::consts::TAU;
    let mut turns = 0.0;
    let mut previous: Option<f64> = None;
    for value in values.iter_mut() {
        let raw = *value;
        if !raw.is_finite() {
            continue;
        }
        if let Some(before) = previous {
            turns += ((before - raw) / TAU).round();
        }
        previous = Some(raw);
        *value = raw + TAU * turns;
    }
}
