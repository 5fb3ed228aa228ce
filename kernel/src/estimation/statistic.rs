//! The importance-weighted estimate of a failure probability: running sums, the mean with its
//! normal-approximation 95 % interval, and the effective sample sizes.

use serde::{Deserialize, Serialize};
use statrs::distribution::{ContinuousCDF, Normal};

/// Running sums of one scenario's told trials.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub(crate) struct Sums {
    pub runs: u64,
    pub failures: u64,
    /// Σ w·f, Σ (w·f)², Σ w, Σ w².
    pub y: f64,
    pub y2: f64,
    pub w: f64,
    pub w2: f64,
}

impl Sums {
    pub(crate) fn add(&mut self, weight: f64, failure: bool) {
        let y = if failure { weight } else { 0.0 };
        self.runs += 1;
        self.failures += u64::from(failure);
        self.y += y;
        self.y2 += y * y;
        self.w += weight;
        self.w2 += weight * weight;
    }

    /// The mean of w·f and its standard error (infinite below 2 runs).
    fn mean_and_error(&self) -> (f64, f64) {
        if self.runs == 0 {
            return (0.0, f64::INFINITY);
        }
        let n = self.runs as f64;
        let mean = self.y / n;
        if self.runs < 2 {
            return (mean, f64::INFINITY);
        }
        let var = ((self.y2 - n * mean * mean) / (n - 1.0)).max(0.0);
        (mean, (var / n).sqrt())
    }
}

/// The two-sided 95 % normal quantile, 1.959963…
pub fn z95() -> f64 {
    // Normal(0, 1) is a valid distribution: `new` cannot fail for these arguments.
    Normal::new(0.0, 1.0).map_or(1.959_963_984_540_054, |n| n.inverse_cdf(0.975))
}

/// An estimate of P(failure) with its 95 % interval.
///
/// ```
/// use savme_kernel::estimation::Interval;
/// let i = Interval::from_mean_and_error(0.01, 0.001);
/// assert!((i.half_width - 0.00196).abs() < 1e-5);
/// assert!((i.relative_half_width() - 0.196).abs() < 1e-3);
/// ```
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Interval {
    /// The estimate.
    pub mean: f64,
    /// Its standard error.
    pub std_error: f64,
    /// 1.96 standard errors.
    pub half_width: f64,
    /// `mean − half_width`, at least 0.
    pub lo: f64,
    /// `mean + half_width`, at most 1.
    pub hi: f64,
}

impl Interval {
    /// The normal-approximation 95 % interval `mean ± 1.96·std_error`, clamped to [0, 1].
    pub fn from_mean_and_error(mean: f64, std_error: f64) -> Interval {
        let half_width = z95() * std_error;
        Interval {
            mean,
            std_error,
            half_width,
            lo: (mean - half_width).max(0.0),
            hi: (mean + half_width).min(1.0),
        }
    }

    /// `half_width / mean`: 0.1 is "±10 %". Infinite while the estimate is 0.
    pub fn relative_half_width(&self) -> f64 {
        if self.mean > 0.0 {
            self.half_width / self.mean
        } else {
            f64::INFINITY
        }
    }
}

/// The estimate of P(failure | s) for one scenario.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScenarioEstimate {
    /// The scenario.
    pub scenario: String,
    /// Its weight p(s) (normalised).
    pub probability: f64,
    /// HF runs told.
    pub runs: u64,
    /// Of which failed.
    pub failures: u64,
    /// `(1/n) Σ w_i f_i` with its interval.
    pub estimate: Interval,
    /// Kish's effective sample size of all weights, `(Σw)² / Σw²`.
    pub ess: f64,
    /// The same over the failing trials' weights, `(Σ w f)² / Σ (w f)²` (0 without failures):
    /// how many equally weighted failures the estimate rests on.
    pub failure_ess: f64,
    /// `(1/n) Σ w_i`: close to 1 when q covers p (its expectation is exactly 1).
    pub mean_weight: f64,
    /// With control variates: the calibration's plan and the LF runs of the estimate (then
    /// `runs`, `failures`, the ESS and the mean weight are those of the pairs' HF runs, and
    /// `estimate` is the control-variate estimate).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub control: Option<super::ControlReport>,
}

