//! One trial as its own recording, laid out by the trial view: the HF run and (for a paired
//! trial) the LF run side by side on one `sim_time` timeline, the outcome as a short Markdown
//! document under `/outcome`.

use super::layout;
use super::stream::{err, RecordError, RunSide, RunSummary, TrialFrames};
use rerun::RecordingStream;
use savme_campaign::log::TrialLine;
use savme_campaign::Cost;
use savme_kernel::{Assignment, Outcome, Value};
use std::fmt::Write as _;

/// The application id of paired trial recordings.
pub const PAIRED_APP: &str = "savme-trial";
/// The application id of HF-only trial recordings (baselines; `simulate` at θ_HF).
pub const HF_APP: &str = "savme-hf-run";

/// The application id (and so the layout) of a trial recording.
pub fn app(paired: bool) -> &'static str {
    if paired {
        PAIRED_APP
    } else {
        HF_APP
    }
}

/// The name of a campaign trial's recording: outcome first (the viewer's Sources panel cuts
/// long names off at the right), then stage, trial and scenario — `FN · train@0.3 #12
/// lead_vehicle_brakes`.
pub fn name(line: &TrialLine) -> String {
    format!(
        "{} · {} #{} {}",
        outcome_label(line.outcome, line.hf.failure),
        line.stage,
        line.index,
        line.scenario,
    )
}

fn outcome_label(outcome: Option<Outcome>, hf_failure: bool) -> String {
    match outcome {
        Some(o) => format!("{o:?}"),
        None if hf_failure => "HF failure".into(),
        None => "HF pass".into(),
    }
}

/// A trial recording in progress.
pub struct TrialRecording {
    rec: RecordingStream,
}

impl TrialRecording {
    /// A new recording named `name` of application `app`, laid out by `layout`, whose
    /// messages go to `hub`'s sink (one file or viewer holds the campaign and its trials).
    pub fn forwarded(
        hub: &RecordingStream,
        name: &str,
        (app, layout): (&'static str, layout::Layout),
    ) -> Result<Self, RecordError> {
        let hub = hub.clone();
        let sink = rerun::sink::CallbackSink::new(move |msgs| {
            for m in msgs {
                hub.record_msg(m.clone());
            }
        });
        let rec = rerun::RecordingStreamBuilder::new(app)
            .recording_name(name)
            .set_sinks(vec![Box::new(sink) as Box<dyn rerun::sink::LogSink>])
            .map_err(err)?;
        super::stream::quiet_clocks(&rec);
        layout.send(&rec)?;
        Ok(TrialRecording { rec })
    }

    /// A trial recording on a stream of its own (opened with the trial layout).
    pub fn on(rec: RecordingStream) -> Self {
        TrialRecording { rec }
    }

    /// Runs and logs the scene, the HF run at `theta_hf` and, if given, the LF run; None when
    /// the simulator has no frames for `scenario`.
    pub fn record(
        &self,
        frames: &mut dyn TrialFrames,
        scenario: &str,
        phi: &Assignment,
        theta_hf: &Assignment,
        theta_lf: Option<&Assignment>,
    ) -> Result<Option<(RunSummary, Option<RunSummary>)>, RecordError> {
        if !frames.record_scene(&self.rec, scenario)? {
            return Ok(None);
        }
        let Some(hf) = frames.record_run(&self.rec, RunSide::Hf, scenario, phi, theta_hf)? else {
            return Ok(None);
        };
        let lf = match theta_lf {
            Some(t) => frames.record_run(&self.rec, RunSide::Lf, scenario, phi, t)?,
            None => None,
        };
        Ok(Some((hf, lf)))
    }

    /// Its stream.
    pub fn stream(&self) -> &RecordingStream {
        &self.rec
    }

    /// The outcome document.
    pub fn outcome(&self, markdown: &str) -> Result<(), RecordError> {
        self.rec
            .log_static("outcome", &rerun::TextDocument::from_markdown(markdown))
            .map_err(err)
    }

    /// Flushes it into the sink.
    pub fn close(self) -> Result<(), RecordError> {
        self.rec.flush_blocking().map_err(err)
    }
}

/// `name=value, …` with reals to 3 decimals.
pub fn compact(pairs: impl Iterator<Item = (String, Value)>) -> String {
    pairs
        .map(|(name, v)| match v {
            Value::Real(x) => format!(
                "{name}={}",
                format!("{x:.3}")
                    .trim_end_matches('0')
                    .trim_end_matches('.')
            ),
            v => format!("{name}={v}"),
        })
        .collect::<Vec<_>>()
        .join(", ")
}

fn all(a: &Assignment) -> String {
    compact(a.iter().map(|(n, v)| (n.to_string(), v.clone())))
}

/// The settings of `theta` that differ from θ_HF (or "none").
pub fn theta_difference(theta: &Assignment, theta_hf: &Assignment) -> String {
    let diff = compact(
        theta
            .iter()
            .filter(|(name, v)| theta_hf.get(name) != Some(*v))
            .map(|(n, v)| (n.to_string(), v.clone())),
    );
    if diff.is_empty() {
        "none".into()
    } else {
        diff
    }
}

fn run_text(r: &RunSummary) -> String {
    match r.collision_time {
        Some(t) => format!("**collision** at {t:.2} s"),
        None => format!(
            "no collision (closest approach {:.2} m between the bodies)",
            r.min_distance
        ),
    }
}

/// What a cost ratio is a ratio of.
fn cost_unit(cost: Cost) -> &'static str {
    match cost {
        Cost::Work => "work units",
        Cost::Wall => "wall time",
    }
}

