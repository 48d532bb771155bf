//! One FMU instance: the simulator, its inputs and parameters, the history that makes its state,
//! and where it is in the FMI 2.0 life cycle.

use crate::closed_loop::simulator;
use crate::description::{model_description, variables, Role, Variable};
use crate::package::{KIND_FILE, SCENARIO_FILE};
use crate::parameters::{assignments, parameters, Number, Parameter};
use crate::state::{History, State};
use std::path::PathBuf;
use twin::{Overrides, Scenario, Simulator};

/// Where an instance is in FMI 2.0's co-simulation state machine (§4.2.4).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Phase {
    Instantiated,
    Initializing,
    Stepping,
    Terminated,
}

pub struct Instance {
    pub simulator: Simulator,
    /// The scenario as packed (resources/scenario.toml), its path and folder.
    scenario: (String, String, PathBuf),
    /// Whether the scenario's controller is in the loop.
    controlled: bool,
    guid: String,
    variables: Vec<Variable>,
    /// Index into `variables` by Real value reference − 1, and by Integer value reference.
    reals: Vec<usize>,
    integers: Vec<usize>,
    parameters: Vec<Parameter>,
    /// The parameters' values now.
    values: Vec<f64>,
    seed: i32,
    /// The scenario's seed, the seed's start value.
    start_seed: i32,
    /// The inputs now: the efforts (plant), or the reference offset triple then the disturbances
    /// (closed loop).
    inputs: Vec<f64>,
    /// The inputs of every period since t = 0.
    history: History,
    pub phase: Phase,
}

/// The folder a `file://` URI names (`file:///a/b`, `file://localhost/a/b`, `file:/a/b`),
/// percent-decoded.
pub fn resource_folder(uri: &str) -> Result<PathBuf, String> {
    let rest = uri
        .strip_prefix("file://localhost")
        .or_else(|| uri.strip_prefix("file://"))
        .or_else(|| uri.strip_prefix("file:"))
        .filter(|rest| rest.starts_with('/'))
        .ok_or_else(|| format!("resourceLocation `{uri}` is not a file:// URI of a folder"))?;
    let bytes = rest.as_bytes();
    let mut path = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = bytes
            .get(i + 1..i + 3)
            .and_then(|h| std::str::from_utf8(h).ok());
        match (bytes[i], hex.and_then(|h| u8::from_str_radix(h, 16).ok())) {
            (b'%', Some(byte)) => {
                path.push(byte);
                i += 3;
            }
            (byte, _) => {
                path.push(byte);
                i += 1;
            }
        }
    }
    let text =
        String::from_utf8(path).map_err(|_| format!("resourceLocation `{uri}` is not UTF-8"))?;
    Ok(PathBuf::from(text))
}

/// Whether resources/fmu.toml says the controller is in the loop (no file: the plant alone).
fn controlled(folder: &std::path::Path) -> Result<bool, String> {
    let file = folder.join(KIND_FILE);
    let Ok(text) = std::fs::read_to_string(&file) else {
        return Ok(false);
    };
    let table: toml::Table = text
        .parse()
        .map_err(|e| format!("{}: {e}", file.display()))?;
    match table.get("controller") {
        Some(toml::Value::Boolean(on)) => Ok(*on),
        _ => Err(format!(
            "{}: `controller` must be true or false",
            file.display()
        )),
    }
}

/// A number's value as an fmi2Real.
fn real(number: Number) -> f64 {
    match number {
        Number::Real(x) => x,
        Number::Integer(i) => f64::from(i),
    }
}

