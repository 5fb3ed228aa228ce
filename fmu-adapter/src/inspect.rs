//! What `savme fmu info` and `savme fmu validate` report about an `.fmu`: its description
//! ([`Info`], like `fmpy info`) and the problems savme's checks find ([`problems`] on the
//! archive and model description, [`load_problems`] on the library — run by the CLI in a
//! child process, so that a library that crashes is a problem, not the end of `savme`).

use crate::description::{ModelDescription, VarInfo, VarType};
use crate::file::{FmuDescription, FmuFile};
use crate::instance::Instance;
use crate::FmuError;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;
use std::sync::Arc;

/// An FMU as `savme fmu info` shows it.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Serialize)]
pub struct Info {
    /// The `.fmu` path.
    pub fmu: String,
    /// The platforms it has binaries for.
    pub platforms: Vec<String>,
    /// Its model description.
    pub model: ModelDescription,
}

impl Info {
    /// Reads `path` (any FMI version or kind: nothing is checked but the archive and XML).
    pub fn read(path: &Path) -> Result<Info, FmuError> {
        let d = FmuDescription::inspect(path)?;
        Ok(Info {
            fmu: path.display().to_string(),
            platforms: d.platforms(),
            model: d.model,
        })
    }

    /// The human text: the model, its capabilities and its variables in a table.
    pub fn text(&self) -> String {
        let m = &self.model;
        let mut s = String::new();
        let kinds: Vec<&str> = [
            m.co_simulation.as_ref().map(|_| "co-simulation"),
            m.model_exchange.as_ref().map(|_| "model exchange"),
            m.scheduled_execution
                .as_ref()
                .map(|_| "scheduled execution"),
        ]
        .into_iter()
        .flatten()
        .collect();
        let none = || "-".to_string();
        let rows = [
            ("FMU", self.fmu.clone()),
            ("FMI version", m.fmi_version.clone()),
            ("Kinds", kinds.join(", ")),
            ("Model name", m.model_name.clone()),
            ("Description", m.description.clone().unwrap_or_else(none)),
            ("GUID", m.guid.clone()),
            ("Platforms", self.platforms.join(", ")),
            (
                "Generation tool",
                m.generation_tool.clone().unwrap_or_else(none),
            ),
            ("Variables", m.variables.len().to_string()),
        ];
        for (k, v) in rows {
            let _ = writeln!(s, "{k:<17}{v}");
        }
        let d = &m.default_experiment;
        let num = |x: Option<f64>| x.map_or_else(none, |x| x.to_string());
        let _ = writeln!(
            s,
            "{:<17}start {}, stop {}, step {}, tolerance {}",
            "Default run",
            num(d.start_time),
            num(d.stop_time),
            num(d.step_size),
            num(d.tolerance)
        );
        if let Some(cs) = &m.co_simulation {
            let flags = [
                (
                    "canHandleVariableCommunicationStepSize",
                    cs.can_handle_variable_communication_step_size,
                ),
                (
                    "canBeInstantiatedOnlyOncePerProcess",
                    cs.can_be_instantiated_only_once_per_process,
                ),
                ("canGetAndSetFMUstate", cs.can_get_and_set_fmu_state),
                ("canSerializeFMUstate", cs.can_serialize_fmu_state),
                ("canInterpolateInputs", cs.can_interpolate_inputs),
                ("needsExecutionTool", cs.needs_execution_tool),
                (
                    "providesDirectionalDerivative",
                    cs.provides_directional_derivative,
                ),
            ];
            let on: Vec<&str> = flags.iter().filter(|(_, b)| *b).map(|(n, _)| *n).collect();
            let _ = writeln!(
                s,
                "{:<17}model identifier {}; {}",
                "Co-simulation",
                cs.model_identifier,
                if on.is_empty() {
                    "no capability flags".to_string()
                } else {
                    on.join(", ")
                }
            );
        }
        let _ = writeln!(s);
        s.push_str(&variable_table(&m.variables, m.is_fmi3()));
        s
    }
}

/// The variables as an aligned table: name, causality, type (FMI 3.0's own numeric type
/// names: Float64, UInt32, …), start, min, max, unit, items.
fn variable_table(vars: &[VarInfo], fmi3: bool) -> String {
    let cell = |x: &Option<String>| x.clone().unwrap_or_default();
    let num = |x: Option<f64>| x.map(|x| x.to_string()).unwrap_or_default();
    let mut rows = vec![[
        "Name",
        "Causality",
        "Type",
        "Start",
        "Min",
        "Max",
        "Unit",
        "Items / description",
    ]
    .map(String::from)];
    for v in vars {
        let items = if let Some(of) = &v.alias_of {
            match &v.description {
                Some(d) => format!("alias of {of}: {d}"),
                None => format!("alias of {of}"),
            }
        } else if v.items.is_empty() {
            cell(&v.description)
        } else {
            v.items
                .iter()
                .map(|i| format!("{}={}", i.name, i.value))
                .collect::<Vec<_>>()
                .join(" ")
        };
        rows.push([
            v.name.clone(),
            serde_json::to_value(v.causality)
                .ok()
                .and_then(|c| c.as_str().map(String::from))
                .unwrap_or_default(),
            type_name(v, fmi3),
            cell(&v.start),
            num(v.min),
            num(v.max),
            cell(&v.unit),
            items,
        ]);
    }
    let widths: Vec<usize> = (0..8)
        .map(|c| rows.iter().map(|r| r[c].chars().count()).max().unwrap_or(0))
        .collect();
    let mut s = String::new();
    for r in &rows {
        let line: Vec<String> = r
            .iter()
            .zip(&widths)
            .map(|(x, w)| format!("{x:<w$}"))
            .collect();
        let _ = writeln!(s, "{}", line.join("  ").trim_end());
    }
    s
}

