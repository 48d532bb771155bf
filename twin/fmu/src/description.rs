//! modelDescription.xml of a scenario's FMU (FMI 2.0 co-simulation) and its GUID: its variables,
//! for the plant alone or the closed loop with its controller, and their value references.

use crate::parameters::{unit_name, Number, Parameter};
use framework::EffortKind;
use twin::Simulator;

/// What one variable of the FMU holds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Role {
    /// An actuator's effort (input of the plant alone), by actuator index.
    Effort(usize),
    /// An offset on the scenario's reference triple (input of the closed loop): 0 position,
    /// 1 rate, 2 acceleration.
    Setpoint(usize),
    /// An effort from outside on a movable joint (input of the closed loop), by joint index.
    Disturbance(usize),
    /// A signal as the sensors read it at the last control update, by signal index.
    Measured(usize),
    /// A signal's true value, by signal index.
    True(usize),
    /// The effort the controller commanded at its last update (output of the closed loop).
    Commanded(usize),
    /// A controller's internal signal after its last update, by index.
    Internal(usize),
    /// The sensor noise and fault seed (an Integer).
    Seed,
    /// A scenario number, by parameter index.
    Parameter(usize),
}

impl Role {
    pub fn is_input(&self) -> bool {
        matches!(
            self,
            Role::Effort(_) | Role::Setpoint(_) | Role::Disturbance(_)
        )
    }

    pub fn is_output(&self) -> bool {
        matches!(
            self,
            Role::Measured(_) | Role::True(_) | Role::Commanded(_) | Role::Internal(_)
        )
    }
}

/// One scalar variable.
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    pub name: String,
    pub role: Role,
    /// An fmi2Integer, else an fmi2Real.
    pub integer: bool,
    pub reference: u32,
    pub unit: Option<String>,
    pub description: String,
    pub start: Option<String>,
}

/// The value reference of the seed parameter (an Integer); the other Integers follow it, the
/// Reals count from 1.
pub const SEED: u32 = 0;

/// The reference names of the setpoint inputs, as the controller reads them.
pub const SETPOINTS: [&str; 3] = ["reference", "reference_rate", "reference_acceleration"];

/// The FMU's variables in document order, with their value references: the inputs, the
/// outputs, then the parameters; `controlled` says whether the controller is in the loop.
pub fn variables(
    simulator: &Simulator,
    controlled: bool,
    parameters: &[Parameter],
) -> Vec<Variable> {
    let signals = simulator.signal_specs().len();
    let actuators = simulator.actuators().len();
    let mut roles: Vec<Role> = if controlled {
        let setpoints = if simulator.reference_inputs().is_ok() {
            0..3
        } else {
            0..0
        };
        (setpoints.map(Role::Setpoint))
            .chain((0..simulator.joints().len()).map(Role::Disturbance))
            .collect()
    } else {
        (0..actuators).map(Role::Effort).collect()
    };
    roles.extend((0..signals).map(Role::Measured));
    roles.extend((0..signals).map(Role::True));
    if controlled {
        roles.extend((0..actuators).map(Role::Commanded));
        roles.extend((0..simulator.internal_specs().len()).map(Role::Internal));
    }
    let mut variables = vec![seed(simulator)];
    let (mut reals, mut integers) = (0, SEED);
    let parameter_roles = (0..parameters.len()).map(Role::Parameter);
    for role in roles.into_iter().chain(parameter_roles) {
        let mut variable = describe(simulator, parameters, role);
        let count = if variable.integer {
            &mut integers
        } else {
            &mut reals
        };
        *count += 1;
        variable.reference = *count;
        variables.push(variable);
    }
    variables
}

fn seed(simulator: &Simulator) -> Variable {
    Variable {
        name: "seed".into(),
        role: Role::Seed,
        integer: true,
        reference: SEED,
        unit: None,
        description: "sensor noise and fault seed".into(),
        start: Some(simulator.scenario().seed.to_string()),
    }
}

/// A variable's name, unit (empty: none), description and start value.
type About = (String, String, String, Option<String>);