impl Instance {
    /// The FMU of the scenario in `resources`, checked against the host's `guid`.
    pub fn new(resources: &str, guid: &str) -> Result<Self, String> {
        let folder = resource_folder(resources)?;
        let controlled = controlled(&folder)?;
        let file = folder.join(SCENARIO_FILE);
        let text = std::fs::read_to_string(&file)
            .map_err(|e| format!("{}: cannot read: {e}", file.display()))?;
        let scenario = (text, file.display().to_string(), folder);
        let simulator = load(&scenario, controlled, &[])?;
        let parameters = parameters(&scenario.0, &simulator, controlled);
        let variables = variables(&simulator, controlled, &parameters);
        let (_, own) = model_description(&simulator, &variables, controlled);
        if guid != own {
            return Err(format!(
                "fmuGUID {guid} is not this FMU's {own} (modelDescription.xml and the binary differ)"
            ));
        }
        let seed = i32::try_from(simulator.scenario().seed)
            .map_err(|_| "the scenario's seed does not fit an fmi2Integer".to_string())?;
        let inputs = if controlled {
            3 + simulator.joints().len()
        } else {
            simulator.actuators().len()
        };
        let by_kind = |integer: bool| {
            let mut of_kind: Vec<(u32, usize)> = (variables.iter().enumerate())
                .filter(|(_, v)| v.integer == integer)
                .map(|(k, v)| (v.reference, k))
                .collect();
            of_kind.sort();
            of_kind.into_iter().map(|(_, k)| k).collect()
        };
        Ok(Self {
            reals: by_kind(false),
            integers: by_kind(true),
            values: parameters.iter().map(|p| real(p.default)).collect(),
            simulator,
            scenario,
            controlled,
            guid: own,
            variables,
            parameters,
            seed,
            start_seed: seed,
            inputs: vec![0.0; inputs],
            history: History::new(inputs),
            phase: Phase::Instantiated,
        })
    }

    /// Back to the state after instantiation (fmi2Reset): the parameters and the seed at their
    /// start values, the inputs at zero, t = 0.
    pub fn reset(&mut self) -> Result<(), String> {
        let defaults: Vec<f64> = self.parameters.iter().map(|p| real(p.default)).collect();
        self.rebuild(defaults)?;
        self.seed = self.start_seed;
        self.inputs.fill(0.0);
        self.phase = Phase::Instantiated;
        self.restart()
    }

    /// The simulator at t = 0 with the seed now set.
    pub fn restart(&mut self) -> Result<(), String> {
        let seed =
            u64::try_from(self.seed).map_err(|_| format!("seed = {}: must be ≥ 0", self.seed))?;
        self.history.clear();
        self.simulator.reset(seed).map_err(|e| e.to_string())
    }

    /// The simulator of the scenario with the parameters at `values`, if they differ from the
    /// ones now: refused with the scenario's own one-line error, or when they would change the
    /// FMU's variables.
    fn rebuild(&mut self, values: Vec<f64>) -> Result<(), String> {
        let same = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
        if same(&values, &self.values) {
            return Ok(());
        }
        let numbers = self.numbers(&values);
        let set = assignments(&self.parameters, &numbers);
        let simulator = load(&self.scenario, self.controlled, &set)?;
        let now = variables(&simulator, self.controlled, &self.parameters);
        let shape = |v: &Variable| (v.name.clone(), v.unit.clone(), v.reference);
        if !now.iter().map(shape).eq(self.variables.iter().map(shape)) {
            return Err(format!(
                "{}: changes the FMU's variables; make an FMU of the scenario with `twin fmu … \
                 --set` instead",
                set.join(" ")
            ));
        }
        (self.simulator, self.values) = (simulator, values);
        Ok(())
    }

    /// The parameters' values as the scenario's numbers.
    fn numbers(&self, values: &[f64]) -> Vec<Number> {
        (self.parameters.iter().zip(values))
            .map(|(p, &x)| match p.default {
                Number::Real(_) => Number::Real(x),
                Number::Integer(_) => Number::Integer(x as i32),
            })
            .collect()
    }

    fn variable(&self, integer: bool, reference: u32) -> Result<&Variable, String> {
        let index = if integer {
            self.integers.get(reference as usize)
        } else {
            (reference as usize)
                .checked_sub(1)
                .and_then(|i| self.reals.get(i))
        };
        let kind = if integer { "Integer" } else { "Real" };
        index
            .map(|&k| &self.variables[k])
            .ok_or_else(|| format!("no {kind} variable has value reference {reference}"))
    }

