//! `faithd replay`: recorded events (and attitude) through the same pipeline, one
//! line per decision window. Deterministic: a recording replays to identical output.
//!
//! Attitude comes from a `.tlog` (ATTITUDE messages, stamped with the autopilot's
//! `time_boot_ms` plus `attitude_offset_us`) or from the `imu.txt` beside a text
//! dataset (`t ax ay az gx gy gz`, seconds and rad/s in the camera's axes: x right,
//! y down, z forward, so body roll rate = gz, pitch rate = gx, yaw rate = gy). Without
//! either, derotation is switched off and every line says so.

use std::io::{BufRead, Write};
use std::path::Path;

use crate::link::clock_sync::ClockSync;
use crate::link::telemetry::{self, Update};
use faithd_core::attitude::{AttitudeLog, AttitudeSample, AttitudeUsed};
use faithd_core::derotate::DerotationState;
use faithd_core::event::Event;
use faithd_core::pipeline::{NoClock, Pipeline, PipelineConfig, WindowReport};
use faithd_core::safety::vehicle::VehicleState;
use faithd_formats::events::{SourceError, open_events};
use faithd_formats::tlog::{TlogError, TlogReader};
use faithd_formats::window_log::{
    RecordedWindow, WINDOW_LOG_VERSION, WindowLine, WindowLogHeader, difference,
};
use mavlink::dialects::common::MavMessage;
use serde::Deserialize;

#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    #[error("{path}: {source}")]
    Events { path: String, source: SourceError },
    #[error("{path}: {source}")]
    Tlog { path: String, source: TlogError },
    #[error("{path}: cannot read: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}, line {line}: {what}")]
    Imu {
        path: String,
        line: usize,
        what: String,
    },
    #[error("{path}, line {line}: {what}")]
    WindowLog {
        path: String,
        line: usize,
        what: String,
    },
    #[error("cannot write the output: {0}")]
    Output(std::io::Error),
    #[error(
        "{path}: event {index} has time {t_us} us, beyond +-2^53 us: not a clock faithd can window"
    )]
    EventTime { path: String, index: u64, t_us: i64 },
    #[error(
        "{path}: holds no attitude samples: give this recording's own attitude, or leave the option out to replay without derotation"
    )]
    NoAttitude { path: String },
    #[error(
        "{path}: its attitude spans {} to {}, the events {} to {}: they do not overlap, so no window could be derotated; --attitude-offset-us {shift_us} puts the attitude's start on the events' start",
        seconds(attitude.0), seconds(attitude.1), seconds(events.0), seconds(events.1)
    )]
    AttitudeSpan {
        path: String,
        attitude: (i64, i64),
        events: (i64, i64),
        shift_us: i64,
    },
    /// The [`Watch`] stopped the replay (the video could not be written).
    #[error("{0}")]
    Watch(String),
}

