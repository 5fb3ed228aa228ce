//! A kernel's complete state ([`Snapshot`]): saved as JSON, restored after checking that it
//! is consistent (posteriors fit their spaces, pending trials fit their phases, archives fit
//! the search model), so a restored kernel makes exactly the asks the original would have.

use super::validation::validate_config;
use super::{ConfigError, Kernel, KernelConfig, KernelStats, Pending, Phase};
use crate::allocation::{Allocation, Ledger};
use crate::evidence::FidelityEvidence;
use crate::posterior::{Estimator, Posterior};
use crate::search::{Archive, SearchModel};
use crate::space::Space;
use rand_pcg::Pcg64 as Rng64;
use serde::{Deserialize, Serialize};

/// The complete, serialisable state of a kernel ([`Kernel::snapshot`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Snapshot {
    pub(super) config: KernelConfig,
    pub(super) phase: Phase,
    pub(super) next_id: u64,
    pub(super) stats: KernelStats,
    pub(super) fidelity: Posterior,
    pub(super) scenarios: Vec<Posterior>,
    pub(super) pending: Vec<Pending>,
    pub(super) rng: Rng64,
    /// Per scenario, the archive of [`SearchModel::EliteMixture`] (empty for the paper's
    /// independent bins, and then left out of the JSON).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub(super) search: Vec<Archive>,
    /// Per scenario, what its told trials cost and found ([`Allocation::CostRate`]; empty for
    /// the paper's p(s), and then left out of the JSON).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub(super) ledgers: Vec<Ledger>,
    /// Per scenario, per fidelity arm, what the learning trials showed (kept with
    /// [`crate::Estimator::Evidence`] only; otherwise None and left out of the JSON).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) evidence: Option<FidelityEvidence>,
}

impl Kernel {
    /// Rebuilds a kernel from a snapshot, checking it for consistency first. The restored
    /// kernel makes exactly the asks the original would have made.
    pub fn restore(snapshot: Snapshot) -> Result<Kernel, ConfigError> {
        let cumulative = validate_config(&snapshot.config)?;
        let cfg = &snapshot.config;
        let state = |m: String| ConfigError::State(m);
        snapshot
            .fidelity
            .check_fits(&cfg.fidelity)
            .map_err(|e| state(format!("fidelity posterior: {e}")))?;
        if snapshot.scenarios.len() != cfg.scenarios.len() {
            return Err(state(format!(
                "{} scenario posteriors for {} scenarios",
                snapshot.scenarios.len(),
                cfg.scenarios.len()
            )));
        }
        for (p, s) in snapshot.scenarios.iter().zip(&cfg.scenarios) {
            p.check_fits(&s.space)
                .map_err(|e| state(format!("scenario `{}` posterior: {e}", s.name)))?;
        }
        check_archives(&snapshot)?;
        check_ledgers(&snapshot)?;
        let keeps = cfg.estimator == Estimator::Evidence;
        match &snapshot.evidence {
            None if !keeps => {}
            Some(e) if keeps && e.fits(cfg.scenarios.len(), &cfg.fidelity) => {}
            _ => {
                return Err(state(format!(
                    "the fidelity evidence does not fit the estimator `{}` (kept with `evidence` only), the scenarios or the fidelity space",
                    serde_json::to_string(&cfg.estimator).unwrap_or_default()
                )))
            }
        }
        let mut last = None;
        for p in &snapshot.pending {
            let t = &p.trial;
            let bad = |m: &str| state(format!("pending trial {}: {m}", t.id));
            if t.id >= snapshot.next_id || last.is_some_and(|l| t.id <= l) {
                return Err(bad("id out of order"));
            }
            last = Some(t.id);
            let sc = cfg
                .scenarios
                .get(t.scenario_index)
                .filter(|s| s.name == t.scenario)
                .ok_or_else(|| bad("unknown scenario"))?;
            let arms_ok = |space: &Space, arms: &[u16]| {
                arms.len() == space.len()
                    && space
                        .variables()
                        .iter()
                        .zip(arms)
                        .all(|(v, &a)| (a as usize) < v.arms())
            };
            let (phi_arms, theta_arms) = p.arms.split_at(sc.space.len().min(p.arms.len()));
            if !arms_ok(&sc.space, phi_arms) {
                return Err(bad("φ arms do not fit the scenario"));
            }
            let paired = t.theta_lf.is_some();
            let scouts = matches!(cfg.allocation, Allocation::CostRate(r) if r.scout);
            let may_skip = t.phase.learns() && (!cfg.pairing.is_always() || scouts);
            if (paired && !(t.phase.is_paired() && arms_ok(&cfg.fidelity, theta_arms)))
                || (!paired && (t.phase.is_paired() && !may_skip || !theta_arms.is_empty()))
            {
                return Err(bad("θ_LF does not fit its phase or the fidelity space"));
            }
        }
        Ok(Kernel {
            state: snapshot,
            cumulative,
        })
    }

