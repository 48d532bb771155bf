//! What a recording shows, checked without pixels for every shipped scenario: one unit per plot
//! and every series named with it, references and commands on the plot of what they command,
//! the mechanism view's frame fixed and holding the machine all run long, and the frame, the
//! start and end events and the summary in the file.

use std::collections::HashSet;
use twin::recordings::Scene;
use twin::recordings::{PlotSpec, SeriesRole};
use twin::BUILTIN_SCENARIOS as BUILTIN;
use twin::{Findings, Observer, ObserverError, SignalLayout, StepView, Twin};
use twin_tests::{builtin, scratch, Configure};

fn twin(name: &str, duration: Option<f64>) -> Twin {
    let mut scenario = builtin(name);
    if let Some(seconds) = duration {
        scenario = scenario.duration(seconds);
    }
    Twin::new(scenario.loaded()).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn plot<'a>(plots: &'a [PlotSpec], title: &str) -> &'a PlotSpec {
    plots
        .iter()
        .find(|p| p.title() == title)
        .unwrap_or_else(|| {
            let titles: Vec<String> = plots.iter().map(PlotSpec::title).collect();
            panic!("no plot `{title}` among {titles:?}")
        })
}

fn has_series(plot: &PlotSpec, name: &str, role: SeriesRole) -> bool {
    plot.series.iter().any(|s| s.name == name && s.role == role)
}

#[test]
fn every_plot_is_one_unit_and_every_series_says_it() {
    for (name, _) in BUILTIN {
        let (plots, _) = twin(name, None).recording_plan();
        let mut titles = HashSet::new();
        for plot in &plots {
            let unit = format!("[{}]", plot.unit.label());
            assert!(plot.title().ends_with(&unit), "{name}: {}", plot.title());
            assert!(
                titles.insert(plot.title()),
                "{name}: two plots {}",
                plot.title()
            );
            assert!(
                !plot.series.is_empty(),
                "{name}: empty plot {}",
                plot.title()
            );
            let mut labels = HashSet::new();
            for series in &plot.series {
                let label = plot.series_label(series);
                assert!(
                    label.ends_with(&unit),
                    "{name}: {label} on {}",
                    plot.title()
                );
                assert!(labels.insert(label.clone()), "{name}: {label} twice");
            }
        }
    }
}

#[test]
fn references_and_commands_share_a_plot_with_what_they_command() {
    let (plots, _) = twin("whitworth-tracking", None).recording_plan();
    let ram = plot(&plots, "ram position [mm]");
    assert!(has_series(ram, "reference", SeriesRole::Reference));
    assert!(has_series(ram, "ram_position", SeriesRole::True));

    let (plots, _) = twin("feed-axis-micromilling", None).recording_plan();
    let table = plot(&plots, "table position [µm]");
    assert!(has_series(table, "reference", SeriesRole::Reference));
    assert!(has_series(table, "table.position", SeriesRole::True));
    // The scenario's encoder makes the measurement differ from the true position.
    assert!(has_series(
        table,
        "table.position measured",
        SeriesRole::Measured
    ));

    let (plots, _) = twin("lathe-turning", None).recording_plan();
    let feed = plot(&plots, "tool 1 feed [mm/rev]");
    assert!(has_series(feed, "commanded_feed_1", SeriesRole::Commanded));
    assert!(has_series(feed, "feed_1", SeriesRole::True));
    let power = plot(&plots, "spindle power [kW]");
    assert!(power.series.iter().any(|s| s.name == "power_limit"));

    let (plots, _) = twin("arm-milling", None).recording_plan();
    let current = plot(&plots, "shoulder current [A]");
    assert!(has_series(
        current,
        "shoulder commanded",
        SeriesRole::Commanded
    ));
    assert!(has_series(current, "shoulder_current", SeriesRole::True));
    let torque = plot(&plots, "shoulder torque [N·m]");
    assert!(has_series(torque, "shoulder applied", SeriesRole::Applied));

    let (plots, _) = twin("milling-constant-15000", None).recording_plan();
    let speed = plot(&plots, "spindle speed [rpm]");
    assert!(has_series(speed, "speed_command", SeriesRole::Commanded));
    assert!(has_series(speed, "spindle.velocity", SeriesRole::True));
}

/// Checks that every link origin and every scene marker stays inside the frame all run long.
struct InFrame {
    scene: Scene,
    worst: f64,
    where_: String,
}

impl Observer for InFrame {
    fn start(&mut self, _layout: &SignalLayout) -> Result<(), ObserverError> {
        Ok(())
    }

    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        let b = self.scene.bounds;
        for (link, pose) in view.state.link_poses.iter().enumerate() {
            // How far outside the frame, as a fraction of its size (≤ 0: inside).
            let out = [
                (b.x[0] - pose.x) / b.width(),
                (pose.x - b.x[1]) / b.width(),
                (b.y[0] - pose.y) / b.height(),
                (pose.y - b.y[1]) / b.height(),
            ]
            .into_iter()
            .fold(f64::NEG_INFINITY, f64::max);
            if out > self.worst {
                self.worst = out;
                self.where_ = format!("link {link} at t = {} s", view.time);
            }
        }
        Ok(())
    }

    fn finish(&mut self) -> Result<Findings, ObserverError> {
        Ok(Findings::default())
    }
}

#[test]
fn the_mechanism_frame_is_fixed_and_holds_the_machine_all_run() {
    for (name, _) in BUILTIN {
        // Long enough for every machine to move through its working range.
        let twin = twin(name, Some(4.0));
        let (_, scene) = twin.recording_plan();
        let b = scene.bounds;
        assert!(b.width() > 0.0 && b.height() > 0.0, "{name}: {b:?}");
        let mut check = InFrame {
            scene,
            worst: f64::NEG_INFINITY,
            where_: String::new(),
        };
        twin.run_with(None, &mut [&mut check])
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        // Link origins stay inside, at least 1 % of the frame from its border.
        assert!(
            check.worst < -0.01,
            "{name}: {} outside by {:.3}",
            check.where_,
            check.worst
        );
    }
}

#[test]
fn a_recording_holds_its_frame_once_and_its_start_end_and_summary() {
    let dir = scratch("recording-contents");
    let path = dir.join("run.rrd");
    let twin = twin("whitworth-crank-pi", Some(0.5));
    let (_, scene) = twin.recording_plan();
    twin.run(Some(&path)).unwrap();
    let contents = twin::recordings::inspect(&path).unwrap();
    // The mechanism view's bounds: set once, in the layout, to the scene's frame.
    assert_eq!(
        contents.visual_bounds.len(),
        1,
        "{:?}",
        contents.visual_bounds
    );
    let [x0, x1, y0, y1] = contents.visual_bounds[0];
    let b = scene.bounds;
    assert_eq!([x0, x1], [b.x[0] as f32, b.x[1] as f32]);
    // The view is y-down under the y-flip of `/mechanism`.
    assert_eq!([y0, y1], [-b.y[1] as f32, -b.y[0] as f32]);
    assert!(contents.entities.iter().any(|e| e == "/summary"));
    let first = contents.events.first().expect("events");
    let last = contents.events.last().expect("events");
    assert!(
        first.starts_with("run started: scenario whitworth-crank-pi"),
        "{first}"
    );
    assert!(last.starts_with("run ended: ok"), "{last}");
    // One time-series view per plot, each named with its unit.
    assert!(contents.time_series_views.iter().all(|v| v.ends_with(']')));
    let _ = std::fs::remove_dir_all(&dir);
}
