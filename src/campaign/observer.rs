//! Watching a campaign as it runs: the [`Observer`] trait and the two progress displays —
//! [`ProgressBars`] for a terminal and [`ProgressLines`], plain lines per stage and about every
//! 10 s, for pipes, logs and CI. The rerun recording is another observer (`savme::viewer`).

use super::log::TrialLine;
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
/// use savme::campaign::{log::TrialLine, Observer, Stage};
/// /// Counts the failures the HF simulator found.
/// #[derive(Default)]
/// struct Failures(u64);
/// impl Observer for Failures {
///     fn trial(&mut self, _: &Stage, line: &TrialLine, _: &savme::kernel::Kernel) {
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

    /// A trial was told to `kernel` (which has learnt from it).
    fn trial(&mut self, stage: &Stage, line: &TrialLine, kernel: &Kernel) {
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
        let total = self.multi.add(ProgressBar::new(protocol.total_trials()));
        total.set_style(bar_style(
            "{prefix:>15} [{bar:30}] {pos}/{len} trials  {elapsed_precise} elapsed, ETA {eta}",
        ));
        total.set_prefix("campaign");
        self.total = Some(total);
    }

    fn stage(&mut self, stage: &Stage) {
        if let Some(b) = self.bar.take() {
            b.finish();
        }
        let bar = self.multi.add(ProgressBar::new(stage.iterations));
        bar.set_style(bar_style(
            "{prefix:>15} [{bar:30}] {pos}/{len}  {rate}, ETA {eta}  {msg}",
        ));
        bar.set_prefix(stage.label());
        self.failures = 0;
        self.bar = Some(bar);
    }

    fn trial(&mut self, _: &Stage, line: &TrialLine, _: &Kernel) {
        self.failures += u64::from(line.hf.failure);
        if let Some(b) = &self.bar {
            b.inc(1);
            b.set_message(plural(self.failures, "failure"));
        }
        if let Some(t) = &self.total {
            t.inc(1);
        }
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
/// starts, one about every [`ProgressLines::every`] (default 10 s) while it runs, and one when
/// it ends — each with the stage, its trials done of its total, the HF failures found, the
/// elapsed time and an estimate of the time left in the stage and in the campaign.
///
/// ```
/// use savme::campaign::{Observer, ProgressLines, Protocol};
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
}

/// Trials done out of a total, failures among them, since when, and when last printed.
struct Counts {
    done: u64,
    total: u64,
    failures: u64,
    since: Instant,
    printed: Instant,
}

impl Counts {
    fn new(total: u64) -> Self {
        let now = Instant::now();
        Counts {
            done: 0,
            total,
            failures: 0,
            since: now,
            printed: now,
        }
    }

    /// The time left at the rate so far ("?" before the first trial).
    fn eta(&self) -> String {
        if self.done == 0 {
            return "?".into();
        }
        let per_trial = self.since.elapsed().as_secs_f64() / self.done as f64;
        human_seconds(per_trial * self.total.saturating_sub(self.done) as f64)
    }
}

/// `42 s`, `3 min 05 s`, `1 h 02 min`.
fn human_seconds(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
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
            every: Duration::from_secs(10),
            campaign: Counts::new(0),
            stage: None,
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
            "done" => String::new(),
            _ => format!(
                ", ETA {} (campaign: {} of {} trials, ETA {})",
                c.eta(),
                self.campaign.done,
                self.campaign.total,
                self.campaign.eta()
            ),
        };
        // Progress is best effort: a closed pipe must not stop the campaign.
        let _ = writeln!(
            self.out,
            "{label} {state}: {}/{} trials, {} (HF), {} elapsed{eta}",
            c.done,
            c.total,
            plural(c.failures, "failure"),
            human_seconds(c.since.elapsed().as_secs_f64()),
        );
    }

    fn end_stage(&mut self) {
        self.line("done");
        self.stage = None;
    }
}

impl<W: Write> Observer for ProgressLines<W> {
    fn start(&mut self, protocol: &Protocol) {
        self.campaign = Counts::new(protocol.total_trials());
    }

    fn stage(&mut self, stage: &Stage) {
        self.end_stage();
        self.stage = Some((stage.label(), Counts::new(stage.iterations)));
        self.line("started");
    }

    fn trial(&mut self, _: &Stage, line: &TrialLine, _: &Kernel) {
        self.campaign.done += 1;
        self.campaign.failures += u64::from(line.hf.failure);
        let every = self.every;
        let due = self.stage.as_mut().is_some_and(|(_, c)| {
            c.done += 1;
            c.failures += u64::from(line.hf.failure);
            c.printed.elapsed() >= every && c.done < c.total
        });
        if due {
            self.line("running");
        }
    }

    fn finish(&mut self) -> Result<(), CampaignError> {
        self.end_stage();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::campaign::log::RunLine;
    use savme_kernel::{Assignment, Credit, Phase};

    fn line(failure: bool) -> TrialLine {
        let run = RunLine {
            failure,
            runtime: 1.0,
            wall_seconds: 0.1,
            work: None,
        };
        TrialLine {
            stage: "baseline".into(),
            index: 0,
            id: 0,
            phase: Phase::Baseline,
            budget: None,
            scenario: "s".into(),
            phi: Assignment::new(),
            theta_lf: None,
            hf: run,
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
        assert!(
            lines[0].starts_with(&format!(
                "{a} started: 0/{n} trials, 0 failures (HF), 0 s elapsed, ETA ?"
            )),
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
        let total = protocol.total_trials();
        assert!(
            lines[2].contains(&format!("(campaign: 2 of {total} trials, ETA ")),
            "{text}"
        );
        assert!(
            lines[4].starts_with(&format!("{a} done: 3/{n} trials, 1 failure (HF)")),
            "{text}"
        );
        assert!(!lines[4].contains("ETA"), "{text}");
        assert!(lines[5].starts_with(&format!("{b} started: 0/")), "{text}");
        assert!(lines[6].starts_with(&format!("{b} done: 0/")), "{text}");
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

    #[test]
    fn counts_read_as_english() {
        assert_eq!(plural(1, "failure"), "1 failure");
        assert_eq!(plural(0, "failure"), "0 failures");
        assert_eq!(human_seconds(42.4), "42 s");
        assert_eq!(human_seconds(185.0), "3 min 05 s");
        assert_eq!(human_seconds(3720.0), "1 h 02 min");
    }
}
