//! Watching a campaign as it runs: the [`Observer`] trait and the two progress displays —
//! [`ProgressBars`] for a terminal and [`ProgressLines`], plain lines per stage and about every
//! 10 s, for pipes, logs and CI. The rerun recording is another observer (`savme::viewer`).

use super::log::{ScreenLine, TrialLine};
use super::protocol::{Protocol, Stage};
use super::CampaignError;
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use savme_kernel::Kernel;
use std::io::Write;
use std::time::{Duration, Instant};

/// Watches a campaign. Every method is called on the coordinating thread, in tell order —
/// replayed trials (on resume) included.
///
/// ```
/// use savme_campaign::{log::TrialLine, Observer, Stage};
/// /// Counts the failures the HF simulator found.
/// #[derive(Default)]
/// struct Failures(u64);
/// impl Observer for Failures {
///     fn trial(&mut self, _: &Stage, line: &TrialLine, _: &savme_kernel::Kernel) {
///         self.0 += u64::from(line.hf.failure);
///     }
/// }
/// ```
pub trait Observer {
    /// The campaign starts (before any stage).
    fn start(&mut self, protocol: &Protocol) {
        let _ = protocol;
    }

    /// A stage starts.
    fn stage(&mut self, stage: &Stage) {
        let _ = stage;
    }

    /// On resume: the stage's first `trials` told trials are replayed from the store (the
    /// next `trial` / `screened` calls of the stage), with no simulation. Called after
    /// [`Observer::stage`], only when there are some. Progress displays use it to keep
    /// replayed trials out of their rate.
    fn replaying(&mut self, stage: &Stage, trials: u64) {
        let _ = (stage, trials);
    }

    /// A trial was told to `kernel` (which has learnt from it).
    fn trial(&mut self, stage: &Stage, line: &TrialLine, kernel: &Kernel) {
        let _ = (stage, line, kernel);
    }

    /// A trial of an LF screening stage was told (it credits nothing: `kernel` is unchanged).
    fn screened(&mut self, stage: &Stage, line: &ScreenLine, kernel: &Kernel) {
        let _ = (stage, line, kernel);
    }

    /// The campaign ended (finished or stopped by an error): close what needs closing.
    fn finish(&mut self) -> Result<(), CampaignError> {
        Ok(())
    }
}

/// A bar style; `{rate}` is trials per second with one decimal (indicatif's `{per_sec}` prints
/// four).
fn bar_style(template: &str) -> ProgressStyle {
    ProgressStyle::with_template(template)
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .with_key(
            "rate",
            |state: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                let _ = write!(w, "{:.1} trials/s", state.per_sec());
            },
        )
        .progress_chars("=> ")
}

/// Progress bars on standard error: the whole campaign, and one per stage with its failures.
pub struct ProgressBars {
    multi: MultiProgress,
    total: Option<ProgressBar>,
    bar: Option<ProgressBar>,
    failures: u64,
    /// Replayed trials still to come (resume).
    replay_left: u64,
    /// The current stage has a cost budget: its bar counts cost.
    spend: bool,
}

impl ProgressBars {
    /// Bars drawn to standard error.
    pub fn new() -> Self {
        ProgressBars::to(ProgressDrawTarget::stderr())
    }

    /// Bars drawn to `target` (hidden in tests).
    pub fn to(target: ProgressDrawTarget) -> Self {
        ProgressBars {
            multi: MultiProgress::with_draw_target(target),
            total: None,
            bar: None,
            failures: 0,
            replay_left: 0,
            spend: false,
        }
    }

    /// One more told trial that cost `cost`; an HF failure if `failure`. After the last
    /// replayed trial the bars' rates (and so their ETAs) restart, so that they count only
    /// trials run now.
    fn count(&mut self, failure: bool, cost: f64) {
        self.failures += u64::from(failure);
        let bars = self.bar.iter().chain(&self.total);
        if let Some(b) = &self.bar {
            // A stage with a cost budget advances by what the trial cost.
            b.inc(if self.spend { cost.round() as u64 } else { 1 });
        }
        if let Some(t) = &self.total {
            t.inc(1);
        }
        if let Some(b) = &self.bar {
            b.set_message(plural(self.failures, "failure"));
        }
        if self.replay_left > 0 {
            self.replay_left -= 1;
            if self.replay_left == 0 {
                bars.for_each(ProgressBar::reset_eta);
            }
        }
    }
}

impl Default for ProgressBars {
    fn default() -> Self {
        ProgressBars::new()
    }
}

