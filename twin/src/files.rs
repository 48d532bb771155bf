//! Reading the user's input files (scenarios, URDFs, meshes): bounded in size, UTF-8 text, and
//! the vertices of STL and OBJ meshes.

use std::path::Path;

/// Largest scenario, URDF or mesh file read, bytes: far above any real one, and it keeps
/// `/dev/zero` or a mistaken multi-gigabyte path from eating the memory.
pub const MAX_INPUT_BYTES: u64 = 8 << 20;
/// Reads a text file of at most [`MAX_INPUT_BYTES`] (a device or huge file is refused, not read
/// to the end).
pub fn read_text(path: &Path) -> Result<String, String> {
    let bytes = read_bytes(path).map_err(|reason| match reason {
        Bounded::TooLarge => format!(
            "larger than {} MiB; not a scenario or URDF file",
            MAX_INPUT_BYTES >> 20
        ),
        Bounded::Io(reason) => reason,
    })?;
    String::from_utf8(bytes).map_err(|_| "not UTF-8 text".into())
}

/// Why a bounded read failed.
enum Bounded {
    TooLarge,
    Io(String),
}

/// The bytes of a file of at most [`MAX_INPUT_BYTES`].
fn read_bytes(path: &Path) -> Result<Vec<u8>, Bounded> {
    use std::io::Read;
    let io = |e: std::io::Error| Bounded::Io(e.to_string());
    let file = std::fs::File::open(path).map_err(io)?;
    if file.metadata().is_ok_and(|m| m.is_dir()) {
        return Err(Bounded::Io("is a directory".into()));
    }
    let mut bytes = Vec::new();
    file.take(MAX_INPUT_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(io)?;
    if bytes.len() as u64 > MAX_INPUT_BYTES {
        return Err(Bounded::TooLarge);
    }
    Ok(bytes)
}

/// The vertices of a mesh file, by its extension: STL (binary or ASCII) or Wavefront OBJ (its
/// `v` lines). Only the vertices are read: the twin uses a mesh's outline on the plane, the
/// convex hull of its vertices, for which faces do not matter. Fails on a file of another kind,
/// one without vertices, or a vertex that is not three finite numbers.
pub fn mesh_vertices(path: &Path) -> Result<Vec<[f64; 3]>, String> {
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if extension != "stl" && extension != "obj" {
        return Err(format!(
            "unsupported mesh format `.{extension}` (STL and OBJ are read)"
        ));
    }
    let bytes = read_bytes(path).map_err(|reason| match reason {
        Bounded::TooLarge => format!("larger than {} MiB", MAX_INPUT_BYTES >> 20),
        Bounded::Io(reason) => reason,
    })?;
    let vertices = if extension == "obj" {
        obj_vertices(&text(&bytes)?)?
    } else if let Some(vertices) = binary_stl_vertices(&bytes) {
        vertices
    } else {
        ascii_stl_vertices(&text(&bytes)?)?
    };
    if vertices.is_empty() {
        return Err("the mesh has no vertices".into());
    }
    if let Some(bad) = vertices.iter().find(|v| !v.iter().all(|c| c.is_finite())) {
        return Err(format!("a vertex is not finite: {bad:?}"));
    }
    Ok(vertices)
}

fn text(bytes: &[u8]) -> Result<String, String> {
    String::from_utf8(bytes.to_vec()).map_err(|_| {
        "neither a binary STL (its size does not match its triangle count) nor UTF-8 text".into()
    })
}

/// A binary STL: an 80-byte header, a little-endian u32 triangle count, then 50 bytes per
/// triangle (normal, three vertices as f32 triples, attribute). `None` when the size does not
/// match the count (an ASCII file, which may also begin with `solid`).
fn binary_stl_vertices(bytes: &[u8]) -> Option<Vec<[f64; 3]>> {
    const HEADER: usize = 84;
    const TRIANGLE: usize = 50;
    let count = u32::from_le_bytes(bytes.get(80..HEADER)?.try_into().ok()?) as usize;
    if bytes.len() != HEADER.checked_add(count.checked_mul(TRIANGLE)?)? {
        return None;
    }
    let float =
        |at: usize| f32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    Some(
        (0..count)
            .flat_map(|t| (1..4).map(move |v| HEADER + t * TRIANGLE + 12 * v))
            .map(|at| [float(at), float(at + 4), float(at + 8)].map(f64::from))
            .collect(),
    )
}

/// An ASCII STL: every `vertex x y z` line.
fn ascii_stl_vertices(text: &str) -> Result<Vec<[f64; 3]>, String> {
    if !text.trim_start().starts_with("solid") {
        return Err("not an STL file: neither binary nor ASCII (`solid …`)".into());
    }
    text.lines()
        .enumerate()
        .filter_map(|(i, line)| {
            let mut words = line.split_whitespace();
            (words.next() == Some("vertex")).then(|| triple(words, i + 1))
        })
        .collect()
}

/// A Wavefront OBJ: every `v x y z [w]` line.
fn obj_vertices(text: &str) -> Result<Vec<[f64; 3]>, String> {
    text.lines()
        .enumerate()
        .filter_map(|(i, line)| {
            let mut words = line.split_whitespace();
            (words.next() == Some("v")).then(|| triple(words, i + 1))
        })
        .collect()
}

/// The first three words as numbers.
fn triple<'a>(mut words: impl Iterator<Item = &'a str>, line: usize) -> Result<[f64; 3], String> {
    let mut value = || -> Result<f64, String> {
        let word = words.next().unwrap_or("");
        word.parse::<f64>()
            .map_err(|_| format!("line {line}: `{word}` is not a vertex coordinate"))
    };
    Ok([value()?, value()?, value()?])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(name: &str, bytes: &[u8]) -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join(name), bytes).unwrap();
        dir
    }

    #[test]
    fn binary_and_ascii_stl_and_obj_give_their_vertices() {
        let mut binary = vec![0u8; 80];
        binary.extend_from_slice(&1u32.to_le_bytes());
        for value in [
            0.0f32, 0.0, 1.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0,
        ] {
            binary.extend_from_slice(&value.to_le_bytes());
        }
        binary.extend_from_slice(&[0, 0]);
        let dir = write("a.STL", &binary);
        let vertices = mesh_vertices(&dir.path().join("a.STL")).unwrap();
        assert_eq!(
            vertices,
            vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0]]
        );

        let ascii = "solid s\nfacet normal 0 0 1\nouter loop\nvertex 1 2 3\n  vertex -1 0 0.5\nvertex 0 1e-3 2\nendloop\nendfacet\nendsolid s\n";
        let dir = write("b.stl", ascii.as_bytes());
        let vertices = mesh_vertices(&dir.path().join("b.stl")).unwrap();
        assert_eq!(
            vertices,
            vec![[1.0, 2.0, 3.0], [-1.0, 0.0, 0.5], [0.0, 1e-3, 2.0]]
        );

        let obj = "# cube corner\no c\nv 0 0 0\nv 1 0 0 1.0\nvn 0 0 1\nv 0 1 0\nf 1 2 3\n";
        let dir = write("c.obj", obj.as_bytes());
        let vertices = mesh_vertices(&dir.path().join("c.obj")).unwrap();
        assert_eq!(vertices, vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    }

    #[test]
    fn bad_meshes_are_refused_with_a_reason() {
        let cases: [(&str, &[u8], &str); 5] = [
            ("a.dae", b"<COLLADA/>", "unsupported mesh format `.dae`"),
            ("b.stl", b"\xff\xfe binary junk", "neither a binary STL"),
            ("c.stl", b"hello", "not an STL file"),
            ("d.obj", b"v 1 nan-ish 2\n", "line 1: `nan-ish`"),
            ("e.obj", b"# nothing\n", "no vertices"),
        ];
        for (name, bytes, expected) in cases {
            let dir = write(name, bytes);
            let err = mesh_vertices(&dir.path().join(name)).unwrap_err();
            assert!(err.contains(expected), "{name}: {err}");
        }
        let dir = write("f.obj", b"v 1 inf 2\n");
        let err = mesh_vertices(&dir.path().join("f.obj")).unwrap_err();
        assert!(err.contains("not finite"), "{err}");
        let err = mesh_vertices(Path::new("/no/such/mesh.stl")).unwrap_err();
        assert!(err.contains("No such file"), "{err}");
    }
}
