//! LF screening with HF confirmation: the deployment of a learned fidelity θ_LF*. Every trial
//! runs the LF simulator; an LF failure is re-run on the HF simulator (confirmed, or a false
//! positive); a random audit fraction α of the LF passes is also run on HF, to estimate how
//! many failures the LF simulator misses (its FN rate among passes).
//!
//! A fidelity ladder generalises this to several LF levels, cheapest first ([`plan`]: which
//! levels pay; [`next`]: what a trial runs next): a level's failure is confirmed at the next
//! level up, HF last. The two-level screening is the ladder of one level.
//!
//! Screening asks what evaluation asks (φ ~ p_ψ, θ_LF*) and credits nothing, so it is not a
//! phase of its own: a harness asks [`Phase::Evaluate`](crate::Phase::Evaluate) trials, runs
//! LF, decides with [`decide`] and tells a paired observation when HF ran, or
//! [`Kernel::tell_unconfirmed`](crate::Kernel::tell_unconfirmed) when it did not.
//!
//! ```
//! use savme_kernel::screening::{audited, decide, Screen, ScreeningCounts};
//! use savme_kernel::Run;
//! let mut counts = ScreeningCounts::default();
//! for index in 0..1000u64 {
//!     let lf = Run::new(index % 10 == 0, 0.2);
//!     let screen = decide(lf.failure, audited(7, index, 0.1));
//!     let hf = match screen {
//!         Screen::Pass => None,
//!         _ => Some(Run::new(index % 20 == 0, 1.0)),
//!     };
//!     counts.add(Some(&lf), hf.as_ref(), screen);
//! }
//! assert_eq!((counts.lf_failures, counts.confirmed), (100, 50));
//! assert!(counts.audited > 60 && counts.audited < 120); // ≈ 0.1 · 900 passes
//! assert_eq!(counts.audit_misses, 0); // this LF simulator misses nothing
//! ```

use crate::outcome::Run;
use serde::{Deserialize, Serialize};

/// What a screened trial's LF result calls for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Screen {
    /// The LF run failed: confirm it on HF.
    Confirm,
    /// The LF run passed within the [`Rule::margin`]: check it on HF.
    Margin,
    /// No LF run: screening does not pay here ([`Economy::screen_pays`]), so HF ran directly.
    Direct,
    /// The LF run passed and the trial was drawn for the audit: run HF to look for a miss.
    Audit,
    /// The LF run passed, not audited: no HF run.
    Pass,
}

/// The decision for an LF result under the paper's rule (`audited`: the trial was drawn for
/// the audit): [`Rule::PAPER`]`.decide`.
pub fn decide(lf_failure: bool, audited: bool) -> Screen {
    match (lf_failure, audited) {
        (true, _) => Screen::Confirm,
        (false, true) => Screen::Audit,
        (false, false) => Screen::Pass,
    }
}

/// Which LF results call for an HF run: the LF failures (the paper's), and with a margin also
/// the LF passes whose robustness is at most the margin — near-misses of the LF simulator,
/// where the HF simulator may fail (an LF simulator misses some HF failures: it is cheaper
/// because it is less exact).
///
/// ```
/// use savme_kernel::screening::{Rule, Screen};
/// use savme_kernel::Run;
/// let near = Run::new(false, 1.0).with_robustness(0.4);
/// assert_eq!(Rule::PAPER.decide(&near, false), Screen::Pass);
/// assert_eq!(Rule { margin: Some(0.5) }.decide(&near, false), Screen::Margin);
/// assert_eq!(Rule { margin: Some(0.3) }.decide(&near, true), Screen::Audit);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rule {
    /// LF passes with a robustness at most this are checked on HF (None: none, the paper's;
    /// a pass without a robustness never is).
    pub margin: Option<f64>,
}

impl Rule {
    /// The paper's: only LF failures are confirmed on HF.
    pub const PAPER: Rule = Rule { margin: None };

    /// The decision for an LF result (`audited`: the trial was drawn for the audit).
    pub fn decide(&self, lf: &Run, audited: bool) -> Screen {
        let near = !lf.failure && self.margin.zip(lf.robustness).is_some_and(|(m, r)| r <= m);
        match (lf.failure, near, audited) {
            (true, _, _) => Screen::Confirm,
            (false, true, _) => Screen::Margin,
            (false, false, true) => Screen::Audit,
            (false, false, false) => Screen::Pass,
        }
    }