    pub fn get_real(&self, reference: u32) -> Result<f64, String> {
        let simulator = &self.simulator;
        Ok(match self.variable(false, reference)?.role {
            Role::Effort(a) => self.inputs[a],
            Role::Setpoint(k) => self.inputs[k],
            Role::Disturbance(j) => self.inputs[3 + j],
            Role::Measured(i) => simulator.measured()[i],
            Role::True(i) => simulator.true_signals()[i],
            Role::Commanded(a) => simulator.commanded()[a],
            Role::Internal(i) => simulator.internals()[i],
            Role::Parameter(p) => self.values[p],
            Role::Seed => f64::from(self.seed),
        })
    }

    /// An input (finite), or a Real parameter before the initialization ends.
    pub fn set_real(&mut self, reference: u32, value: f64) -> Result<(), String> {
        let variable = self.variable(false, reference)?;
        let slot = match variable.role {
            Role::Parameter(p) => return self.set_parameter(p, value),
            Role::Effort(a) => a,
            Role::Setpoint(k) => k,
            Role::Disturbance(j) => 3 + j,
            _ => {
                return Err(format!(
                    "{} (value reference {reference}) is an output; only inputs and parameters \
                     can be set",
                    variable.name
                ))
            }
        };
        if !value.is_finite() {
            return Err(match variable.role {
                Role::Effort(a) => format!(
                    "effort of actuator `{}` is {value}: must be a finite number",
                    self.simulator.actuators()[a].joint
                ),
                _ => format!("{} is {value}: must be a finite number", variable.name),
            });
        }
        self.inputs[slot] = value;
        Ok(())
    }

    /// A parameter, applied through the scenario's `--set` path; fixed once initialized.
    fn set_parameter(&mut self, p: usize, value: f64) -> Result<(), String> {
        let name = &self.parameters[p].name;
        if !matches!(self.phase, Phase::Instantiated | Phase::Initializing) {
            return Err(format!(
                "{name} is fixed: set it before fmi2ExitInitializationMode"
            ));
        }
        let mut values = self.values.clone();
        values[p] = value;
        self.rebuild(values)
    }

    pub fn get_integer(&self, reference: u32) -> Result<i32, String> {
        Ok(match self.variable(true, reference)?.role {
            Role::Parameter(p) => self.values[p] as i32,
            _ => self.seed,
        })
    }

    /// The seed or an Integer parameter, before the initialization mode ends (they are `fixed`).
    pub fn set_integer(&mut self, reference: u32, value: i32) -> Result<(), String> {
        let variable = self.variable(true, reference)?;
        if !matches!(self.phase, Phase::Instantiated | Phase::Initializing) {
            return Err(format!(
                "{} is fixed: set it before fmi2ExitInitializationMode",
                variable.name
            ));
        }
        match variable.role {
            Role::Parameter(p) => self.set_parameter(p, f64::from(value)),
            _ if value < 0 => Err(format!("seed = {value}: must be ≥ 0")),
            _ => {
                self.seed = value;
                Ok(())
            }
        }
    }

    /// fmi2DoStep: from `time` by `size`, in whole control periods (each of the scenario's `dt`
    /// substeps) with the inputs held.
    pub fn do_step(&mut self, time: f64, size: f64) -> Result<(), String> {
        if self.phase != Phase::Stepping {
            return Err(
                "fmi2DoStep before fmi2ExitInitializationMode or after fmi2Terminate".into(),
            );
        }
        let period = self.simulator.scenario().control_period();
        let now = self.simulator.time();
        if (time - now).abs() > 1e-6 * period {
            return Err(format!(
                "currentCommunicationPoint {time} s is not the FMU's time {now} s"
            ));
        }
        let periods = (size / period).round();
        let scenario = self.simulator.scenario();
        let steps = periods * (period / scenario.dt).round();
        if steps > scenario.max_steps as f64 {
            return Err(format!(
                "communicationStepSize {size} s is {steps} physics steps, beyond max_steps = {}; \
                 take smaller steps",
                scenario.max_steps
            ));
        }
        if size.is_nan() || periods < 1.0 || (periods * period - size).abs() > 1e-6 * period {
            return Err(format!(
                "communicationStepSize {size} s is not a whole multiple of the scenario's control \
                 period {period} s (inputs change only at control updates); use a multiple of it"
            ));
        }
        (0..periods as u64).try_for_each(|_| self.period())
    }