/// Hears every replayed window: the events it took and everything the pipeline
/// made of them (a flight's video is drawn from it). An error stops the replay.
pub type Watch<'a> = &'a mut dyn FnMut(&[Event], &WindowReport<'_>) -> Result<(), String>;

/// Microseconds as seconds, for a person.
fn seconds(t_us: i64) -> String {
    format!("{:.6} s", t_us as f64 / 1e6)
}

/// A watch that hears nothing.
pub fn unwatched(_: &[Event], _: &WindowReport<'_>) -> Result<(), String> {
    Ok(())
}

/// Refuses events whose times no recording can hold (they would overflow the window
/// arithmetic); `seen` counts the events before this batch.
fn check_times(path: &Path, batch: &[Event], seen: &mut u64) -> Result<(), ReplayError> {
    if let Some(i) = batch
        .iter()
        .position(|e| e.t_us.unsigned_abs() > Event::MAX_ABS_T_US as u64)
    {
        return Err(ReplayError::EventTime {
            path: path.display().to_string(),
            index: *seen + i as u64,
            t_us: batch[i].t_us,
        });
    }
    *seen += batch.len() as u64;
    Ok(())
}

/// Where a replay's attitude comes from, and `offset_us` added to its times to put
/// them on the events' clock.
pub enum AttitudeInput<'a> {
    None,
    Tlog { path: &'a Path, offset_us: i64 },
    Imu { path: &'a Path, offset_us: i64 },
}

impl AttitudeInput<'_> {
    /// The samples, on the events' clock; refused when there are none (an empty file
    /// would switch derotation off without a word).
    fn samples(&self) -> Result<Vec<AttitudeSample>, ReplayError> {
        let (path, mut samples, offset_us) = match *self {
            AttitudeInput::None => return Ok(Vec::new()),
            AttitudeInput::Tlog { path, offset_us } => (path, attitude_from_tlog(path)?, offset_us),
            AttitudeInput::Imu { path, offset_us } => {
                (path, attitude_from_imu_txt(path)?, offset_us)
            }
        };
        if samples.is_empty() {
            return Err(ReplayError::NoAttitude {
                path: path.display().to_string(),
            });
        }
        for s in &mut samples {
            s.t_us = s.t_us.saturating_add(offset_us);
        }
        Ok(samples)
    }

    fn path(&self) -> Option<&Path> {
        match *self {
            AttitudeInput::None => None,
            AttitudeInput::Tlog { path, .. } | AttitudeInput::Imu { path, .. } => Some(path),
        }
    }
}

/// ATTITUDE samples of a .tlog, on the autopilot's boot clock.
pub fn attitude_from_tlog(path: &Path) -> Result<Vec<AttitudeSample>, ReplayError> {
    let file = std::fs::File::open(path).map_err(|source| ReplayError::Io {
        path: path.display().to_string(),
        source,
    })?;
    let mut reader = TlogReader::new(std::io::BufReader::new(file));
    let mut out = Vec::new();
    while let Some(rec) = reader.next_record().map_err(|source| ReplayError::Tlog {
        path: path.display().to_string(),
        source,
    })? {
        if let Some(mavlink::dialects::common::MavMessage::ATTITUDE(a)) = rec.message {
            let t_us = i64::from(a.time_boot_ms) * 1000;
            out.push(crate::link::telemetry::attitude_sample(t_us, &a));
        }
    }
    out.sort_by_key(|s| s.t_us);
    Ok(out)
}

/// Body rates from a dataset's imu.txt (gyro in camera axes).
pub fn attitude_from_imu_txt(path: &Path) -> Result<Vec<AttitudeSample>, ReplayError> {
    let p = path.display().to_string();
    let file = std::fs::File::open(path).map_err(|source| ReplayError::Io {
        path: p.clone(),
        source,
    })?;
    imu_samples(std::io::BufReader::new(file), &p)
}

/// The fields of an imu.txt line, in order.
const IMU_FIELDS: [&str; 7] = ["t", "ax", "ay", "az", "gx", "gy", "gz"];

/// Parses imu.txt lines (`t ax ay az gx gy gz`, seconds and rad/s) from `input`;
/// errors name `label`, the line, and of a bad number its column and field.
pub fn imu_samples(
    input: impl std::io::BufRead,
    label: &str,
) -> Result<Vec<AttitudeSample>, ReplayError> {
    let imu_err = |line: usize, what: String| ReplayError::Imu {
        path: label.to_string(),
        line,
        what,
    };
    let mut out = Vec::new();
    for (i, line) in input.lines().enumerate() {
        let line = line.map_err(|source| ReplayError::Io {
            path: label.to_string(),
            source,
        })?;
        let text = line.trim_end();
        if text.trim_start().is_empty() || text.trim_start().starts_with('#') {
            continue;
        }
        let v = imu_numbers(text).map_err(|what| imu_err(i + 1, what))?;
        let t_us = (v[0] * 1e6).round();
        if t_us.abs() > Event::MAX_ABS_T_US as f64 {
            return Err(imu_err(i + 1, format!("time {} s beyond +-2^53 us", v[0])));
        }
        out.push(AttitudeSample {
            t_us: t_us as i64,
            roll_rate_rad_s: v[6],
            pitch_rate_rad_s: v[4],
            yaw_rate_rad_s: v[5],
            ..Default::default()
        });
    }
    out.sort_by_key(|s| s.t_us);
    Ok(out)
}

/// The seven finite numbers of an imu.txt line, or what is wrong: the column (from 1)
/// and field of a bad number and what stood there, or how many fields there were.
fn imu_numbers(text: &str) -> Result<[f64; 7], String> {
    let mut v = [0.0; 7];
    let mut count = 0;
    for (column, field) in fields_with_columns(text) {
        if count < v.len() {
            let name = IMU_FIELDS[count];
            let x = field
                .parse::<f64>()
                .map_err(|_| format!("column {column} ({name}): `{field}` is not a number"))?;
            if !x.is_finite() {
                return Err(format!(
                    "column {column} ({name}): `{field}` is not a finite number"
                ));
            }
            v[count] = x;
        }
        count += 1;
    }
    if count != v.len() {
        return Err(format!(
            "expected 7 numbers (t ax ay az gx gy gz), got {count} fields"
        ));
    }
    Ok(v)
}

/// The whitespace-separated fields of `text`, each with its column (from 1, in
/// characters).
fn fields_with_columns(text: &str) -> impl Iterator<Item = (usize, &str)> {
    let mut rest = text;
    let mut column = 1;
    std::iter::from_fn(move || {
        let skipped = rest.len() - rest.trim_start().len();
        column += rest[..skipped].chars().count();
        rest = &rest[skipped..];
        if rest.is_empty() {
            return None;
        }
        let end = rest.find(char::is_whitespace).unwrap_or(rest.len());
        let (field, after) = rest.split_at(end);
        let at = column;
        column += field.chars().count();
        rest = after;
        Some((at, field))
    })
}

/// What a replay of a recording did: its windows, and those that ran without
/// derotation for want of attitude.
#[derive(Debug, Default, PartialEq)]
pub struct ReplaySummary {
    pub windows: usize,
    /// Windows whose flow was not derotated though derotation was on: their runs,
    /// `(first window's end, last window's end, windows)`, in order.
    pub not_derotated: Vec<(i64, i64, usize)>,
    /// The share of the events' span the attitude's span covers, 0 to 1 (`None`:
    /// no attitude was given).
    pub attitude_covers: Option<f64>,
    /// Whether the last window counted was one of the last run.
    in_run: bool,
}

impl ReplaySummary {
    fn count(&mut self, end_us: i64, state: DerotationState) {
        self.windows += 1;
        let missed = !state.usable();
        match self.not_derotated.last_mut() {
            Some(run) if missed && self.in_run => {
                run.1 = end_us;
                run.2 += 1;
            }
            _ if missed => self.not_derotated.push((end_us, end_us, 1)),
            _ => {}
        }
        self.in_run = missed;
    }
}

/// Replays `events_path`, writing one line per `window_us` window to `out` and
/// telling `watch` of each. Attitude whose span does not overlap the events' is
/// refused before the first window runs.
pub fn replay(
    events_path: &Path,
    attitude: AttitudeInput<'_>,
    mut config: PipelineConfig,
    window_us: i64,
    json: bool,
    out: &mut dyn Write,
    watch: Watch<'_>,
) -> Result<ReplaySummary, ReplayError> {
    let samples = attitude.samples()?;
    let mut summary = ReplaySummary::default();
    if attitude.path().is_none() {
        config.derotation.enabled = false;
    }
    // The events' first and last times so far.
    let mut span: Option<(i64, i64)> = None;
    let events_err = events_error(events_path);
    let mut reader = open_events(events_path).map_err(events_err)?;
    let mut pipeline = Pipeline::new(config);
    let mut pending: Vec<Event> = Vec::new();
    let mut batch = Vec::new();
    let mut window_end_us: Option<i64> = None;
    let mut seen = 0;
    let mut more = true;
    while more || !pending.is_empty() {
        if more {
            more = reader.next_batch(&mut batch).map_err(events_err)?;
            check_times(events_path, &batch, &mut seen)?;
            pending.extend_from_slice(&batch);
            if let (Some(first), Some(last)) = (batch.first(), batch.last()) {
                if span.is_none()
                    && let Some(path) = attitude.path()
                {
                    check_overlap(events_path, path, first.t_us, &samples)?;
                }
                span = Some((span.map_or(first.t_us, |s| s.0), last.t_us));
            }
        }
        let Some(first) = pending.first() else {
            continue;
        };
        let first_us = first.t_us;
        let end = *window_end_us.get_or_insert(first_us + window_us);

        if first_us >= end + 1_000_000 {
            // A gap of over a second (recording paused): skip it rather than print
            // a line for every empty window.
            window_end_us = Some(first_us + window_us);
            continue;
        }
        // Process every window whose end the data has passed (or all, at the end).
        loop {
            let end_us = window_end_us.expect("set above");
            let data_passed = pending.last().is_some_and(|e| e.t_us > end_us);
            // Wait for more data unless it already passed the window end or has ended.
            if pending.is_empty() || (!data_passed && more) {
                break;
            }
            let take = faithd_core::window::events_until(&pending, end_us);
            let report = pipeline.process_window(&pending[..take], &samples, end_us, &mut NoClock);
            watch(&pending[..take], &report).map_err(ReplayError::Watch)?;
            let line = WindowLine::from_report(end_us, take, &report);
            summary.count(end_us, report.derotation.state);
            pending.drain(..take);
            window_end_us = Some(end_us + window_us);
            print_line(&line, json, out)?;
        }
    }
    if attitude.path().is_some() {
        summary.attitude_covers = span.map(|events| covered_share(events, &samples));
    }
    Ok(summary)
}

/// Refuses attitude (`samples`, from `path`) whose span does not overlap the events',
/// whose first is at `first_event_us`, with both spans and the offset that puts one
/// on the other. The events' end is read ahead only when the attitude does not span
/// their first event, so a replay with the usual attitude reads its events once.
fn check_overlap(
    events_path: &Path,
    path: &Path,
    first_event_us: i64,
    samples: &[AttitudeSample],
) -> Result<(), ReplayError> {
    let (Some(a), Some(b)) = (samples.first(), samples.last()) else {
        return Ok(());
    };
    let (a0, a1) = (a.t_us, b.t_us);
    if (a0..=a1).contains(&first_event_us) {
        return Ok(());
    }
    let Some((e0, e1)) = events_span(events_path)? else {
        return Ok(());
    };
    if e0.max(a0) > e1.min(a1) {
        return Err(ReplayError::AttitudeSpan {
            path: path.display().to_string(),
            attitude: (a0, a1),
            events: (e0, e1),
            shift_us: e0.saturating_sub(a0),
        });
    }
    Ok(())
}

/// The share of the events' span (`e0`, `e1`) that the attitude's covers, 0 to 1.
fn covered_share((e0, e1): (i64, i64), samples: &[AttitudeSample]) -> f64 {
    let (Some(a), Some(b)) = (samples.first(), samples.last()) else {
        return 0.0;
    };
    let (from, to) = (e0.max(a.t_us), e1.min(b.t_us));
    match (from <= to, e1 > e0) {
        (false, _) => 0.0,
        (true, true) => (to - from) as f64 / (e1 - e0) as f64,
        (true, false) => 1.0,
    }
}

/// Names the event file in its reader's errors.
fn events_error(path: &Path) -> impl Fn(SourceError) -> ReplayError + Copy + '_ {
    move |source| ReplayError::Events {
        path: path.display().to_string(),
        source,
    }
}