    /// The rule that would have found the most HF-confirmed failures per unit of cost on
    /// paired results `(lf, hf)` of the LF fidelity to be deployed (e.g. the search's trials
    /// at θ_LF*): the paper's, or a margin at one of the LF passes' robustness values. The
    /// paper's rule is kept unless a margin finds at least two more failures *and* at least
    /// 2 % more failures per cost, or with fewer than `min_samples` results.
    ///
    /// ```
    /// use savme_kernel::screening::Rule;
    /// use savme_kernel::Run;
    /// // The LF simulator misses HF failures that come within 0.5 m; checking them pays.
    /// let pairs: Vec<(Run, Run)> = (0..40)
    ///     .map(|i| {
    ///         let r = f64::from(i % 10) * 0.25;
    ///         let lf = Run::new(i % 10 == 0, 1.0).with_robustness(r);
    ///         (lf, Run::new(r <= 0.5, if r <= 0.5 { 5.0 } else { 10.0 }))
    ///     })
    ///     .collect();
    /// assert_eq!(Rule::fit(&pairs, 20).margin, Some(0.5));
    /// assert_eq!(Rule::fit(&pairs[..10], 20), Rule::PAPER);
    /// ```
    pub fn fit(pairs: &[(Run, Run)], min_samples: usize) -> Rule {
        if pairs.len() < min_samples.max(1) {
            return Rule::PAPER;
        }
        let lf_cost: f64 = pairs.iter().map(|(lf, _)| lf.runtime).sum();
        let value = |rule: &Rule| {
            let (mut found, mut cost) = (0u64, lf_cost);
            for (lf, hf) in pairs {
                if rule.decide(lf, false) != Screen::Pass {
                    cost += hf.runtime;
                    found += u64::from(hf.failure);
                }
            }
            (found, found as f64 / cost)
        };
        let (paper_found, paper_rate) = value(&Rule::PAPER);
        let mut margins: Vec<f64> = pairs
            .iter()
            .filter(|(lf, _)| !lf.failure)
            .filter_map(|(lf, _)| lf.robustness)
            .collect();
        margins.sort_by(f64::total_cmp);
        margins.dedup();
        let mut best = (Rule::PAPER, paper_rate);
        for m in margins {
            let rule = Rule { margin: Some(m) };
            let (found, rate) = value(&rule);
            if found >= paper_found + 2 && rate >= paper_rate * 1.02 && rate > best.1 {
                best = (rule, rate);
            }
        }
        best.0
    }
}

/// Whether LF screening pays in one scenario, from what its runs cost and how often they
/// fail. A screened trial pays an LF run to save the HF run of a pass; when nearly every trial
/// fails (a deployed proposal that has concentrated on a failure region) the LF run saves
/// nothing and HF alone finds the same failures for less. Screening pays while
/// `c_LF < (1 − p) · c_HF,pass`: the mean LF cost against the HF pass cost it is expected to
/// save, with `p` the share of failures (LF failures of screened trials, HF failures of direct
/// ones, under a uniform prior). The LF verdict is taken as exact (at θ_LF* it is the search's
/// best agreement with HF; the audit measures its misses).
///
/// ```
/// use savme_kernel::screening::Economy;
/// use savme_kernel::Run;
/// let mut e = Economy::default();
/// e.saw_hf(&Run::new(false, 10.0)); // the search's HF passes cost 10
/// assert!(e.screen_pays(), "it screens until it has measured the LF runs");
/// for _ in 0..Economy::WARMUP {
///     e.add_screened(&Run::new(true, 3.0), None); // every LF run fails, at 3 each
/// }
/// assert!(!e.screen_pays(), "3 > (1 − p) · 10 once p > 0.7");
/// for _ in 0..20 {
///     e.add_direct(&Run::new(false, 10.0)); // the failures stop
/// }
/// assert!(e.screen_pays());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Economy {
    /// Screened trials (an LF run each).
    pub screened: u64,
    /// Their LF failures.
    pub lf_failures: u64,
    /// Trials run on HF directly.
    pub direct: u64,
    /// Their HF failures.
    pub direct_failures: u64,
    /// Summed cost of the LF runs.
    pub lf_cost: f64,
    /// HF passes seen (the search's and the screening's).
    pub hf_passes: u64,
    /// Their summed cost.
    pub hf_pass_cost: f64,
}

impl Economy {
    /// Screened trials before the LF cost counts as measured: until then every trial is
    /// screened.
    pub const WARMUP: u64 = 10;

