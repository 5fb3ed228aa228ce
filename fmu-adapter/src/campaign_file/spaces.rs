//! What each savme variable is bound to: the fidelity settings' FMU variables and each
//! scenario's φ and fixed parameters, every FMU variable remembered with where it was named.

use super::*;

/// The fidelity settings bound to FMU variables (a setting that drives the step size or the
/// tolerance is bound to none), each remembered as set in every run.
pub(super) fn fidelity_bindings(
    src: &Source,
    fidelity: &Fidelity,
    origins: &mut Origins,
) -> Result<Vec<Binding>, ConfigError> {
    let mut bindings = Vec::new();
    for s in &fidelity.settings {
        let Bound::To(named) = &s.bound else {
            continue;
        };
        origins.set(src, &named.name, named.line, &named.key, Use::Fidelity)?;
        bindings.push(Binding {
            variable: s.variable.clone(),
            fmu_variable: named.name.clone(),
            labels: crate::simulator::labels_of(&fidelity.space, &s.variable),
        });
    }
    Ok(bindings)
}

/// Each scenario's run specification: its fixed parameters and φ bindings, each remembered as
/// set in that scenario's runs.
pub(super) fn scenario_specs(
    src: &Source,
    common: &CampaignFile,
    origins: &mut Origins,
) -> Result<Vec<ScenarioSpec>, ConfigError> {
    let mut specs = Vec::new();
    for (k, s) in common.scenarios.bindings.iter().enumerate() {
        let used = Use::Scenario(k);
        let mut fixed = Vec::new();
        for (named, value) in &s.fixed {
            origins.set(src, &named.name, named.line, &named.key, used)?;
            fixed.push(Fixed {
                fmu_variable: named.name.clone(),
                value: value.clone(),
            });
        }
        let mut phi = Vec::new();
        for (variable, named) in &s.phi {
            origins.set(src, &named.name, named.line, &named.key, used)?;
            phi.push(Binding {
                variable: variable.clone(),
                fmu_variable: named.name.clone(),
                labels: None,
            });
        }
        specs.push(ScenarioSpec {
            name: s.name.clone(),
            phi,
            fixed,
        });
    }
    Ok(specs)
}