    /// One control period with the inputs now, remembered in the history.
    fn period(&mut self) -> Result<(), String> {
        self.history.push(&self.inputs);
        let stepped = if self.controlled {
            let offset = [self.inputs[0], self.inputs[1], self.inputs[2]];
            self.simulator.step_closed_loop(&self.inputs[3..], offset)
        } else {
            self.simulator.step(&self.inputs)
        };
        stepped.map(|_| ()).map_err(|e| e.to_string())
    }

    /// The instance's state (fmi2GetFMUstate).
    pub fn state(&self) -> State {
        State {
            guid: self.guid.clone(),
            parameters: self.numbers(&self.values),
            seed: self.seed,
            inputs: self.inputs.clone(),
            history: self.history.clone(),
        }
    }

    /// Back to `state` (fmi2SetFMUstate): its parameters and seed, then its periods replayed —
    /// from t = 0, or from now when the state continues the history so far.
    pub fn set_state(&mut self, state: &State) -> Result<(), String> {
        if state.guid != self.guid {
            return Err(format!(
                "the FMU state is of another FMU (GUID {}, this one {})",
                state.guid, self.guid
            ));
        }
        let values: Vec<f64> = state.parameters.iter().map(|&n| real(n)).collect();
        let fits = values.len() == self.values.len()
            && state.inputs.len() == self.inputs.len()
            && state.history.fits(self.inputs.len());
        if !fits || state.seed < 0 {
            return Err("the FMU state does not fit this FMU's variables".into());
        }
        let same = state.seed == self.seed
            && (values.iter().zip(&self.values)).all(|(a, b)| a.to_bits() == b.to_bits());
        let shared = if same {
            self.history.shared(&state.history)
        } else {
            0
        };
        if !same || shared < self.history.periods() {
            self.rebuild(values)?;
            self.seed = state.seed;
            self.restart()?;
        }
        let from = self.history.periods();
        for (periods, inputs) in state.history.after(from) {
            self.inputs.copy_from_slice(inputs);
            // A period refused here (a divergence) was refused when first stepped too.
            for _ in 0..periods {
                let _ = self.period();
            }
        }
        self.inputs.copy_from_slice(&state.inputs);
        Ok(())
    }
}