/// The variable of `role`, its value reference still to be given.
fn describe(simulator: &Simulator, parameters: &[Parameter], role: Role) -> Variable {
    let (name, unit, description, start) = match role {
        Role::Seed => return seed(simulator),
        Role::Parameter(p) => about_parameter(&parameters[p]),
        Role::Effort(a) => about_effort(simulator, a),
        Role::Setpoint(k) => about_setpoint(simulator, k),
        Role::Disturbance(j) => about_disturbance(simulator, j),
        Role::Measured(i) | Role::True(i) => about_signal(simulator, i, role == Role::True(i)),
        Role::Commanded(a) => about_command(simulator, a),
        Role::Internal(i) => about_internal(simulator, i),
    };
    Variable {
        integer: matches!(role, Role::Parameter(p) if matches!(parameters[p].default, Number::Integer(_))),
        name,
        role,
        reference: 0,
        unit: Some(unit).filter(|u| !u.is_empty()),
        description,
        start,
    }
}

fn about_effort(simulator: &Simulator, a: usize) -> About {
    let actuator = &simulator.actuators()[a];
    let text = format!(
        "command to the drive of {}, held over the step, clipped to ±{}",
        actuator.joint,
        simulator.command_limits()[a]
    );
    let unit = unit_name(simulator.command_units()[a]);
    (
        format!("effort.{}", actuator.joint),
        unit,
        text,
        Some("0".into()),
    )
}

fn about_setpoint(simulator: &Simulator, k: usize) -> About {
    let specs = simulator.signal_specs();
    let reference = specs.iter().position(|s| s.name == SETPOINTS[k]);
    let unit = reference.map_or(String::new(), |i| unit_name(simulator.signal_units()[i]));
    let text = format!(
        "added to the scenario's {} from the step's start on, held over it",
        SETPOINTS[k]
    );
    (
        format!("setpoint.{}", SETPOINTS[k]),
        unit,
        text,
        Some("0".into()),
    )
}

fn about_disturbance(simulator: &Simulator, j: usize) -> About {
    let (joint, kind) = simulator.joints()[j];
    let text =
        format!("effort from outside on joint {joint}, on top of its drive, held over the step");
    let unit = match kind {
        EffortKind::Torque => "N.m",
        EffortKind::Force => "N",
    };
    (
        format!("disturbance.{joint}"),
        unit.into(),
        text,
        Some("0".into()),
    )
}

/// A signal as measured, or with `true_value` its true value.
fn about_signal(simulator: &Simulator, i: usize, true_value: bool) -> About {
    let spec = &simulator.signal_specs()[i];
    let unit = unit_name(simulator.signal_units()[i]);
    if true_value {
        let text = format!("{}: the true value", spec.name);
        (format!("true.{}", spec.name), unit, text, None)
    } else {
        // Named by the signal itself: several signals share one plot (the reference, its rate
        // and its acceleration sit on the table position's).
        let text = format!(
            "{}, as the sensors read it at the last control update",
            spec.name
        );
        (format!("measured.{}", spec.name), unit, text, None)
    }
}

fn about_command(simulator: &Simulator, a: usize) -> About {
    let actuator = &simulator.actuators()[a];
    let text = format!(
        "command the controller gave the drive of {} at its last update (the step's start), \
         before the limit ±{}",
        actuator.joint,
        simulator.command_limits()[a]
    );
    let unit = unit_name(simulator.command_units()[a]);
    (format!("effort.{}", actuator.joint), unit, text, None)
}

fn about_internal(simulator: &Simulator, i: usize) -> About {
    let spec = &simulator.internal_specs()[i];
    let text = format!(
        "controller {}: {} at its last update (the step's start)",
        simulator.controller(),
        spec.plot
    );
    let unit = unit_name(simulator.internal_units()[i]);
    (format!("controller.{}", spec.name), unit, text, None)
}

fn about_parameter(parameter: &Parameter) -> About {
    let text = format!(
        "scenario value {} (as --set {}), fixed at initialization",
        parameter.name, parameter.key
    );
    let start = match parameter.default {
        Number::Real(x) => format!("{x:?}"),
        Number::Integer(i) => i.to_string(),
    };
    let unit = parameter.unit.clone().unwrap_or_default();
    (parameter.name.clone(), unit, text, Some(start))
}

/// The C identifier of a scenario's FMU: `twin_` and its name with `-` and `.` as `_`.
pub fn model_identifier(scenario: &str) -> String {
    let tail: String = scenario
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    format!("twin_{tail}")
}

