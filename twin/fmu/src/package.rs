//! The .fmu file: modelDescription.xml, the shared library under binaries/linux64/ and the
//! scenario with its URDF and the FMU's kind under resources/, in a zip archive (stored, not
//! compressed).

use crate::closed_loop::simulator;
use crate::description::{model_description, model_identifier, variables};
use crate::error::FmuError;
use crate::parameters::parameters;
use framework::Registry;
use std::path::Path;
use twin::LoadedScenario;

/// The scenario file inside resources/.
pub const SCENARIO_FILE: &str = "scenario.toml";

/// The FMU's kind inside resources/: `controller = true` when the scenario's controller is in
/// the loop.
pub const KIND_FILE: &str = "fmu.toml";

/// What was packed.
pub struct Packed {
    pub model_identifier: String,
    /// The controller in the loop, `None` for the plant alone.
    pub controller: Option<String>,
    pub guid: String,
    pub bytes: usize,
}

/// The FMU of `loaded`'s plant, or with `controlled` of its closed loop with its controller
/// (built from `registry`), with `library` (the built twin-fmu shared library), as bytes.
pub fn package(
    loaded: LoadedScenario,
    controlled: bool,
    registry: &Registry,
    library: &Path,
) -> Result<(Vec<u8>, Packed), FmuError> {
    let urdf_name = Path::new(&loaded.urdf_source)
        .file_name()
        .and_then(|n| n.to_str())
        .filter(|n| n.ends_with(".urdf"))
        .unwrap_or("model.urdf")
        .to_string();
    let mut table: toml::Table = toml::from_str(&loaded.toml)
        .map_err(|e| FmuError::Scenario(format!("{}: {e}", loaded.source)))?;
    table.insert("urdf".into(), format!("urdf/{urdf_name}").into());
    let scenario_text = toml::to_string(&table)
        .map_err(|e| FmuError::Scenario(format!("{}: {e}", loaded.source)))?;
    let (urdf_text, toml) = (loaded.urdf_text.clone(), loaded.toml.clone());
    let simulator =
        simulator(loaded, controlled, registry).map_err(|e| FmuError::Scenario(e.to_string()))?;
    let variables = variables(
        &simulator,
        controlled,
        &parameters(&toml, &simulator, controlled),
    );
    let (xml, guid) = model_description(&simulator, &variables, controlled);
    let id = model_identifier(&simulator.scenario().name);
    let shared = std::fs::read(library).map_err(|e| FmuError::Library {
        path: library.display().to_string(),
        reason: e.to_string(),
    })?;
    let mut zip = Zip::default();
    zip.add("modelDescription.xml", xml.as_bytes());
    zip.add(&format!("binaries/linux64/{id}.so"), &shared);
    zip.add(
        &format!("resources/{SCENARIO_FILE}"),
        scenario_text.as_bytes(),
    );
    zip.add(&format!("resources/urdf/{urdf_name}"), urdf_text.as_bytes());
    let kind = format!("controller = {controlled}\n");
    zip.add(&format!("resources/{KIND_FILE}"), kind.as_bytes());
    let bytes = zip.finish();
    let packed = Packed {
        model_identifier: id,
        controller: controlled.then(|| simulator.controller().to_string()),
        guid,
        bytes: bytes.len(),
    };
    Ok((bytes, packed))
}

/// A zip archive of stored entries (APPNOTE 6.3: local headers, central directory, end record),
/// with a fixed date so that the same inputs give the same bytes.
#[derive(Default)]
struct Zip {
    bytes: Vec<u8>,
    central: Vec<u8>,
    entries: u16,
}

impl Zip {
    fn add(&mut self, name: &str, data: &[u8]) {
        let offset = self.bytes.len() as u32;
        let crc = crc32fast::hash(data);
        let size = data.len() as u32;
        // Version 2.0, no flags, stored, 1980-01-01 00:00.
        let common = |out: &mut Vec<u8>| {
            for v in [20u16, 0, 0, 0, 0x21] {
                out.extend(v.to_le_bytes());
            }
            out.extend(crc.to_le_bytes());
            out.extend(size.to_le_bytes());
            out.extend(size.to_le_bytes());
            out.extend((name.len() as u16).to_le_bytes());
            out.extend(0u16.to_le_bytes());
        };
        self.bytes.extend(0x0403_4b50u32.to_le_bytes());
        common(&mut self.bytes);
        self.bytes.extend(name.as_bytes());
        self.bytes.extend(data);
        self.central.extend(0x0201_4b50u32.to_le_bytes());
        self.central.extend(20u16.to_le_bytes());
        common(&mut self.central);
        // Comment length, disk, internal and external attributes, local header offset.
        self.central.extend([0u8; 10]);
        self.central.extend(offset.to_le_bytes());
        self.central.extend(name.as_bytes());
        self.entries += 1;
    }

    fn finish(mut self) -> Vec<u8> {
        let start = self.bytes.len() as u32;
        let size = self.central.len() as u32;
        self.bytes.extend(&self.central);
        self.bytes.extend(0x0605_4b50u32.to_le_bytes());
        self.bytes.extend([0u8; 4]);
        self.bytes.extend(self.entries.to_le_bytes());
        self.bytes.extend(self.entries.to_le_bytes());
        self.bytes.extend(size.to_le_bytes());
        self.bytes.extend(start.to_le_bytes());
        self.bytes.extend(0u16.to_le_bytes());
        self.bytes
    }
}