/// How a flight's replay against its window log went.
#[derive(Debug, Default)]
pub struct LogReplay {
    pub windows: usize,
    /// Windows whose replay differs from what the daemon decided live.
    pub differing: usize,
    /// The first difference: window time and what differed.
    pub first_difference: Option<(i64, String)>,
    /// Windows that ran in flight before attitude whose frame had arrived reached the
    /// pipeline (replayed with what they had): how late the flight was.
    pub late_windows: usize,
}

/// Replays a daemon recording window by window as its window log says the daemon ran
/// it (see [`faithd_formats::window_log`]), printing each window as [`replay`] does and
/// comparing it with the recorded one, and telling `watch` of each. `config`
/// overrides the logged pipeline configuration (to try other settings on a recorded
/// flight).
pub fn replay_window_log(
    events_path: &Path,
    tlog_path: Option<&Path>,
    log_path: &Path,
    config: Option<PipelineConfig>,
    json: bool,
    out: &mut dyn Write,
    watch: Watch<'_>,
) -> Result<LogReplay, ReplayError> {
    let mut log = WindowLogLines::open(log_path)?;
    let header = log.header()?;
    let as_run = header.pipeline_as_run().map_err(|e| log.error(1, e))?;
    // The daemon's own checks, before anything is sized from it.
    as_run
        .validate()
        .map_err(|inv| log.error(1, format!("header: `{}` {}", inv.key, inv.reason)))?;
    let version = header.faithd_window_log;
    if config.is_none() && version != WINDOW_LOG_VERSION {
        tracing::info!(
            version,
            "window log from an older faithd: replaying as it flew (version 1: without FAITH's speed fit; versions 1 and 2: every event fitted; up to 3: any attitude sample held)"
        );
    }
    if version < 4 && tlog_path.is_some() {
        tracing::warn!(
            version,
            "window log from before windows named their attitude samples: each window takes the samples whose frames were recorded before it, so a window that ran before a sample reached its pipeline (a loaded board) can replay otherwise"
        );
    }
    let mut attitude = match tlog_path {
        Some(path) => RecordedAttitude::from_tlog(path, &header)?,
        None => RecordedAttitude::default(),
    };
    let config = config.unwrap_or(as_run);
    let mut events = RecordedEvents::open(events_path)?;
    let mut pipeline = Pipeline::new(config);
    let mut samples = Vec::new();
    let mut result = LogReplay::default();
    while let Some((line_no, recorded, window)) = log.next_window()? {
        let (max_fits, max_events) =
            check_window(&window, &config).map_err(|e| log.error(line_no, e))?;
        let taken = events
            .take(window.events)
            .map_err(|e| e.or_short(|short| log.error(line_no, ends_short(&window, short))))?;
        pipeline.set_max_vectors(window.max_vectors);
        pipeline.set_foe_iterations(window.foe_iterations);
        pipeline.set_max_fits(max_fits);
        pipeline.set_max_events(max_events);
        match (&window.attitude, tlog_path) {
            (Some(used), Some(_)) => {
                attitude
                    .used(used, &mut samples)
                    .map_err(|e| log.error(line_no, e))?;
                if attitude.arrived_before(window.t_us) > used.to {
                    result.late_windows += 1;
                }
            }
            (Some(_), None) => samples.clear(),
            (None, _) => attitude.arrived_by(window.t_us, config.history_us, &mut samples),
        }
        let report = pipeline.process_window(taken, &samples, window.t_us, &mut NoClock);
        watch(taken, &report).map_err(ReplayError::Watch)?;
        let replayed = WindowLine::from_report(window.t_us, window.events, &report);
        let legacy_derotated = report.derotation.state != DerotationState::NoAttitude;
        events.consume(window.events);
        result.windows += 1;
        let mut replayed_json =
            serde_json::to_value(&replayed).map_err(|e| ReplayError::Output(e.into()))?;
        if version < 4 {
            // Those logs said `derotated` of a window that had any sample, or had
            // derotation off.
            replayed_json["derotated"] = legacy_derotated.into();
        }
        if let Some(why) = difference(&recorded, &replayed_json) {
            result.differing += 1;
            result.first_difference.get_or_insert((window.t_us, why));
        }
        print_line(&replayed, json, out)?;
    }
    Ok(result)
}

