//! The recording to the rerun viewer (cargo feature `rerun`): a campaign [`Observer`] that
//! writes one *campaign recording* (its own blueprint: found failures over runtime per stage,
//! fidelity success rate and cost ratio, the posterior grids — see `campaign`) and, for a
//! bounded choice of trials, one *trial recording* each, in the same file or viewer, named by
//! stage, trial, scenario and outcome (the trial view — see `trial`).
//!
//! Which trials get frames: every `every`-th told trial as it is told, and — when the campaign
//! ends — up to `failure_cap` of the informative ones: FN and FP of the learning and evaluation
//! stages first (alternately, in campaign order), then TP, and HF failures of the baselines
//! (which have no LF run) only while no other remains. Frames are re-runs of the same
//! deterministic runs with recording on.

use super::campaign::CampaignView;
use super::layout;
use super::stream::{close, open, RecordError, RecordOptions, TrialFrames};
use super::trial::{self, TrialRecording};
use rerun::RecordingStream;
use savme_campaign::log::{ScreenLine, TrialLine};
use savme_campaign::{CampaignError, Observer, Problem, Protocol, Stage};
use savme_kernel::{Kernel, Outcome};
use std::collections::BTreeSet;

/// The application id of campaign recordings (the viewer keeps one layout per application).
pub const CAMPAIGN_APP: &str = "savme-campaign";

/// How informative a trial's frames are: lower goes first.
fn priority(line: &TrialLine) -> Option<u8> {
    match line.outcome {
        Some(Outcome::FN) | Some(Outcome::FP) => Some(0),
        Some(Outcome::TP) => Some(1),
        None if line.hf.failure => Some(2),
        _ => None,
    }
}

/// The informative trials kept for frames, bounded per class.
#[derive(Debug, Default)]
struct Candidates {
    fn_: Vec<(u64, TrialLine)>,
    fp: Vec<(u64, TrialLine)>,
    tp: Vec<(u64, TrialLine)>,
    baseline: Vec<(u64, TrialLine)>,
}

impl Candidates {
    fn offer(&mut self, n: u64, line: &TrialLine, cap: usize) {
        let list = match (priority(line), line.outcome) {
            (Some(0), Some(Outcome::FN)) => &mut self.fn_,
            (Some(0), _) => &mut self.fp,
            (Some(1), _) => &mut self.tp,
            (Some(2), _) => &mut self.baseline,
            _ => return,
        };
        if list.len() < cap {
            list.push((n, line.clone()));
        }
    }

    /// Up to `cap` trials not in `done`: FN and FP alternately, then TP, then baselines.
    fn choose(self, cap: usize, done: &BTreeSet<u64>) -> Vec<(u64, TrialLine)> {
        let fresh = |v: Vec<(u64, TrialLine)>| -> Vec<(u64, TrialLine)> {
            v.into_iter().filter(|(n, _)| !done.contains(n)).collect()
        };
        let (mut fns, mut fps) = (fresh(self.fn_).into_iter(), fresh(self.fp).into_iter());
        let mut out = Vec::new();
        loop {
            let (a, b) = (fns.next(), fps.next());
            if a.is_none() && b.is_none() {
                break;
            }
            out.extend(a);
            out.extend(b);
        }
        out.extend(fresh(self.tp));
        out.extend(fresh(self.baseline));
        out.truncate(cap);
        out
    }
}

/// A campaign's recording in progress. Close it with [`Observer::finish`] (also done on drop,
/// and by the Ctrl-C handler), so the file always gets its footer.
pub struct Recorder {
    rec: RecordingStream,
    opts: RecordOptions,
    told: u64,
    recorded: BTreeSet<u64>,
    names: Vec<String>,
    candidates: Candidates,
    frames: Option<Box<dyn TrialFrames>>,
    problem: Problem,
    view: CampaignView,
    finished: bool,
}

impl std::fmt::Debug for Recorder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recorder")
            .field("opts", &self.opts)
            .field("told", &self.told)
            .finish()
    }
}

impl Recorder {
    /// Opens the sink with the campaign view. `frames` re-runs the trials that get frames.
    pub fn start(
        opts: RecordOptions,
        frames: Option<Box<dyn TrialFrames>>,
        protocol: &Protocol,
        problem: Problem,
    ) -> Result<Recorder, RecordError> {
        let rec = open(
            &opts.sink,
            CAMPAIGN_APP,
            &format!("campaign (seed {})", protocol.seed),
            layout::campaign(&CampaignView::learning_labels(protocol)),
        )?;
        Ok(Recorder {
            rec,
            opts,
            told: 0,
            recorded: BTreeSet::new(),
            names: Vec::new(),
            candidates: Candidates::default(),
            frames,
            view: CampaignView::new(&problem),
            problem,
            finished: false,
        })
    }

    /// The campaign recording's stream.
    pub fn stream(&self) -> &RecordingStream {
        &self.rec
    }

    /// Records one trial as its own recording (in the same sink), named by stage, trial,
    /// scenario and outcome.
    pub fn record_trial(&mut self, n: u64, line: &TrialLine) -> Result<(), RecordError> {
        let Some(frames) = self.frames.as_mut() else {
            return Ok(());
        };
        let name = trial::name(line);
        let t =
            TrialRecording::forwarded(&self.rec, &name, frames.layout(line.theta_lf.is_some()))?;
        let runs = t.record(
            frames.as_mut(),
            &line.scenario,
            &line.phi,
            &self.problem.theta_hf,
            line.theta_lf.as_ref(),
        )?;
        if runs.is_some() {
            t.outcome(&trial::campaign_markdown(line, &self.problem.theta_hf))?;
            self.recorded.insert(n);
            self.names.push(name);
        }
        t.close()
    }

    fn observer_finish(&mut self) -> Result<(), CampaignError> {
        if self.finished {
            return Ok(());
        }
        self.finished = true;
        let chosen = std::mem::take(&mut self.candidates)
            .choose(self.opts.failure_cap as usize, &self.recorded);
        for (n, line) in chosen {
            if let Err(e) = self.record_trial(n, &line) {
                eprintln!(
                    "savme: recording trial {} of {}: {e}",
                    line.index, line.stage
                );
            }
        }
        let summary = self.view.summary_markdown(&self.names, &self.opts);
        let _ = self.rec.log_static(
            "campaign/summary",
            &rerun::TextDocument::from_markdown(summary),
        );
        close(&self.rec, &self.opts.sink).map_err(|e| CampaignError::Recording(e.0))
    }
}

impl Observer for Recorder {
    fn finish(&mut self) -> Result<(), CampaignError> {
        self.observer_finish()
    }

    fn screened(&mut self, stage: &Stage, line: &ScreenLine, _: &Kernel) {
        // On the campaign's curves only: a screening trial is not a paired trial to replay.
        let n = self.told;
        self.told += 1;
        if let Err(e) = self.view.screened(&self.rec, n, stage, line) {
            eprintln!("savme: recording: {e}");
        }
    }

    fn trial(&mut self, stage: &Stage, line: &TrialLine, kernel: &Kernel) {
        let n = self.told;
        self.told += 1;
        if let Err(e) = self.view.trial(&self.rec, n, stage, line, kernel) {
            eprintln!("savme: recording: {e}");
        }
        if self.opts.every > 0 && n.is_multiple_of(self.opts.every) {
            if let Err(e) = self.record_trial(n, line) {
                eprintln!(
                    "savme: recording trial {} of {}: {e}",
                    line.index, line.stage
                );
            }
        } else {
            self.candidates
                .offer(n, line, self.opts.failure_cap as usize);
        }
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        let _ = self.rec.flush_blocking();
    }
}
