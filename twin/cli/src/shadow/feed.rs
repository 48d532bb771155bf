//! Where a shadow's samples come from: a logged run played in (at once or at its own pace), or
//! a live machine over OPC UA through its map; and the loop that feeds them to the shadow,
//! records each processed step and publishes it.

use super::args::ShadowArgs;
use super::publish::Publisher;
use crate::data_flags::leave_out_unknown;
use crate::failure::Failure;
use crate::machine_link::{LinkEvent, LinkOptions, MachineLink, MachineMap};
use crate::opcua::security::read_password;
use framework::EventLevel;
use std::path::Path;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};
use twin::data::{ColumnRole, RunData};
use twin::shadowing::{describe, Shadow, ShadowRecording, ShadowStep};
use twin::StopFlag;

/// How long the live loop waits for a sample before it looks at the stop flag again.
const POLL: Duration = Duration::from_millis(20);
/// Events taken from the link at most before the samples are processed.
const DRAIN: usize = 100_000;
/// Spacings of a node's samples measured before its pace is judged.
const SPACINGS: usize = 100;
/// Seconds the shadow may fall behind the machine (net of the clocks' offset) before it says so.
pub const BEHIND: f64 = 1.0;

/// What a column carries into the shadow.
#[derive(Debug, Clone)]
pub enum Binding {
    /// An actuator's command (index) and the factor to SI.
    Command(usize, f64),
    /// A watched signal and the factor to SI.
    Measured(String, f64),
    /// A column the shadow does not use (true values, signals not watched).
    Unused,
}

/// The source of samples.
pub enum Feed {
    /// A logged run.
    Data {
        data: RunData,
        bindings: Vec<Binding>,
    },
    /// A live machine.
    Live {
        map: MachineMap,
        path: String,
        link: Option<MachineLink>,
        endpoint: String,
        bindings: Vec<Binding>,
    },
}

/// How the feeding went, for the summary.
#[derive(Debug, Default)]
pub struct Outcome {
    /// Wall-clock cost of each processed step, s.
    pub costs: Vec<f64>,
    /// Live: wall-clock time from each step's source timestamp to its being recorded, s, net
    /// of the clocks' offset.
    pub latencies: Vec<f64>,
    /// Live: the machine's clock behind the shadow's, s: the least time from a sample's source
    /// timestamp to its arrival (the clocks' offset and the fastest transport).
    pub clock_offset: Option<f64>,
    /// Live: spans the shadow fell more than [`BEHIND`] s behind the machine, (from, to) in
    /// machine seconds since the first sample.
    pub behind: Vec<(f64, Option<f64>)>,
    /// Live: the most the shadow fell behind the machine, s.
    pub most_behind: f64,
    /// Live: nodes the server samples more slowly than the control period, and how often, s.
    pub slow_sampling: Vec<(usize, f64)>,
    /// Live: connection losses, (lost at, restored at) in machine seconds since the first
    /// sample.
    pub gaps: Vec<(f64, Option<f64>)>,
    /// The signal that stopped it, if one did.
    pub interrupted: Option<usize>,
}

impl Feed {
    /// Reads the data or the map (connecting happens once the shadow is bound).
    pub fn open(args: &ShadowArgs) -> Result<Self, Failure> {
        if let Some(path) = &args.data {
            let options = args.reading.options(&Default::default())?;
            let data = RunData::read_with(path, &options)?;
            check_span(&data, args.learn)?;
            return Ok(Feed::Data {
                data,
                bindings: Vec::new(),
            });
        }
        let path = args.map.as_deref().unwrap_or(Path::new("map.toml"));
        let map = MachineMap::read(path)?;
        let endpoint = args.opcua.clone().or(map.endpoint.clone()).ok_or_else(|| {
            Failure::usage(format!(
                "{}: no endpoint: give --opcua opc.tcp://HOST:PORT or `endpoint` in the map",
                path.display()
            ))
        })?;
        Ok(Feed::Live {
            map,
            path: path.display().to_string(),
            link: None,
            endpoint,
            bindings: Vec::new(),
        })
    }

    /// The measured columns the source gives among `watchable`, in its order.
    pub fn measured_columns(&self, watchable: &[String]) -> Vec<String> {
        let names: Vec<&str> = match self {
            Feed::Data { data, .. } => data.columns.iter().map(|c| c.name.as_str()).collect(),
            Feed::Live { map, .. } => map.nodes.iter().map(|n| n.column.as_str()).collect(),
        };
        names
            .into_iter()
            .filter(|name| watchable.iter().any(|w| w == name))
            .map(str::to_owned)
            .collect()
    }

    /// A digest of the input for the recording's id.
    pub fn digest(&self) -> String {
        match self {
            Feed::Data { data, .. } => data.digest.chars().take(16).collect(),
            Feed::Live { .. } => "live".into(),
        }
    }