/// Refuses a recorded window the configuration could not have produced (load
/// shedding only ever lowers its limits) or whose time is out of range; its fit and
/// event limits otherwise.
fn check_window(
    window: &RecordedWindow,
    config: &PipelineConfig,
) -> Result<(usize, usize), String> {
    let max_fits = window.max_fits.unwrap_or(config.flow.max_fits_per_window);
    let max_events = window
        .max_events
        .unwrap_or(config.flow.max_events_per_window);
    if window.max_vectors > config.max_vectors
        || window.foe_iterations > config.faith.iterations
        || max_fits > config.flow.max_fits_per_window
        || max_events > config.flow.max_events_per_window
    {
        return Err(format!(
            "max_vectors {} / foe_iterations {} / max_fits {} / max_events {} exceed the configuration's {} / {} / {} / {}",
            window.max_vectors,
            window.foe_iterations,
            max_fits,
            max_events,
            config.max_vectors,
            config.faith.iterations,
            config.flow.max_fits_per_window,
            config.flow.max_events_per_window
        ));
    }
    if window.t_us.unsigned_abs() > Event::MAX_ABS_T_US as u64 {
        return Err(format!("window time {} us beyond +-2^53 us", window.t_us));
    }
    if let Some(why) = window.attitude.as_ref().and_then(AttitudeUsed::impossible) {
        return Err(why);
    }
    Ok((max_fits, max_events))
}

