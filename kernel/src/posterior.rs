//! Beta–Bernoulli beliefs over the arms of a space: Thompson draws, MAP, updates, transfer.

use crate::sampler::BetaSampler;
use crate::space::{Space, SpaceError};
use rand::Rng;
use serde::{Deserialize, Serialize};

/// The belief `Beta(alpha, beta)` that one arm yields a success.
///
/// `alpha = n_prior,S + n_S` and `beta = n_prior,L + n_L` (the paper's notation).
///
/// ```
/// use savme_kernel::Arm;
/// let arm = Arm { alpha: 41.0, beta: 11.0 }; // 40 successes of 50 on a uniform prior
/// assert_eq!(arm.mode(), 0.8);
/// assert!((arm.mean() - 41.0 / 52.0).abs() < 1e-12);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Arm {
    /// Prior plus observed successes.
    pub alpha: f64,
    /// Prior plus observed losses.
    pub beta: f64,
}

impl Arm {
    /// The mode of `Beta(alpha, beta)`, the paper's MAP score `(α−1)/(α+β−2)`, extended to where
    /// that formula is undefined:
    /// - `α ≥ 1, β ≥ 1, α+β > 2`: `(α−1)/(α+β−2)` (so `Beta(1, β>1)` → 0, `Beta(α>1, 1)` → 1);
    /// - `Beta(1, 1)` (no evidence on a uniform prior): every point is a mode; 0.5 is used;
    /// - `α < 1 ≤ β` → 0; `β < 1 ≤ α` → 1; both below 1 (two modes, at 0 and 1) → the mean.
    pub fn mode(&self) -> f64 {
        let (a, b) = (self.alpha, self.beta);
        if a >= 1.0 && b >= 1.0 {
            if a + b > 2.0 {
                (a - 1.0) / (a + b - 2.0)
            } else {
                0.5
            }
        } else if a < 1.0 && b >= 1.0 {
            0.0
        } else if b < 1.0 && a >= 1.0 {
            1.0
        } else {
            self.mean()
        }
    }

    /// The posterior mean `α / (α + β)`.
    pub fn mean(&self) -> f64 {
        self.alpha / (self.alpha + self.beta)
    }

    fn valid(&self) -> bool {
        self.alpha.is_finite() && self.beta.is_finite() && self.alpha > 0.0 && self.beta > 0.0
    }
}

/// Prior pseudo-counts `(n_prior,S, n_prior,L)` given to every arm; uniform is `(1, 1)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PriorCounts {
    /// Pseudo-successes (added to α).
    pub successes: f64,
    /// Pseudo-losses (added to β).
    pub losses: f64,
}

impl PriorCounts {
    /// The uniform prior `Beta(1, 1)`.
    pub const UNIFORM: PriorCounts = PriorCounts {
        successes: 1.0,
        losses: 1.0,
    };

    pub(crate) fn validate(&self) -> Result<(), PosteriorError> {
        let ok = |x: f64| x.is_finite() && x > 0.0;
        if ok(self.successes) && ok(self.losses) {
            Ok(())
        } else {
            Err(PosteriorError::BadPrior {
                successes: self.successes,
                losses: self.losses,
            })
        }
    }
}

impl Default for PriorCounts {
    fn default() -> Self {
        Self::UNIFORM
    }
}

/// How the greedy (evaluation) setting is read off a posterior.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Estimator {
    /// The paper's rule: the arm with the highest mode [`Arm::mode`]. It trusts thin evidence:
    /// one success out of one (mode 1.0) beats forty out of fifty (mode 0.8).
    #[default]
    Map,
    /// The arm with the highest posterior mean `α/(α+β)`: forty out of fifty (0.79) beats one
    /// out of one (0.67). Steadier when some arms were tried only a few times.
    Mean,
    /// θ_LF* from evidence: the arm with the highest lower 10 % quantile of its Beta belief,
    /// a false alarm (LF fails, HF passes) charged as `1 / C_budget` losses
    /// ([`crate::evidence`]); a kernel with it keeps per-arm tallies of its learning trials.
    /// Forty out of fifty (0.71) beats one out of one (0.32).
    Evidence,
}