impl ScenarioEstimate {
    pub(crate) fn new(scenario: &str, probability: f64, s: &Sums) -> ScenarioEstimate {
        let (mean, se) = s.mean_and_error();
        let ratio = |a: f64, b: f64| if b > 0.0 { a * a / b } else { 0.0 };
        ScenarioEstimate {
            scenario: scenario.to_string(),
            probability,
            runs: s.runs,
            failures: s.failures,
            estimate: Interval::from_mean_and_error(mean, se),
            ess: ratio(s.w, s.w2),
            failure_ess: ratio(s.y, s.y2),
            mean_weight: if s.runs > 0 { s.w / s.runs as f64 } else { 0.0 },
            control: None,
        }
    }

    /// The control-variate estimate of a scenario from its pairs and extra LF runs.
    pub(crate) fn with_control(
        scenario: &str,
        probability: f64,
        pairs: &super::control::PairSums,
        extra: &Sums,
        plan: super::ControlPlan,
    ) -> ScenarioEstimate {
        let mut e = ScenarioEstimate::new(scenario, probability, &pairs.hf);
        let hf_only_mean = e.estimate.mean;
        e.estimate = super::control::estimate(pairs, extra, plan.alpha);
        e.control = Some(super::ControlReport {
            plan,
            lf_runs: pairs.lf.runs + extra.runs,
            lf_failures: pairs.lf.failures + extra.failures,
            hf_only_mean,
        });
        e
    }
}

/// The estimate of every scenario and of the p(s)-weighted total.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    /// One per scenario, in the estimation's scenario order.
    pub scenarios: Vec<ScenarioEstimate>,
    /// `Σ_s p(s) P(failure | s)`, its standard error `√(Σ_s p(s)² se_s²)` (scenarios are
    /// sampled independently).
    pub total: Interval,
    /// HF runs told over all scenarios.
    pub runs: u64,
    /// Of which failed.
    pub failures: u64,
}

impl Estimate {
    pub(crate) fn from_scenarios(scenarios: Vec<ScenarioEstimate>) -> Estimate {
        let mean = scenarios
            .iter()
            .map(|s| s.probability * s.estimate.mean)
            .sum();
        let var: f64 = scenarios
            .iter()
            .map(|s| (s.probability * s.estimate.std_error).powi(2))
            .sum();
        Estimate {
            total: Interval::from_mean_and_error(mean, var.sqrt()),
            runs: scenarios.iter().map(|s| s.runs).sum(),
            failures: scenarios.iter().map(|s| s.failures).sum(),
            scenarios,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sums_match_hand_computed_moments() {
        let mut s = Sums::default();
        // weights 2, 0.5, 1 with failures on the first and the third: y = 2, 0, 1.
        s.add(2.0, true);
        s.add(0.5, false);
        s.add(1.0, true);
        let e = ScenarioEstimate::new("s", 1.0, &s);
        assert_eq!((e.runs, e.failures), (3, 2));
        assert!((e.estimate.mean - 1.0).abs() < 1e-12);
        // sample variance of (2, 0, 1) = 1, so se = 1/√3.
        assert!((e.estimate.std_error - (1.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert!((e.ess - 3.5 * 3.5 / 5.25).abs() < 1e-12);
        assert!((e.failure_ess - 9.0 / 5.0).abs() < 1e-12);
        assert!((e.mean_weight - 3.5 / 3.0).abs() < 1e-12);
        assert!((z95() - 1.959_964).abs() < 1e-6);
    }

    #[test]
    fn total_weights_scenarios_by_probability() {
        let mut a = Sums::default();
        let mut b = Sums::default();
        for i in 0..10 {
            a.add(1.0, i < 2); // 0.2
            b.add(1.0, i < 5); // 0.5
        }
        let e = Estimate::from_scenarios(vec![
            ScenarioEstimate::new("a", 0.25, &a),
            ScenarioEstimate::new("b", 0.75, &b),
        ]);
        assert!((e.total.mean - (0.25 * 0.2 + 0.75 * 0.5)).abs() < 1e-12);
        let se = ((0.25f64 * a_se(&a)).powi(2) + (0.75 * a_se(&b)).powi(2)).sqrt();
        assert!((e.total.std_error - se).abs() < 1e-12);
        assert_eq!((e.runs, e.failures), (20, 7));
    }

    fn a_se(s: &Sums) -> f64 {
        s.mean_and_error().1
    }

    #[test]
    fn no_failures_has_an_infinite_relative_width() {
        let mut s = Sums::default();
        s.add(1.0, false);
        s.add(1.0, false);
        let e = ScenarioEstimate::new("s", 1.0, &s);
        assert_eq!(e.estimate.mean, 0.0);
        assert_eq!(e.estimate.relative_half_width(), f64::INFINITY);
        assert_eq!(e.failure_ess, 0.0);
    }
}