    /// Counts an HF run's cost if it passed.
    pub fn saw_hf(&mut self, hf: &Run) {
        if !hf.failure {
            self.hf_passes += 1;
            self.hf_pass_cost += hf.runtime;
        }
    }

    /// Adds a screened trial: its LF run and the HF run if one was made.
    pub fn add_screened(&mut self, lf: &Run, hf: Option<&Run>) {
        self.screened += 1;
        self.lf_failures += u64::from(lf.failure);
        self.lf_cost += lf.runtime;
        if let Some(hf) = hf {
            self.saw_hf(hf);
        }
    }

    /// Adds a direct trial (HF only).
    pub fn add_direct(&mut self, hf: &Run) {
        self.add_skipped(hf);
        self.saw_hf(hf);
    }

    /// Adds a trial that skipped this level of a [ladder](plan) (it did not pay): `next` is
    /// the run that was made instead — the next level's LF run, or the HF run — whose verdict
    /// stands in for this level's in the failure share.
    pub fn add_skipped(&mut self, next: &Run) {
        self.direct += 1;
        self.direct_failures += u64::from(next.failure);
    }

    /// The estimated share of failures among the next trials.
    pub fn failure_share(&self) -> f64 {
        let failures = self.lf_failures + self.direct_failures;
        (failures as f64 + 1.0) / ((self.screened + self.direct) as f64 + 2.0)
    }

    /// Whether the next trial should run LF first: during the warm-up, without a known HF
    /// pass cost, or while `c_LF < (1 − p) · c_HF,pass`.
    pub fn screen_pays(&self) -> bool {
        self.pays_against(self.hf_pass_cost())
    }

    /// The mean cost of the HF passes seen (None before any).
    pub fn hf_pass_cost(&self) -> Option<f64> {
        (self.hf_passes > 0).then(|| self.hf_pass_cost / self.hf_passes as f64)
    }

    /// The mean cost of this level's LF runs (None before any).
    pub fn lf_run_cost(&self) -> Option<f64> {
        (self.screened > 0).then(|| self.lf_cost / self.screened as f64)
    }

    /// Whether running this level first pays when a pass saves `saved` (the expected cost of
    /// what would run after it; None: not known yet): during the warm-up, without `saved`, or
    /// while `c_LF < (1 − p) · saved`.
    pub fn pays_against(&self, saved: Option<f64>) -> bool {
        match (self.screened < Self::WARMUP, self.lf_run_cost(), saved) {
            (false, Some(lf), Some(saved)) => lf < (1.0 - self.failure_share()) * saved,
            _ => true,
        }
    }
}

/// Which levels of a fidelity ladder the next trial runs, from each level's [`Economy`]
/// (cheapest level first; the last is the one nearest HF). A screened trial runs the levels
/// of the plan in order; a level's failure is confirmed at the next planned level up, HF last;
/// a pass ends the trial (unless it is audited). A level pays while its LF run costs less than
/// the share of passes times what a pass saves: the expected cost of the plan above it
/// (`c + p · rest` for each planned level above, the HF pass cost at the top, which the last
/// level's economy keeps). A ladder of one level is the two-level screening:
/// `plan(&[e]) == [e.screen_pays()]`.
///
/// ```
/// use savme_kernel::screening::{plan, Economy};
/// use savme_kernel::Run;
/// let mut top = Economy::default();
/// top.saw_hf(&Run::new(false, 10.0)); // an HF pass costs 10
/// let mut low = Economy::default();
/// assert_eq!(plan(&[low, top]), [true, true], "both screen until measured");
/// for _ in 0..Economy::WARMUP {
///     low.add_screened(&Run::new(false, 0.5), None); // the cheap level passes everything
///     top.add_screened(&Run::new(true, 3.0), None); // what reaches the top fails there
/// }
/// // The top, where nearly everything fails, no longer pays (its failures go to HF at once);
/// // the bottom, which passes nearly everything, saves those HF runs: it pays.
/// assert_eq!(plan(&[low, top]), [true, false]);
/// assert_eq!(plan(&[top]), [top.screen_pays()]);
/// ```
pub fn plan(levels: &[Economy]) -> Vec<bool> {
    let mut runs = vec![true; levels.len()];
    // What a pass at the level below saves: the expected cost of the plan from here up.
    let mut rest = levels.last().and_then(Economy::hf_pass_cost);
    for (i, e) in levels.iter().enumerate().rev() {
        runs[i] = e.pays_against(rest);
        if runs[i] {
            rest = match (e.lf_run_cost(), rest) {
                (Some(c), Some(r)) => Some(c + e.failure_share() * r),
                _ => None,
            };
        }
    }
    runs
}