impl Observer for ProgressBars {
    fn start(&mut self, protocol: &Protocol) {
        let total = match protocol.known_total_trials() {
            Some(n) => {
                let bar = self.multi.add(ProgressBar::new(n));
                bar.set_style(bar_style(
                    "{prefix:>15} [{bar:30}] {pos}/{len} trials  {elapsed_precise} elapsed, ETA {eta}",
                ));
                bar
            }
            // A cost budget: the number of trials is not known in advance.
            None => {
                let bar = self.multi.add(ProgressBar::no_length());
                bar.set_style(bar_style(
                    "{prefix:>15} {pos} trials  {elapsed_precise} elapsed",
                ));
                bar
            }
        };
        total.set_prefix("campaign");
        self.total = Some(total);
    }

    fn stage(&mut self, stage: &Stage) {
        if let Some(b) = self.bar.take() {
            b.finish();
        }
        let bar = match stage.spend {
            // Progress in cost: the bar's unit is one cost unit (rounded up to a whole one).
            Some(budget) => {
                let bar = self.multi.add(ProgressBar::new(budget.ceil() as u64));
                bar.set_style(bar_style(
                    "{prefix:>15} [{bar:30}] {percent}% of the cost budget, ETA {eta}  {msg}",
                ));
                bar
            }
            None => {
                let bar = self.multi.add(ProgressBar::new(stage.iterations));
                bar.set_style(bar_style(
                    "{prefix:>15} [{bar:30}] {pos}/{len}  {rate}, ETA {eta}  {msg}",
                ));
                bar
            }
        };
        self.spend = stage.spend.is_some();
        bar.set_prefix(stage.label());
        self.failures = 0;
        self.bar = Some(bar);
    }

    fn replaying(&mut self, _: &Stage, trials: u64) {
        self.replay_left += trials;
    }

    fn trial(&mut self, _: &Stage, line: &TrialLine, _: &Kernel) {
        self.count(line.hf.failure, line.cost());
    }

    fn screened(&mut self, _: &Stage, line: &ScreenLine, _: &Kernel) {
        self.count(line.hf.as_ref().is_some_and(|h| h.failure), line.cost());
    }

    fn finish(&mut self) -> Result<(), CampaignError> {
        if let Some(b) = self.bar.take() {
            b.finish();
        }
        if let Some(t) = self.total.take() {
            t.finish();
        }
        Ok(())
    }
}

/// Plain progress lines for pipes, logs and CI (no terminal, no bars): one when a stage
/// starts (its size and the campaign's count and time left), one about every
/// [`ProgressLines::every`] (default 10 s) while it runs, and one when it ends — each with the
/// stage, its trials done of its total, the HF failures found, the elapsed time and an estimate
/// of the time left in the stage and in the campaign.
///
/// ```
/// use savme_campaign::{Observer, ProgressLines, Protocol};
/// let (train, test) = savme_sim::scenario::train_test_names();
/// let protocol = Protocol::quick("savme-sim/sensors", train, test);
/// let mut lines = ProgressLines::new(Vec::new());
/// lines.start(&protocol);
/// lines.stage(&protocol.stages()[0]);
/// let text = String::from_utf8(lines.into_inner()).unwrap();
/// assert!(text.starts_with("baseline-train started: 0/260 trials"));
/// ```
pub struct ProgressLines<W: Write> {
    out: W,
    every: Duration,
    campaign: Counts,
    stage: Option<(String, Counts)>,
    prefix: String,
    /// The cost measure's unit (`work units`, `s`).
    unit: &'static str,
}

/// Trials done out of a total, failures among them, since when, and when last printed.
struct Counts {
    done: u64,
    /// Trials to run; 0 when unknown (a campaign with a cost budget).
    total: u64,
    failures: u64,
    /// A stage with a cost budget: (the budget, what its told runs cost so far). Its progress
    /// and ETA are in cost, not trials.
    spend: Option<(f64, f64)>,
    since: Instant,
    printed: Instant,
    /// Replayed trials still to come (resume), and where the rate is measured from: the
    /// time and count after the last replayed trial.
    replay_left: u64,
    /// Where the rate is measured from: the time, trials and cost after the last replay.
    rate_from: (Instant, u64, f64),
}

impl Counts {
    fn new(total: u64) -> Self {
        let now = Instant::now();
        Counts {
            done: 0,
            total,
            failures: 0,
            spend: None,
            since: now,
            printed: now,
            replay_left: 0,
            rate_from: (now, 0, 0.0),
        }
    }