fn failed(f: bool) -> &'static str {
    if f {
        "**failure**"
    } else {
        "pass"
    }
}

/// The outcome of a campaign trial: its line (the campaign's measured runtimes and outcome);
/// `cost` is what the campaign's cost ratios measure.
pub fn campaign_markdown(line: &TrialLine, theta_hf: &Assignment, cost: Cost) -> String {
    let mut s = format!(
        "## {} — {}\n\n{} · trial #{}\n\n",
        outcome_label(line.outcome, line.hf.failure),
        line.scenario,
        line.stage,
        line.index,
    );
    let _ = writeln!(
        s,
        "- **HF**: {} · {:.1} ms wall",
        failed(line.hf.failure),
        line.hf.wall_seconds * 1e3
    );
    if let Some(l) = &line.lf {
        let _ = writeln!(
            s,
            "- **LF**: {} · {:.1} ms wall",
            failed(l.failure),
            l.wall_seconds * 1e3
        );
    }
    if let Some(r) = line.cost_ratio {
        let unit = cost_unit(cost);
        let _ = writeln!(s, "- cost ratio t_LF / t_HF ({unit}): **{r:.3}**");
    }
    let _ = writeln!(s, "\n**φ**: {}", all(&line.phi));
    if let Some(t) = &line.theta_lf {
        let _ = writeln!(
            s,
            "\n**θ_LF**, settings off θ_HF: {}",
            theta_difference(t, theta_hf)
        );
    }
    s
}

/// The outcome of `savme simulate`: its runs as just run.
pub fn run_markdown(
    scenario: &str,
    phi: &Assignment,
    hf: &RunSummary,
    lf: Option<(&RunSummary, &Assignment, &Assignment)>,
) -> String {
    let head = match lf {
        Some((l, _, _)) => format!("{:?}", Outcome::classify(hf.failure, l.failure)),
        None => outcome_label(None, hf.failure),
    };
    let mut s = format!("## {head} — {scenario}\n\n");
    let _ = writeln!(
        s,
        "- **HF**: {} · {:.1} ms wall",
        run_text(hf),
        hf.wall_seconds * 1e3
    );
    if let Some((l, _, _)) = lf {
        let _ = writeln!(
            s,
            "- **LF**: {} · {:.1} ms wall",
            run_text(l),
            l.wall_seconds * 1e3
        );
        if let (Some(hw), Some(lw)) = (hf.work, l.work) {
            let _ = writeln!(
                s,
                "- cost ratio t_LF / t_HF (work units): **{:.3}**",
                lw as f64 / hw.max(1) as f64
            );
        }
    }
    let _ = writeln!(s, "\n**φ**: {}", all(phi));
    if let Some((_, theta, theta_hf)) = lf {
        let _ = writeln!(
            s,
            "\n**θ_LF**, settings off θ_HF: {}",
            theta_difference(theta, theta_hf)
        );
    }
    s
}
