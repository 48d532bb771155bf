//! The served address space: one object per machine, under it a folder per axis (OPC 40502
//! CncAxis in spirit: actual position, actual velocity, commanded effort), the signals, the
//! commands (the only writable variables: the efforts, or with the scenario's controller inside
//! its setpoint offsets), the run's status and the `Advance` method.

use super::shared::{AdvanceRefusal, Shared};
use crate::opcua::units::add_engineering_units;
use opcua::server::address_space::{AddressSpace, MethodBuilder, ObjectBuilder, VariableBuilder};
use opcua::server::node_manager::memory::SimpleNodeManager;
use opcua::types::{
    DataTypeId, DataValue, NodeId, ObjectId, QualifiedName, ReferenceTypeId, StatusCode, Variant,
};
use std::sync::Arc;
use std::time::Duration;
use twin::SignalLayout;

/// How long one `Advance` call waits for the run before it returns what was reached.
const ADVANCE_TIMEOUT: Duration = Duration::from_secs(30);

/// The status variables, by their names under `status.`.
pub const STATUS: [(&str, DataTypeId, &str); 6] = [
    ("time", DataTypeId::Double, "simulated time, s"),
    ("step", DataTypeId::UInt64, "physics step index"),
    (
        "period",
        DataTypeId::UInt64,
        "control updates done (the lockstep counter)",
    ),
    (
        "state",
        DataTypeId::String,
        "running, finished, diverged or interrupted",
    ),
    (
        "deadline_misses",
        DataTypeId::UInt64,
        "control updates reached after their wall-clock deadline",
    ),
    (
        "last_event",
        DataTypeId::String,
        "the run's last event, one line (a fault's onset, a deadline miss, the run's end)",
    ),
];

/// The setpoint variables of `--with-controller`, by their names under `setpoint.`, in the
/// order of the reference offset, each with the reference signal it offsets.
pub const SETPOINTS: [&str; 3] = ["reference", "reference_rate", "reference_acceleration"];

/// Who commands the actuators of a served run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Commanding {
    /// The client writes `effort.<joint>`.
    Client,
    /// The scenario's controller; the client writes `setpoint.<reference>`, and `effort.<joint>`
    /// shows what the controller commands (read only).
    Controller,
}

/// The node ids the run publishes to, in the layout's order.
#[derive(Debug, Clone)]
pub struct Nodes {
    /// One per measured plant signal.
    pub signals: Vec<NodeId>,
    /// One per actuator when the scenario's controller commands them (published as it
    /// commands); none when the client does.
    pub efforts: Vec<NodeId>,
    /// In the order of [`STATUS`].
    pub status: Vec<NodeId>,
}

/// Builds the machine's nodes in namespace `ns` and hooks the commands and `Advance` to
/// `shared`.
pub fn build(
    manager: &SimpleNodeManager,
    ns: u16,
    machine: &str,
    layout: &SignalLayout,
    shared: &Arc<Shared>,
    commanding: Commanding,
) -> Nodes {
    let id = |name: &str| NodeId::new(ns, name.to_string());
    let root = id(machine);
    let mut space = manager.address_space().write();
    ObjectBuilder::new(&root, QualifiedName::new(ns, machine), machine)
        .description(format!("the twin's {machine}: signals SI, commands SI"))
        .organized_by(ObjectId::ObjectsFolder)
        .insert(&mut *space);
    for folder in ["Axes", "Signals", "Commands", "Status"] {
        let folder_id = id(&format!("{machine}.{folder}"));
        space.add_folder(&folder_id, QualifiedName::new(ns, folder), folder, &root);
    }
    let signals = add_signals(&mut space, &id, machine, layout);
    let efforts = add_commands(&mut space, &id, machine, layout, commanding);
    if commanding == Commanding::Controller {
        add_setpoints(&mut space, &id, machine, layout);
    }
    add_axes(&mut space, &id, machine, layout);
    let status = STATUS
        .iter()
        .map(|(name, data_type, description)| {
            let node = id(&format!("status.{name}"));
            VariableBuilder::new(&node, QualifiedName::new(ns, *name), *name)
                .description(*description)
                .data_type(*data_type)
                .value(initial(*data_type))
                .organized_by(id(&format!("{machine}.Status")))
                .insert(&mut *space);
            node
        })
        .collect();
    add_advance(&mut space, &id, &root);
    drop(space);
    match commanding {
        Commanding::Client => hook_commands(manager, &id, layout, shared),
        Commanding::Controller => hook_setpoints(manager, &id, shared),
    }
    hook_advance(manager, id("Advance"), shared.clone());
    Nodes {
        signals,
        efforts,
        status,
    }
}