/// Why a posterior cannot be built, updated or transferred.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PosteriorError {
    /// Prior counts must be finite and positive.
    #[error("prior counts must be finite and > 0, got successes = {successes}, losses = {losses}")]
    BadPrior {
        /// Given pseudo-successes.
        successes: f64,
        /// Given pseudo-losses.
        losses: f64,
    },
    /// The prior strength must be finite and positive.
    #[error("prior strength must be finite and > 0 (≥ 0 per variable), got {0}")]
    BadStrength(f64),
    /// A posterior does not fit the space it is used with.
    #[error("posterior does not fit the space: {0}")]
    Shape(String),
    /// An arm's counts are not finite and positive.
    #[error("variable `{variable}` arm {arm}: Beta({alpha}, {beta}) needs finite counts > 0")]
    BadArm {
        /// The variable.
        variable: String,
        /// The arm index.
        arm: usize,
        /// Its α.
        alpha: f64,
        /// Its β.
        beta: f64,
    },
    /// A space error, e.g. an assignment outside the space.
    #[error(transparent)]
    Space(#[from] SpaceError),
}

/// Independent Beta beliefs for every arm of every variable of one space.
///
/// ```
/// use savme_kernel::{Posterior, PriorCounts, Space, Variable, Estimator};
/// let space = Space::new(vec![Variable::discrete("rate", [2, 10])])?;
/// let mut p = Posterior::new(&space, PriorCounts::UNIFORM)?;
/// p.update(&[0], true);
/// assert_eq!(p.best_arms(Estimator::Map), vec![0]);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(from = "PosteriorData", into = "PosteriorData")]
pub struct Posterior {
    data: PosteriorData,
    /// Samplers derived from `data.arms`, kept in step on every update.
    samplers: Vec<Vec<BetaSampler>>,
}

/// What a posterior is; everything else is derived from it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct PosteriorData {
    /// The base prior of every arm (before any transferred evidence).
    prior: PriorCounts,
    /// Variable names, in space order (to check the fit with a space).
    names: Vec<String>,
    /// `arms[variable][arm]`.
    arms: Vec<Vec<Arm>>,
}

impl From<PosteriorData> for Posterior {
    fn from(data: PosteriorData) -> Self {
        let samplers = data
            .arms
            .iter()
            .map(|v| {
                v.iter()
                    .map(|a| BetaSampler::new(a.alpha, a.beta))
                    .collect()
            })
            .collect();
        Posterior { data, samplers }
    }
}

impl From<Posterior> for PosteriorData {
    fn from(p: Posterior) -> Self {
        p.data
    }
}

impl PartialEq for Posterior {
    fn eq(&self, other: &Self) -> bool {
        self.data == other.data
    }
}

impl Posterior {
    /// Every arm of `space` at the base prior.
    pub fn new(space: &Space, prior: PriorCounts) -> Result<Self, PosteriorError> {
        prior.validate()?;
        let arm = Arm {
            alpha: prior.successes,
            beta: prior.losses,
        };
        Ok(PosteriorData {
            prior,
            names: space
                .variables()
                .iter()
                .map(|v| v.name.to_string())
                .collect(),
            arms: space
                .variables()
                .iter()
                .map(|v| vec![arm; v.arms()])
                .collect(),
        }
        .into())
    }

    /// The base prior.
    pub fn prior(&self) -> PriorCounts {
        self.data.prior
    }

    /// `arms()[variable][arm]`: the Beta belief of every arm.
    pub fn arms(&self) -> &[Vec<Arm>] {
        &self.data.arms
    }

    /// The variables' names, in the order of [`Posterior::arms`].
    pub fn names(&self) -> &[String] {
        &self.data.names
    }

    /// The beliefs of the variable called `name`.
    pub fn variable(&self, name: &str) -> Option<&[Arm]> {
        let i = self.data.names.iter().position(|n| n == name)?;
        Some(&self.data.arms[i])
    }