    /// Binds the source's columns to the shadow's actuators and watched signals, and connects
    /// to a live machine.
    pub fn bind(&mut self, shadow: &Shadow, args: &ShadowArgs) -> Result<(), Failure> {
        let bind = |name: &str, unit: &str| -> Result<Binding, String> {
            let (role, index, factor) = shadow.columns().bind_column(name, unit)?;
            Ok(match role {
                ColumnRole::Command => Binding::Command(index, factor),
                ColumnRole::Measured if shadow.watched().iter().any(|w| w == name) => {
                    Binding::Measured(name.to_string(), factor)
                }
                _ => Binding::Unused,
            })
        };
        match self {
            Feed::Data { data, bindings } => {
                leave_out_unknown(data, shadow.columns())?;
                *bindings = (data.columns.iter())
                    .map(|c| bind(&c.name, &c.unit).map_err(|e| format!("{}: {e}", data.source)))
                    .collect::<Result<_, _>>()?;
            }
            Feed::Live {
                map,
                path,
                link,
                endpoint,
                bindings,
            } => {
                let options = link_options(args)?;
                *bindings = (map.nodes.iter())
                    .map(|n| {
                        bind(&n.column, &n.unit)
                            .map_err(|e| format!("{path}: nodes.\"{}\": {e}", n.column))
                    })
                    .collect::<Result<_, _>>()?;
                *link = Some(MachineLink::connect(endpoint, &map.nodes, options)?);
            }
        }
        Ok(())
    }

    /// Feeds the shadow until the source ends, `--duration` is reached or a signal stops it.
    pub fn run(
        &mut self,
        shadow: &mut Shadow,
        recording: &mut ShadowRecording,
        publisher: Publisher,
        args: &ShadowArgs,
        stop: &StopFlag,
    ) -> Result<Outcome, Failure> {
        let mut sink = Sink {
            recording,
            publisher,
            nodes: Vec::new(),
            granted: Vec::new(),
            spacings: Vec::new(),
            outcome: Outcome::default(),
            live: matches!(self, Feed::Live { .. }),
        };
        match self {
            Feed::Data { data, bindings } => play(data, bindings, shadow, &mut sink, args, stop)?,
            Feed::Live {
                link,
                bindings,
                map,
                ..
            } => {
                let link = link.as_mut().ok_or("the machine link is not connected")?;
                sink.nodes = (map.nodes.iter())
                    .map(|n| format!("nodes.\"{}\" ({})", n.column, n.node))
                    .collect();
                watch(link, bindings, shadow, &mut sink, args, stop)?;
            }
        }
        let start = Instant::now();
        let steps = match sink.live {
            true => shadow.finish()?,
            false => shadow.flush()?,
        };
        // The samples still waiting at the end are no measure of the shadow's pace.
        sink.live = false;
        sink.take(shadow, steps, start)?;
        sink.publisher.stop();
        Ok(sink.outcome)
    }
}

/// Refuses a logged run with no rows, or no longer than `--learn` (all of it would be learnt
/// as healthy and nothing tested).
fn check_span(data: &RunData, learn: f64) -> Result<(), Failure> {
    let (Some(first), Some(last)) = (data.time.first(), data.time.last()) else {
        return Err(Failure::usage(format!(
            "{}: no rows of samples: the shadow needs a logged run",
            data.source
        )));
    };
    let span = last - first;
    if span <= learn {
        return Err(Failure::usage(format!(
            "{}: {span} s of data, no longer than --learn {learn} s (taken as healthy to set the \
             tests): give a longer run or a shorter --learn",
            data.source
        )));
    }
    Ok(())
}

/// The link's options from the command line: security, PKI, user and timeout.
fn link_options(args: &ShadowArgs) -> Result<LinkOptions, Failure> {
    let user = match &args.user {
        Some(user) => {
            let password = read_password(user, args.password_file.as_deref())
                .map_err(|e| Failure::usage(e.to_string()))?;
            Some((user.clone(), password))
        }
        None => None,
    };
    Ok(LinkOptions {
        connect_timeout: Duration::from_secs_f64(args.connect_timeout),
        security: args.security,
        pki: args.pki.clone(),
        user,
        ..LinkOptions::default()
    })
}

/// Marks the last gap as ended at `time` (machine seconds since the first sample).
fn restored(sink: &mut Sink, time: f64) -> Result<(), Failure> {
    if let Some(gap) = sink.outcome.gaps.last_mut() {
        gap.1 = Some(time);
    }
    let text = "connection to the machine restored; samples again from here";
    sink.recording.note(time, EventLevel::Info, text)?;
    Ok(())
}