/// Why the events ran out for `window`.
fn ends_short(window: &RecordedWindow, short: usize) -> String {
    format!(
        "the window at {} us took {} events, but the event recording ends {short} events short",
        window.t_us, window.events
    )
}

/// A window log read line by line, its errors naming the file and the line.
struct WindowLogLines<'a> {
    path: &'a Path,
    lines: std::iter::Peekable<
        std::iter::Enumerate<std::io::Lines<std::io::BufReader<std::fs::File>>>,
    >,
}

impl<'a> WindowLogLines<'a> {
    fn open(path: &'a Path) -> Result<Self, ReplayError> {
        let file = std::fs::File::open(path).map_err(|source| ReplayError::Io {
            path: path.display().to_string(),
            source,
        })?;
        let lines = std::io::BufReader::new(file).lines().enumerate().peekable();
        Ok(Self { path, lines })
    }

    fn error(&self, line: usize, what: String) -> ReplayError {
        ReplayError::WindowLog {
            path: self.path.display().to_string(),
            line,
            what,
        }
    }

    fn io_error(&self, source: std::io::Error) -> ReplayError {
        ReplayError::Io {
            path: self.path.display().to_string(),
            source,
        }
    }

    /// The first line: the run's header.
    fn header(&mut self) -> Result<WindowLogHeader, ReplayError> {
        let text = match self.lines.next() {
            Some((_, line)) => line.map_err(|e| self.io_error(e))?,
            None => return Err(self.error(1, "empty file: no header line".into())),
        };
        serde_json::from_str(&text).map_err(|e| self.error(1, format!("header: {e}")))
    }

