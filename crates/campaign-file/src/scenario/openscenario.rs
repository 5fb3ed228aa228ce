//! A scenario whose φ comes from an OpenSCENARIO `ParameterValueDistribution` file:
//!
//! ```toml
//! [[scenario]]
//! name = "cut_in"
//! role = "train"
//! openscenario = "cut_in_variation.xosc"  # relative to the campaign file
//! bind = { EgoSpeed = "ego_speed" }       # optional: simulator variables named otherwise
//! fixed = { scenario = 2 }                # as for any scenario
//! ```
//!
//! Every parameter the file varies is a φ variable bound to the simulator variable of its name,
//! or the one `bind` gives (continuous ones in 10 linear bins); its stochastic distribution is
//! the scenario's nominal for `[estimate]` (see `savme_openscenario` for the mapping). An error
//! in the file names the campaign file, the key's line and the key, then the distribution
//! file, its line and element.

use super::{fixed, ScenarioBindings, ScenarioSection};
use crate::{resolve, ConfigError, Named, Source};
use savme_kernel::estimation::Nominal;
use savme_kernel::Space;
use savme_openscenario::ParameterDistribution;
use std::collections::BTreeMap;
use std::path::Path;
use toml::Spanned;

/// The bins of a continuous parameter.
const BINS: u32 = 10;

/// Scenario `k`'s φ-space, bindings and nominal from its `openscenario` file.
pub(crate) fn scenario(
    src: &Source,
    k: usize,
    table: &Spanned<ScenarioSection>,
    file: &Spanned<String>,
    base: &Path,
) -> Result<(Space, ScenarioBindings, BTreeMap<String, Nominal>), ConfigError> {
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
    let fixed = fixed(src, k, s)?;
    let phi = (d.parameters.iter())
        .map(|p| {
            let named = match s.bind.get(&p.name) {
                Some(v) => Named {
                    name: v.get_ref().clone(),
                    line: src.line(v.span()),
                    key: format!("scenario[{k}].bind.{}", p.name),
                },
                None => Named {
                    name: p.name.clone(),
                    line,
                    key: key.clone(),
                },
            };
            (p.name.clone(), named)
        })
        .collect();
    let bindings = ScenarioBindings {
        name: s.name.get_ref().clone(),
        fixed,
        phi,
    };
    Ok((space, bindings, d.nominal()))
}