    /// The snapshot as JSON.
    pub fn to_json(&self) -> String {
        // A snapshot holds only strings, numbers and maps with string keys: it always serialises.
        serde_json::to_string(&self.state).unwrap_or_default()
    }

    /// Restores from [`Kernel::to_json`] output; errors name what is wrong.
    pub fn from_json(json: &str) -> Result<Kernel, RestoreError> {
        let snapshot: Snapshot = serde_json::from_str(json).map_err(RestoreError::Parse)?;
        Kernel::restore(snapshot).map_err(RestoreError::Config)
    }
}

/// Why a JSON snapshot could not be restored.
#[derive(Debug, thiserror::Error)]
pub enum RestoreError {
    /// Not a snapshot (the message names line and column).
    #[error("snapshot is not valid JSON for a kernel state: {0}")]
    Parse(serde_json::Error),
    /// A snapshot whose contents are inconsistent.
    #[error(transparent)]
    Config(ConfigError),
}

/// Checks that a snapshot's ledgers fit its allocation and scenarios.
fn check_ledgers(snapshot: &Snapshot) -> Result<(), ConfigError> {
    let cfg = &snapshot.config;
    let expected = match cfg.allocation {
        Allocation::Weights => 0,
        Allocation::CostRate(_) => cfg.scenarios.len(),
    };
    if snapshot.ledgers.len() != expected {
        return Err(ConfigError::State(format!(
            "{} scenario ledgers for {expected} expected",
            snapshot.ledgers.len()
        )));
    }
    for (l, s) in snapshot.ledgers.iter().zip(&cfg.scenarios) {
        let recent = [l.recent_cost, l.recent_failures];
        if !(l.cost.is_finite() && l.cost >= 0.0)
            || l.failures > l.trials
            || recent.iter().any(|x| !(x.is_finite() && *x >= 0.0))
        {
            return Err(ConfigError::State(format!(
                "scenario `{}`: its ledger ({} trials, {} failures, cost {}) is impossible",
                s.name, l.trials, l.failures, l.cost
            )));
        }
    }
    Ok(())
}

/// Checks that a snapshot's search archives fit its search model and scenarios.
fn check_archives(snapshot: &Snapshot) -> Result<(), ConfigError> {
    let cfg = &snapshot.config;
    let expected = match cfg.search {
        SearchModel::IndependentBins => 0,
        SearchModel::EliteMixture(_) => cfg.scenarios.len(),
    };
    if snapshot.search.len() != expected {
        return Err(ConfigError::State(format!(
            "{} search archives for {expected} expected",
            snapshot.search.len()
        )));
    }
    for (a, s) in snapshot.search.iter().zip(&cfg.scenarios) {
        a.check_fits(&s.space)
            .map_err(|e| ConfigError::State(format!("scenario `{}`: {e}", s.name)))?;
    }
    Ok(())
}