    /// The next window: its line number, the line as recorded and what the replay
    /// needs of it; `None` at the end, or at a last line cut short (the daemon was
    /// killed or lost power while writing it), which is said in the journal.
    fn next_window(
        &mut self,
    ) -> Result<Option<(usize, serde_json::Value, RecordedWindow)>, ReplayError> {
        let Some((index, line)) = self.lines.next() else {
            return Ok(None);
        };
        let line_no = index + 1;
        let text = line.map_err(|e| self.io_error(e))?;
        let recorded: serde_json::Value = match serde_json::from_str(&text) {
            Ok(v) => v,
            Err(e) if self.lines.peek().is_none() && !ends_with_newline(self.path) => {
                tracing::warn!(
                    line = line_no,
                    "the window log ends in a line cut short ({e}): the recording stopped mid-write; replayed up to the line before"
                );
                return Ok(None);
            }
            Err(e) => return Err(self.error(line_no, e.to_string())),
        };
        let window = RecordedWindow::deserialize(&recorded)
            .map_err(|e| self.error(line_no, e.to_string()))?;
        Ok(Some((line_no, recorded, window)))
    }
}

/// A recording's events, read ahead as far as the windows take them.
struct RecordedEvents<'a> {
    path: &'a Path,
    reader: Box<dyn faithd_formats::events::EventReader>,
    pending: Vec<Event>,
    batch: Vec<Event>,
    seen: u64,
}

/// Why a window's events could not be taken.
enum TakeError {
    Replay(ReplayError),
    /// The recording ended this many events short.
    Short(usize),
}

impl TakeError {
    fn or_short(self, short: impl FnOnce(usize) -> ReplayError) -> ReplayError {
        match self {
            TakeError::Replay(e) => e,
            TakeError::Short(n) => short(n),
        }
    }
}

impl<'a> RecordedEvents<'a> {
    fn open(path: &'a Path) -> Result<Self, ReplayError> {
        let reader = open_events(path).map_err(events_error(path))?;
        Ok(Self {
            path,
            reader,
            pending: Vec::new(),
            batch: Vec::new(),
            seen: 0,
        })
    }

    /// The next `count` events, read as needed; [`Self::consume`] drops them.
    fn take(&mut self, count: usize) -> Result<&[Event], TakeError> {
        while self.pending.len() < count {
            let more = self
                .reader
                .next_batch(&mut self.batch)
                .map_err(|e| TakeError::Replay(events_error(self.path)(e)))?;
            if !more {
                return Err(TakeError::Short(count - self.pending.len()));
            }
            check_times(self.path, &self.batch, &mut self.seen).map_err(TakeError::Replay)?;
            self.pending.extend_from_slice(&self.batch);
        }
        Ok(&self.pending[..count])
    }

    fn consume(&mut self, count: usize) {
        self.pending.drain(..count);
    }
}