    /// The counts of `stage`: its trials, or its cost budget.
    fn of(stage: &Stage) -> Self {
        match stage.spend {
            Some(budget) => Counts {
                spend: Some((budget, 0.0)),
                ..Counts::new(0)
            },
            None => Counts::new(stage.iterations),
        }
    }

    /// What has been spent (trials, or cost with a cost budget) and what is to be spent.
    fn progress(&self) -> (f64, f64) {
        match self.spend {
            Some((budget, spent)) => (spent, budget),
            None => (self.done as f64, self.total as f64),
        }
    }

    /// Whether the stage ended short of its trials or its cost budget.
    fn short(&self) -> bool {
        let (done, total) = self.progress();
        done < total
    }

    /// One more told trial, which cost `cost`.
    fn count(&mut self, failure: bool, cost: f64) {
        self.done += 1;
        self.failures += u64::from(failure);
        if let Some((_, spent)) = &mut self.spend {
            *spent += cost;
        }
        if self.replay_left > 0 {
            self.replay_left -= 1;
            if self.replay_left == 0 {
                self.rate_from = (Instant::now(), self.done, self.progress().0);
            }
        }
    }

    /// The time left at the rate of the trials run so far (in cost with a cost budget),
    /// replayed ones not counted ("?" before the first trial run, or with no known total).
    fn eta(&self) -> String {
        let (from, base, base_spent) = self.rate_from;
        let (done, total) = self.progress();
        let run = if self.spend.is_some() {
            done - base_spent
        } else {
            self.done.saturating_sub(base) as f64
        };
        if run <= 0.0 || self.replay_left > 0 || total <= 0.0 {
            return "?".into();
        }
        let per_unit = from.elapsed().as_secs_f64() / run;
        human_seconds(per_unit * (total - done).max(0.0))
    }

    /// `3/200 trials`, or with a cost budget `3 trials, 1.2e9 of 2e9 work units`.
    fn done_of(&self, unit: &str) -> String {
        match self.spend {
            Some((budget, spent)) => format!(
                "{} trials, {} of {} {unit}",
                self.done,
                short_number(spent),
                short_number(budget)
            ),
            None => format!("{}/{} trials", self.done, self.total),
        }
    }

    /// The campaign's part of a line: `campaign: 3 of 860 trials, ETA 1 min 02 s`, or with a
    /// cost budget (no known total) `campaign: 3 trials`.
    fn campaign(&self) -> String {
        if self.total == 0 {
            format!("campaign: {} trials", self.done)
        } else {
            format!(
                "campaign: {} of {} trials, ETA {}",
                self.done,
                self.total,
                self.eta()
            )
        }
    }
}

/// A cost as people read it: `950`, `12.5`, `1.23e9`.
fn short_number(x: f64) -> String {
    if x.abs() >= 1e5 {
        format!("{x:.3e}")
    } else if x.fract() == 0.0 {
        format!("{x:.0}")
    } else {
        format!("{x:.1}")
    }
}

/// `42 s`, `3 min 05 s`, `1 h 02 min`; below a second `350.0 ms`, `12.0 µs`.
fn human_seconds(s: f64) -> String {
    if s < 1.0 {
        return super::report::format_seconds(s);
    }
    let s = s.round() as u64;
    match s {
        0..=59 => format!("{s} s"),
        60..=3599 => format!("{} min {:02} s", s / 60, s % 60),
        _ => format!("{} h {:02} min", s / 3600, (s % 3600) / 60),
    }
}

