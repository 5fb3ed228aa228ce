//! Checks of a kernel configuration before the kernel is built or restored.

use super::{ConfigError, KernelConfig};
use crate::posterior::PosteriorError;
use crate::space::Space;

/// Validates a configuration; returns the cumulative normalised scenario weights.
pub(crate) fn validate_config(c: &KernelConfig) -> Result<Vec<f64>, ConfigError> {
    if c.scenarios.is_empty() {
        return Err(ConfigError::NoScenarios);
    }
    for (i, s) in c.scenarios.iter().enumerate() {
        if s.name.trim().is_empty() {
            return Err(ConfigError::EmptyScenarioName { index: i });
        }
        if c.scenarios[..i].iter().any(|t| t.name == s.name) {
            return Err(ConfigError::DuplicateScenario(s.name.to_string()));
        }
        if !(s.weight.is_finite() && s.weight > 0.0) {
            return Err(ConfigError::BadWeight {
                scenario: s.name.to_string(),
                weight: s.weight,
            });
        }
        // Spaces built by `Space::new` or deserialised are valid; re-check to name the scenario.
        Space::new(s.space.variables().to_vec()).map_err(|source| ConfigError::ScenarioSpace {
            scenario: s.name.to_string(),
            source,
        })?;
    }
    Space::new(c.fidelity.variables().to_vec()).map_err(ConfigError::FidelitySpace)?;
    c.fidelity
        .arms_of(&c.theta_hf)
        .map_err(ConfigError::ThetaHf)?;
    if !(c.budget > 0.0 && c.budget <= 1.0) {
        return Err(ConfigError::BadBudget(c.budget));
    }
    c.prior.validate().map_err(ConfigError::Prior)?;
    c.search.validate().map_err(ConfigError::Search)?;
    c.pairing.validate().map_err(ConfigError::Pairing)?;
    c.allocation.validate().map_err(ConfigError::Allocation)?;
    if let Some(fp) = &c.fidelity_prior {
        fp.posterior
            .check_fits(&c.fidelity)
            .map_err(ConfigError::Prior)?;
        if !(fp.strength.is_finite() && fp.strength > 0.0) {
            return Err(ConfigError::Prior(PosteriorError::BadStrength(fp.strength)));
        }
    }
    for (i, p) in c.scenario_priors.iter().enumerate() {
        let bad = |problem: String| ConfigError::ScenarioPrior {
            scenario: p.scenario.to_string(),
            problem,
        };
        let Some(s) = c.scenarios.iter().find(|s| s.name == p.scenario) else {
            return Err(bad("no scenario has this name".into()));
        };
        if c.scenario_priors[..i]
            .iter()
            .any(|q| q.scenario == p.scenario)
        {
            return Err(bad("given twice".into()));
        }
        p.posterior
            .check_fits(&s.space)
            .map_err(|e| bad(e.to_string()))?;
    }
    let total: f64 = c.scenarios.iter().map(|s| s.weight).sum();
    let mut acc = 0.0;
    let mut cumulative: Vec<f64> = c
        .scenarios
        .iter()
        .map(|s| {
            acc += s.weight / total;
            acc
        })
        .collect();
    if let Some(last) = cumulative.last_mut() {
        *last = 1.0;
    }
    Ok(cumulative)
}
