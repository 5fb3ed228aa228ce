//! The defensive mixture proposal built from a posterior and the nominal ([`super::nominal`]).
//!
//! Densities are products over the variables of a probability (discrete variables) or a
//! density (continuous variables). Both the nominal p and the proposal q use that same base
//! measure, so the weight p(φ)/q(φ) is well defined for any mix of variable kinds.

use super::nominal::{categorical, NominalOf};
use crate::posterior::Posterior;
use crate::space::{Space, Variable};
use crate::value::{Assignment, Value};
use rand::{Rng, RngExt};
use serde::{Deserialize, Serialize};

/// How p̂_ψ weighs the bins of a variable.
///
/// ```
/// use savme_kernel::estimation::Tilt;
/// assert_eq!(Tilt::default(), Tilt::Posterior);
/// assert_eq!(serde_json::to_string(&Tilt::NominalWeighted).unwrap(), "\"nominal-weighted\"");
/// ```
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Tilt {
    /// Bin k with probability ∝ its posterior mean (the issue's rule): toward where the
    /// system fails most often.
    #[default]
    Posterior,
    /// ∝ posterior mean × the nominal's probability of bin k: toward where p(φ)·P(failure)
    /// is largest. The same as `Posterior` under a uniform nominal; for a nominal concentrated
    /// away from the failures (a rare event).
    NominalWeighted,
}

/// The fixed proposal of one scenario: q = (1 − ε)·p̂_ψ + ε·p, with p̂_ψ the product over the
/// variables of the bins' posterior means (normalised), uniform or log-uniform inside a bin.
/// A cross-entropy refit ([`Proposal::refit`]) replaces the bins' probabilities and draws
/// inside a bin from the nominal restricted to the bin.
#[derive(Debug, Clone)]
pub(crate) struct Proposal {
    space: Space,
    /// Per variable, the probability of each arm under p̂_ψ.
    bins: Vec<Vec<f64>>,
    nominal: Vec<NominalOf>,
    epsilon: f64,
    /// What φ looks like inside a bin.
    shape: InBin,
}

/// The density of p̂_ψ inside a bin.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum InBin {
    /// Uniform (linear) or log-uniform (log): the issue's rule for the posterior's proposal.
    Scale,
    /// The nominal restricted to the bin (the same as `Scale` for a uniform nominal): a
    /// refitted proposal's, so that the weight is constant inside a bin along that variable.
    Nominal,
}

/// Bins whose nominal probability is below this get no share of a refitted p̂_ψ: a truncated
/// normal cannot be drawn accurately there, and p(φ) is negligible (the defensive component
/// still covers them).
pub(crate) const MIN_BIN_MASS: f64 = 1e-12;

/// The densities of one φ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Densities {
    /// Under the proposal q.
    pub q: f64,
    /// Under the nominal p.
    pub p: f64,
}

impl Proposal {
    pub(crate) fn new(
        space: &Space,
        posterior: &Posterior,
        nominal: Vec<NominalOf>,
        epsilon: f64,
        tilt: Tilt,
    ) -> Proposal {
        let bins = posterior
            .arms()
            .iter()
            .zip(space.variables().iter().zip(&nominal))
            .map(|(arms, (var, n))| {
                let score = |k: usize| match tilt {
                    Tilt::Posterior => arms[k].mean(),
                    Tilt::NominalWeighted => arms[k].mean() * n.bin_mass(var, k),
                };
                let total: f64 = (0..arms.len()).map(score).sum();
                if total > 0.0 {
                    (0..arms.len()).map(|k| score(k) / total).collect()
                } else {
                    vec![1.0 / arms.len() as f64; arms.len()]
                }
            })
            .collect();
        Proposal {
            space: space.clone(),
            bins,
            nominal,
            epsilon,
            shape: InBin::Scale,
        }
    }

    /// One cross-entropy step: each variable's bin probabilities become
    /// `smoothing · m_k / Σm + (1 − smoothing) · old_k`, where `mass[i][k]` is the summed
    /// weight w·f of the failing pilot trials whose variable i fell in bin k (the weighted
    /// failures estimate the marginals of the zero-variance density ∝ p(φ)·1{failure}).
    /// Returns false, changing nothing, when `mass` holds no failure.
    pub(crate) fn refit(&mut self, mass: &[Vec<f64>], smoothing: f64) -> bool {
        if !mass.iter().all(|m| m.iter().sum::<f64>() > 0.0) {
            return false;
        }
        for ((bins, m), (var, n)) in self
            .bins
            .iter_mut()
            .zip(mass)
            .zip(self.space.variables().iter().zip(&self.nominal))
        {
            let total: f64 = m.iter().sum();
            for (k, b) in bins.iter_mut().enumerate() {
                *b = if n.bin_mass(var, k) < MIN_BIN_MASS {
                    0.0
                } else {
                    smoothing * m[k] / total + (1.0 - smoothing) * *b
                };
            }
            let sum: f64 = bins.iter().sum();
            if sum > 0.0 {
                bins.iter_mut().for_each(|b| *b /= sum);
            }
        }
        self.shape = InBin::Nominal;
        true
    }