/// A status variable's value before the run's first step.
fn initial(data_type: DataTypeId) -> Variant {
    match data_type {
        DataTypeId::UInt64 => Variant::UInt64(0),
        DataTypeId::String => Variant::from("starting"),
        _ => Variant::Double(0.0),
    }
}

fn add_signals(
    space: &mut AddressSpace,
    id: &dyn Fn(&str) -> NodeId,
    machine: &str,
    layout: &SignalLayout,
) -> Vec<NodeId> {
    let folder = id(&format!("{machine}.Signals"));
    layout
        .signals
        .iter()
        .zip(&layout.specs.signals)
        .map(|(name, spec)| {
            let node = id(name);
            VariableBuilder::new(
                &node,
                QualifiedName::new(node.namespace, name),
                name.as_str(),
            )
            .description(format!(
                "{} as measured, SI (the twin plots it in {})",
                spec.plot,
                spec.unit.label()
            ))
            .data_type(DataTypeId::Double)
            .value(0.0)
            .organized_by(folder.clone())
            .insert(space);
            add_engineering_units(space, &node, name, spec.unit.si_label());
            node
        })
        .collect()
}

/// The `effort.<joint>` variables: writable when the client commands, else read only (the
/// controller's commands, returned to be published).
fn add_commands(
    space: &mut AddressSpace,
    id: &dyn Fn(&str) -> NodeId,
    machine: &str,
    layout: &SignalLayout,
    commanding: Commanding,
) -> Vec<NodeId> {
    let folder = id(&format!("{machine}.Commands"));
    let mut published = Vec::new();
    for (joint, units) in layout.actuators.iter().zip(&layout.specs.efforts) {
        let name = format!("effort.{joint}");
        let node = id(&name);
        let unit = units[0].label();
        let builder = VariableBuilder::new(
            &node,
            QualifiedName::new(node.namespace, &name),
            name.as_str(),
        )
        .data_type(DataTypeId::Double)
        .value(0.0)
        .organized_by(folder.clone());
        let builder = match commanding {
            Commanding::Client => builder
                .description(format!(
                    "the command to actuator {joint}, {unit} (held between control updates)"
                ))
                .writable(),
            Commanding::Controller => {
                published.push(node.clone());
                builder.description(format!(
                    "the scenario's controller's command to actuator {joint}, {unit}, before \
                     its limit (read only: the controller commands it)"
                ))
            }
        };
        builder.insert(space);
        add_engineering_units(space, &node, &name, units[0].si_label());
    }
    published
}

/// The writable `setpoint.<reference>` variables: offsets on the scenario's reference triple.
fn add_setpoints(
    space: &mut AddressSpace,
    id: &dyn Fn(&str) -> NodeId,
    machine: &str,
    layout: &SignalLayout,
) {
    let folder = id(&format!("{machine}.Commands"));
    for signal in SETPOINTS {
        let name = format!("setpoint.{signal}");
        let node = id(&name);
        let unit = layout
            .signal(signal)
            .map_or("SI", |i| layout.specs.signals[i].unit.si_label());
        VariableBuilder::new(
            &node,
            QualifiedName::new(node.namespace, &name),
            name.as_str(),
        )
        .description(format!(
            "the offset added to the scenario's {signal}, {unit} (the reference's SI unit), \
             from the next control update on"
        ))
        .data_type(DataTypeId::Double)
        .value(0.0)
        .writable()
        .organized_by(folder.clone())
        .insert(space);
    }
}

