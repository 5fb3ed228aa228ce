//! LF runs as control variates for the HF estimate (multi-fidelity Monte Carlo,
//! Peherstorfer, Willcox & Gunzburger 2016), on the importance-weighted terms y = w·f.
//!
//! Each *pair* draws φ ~ q and runs it at HF (a = w·f_HF) and at LF (b = w·f_LF); each pair
//! is followed by `k` *extra* LF-only draws from the same q. With n pairs and m = n·(1 + k)
//! LF outcomes in all (the pairs' included),
//!
//! > P̂ = ā_n + α·(b̄_m − b̄_n),
//!
//! unbiased for any α fixed in advance (b̄_m − b̄_n has mean 0). α and k are chosen from a
//! **calibration** phase of paired runs that are not part of the estimate, so α is independent
//! of the runs it multiplies and the estimate stays exactly unbiased. Its variance is
//!
//! > Var P̂ = σ_a²/n + (1/n − 1/m)·(α²σ_b² − 2α·σ_ab),
//!
//! estimated with the sample moments (σ_a², σ_ab from the pairs, σ_b² from every LF outcome).

use super::statistic::{Interval, Sums};
use serde::{Deserialize, Serialize};

/// The most extra LF runs per pair the plan may choose.
pub const MAX_EXTRA: u32 = 64;

/// LF runs as control variates ([`super::EstimationConfig::control`]): after the pilot,
/// `calibration` pairs (φ run at HF and at LF) measure the correlation and the costs; then
/// every estimate draw runs at HF and LF, followed by `extra` LF-only draws — or, when the
/// measured correlation and costs say the LF does not pay, the estimate runs HF only.
///
/// ```
/// use savme_kernel::estimation::Control;
/// let c: Control = serde_json::from_str(r#"{"calibration":2000}"#)?;
/// assert_eq!(c, Control { calibration: 2000, extra: None });
/// # Ok::<(), serde_json::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Control {
    /// Calibration pairs over all scenarios (shared by p(s)), ≥ 2 per scenario; their runs
    /// choose α and `extra` and are not part of the estimate.
    pub calibration: u64,
    /// Extra LF runs per pair, 0 ..= [`MAX_EXTRA`] (None: chosen from the calibration, the
    /// k minimising the cost × variance of the estimate; 0: HF only after the calibration).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub extra: Option<u32>,
}

/// Which part of a control-variate estimation a trial is.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ControlPart {
    /// A calibration pair's HF or LF run (not part of the estimate).
    Calibration,
    /// An estimate pair's HF or LF run.
    Paired,
    /// An extra LF-only run of the estimate.
    Extra,
}

/// The moments of paired (a, b) = (w·f_HF, w·f_LF) outcomes.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct PairSums {
    pub hf: Sums,
    pub lf: Sums,
    /// Σ a·b.
    pub ab: f64,
}

impl PairSums {
    pub(crate) fn add(&mut self, weight: f64, hf: bool, lf: bool) {
        self.hf.add(weight, hf);
        self.lf.add(weight, lf);
        if hf && lf {
            self.ab += weight * weight;
        }
    }

    /// Sample variances of a and b and their covariance (0 below 2 pairs).
    pub(crate) fn moments(&self) -> (f64, f64, f64) {
        let n = self.hf.runs as f64;
        if self.hf.runs < 2 {
            return (0.0, 0.0, 0.0);
        }
        let (ma, mb) = (self.hf.y / n, self.lf.y / n);
        let va = ((self.hf.y2 - n * ma * ma) / (n - 1.0)).max(0.0);
        let vb = ((self.lf.y2 - n * mb * mb) / (n - 1.0)).max(0.0);
        (va, vb, (self.ab - n * ma * mb) / (n - 1.0))
    }
}

/// What the calibration chose for one scenario.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ControlPlan {
    /// Calibration pairs of the scenario.
    pub calibration_pairs: u64,
    /// Of which failed at HF.
    pub calibration_hf_failures: u64,
    /// Of which failed at LF.
    pub calibration_lf_failures: u64,
    /// The correlation of w·f_HF and w·f_LF over the calibration pairs.
    pub rho: f64,
    /// The mean LF run's cost over the mean HF run's (all scenarios' calibration runs; 1
    /// when no cost was told).
    pub cost_ratio: f64,
    /// The frozen coefficient α = σ_ab / σ_b² (0 when the LF is not used).
    pub alpha: f64,
    /// Extra LF runs per pair (0 with `use_lf` false).
    pub extra: u32,
    /// Whether the estimate runs LF at all (false: HF only, the plain importance-sampling
    /// estimate).
    pub use_lf: bool,
    /// The predicted cost × variance of the chosen design over HF-only sampling's,
    /// (1 + c·(1 + k))·(1 − ρ²·k/(1 + k)) (1 when HF only): below 1 the LF pays.
    pub predicted_factor: f64,
}

/// The predicted cost × variance over HF-only's with `k` extra LF runs per pair.
pub(crate) fn factor(rho: f64, cost_ratio: f64, k: u32) -> f64 {
    let k = f64::from(k);
    (1.0 + cost_ratio * (1.0 + k)) * (1.0 - rho * rho * k / (1.0 + k))
}

