//! Which learning trials (train, test) run the LF simulator next to HF.
//!
//! The paper pairs every learning trial: an HF run at θ_HF and an LF run at a Thompson draw of
//! θ_LF, both paid for. The LF run teaches the fidelity bandit p_ω(θ_LF) and nothing else —
//! the φ search is credited by the HF run alone (Table I: TP or FN). Once the fidelity
//! posterior has *settled* — the arm with the highest posterior mean of every fidelity
//! variable holds at least [`Pairing::settle`] observations, i.e. Thompson sampling has
//! concentrated on it (the MAP arm is no measure: one success in one try has mode 1) — further
//! LF runs mostly confirm what is known, so [`Pairing::fraction`] < 1 pairs only that share of
//! the later learning trials; the others are HF only (their trial has no θ_LF), still credit
//! the φ search, and cost one HF run. On the bundled simulator a failing HF run stops at the
//! collision, so the LF run is up to half of a failing trial's cost (docs/RESULTS.md, issue 25).
//!
//! The default pairs every trial and draws no random number, so the paper's campaigns keep
//! their trials bit for bit.
//!
//! ```
//! use savme_kernel::Pairing;
//! assert!(Pairing::default().is_always());
//! let p = Pairing { fraction: 0.25, settle: 30 };
//! assert!(p.validate().is_ok());
//! assert!(Pairing { fraction: 0.0, ..p }.validate().is_err());
//! ```

use crate::posterior::{Estimator, Posterior, PriorCounts};
use rand::{Rng, RngExt};
use serde::{Deserialize, Serialize};

/// How often a learning trial is paired (HF and LF) once θ_LF* is settled. Part of the
/// [`crate::KernelConfig`]; missing fields take their defaults when deserialised.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Pairing {
    /// Probability that a learning trial is paired once the fidelity posterior has settled, in
    /// `(0, 1]`; 1 (the default, the paper's) pairs every trial.
    pub fraction: f64,
    /// Observations the arm with the highest posterior mean of every fidelity variable needs
    /// before the posterior counts as settled (transferred evidence of a fidelity prior included); until then every
    /// learning trial is paired.
    pub settle: u64,
}

impl Default for Pairing {
    fn default() -> Self {
        Pairing {
            fraction: 1.0,
            settle: 30,
        }
    }
}

/// A pairing parameter out of its range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("pairing parameter `{name}` = {value} is outside {range}")]
pub struct PairingError {
    /// The parameter (`fraction`).
    pub name: &'static str,
    /// Its value.
    pub value: f64,
    /// The allowed range.
    pub range: &'static str,
}

impl Pairing {
    /// True when every learning trial is paired (the paper's protocol).
    pub fn is_always(&self) -> bool {
        self.fraction >= 1.0
    }

    /// True for the default (left out of a serialised configuration).
    pub fn is_default(&self) -> bool {
        *self == Pairing::default()
    }

    /// Checks the parameters.
    pub fn validate(&self) -> Result<(), PairingError> {
        let f = self.fraction;
        if f > 0.0 && f <= 1.0 {
            Ok(())
        } else {
            Err(PairingError {
                name: "fraction",
                value: f,
                range: "(0, 1]",
            })
        }
    }

    /// Whether the next learning trial is paired. Draws from `rng` only when the fraction is
    /// below 1 and the fidelity posterior has settled.
    pub(crate) fn pairs<R: Rng + ?Sized>(&self, fidelity: &Posterior, rng: &mut R) -> bool {
        if self.is_always() || !settled(fidelity, self.settle) {
            return true;
        }
        rng.random::<f64>() < self.fraction
    }
}

/// True when the arm with the highest posterior mean of every variable holds at least `n`
/// observations beyond the base prior.
fn settled(fidelity: &Posterior, n: u64) -> bool {
    let PriorCounts { successes, losses } = fidelity.prior();
    let best = fidelity.best_arms(Estimator::Mean);
    fidelity.arms().iter().zip(best).all(|(arms, b)| {
        let a = &arms[b as usize];
        a.alpha + a.beta - successes - losses >= n as f64
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::space::{Space, Variable};
    use rand::SeedableRng;

    #[test]
    fn the_posterior_settles_when_its_greedy_arm_has_the_evidence() {
        let space = Space::new(vec![Variable::discrete("r", [1, 2])]).unwrap();
        let mut p = Posterior::new(&space, PriorCounts::UNIFORM).unwrap();
        let pairing = Pairing {
            fraction: 0.5,
            settle: 3,
        };
        let mut rng = rand_pcg::Pcg64::seed_from_u64(1);
        let before = rng.clone();
        assert!(pairing.pairs(&p, &mut rng));
        assert_eq!(rng, before, "no draw before the posterior settles");
        for _ in 0..3 {
            p.update(&[1], true);
        }
        assert!(settled(&p, 3));
        assert!(!settled(&p, 4));
        let paired = (0..1000).filter(|_| pairing.pairs(&p, &mut rng)).count();
        assert!((430..570).contains(&paired), "{paired} of 1000 paired");
    }
}