/// A folder per actuated joint organizing its position, velocity and command (the same nodes
/// as under Signals and Commands).
fn add_axes(
    space: &mut AddressSpace,
    id: &dyn Fn(&str) -> NodeId,
    machine: &str,
    layout: &SignalLayout,
) {
    let axes = id(&format!("{machine}.Axes"));
    for joint in &layout.actuators {
        let folder = id(&format!("{machine}.Axes.{joint}"));
        let browse_name = QualifiedName::new(folder.namespace, joint);
        space.add_folder(&folder, browse_name, joint.as_str(), &axes);
        let members = [
            format!("{joint}.position"),
            format!("{joint}.velocity"),
            format!("effort.{joint}"),
        ];
        for member in members {
            let node = id(&member);
            if space.node_exists(&node) {
                space.insert_reference(&folder, &node, ReferenceTypeId::Organizes);
            }
        }
    }
}

fn add_advance(space: &mut AddressSpace, id: &dyn Fn(&str) -> NodeId, root: &NodeId) {
    let node = id("Advance");
    MethodBuilder::new(
        &node,
        QualifiedName::new(node.namespace, "Advance"),
        "Advance",
    )
    .description("lockstep: run this many control periods, then return the period reached")
    .component_of(root.clone())
    .input_args(
        space,
        &id("Advance.InputArguments"),
        &[("Periods", DataTypeId::UInt32).into()],
    )
    .output_args(
        space,
        &id("Advance.OutputArguments"),
        &[("Period", DataTypeId::UInt64).into()],
    )
    .executable(true)
    .user_executable(true)
    .insert(space);
}

/// Writes to `effort.<joint>` go to the shared commands (finite numbers only); reads return
/// them.
fn hook_commands(
    manager: &SimpleNodeManager,
    id: &dyn Fn(&str) -> NodeId,
    layout: &SignalLayout,
    shared: &Arc<Shared>,
) {
    for (index, joint) in layout.actuators.iter().enumerate() {
        let (writer, reader) = (shared.clone(), shared.clone());
        hook_number(
            manager,
            id(&format!("effort.{joint}")),
            move |command| writer.set_command(index, command),
            move || reader.command(index),
        );
    }
}

/// Writes to `setpoint.<reference>` go to the shared offset (finite numbers only); reads
/// return it.
fn hook_setpoints(manager: &SimpleNodeManager, id: &dyn Fn(&str) -> NodeId, shared: &Arc<Shared>) {
    for (index, signal) in SETPOINTS.iter().enumerate() {
        let (writer, reader) = (shared.clone(), shared.clone());
        hook_number(
            manager,
            id(&format!("setpoint.{signal}")),
            move |offset| writer.set_setpoint(index, offset),
            move || reader.setpoint_component(index),
        );
    }
}

/// A writable number: a finite write goes to `write` (`BadOutOfRange` otherwise,
/// `BadTypeMismatch` for what is not a number), a read returns `read`.
fn hook_number(
    manager: &SimpleNodeManager,
    node: NodeId,
    write: impl Fn(f64) + Send + Sync + 'static,
    read: impl Fn() -> f64 + Send + Sync + 'static,
) {
    manager
        .inner()
        .add_write_callback(node.clone(), move |value, _range| {
            match value.value.and_then(|v| v.try_cast_to::<f64>().ok()) {
                Some(number) if number.is_finite() => {
                    write(number);
                    StatusCode::Good
                }
                Some(_) => StatusCode::BadOutOfRange,
                None => StatusCode::BadTypeMismatch,
            }
        });
    manager
        .inner()
        .add_read_callback(node, move |_range, _timestamps, _age| {
            Ok(DataValue::new_now(read()))
        });
}

fn hook_advance(manager: &SimpleNodeManager, node: NodeId, shared: Arc<Shared>) {
    manager.inner().add_method_callback(node, move |arguments| {
        let periods = match arguments {
            [periods] => periods
                .clone()
                .try_cast_to::<u32>()
                .map_err(|_| StatusCode::BadInvalidArgument)?,
            _ => return Err(StatusCode::BadArgumentsMissing),
        };
        match shared.advance(u64::from(periods), ADVANCE_TIMEOUT) {
            Ok(period) => Ok(vec![Variant::UInt64(period)]),
            Err(AdvanceRefusal::Ended) => Err(StatusCode::BadInvalidState),
        }
    });
}
