//! A campaign's trial frames as time series ([`SeriesFrames`]): no scene, but the outputs a
//! simulator records (an FMU campaign: those its file lists under `[fmu] record = [...]`, read at
//! every communication point of a re-run of the trial, in this process or in an FMU worker, as
//! the campaign ran it; any simulator through [`Rerun`]), logged as time series over `sim_time`: `/plots/<output>/hf` and `/plots/<output>/lf` (one plot per output,
//! HF and LF in it, as the trial view plots the bundled simulator's clearance); for a threshold
//! failure on a recorded output, the threshold as `/plots/<output>/threshold`; the first
//! failure (or its absence) in `/{hf,lf}/events`. Laid out by [`super::layout::fmu_trial`].
//!
//! An output that starts at a sentinel (a magnitude of at least [`SENTINEL`], e.g. a
//! `min_distance` of 1e6 before anything was measured) would stretch its plot's axis so that
//! every real value sits at zero: its leading sentinel points are left out of the plot, and
//! the events say so.

use super::layout::plot_path;
use super::layout::{self, Layout};
use super::palette::{self, rgb};
use super::series::{Rerun, Signal};
use super::stream::{err, RecordError, RunSide, RunSummary, TrialFrames};
use rerun::{EntityPath, RecordingStream, TimeColumn};
use savme_kernel::{Assignment, Role};

/// The application id of paired trial recordings of time series (their own layout: one plot per
/// output; the id names FMUs, whose campaigns record them first).
pub const FMU_APP: &str = "savme-fmu-trial";
/// The application of an HF-only trial's recording of time series (its plots have no LF run: the viewer
/// keeps one layout per application, so HF-only trials get their own).
pub const FMU_HF_APP: &str = "savme-fmu-hf-run";

/// Values of at least this magnitude at the start of an output are placeholders, not plotted.
pub const SENTINEL: f64 = 1e6;

/// How many leading points of `values` are sentinels (0 when every point is one: then there is
/// nothing else to show).
///
/// ```
/// use savme_viewer::leading_sentinels;
/// assert_eq!(leading_sentinels(&[1e6, 1e6, 3.0, 2.0]), 2);
/// assert_eq!(leading_sentinels(&[4.0, 1e6]), 0);
/// assert_eq!(leading_sentinels(&[1e6, 1e6]), 0);
/// ```
pub fn leading_sentinels(values: &[f64]) -> usize {
    let k = values.iter().take_while(|v| v.abs() >= SENTINEL).count();
    if k == values.len() {
        0
    } else {
        k
    }
}

/// Re-runs a campaign's trials recording the outputs `record`.
pub struct SeriesFrames {
    runner: Box<dyn Rerun>,
    record: Vec<String>,
    signal: Signal,
}

fn colour(run: RunSide) -> rerun::Color {
    match run {
        RunSide::Hf => rgb(palette::HF),
        RunSide::Lf => rgb(palette::LF),
    }
}

impl SeriesFrames {
    /// Frames of `runner`'s re-runs showing the outputs `record` (checked against the
    /// simulator by its adapter, e.g. the campaign file against the FMUs); `signal` is the
    /// campaign's failure signal (its threshold is drawn).
    pub fn new(runner: impl Rerun + 'static, record: Vec<String>, signal: Signal) -> Self {
        SeriesFrames {
            runner: Box::new(runner),
            record,
            signal,
        }
    }

    /// The first failure, or none, as an event of `run`.
    fn log_event(
        &self,
        rec: &RecordingStream,
        run: RunSide,
        failure_time: Option<f64>,
        end: f64,
    ) -> Result<(), RecordError> {
        let signal = self.signal.text();
        let (time, log) = match failure_time {
            Some(t) => (
                t,
                rerun::TextLog::new(format!("{}: failure ({signal}) at {t:.2} s", run.label()))
                    .with_level(rerun::TextLogLevel::WARN),
            ),
            None => (
                end,
                rerun::TextLog::new(format!(
                    "{}: no failure ({signal}) until {end:.2} s",
                    run.label()
                ))
                .with_level(rerun::TextLogLevel::INFO),
            ),
        };
        rec.set_duration_secs("sim_time", time);
        rec.log(format!("{}/events", run.path()), &log).map_err(err)
    }
}

impl TrialFrames for SeriesFrames {
    fn layout(&self, paired: bool) -> (&'static str, Layout) {
        let app = if paired { FMU_APP } else { FMU_HF_APP };
        (app, layout::fmu_trial(&self.record, paired))
    }

    fn record_scene(
        &mut self,
        rec: &RecordingStream,
        _scenario: &str,
    ) -> Result<bool, RecordError> {
        if let Some((variable, _, name)) = self.signal.line() {
            if self.record.iter().any(|r| r == variable) {
                rec.log_static(
                    plot_path(variable).join(&EntityPath::from("threshold")),
                    &rerun::SeriesLines::new()
                        .with_names([name])
                        .with_colors([rerun::Color::from_rgb(200, 200, 200)]),
                )
                .map_err(err)?;
            }
        }
        Ok(true)
    }

    fn record_run(
        &mut self,
        rec: &RecordingStream,
        run: RunSide,
        scenario: &str,
        phi: &Assignment,
        theta: &Assignment,
    ) -> Result<Option<RunSummary>, RecordError> {
        let role = match run {
            RunSide::Hf => Role::High,
            RunSide::Lf => Role::Learned,
        };
        let (result, trace) = self
            .runner
            .rerun(role, scenario, phi, theta, &self.record)
            .map_err(err)?;
        let times = || TimeColumn::new_duration_secs("sim_time", trace.times.iter().copied());
        for (name, values) in trace.names.iter().zip(&trace.values) {
            let path = plot_path(name).join(&EntityPath::from(run.path()));
            rec.log_static(
                path.clone(),
                &rerun::SeriesLines::new()
                    .with_names([run.label()])
                    .with_colors([colour(run)]),
            )
            .map_err(err)?;
            let skip = leading_sentinels(values);
            if skip > 0 {
                let until = trace.times.get(skip).copied().unwrap_or(0.0);
                rec.set_duration_secs("sim_time", 0.0);
                rec.log(
                    format!("{}/events", run.path()),
                    &rerun::TextLog::new(format!(
                        "{}: `{name}` starts at placeholder {:e}: plotted from {until:.2} s",
                        run.label(),
                        values[0]
                    ))
                    .with_level(rerun::TextLogLevel::INFO),
                )
                .map_err(err)?;
            }
            rec.send_columns(
                path,
                [TimeColumn::new_duration_secs(
                    "sim_time",
                    trace.times.iter().skip(skip).copied(),
                )],
                rerun::Scalars::new(values.iter().skip(skip).copied())
                    .columns_of_unit_batches()
                    .map_err(err)?,
            )
            .map_err(err)?;
        }
        if let Some((variable, value, _)) = self.signal.line() {
            if run == RunSide::Hf && self.record.iter().any(|r| r == variable) {
                rec.send_columns(
                    plot_path(variable).join(&EntityPath::from("threshold")),
                    [times()],
                    rerun::Scalars::new(vec![value; trace.times.len()])
                        .columns_of_unit_batches()
                        .map_err(err)?,
                )
                .map_err(err)?;
            }
        }
        let end = trace.times.last().copied().unwrap_or(0.0);
        self.log_event(rec, run, trace.failure_time, end)?;
        Ok(Some(RunSummary {
            failure: result.failure,
            collision_time: trace.failure_time,
            min_distance: f64::NAN,
            steps: trace.times.len().saturating_sub(1) as u64,
            wall_seconds: result.wall_seconds,
            work: result.work,
        }))
    }
}
