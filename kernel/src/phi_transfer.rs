//! Meta-testing's p_ψ transfer: where a new scenario shares a φ variable (the same name and
//! the same domain — range, bins and scale, or values) with training scenarios, its φ prior
//! for that variable may start from what their p_ψ learned, at a strength chosen by
//! leave-one-scenario-out on those training scenarios, exactly as the fidelity prior's
//! ([`crate::evidence::choose_strengths`]): each sharing training scenario is held out once,
//! its bins' failures and passes scored by their Beta–Binomial log marginal likelihood under
//! `base + λ · m · the others' evidence`; the strength with the best sum wins, and 0 (the
//! uniform prior) unless it gains [`MIN_GAIN_PER_SCENARIO`] nats per held-out scenario. When
//! the training scenarios disagree on where a variable's failures are, the transfer shrinks to
//! the uniform prior; when they agree, it carries their evidence. A variable no training
//! scenario shares, or shares with fewer than two scenarios with evidence, transfers nothing.
//!
//! ```
//! use savme_kernel::phi_transfer::{choose_phi_transfer, TrainingScenario};
//! use savme_kernel::{Posterior, PriorCounts, Scale, Space, Variable};
//! let gap = || Variable::continuous("gap", 0.0, 10.0, 5, Scale::Linear);
//! let space = Space::new(vec![gap()])?;
//! // Three training scenarios that agree: failures in bin 0 only.
//! let mut learned = Vec::new();
//! for _ in 0..3 {
//!     let mut p = Posterior::new(&space, PriorCounts::UNIFORM)?;
//!     for _ in 0..20 {
//!         p.update(&[0], true);
//!         p.update(&[4], false);
//!     }
//!     learned.push(p);
//! }
//! let training: Vec<TrainingScenario> = learned
//!     .iter()
//!     .map(|p| TrainingScenario { name: "s", space: &space, posterior: p })
//!     .collect();
//! let test = Space::new(vec![gap(), Variable::boolean("rain")])?;
//! let t = choose_phi_transfer(&test, &training, PriorCounts::UNIFORM, &[0.0, 0.1, 1.0]);
//! assert_eq!(t.variables[0].strength, 1.0);
//! assert!(t.variables[1].scenarios.is_empty(), "no training scenario has `rain`");
//! let prior = t.prior(&test, &training, PriorCounts::UNIFORM)?.expect("a transfer");
//! assert_eq!(prior.arms()[0][0].alpha, 61.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::evidence::{choose_one, clean_candidates};
use crate::posterior::{Posterior, PosteriorError, PriorCounts};
use crate::space::Space;
use serde::{Deserialize, Serialize};

pub use crate::evidence::MIN_GAIN_PER_SCENARIO;

/// One training scenario as the φ transfer reads it: its φ-space and its p_ψ after training.
#[derive(Debug, Clone, Copy)]
pub struct TrainingScenario<'a> {
    /// Its name (reported).
    pub name: &'a str,
    /// Its φ-space.
    pub space: &'a Space,
    /// Its p_ψ after meta-training; the evidence is each arm's counts above the posterior's
    /// base prior.
    pub posterior: &'a Posterior,
}

/// One φ variable of the new scenario and the strength its prior was given.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SharedVariable {
    /// The variable.
    pub variable: String,
    /// The training scenarios with the same variable (name and domain), in the order given.
    pub scenarios: Vec<String>,
    /// Of those, the scenarios with evidence on it (each held out once).
    pub held_out: usize,
    /// The chosen strength (0: the uniform prior).
    pub strength: f64,
    /// Held-out log marginal likelihood per candidate strength ([`PhiTransfer::candidates`]);
    /// empty when fewer than two sharing scenarios have evidence (nothing to hold out).
    pub log_likelihood: Vec<f64>,
}

impl SharedVariable {
    /// Why the strength is what it is, in words.
    pub fn why(&self) -> String {
        match (self.scenarios.len(), self.log_likelihood.is_empty()) {
            (0, _) => "no training scenario has this variable with this domain".into(),
            (n, true) => format!(
                "{n} training scenario(s) share it, {} with evidence: two are needed to hold one out",
                self.held_out
            ),
            (_, false) if self.strength == 0.0 => format!(
                "the {} sharing training scenarios disagree: no strength predicts the held-out ones by {} nat(s) per scenario more than the uniform prior",
                self.held_out, MIN_GAIN_PER_SCENARIO
            ),
            _ => format!(
                "the {} sharing training scenarios agree: the best held-out likelihood",
                self.held_out
            ),
        }
    }
}

