//! LF screening with HF confirmation: the deployment of a learned fidelity θ_LF*. Every trial
//! runs the LF simulator; an LF failure is re-run on the HF simulator (confirmed, or a false
//! positive); a random audit fraction α of the LF passes is also run on HF, to estimate how
//! many failures the LF simulator misses (its FN rate among passes).
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
//!     let hf = match decide(lf.failure, audited(7, index, 0.1)) {
//!         Screen::Confirm | Screen::Audit => Some(Run::new(index % 20 == 0, 1.0)),
//!         Screen::Pass => None,
//!     };
//!     counts.add(&lf, hf.as_ref(), audited(7, index, 0.1));
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
    /// The LF run passed and the trial was drawn for the audit: run HF to look for a miss.
    Audit,
    /// The LF run passed, not audited: no HF run.
    Pass,
}

/// The decision for an LF result (`audited`: the trial was drawn for the audit).
pub fn decide(lf_failure: bool, audited: bool) -> Screen {
    match (lf_failure, audited) {
        (true, _) => Screen::Confirm,
        (false, true) => Screen::Audit,
        (false, false) => Screen::Pass,
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
    /// Cost of the LF runs.
    pub lf_runtime: f64,
    /// Cost of the HF runs (confirmations and audits).
    pub hf_runtime: f64,
}

impl ScreeningCounts {
    /// Adds a trial: its LF run, its HF run if one was made, and whether it was audited.
    pub fn add(&mut self, lf: &Run, hf: Option<&Run>, audited: bool) {
        self.trials += 1;
        self.lf_runtime += lf.runtime;
        if let Some(hf) = hf {
            self.hf_runtime += hf.runtime;
        }
        let hf_failed = hf.is_some_and(|h| h.failure);
        match decide(lf.failure, audited) {
            Screen::Confirm => {
                self.lf_failures += 1;
                self.confirmed += u64::from(hf_failed);
                self.false_positives += u64::from(!hf_failed);
            }
            Screen::Audit if hf.is_some() => {
                self.audited += 1;
                self.audit_misses += u64::from(hf_failed);
            }
            Screen::Audit | Screen::Pass => {}
        }
    }

    /// Every run's cost (LF + HF).
    pub fn runtime(&self) -> f64 {
        self.lf_runtime + self.hf_runtime
    }

    /// Confirmed failures per unit of total cost (None before any cost).
    pub fn confirmed_per_runtime(&self) -> Option<f64> {
        let r = self.runtime();
        (r > 0.0).then(|| self.confirmed as f64 / r)
    }

    /// The miss (FN) rate among LF passes, from the audit (None without audited trials).
    pub fn miss_rate(&self) -> Option<f64> {
        (self.audited > 0).then(|| self.audit_misses as f64 / self.audited as f64)
    }

    /// LF passes: trials the LF simulator called safe.
    pub fn passes(&self) -> u64 {
        self.trials - self.lf_failures
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
        c.add(&Run::new(true, 1.0), Some(&Run::new(true, 4.0)), false);
        c.add(&Run::new(true, 1.0), Some(&Run::new(false, 4.0)), true);
        c.add(&Run::new(false, 1.0), Some(&Run::new(true, 4.0)), true);
        c.add(&Run::new(false, 1.0), Some(&Run::new(false, 4.0)), true);
        c.add(&Run::new(false, 1.0), None, false);
        assert_eq!((c.trials, c.lf_failures, c.confirmed), (5, 2, 1));
        assert_eq!((c.false_positives, c.audited, c.audit_misses), (1, 2, 1));
        assert_eq!(c.runtime(), 5.0 + 16.0);
        assert_eq!(c.miss_rate(), Some(0.5));
        assert_eq!(c.estimated_misses(), Some(1.5));
        assert_eq!(c.confirmed_per_runtime(), Some(1.0 / 21.0));
    }
}