/// The first and last event times of a recording, microseconds (`None`: no
/// events): a replay's windows run between them. Reads the file once more.
pub fn events_span(path: &Path) -> Result<Option<(i64, i64)>, ReplayError> {
    let events_err = events_error(path);
    let mut reader = open_events(path).map_err(events_err)?;
    let mut batch = Vec::new();
    let mut span: Option<(i64, i64)> = None;
    let mut seen = 0;
    while reader.next_batch(&mut batch).map_err(events_err)? {
        check_times(path, &batch, &mut seen)?;
        if let (Some(first), Some(last)) = (batch.first(), batch.last()) {
            span = Some((span.map_or(first.t_us, |s| s.0), last.t_us));
        }
    }
    Ok(span)
}

/// What a window log holds, at a glance: its settings, its first and last window
/// times (microseconds) and how many windows lie between (`None`: no windows).
/// Lines that do not parse are left to the replay to report.
pub struct WindowLogOutline {
    /// The pipeline settings the flight ran with.
    pub pipeline: PipelineConfig,
    pub windows: Option<(i64, i64, usize)>,
}

/// Reads a window log once through for its [`WindowLogOutline`].
pub fn window_log_outline(path: &Path) -> Result<WindowLogOutline, ReplayError> {
    let log_err = |line: usize, what: String| ReplayError::WindowLog {
        path: path.display().to_string(),
        line,
        what,
    };
    let file = std::fs::File::open(path).map_err(|source| ReplayError::Io {
        path: path.display().to_string(),
        source,
    })?;
    let mut lines = std::io::BufReader::new(file).lines();
    let header_text = lines
        .next()
        .and_then(Result::ok)
        .ok_or_else(|| log_err(1, "empty file: no header line".into()))?;
    let header: WindowLogHeader =
        serde_json::from_str(&header_text).map_err(|e| log_err(1, format!("header: {e}")))?;
    let mut windows: Option<(i64, i64, usize)> = None;
    for line in lines {
        let Ok(line) = line else { break };
        let Ok(window) = serde_json::from_str::<RecordedWindow>(&line) else {
            continue;
        };
        windows = Some(match windows {
            None => (window.t_us, window.t_us, 1),
            Some((first, _, n)) => (first, window.t_us, n + 1),
        });
    }
    Ok(WindowLogOutline {
        pipeline: header.pipeline_as_run().unwrap_or(header.pipeline),
        windows,
    })
}

fn print_line(line: &WindowLine, json: bool, out: &mut dyn Write) -> Result<(), ReplayError> {
    if json {
        serde_json::to_writer(&mut *out, line).map_err(|e| ReplayError::Output(e.into()))?;
        writeln!(out).map_err(ReplayError::Output)
    } else {
        writeln!(
            out,
            "{:>12} us  {:>6} events  {}",
            line.t_us, line.events, line.decision
        )
        .map_err(ReplayError::Output)
    }
}

/// The ATTITUDE frames of a daemon recording, in the order the link read them, and
/// the samples the link made of them. A version-4 window names the samples it was
/// handed ([`Self::used`]); an older one takes those whose frames arrived before it
/// ([`Self::arrived_by`]).
#[derive(Default)]
struct RecordedAttitude {
    /// (arrival_us, message) of every ATTITUDE the link turned into a sample.
    frames: Vec<(i64, MavMessage)>,
    /// The samples made so far: `samples[k]` is the link's sample number `k`.
    samples: Vec<AttitudeSample>,
    sync: ClockSync,
    /// The number of the session `sync` belongs to.
    session: u64,
    /// Older logs: the samples pushed so far, as the daemon's log held them.
    arrived: usize,
    log: AttitudeLog,
}