/// The φ transfer to one new scenario, variable by variable ([`choose_phi_transfer`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PhiTransfer {
    /// The candidate strengths, ascending.
    pub candidates: Vec<f64>,
    /// Every variable of the new scenario's φ-space, in space order.
    pub variables: Vec<SharedVariable>,
}

impl PhiTransfer {
    /// Whether any variable is transferred (a strength above 0).
    pub fn transfers(&self) -> bool {
        self.variables.iter().any(|v| v.strength > 0.0)
    }

    /// The new scenario's φ prior: per variable `base + strength · Σ the sharing training
    /// scenarios' evidence` per arm; None when nothing is transferred (the kernel then starts
    /// from its base prior, as without a transfer). `space` and `training` as given to
    /// [`choose_phi_transfer`].
    pub fn prior(
        &self,
        space: &Space,
        training: &[TrainingScenario<'_>],
        base: PriorCounts,
    ) -> Result<Option<Posterior>, PosteriorError> {
        if !self.transfers() {
            return Ok(None);
        }
        let pooled: Vec<Vec<(f64, f64)>> = space
            .variables()
            .iter()
            .zip(&self.variables)
            .map(|(var, shared)| {
                let mut sum = vec![(0.0, 0.0); var.arms()];
                if shared.strength > 0.0 {
                    for counts in sharing(var, training) {
                        for (t, (s, l)) in sum.iter_mut().zip(counts) {
                            t.0 += shared.strength * s;
                            t.1 += shared.strength * l;
                        }
                    }
                }
                sum
            })
            .collect();
        Posterior::with_extra(space, base, |v, k| pooled[v][k]).map(Some)
    }
}

/// Per training scenario that has `var` (same name and domain), its evidence on it per arm:
/// (successes, losses) above its posterior's base prior.
fn sharing<'t>(
    var: &'t crate::space::Variable,
    training: &'t [TrainingScenario<'_>],
) -> impl Iterator<Item = Vec<(f64, f64)>> + 't {
    training.iter().filter_map(move |t| {
        let i = t.space.variables().iter().position(|v| v == var)?;
        let arms = t.posterior.arms().get(i)?;
        let base = t.posterior.prior();
        Some(
            arms.iter()
                .map(|a| {
                    (
                        (a.alpha - base.successes).max(0.0),
                        (a.beta - base.losses).max(0.0),
                    )
                })
                .collect(),
        )
    })
}