/// What a screened trial on a ladder runs next ([`next`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Step {
    /// The LF run at this level of the ladder (0: the cheapest).
    Level(usize),
    /// The HF run: to confirm the last level's failure, for the audit, or directly.
    Hf,
    /// Nothing more: a pass, not audited.
    Stop,
}

/// The next run of a screened trial on a ladder with `plan` ([`plan`]: which levels run),
/// after `last` (the last level run and whether its LF run failed; None: nothing ran yet):
/// the first planned level (HF directly if none is), after a failure the next planned level
/// up (HF after the top), after a pass HF if the trial is `audited`, else nothing.
///
/// ```
/// use savme_kernel::screening::{next, Step};
/// let plan = [true, false, true];
/// assert_eq!(next(&plan, None, false), Step::Level(0));
/// assert_eq!(next(&plan, Some((0, true)), false), Step::Level(2)); // level 1 does not pay
/// assert_eq!(next(&plan, Some((2, true)), false), Step::Hf);
/// assert_eq!(next(&plan, Some((0, false)), false), Step::Stop);
/// assert_eq!(next(&plan, Some((0, false)), true), Step::Hf); // the audit
/// assert_eq!(next(&[false], None, false), Step::Hf); // direct
/// ```
pub fn next(plan: &[bool], last: Option<(usize, bool)>, audited: bool) -> Step {
    let from = match last {
        None => 0,
        Some((_, false)) if audited => return Step::Hf,
        Some((_, false)) => return Step::Stop,
        Some((level, true)) => level + 1,
    };
    match (from..plan.len()).find(|&i| plan[i]) {
        Some(i) => Step::Level(i),
        None => Step::Hf,
    }
}

/// Whether trial `index` of a screening stage seeded `seed` belongs to the audit sample: a
/// uniform draw (SplitMix64 of seed and index) below `alpha`. A pure function, so a replayed
/// stage audits the same trials, whatever order the runs finish in.
pub fn audited(seed: u64, index: u64, alpha: f64) -> bool {
    let mut z = seed ^ index.wrapping_mul(0x9e37_79b9_7f4a_7c15);
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    ((z >> 11) as f64 / (1u64 << 53) as f64) < alpha
}

/// Counts and costs of a screening run.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ScreeningCounts {
    /// Trials (LF runs).
    pub trials: u64,
    /// LF failures (each re-run on HF).
    pub lf_failures: u64,
    /// LF failures the HF run confirmed.
    pub confirmed: u64,
    /// LF failures the HF run did not confirm.
    pub false_positives: u64,
    /// LF passes run on HF for the audit.
    pub audited: u64,
    /// Audited LF passes whose HF run failed: failures the LF simulator missed.
    pub audit_misses: u64,
    /// LF passes within the [`Rule::margin`], checked on HF.
    #[serde(default)]
    pub margin_checks: u64,
    /// Of those, the HF failures: failures the margin found that the LF verdict missed.
    #[serde(default)]
    pub margin_found: u64,
    /// Trials run on HF directly, without an LF run ([`Screen::Direct`]).
    #[serde(default)]
    pub direct: u64,
    /// Of those, the HF failures.
    #[serde(default)]
    pub direct_found: u64,
    /// Cost of the LF runs.
    pub lf_runtime: f64,
    /// Cost of the HF runs (confirmations and audits).
    pub hf_runtime: f64,
}

impl ScreeningCounts {
    /// Adds a trial: its LF run (None for a direct trial), its HF run if one was made, and the
    /// screen's decision.
    pub fn add(&mut self, lf: Option<&Run>, hf: Option<&Run>, screen: Screen) {
        self.trials += 1;
        self.lf_runtime += lf.map_or(0.0, |l| l.runtime);
        if let Some(hf) = hf {
            self.hf_runtime += hf.runtime;
        }
        let hf_failed = hf.is_some_and(|h| h.failure);
        match screen {
            Screen::Confirm => {
                self.lf_failures += 1;
                self.confirmed += u64::from(hf_failed);
                self.false_positives += u64::from(!hf_failed);
            }
            Screen::Margin if hf.is_some() => {
                self.margin_checks += 1;
                self.margin_found += u64::from(hf_failed);
            }
            Screen::Audit if hf.is_some() => {
                self.audited += 1;
                self.audit_misses += u64::from(hf_failed);
            }
            Screen::Direct => {
                self.direct += 1;
                self.direct_found += u64::from(hf_failed);
            }
            Screen::Margin | Screen::Audit | Screen::Pass => {}
        }
    }

