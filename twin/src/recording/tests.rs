use super::*;
use std::time::Instant;

fn scratch_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("twin-recording-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch dir");
    dir
}

/// Removes a test's directory, unless `TWIN_KEEP_RECORDINGS` is set (to inspect the files).
fn cleanup(dir: &Path) {
    if std::env::var_os("TWIN_KEEP_RECORDINGS").is_none() {
        std::fs::remove_dir_all(dir).ok();
    } else {
        eprintln!("kept {}", dir.display());
    }
}

fn layout(links: usize, groups: &[(&str, usize)]) -> RecordingLayout {
    let shapes = |i: usize| {
        vec![
            Shape {
                origin: Pose2::new(0.1 * i as f64, 0.0, 0.0),
                outline: Outline::Rectangle {
                    width: 0.2,
                    height: 0.02,
                },
                color: Some([0.8, 0.2, 0.2, 1.0]),
            },
            Shape {
                origin: Pose2::IDENTITY,
                outline: Outline::Circle { radius: 0.015 },
                color: None,
            },
        ]
    };
    RecordingLayout {
        app: "recording_test".to_owned(),
        live: None,
        scenario_toml: "name = \"recording_test\"\n[run]\nduration = 1.0\n".to_owned(),
        links: (0..links)
            .map(|i| (format!("link {i}"), shapes(i)))
            .collect(),
        series: groups
            .iter()
            .map(|&(path, n)| SeriesGroup {
                path: path.to_owned(),
                names: (0..n).map(|k| format!("s{k}")).collect(),
            })
            .collect(),
    }
}

fn poses(links: usize, t: f64) -> Vec<Pose2> {
    (0..links)
        .map(|i| Pose2::new(0.1 * i as f64 + t.cos(), t.sin(), 3.0 * t + i as f64))
        .collect()
}

/// The `rerun` CLI: `$TWIN_RERUN_CLI` (set by `scripts/test-tools`), else `rerun` on PATH.
fn rerun_cli() -> PathBuf {
    let cli = std::env::var_os("TWIN_RERUN_CLI")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("rerun"));
    let ok = std::process::Command::new(&cli)
        .arg("--version")
        .output()
        .is_ok_and(|out| out.status.success());
    assert!(
        ok,
        "the Rerun CLI ({}) is needed to verify recordings: run `eval \"$(scripts/test-tools)\"`",
        cli.display()
    );
    cli
}