/// Chooses, per φ variable of the new scenario's `space`, the strength of its transferred prior
/// from `candidates` (finite, ≥ 0) by leave-one-scenario-out on the training scenarios that
/// share it (module docs). A training posterior that does not fit its space is skipped.
pub fn choose_phi_transfer(
    space: &Space,
    training: &[TrainingScenario<'_>],
    base: PriorCounts,
    candidates: &[f64],
) -> PhiTransfer {
    let cands = clean_candidates(candidates);
    let fits: Vec<TrainingScenario<'_>> = training
        .iter()
        .copied()
        .filter(|t| t.posterior.check_fits(t.space).is_ok())
        .collect();
    let variables = space
        .variables()
        .iter()
        .map(|var| {
            let scenarios: Vec<String> = fits
                .iter()
                .filter(|t| t.space.variables().contains(var))
                .map(|t| t.name.to_string())
                .collect();
            let counts: Vec<Vec<(f64, f64)>> = sharing(var, &fits)
                .filter(|c| c.iter().any(|(s, l)| s + l > 0.0))
                .collect();
            let (strength, log_likelihood) = if counts.len() >= 2 && !cands.is_empty() {
                choose_one(&counts, base, &cands)
            } else {
                (0.0, Vec::new())
            };
            SharedVariable {
                variable: var.name.to_string(),
                held_out: counts.len(),
                scenarios,
                strength,
                log_likelihood,
            }
        })
        .collect();
    PhiTransfer {
        candidates: cands,
        variables,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::space::{Scale, Variable};
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    fn gap() -> Variable {
        Variable::continuous("gap", 0.0, 10.0, 5, Scale::Linear)
    }

    /// Four training scenarios' p_ψ on `gap`, 60 seeded trials each, failing with probability
    /// 0.9 in the scenario's failure bin and 0.05 elsewhere: `failure_bin(s)` per scenario.
    fn trained(failure_bin: impl Fn(usize) -> usize, seed: u64) -> Vec<Posterior> {
        let space = Space::new(vec![gap()]).unwrap();
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        (0..4)
            .map(|s| {
                let mut p = Posterior::new(&space, PriorCounts::UNIFORM).unwrap();
                for _ in 0..60 {
                    let arm = rng.random_range(0..5usize);
                    let q = if arm == failure_bin(s) { 0.9 } else { 0.05 };
                    p.update(&[arm as u16], rng.random_bool(q));
                }
                p
            })
            .collect()
    }

    fn choose(posteriors: &[Posterior], test: &Space) -> PhiTransfer {
        let space = Space::new(vec![gap()]).unwrap();
        let training: Vec<TrainingScenario> = posteriors
            .iter()
            .map(|p| TrainingScenario {
                name: "s",
                space: &space,
                posterior: p,
            })
            .collect();
        choose_phi_transfer(
            test,
            &training,
            PriorCounts::UNIFORM,
            &crate::evidence::STRENGTHS,
        )
    }

    #[test]
    fn training_scenarios_that_disagree_shrink_to_uniform_and_ones_that_agree_transfer() {
        let test = Space::new(vec![gap()]).unwrap();
        for seed in 1..=5 {
            // Agree: every scenario fails in bin 1.
            let agree = choose(&trained(|_| 1, seed), &test);
            let v = &agree.variables[0];
            assert_eq!(v.held_out, 4);
            assert!(v.strength >= 0.3, "seed {seed}: {v:?}");
            // The margin is wide, not knife-edge.
            assert!(
                v.log_likelihood.iter().cloned().fold(f64::MIN, f64::max)
                    > v.log_likelihood[0] + 4.0 * MIN_GAIN_PER_SCENARIO + 10.0,
                "seed {seed}: {v:?}"
            );
            // Disagree: each scenario fails in a bin of its own.
            let disagree = choose(&trained(|s| s, seed), &test);
            let v = &disagree.variables[0];
            assert_eq!(v.strength, 0.0, "seed {seed}: {v:?}");
            assert!(
                v.log_likelihood[0] > v.log_likelihood[5] + 10.0,
                "seed {seed}: {v:?}"
            );
            assert!(v.why().contains("disagree"), "{}", v.why());
        }
    }

    #[test]
    fn only_a_variable_with_the_same_name_and_domain_is_shared() {
        let posteriors = trained(|_| 1, 1);
        let other_range = Variable::continuous("gap", 0.0, 12.0, 5, Scale::Linear);
        let other_bins = Variable::continuous("gap", 0.0, 10.0, 4, Scale::Linear);
        for var in [other_range, other_bins] {
            let test = Space::new(vec![var]).unwrap();
            let t = choose(&posteriors, &test);
            assert!(t.variables[0].scenarios.is_empty(), "{t:?}");
            assert!(!t.transfers());
            let space = Space::new(vec![gap()]).unwrap();
            let training: Vec<TrainingScenario> = posteriors
                .iter()
                .map(|p| TrainingScenario {
                    name: "s",
                    space: &space,
                    posterior: p,
                })
                .collect();
            assert_eq!(
                t.prior(&test, &training, PriorCounts::UNIFORM).unwrap(),
                None
            );
        }
    }

    #[test]
    fn the_prior_pools_the_sharing_scenarios_evidence_at_the_chosen_strength() {
        let posteriors = trained(|_| 1, 2);
        let space = Space::new(vec![gap()]).unwrap();
        let test = Space::new(vec![Variable::boolean("rain"), gap()]).unwrap();
        let training: Vec<TrainingScenario> = posteriors
            .iter()
            .map(|p| TrainingScenario {
                name: "s",
                space: &space,
                posterior: p,
            })
            .collect();
        let t = choose_phi_transfer(&test, &training, PriorCounts::UNIFORM, &[0.0, 0.5]);
        assert_eq!(t.variables[0].strength, 0.0);
        assert_eq!(t.variables[1].strength, 0.5);
        let prior = t
            .prior(&test, &training, PriorCounts::UNIFORM)
            .unwrap()
            .unwrap();
        assert!(prior.arms()[0]
            .iter()
            .all(|a| a.alpha == 1.0 && a.beta == 1.0));
        for k in 0..5 {
            let s: f64 = posteriors.iter().map(|p| p.arms()[0][k].alpha - 1.0).sum();
            assert_eq!(prior.arms()[1][k].alpha, 1.0 + 0.5 * s);
        }
    }
}