impl ControlPlan {
    /// The plan from a scenario's calibration pairs, the cost ratio and the forced `extra`.
    pub(crate) fn new(c: &PairSums, cost_ratio: f64, extra: Option<u32>) -> ControlPlan {
        let (va, vb, cov) = c.moments();
        let rho = if va > 0.0 && vb > 0.0 {
            (cov / (va * vb).sqrt()).clamp(-1.0, 1.0)
        } else {
            0.0
        };
        let best = (1..=MAX_EXTRA)
            .map(|k| (k, factor(rho, cost_ratio, k)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap_or((1, f64::INFINITY));
        let (extra, use_lf) = match extra {
            Some(k) => (k, k > 0),
            None => (best.0, best.1 < 1.0),
        };
        let alpha = if use_lf && vb > 0.0 { cov / vb } else { 0.0 };
        ControlPlan {
            calibration_pairs: c.hf.runs,
            calibration_hf_failures: c.hf.failures,
            calibration_lf_failures: c.lf.failures,
            rho,
            cost_ratio,
            alpha,
            extra: if use_lf { extra } else { 0 },
            use_lf,
            predicted_factor: if use_lf {
                factor(rho, cost_ratio, extra)
            } else {
                1.0
            },
        }
    }
}

/// The control-variate estimate of one scenario and its standard error (infinite below 2
/// pairs): `pairs` the estimate's pairs, `extra` its LF-only runs.
pub(crate) fn estimate(pairs: &PairSums, extra: &Sums, alpha: f64) -> Interval {
    let n = pairs.hf.runs as f64;
    if pairs.hf.runs < 2 {
        let mean = if n > 0.0 { pairs.hf.y / n } else { 0.0 };
        return Interval::from_mean_and_error(mean, f64::INFINITY);
    }
    let m = n + extra.runs as f64;
    let (ma, mbn) = (pairs.hf.y / n, pairs.lf.y / n);
    let mbm = (pairs.lf.y + extra.y) / m;
    let mean = ma + alpha * (mbm - mbn);
    let (va, _, cov) = pairs.moments();
    let vb = ((pairs.lf.y2 + extra.y2 - m * mbm * mbm) / (m - 1.0)).max(0.0);
    let var = va / n + (1.0 / n - 1.0 / m) * (alpha * alpha * vb - 2.0 * alpha * cov);
    Interval::from_mean_and_error(mean, var.max(0.0).sqrt())
}

/// A scenario's control-variate part of the estimate ([`super::ScenarioEstimate::control`]).
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ControlReport {
    /// What the calibration chose.
    pub plan: ControlPlan,
    /// LF runs in the estimate (the pairs' and the extra ones).
    pub lf_runs: u64,
    /// Of which failed.
    pub lf_failures: u64,
    /// The HF-only importance-sampling mean ā_n of the same pairs (what the control
    /// variate corrects).
    pub hf_only_mean: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_plan_uses_the_lf_only_when_it_pays() {
        // Perfectly correlated pairs: identical HF and LF outcomes.
        let mut c = PairSums::default();
        for i in 0..100 {
            c.add(2.0, i % 10 == 0, i % 10 == 0);
        }
        let p = ControlPlan::new(&c, 0.01, None);
        assert!(p.use_lf && (p.rho - 1.0).abs() < 1e-12 && (p.alpha - 1.0).abs() < 1e-12);
        assert!(p.extra > 1 && p.predicted_factor < 0.5, "{p:?}");
        // Independent-looking pairs at a quarter of the cost: no gain.
        let mut c = PairSums::default();
        for i in 0..100 {
            c.add(1.0, i % 10 == 0, i % 10 == 5);
        }
        let p = ControlPlan::new(&c, 0.25, None);
        assert!(!p.use_lf && p.alpha == 0.0 && p.extra == 0, "{p:?}");
        // A forced design is kept, with α from the pairs.
        let p = ControlPlan::new(&c, 0.25, Some(3));
        assert!(p.use_lf && p.extra == 3 && p.alpha < 0.0, "{p:?}");
    }

    #[test]
    fn the_estimate_matches_hand_computed_moments() {
        let mut pairs = PairSums::default();
        // a = (1, 0, 1, 0), b = (1, 1, 0, 0), weights 1.
        for (h, l) in [(true, true), (false, true), (true, false), (false, false)] {
            pairs.add(1.0, h, l);
        }
        let mut extra = Sums::default();
        for l in [true, false, false, false] {
            extra.add(1.0, l);
        }
        let alpha = 0.5;
        let e = estimate(&pairs, &extra, alpha);
        // ā = 0.5, b̄_n = 0.5, b̄_m = 3/8: 0.5 + 0.5·(−1/8).
        assert!((e.mean - 0.4375).abs() < 1e-12);
        // σ_a² = 1/3, σ_ab = 0, σ_b² over 8 values with 3 ones = (3 − 8·(3/8)²)/7.
        let vb = (3.0 - 8.0 * 0.375f64 * 0.375) / 7.0;
        let var = (1.0 / 3.0) / 4.0 + (0.25 - 0.125) * (0.25 * vb);
        assert!((e.std_error - var.sqrt()).abs() < 1e-12);
    }
}