    /// Checks that this posterior fits `space` (same names and arm counts) and that every arm
    /// is a proper Beta distribution. Used when a posterior is read from a file.
    pub fn check_fits(&self, space: &Space) -> Result<(), PosteriorError> {
        let PosteriorData { prior, names, arms } = &self.data;
        prior.validate()?;
        let vars = space.variables();
        if vars.len() != arms.len() || names.len() != arms.len() {
            return Err(PosteriorError::Shape(format!(
                "{} variables in the posterior, {} in the space",
                arms.len(),
                vars.len()
            )));
        }
        for ((v, name), arms) in vars.iter().zip(names).zip(arms) {
            if *v.name != **name || v.arms() != arms.len() {
                return Err(PosteriorError::Shape(format!(
                    "posterior variable `{name}` with {} arms where the space has `{}` with {} arms",
                    arms.len(),
                    v.name,
                    v.arms()
                )));
            }
            if let Some((k, a)) = arms.iter().enumerate().find(|(_, a)| !a.valid()) {
                return Err(PosteriorError::BadArm {
                    variable: name.clone(),
                    arm: k,
                    alpha: a.alpha,
                    beta: a.beta,
                });
            }
        }
        Ok(())
    }

    /// A posterior over `space` whose arm `k` of variable `v` is `base + extra(v, k)`, `extra`
    /// giving (successes, losses) added to the base prior (the φ transfer's prior:
    /// [`crate::phi_transfer`]). Each added count must be finite and ≥ 0.
    pub(crate) fn with_extra(
        space: &Space,
        base: PriorCounts,
        extra: impl Fn(usize, usize) -> (f64, f64),
    ) -> Result<Self, PosteriorError> {
        let mut p = Posterior::new(space, base)?;
        for (v, arms) in p.data.arms.iter_mut().enumerate() {
            for (k, a) in arms.iter_mut().enumerate() {
                let (s, l) = extra(v, k);
                a.alpha += s;
                a.beta += l;
                if !a.valid() {
                    return Err(PosteriorError::BadArm {
                        variable: p.data.names[v].clone(),
                        arm: k,
                        alpha: a.alpha,
                        beta: a.beta,
                    });
                }
            }
        }
        Ok(p.data.into())
    }

    /// A Thompson draw: for every variable, one sample of every arm's Beta; the argmax arm is
    /// appended to `out` (one per variable, in order). Variables with a single arm take it
    /// without drawing.
    pub fn thompson<R: Rng + ?Sized>(&self, rng: &mut R, out: &mut Vec<u16>) {
        for arms in &self.samplers {
            if arms.len() == 1 {
                out.push(0);
                continue;
            }
            let mut best = 0usize;
            let mut best_x = f64::NEG_INFINITY;
            for (k, a) in arms.iter().enumerate() {
                let x = a.sample(rng);
                if x > best_x {
                    best_x = x;
                    best = k;
                }
            }
            out.push(best as u16);
        }
    }

    /// The greedy arm of every variable under `estimator`. Ties (equal scores) go to the arm
    /// with the higher posterior mean, then to the lower arm index — so an untried variable
    /// (all arms at the base prior) returns arm 0.
    ///
    /// Without tallies, [`Estimator::Evidence`] charges no false alarm (the kernel passes its
    /// tallies: [`Posterior::best_arms_by`]).
    pub fn best_arms(&self, estimator: Estimator) -> Vec<u16> {
        let none = crate::evidence::ArmTally::default();
        self.best_arms_by(|_, _, a| match estimator {
            Estimator::Map => a.mode(),
            Estimator::Mean => a.mean(),
            Estimator::Evidence => crate::evidence::evidence_score(a, &none, 1.0),
        })
    }

    /// The arm of every variable with the highest `score(variable, arm, belief)`; ties as in
    /// [`Posterior::best_arms`].
    pub fn best_arms_by(&self, score: impl Fn(usize, usize, &Arm) -> f64) -> Vec<u16> {
        self.data
            .arms
            .iter()
            .enumerate()
            .map(|(v, arms)| {
                let mut best = 0usize;
                let mut sb = score(v, 0, &arms[0]);
                for (k, a) in arms.iter().enumerate().skip(1) {
                    let b = &arms[best];
                    let sa = score(v, k, a);
                    if sa > sb || (sa == sb && a.mean() > b.mean()) {
                        best = k;
                        sb = sa;
                    }
                }
                best as u16
            })
            .collect()
    }

