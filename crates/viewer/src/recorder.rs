//! The recording to the rerun viewer (cargo feature `rerun`): a campaign [`Observer`] that
//! writes one *campaign recording* (its own blueprint: found failures over runtime per stage,
//! fidelity success rate and cost ratio, the posterior grids — see `campaign`) and, for a
//! bounded choice of trials, one *trial recording* each, in the same file or viewer, named by
//! stage, trial, scenario and outcome (the trial view — see `trial`).
//!
//! Which trials get frames: every `every`-th told trial as it is told, and — when the campaign
//! ends — up to `failure_cap` of the informative ones, spread over the stages and the outcome
//! classes (FN, FP, TP, and HF failures of the baselines, which have no LF run): the first
//! trial of each (stage, class) in turn — first the first stage that has each class, in the
//! order FN, FP, TP, baseline failure, then the second stage that has each, … — then the
//! second trial of each, and so on (see [`Candidates::choose`]). Frames are re-runs of the same
//! deterministic runs with recording on. When the campaign ends the campaign's blueprint is
//! activated again, last in the file, so that a viewer opens on the campaign view.

use super::campaign::CampaignView;
use super::layout;
use super::stream::{close, open, RecordError, RecordOptions, TrialFrames};
use super::trial::{self, TrialRecording};
use rerun::external::re_log_types::BlueprintActivationCommand;
use rerun::RecordingStream;
use savme_campaign::log::{ScreenLine, TrialLine};
use savme_campaign::{CampaignError, Cost, Observer, Problem, Protocol, Stage};
use savme_kernel::{Kernel, Outcome};
use std::collections::BTreeSet;

/// The application id of campaign recordings (the viewer keeps one layout per application).
pub const CAMPAIGN_APP: &str = "savme-campaign";

/// The outcome classes whose trials are worth frames, in the order they are picked.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Class {
    Fn,
    Fp,
    Tp,
    /// An HF failure of a baseline (no LF run).
    HfFailure,
}

fn class(line: &TrialLine) -> Option<Class> {
    match line.outcome {
        Some(Outcome::FN) => Some(Class::Fn),
        Some(Outcome::FP) => Some(Class::Fp),
        Some(Outcome::TP) => Some(Class::Tp),
        None if line.hf.failure => Some(Class::HfFailure),
        _ => None,
    }
}

/// Trials kept for frames, with their campaign-wide told index.
type Kept = Vec<(u64, TrialLine)>;

/// The informative trials kept for frames: per (stage, class), in campaign order, at most
/// `cap` each.
#[derive(Debug, Default)]
struct Candidates {
    buckets: Vec<((savme_campaign::StageId, Class), Kept)>,
}

impl Candidates {
    fn offer(&mut self, n: u64, line: &TrialLine, cap: usize) {
        let Some(c) = class(line) else {
            return;
        };
        let key = (line.stage, c);
        let k = match self.buckets.iter().position(|(k, _)| *k == key) {
            Some(k) => k,
            None => {
                self.buckets.push((key, Vec::new()));
                self.buckets.len() - 1
            }
        };
        let list = &mut self.buckets[k].1;
        if list.len() < cap {
            list.push((n, line.clone()));
        }
    }

    /// Up to `cap` trials not in `done`, spread over stages and classes: round `r` takes the
    /// `r`-th trial of every (stage, class), visiting them by (the stage's rank among the
    /// stages that have this class, class).
    fn choose(self, cap: usize, done: &BTreeSet<u64>) -> Kept {
        let mut seen: Vec<(Class, usize)> = Vec::new();
        let mut order: Vec<((usize, Class), Kept)> = Vec::new();
        for ((_, c), list) in self.buckets {
            let rank = match seen.iter_mut().find(|(k, _)| *k == c) {
                Some((_, r)) => {
                    *r += 1;
                    *r
                }
                None => {
                    seen.push((c, 0));
                    0
                }
            };
            let fresh: Kept = list
                .into_iter()
                .filter(|(n, _)| !done.contains(n))
                .collect();
            order.push(((rank, c), fresh));
        }
        order.sort_by_key(|(k, _)| *k);
        let mut out = Vec::new();
        let rounds = order.iter().map(|(_, l)| l.len()).max().unwrap_or(0);
        for r in 0..rounds {
            for (_, list) in &order {
                if out.len() == cap {
                    return out;
                }
                out.extend(list.get(r).cloned());
            }
        }
        out.truncate(cap);
        out
    }
}

/// A campaign's recording in progress. Close it with [`Observer::finish`] (also done on drop,
/// and by the Ctrl-C handler), so the file always gets its footer.
pub struct Recorder {
    rec: RecordingStream,
    activation: BlueprintActivationCommand,
    cost: Cost,
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
        let (rec, activation) = open(
            &opts.sink,
            CAMPAIGN_APP,
            &format!("campaign (seed {})", protocol.seed),
            layout::campaign(&CampaignView::plan(&problem, protocol)),
        )?;
        let view = CampaignView::new(&problem, protocol);
        view.log_key(&rec)?;
        Ok(Recorder {
            rec,
            activation,
            cost: protocol.cost,
            opts,
            told: 0,
            recorded: BTreeSet::new(),
            names: Vec::new(),
            candidates: Candidates::default(),
            frames,
            view,
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
            t.outcome(&trial::campaign_markdown(
                line,
                &self.problem.theta_hf,
                self.cost,
            ))?;
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
        // Last in the file: a viewer opens on the campaign view, not on the last trial.
        layout::activate(&self.rec, self.activation.clone());
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