impl RecordedAttitude {
    fn from_tlog(path: &Path, header: &WindowLogHeader) -> Result<Self, ReplayError> {
        let file = std::fs::File::open(path).map_err(|source| ReplayError::Io {
            path: path.display().to_string(),
            source,
        })?;
        let mut reader = TlogReader::new(std::io::BufReader::new(file));
        // Which frames the link took: a throwaway clock, since a frame's sample
        // depends on it only for its time.
        let mut scratch = ClockSync::new(header.clock_sync_window);
        let mut vehicle = VehicleState::default();
        let mut frames = Vec::new();
        while let Some(rec) = reader.next_record().map_err(|source| ReplayError::Tlog {
            path: path.display().to_string(),
            source,
        })? {
            let own = rec.header.system_id == u32::from(header.own_system_id)
                && rec.header.component_id == header.own_component_id;
            let autopilot = rec.header.system_id == u32::from(header.autopilot_system_id)
                && header
                    .autopilot_component_id
                    .is_none_or(|c| rec.header.component_id == c);
            if own || !autopilot {
                continue;
            }
            let Some(msg) = rec.message else { continue };
            let rx_us = rec.t_unix_us as i64 - header.clock_start_unix_us;
            if let Update::Attitude(_) = telemetry::apply(&mut vehicle, &mut scratch, &msg, rx_us) {
                frames.push((rx_us, msg));
            }
        }
        Ok(Self {
            frames,
            sync: ClockSync::new(header.clock_sync_window),
            ..Self::default()
        })
    }

    /// Makes samples up to number `to`, the clock offset estimated afresh from number
    /// `session` on, as the link did in a new session.
    fn make_until(&mut self, to: u64, session: u64) -> Result<(), String> {
        let fresh = |sync: &ClockSync| ClockSync::new(sync.window());
        if session > self.session {
            if self.samples.len() as u64 > session {
                return Err(format!(
                    "attitude session from sample {session} begins before samples already used ({})",
                    self.samples.len()
                ));
            }
            self.make(session)?;
            self.sync = fresh(&self.sync);
            self.session = session;
        }
        self.make(to)
    }

    fn make(&mut self, to: u64) -> Result<(), String> {
        let mut vehicle = VehicleState::default();
        while (self.samples.len() as u64) < to {
            let k = self.samples.len();
            let Some((rx_us, msg)) = self.frames.get(k) else {
                return Err(format!(
                    "the flight used attitude samples up to number {to}, but the .tlog holds {}: not this flight's .tlog, or part of it",
                    self.frames.len()
                ));
            };
            let Update::Attitude(sample) =
                telemetry::apply(&mut vehicle, &mut self.sync, msg, *rx_us)
            else {
                unreachable!("only frames that gave a sample are kept");
            };
            self.samples.push(sample);
        }
        Ok(())
    }

    /// The samples a version-4 window names, checked against the newest one's time.
    fn used(&mut self, used: &AttitudeUsed, out: &mut Vec<AttitudeSample>) -> Result<(), String> {
        self.make_until(used.to, used.session)?;
        out.clear();
        out.extend_from_slice(&self.samples[used.from as usize..used.to as usize]);
        let last_t_us = out.last().map(|s| s.t_us);
        if last_t_us != used.last_t_us {
            return Err(format!(
                "the .tlog's attitude sample {} is at {} us, the one the flight used at {} us: not this flight's .tlog, or frames were lost from it",
                used.to.saturating_sub(1),
                last_t_us.unwrap_or_default(),
                used.last_t_us.unwrap_or_default()
            ));
        }
        Ok(())
    }

    /// How many samples' frames had arrived by `t_us`.
    fn arrived_before(&self, t_us: i64) -> u64 {
        self.frames
            .partition_point(|(arrival_us, _)| *arrival_us <= t_us) as u64
    }

    /// An older window: the samples whose frames arrived by `t_us`, as the daemon's
    /// log would hold them had each reached it on arrival.
    fn arrived_by(&mut self, t_us: i64, history_us: i64, out: &mut Vec<AttitudeSample>) {
        while let Some(&(arrival_us, _)) = self.frames.get(self.arrived)
            && arrival_us <= t_us
        {
            // Older logs never name a session: one clock estimate over the flight.
            if self.make(self.arrived as u64 + 1).is_err() {
                break;
            }
            self.log.push(self.samples[self.arrived]);
            self.arrived += 1;
        }
        self.log.copy_for_window(t_us, history_us, out);
    }
}

/// Whether a file's last byte is a newline (a file cut mid-line is not).
fn ends_with_newline(path: &std::path::Path) -> bool {
    use std::io::{Read, Seek, SeekFrom};
    let Ok(mut file) = std::fs::File::open(path) else {
        return false;
    };
    let mut last = [0u8; 1];
    file.seek(SeekFrom::End(-1)).is_ok() && file.read_exact(&mut last).is_ok() && last[0] == b'\n'
}
