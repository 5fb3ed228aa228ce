//! `[[scenario]]`: each scenario's φ-space, role, weight and bindings, with where it is in the
//! file.

mod openscenario;

use crate::variable::{binding, toml_value, variables, Named, VarSection};
use crate::{ConfigError, Source};
use savme_kernel::estimation::Nominal;
use savme_kernel::{Space, Value};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// A `[[scenario]]` table as serde reads it.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ScenarioSection {
    pub name: Spanned<String>,
    /// Default 1.
    pub weight: Option<Spanned<f64>>,
    pub role: Spanned<String>,
    #[serde(default)]
    pub fixed: BTreeMap<String, Spanned<toml::Value>>,
    #[serde(rename = "phi", default)]
    pub phi: Vec<Spanned<VarSection>>,
    /// A ParameterValueDistribution file whose parameters are φ (instead of `phi`).
    pub openscenario: Option<Spanned<String>>,
    /// The simulator variable of a parameter of the `openscenario` file, if named otherwise.
    #[serde(default)]
    pub bind: BTreeMap<String, Spanned<String>>,
}

/// Every scenario of the file.
#[derive(Debug, Clone, Default)]
pub struct Scenarios {
    /// Each scenario's φ-space, by name.
    pub spaces: BTreeMap<String, Space>,
    /// The meta-training scenarios (role `"train"`), in file order.
    pub train: Vec<String>,
    /// The meta-testing scenarios (role `"test"`), in file order.
    pub test: Vec<String>,
    /// Scenario weights other than 1.
    pub weights: BTreeMap<String, f64>,
    /// Where each scenario is in the file, in file order: to name the line of an error found
    /// later in its role or weight (a protocol without meta-testing scenarios, a weight ≤ 0).
    pub lines: Vec<ScenarioLines>,
    /// What each scenario sets in a run, in file order.
    pub bindings: Vec<ScenarioBindings>,
    /// The nominal distributions the scenarios' OpenSCENARIO files declare (`openscenario`),
    /// by scenario then variable; `[estimate.nominal]` entries override them.
    pub nominal: BTreeMap<String, BTreeMap<String, Nominal>>,
    /// The OpenSCENARIO file of each scenario that has one (`openscenario`, resolved against
    /// the campaign file's directory), by scenario.
    pub openscenario: BTreeMap<String, PathBuf>,
}

/// Where one `[[scenario]]` table is in its file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ScenarioLines {
    /// The scenario's name.
    pub name: String,
    /// Its position among the file's scenarios: its keys are `scenario[index].…`.
    pub index: usize,
    /// The 1-based line of its `[[scenario]]` header.
    pub table: usize,
    /// The line of its `role`.
    pub role: usize,
    /// The line of its `weight`, when given.
    pub weight: Option<usize>,
}

/// What one scenario sets in its runs.
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioBindings {
    /// The scenario's name.
    pub name: String,
    /// `fixed = { … }`: a simulator variable and the value it gets in every run.
    pub fixed: Vec<(Named, Value)>,
    /// Each φ variable and the simulator variable it binds to.
    pub phi: Vec<(String, Named)>,
}

/// `[[scenario]]`: every scenario, at least one.
pub(crate) fn read(
    src: &Source,
    list: &Spanned<Vec<Spanned<ScenarioSection>>>,
    base: &Path,
) -> Result<Scenarios, ConfigError> {
    if list.get_ref().is_empty() {
        return Err(src.err(
            Some(src.line(list.span())),
            Some("scenario"),
            "no scenarios: give [[scenario]] tables",
        ));
    }
    let mut parts = Scenarios::default();
    for (k, table) in list.get_ref().iter().enumerate() {
        let key = format!("scenario[{k}]");
        let s = table.get_ref();
        let name = s.name.get_ref();
        if name.trim().is_empty() || parts.spaces.contains_key(name) {
            let message = if name.trim().is_empty() {
                "a scenario has an empty name".to_string()
            } else {
                format!("scenario `{name}` is defined twice")
            };
            return Err(src.err(
                Some(src.line(s.name.span())),
                Some(&format!("{key}.name")),
                message,
            ));
        }
        match s.role.get_ref().as_str() {
            "train" => parts.train.push(name.clone()),
            "test" => parts.test.push(name.clone()),
            other => {
                return Err(src.err(
                    Some(src.line(s.role.span())),
                    Some(&format!("{key}.role")),
                    format!("`{other}`: expected \"train\" or \"test\""),
                ))
            }
        }
        let weight = s.weight.as_ref().map_or(1.0, |w| *w.get_ref());
        if weight != 1.0 {
            parts.weights.insert(name.clone(), weight);
        }
        parts.lines.push(ScenarioLines {
            name: name.clone(),
            index: k,
            table: src.line(table.span()),
            role: src.line(s.role.span()),
            weight: s.weight.as_ref().map(|w| src.line(w.span())),
        });
        let (space, bindings) = match &s.openscenario {
            Some(file) => {
                let (space, bindings, nominal) = openscenario::scenario(src, k, table, file, base)?;
                parts.nominal.insert(name.clone(), nominal);
                (parts.openscenario).insert(name.clone(), crate::resolve(base, file.get_ref()));
                (space, bindings)
            }
            None => {
                if let Some((name, v)) = s.bind.iter().next() {
                    return Err(src.err(
                        Some(src.line(v.span())),
                        Some(&format!("{key}.bind.{name}")),
                        "`bind` renames the parameters of an `openscenario` file: give the file, \
                         or bind [[scenario.phi]] variables with their `fmu` key",
                    ));
                }
                scenario(src, k, table)?
            }
        };
        parts.spaces.insert(name.clone(), space);
        parts.bindings.push(bindings);
    }
    Ok(parts)
}

/// Scenario `k`'s φ-space and bindings (its fixed parameters and φ variables).
fn scenario(
    src: &Source,
    k: usize,
    table: &Spanned<ScenarioSection>,
) -> Result<(Space, ScenarioBindings), ConfigError> {
    let key = format!("scenario[{k}]");
    let s = table.get_ref();
    let vars = variables(src, &format!("{key}.phi"), &s.phi)?;
    let space = Space::new(vars).map_err(|e| {
        src.err(
            Some(src.line(table.span())),
            Some(&format!("{key}.phi")),
            format!("{e}: give at least one [[scenario.phi]] table"),
        )
    })?;
    let fixed = fixed(src, k, s)?;
    let phi = (s.phi.iter().enumerate())
        .map(|(j, sv)| {
            let variable = sv.get_ref().name.get_ref().clone();
            (
                variable,
                binding(src, sv.get_ref(), &format!("{key}.phi[{j}]")),
            )
        })
        .collect();
    let bindings = ScenarioBindings {
        name: s.name.get_ref().clone(),
        fixed,
        phi,
    };
    Ok((space, bindings))
}

/// Scenario `k`'s fixed parameters: each simulator variable with its value.
pub(crate) fn fixed(
    src: &Source,
    k: usize,
    s: &ScenarioSection,
) -> Result<Vec<(Named, Value)>, ConfigError> {
    let mut fixed = Vec::new();
    for (name, v) in &s.fixed {
        let fkey = format!("scenario[{k}].fixed.{name}");
        let line = src.line(v.span());
        let value = toml_value(v.get_ref()).ok_or_else(|| {
            src.err(
                Some(line),
                Some(&fkey),
                "expected a number, boolean or string",
            )
        })?;
        let named = Named {
            name: name.clone(),
            line,
            key: fkey,
        };
        fixed.push((named, value));
    }
    Ok(fixed)
}
