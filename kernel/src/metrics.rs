//! Metrics from a trial history: TP-rate, mean LF cost, speedup, failures-over-runtime curves
//! and their break-even time.

use crate::kernel::TrialRecord;
use crate::outcome::Outcome;
use serde::{Deserialize, Serialize};

/// Counts over a set of told trials.
///
/// ```
/// use savme_kernel::metrics::Summary;
/// let s = Summary::default();
/// assert_eq!(s.tp_rate(), None); // nothing told yet
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Summary {
    /// Trials counted.
    pub trials: u64,
    /// Paired trials (HF and LF) among them.
    pub paired: u64,
    /// Paired trials per class.
    pub tp: u64,
    /// Both runs passed.
    pub tn: u64,
    /// Only the LF run failed.
    pub fp: u64,
    /// Only the HF run failed (`fn` in JSON).
    #[serde(rename = "fn")]
    pub fn_: u64,
    /// Trials whose HF run failed (paired or not).
    pub hf_failures: u64,
    /// Sum of `t_LF / t_HF` over paired trials.
    pub cost_ratio_sum: f64,
    /// Sum of HF runtimes.
    pub hf_runtime: f64,
    /// Sum of LF runtimes.
    pub lf_runtime: f64,
}

impl Summary {
    /// Counts the given records.
    pub fn of<'a>(records: impl IntoIterator<Item = &'a TrialRecord>) -> Summary {
        let mut s = Summary::default();
        for r in records {
            s.add(r);
        }
        s
    }

    /// Adds one record.
    pub fn add(&mut self, r: &TrialRecord) {
        self.trials += 1;
        let hf = r.observation.hf();
        self.hf_runtime += hf.runtime;
        self.hf_failures += u64::from(hf.failure);
        if let Some(lf) = r.observation.lf() {
            self.lf_runtime += lf.runtime;
        }
        if let (Some(o), Some(c)) = (r.observation.outcome(), r.observation.cost_ratio()) {
            self.paired += 1;
            self.cost_ratio_sum += c;
            match o {
                Outcome::TP => self.tp += 1,
                Outcome::TN => self.tn += 1,
                Outcome::FP => self.fp += 1,
                Outcome::FN => self.fn_ += 1,
            }
        }
    }

    /// TP / paired trials: the share of trials in which the LF simulator alone would have found
    /// a true failure. None without paired trials.
    pub fn tp_rate(&self) -> Option<f64> {
        (self.paired > 0).then(|| self.tp as f64 / self.paired as f64)
    }

    /// Mean `t_LF / t_HF` over paired trials. None without paired trials.
    pub fn mean_lf_cost(&self) -> Option<f64> {
        (self.paired > 0).then(|| self.cost_ratio_sum / self.paired as f64)
    }

    /// Share of trials whose HF run failed (the baseline's failure rate). None without trials.
    pub fn hf_failure_rate(&self) -> Option<f64> {
        (self.trials > 0).then(|| self.hf_failures as f64 / self.trials as f64)
    }

    /// Share of paired trials where LF and HF agree (TP + TN).
    pub fn agreement(&self) -> Option<f64> {
        (self.paired > 0).then(|| (self.tp + self.tn) as f64 / self.paired as f64)
    }
}

/// Failures found per unit of cost relative to the baseline:
/// `(tp_rate / mean_lf_cost) / baseline_failure_rate` — the paper's Table III column. None when
/// the denominator is zero or a value is not finite.
///
/// ```
/// use savme_kernel::metrics::speedup;
/// let s = speedup(0.74, 0.25, 0.17).unwrap();
/// assert!((s - 17.41).abs() < 0.01); // Table III prints 17.99 from unrounded inputs
/// ```
pub fn speedup(tp_rate: f64, mean_lf_cost: f64, baseline_failure_rate: f64) -> Option<f64> {
    let s = (tp_rate / mean_lf_cost) / baseline_failure_rate;
    (s.is_finite() && mean_lf_cost > 0.0 && baseline_failure_rate > 0.0).then_some(s)
}