/// Runs `rerun rrd verify` on the file.
fn verify(path: &Path) {
    let cli = rerun_cli();
    let out = std::process::Command::new(&cli)
        .args(["rrd", "verify"])
        .arg(path)
        .output()
        .expect("run rerun rrd verify");
    assert!(
        out.status.success(),
        "rerun rrd verify {} failed:\n{}\n{}",
        path.display(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    eprintln!("rerun rrd verify {}: ok", path.display());
}

#[test]
fn records_samples_and_events_to_a_valid_file() {
    let dir = scratch_dir("roundtrip");
    let path = dir.join("run.rrd");
    let layout = layout(2, &[("joints/position", 2), ("effort/commanded", 1)]);
    let mut rec = Recorder::create(&path, &layout).expect("create");
    for step in 0..5000 {
        let t = step as f64 * 1e-3;
        rec.push(step, t, &poses(2, t), &[t.sin(), t.cos(), 2.0 * t]);
        if step == 2500 {
            rec.event(step, t, EventLevel::Warning, "effort saturated");
        }
    }
    rec.event(4999, 4.999, EventLevel::Info, "done");
    rec.finish().expect("finish");
    let len = std::fs::metadata(&path).expect("file exists").len();
    assert!(len > 0);
    verify(&path);
    cleanup(&dir);
}

#[test]
fn non_finite_values_and_poses_are_recorded() {
    let dir = scratch_dir("diverging");
    let path = dir.join("run.rrd");
    let layout = layout(1, &[("task", 2)]);
    let mut rec = Recorder::create(&path, &layout).expect("create");
    for step in 0..(FLUSH_EVERY as i64 + 100) {
        let t = step as f64 * 1e-3;
        let (value, pose) = if step < 3000 {
            (t, poses(1, t))
        } else {
            (f64::NAN, vec![Pose2::new(f64::INFINITY, f64::NAN, 1e300)])
        };
        rec.push(step, t, &pose, &[value, f64::NEG_INFINITY]);
    }
    rec.event(3000, 3.0, EventLevel::Error, "diverged");
    rec.finish().expect("finish");
    verify(&path);
    cleanup(&dir);
}

#[test]
fn dropping_without_finish_still_closes_the_file() {
    let dir = scratch_dir("dropped");
    let path = dir.join("run.rrd");
    {
        let mut rec = Recorder::create(&path, &layout(2, &[("process", 3)])).expect("create");
        for step in 0..1234 {
            let t = step as f64 * 1e-3;
            rec.push(step, t, &poses(2, t), &[1.0, 2.0, 3.0]);
        }
    }
    assert!(std::fs::metadata(&path).expect("file exists").len() > 0);
    verify(&path);
    cleanup(&dir);
}

#[test]
fn create_in_a_missing_directory_names_the_path() {
    let dir = scratch_dir("missing");
    let path = dir.join("no/such/dir/run.rrd");
    let err = match Recorder::create(&path, &layout(1, &[("task", 1)])) {
        Ok(_) => panic!("created a recording in a missing directory"),
        Err(err) => err,
    };
    match &err {
        RecordingError::Create { path: p, reason } => {
            assert_eq!(p, &path);
            assert!(!reason.is_empty());
        }
        other => panic!("unexpected error {other:?}"),
    }
    assert!(
        err.to_string().contains(&path.display().to_string()),
        "{err}"
    );
    eprintln!("{err}");
    cleanup(&dir);
}

#[test]
fn create_over_a_directory_names_the_path() {
    let dir = scratch_dir("is-a-directory");
    let err = match Recorder::create(&dir, &layout(1, &[("task", 1)])) {
        Ok(_) => panic!("created a recording over a directory"),
        Err(err) => err,
    };
    assert!(
        matches!(&err, RecordingError::Create { path, .. } if path == &dir),
        "{err:?}"
    );
    cleanup(&dir);
}

#[test]
fn an_empty_layout_records_a_valid_file() {
    let dir = scratch_dir("empty");
    let path = dir.join("run.rrd");
    let mut layout = layout(0, &[("nothing", 0)]);
    layout.app = String::new();
    layout.scenario_toml = String::new();
    let mut rec = Recorder::create(&path, &layout).expect("create");
    for step in 0..10 {
        rec.push(step, step as f64, &[], &[]);
    }
    rec.event(3, 3.0, EventLevel::Info, "nothing happens");
    rec.finish().expect("finish");
    verify(&path);
    cleanup(&dir);
}

#[test]
fn the_recorder_can_move_to_another_thread() {
    fn assert_send<T: Send>() {}
    assert_send::<Recorder>();
}

/// A `/proc/self/status` memory figure, kB (Linux).
fn memory_kb(key: &str) -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(key))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// CPU time of the calling thread, ns (Linux).
fn thread_cpu_ns() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    text.split_whitespace().next()?.parse().ok()
}

/// CPU time (user + system) of the whole process, ms (Linux, assuming 100 ticks per second).
fn process_cpu_ms() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/stat").ok()?;
    let fields: Vec<&str> = text.rsplit_once(')')?.1.split_whitespace().collect();
    let ticks: u64 = fields.get(11)?.parse::<u64>().ok()? + fields.get(12)?.parse::<u64>().ok()?;
    Some(ticks * 10)
}

