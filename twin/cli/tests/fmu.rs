//! `twin fmu`: the .fmu archive on success (its entries, the GUID in its description, the same
//! bytes twice); every bad input a one-line error naming the argument or key, nothing on disk.
//! FMPy's checks of the FMUs are in twin/fmu/tests/test_fmpy.py.

mod common;

use common::twin;

fn scratch(test: &str) -> common::Scratch {
    let dir = common::scratch("fmu", test);
    // Stands for the shared library: the packing copies its bytes.
    std::fs::write(dir.join("lib.so"), b"\x7fELF stand-in").unwrap();
    dir
}

/// The names of a stored zip's entries, from its central directory.
fn entries(zip: &[u8]) -> Vec<String> {
    let end = zip.len() - 22;
    assert_eq!(&zip[end..end + 4], b"PK\x05\x06", "end record");
    let count = u16::from_le_bytes([zip[end + 10], zip[end + 11]]) as usize;
    let mut at = u32::from_le_bytes(zip[end + 16..end + 20].try_into().unwrap()) as usize;
    (0..count)
        .map(|_| {
            assert_eq!(&zip[at..at + 4], b"PK\x01\x02", "central entry");
            let len = u16::from_le_bytes([zip[at + 28], zip[at + 29]]) as usize;
            let name = String::from_utf8(zip[at + 46..at + 46 + len].to_vec()).unwrap();
            at += 46 + len;
            name
        })
        .collect()
}

/// `twin fmu feed-axis-micromilling --out OUT` with a stand-in library and `extra` arguments.
fn feed_axis_fmu(dir: &std::path::Path, out: &str, extra: &[&str]) -> std::process::Output {
    let args = [
        "fmu",
        "feed-axis-micromilling",
        "--out",
        out,
        "--library",
        "lib.so",
    ];
    twin(&[&args[..], extra].concat(), dir)
}

#[test]
fn an_fmu_holds_its_description_library_and_resources_and_is_reproducible() {
    let dir = scratch("ok");
    let output = feed_axis_fmu(&dir, "a.fmu", &[]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        stdout.contains("model identifier twin_feed_axis_micromilling"),
        "{stdout}"
    );
    let zip = std::fs::read(dir.join("a.fmu")).unwrap();
    assert_eq!(
        entries(&zip),
        [
            "modelDescription.xml",
            "binaries/linux64/twin_feed_axis_micromilling.so",
            "resources/scenario.toml",
            "resources/urdf/feed_axis.urdf",
            "resources/fmu.toml",
        ]
    );
    let text = String::from_utf8_lossy(&zip);
    let guid = stdout
        .split("GUID ")
        .nth(1)
        .unwrap()
        .split(',')
        .next()
        .unwrap();
    assert!(text.contains(&format!("guid=\"{guid}\"")), "{guid}");
    // The closed loop by default: a setpoint and a disturbance in, the controller's effort out.
    assert!(
        stdout.contains("closed loop with controller p-pi"),
        "{stdout}"
    );
    assert!(text.contains("controller = true"));
    for input in ["setpoint.reference", "disturbance.table"] {
        assert!(
            text.contains(&format!("name=\"{input}\" valueReference=\"")),
            "{input}"
        );
    }
    assert!(text.contains("name=\"effort.table\" valueReference=\"17\" causality=\"output\""));
    assert!(text.contains("urdf = \"urdf/feed_axis.urdf\""));
    assert!(feed_axis_fmu(&dir, "b.fmu", &[]).status.success());
    assert_eq!(
        zip,
        std::fs::read(dir.join("b.fmu")).unwrap(),
        "same inputs, same bytes"
    );
    assert!(feed_axis_fmu(&dir, "c.fmu", &["--set", "seed=7"])
        .status
        .success());
    let other = String::from_utf8_lossy(&std::fs::read(dir.join("c.fmu")).unwrap()).into_owned();
    assert!(
        other.contains("<Integer start=\"7\"/>") && !other.contains(&format!("guid=\"{guid}\""))
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_plant_alone_or_another_controller_is_asked_for_by_flag() {
    let dir = scratch("kinds");
    let made = |extra: &[&str], out: &str| {
        let mut args = vec![
            "fmu",
            "whitworth-crank-pi",
            "--library",
            "lib.so",
            "--out",
            out,
        ];
        args.extend(extra);
        let output = twin(&args, &dir);
        let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
        assert!(output.status.success(), "{args:?}");
        let text = String::from_utf8_lossy(&std::fs::read(dir.join(out)).unwrap()).into_owned();
        (stdout, text)
    };
    let (stdout, plant) = made(&["--no-controller"], "plant.fmu");
    assert!(stdout.contains("of the plant alone"), "{stdout}");
    assert!(plant.contains("controller = false"));
    assert!(plant.contains("name=\"effort.crank\" valueReference=\"1\" causality=\"input\""));
    assert!(!plant.contains("disturbance."));
    let (stdout, other) = made(&["--controller", "osmc"], "osmc.fmu");
    assert!(
        stdout.contains("closed loop with controller osmc"),
        "{stdout}"
    );
    assert!(other.contains("name=\"controller.sigma\""));
    assert!(other.contains("name=\"disturbance.ram\""));
    // The scenario's own parameters are dropped with its controller, as in `twin run`.
    assert!(!other.contains("controller.params.crank_speed"));
    let (_, own) = made(&[], "own.fmu");
    assert!(own.contains("name=\"controller.params.crank_speed\""));
    let output = twin(
        &[
            "fmu",
            "whitworth-crank-pi",
            "--library",
            "lib.so",
            "--out",
            "x.fmu",
            "--controller",
            "osmc",
            "--no-controller",
        ],
        &dir,
    );
    assert_eq!(output.status.code(), Some(2), "a usage error");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_inputs_are_one_line_errors_and_leave_nothing() {
    for (test, args, parts) in [
        (
            "lib",
            vec!["--library", "missing.so"],
            vec![
                "FMU library missing.so",
                "cargo build --release -p twin-fmu",
            ],
        ),
        (
            "set",
            vec!["--library", "lib.so", "--set", "dt=-1"],
            vec!["dt"],
        ),
        (
            "out",
            vec!["--library", "lib.so", "--out", "no/such/x.fmu"],
            vec!["--out", "no/such"],
        ),
        (
            "controller",
            vec!["--library", "lib.so", "--controller", "p-pi"],
            vec!["controller `p-pi` is written for machine `feed_axis`, not `whitworth`"],
        ),
    ] {
        let dir = scratch(test);
        let mut all = vec!["fmu", "whitworth-crank-pi"];
        if !args.contains(&"--out") {
            all.extend(["--out", "x.fmu"]);
        }
        all.extend(&args);
        let output = twin(&all, &dir);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{all:?}: {stderr}");
        assert_eq!(common::error_lines(stderr.trim()), 1, "{stderr}");
        for part in parts {
            assert!(stderr.contains(part), "{all:?}: {stderr} lacks {part}");
        }
        let left: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(left, ["lib.so"], "{all:?} left files");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