    /// Every run's cost (LF + HF).
    pub fn runtime(&self) -> f64 {
        self.lf_runtime + self.hf_runtime
    }

    /// HF-confirmed failures: LF failures confirmed, and near-misses within the margin that
    /// failed on HF.
    pub fn found(&self) -> u64 {
        self.confirmed + self.margin_found + self.direct_found
    }

    /// HF-confirmed failures ([`ScreeningCounts::found`]) per unit of total cost (None before
    /// any cost).
    pub fn confirmed_per_runtime(&self) -> Option<f64> {
        let r = self.runtime();
        (r > 0.0).then(|| self.found() as f64 / r)
    }

    /// The miss (FN) rate among LF passes, from the audit (None without audited trials).
    pub fn miss_rate(&self) -> Option<f64> {
        (self.audited > 0).then(|| self.audit_misses as f64 / self.audited as f64)
    }

    /// LF passes not checked within the margin: trials the screen called safe.
    pub fn passes(&self) -> u64 {
        self.trials - self.lf_failures - self.margin_checks - self.direct
    }

    /// Estimated failures among all LF passes (miss rate × passes).
    pub fn estimated_misses(&self) -> Option<f64> {
        self.miss_rate().map(|r| r * self.passes() as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_audit_draws_about_alpha_of_the_trials_and_is_reproducible() {
        let n = (0..100_000u64).filter(|&i| audited(3, i, 0.1)).count();
        assert!((9_700..=10_300).contains(&n), "{n}");
        assert_eq!(audited(3, 17, 0.1), audited(3, 17, 0.1));
        assert!(!(0..1000u64).any(|i| audited(3, i, 0.0)));
        assert!((0..1000u64).all(|i| audited(3, i, 1.0)));
        // Another seed audits other trials.
        let a: Vec<bool> = (0..64u64).map(|i| audited(3, i, 0.5)).collect();
        let b: Vec<bool> = (0..64u64).map(|i| audited(4, i, 0.5)).collect();
        assert_ne!(a, b);
    }

    #[test]
    fn counts_split_confirmations_false_positives_and_misses() {
        let mut c = ScreeningCounts::default();
        let add = |c: &mut ScreeningCounts, lf: Run, hf: Option<Run>, audit| {
            c.add(Some(&lf), hf.as_ref(), Rule::PAPER.decide(&lf, audit));
        };
        add(
            &mut c,
            Run::new(true, 1.0),
            Some(Run::new(true, 4.0)),
            false,
        );
        add(
            &mut c,
            Run::new(true, 1.0),
            Some(Run::new(false, 4.0)),
            true,
        );
        add(
            &mut c,
            Run::new(false, 1.0),
            Some(Run::new(true, 4.0)),
            true,
        );
        add(
            &mut c,
            Run::new(false, 1.0),
            Some(Run::new(false, 4.0)),
            true,
        );
        add(&mut c, Run::new(false, 1.0), None, false);
        assert_eq!((c.trials, c.lf_failures, c.confirmed), (5, 2, 1));
        assert_eq!((c.false_positives, c.audited, c.audit_misses), (1, 2, 1));
        assert_eq!(c.runtime(), 5.0 + 16.0);
        assert_eq!(c.miss_rate(), Some(0.5));
        assert_eq!(c.estimated_misses(), Some(1.5));
        assert_eq!(c.confirmed_per_runtime(), Some(1.0 / 21.0));
    }

    #[test]
    fn margin_checks_count_as_found_failures_and_not_as_passes() {
        let rule = Rule { margin: Some(0.5) };
        let mut c = ScreeningCounts::default();
        for (lf, hf) in [
            (
                Run::new(false, 1.0).with_robustness(0.2),
                Some(Run::new(true, 4.0)),
            ),
            (
                Run::new(false, 1.0).with_robustness(0.4),
                Some(Run::new(false, 4.0)),
            ),
            (Run::new(false, 1.0).with_robustness(3.0), None),
            (
                Run::new(true, 1.0).with_robustness(-1.0),
                Some(Run::new(true, 4.0)),
            ),
        ] {
            c.add(Some(&lf), hf.as_ref(), rule.decide(&lf, false));
        }
        assert_eq!((c.lf_failures, c.confirmed), (1, 1));
        assert_eq!((c.margin_checks, c.margin_found, c.found()), (2, 1, 2));
        assert_eq!(c.passes(), 1);
        assert_eq!(c.confirmed_per_runtime(), Some(2.0 / 16.0));
    }

    /// Economies of every kind: in and after the warm-up, with and without HF passes, cheap
    /// and dear LF runs, rare and frequent failures, skipped trials.
    fn economies() -> Vec<Economy> {
        let mut all = vec![Economy::default()];
        for (n, fail_every, lf, hf_pass, skipped) in [
            (3u64, 2u64, 1.0, Some(10.0), 0u64),
            (12, 2, 1.0, Some(10.0), 0),
            (12, 1, 3.0, Some(10.0), 5),
            (40, 5, 2.0, Some(4.0), 0),
            (40, 10, 0.2, None, 3),
            (25, 3, 6.0, Some(5.0), 8),
        ] {
            let mut e = Economy::default();
            if let Some(c) = hf_pass {
                e.saw_hf(&Run::new(false, c));
            }
            for i in 0..n {
                e.add_screened(&Run::new(i % fail_every == 0, lf), None);
            }
            for i in 0..skipped {
                e.add_direct(&Run::new(i % 2 == 0, 9.0));
            }
            all.push(e);
        }
        all
    }

    #[test]
    fn a_ladder_of_one_level_is_the_two_level_screening() {
        for e in economies() {
            assert_eq!(plan(&[e]), [e.screen_pays()], "{e:?}");
        }
        assert!(plan(&[]).is_empty());
    }

    #[test]
    fn a_level_pays_against_the_plan_above_it() {
        let mut top = Economy::default();
        top.saw_hf(&Run::new(false, 10.0));
        let mut mid = top;
        let mut low = top;
        for i in 0..20 {
            // The cheapest level flags half, the middle one confirms a fifth of those: both
            // save HF runs.
            low.add_screened(&Run::new(i % 2 == 0, 0.1), None);
            mid.add_screened(&Run::new(i % 5 == 0, 1.0), None);
            top.add_screened(&Run::new(i % 5 == 0, 3.0), None);
        }
        assert_eq!(plan(&[low, mid, top]), [true, true, true]);
        // A middle level that costs as much as what it saves above it is skipped; the levels
        // below it then save against the level above it instead.
        let mut dear = Economy::default();
        for _ in 0..20 {
            dear.add_screened(&Run::new(false, 50.0), None);
        }
        assert_eq!(plan(&[low, dear, top]), [true, false, true]);
        // A bottom level that flags everything saves nothing.
        let mut flags = Economy::default();
        for _ in 0..20 {
            flags.add_screened(&Run::new(true, 0.5), None);
        }
        assert_eq!(plan(&[flags, mid, top]), [false, true, true]);
        // Skipped trials count the verdict of the run made instead, not as an HF pass.
        let mut skip = Economy::default();
        skip.add_skipped(&Run::new(true, 4.0));
        assert_eq!(
            (skip.direct, skip.direct_failures, skip.hf_passes),
            (1, 1, 0)
        );
    }

    #[test]
    fn a_fitted_rule_keeps_the_papers_unless_a_margin_clearly_pays() {
        // An LF simulator that misses nothing: no margin pays.
        let exact: Vec<(Run, Run)> = (0..50)
            .map(|i| {
                let fail = i % 5 == 0;
                let r = if fail { -1.0 } else { f64::from(i % 7) * 0.1 };
                (Run::new(fail, 1.0).with_robustness(r), Run::new(fail, 4.0))
            })
            .collect();
        assert_eq!(Rule::fit(&exact, 20), Rule::PAPER);
        // Passes without a robustness give no margin to choose.
        let bare: Vec<(Run, Run)> = (0..50)
            .map(|i| (Run::new(false, 1.0), Run::new(i % 2 == 0, 4.0)))
            .collect();
        assert_eq!(Rule::fit(&bare, 20), Rule::PAPER);
        // One miss is not enough evidence.
        let mut one = exact.clone();
        one[1].1 = Run::new(true, 4.0);
        assert_eq!(Rule::fit(&one, 20), Rule::PAPER);
    }
}
