use super::*;
use std::time::Instant;

fn scratch_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("twin-recording-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch dir");
    dir
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

/// The `rerun` CLI, when available: `$TWIN_RERUN_CLI`, the project's venv, or `rerun` on PATH.
fn rerun_cli() -> Option<PathBuf> {
    let candidates = std::env::var_os("TWIN_RERUN_CLI")
        .map(PathBuf::from)
        .into_iter()
        .chain([
            PathBuf::from("/root/.cache/twin/rerun-venv/bin/rerun"),
            PathBuf::from("rerun"),
        ]);
    for cli in candidates {
        let ok = std::process::Command::new(&cli)
            .arg("--version")
            .output()
            .is_ok_and(|out| out.status.success());
        if ok {
            return Some(cli);
        }
    }
    None
}

/// Runs `rerun rrd verify` on the file when the CLI is available; prints a note otherwise.
fn verify(path: &Path) {
    let Some(cli) = rerun_cli() else {
        eprintln!(
            "note: rerun CLI not found, `rerun rrd verify {}` skipped",
            path.display()
        );
        return;
    };
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
    std::fs::remove_dir_all(&dir).ok();
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
    std::fs::remove_dir_all(&dir).ok();
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
    std::fs::remove_dir_all(&dir).ok();
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
    std::fs::remove_dir_all(&dir).ok();
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
    let start = Instant::now();
    let mut rec = Recorder::create(&path, &layout).expect("create");
    let created = start.elapsed();
    let mut values = vec![0.0; 30];
    let mut link_poses = poses(5, 0.0);
    let pushing = Instant::now();
    for step in 0..SAMPLES {
        let t = step as f64 * 1e-3;
        for (k, v) in values.iter_mut().enumerate() {
            *v = (t * (k + 1) as f64).sin();
        }
        for (i, pose) in link_poses.iter_mut().enumerate() {
            *pose = Pose2::new(i as f64 * 0.1 + t.cos(), t.sin(), 10.0 * t);
        }
        rec.push(step, t, &link_poses, &values);
    }
    let pushed = pushing.elapsed();
    let finishing = Instant::now();
    rec.finish().expect("finish");
    let finished = finishing.elapsed();
    let total = start.elapsed();
    let len = std::fs::metadata(&path).expect("file").len();
    let peak = std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM"))
                .map(|l| l.split_whitespace().nth(1).unwrap_or("?").to_owned() + " kB")
        })
        .unwrap_or_else(|| "?".to_owned());
    eprintln!(
        "{SAMPLES} samples x 30 values + 5 poses ({} build): create {:?}, push {:?} \
         ({:.2} µs/sample), finish {:?}, total {:?}; file {:.1} MB; process peak RSS {peak}",
        if cfg!(debug_assertions) {
            "debug"
        } else {
            "release"
        },
        created,
        pushed,
        pushed.as_secs_f64() * 1e6 / SAMPLES as f64,
        finished,
        total,
        len as f64 / 1e6,
    );
    assert!(total.as_secs_f64() < 30.0, "recording took {total:?}");
    verify(&path);
    std::fs::remove_dir_all(&dir).ok();
}
