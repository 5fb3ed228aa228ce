//! A scenario whose φ comes from an OpenSCENARIO `ParameterValueDistribution` file:
//!
//! ```toml
//! [[scenario]]
//! name = "cut_in"
//! role = "train"
//! openscenario = "cut_in_variation.xosc"  # relative to the campaign file
//! bind = { EgoSpeed = "ego_speed" }       # optional: FMU variables named otherwise
//! fixed = { scenario = 2 }                # as for any scenario
//! ```
//!
//! Every parameter the file varies is a φ variable bound to the FMU variable of its name, or
//! the one `bind` gives (continuous ones in 10 linear bins); its stochastic distribution is the scenario's nominal
//! for `[estimate]` (see `savme_openscenario` for the mapping). An error in the file names the
//! campaign file, the key's line and the key, then the distribution file, its line and element.

use super::bindings::{Origins, Use};
use super::{raw, resolve, ConfigError, Source};
use crate::{Binding, ScenarioSpec};
use savme_kernel::estimation::Nominal;
use savme_kernel::Space;
use savme_openscenario::ParameterDistribution;
use std::collections::BTreeMap;
use std::path::Path;
use toml::Spanned;

/// The bins of a continuous parameter.
const BINS: u32 = 10;

/// Scenario `k`'s φ-space, run specification and nominal from its `openscenario` file.
pub(super) fn scenario(
    src: &Source,
    k: usize,
    table: &Spanned<raw::ScenarioSection>,
    file: &Spanned<String>,
    base: &Path,
    origins: &mut Origins,
) -> Result<(Space, ScenarioSpec, BTreeMap<String, Nominal>), ConfigError> {
    let key = format!("scenario[{k}].openscenario");
    let line = src.line(file.span());
    let s = table.get_ref();
    if let Some(first) = s.phi.first() {
        return Err(src.err(
            Some(src.line(first.span())),
            Some(&format!("scenario[{k}].phi")),
            "φ comes from the `openscenario` file: give either it or [[scenario.phi]] tables",
        ));
    }
    let path = resolve(base, file.get_ref());
    let d = ParameterDistribution::read(&path)
        .map_err(|e| src.err(Some(line), Some(&key), e.to_string()))?;
    let space = d
        .space(BINS)
        .map_err(|e| src.err(Some(line), Some(&key), e.to_string()))?;
    if let Some((name, v)) = s.bind.iter().find(|(n, _)| d.parameter(n).is_none()) {
        let names: Vec<&str> = d.parameters.iter().map(|p| p.name.as_str()).collect();
        return Err(src.err(
            Some(src.line(v.span())),
            Some(&format!("scenario[{k}].bind.{name}")),
            format!(
                "`{name}` is no parameter of {} (its parameters: {})",
                path.display(),
                names.join(", ")
            ),
        ));
    }
    let fixed = super::fixed(src, k, s, origins)?;
    let mut phi = Vec::new();
    for p in &d.parameters {
        let (fmu_variable, line, key) = match s.bind.get(&p.name) {
            Some(v) => (
                v.get_ref().clone(),
                src.line(v.span()),
                format!("scenario[{k}].bind.{}", p.name),
            ),
            None => (p.name.clone(), line, key.clone()),
        };
        origins.set(src, &fmu_variable, line, &key, Use::Scenario(k))?;
        phi.push(Binding {
            variable: p.name.clone(),
            fmu_variable,
            labels: None,
        });
    }
    let spec = ScenarioSpec {
        name: s.name.get_ref().clone(),
        phi,
        fixed,
    };
    Ok((space, spec, d.nominal()))
}