/// `1 failure`, `2 failures`.
pub(crate) fn plural(n: u64, noun: &str) -> String {
    if n == 1 {
        format!("{n} {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

impl<W: Write> ProgressLines<W> {
    /// Lines written to `out` (e.g. standard error).
    pub fn new(out: W) -> Self {
        ProgressLines {
            out,
            prefix: String::new(),
            every: Duration::from_secs(10),
            campaign: Counts::new(0),
            stage: None,
            unit: "s",
        }
    }

    /// Lines starting with `prefix` (e.g. `seed 3: `, for campaigns running side by side).
    pub fn with_prefix(out: W, prefix: &str) -> Self {
        ProgressLines {
            prefix: prefix.into(),
            ..ProgressLines::new(out)
        }
    }

    /// A line at most this often while a stage runs (besides its first and last).
    pub fn every(mut self, every: Duration) -> Self {
        self.every = every;
        self
    }

    /// The lines written so far (for tests and embedding).
    pub fn into_inner(self) -> W {
        self.out
    }

    fn line(&mut self, state: &str) {
        let Some((label, c)) = &mut self.stage else {
            return;
        };
        c.printed = Instant::now();
        let eta = match state {
            "done" | "stopped" => String::new(),
            _ => format!(", ETA {} ({})", c.eta(), self.campaign.campaign()),
        };
        let unit = self.unit;
        // Progress is best effort: a closed pipe must not stop the campaign. A stage that has
        // just started has no failures, elapsed time or ETA of its own to show yet.
        let _ = if state == "started" {
            writeln!(
                self.out,
                "{}{label} started: {} ({})",
                self.prefix,
                c.done_of(unit),
                self.campaign.campaign()
            )
        } else {
            writeln!(
                self.out,
                "{}{label} {state}: {}, {} (HF), {} elapsed{eta}",
                self.prefix,
                c.done_of(unit),
                plural(c.failures, "failure"),
                human_seconds(c.since.elapsed().as_secs_f64()),
            )
        };
    }

    /// One more told trial (an HF failure if `failure`) that cost `cost`; a line if one is
    /// due.
    fn count(&mut self, failure: bool, cost: f64) {
        self.campaign.count(failure, cost);
        let every = self.every;
        let due = self.stage.as_mut().is_some_and(|(_, c)| {
            c.count(failure, cost);
            c.printed.elapsed() >= every && c.short()
        });
        if due {
            self.line("running");
        }
    }

    /// The stage's last line: `done`, or `stopped` when it ends short of its trials (the
    /// campaign was interrupted or failed).
    fn end_stage(&mut self) {
        let short = self.stage.as_ref().is_some_and(|(_, c)| c.short());
        self.line(if short { "stopped" } else { "done" });
        self.stage = None;
    }
}

impl<W: Write> Observer for ProgressLines<W> {
    fn start(&mut self, protocol: &Protocol) {
        self.campaign = Counts::new(protocol.known_total_trials().unwrap_or(0));
        self.unit = protocol.cost.unit();
    }

    fn stage(&mut self, stage: &Stage) {
        self.end_stage();
        self.stage = Some((stage.label(), Counts::of(stage)));
        self.line("started");
    }

    fn replaying(&mut self, _: &Stage, trials: u64) {
        self.campaign.replay_left += trials;
        if let Some((_, c)) = &mut self.stage {
            c.replay_left += trials;
        }
    }

    fn trial(&mut self, _: &Stage, line: &TrialLine, _: &Kernel) {
        self.count(line.hf.failure, line.cost());
    }

    fn screened(&mut self, _: &Stage, line: &ScreenLine, _: &Kernel) {
        self.count(line.hf.as_ref().is_some_and(|h| h.failure), line.cost());
    }

    fn finish(&mut self) -> Result<(), CampaignError> {
        self.end_stage();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::log::RunLine;
    use crate::{StageId, StageKind};
    use savme_kernel::{Assignment, Credit, Phase};

    fn run(failure: bool) -> RunLine {
        RunLine {
            failure,
            runtime: 1.0,
            wall_seconds: 0.1,
            work: None,
            robustness: None,
        }
    }

    fn line(failure: bool) -> TrialLine {
        TrialLine {
            stage: StageId::new(StageKind::BaselineTrain, None),
            index: 0,
            id: 0,
            phase: Phase::Baseline,
            budget: None,
            scenario: "s".into(),
            phi: Assignment::new(),
            theta_lf: None,
            hf: run(failure),
            lf: None,
            cost_ratio: None,
            outcome: None,
            credit: Credit::default(),
        }
    }

    #[test]
    fn lines_say_stage_progress_failures_and_eta() {
        let (train, test) = savme_sim::scenario::train_test_names();
        let protocol = Protocol::quick("test", train, test);
        let stages = protocol.stages();
        let kernel = crate::toy::kernel_builder().build().unwrap();
        let mut p = ProgressLines::new(Vec::new()).every(Duration::ZERO);
        p.start(&protocol);
        p.stage(&stages[0]);
        for i in 0..3 {
            p.trial(&stages[0], &line(i == 1), &kernel);
        }
        p.stage(&stages[1]);
        p.finish().unwrap();
        let text = String::from_utf8(p.into_inner()).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        let (a, b) = (stages[0].label(), stages[1].label());
        let n = stages[0].iterations;
        assert_eq!(lines.len(), 7, "{text}");
        // A start line has nothing of the stage's own to time yet: only the campaign's count.
        let total = protocol.total_trials();
        assert_eq!(
            lines[0],
            format!("{a} started: 0/{n} trials (campaign: 0 of {total} trials, ETA ?)"),
            "{text}"
        );
        assert!(
            lines[1].starts_with(&format!("{a} running: 1/{n} trials, 0 failures")),
            "{text}"
        );
        assert!(
            lines[2].starts_with(&format!("{a} running: 2/{n} trials, 1 failure (HF)")),
            "{text}"
        );
        assert!(
            lines[2].contains(&format!("(campaign: 2 of {total} trials, ETA ")),
            "{text}"
        );
        assert!(
            // Ended short of its trials (here by the next stage; really by a stop).
            lines[4].starts_with(&format!("{a} stopped: 3/{n} trials, 1 failure (HF)")),
            "{text}"
        );
        assert!(!lines[4].contains("ETA"), "{text}");
        assert!(lines[5].starts_with(&format!("{b} started: 0/")), "{text}");
        assert!(lines[6].starts_with(&format!("{b} stopped: 0/")), "{text}");
    }

    #[test]
    fn lines_come_at_most_as_often_as_asked() {
        let (train, test) = savme_sim::scenario::train_test_names();
        let protocol = Protocol::quick("test", train, test);
        let stage = &protocol.stages()[0];
        let kernel = crate::toy::kernel_builder().build().unwrap();
        let mut p = ProgressLines::new(Vec::new());
        p.start(&protocol);
        p.stage(stage);
        for _ in 0..50 {
            p.trial(stage, &line(false), &kernel);
        }
        let text = String::from_utf8(p.into_inner()).unwrap();
        assert_eq!(text.lines().count(), 1, "{text}");
    }

    fn screen_line(hf_failure: Option<bool>) -> ScreenLine {
        ScreenLine {
            stage: StageId::new(StageKind::Screen, Some(0.3)),
            index: 0,
            id: 0,
            budget: Some(0.3),
            scenario: "s".into(),
            phi: Assignment::new(),
            theta_lf: None,
            ladder: Vec::new(),
            screen: savme_kernel::screening::Screen::Confirm,
            lf: Some(run(true)),
            hf: hf_failure.map(run),
            outcome: None,
        }
    }

    /// On resume the replayed trials are counted as done but not in the rate: the ETA is "?"
    /// until a trial runs, then it is the live trials' rate (here ≥ 20 ms a trial, so the
    /// campaign's > 3,000 trials left take minutes — counting the 3 instant replays in the
    /// rate would give about a quarter of that). Screened trials count too, their confirmed
    /// HF failures as failures.
    #[test]
    fn replayed_trials_stay_out_of_the_eta_and_screened_trials_count() {
        let (train, test) = savme_sim::scenario::train_test_names();
        let protocol = Protocol::paper("test", train, test);
        let stage = &protocol.stages()[0];
        let kernel = crate::toy::kernel_builder().build().unwrap();
        let mut p = ProgressLines::new(Vec::new()).every(Duration::ZERO);
        p.start(&protocol);
        p.stage(stage);
        p.replaying(stage, 3);
        for _ in 0..3 {
            p.trial(stage, &line(false), &kernel);
        }
        std::thread::sleep(Duration::from_millis(20));
        p.trial(stage, &line(true), &kernel);
        p.screened(stage, &screen_line(Some(true)), &kernel);
        p.screened(stage, &screen_line(None), &kernel);
        let text = String::from_utf8(p.into_inner()).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert!(protocol.total_trials() > 3000);
        for l in &lines[1..4] {
            assert!(l.ends_with("trials, ETA ?)"), "{text}");
        }
        let live = lines[4];
        assert!(
            live.contains("4/") && live.contains("1 failure (HF)"),
            "{text}"
        );
        let campaign_eta = live.rsplit("ETA ").next().unwrap();
        assert!(campaign_eta.contains("min"), "{text}");
        assert!(
            lines[6].contains("6/") && lines[6].contains("2 failures (HF)"),
            "{text}"
        );
    }

    #[test]
    fn counts_read_as_english() {
        assert_eq!(plural(1, "failure"), "1 failure");
        assert_eq!(plural(0, "failure"), "0 failures");
        assert_eq!(human_seconds(42.4), "42 s");
        assert_eq!(human_seconds(0.35), "350.0 ms");
        assert_eq!(human_seconds(1.2e-5), "12.0 µs");
        assert_eq!(human_seconds(185.0), "3 min 05 s");
        assert_eq!(human_seconds(3720.0), "1 h 02 min");
    }
}