/// The FMU's simulator of the packed scenario with the `set` assignments applied.
fn load(
    (text, file, folder): &(String, String, PathBuf),
    controlled: bool,
    set: &[String],
) -> Result<Simulator, String> {
    let overrides = Overrides {
        set: set.to_vec(),
        ..Overrides::default()
    };
    let registry = controllers::builtin();
    let loaded = Scenario::from_toml(text, file, Some(folder))
        .and_then(|s| s.overrides(&overrides))
        .and_then(|s| s.build(&registry))
        .map_err(|e| e.to_string())?;
    simulator(loaded, controlled, &registry).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::description::SEED;

    /// A resources/ folder as `twin fmu` writes it (the scenario's TOML with `urdf = "urdf/…"`,
    /// the FMU's kind) and its GUID.
    fn resources(name: &str, controlled: bool) -> (tempfile::TempDir, String, String) {
        let loaded = Scenario::builtin(name)
            .and_then(|s| s.build(&controllers::builtin()))
            .unwrap();
        let dir = tempfile::tempdir().unwrap();
        let mut table: toml::Table = toml::from_str(&loaded.toml).unwrap();
        table.insert("urdf".into(), "urdf/model.urdf".into());
        std::fs::create_dir(dir.path().join("urdf")).unwrap();
        std::fs::write(dir.path().join("urdf/model.urdf"), &loaded.urdf_text).unwrap();
        let text = toml::to_string(&table).unwrap();
        std::fs::write(dir.path().join(SCENARIO_FILE), &text).unwrap();
        let kind = format!("controller = {controlled}\n");
        std::fs::write(dir.path().join(KIND_FILE), kind).unwrap();
        let simulator = simulator(loaded, controlled, &controllers::builtin()).unwrap();
        let variables = variables(
            &simulator,
            controlled,
            &parameters(&text, &simulator, controlled),
        );
        let (_, guid) = model_description(&simulator, &variables, controlled);
        let uri = format!("file://{}", dir.path().display()).replace(' ', "%20");
        (dir, uri, guid)
    }

    /// The value reference of the variable called `name`.
    fn reference(instance: &Instance, name: &str) -> u32 {
        let variable = instance.variables.iter().find(|v| v.name == name);
        variable.unwrap_or_else(|| panic!("no {name}")).reference
    }

    fn started(instance: &mut Instance) {
        instance.restart().unwrap();
        instance.phase = Phase::Stepping;
    }

    #[test]
    fn resource_uris_are_read_as_folders() {
        let folder = |uri: &str| resource_folder(uri).map(|p| p.display().to_string());
        assert_eq!(
            folder("file:///a/b%20c/resources"),
            Ok("/a/b c/resources".into())
        );
        assert_eq!(folder("file://localhost/a/r"), Ok("/a/r".into()));
        assert_eq!(folder("file:/a/r"), Ok("/a/r".into()));
        let error = folder("http://host/a").unwrap_err();
        assert_eq!(
            error,
            "resourceLocation `http://host/a` is not a file:// URI of a folder"
        );
    }

    #[test]
    fn a_plant_instance_checks_its_guid_inputs_and_steps() {
        let (_dir, uri, guid) = resources("whitworth-crank-pi", false);
        let error = Instance::new(&uri, "{other}").err().unwrap();
        assert!(
            error.starts_with(&format!("fmuGUID {{other}} is not this FMU's {guid}")),
            "{error}"
        );
        let mut instance = Instance::new(&uri, &guid).unwrap();
        let refused = instance.do_step(0.0, 0.001).unwrap_err();
        assert!(
            refused.contains("before fmi2ExitInitializationMode"),
            "{refused}"
        );
        started(&mut instance);
        let crank = reference(&instance, "effort.crank");
        let error = instance.set_real(crank, f64::NAN).unwrap_err();
        assert_eq!(
            error,
            "effort of actuator `crank` is NaN: must be a finite number"
        );
        let output = reference(&instance, "measured.crank.position");
        assert!(instance
            .set_real(output, 1.0)
            .unwrap_err()
            .contains("is an output"));
        assert_eq!(
            instance.set_integer(SEED, 3).unwrap_err(),
            "seed is fixed: set it before fmi2ExitInitializationMode"
        );
        for size in [0.0015, 0.0, -0.001, f64::NAN, f64::INFINITY] {
            assert!(instance.do_step(0.0, size).is_err(), "{size}");
        }
        assert_eq!(
            instance.simulator.time(),
            0.0,
            "refused steps do not advance"
        );
        instance.set_real(crank, 5.0).unwrap();
        instance.do_step(0.0, 0.003).unwrap();
        assert_eq!(instance.simulator.time(), 0.003);
        assert!(instance
            .do_step(0.002, 0.001)
            .unwrap_err()
            .contains("is not the FMU's time"));
        let velocity = reference(&instance, "true.crank.velocity");
        assert!(
            instance.get_real(velocity).unwrap().abs() > 0.0,
            "the crank turned"
        );
        instance.reset().unwrap();
        assert_eq!(
            (instance.simulator.time(), instance.get_real(crank)),
            (0.0, Ok(0.0))
        );
    }

    /// `periods` control periods of the closed loop with no input, the measured signals after
    /// each.
    fn closed_loop(simulator: &mut Simulator, periods: usize) -> Vec<Vec<f64>> {
        let joints = simulator.joints().len();
        (0..periods)
            .map(|_| {
                let measured = simulator.step_closed_loop(&vec![0.0; joints], [0.0; 3]);
                measured.unwrap().to_vec()
            })
            .collect()
    }

    #[test]
    fn a_parameter_acts_as_the_same_set_does_and_a_bad_one_is_refused_by_key() {
        let (_dir, uri, guid) = resources("feed-axis-micromilling", true);
        let mut instance = Instance::new(&uri, &guid).unwrap();
        let gain = reference(&instance, "controller.params.position_gain");
        assert_eq!(instance.get_real(gain), Ok(30.0));
        instance.set_real(gain, 60.0).unwrap();
        let mass = reference(&instance, "controller.params.mass_estimate");
        let refused = instance.set_real(mass, -1.0).unwrap_err();
        let builder = Scenario::builtin("feed-axis-micromilling").unwrap();
        let from_set = (builder.clone())
            .assign("controller.params.mass_estimate=-1.0")
            .and_then(|s| s.build(&controllers::builtin()))
            .unwrap_err()
            .to_string();
        let reason = |message: &str| message.split_once(": ").unwrap().1.to_string();
        assert_eq!(reason(&refused), reason(&from_set), "{refused}");
        assert!(
            refused.contains("controller.params.mass_estimate"),
            "{refused}"
        );
        assert_eq!(
            instance.get_real(mass),
            Ok(11.0),
            "a refused value is not kept"
        );
        let teeth = reference(&instance, "process.cut.teeth");
        assert_eq!(instance.get_integer(teeth), Ok(2));
        started(&mut instance);
        assert_eq!(
            instance.set_real(gain, 1.0).unwrap_err(),
            "controller.params.position_gain is fixed: set it before fmi2ExitInitializationMode"
        );
        instance.do_step(0.0, 0.02).unwrap();
        let set = builder
            .assign("controller.params.position_gain=60.0")
            .unwrap();
        let loaded = set.build(&controllers::builtin()).unwrap();
        let mut direct = Simulator::with_controller(loaded, &controllers::builtin()).unwrap();
        let expected = closed_loop(&mut direct, 200);
        assert_eq!(
            instance.simulator.measured(),
            &expected[199][..],
            "bit for bit"
        );
        instance.reset().unwrap();
        assert_eq!(instance.get_real(gain), Ok(30.0), "fmi2Reset: start values");
    }

    /// The outputs after each of `periods` periods with the disturbance `load` on the table.
    fn outputs(instance: &mut Instance, load: f64, periods: usize) -> Vec<Vec<f64>> {
        let table = reference(instance, "disturbance.table");
        instance.set_real(table, load).unwrap();
        let period = instance.simulator.scenario().control_period();
        let count = instance.reals.len() as u32;
        (0..periods)
            .map(|_| {
                let time = instance.simulator.time();
                instance.do_step(time, period).unwrap();
                (1..=count).map(|r| instance.get_real(r).unwrap()).collect()
            })
            .collect()
    }

    #[test]
    fn a_state_set_again_gives_the_same_outputs_bit_for_bit() {
        let (_dir, uri, guid) = resources("feed-axis-micromilling", true);
        let mut instance = Instance::new(&uri, &guid).unwrap();
        started(&mut instance);
        outputs(&mut instance, 2.0, 30);
        let state = instance.state();
        let first = [
            outputs(&mut instance, -3.0, 20),
            outputs(&mut instance, 0.5, 20),
        ];
        let later = instance.state();
        instance.set_state(&state).unwrap();
        assert_eq!(
            instance.simulator.time(),
            state.history.periods() as f64 * 1e-4
        );
        let again = [
            outputs(&mut instance, -3.0, 20),
            outputs(&mut instance, 0.5, 20),
        ];
        assert_eq!(first, again);
        // Forward again, through the serialized state.
        let bytes = later.to_bytes();
        instance
            .set_state(&State::from_bytes(&bytes).unwrap())
            .unwrap();
        assert_eq!(instance.state(), later);
        let mut other = later.clone();
        other.guid = "{x}".into();
        assert!(instance
            .set_state(&other)
            .unwrap_err()
            .contains("another FMU"));
    }
}
