//! Reading the user's input files (scenarios, URDFs, meshes): bounded in size, UTF-8 text.

use std::path::Path;

/// Largest scenario or URDF file read, bytes: far above any real one, and it keeps `/dev/zero`
/// or a mistaken multi-gigabyte path from eating the memory.
pub const MAX_INPUT_BYTES: u64 = 8 << 20;
/// Reads a text file of at most [`MAX_INPUT_BYTES`] (a device or huge file is refused, not read
/// to the end).
pub fn read_text(path: &Path) -> Result<String, String> {
    use std::io::Read;
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    if file.metadata().is_ok_and(|m| m.is_dir()) {
        return Err("is a directory".into());
    }
    let mut bytes = Vec::new();
    file.take(MAX_INPUT_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| e.to_string())?;
    if bytes.len() as u64 > MAX_INPUT_BYTES {
        return Err(format!(
            "larger than {} MiB; not a scenario or URDF file",
            MAX_INPUT_BYTES >> 20
        ));
    }
    String::from_utf8(bytes).map_err(|_| "not UTF-8 text".into())
}
