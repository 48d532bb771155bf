//! Studies: the run plan, reproducible single runs, failures recorded without stopping the
//! study, resume, shards merged byte-identical to one machine, and refusals before any run.

use std::path::{Path, PathBuf};
use twin::StopFlag;
use twin_cli::study::{merge, run_study, RecordMode, Shard, Spec, Study, StudyOptions};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("twin-study-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// OSMC and SMC2 on a short tracking run, the ram's mass drawn around its URDF value.
fn study(seed: u64) -> Study {
    Study::new(
        "whitworth-tracking",
        &["duration=0.6".into(), "metrics.0.from=0.1".into()],
        &["controller=osmc,smc2".into()],
        &["urdf.link.ram.mass=normal(5,0.5,4,6)".into()],
        3,
        seed,
        &controllers::builtin(),
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

fn options(out: &Path) -> StudyOptions {
    StudyOptions {
        out: out.to_path_buf(),
        jobs: 2,
        record: RecordMode::None,
        resume: false,
        only: None,
        shard: None,
        specs: vec![Spec::parse("tracking_mse<1e-3").unwrap()],
    }
}

fn run(study: &Study, options: &StudyOptions) -> twin_cli::study::StudyOutcome {
    run_study(
        study,
        options,
        &controllers::builtin(),
        &StopFlag::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn the_plan_spans_the_grid_with_the_last_axis_fastest_and_seeds_by_index() {
    let study = study(7);
    assert_eq!(study.runs(), 6);
    let plans: Vec<_> = (0..6).map(|i| study.plan(i).unwrap()).collect();
    let controllers: Vec<&str> = plans
        .iter()
        .map(|p| p.parameters[0].1.as_str().unwrap())
        .collect();
    assert_eq!(
        controllers,
        ["osmc", "osmc", "osmc", "smc2", "smc2", "smc2"]
    );
    for plan in &plans {
        let mass = plan.parameters[1].1.as_float().unwrap();
        assert!((4.0..=6.0).contains(&mass), "truncated draw {mass}");
        assert_eq!(
            study.plan(plan.index).unwrap(),
            *plan,
            "a run's plan is fixed"
        );
    }
    assert_ne!(plans[0].seed, plans[1].seed);
    assert_ne!(plans[0].parameters[1], plans[1].parameters[1]);
    assert_ne!(study.plan(0).unwrap(), self::study(8).plan(0).unwrap());
}

#[test]
fn shards_merge_into_the_same_bytes_as_one_machine_and_a_run_repeats_alone() {
    let study = study(3);
    let whole = scratch("whole");
    let outcome = run(&study, &options(&whole));
    assert_eq!(outcome.ran, 6);
    assert_eq!(outcome.report["ok"], 6);
    let mut shards = Vec::new();
    for index in 0..3 {
        let folder = scratch(&format!("shard{index}"));
        let shard = Some(Shard { index, count: 3 });
        let jobs = 1;
        run(
            &study,
            &StudyOptions {
                shard,
                jobs,
                ..options(&folder)
            },
        );
        shards.push(folder);
    }
    let merged = scratch("merged");
    merge(&shards, &merged).unwrap();
    for file in ["results.csv", "report.json", "study.json"] {
        assert_eq!(read(&whole.join(file)), read(&merged.join(file)), "{file}");
    }
    let csv = read(&whole.join("results.csv"));
    assert!(csv.starts_with("index,seed,controller,urdf.link.ram.mass,status,failure,"));
    assert_eq!(csv.lines().count(), 7);
    // Run 4 alone, in a fresh folder: the same series, bit for bit.
    let alone = scratch("alone");
    run(
        &study,
        &StudyOptions {
            only: Some(4),
            ..options(&alone)
        },
    );
    let digest = |folder: &Path| {
        let record: serde_json::Value =
            serde_json::from_str(&read(&folder.join("runs/4.json"))).unwrap();
        record["summary"]["series_digest"].clone()
    };
    assert_eq!(digest(&alone), digest(&whole));
    // A missing shard is named, not merged.
    let error = merge(&shards[..2], &scratch("partial")).unwrap_err();
    assert!(
        error.to_string().contains("2 of 6 runs are missing"),
        "{error}"
    );
    for folder in shards.iter().chain([&whole, &merged, &alone]) {
        let _ = std::fs::remove_dir_all(folder);
    }
}

#[test]
fn failed_runs_are_recorded_and_resume_finishes_a_study() {
    // The first health limit stops every run at once; the second lets them run.
    let study = Study::new(
        "whitworth-crank-pi",
        &["duration=0.2".into()],
        &["health.max_joint_speed=[1e-6, 1e3]".into()],
        &[],
        2,
        1,
        &controllers::builtin(),
    )
    .unwrap();
    let out = scratch("failures");
    let outcome = run(&study, &options_without_specs(&out));
    assert_eq!(outcome.report["failed"], 2);
    assert_eq!(outcome.report["failure_rate"], 0.5);
    let csv = read(&out.join("results.csv"));
    let failed: Vec<&str> = csv.lines().filter(|l| l.contains(",failed,")).collect();
    assert_eq!(failed.len(), 2);
    assert!(failed[0].contains("run diverged at step"), "{}", failed[0]);
    let before = read(&out.join("results.csv"));
    // A killed study: two records lost; --resume runs only those and ends the same.
    std::fs::remove_file(out.join("runs/1.json")).unwrap();
    std::fs::remove_file(out.join("runs/3.json")).unwrap();
    let resumed = run(
        &study,
        &StudyOptions {
            resume: true,
            ..options_without_specs(&out)
        },
    );
    assert_eq!((resumed.ran, resumed.skipped), (2, 2));
    assert_eq!(read(&out.join("results.csv")), before);
    let _ = std::fs::remove_dir_all(&out);
}

fn options_without_specs(out: &Path) -> StudyOptions {
    StudyOptions {
        specs: Vec::new(),
        ..options(out)
    }
}

#[test]
fn another_study_in_the_same_folder_is_refused() {
    let out = scratch("mismatch");
    let first = study(1);
    run(
        &first,
        &StudyOptions {
            only: Some(0),
            ..options(&out)
        },
    );
    let error = run_study(
        &study(2),
        &options(&out),
        &controllers::builtin(),
        &StopFlag::default(),
    )
    .unwrap_err();
    assert!(error.to_string().contains("another --seed"), "{error}");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn bad_studies_are_one_line_errors_before_any_run_and_leave_nothing() {
    let new = |set: &[&str], grid: &[&str], random: &[&str], samples| {
        let strings = |s: &[&str]| s.iter().map(|x| x.to_string()).collect::<Vec<_>>();
        Study::new(
            "whitworth-tracking",
            &strings(set),
            &strings(grid),
            &strings(random),
            samples,
            0,
            &controllers::builtin(),
        )
    };
    let cases: [(Result<Study, _>, &str); 6] = [
        (new(&[], &["k=lin(1,2)"], &[], 1), "three numbers"),
        (new(&[], &["k=[]"], &[], 1), "the grid is empty"),
        (new(&[], &[], &["k=gamma(1,2)"], 1), "unknown distribution"),
        (new(&[], &[], &["k=normal(1,0)"], 1), "sd > 0"),
        (new(&[], &["k=1,2", "k=3"], &[], 1), "given twice"),
        (new(&["bogus=1"], &[], &[], 1), "unknown field `bogus`"),
    ];
    for (result, expected) in cases {
        let message = result.err().map(|e| e.to_string()).unwrap_or_default();
        assert!(message.contains(expected), "{expected}: {message}");
        assert_eq!(message.lines().count(), 1);
    }
    let out = scratch("refused");
    let unknown_key = new(&[], &["controller.params.bogus=1,2"], &[], 1).unwrap();
    let error = run_study(
        &unknown_key,
        &options(&out),
        &controllers::builtin(),
        &StopFlag::default(),
    )
    .unwrap_err();
    assert!(
        error.to_string().starts_with("run 0 (and 1 more): "),
        "{error}"
    );
    assert!(error.to_string().contains("bogus"), "{error}");
    assert!(!out.exists(), "nothing written for a refused study");
    // A bad gain from an axis value, in a run that is not the first, is refused before any run.
    let bad_gain = Study::new(
        "whitworth-crank-pi",
        &["duration=0.2".into()],
        &["controller.params.natural_frequency=40,-1,30".into()],
        &[],
        1,
        0,
        &controllers::builtin(),
    )
    .unwrap();
    let error = run_study(
        &bad_gain,
        &options(&out),
        &controllers::builtin(),
        &StopFlag::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        error
            == "run 1: built-in scenario whitworth-crank-pi: \
                controller.params.natural_frequency = -1: must be > 0",
        "{error}"
    );
    assert!(!out.exists(), "nothing written for a refused study");
    assert!(Shard::parse("2/2", None)
        .unwrap_err()
        .contains("out of range"));
    assert!(Shard::parse("1/0", None)
        .unwrap_err()
        .contains("out of range"));
    assert!(Shard::parse("x", None).unwrap_err().contains("i/n"));
}
