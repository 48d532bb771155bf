//! `frf.csv`: one line per frequency, `frequency_hz,magnitude,phase_deg,coherence,real,imag`
//! (magnitude, real and imaginary parts in SI output unit per input unit, e.g. m/N); written in
//! full precision (Rust's shortest round-trip form) and read back with every fault located.

use super::estimate::{Complex, FrfLine};
use std::fmt::Write as _;
use std::path::Path;

pub const HEADER: &str = "frequency_hz,magnitude,phase_deg,coherence,real,imag";
/// Largest FRF file read (a million lines at most).
const MAX_BYTES: u64 = 64 << 20;

/// The CSV text of `frf`.
pub fn to_csv(frf: &[FrfLine]) -> String {
    let mut out = format!("{HEADER}\n");
    for line in frf {
        let h = line.response;
        let _ = writeln!(
            out,
            "{},{},{},{},{},{}",
            line.frequency_hz,
            h.abs(),
            h.arg().to_degrees(),
            line.coherence,
            h.re,
            h.im
        );
    }
    out
}

/// Reads an FRF file as written by `twin frf`: the header, then ascending frequencies with
/// finite values (the response from `real`, `imag`). Errors name the file, line and column.
pub fn read_csv(path: &Path) -> Result<Vec<FrfLine>, String> {
    let shown = path.display();
    let size = std::fs::metadata(path)
        .map_err(|e| format!("{shown}: cannot read: {e}"))?
        .len();
    if size > MAX_BYTES {
        return Err(format!(
            "{shown}: {size} bytes, more than the {MAX_BYTES} an FRF file may have"
        ));
    }
    let text = std::fs::read_to_string(path).map_err(|e| format!("{shown}: cannot read: {e}"))?;
    let mut lines = text.lines();
    let header = lines.next().unwrap_or("").trim();
    if header != HEADER {
        return Err(format!(
            "{shown}:1: the header must be `{HEADER}`, got `{header}`"
        ));
    }
    let mut frf = Vec::new();
    for (i, line) in lines.enumerate() {
        let number = i + 2;
        if line.trim().is_empty() {
            continue;
        }
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() != 6 {
            return Err(format!(
                "{shown}:{number}: {} columns, 6 expected ({HEADER})",
                fields.len()
            ));
        }
        let mut values = [0.0; 6];
        for (c, (field, value)) in fields.iter().zip(&mut values).enumerate() {
            *value = field
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    let name = HEADER.split(',').nth(c).unwrap_or("?");
                    format!(
                        "{shown}:{number}: column {} ({name}): `{}` is not a finite number",
                        c + 1,
                        field.trim()
                    )
                })?;
        }
        let last = frf.last().map_or(-1.0, |l: &FrfLine| l.frequency_hz);
        if !(values[0] >= 0.0 && values[0] > last) {
            return Err(format!(
                "{shown}:{number}: column 1 (frequency_hz): {} must be ≥ 0 and above the line \
                 before's {last}",
                values[0]
            ));
        }
        frf.push(FrfLine {
            frequency_hz: values[0],
            response: Complex::new(values[4], values[5]),
            coherence: values[3],
        });
    }
    if frf.is_empty() {
        return Err(format!("{shown}: no frequency lines after the header"));
    }
    Ok(frf)
}