/// Which runs a failures-over-runtime curve charges for, and what counts as a found failure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Accounting {
    /// Every run costs (`t_HF + t_LF` for a paired trial, `t_HF` for an HF-only one); a failure
    /// is found when the HF run fails. This is meta-training and meta-testing as run, and the
    /// baseline.
    AllRuns,
    /// Only the LF run costs and a failure is found when it is a TP (for HF-only trials: the HF
    /// run). This is deploying θ_LF* alone, as the evaluation's speedup assumes.
    LfOnly,
}

/// A point of a [`FailureCurve`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CurvePoint {
    /// Cumulative cost.
    pub time: f64,
    /// Failures found by then.
    pub failures: u64,
}

/// Cumulative found failures over cumulative cost: a right-continuous step function starting at
/// (0, 0).
///
/// ```
/// use savme_kernel::metrics::FailureCurve;
/// let mut c = FailureCurve::new();
/// c.push(2.0, true);
/// c.push(1.0, false);
/// assert_eq!(c.failures_at(1.9), 0);
/// assert_eq!(c.failures_at(2.0), 1);
/// assert_eq!(c.end(), 3.0);
/// ```
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct FailureCurve {
    points: Vec<CurvePoint>,
}

impl FailureCurve {
    /// An empty curve.
    pub fn new() -> Self {
        Self::default()
    }

    /// The curve of `records`, in the given order, under `accounting`.
    pub fn from_records<'a>(
        records: impl IntoIterator<Item = &'a TrialRecord>,
        accounting: Accounting,
    ) -> Self {
        let mut c = FailureCurve::new();
        for r in records {
            let hf = r.observation.hf();
            let (cost, found) = match (accounting, r.observation.lf()) {
                (_, None) => (hf.runtime, hf.failure),
                (Accounting::AllRuns, Some(lf)) => (hf.runtime + lf.runtime, hf.failure),
                (Accounting::LfOnly, Some(lf)) => (lf.runtime, hf.failure && lf.failure),
            };
            c.push(cost, found);
        }
        c
    }

    /// Appends a trial that cost `cost` and did or did not find a failure.
    pub fn push(&mut self, cost: f64, found: bool) {
        let last = self.points.last().copied().unwrap_or(CurvePoint {
            time: 0.0,
            failures: 0,
        });
        self.points.push(CurvePoint {
            time: last.time + cost,
            failures: last.failures + u64::from(found),
        });
    }

    /// The points, one per trial.
    pub fn points(&self) -> &[CurvePoint] {
        &self.points
    }

    /// Total cost.
    pub fn end(&self) -> f64 {
        self.points.last().map_or(0.0, |p| p.time)
    }

    /// Total failures found.
    pub fn failures(&self) -> u64 {
        self.points.last().map_or(0, |p| p.failures)
    }

    /// Failures found by cost `t` (trials completing at exactly `t` included).
    pub fn failures_at(&self, t: f64) -> u64 {
        let k = self.points.partition_point(|p| p.time <= t);
        if k == 0 {
            0
        } else {
            self.points[k - 1].failures
        }
    }
}

/// The break-even time of `method` against `baseline`: the earliest cost from which on `method`
/// has found strictly more failures than `baseline`, up to the end of the shorter curve. None
/// when `method` is not ahead at that end (break-even not reached within the common horizon).
///
/// ```
/// use savme_kernel::metrics::{break_even, FailureCurve};
/// let mut base = FailureCurve::new();
/// let mut savme = FailureCurve::new();
/// for i in 0..10 {
///     base.push(1.0, i % 4 == 0);      // a failure every 4 cost units
///     savme.push(1.0, i >= 5);         // slow start, then a failure every unit
/// }
/// assert_eq!(break_even(&savme, &base), Some(8.0));
/// ```
pub fn break_even(method: &FailureCurve, baseline: &FailureCurve) -> Option<f64> {
    let horizon = method.end().min(baseline.end());
    let mut times: Vec<f64> = method
        .points
        .iter()
        .chain(&baseline.points)
        .map(|p| p.time)
        .filter(|&t| t <= horizon)
        .collect();
    times.sort_by(f64::total_cmp);
    times.dedup();
    let mut since = None;
    for t in times {
        if method.failures_at(t) > baseline.failures_at(t) {
            since.get_or_insert(t);
        } else {
            since = None;
        }
    }
    since
}