/// Where processed steps go: the recording, the published variables, the timing figures.
struct Sink<'a> {
    recording: &'a mut ShadowRecording,
    publisher: Publisher,
    /// Live: each mapped node, as the map names it.
    nodes: Vec<String>,
    /// Live: each node's sampling interval the server granted, s.
    granted: Vec<Option<f64>>,
    /// Live: per node, its last sample's source time and the first spacings of its samples, s.
    spacings: Vec<(Option<f64>, Vec<f64>)>,
    outcome: Outcome,
    live: bool,
}

impl Sink<'_> {
    /// Records and publishes `steps`, processed since `start`.
    fn take(
        &mut self,
        shadow: &Shadow,
        steps: Vec<ShadowStep>,
        start: Instant,
    ) -> Result<(), Failure> {
        if steps.is_empty() {
            return Ok(());
        }
        let cost = start.elapsed().as_secs_f64() / steps.len() as f64;
        for step in &steps {
            self.recording.push(step)?;
            self.publisher.publish(shadow, step)?;
            if let Some(change) = &step.change {
                eprintln!("t = {:.3} s: {}", step.time, describe(change).1);
            }
            self.outcome.costs.push(cost);
            if self.live {
                let source = shadow.origin().unwrap_or(0.0) + step.time;
                let offset = self.outcome.clock_offset.unwrap_or(0.0);
                let late = (now() - source - offset).max(0.0);
                self.outcome.latencies.push(late);
                self.keep_pace(step.time, late)?;
            }
        }
        Ok(())
    }

    /// Takes the arrival of a sample of `node` at source time `time`: once [`SPACINGS`] have
    /// come, warns, naming the node, if their median spacing is longer than the machine's
    /// control period (a server's own minimum sampling, revised silently, or a slow publisher):
    /// values changed between two samples never reach the shadow, and a command held across
    /// them drives the model with what the machine did not do.
    fn spacing(&mut self, node: usize, time: f64, period: f64, granted: &[Option<f64>]) {
        if node >= self.spacings.len() {
            self.spacings.resize(node + 1, (None, Vec::new()));
        }
        let (last, spacings) = &mut self.spacings[node];
        if let Some(last) = last.replace(time) {
            if time > last && spacings.len() < SPACINGS {
                spacings.push(time - last);
                if spacings.len() == SPACINGS {
                    let median = quantile(spacings, 0.5);
                    self.slow(node, median, period, granted.get(node).copied().flatten());
                }
            }
        }
    }

    /// The warning of [`Sink::spacing`], when `median` is longer than 1.5 control periods.
    fn slow(&mut self, node: usize, median: f64, period: f64, granted: Option<f64>) {
        if median <= 1.5 * period {
            return;
        }
        let granted = granted.map_or(String::new(), |g| {
            format!(" (its server granted sampling every {:.1} ms)", g * 1e3)
        });
        let text = format!(
            "{}: samples arrive every {:.1} ms{granted}, slower than the machine's {:.1} ms \
             control period: changes between them never reach the shadow (ask for the server's \
             minimum sampling interval to be lowered)",
            self.nodes.get(node).map_or("a node", String::as_str),
            median * 1e3,
            period * 1e3
        );
        eprintln!("warning: {text}");
        let _ = self.recording.note(0.0, EventLevel::Warning, &text);
        self.outcome.slow_sampling.push((node, median));
    }

    /// Notes when the shadow falls more than [`BEHIND`] s behind the machine and when it has
    /// caught up (its samples are all processed, only later: nothing is dropped for it).
    fn keep_pace(&mut self, time: f64, late: f64) -> Result<(), Failure> {
        self.outcome.most_behind = self.outcome.most_behind.max(late);
        let open = self
            .outcome
            .behind
            .last()
            .is_some_and(|(_, to)| to.is_none());
        if late > BEHIND && !open {
            self.outcome.behind.push((time, None));
            let text = format!(
                "behind: the shadow is {late:.1} s behind the machine (this computer is busy); \
                 it catches up, dropping nothing"
            );
            eprintln!("t = {time:.3} s: {text}");
            self.recording.note(time, EventLevel::Warning, &text)?;
        } else if late < 0.5 * BEHIND && open {
            if let Some(span) = self.outcome.behind.last_mut() {
                span.1 = Some(time);
            }
            let text = "caught up with the machine";
            eprintln!("t = {time:.3} s: {text}");
            self.recording.note(time, EventLevel::Info, text)?;
        }
        Ok(())
    }
}

