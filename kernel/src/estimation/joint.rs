//! The joint (non-product) learned part of an estimation proposal: a mixture of K
//! components over the whole of φ, each a product over the variables of a distribution over
//! the variable's bins (or values), with φ drawn inside a bin from the nominal restricted to
//! the bin (a latent-class mixture of product histograms). The mixture is not a product over
//! the variables, so it can put its mass on a joint corner of φ ("fast ego *and* short gap
//! *and* early braking", or two opposite corners) that no product of per-variable
//! distributions reaches without also covering the rest of the box; with one component it is
//! the product proposal's refit.
//!
//! Densities are exact and normalised, in the nominal's base measure (a density for a
//! continuous variable, a probability for a discrete one): q_k(φ) = Π_i π_ki(b_i) · p_i(x_i) /
//! P_i(b_i), with b_i the bin of x_i and P_i(b) the nominal's probability of bin b — so inside
//! a joint cell the weight p/q is constant, as with the product proposal's refit, and bins the
//! nominal gives (almost) no mass get none ([`super::proposal::MIN_BIN_MASS`]).

use super::nominal::categorical;
use super::proposal::{Densities, Proposal};
use crate::space::Space;
use crate::value::Assignment;
use rand::{Rng, RngExt};

/// A mixture of components with weights `alpha` (normalised), over one scenario's space.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Mixture {
    pub(crate) alpha: Vec<f64>,
    /// Per component, per variable, the probability of each bin (normalised; 0 where the
    /// nominal has no mass).
    pub(crate) components: Vec<Vec<Vec<f64>>>,
}

/// The bin (or value index) of every variable of `phi`; None for a missing or out-of-range
/// value.
pub(crate) fn point_of(space: &Space, phi: &Assignment) -> Option<Vec<usize>> {
    space
        .variables()
        .iter()
        .map(|var| phi.get(&var.name).and_then(|x| var.arm_of(x)))
        .collect()
}

impl Mixture {
    /// The mixture's probability of the joint cell `arms` (the bins' probabilities, summed
    /// over the components).
    pub(crate) fn cell(&self, arms: &[usize]) -> f64 {
        self.alpha
            .iter()
            .zip(&self.components)
            .map(|(a, dims)| a * dims.iter().zip(arms).map(|(p, &b)| p[b]).product::<f64>())
            .sum()
    }

    /// The density of `phi` in the nominal's base measure (0 outside the space).
    pub(crate) fn density(&self, base: &Proposal, phi: &Assignment) -> f64 {
        let space = base.space();
        let Some(arms) = point_of(space, phi) else {
            return 0.0;
        };
        let mut inside = 1.0;
        for ((var, n), &arm) in space.variables().iter().zip(base.nominals()).zip(&arms) {
            match phi.get(&var.name) {
                Some(x) => inside *= n.density_in_bin(var, arm, x),
                None => return 0.0,
            }
        }
        if inside > 0.0 {
            self.cell(&arms) * inside
        } else {
            0.0
        }
    }

    /// Draws φ: a component by its weight, then every variable's bin from the component and
    /// φ inside the bin from the nominal.
    pub(crate) fn draw<R: Rng + ?Sized>(&self, base: &Proposal, rng: &mut R) -> Assignment {
        let k = categorical(&self.alpha, rng);
        let mut phi = Assignment::new();
        let vars = base.space().variables();
        for ((var, n), p) in vars.iter().zip(base.nominals()).zip(&self.components[k]) {
            let arm = categorical(p, rng);
            phi.set(&var.name, n.draw_in_bin(var, arm, rng));
        }
        phi
    }
}

/// Draws from a scenario's proposal once a mixture is fitted: q = (1 − ε)·mixture + ε·p, with
/// p the nominal of the product proposal `base` (which keeps its nominal and ε).
pub(crate) fn draw<R: Rng + ?Sized>(
    mixture: &Mixture,
    base: &Proposal,
    rng: &mut R,
) -> (Assignment, Densities) {
    let u: f64 = rng.random();
    let phi = if u < base.epsilon() {
        base.draw_nominal(rng)
    } else {
        mixture.draw(base, rng)
    };
    let d = densities(mixture, base, &phi);
    (phi, d)
}

/// q(φ) and p(φ) under the mixture proposal.
pub(crate) fn densities(mixture: &Mixture, base: &Proposal, phi: &Assignment) -> Densities {
    let p = base.nominal(phi);
    let eps = base.epsilon();
    Densities {
        q: (1.0 - eps) * mixture.density(base, phi) + eps * p,
        p,
    }
}
