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
//! deterministic runs with recording on. The campaign's blueprint is activated again after
//! each trial recorded as it is told and, when the campaign ends, last in the file or stream,
//! so that a viewer — opening the file, or watching live — shows the campaign view; each
//! campaign is its own application ([`campaign_app`]), so that it is this campaign's view.

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

/// The start of every campaign recording's application id (see [`campaign_app`]).
pub const CAMPAIGN_APP: &str = "savme-campaign";

/// The application id of a campaign recording started at `unix_seconds`: [`CAMPAIGN_APP`], the
/// seed and the UTC start time, e.g. `savme-campaign - seed 1 - 2026-11-26 12:44:01 UTC` (an
/// application id allows letters, digits, spaces and `_-[]:` only).
///
/// Each campaign is its own application, because the viewer keeps one active layout per
/// application and, when a layout is activated, switches to that application's *earliest*
/// recording: with one id for every campaign, a second campaign streamed into a running
/// viewer (or a second file opened beside the first) would bring back the first campaign, and
/// show it with the second one's stages and scenarios. It is also the name the viewer's
/// *Sources* panel lists the campaign under.
///
/// ```
/// use savme_viewer::{campaign_app, is_campaign_app};
/// let app = campaign_app(1, 1_795_697_041);
/// assert_eq!(app, "savme-campaign - seed 1 - 2026-11-26 12:44:01 UTC");
/// assert!(is_campaign_app(&app) && !is_campaign_app("savme-trial"));
/// ```
pub fn campaign_app(seed: u64, unix_seconds: u64) -> String {
    let (days, secs) = (unix_seconds / 86_400, unix_seconds % 86_400);
    let (y, m, d) = civil_date(days);
    format!(
        "{CAMPAIGN_APP} - seed {seed} - {y:04}-{m:02}-{d:02} {:02}:{:02}:{:02} UTC",
        secs / 3600,
        secs / 60 % 60,
        secs % 60
    )
}

/// True for a campaign recording's application id (one made by [`campaign_app`]).
pub fn is_campaign_app(app: &str) -> bool {
    app == CAMPAIGN_APP || app.starts_with(&format!("{CAMPAIGN_APP} - "))
}

/// The proleptic Gregorian date of `days` since 1970-01-01 (H. Hinnant's `civil_from_days`).
fn civil_date(days: u64) -> (u64, u64, u64) {
    let z = days + 719_468;
    let era = z / 146_097;
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    (yoe + era * 400 + u64::from(m <= 2), m, d)
}

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
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs());
        let (rec, activation) = open(
            &opts.sink,
            &campaign_app(protocol.seed, now),
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
        match self.open_trial(line)? {
            Some(t) => self.fill_trial(n, line, t),
            None => Ok(()),
        }
    }

    /// Opens `line`'s trial recording in the sink (its store and layout reach the viewer now);
    /// None without frames.
    fn open_trial(&self, line: &TrialLine) -> Result<Option<TrialRecording>, RecordError> {
        let Some(frames) = self.frames.as_ref() else {
            return Ok(None);
        };
        let name = trial::name(line);
        TrialRecording::forwarded(&self.rec, &name, frames.layout(line.theta_lf.is_some()))
            .map(Some)
    }

    /// Runs and logs `line`'s trial into its opened recording `t`, then closes it.
    fn fill_trial(
        &mut self,
        n: u64,
        line: &TrialLine,
        t: TrialRecording,
    ) -> Result<(), RecordError> {
        let Some(frames) = self.frames.as_mut() else {
            return t.close();
        };
        let name = trial::name(line);
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
        // Every chosen trial's recording is opened before any is filled. A viewer selects a
        // new recording when its first message arrives, but only once it has read the batch
        // of messages that holds it (rerun 0.36: a deferred selection), so a campaign
        // activation in the same batch as the last trial's first message loses to it and a
        // live viewer (`--connect`, `--spawn`) stays on that trial. Opened first, all the
        // trials' frames lie between the last new recording and the activation.
        let mut opened = Vec::new();
        for (n, line) in chosen {
            match self.open_trial(&line) {
                Ok(Some(t)) => opened.push((n, line, t)),
                Ok(None) => {}
                Err(e) => trial_error(&line, &e),
            }
        }
        for (n, line, t) in opened {
            if let Err(e) = self.fill_trial(n, &line, t) {
                trial_error(&line, &e);
            }
        }
        let summary = self.view.summary_markdown(&self.names, &self.opts);
        let _ = self.rec.log_static(
            "campaign/summary",
            &rerun::TextDocument::from_markdown(summary),
        );
        // Last in the file or stream: a viewer opens on the campaign view (the earliest, and
        // only, recording of this campaign's application), not on the last trial.
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
                trial_error(line, &e);
            }
            // A live viewer selected the trial's new recording: back to the campaign view,
            // which goes on (the trial stays listed under the viewer's *Sources*).
            layout::activate(&self.rec, self.activation.clone());
        } else {
            self.candidates
                .offer(n, line, self.opts.failure_cap as usize);
        }
    }
}

fn trial_error(line: &TrialLine, e: &RecordError) {
    eprintln!(
        "savme: recording trial {} of {}: {e}",
        line.index, line.stage
    );
}

impl Drop for Recorder {
    fn drop(&mut self) {
        let _ = self.rec.flush_blocking();
    }
}
