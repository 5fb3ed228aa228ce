//! Watching a campaign as it runs: the [`Observer`] trait and the two progress displays —
//! [`ProgressBars`] for a terminal and [`ProgressLines`], one plain line per finished stage, for
//! pipes, logs and CI. The rerun recording is another observer (`savme::viewer`).

use super::log::TrialLine;
use super::protocol::{Protocol, Stage};
use super::CampaignError;
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use savme_kernel::Kernel;
use std::io::Write;
use std::time::Instant;

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

fn bar_style(template: &str) -> ProgressStyle {
    ProgressStyle::with_template(template)
        .unwrap_or_else(|_| ProgressStyle::default_bar())
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
            "{prefix:>15} [{bar:30}] {pos}/{len}  {per_sec}, ETA {eta}  {msg}",
        ));
        bar.set_prefix(stage.label());
        self.failures = 0;
        self.bar = Some(bar);
    }

    fn trial(&mut self, _: &Stage, line: &TrialLine, _: &Kernel) {
        self.failures += u64::from(line.hf.failure);
        if let Some(b) = &self.bar {
            b.inc(1);
            b.set_message(format!("{} failures", self.failures));
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

/// One plain line per finished stage (`train@0.3: 500 trials, 97 HF failures, 41.2 s`), for
/// output that is not a terminal.
pub struct ProgressLines<W: Write> {
    out: W,
    prefix: String,
    current: Option<(String, u64, u64, Instant)>,
}

impl<W: Write> ProgressLines<W> {
    /// Lines written to `out` (e.g. standard error).
    pub fn new(out: W) -> Self {
        ProgressLines::with_prefix(out, "")
    }

    /// Lines starting with `prefix` (e.g. `seed 3: `, for campaigns running side by side).
    pub fn with_prefix(out: W, prefix: &str) -> Self {
        ProgressLines {
            out,
            prefix: prefix.into(),
            current: None,
        }
    }

    fn end_stage(&mut self) {
        if let Some((label, trials, failures, since)) = self.current.take() {
            // Progress is best effort: a closed pipe must not stop the campaign.
            let _ = writeln!(
                self.out,
                "{}{label}: {trials} trials, {failures} HF failures, {:.1} s",
                self.prefix,
                since.elapsed().as_secs_f64()
            );
        }
    }
}

impl<W: Write> Observer for ProgressLines<W> {
    fn stage(&mut self, stage: &Stage) {
        self.end_stage();
        self.current = Some((stage.label(), 0, 0, Instant::now()));
    }

    fn trial(&mut self, _: &Stage, line: &TrialLine, _: &Kernel) {
        if let Some((_, trials, failures, _)) = &mut self.current {
            *trials += 1;
            *failures += u64::from(line.hf.failure);
        }
    }

    fn finish(&mut self) -> Result<(), CampaignError> {
        self.end_stage();
        Ok(())
    }
}