    /// The per-variable bin probabilities of p̂_ψ.
    pub(crate) fn bins(&self) -> &[Vec<f64>] {
        &self.bins
    }

    /// The density of `phi` under the learned part p̂_ψ.
    fn learned(&self, phi: &Assignment) -> f64 {
        let mut d = 1.0;
        for ((var, bins), n) in self
            .space
            .variables()
            .iter()
            .zip(&self.bins)
            .zip(&self.nominal)
        {
            let Some(x) = phi.get(&var.name) else {
                return 0.0;
            };
            let Some(arm) = var.arm_of(x) else {
                return 0.0;
            };
            d *= bins[arm]
                * match self.shape {
                    InBin::Scale => in_bin_density(var, arm, x),
                    InBin::Nominal => n.density_in_bin(var, arm, x),
                };
        }
        d
    }

    /// The bin (arm) of each variable that `phi` falls in (None for a value outside).
    pub(crate) fn arms_of(&self, phi: &Assignment) -> Option<Vec<usize>> {
        self.space
            .variables()
            .iter()
            .map(|var| phi.get(&var.name).and_then(|x| var.arm_of(x)))
            .collect()
    }

    /// The space, the defensive share ε, and a draw from the nominal alone (for the joint
    /// proposal, [`super::joint`], which keeps this proposal's nominal and ε).
    pub(crate) fn space(&self) -> &Space {
        &self.space
    }

    pub(crate) fn epsilon(&self) -> f64 {
        self.epsilon
    }

    /// The nominal of each variable, in the space's order.
    pub(crate) fn nominals(&self) -> &[NominalOf] {
        &self.nominal
    }

    /// Per variable, the nominal's probability of each bin (or value); 0 for a bin below
    /// [`MIN_BIN_MASS`], which a fitted proposal never draws.
    pub(crate) fn nominal_bins(&self) -> Vec<Vec<f64>> {
        self.space
            .variables()
            .iter()
            .zip(&self.nominal)
            .map(|(var, n)| {
                (0..var.arms())
                    .map(|k| {
                        Some(n.bin_mass(var, k))
                            .filter(|m| *m >= MIN_BIN_MASS)
                            .unwrap_or(0.0)
                    })
                    .collect()
            })
            .collect()
    }

    pub(crate) fn draw_nominal<R: Rng + ?Sized>(&self, rng: &mut R) -> Assignment {
        let mut phi = Assignment::new();
        for (var, n) in self.space.variables().iter().zip(&self.nominal) {
            phi.set(&var.name, n.draw(var, rng));
        }
        phi
    }

    /// The density of `phi` under the nominal p.
    pub(crate) fn nominal(&self, phi: &Assignment) -> f64 {
        let mut d = 1.0;
        for (var, n) in self.space.variables().iter().zip(&self.nominal) {
            match phi.get(&var.name) {
                Some(x) => d *= n.density(var, x),
                None => return 0.0,
            }
        }
        d
    }

    /// q(φ) and p(φ).
    pub(crate) fn densities(&self, phi: &Assignment) -> Densities {
        let p = self.nominal(phi);
        Densities {
            q: (1.0 - self.epsilon) * self.learned(phi) + self.epsilon * p,
            p,
        }
    }

    /// Draws φ from q: the nominal with probability ε, else p̂_ψ.
    pub(crate) fn draw<R: Rng + ?Sized>(&self, rng: &mut R) -> Assignment {
        let u: f64 = rng.random();
        let mut phi = Assignment::new();
        for (i, var) in self.space.variables().iter().enumerate() {
            let x = if u < self.epsilon {
                self.nominal[i].draw(var, rng)
            } else {
                let arm = categorical(&self.bins[i], rng);
                match self.shape {
                    InBin::Scale => var.draw_in_arm(arm, rng),
                    InBin::Nominal => self.nominal[i].draw_in_bin(var, arm, rng),
                }
            };
            phi.set(&var.name, x);
        }
        phi
    }
}

/// The density of `x` inside bin `arm` of `var` ([`Variable::in_bin_density`]).
fn in_bin_density(var: &Variable, arm: usize, x: &Value) -> f64 {
    var.in_bin_density(arm, x)
}