/// Seconds since the UNIX epoch now.
fn now() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// Whether the run should stop: a signal, or the machine's time past `--duration`.
fn stopping(stop: &StopFlag, shadow: &Shadow, args: &ShadowArgs, outcome: &mut Outcome) -> bool {
    let signal = stop.load(std::sync::atomic::Ordering::Relaxed);
    if signal != 0 {
        outcome.interrupted = Some(signal);
        return true;
    }
    args.length
        .duration
        .is_some_and(|d| shadow.newest().is_some_and(|t| t >= d))
}

/// Plays a logged run in, row by row, paced with --replay.
fn play(
    data: &RunData,
    bindings: &[Binding],
    shadow: &mut Shadow,
    sink: &mut Sink,
    args: &ShadowArgs,
    stop: &StopFlag,
) -> Result<(), Failure> {
    let wall = Instant::now();
    let first = data.time.first().copied().unwrap_or(0.0);
    for (row, &time) in data.time.iter().enumerate() {
        if args.replay {
            let due = Duration::from_secs_f64(((time - first) / args.rate).max(0.0));
            if let Some(wait) = due.checked_sub(wall.elapsed()) {
                std::thread::sleep(wait);
            }
        }
        for (column, binding) in data.columns.iter().zip(bindings) {
            let value = column.values[row];
            match binding {
                Binding::Command(a, factor) => shadow.command(*a, time, value * factor),
                Binding::Measured(name, factor) => shadow.measurement(name, time, value * factor),
                Binding::Unused => {}
            }
        }
        let start = Instant::now();
        let steps = shadow.advance()?;
        sink.take(shadow, steps, start)?;
        if stopping(stop, shadow, args, &mut sink.outcome) {
            break;
        }
    }
    Ok(())
}

/// Watches a live machine until a signal or --duration.
fn watch(
    link: &mut MachineLink,
    bindings: &[Binding],
    shadow: &mut Shadow,
    sink: &mut Sink,
    args: &ShadowArgs,
    stop: &StopFlag,
) -> Result<(), Failure> {
    // A gap is marked on the machine's clock: from the newest sample before the loss to the
    // first one after the restoration.
    let mut restoring = false;
    let clock = Instant::now();
    while !stopping(stop, shadow, args, &mut sink.outcome) {
        let Some(first) = link.recv(POLL) else {
            continue;
        };
        // Everything the link holds is taken in before the samples are processed: a publish
        // response that carries one node's second of samples before the next node's is then
        // taken whole, and the slow stream is not left behind.
        shadow.arrival_clock(clock.elapsed().as_secs_f64());
        sink.granted = link.granted_sampling();
        let mut event = Some(first);
        for _ in 0..DRAIN {
            let Some(taken) = event.take() else { break };
            take_event(taken, bindings, shadow, sink, &mut restoring)?;
            event = link.recv(Duration::ZERO);
        }
        if let Some(taken) = event {
            take_event(taken, bindings, shadow, sink, &mut restoring)?;
        }
        let start = Instant::now();
        let steps = shadow.advance()?;
        sink.take(shadow, steps, start)?;
    }
    Ok(())
}

/// Takes one event from the link: a sample into the shadow, a loss or a restoration noted.
fn take_event(
    event: LinkEvent,
    bindings: &[Binding],
    shadow: &mut Shadow,
    sink: &mut Sink,
    restoring: &mut bool,
) -> Result<(), Failure> {
    match event {
        LinkEvent::Sample {
            node,
            source_time,
            value,
        } => {
            let granted = sink.granted.clone();
            sink.spacing(node, source_time, shadow.control_period(), &granted);
            let arrived = now() - source_time;
            let offset = sink.outcome.clock_offset.get_or_insert(arrived);
            *offset = offset.min(arrived);
            match bindings.get(node) {
                Some(Binding::Command(a, factor)) => {
                    shadow.command(*a, source_time, value * factor)
                }
                Some(Binding::Measured(name, factor)) => {
                    shadow.measurement(name, source_time, value * factor)
                }
                _ => {}
            }
            if std::mem::take(restoring) {
                restored(sink, shadow.newest().unwrap_or(0.0))?;
            }
        }
        LinkEvent::Lost { reason, .. } => {
            let time = shadow.newest().unwrap_or(0.0);
            sink.outcome.gaps.push((time, None));
            let text = format!("connection to the machine lost: {reason}; reconnecting");
            eprintln!("{text}");
            sink.recording.note(time, EventLevel::Warning, &text)?;
        }
        LinkEvent::Restored { attempts, .. } => {
            eprintln!("connection to the machine restored after {attempts} tries");
            *restoring = true;
        }
        LinkEvent::Refused { node, reason } => eprintln!("node {node}: {reason}"),
    }
    Ok(())
}

/// The p-th quantile (0–1) of `values`.
fn quantile(values: &[f64], p: f64) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let index = ((sorted.len() as f64 - 1.0) * p).round() as usize;
    sorted.get(index).copied().unwrap_or(0.0)
}
