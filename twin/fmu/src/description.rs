//! modelDescription.xml of a scenario's plant (FMI 2.0 co-simulation) and its GUID.

use twin::Simulator;

/// What one real variable of the FMU holds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Real {
    /// An actuator's effort (input), by actuator index.
    Effort(usize),
    /// A signal as the sensors read it at the last control update, by signal index.
    Measured(usize),
    /// A signal's true value, by signal index.
    True(usize),
}

/// The value reference of the seed parameter (an Integer); the reals follow from 1 on.
pub const SEED: u32 = 0;

/// The real variables in value-reference order (reference = position + 1).
pub fn reals(simulator: &Simulator) -> Vec<Real> {
    let signals = simulator.signal_specs().len();
    (0..simulator.actuators().len())
        .map(Real::Effort)
        .chain((0..signals).map(Real::Measured))
        .chain((0..signals).map(Real::True))
        .collect()
}

/// The C identifier of a scenario's FMU: `twin_` and its name with `-` and `.` as `_`.
pub fn model_identifier(scenario: &str) -> String {
    let tail: String = scenario
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    format!("twin_{tail}")
}

/// An SI unit written in ASCII, as FMI unit names are compared as strings.
fn unit_name(unit: &str) -> String {
    unit.replace('·', ".").replace('²', "2")
}

/// The variable's name, unit and description.
fn variable(simulator: &Simulator, real: Real) -> (String, String, String) {
    let specs = simulator.signal_specs();
    let units = simulator.signal_units();
    match real {
        Real::Effort(a) => {
            let actuator = &simulator.actuators()[a];
            let unit = match actuator.kind {
                controllers::EffortKind::Torque => "N.m",
                controllers::EffortKind::Force => "N",
            };
            let description = format!(
                "effort on {}, held over the step, clipped to ±{}",
                actuator.joint, actuator.effort_limit
            );
            (
                format!("effort.{}", actuator.joint),
                unit.into(),
                description,
            )
        }
        Real::Measured(i) => (
            format!("measured.{}", specs[i].name),
            unit_name(units[i]),
            format!(
                "{} as the sensors read it at the last control update",
                specs[i].plot
            ),
        ),
        Real::True(i) => (
            format!("true.{}", specs[i].name),
            unit_name(units[i]),
            format!("{}: the true value", specs[i].name),
        ),
    }
}

/// modelDescription.xml with `guid` in its place.
fn with_guid(simulator: &Simulator, guid: &str) -> String {
    let scenario = simulator.scenario();
    let id = model_identifier(&scenario.name);
    let reals = reals(simulator);
    let mut units: Vec<String> = reals.iter().map(|&r| variable(simulator, r).1).collect();
    units.sort();
    units.dedup();
    let mut xml = format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<fmiModelDescription fmiVersion=\"2.0\" \
         modelName=\"{name}\" guid=\"{guid}\" description=\"{machine} plant of scenario {name} \
         (twin), its controller left out\" generationTool=\"twin {version}\" \
         variableNamingConvention=\"flat\" numberOfEventIndicators=\"0\">\n  <CoSimulation \
         modelIdentifier=\"{id}\" canHandleVariableCommunicationStepSize=\"true\" \
         canInterpolateInputs=\"false\" maxOutputDerivativeOrder=\"0\" \
         canGetAndSetFMUstate=\"false\" canSerializeFMUstate=\"false\" \
         providesDirectionalDerivative=\"false\"/>\n  <UnitDefinitions>\n",
        name = escape(&scenario.name),
        machine = escape(&scenario.machine),
        version = env!("CARGO_PKG_VERSION"),
    );
    for unit in &units {
        xml += &format!("    <Unit name=\"{}\"/>\n", escape(unit));
    }
    xml += &format!(
        "  </UnitDefinitions>\n  <DefaultExperiment startTime=\"0\" stopTime=\"{}\" \
         stepSize=\"{}\"/>\n  <ModelVariables>\n    <ScalarVariable name=\"seed\" \
         valueReference=\"{SEED}\" causality=\"parameter\" variability=\"fixed\" \
         initial=\"exact\" description=\"sensor noise and fault seed\">\n      <Integer \
         start=\"{}\"/>\n    </ScalarVariable>\n",
        scenario.duration,
        scenario.control_period(),
        scenario.seed
    );
    for (k, &real) in reals.iter().enumerate() {
        let (name, unit, description) = variable(simulator, real);
        let (causality, start) = match real {
            Real::Effort(_) => ("input", " start=\"0\""),
            _ => ("output", ""),
        };
        xml += &format!(
            "    <ScalarVariable name=\"{}\" valueReference=\"{}\" causality=\"{causality}\" \
             variability=\"continuous\" description=\"{}\">\n      <Real unit=\"{}\"{start}/>\n    \
             </ScalarVariable>\n",
            escape(&name),
            k + 1,
            escape(&description),
            escape(&unit),
        );
    }
    xml += "  </ModelVariables>\n  <ModelStructure>\n    <Outputs>\n";
    let outputs = (0..reals.len()).filter(|&k| !matches!(reals[k], Real::Effort(_)));
    // Index 1 is the seed; outputs depend on the state only (no direct feedthrough).
    for k in outputs.clone() {
        xml += &format!("      <Unknown index=\"{}\" dependencies=\"\"/>\n", k + 2);
    }
    xml += "    </Outputs>\n    <InitialUnknowns>\n";
    for k in outputs {
        xml += &format!("      <Unknown index=\"{}\"/>\n", k + 2);
    }
    xml += "    </InitialUnknowns>\n  </ModelStructure>\n</fmiModelDescription>\n";
    xml
}

/// modelDescription.xml of the simulator's scenario and its GUID: a hash of the description's
/// content with an empty GUID (two FNV-1a 64 passes with different offsets).
pub fn model_description(simulator: &Simulator) -> (String, String) {
    let blank = with_guid(simulator, "");
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
    (with_guid(simulator, &guid), guid)
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
