//! One FMU instance: the plant, its inputs and where it is in the FMI 2.0 life cycle.

use crate::description::{model_description, reals, Real, SEED};
use crate::package::SCENARIO_FILE;
use controllers::Registry;
use std::path::PathBuf;
use twin::{Overrides, Simulator};

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
    reals: Vec<Real>,
    efforts: Vec<f64>,
    seed: i32,
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

impl Instance {
    /// The plant of the scenario in `resources`, checked against the host's `guid`.
    pub fn new(resources: &str, guid: &str) -> Result<Self, String> {
        let folder = resource_folder(resources)?;
        let file = folder.join(SCENARIO_FILE);
        let file = file.to_str().ok_or("resource folder is not UTF-8")?;
        let loaded = twin::load_scenario(file, &Overrides::default(), &Registry::builtin())
            .map_err(|e| e.to_string())?;
        let simulator = Simulator::new(loaded).map_err(|e| e.to_string())?;
        let (_, own) = model_description(&simulator);
        if guid != own {
            return Err(format!(
                "fmuGUID {guid} is not this FMU's {own} (modelDescription.xml and the binary differ)"
            ));
        }
        let seed = i32::try_from(simulator.scenario().seed)
            .map_err(|_| "the scenario's seed does not fit an fmi2Integer".to_string())?;
        Ok(Self {
            reals: reals(&simulator),
            efforts: vec![0.0; simulator.actuators().len()],
            simulator,
            seed,
            phase: Phase::Instantiated,
        })
    }

    /// Back to the state after instantiation (fmi2Reset), the scenario's seed kept as set.
    pub fn reset(&mut self) -> Result<(), String> {
        self.efforts.fill(0.0);
        self.phase = Phase::Instantiated;
        self.restart()
    }

    /// The plant at t = 0 with the seed now set.
    pub fn restart(&mut self) -> Result<(), String> {
        let seed =
            u64::try_from(self.seed).map_err(|_| format!("seed = {}: must be ≥ 0", self.seed))?;
        self.simulator.reset(seed).map_err(|e| e.to_string())
    }

    fn real(&self, reference: u32) -> Result<Real, String> {
        let index = (reference as usize).checked_sub(1);
        index
            .and_then(|i| self.reals.get(i).copied())
            .ok_or_else(|| format!("no Real variable has value reference {reference}"))
    }

    pub fn get_real(&self, reference: u32) -> Result<f64, String> {
        Ok(match self.real(reference)? {
            Real::Effort(a) => self.efforts[a],
            Real::Measured(i) => self.simulator.measured()[i],
            Real::True(i) => self.simulator.true_signals()[i],
        })
    }

    /// An input effort; only the efforts can be set, and only to finite values.
    pub fn set_real(&mut self, reference: u32, value: f64) -> Result<(), String> {
        match self.real(reference)? {
            Real::Effort(a) if value.is_finite() => {
                self.efforts[a] = value;
                Ok(())
            }
            Real::Effort(a) => Err(format!(
                "effort of actuator `{}` is {value}: must be a finite number",
                self.simulator.actuators()[a].joint
            )),
            _ => Err(format!(
                "value reference {reference} is an output; only the efforts can be set"
            )),
        }
    }

    pub fn get_integer(&self, reference: u32) -> Result<i32, String> {
        (reference == SEED)
            .then_some(self.seed)
            .ok_or_else(|| format!("no Integer variable has value reference {reference}"))
    }

    /// The seed, before the initialization mode ends (it is `fixed`).
    pub fn set_integer(&mut self, reference: u32, value: i32) -> Result<(), String> {
        if reference != SEED {
            return Err(format!(
                "no Integer variable has value reference {reference}"
            ));
        }
        if !matches!(self.phase, Phase::Instantiated | Phase::Initializing) {
            return Err("seed is fixed: set it before fmi2ExitInitializationMode".into());
        }
        if value < 0 {
            return Err(format!("seed = {value}: must be ≥ 0"));
        }
        self.seed = value;
        Ok(())
    }

    /// fmi2DoStep: from `time` by `size`, in whole control periods (each of the scenario's `dt`
    /// substeps) with the efforts held.
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
                 period {period} s (efforts change only at control updates); use a multiple of it"
            ));
        }
        for _ in 0..periods as u64 {
            self.simulator
                .step(&self.efforts)
                .map_err(|e| e.to_string())?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::description::model_description;
    use twin::{Scenario, Simulator};

    /// A resources/ folder as `twin fmu` writes it (the scenario's TOML with `urdf = "urdf/…"`).
    fn resources(name: &str) -> (tempfile::TempDir, String, String) {
        let loaded = Scenario::builtin(name)
            .and_then(|s| s.build(&Registry::builtin()))
            .unwrap();
        let dir = tempfile::tempdir().unwrap();
        let mut table: toml::Table = toml::from_str(&loaded.toml).unwrap();
        table.insert("urdf".into(), "urdf/model.urdf".into());
        std::fs::create_dir(dir.path().join("urdf")).unwrap();
        std::fs::write(dir.path().join("urdf/model.urdf"), &loaded.urdf_text).unwrap();
        std::fs::write(
            dir.path().join(SCENARIO_FILE),
            toml::to_string(&table).unwrap(),
        )
        .unwrap();
        let (_, guid) = model_description(&Simulator::new(loaded).unwrap());
        let uri = format!("file://{}", dir.path().display()).replace(' ', "%20");
        (dir, uri, guid)
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
    fn an_instance_checks_its_guid_inputs_and_steps() {
        let (_dir, uri, guid) = resources("whitworth-crank-pi");
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
        instance.restart().unwrap();
        instance.phase = Phase::Stepping;
        let error = instance.set_real(1, f64::NAN).unwrap_err();
        assert_eq!(
            error,
            "effort of actuator `crank` is NaN: must be a finite number"
        );
        assert!(instance
            .set_real(2, 1.0)
            .unwrap_err()
            .contains("is an output"));
        assert!(instance
            .set_integer(SEED, 3)
            .unwrap_err()
            .contains("seed is fixed"));
        for size in [0.0015, 0.0, -0.001, f64::NAN, f64::INFINITY] {
            assert!(instance.do_step(0.0, size).is_err(), "{size}");
        }
        assert_eq!(
            instance.simulator.time(),
            0.0,
            "refused steps do not advance"
        );
        instance.set_real(1, 5.0).unwrap();
        instance.do_step(0.0, 0.003).unwrap();
        assert_eq!(instance.simulator.time(), 0.003);
        assert!(instance
            .do_step(0.002, 0.001)
            .unwrap_err()
            .contains("is not the FMU's time"));
        // The true crank.velocity, after the efforts and the measured signals.
        let true_velocity = 2 + instance.simulator.signal_specs().len() as u32 + 1;
        assert!(
            instance.get_real(true_velocity).unwrap().abs() > 0.0,
            "the crank turned"
        );
        instance.reset().unwrap();
        assert_eq!(
            (instance.simulator.time(), instance.get_real(1)),
            (0.0, Ok(0.0))
        );
    }
}