/// The head of modelDescription.xml, with `guid` in its place.
fn header(simulator: &Simulator, controlled: bool, guid: &str) -> String {
    let scenario = simulator.scenario();
    let what = if controlled {
        format!("closed loop with its controller {}", simulator.controller())
    } else {
        "plant, its controller left out".into()
    };
    format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<fmiModelDescription fmiVersion=\"2.0\" \
         modelName=\"{name}\" guid=\"{guid}\" description=\"{machine} {what} (scenario {name}, \
         twin)\" generationTool=\"twin {version}\" variableNamingConvention=\"flat\" \
         numberOfEventIndicators=\"0\">\n  <CoSimulation modelIdentifier=\"{id}\" \
         canHandleVariableCommunicationStepSize=\"true\" canInterpolateInputs=\"false\" \
         maxOutputDerivativeOrder=\"0\" canGetAndSetFMUstate=\"true\" \
         canSerializeFMUstate=\"true\" providesDirectionalDerivative=\"false\"/>\n",
        name = escape(&scenario.name),
        machine = escape(&scenario.machine),
        what = escape(&what),
        version = env!("CARGO_PKG_VERSION"),
        id = model_identifier(&scenario.name),
    )
}

/// One `<ScalarVariable>`.
fn scalar(variable: &Variable) -> String {
    let role = variable.role;
    let (causality, variability, initial) = match role {
        _ if role.is_input() => ("input", "continuous", ""),
        _ if role.is_output() => ("output", "continuous", ""),
        _ => ("parameter", "fixed", " initial=\"exact\""),
    };
    let unit =
        (variable.unit.as_ref()).map_or(String::new(), |u| format!(" unit=\"{}\"", escape(u)));
    let start = (variable.start.as_ref()).map_or(String::new(), |s| format!(" start=\"{s}\""));
    let kind = if variable.integer { "Integer" } else { "Real" };
    format!(
        "    <ScalarVariable name=\"{}\" valueReference=\"{}\" causality=\"{causality}\" \
         variability=\"{variability}\"{initial} description=\"{}\">\n      <{kind}{unit}{start}/>\n    \
         </ScalarVariable>\n",
        escape(&variable.name),
        variable.reference,
        escape(&variable.description),
    )
}

/// modelDescription.xml with `guid` in its place.
fn with_guid(
    simulator: &Simulator,
    variables: &[Variable],
    controlled: bool,
    guid: &str,
) -> String {
    let scenario = simulator.scenario();
    let mut units: Vec<&String> = variables.iter().filter_map(|v| v.unit.as_ref()).collect();
    units.sort();
    units.dedup();
    let mut xml = header(simulator, controlled, guid);
    xml += "  <UnitDefinitions>\n";
    for unit in &units {
        xml += &format!("    <Unit name=\"{}\"/>\n", escape(unit));
    }
    xml += &format!(
        "  </UnitDefinitions>\n  <DefaultExperiment startTime=\"0\" stopTime=\"{}\" \
         stepSize=\"{}\"/>\n  <ModelVariables>\n",
        scenario.duration,
        scenario.control_period(),
    );
    for variable in variables {
        xml += &scalar(variable);
    }
    xml += "  </ModelVariables>\n  <ModelStructure>\n    <Outputs>\n";
    // Indices count from 1 in document order; outputs depend on the state only (no direct
    // feedthrough: an input set now acts from the next step's start).
    let outputs = (1..).zip(variables).filter(|(_, v)| v.role.is_output());
    for (index, _) in outputs.clone() {
        xml += &format!("      <Unknown index=\"{index}\" dependencies=\"\"/>\n");
    }
    xml += "    </Outputs>\n    <InitialUnknowns>\n";
    for (index, _) in outputs {
        xml += &format!("      <Unknown index=\"{index}\"/>\n");
    }
    xml += "    </InitialUnknowns>\n  </ModelStructure>\n</fmiModelDescription>\n";
    xml
}

/// modelDescription.xml of the FMU and its GUID: a hash of the description's content with an
/// empty GUID (two FNV-1a 64 passes with different offsets).
pub fn model_description(
    simulator: &Simulator,
    variables: &[Variable],
    controlled: bool,
) -> (String, String) {
    let blank = with_guid(simulator, variables, controlled, "");
    let hash = |offset: u64| {
        blank.bytes().fold(offset, |h, b| {
            (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
        })
    };
    let (a, b) = (hash(0xcbf2_9ce4_8422_2325), hash(0x6c62_272e_07bb_0142));
    let guid = format!(
        "{{{:08x}-{:04x}-{:04x}-{:04x}-{:012x}}}",
        a >> 32,
        (a >> 16) & 0xffff,
        a & 0xffff,
        b >> 48,
        b & 0xffff_ffff_ffff
    );
    (with_guid(simulator, variables, controlled, &guid), guid)
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