/// Throughput of the recording path for a 60 s run at 1 kHz with 30 signals and 5 links.
#[test]
fn sixty_thousand_samples_are_cheap() {
    const SAMPLES: i64 = 60_000;
    let dir = scratch_dir("throughput");
    let path = dir.join("run.rrd");
    let layout = layout(
        5,
        &[
            ("joints/position", 6),
            ("joints/velocity", 6),
            ("effort/commanded", 4),
            ("effort/applied", 4),
            ("task", 4),
            ("controller", 4),
            ("process", 2),
        ],
    );
    // Inputs are computed beforehand so that only the recorder is timed.
    let inputs: Vec<(Vec<Pose2>, Vec<f64>)> = (0..SAMPLES)
        .map(|step| {
            let t = step as f64 * 1e-3;
            let values = (0..30).map(|k| (t * (k + 1) as f64).sin()).collect();
            let poses = (0..5)
                .map(|i| Pose2::new(i as f64 * 0.1 + t.cos(), t.sin(), 10.0 * t))
                .collect();
            (poses, values)
        })
        .collect();
    let rss_before = memory_kb("VmRSS");
    let cpu_start = (thread_cpu_ns(), process_cpu_ms());
    let start = Instant::now();
    let mut rec = Recorder::create(&path, &layout).expect("create");
    let created = start.elapsed();
    let pushing = Instant::now();
    let push_cpu_start = thread_cpu_ns();
    for (step, (link_poses, values)) in inputs.iter().enumerate() {
        rec.push(step as i64, step as f64 * 1e-3, link_poses, values);
    }
    let pushed = pushing.elapsed();
    let push_cpu = push_cpu_start
        .zip(thread_cpu_ns())
        .map(|(a, b)| (b - a) as f64 / 1e6);
    let finishing = Instant::now();
    rec.finish().expect("finish");
    let finished = finishing.elapsed();
    let total = start.elapsed();
    let thread_cpu = cpu_start
        .0
        .zip(thread_cpu_ns())
        .map(|(a, b)| (b - a) as f64 / 1e6);
    let process_cpu = cpu_start.1.zip(process_cpu_ms()).map(|(a, b)| b - a);
    let len = std::fs::metadata(&path).expect("file").len();
    let peak = memory_kb("VmHWM");
    eprintln!(
        "{SAMPLES} samples x 30 values + 5 poses ({} build): wall: create {created:?}, push \
         {pushed:?} ({:.2} µs/sample), finish {finished:?}, total {total:?}; CPU: push (calling \
         thread) {push_cpu:?} ms, whole recording (calling thread) {thread_cpu:?} ms, all threads \
         {process_cpu:?} ms; file {:.1} MB; memory: RSS before create (inputs built) {rss_before:?} kB, \
         process peak RSS {peak:?} kB",
        if cfg!(debug_assertions) {
            "debug"
        } else {
            "release"
        },
        pushed.as_secs_f64() * 1e6 / SAMPLES as f64,
        len as f64 / 1e6,
    );
    assert!(total.as_secs_f64() < 30.0, "recording took {total:?}");
    verify(&path);
    cleanup(&dir);
}

/// The hand-built pose columns equal what the `Transform3D` archetype serializes.
#[test]
fn pose_columns_match_the_archetype_serialization() {
    let translations = [0.5f32, -1.0, 0.0, 2.0, 3.5, 0.0, -0.25, 0.0, 0.0];
    let angles = [0.1f32, -3.0, 3.1];
    let ours = pose_columns(&translations, &angles).expect("columns");
    let reference: Vec<_> = Transform3D::update_fields()
        .with_many_translation(
            translations
                .chunks(3)
                .map(|p| Translation3D::new(p[0], p[1], p[2])),
        )
        .with_many_rotation_axis_angle(angles.iter().map(|&a| {
            RotationAxisAngle::new([0.0, 0.0, 1.0], rerun::datatypes::Angle::from_radians(a))
        }))
        .columns_of_unit_batches()
        .expect("reference columns")
        .collect();
    assert_eq!(reference.len(), 2);
    for (ours, reference) in ours.iter().zip(&reference) {
        assert_eq!(ours.descriptor, reference.descriptor);
        assert_eq!(ours.list_array, reference.list_array);
    }
}

#[test]
fn angles_are_wrapped_and_application_ids_sanitized() {
    use std::f64::consts::PI;
    assert_eq!(wrap_angle(0.5), 0.5);
    assert!((wrap_angle(2.0 * PI + 0.5) - 0.5).abs() < 1e-12);
    assert!((wrap_angle(-7.0 * PI + 0.25) - (-PI + 0.25)).abs() < 1e-9);
    assert_eq!(wrap_angle(PI), PI);
    assert!(wrap_angle(f64::NAN).is_nan());
    assert_eq!(application_id("slider crank").as_str(), "slider crank");
    assert_eq!(application_id("v1.2/run").as_str(), "v1-2-run");
    assert_eq!(application_id("").as_str(), "twin");
}