    /// Credits one success or loss to the given arm of every variable.
    ///
    /// # Panics
    /// If `arms` does not hold one valid arm per variable.
    pub fn update(&mut self, arms: &[u16], success: bool) {
        assert_eq!(arms.len(), self.data.arms.len(), "one arm per variable");
        for ((var, samplers), &k) in self.data.arms.iter_mut().zip(&mut self.samplers).zip(arms) {
            let a = &mut var[k as usize];
            if success {
                a.alpha += 1.0;
            } else {
                a.beta += 1.0;
            }
            samplers[k as usize] = BetaSampler::new(a.alpha, a.beta);
        }
    }

    /// A prior for a new run built from this posterior (meta-testing): every arm gets
    /// `base + strength · evidence`, where `evidence = (α, β) − self.prior` is what this
    /// posterior learned (including evidence it was itself given), and `base` is the new run's
    /// prior counts. `strength = 1` passes the posterior on unchanged when `base` equals this
    /// posterior's prior (the paper's rule); `< 1` weakens it (a power prior), `> 1` sharpens it.
    ///
    /// ```
    /// use savme_kernel::{Posterior, PriorCounts, Space, Variable};
    /// let space = Space::new(vec![Variable::boolean("disable_shadows")])?;
    /// let mut learned = Posterior::new(&space, PriorCounts::UNIFORM)?;
    /// for _ in 0..4 { learned.update(&[1], true); }
    /// let half = learned.as_prior(PriorCounts::UNIFORM, 0.5)?;
    /// assert_eq!(half.arms()[0][1].alpha, 1.0 + 0.5 * 4.0);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn as_prior(&self, base: PriorCounts, strength: f64) -> Result<Posterior, PosteriorError> {
        if !(strength.is_finite() && strength > 0.0) {
            return Err(PosteriorError::BadStrength(strength));
        }
        self.as_prior_per_variable(base, &vec![strength; self.data.arms.len()])
    }

    /// [`Posterior::as_prior`] with a strength per variable, in space order; strength 0 gives
    /// that variable the base prior alone (each strength finite and ≥ 0).
    ///
    /// ```
    /// use savme_kernel::{Posterior, PriorCounts, Space, Variable};
    /// let space = Space::new(vec![Variable::boolean("a"), Variable::boolean("b")])?;
    /// let mut learned = Posterior::new(&space, PriorCounts::UNIFORM)?;
    /// for _ in 0..4 { learned.update(&[1, 1], true); }
    /// let p = learned.as_prior_per_variable(PriorCounts::UNIFORM, &[0.0, 0.5])?;
    /// assert_eq!((p.arms()[0][1].alpha, p.arms()[1][1].alpha), (1.0, 3.0));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn as_prior_per_variable(
        &self,
        base: PriorCounts,
        strengths: &[f64],
    ) -> Result<Posterior, PosteriorError> {
        base.validate()?;
        if strengths.len() != self.data.arms.len() {
            return Err(PosteriorError::Shape(format!(
                "{} strengths for {} variables",
                strengths.len(),
                self.data.arms.len()
            )));
        }
        if let Some(&bad) = strengths.iter().find(|s| !(s.is_finite() && **s >= 0.0)) {
            return Err(PosteriorError::BadStrength(bad));
        }
        let own = self.data.prior;
        let arms = self
            .data
            .arms
            .iter()
            .zip(strengths)
            .map(|(var, &strength)| {
                var.iter()
                    .map(|a| Arm {
                        alpha: base.successes + strength * (a.alpha - own.successes).max(0.0),
                        beta: base.losses + strength * (a.beta - own.losses).max(0.0),
                    })
                    .collect()
            })
            .collect();
        Ok(PosteriorData {
            prior: base,
            names: self.data.names.clone(),
            arms,
        }
        .into())
    }
}