/// A variable's type as `fmu info` shows it: FMI 3.0's own names (Float64, UInt32, Binary,
/// Clock, …), with `[]` for an array.
pub fn type_name(v: &VarInfo, fmi3: bool) -> String {
    let name = if fmi3 && matches!(v.kind, VarType::Real | VarType::Integer | VarType::Other) {
        format!("{:?}", v.repr)
    } else {
        format!("{:?}", v.kind)
    };
    if v.array {
        format!("{name}[]")
    } else {
        name
    }
}

/// The problems savme's checks find in `path` without loading it: the archive, the model
/// description, FMI 2.0 co-simulation, a binary for this platform (one problem if any fails),
/// then every variable's declaration — `min` ≤ `max`, the start value of the right type and
/// inside the bounds or one of the enumeration's items, a start value for every parameter.
pub fn problems(path: &Path) -> Vec<String> {
    let d = match FmuDescription::read(path) {
        Ok(d) => d,
        // Each problem of the model description on its own (the message lists one per line).
        Err(crate::FmuError::BadModelDescription { fmu, message }) => {
            return message
                .lines()
                .map(|m| format!("{fmu}: modelDescription.xml: {m}"))
                .collect()
        }
        Err(e) => return vec![e.to_string()],
    };
    let mut out = Vec::new();
    for v in &d.model.variables {
        if let Some(p) = variable_problem(v) {
            out.push(format!(
                "modelDescription.xml, line {}: variable `{}`: {p}",
                v.line, v.name
            ));
        }
    }
    out
}

/// What is wrong with a variable's declaration, if anything (an array's start holds one value
/// per element, each checked).
fn variable_problem(v: &VarInfo) -> Option<String> {
    if v.alias_of.is_some() {
        return None; // checked as the variable it names
    }
    if v.array {
        let elements = v.start.as_deref().map(str::split_whitespace);
        return elements.into_iter().flatten().find_map(|x| {
            let one = VarInfo {
                array: false,
                start: Some(x.to_string()),
                ..v.clone()
            };
            variable_problem(&one).map(|p| format!("element {p}"))
        });
    }
    if let (Some(lo), Some(hi)) = (v.min, v.max) {
        if lo > hi {
            return Some(format!("min {lo} > max {hi}"));
        }
    }
    let Some(start) = &v.start else {
        let settable = v.causality == crate::VarCausality::Parameter;
        return settable.then(|| "a parameter without a start value".into());
    };
    let value: Option<f64> = match v.kind {
        VarType::Real => start.trim().parse::<f64>().ok(),
        // i128: a UInt64 start may exceed 2⁶³ − 1.
        VarType::Integer | VarType::Enumeration => {
            start.trim().parse::<i128>().ok().map(|i| i as f64)
        }
        VarType::Boolean => {
            return (!["true", "false", "1", "0"].contains(&start.trim()))
                .then(|| format!("start \"{start}\" is not a Boolean"));
        }
        VarType::String | VarType::Other => return None,
    };
    let Some(x) = value else {
        return Some(format!("start \"{start}\" is not a {:?}", v.kind));
    };
    if v.kind == VarType::Enumeration && !v.items.iter().any(|i| i.value as f64 == x) {
        return Some(format!("start {start} is none of its enumeration's items"));
    }
    let (lo, hi) = (
        v.min.unwrap_or(f64::NEG_INFINITY),
        v.max.unwrap_or(f64::INFINITY),
    );
    (x < lo || x > hi).then(|| format!("start {start} lies outside [min, max]"))
}

/// Loads `path`'s library in this process, checks its FMI functions, and instantiates it once
/// (with its GUID and resources) and frees it: the problems found (the FMU's log messages
/// included). The CLI runs this in a child process.
pub fn load_problems(path: &Path) -> Vec<String> {
    let file = match FmuFile::open(path) {
        Ok(f) => Arc::new(f),
        Err(e) => return vec![e.to_string()],
    };
    match Instance::new(file, "savme-validate") {
        Ok(_) => Vec::new(),
        Err(e) => vec![e.to_string()],
    }
}
