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
/// then — all of them, not the first — every problem of the model description (a bad element,
/// a `ModelStructure` output naming no variable, a name declared twice, each with its line and
/// column) and of every variable's declaration: `min` ≤ `max`, the start value of the right
/// type and inside the bounds or one of the enumeration's items, a start value for every
/// parameter, a parameter's variability `fixed` or `tunable` (FMI 2.0 and 3.0), a value
/// reference of its own (FMI 3.0; an alias shares its variable's), as FMPy's validation has
/// them.
pub fn problems(path: &Path) -> Vec<String> {
    match FmuDescription::read(path) {
        Ok(d) => declaration_problems(&d.model),
        // Each problem of the model description on its own (the message lists one per line),
        // then those of the declarations that could be read.
        Err(FmuError::BadModelDescription { fmu, message }) => {
            let parsed = crate::file::model_xml(path)
                .ok()
                .and_then(|xml| ModelDescription::parse_all(&xml).ok());
            let mut out: Vec<String> = match &parsed {
                Some((_, problems)) if !problems.is_empty() => problems.clone(),
                _ => message.lines().map(String::from).collect(),
            };
            out = out
                .into_iter()
                .map(|m| format!("{fmu}: modelDescription.xml: {m}"))
                .collect();
            if let Some((model, _)) = parsed {
                out.extend(declaration_problems(&model));
            }
            out
        }
        // An FMU savme cannot run (no binary for this platform, model exchange only, …): that,
        // then the problems of its declarations, when its description is FMI 2.0 or 3.0.
        Err(e) => {
            let mut out = vec![e.to_string()];
            if let Ok(d) = FmuDescription::inspect(path) {
                if d.model.fmi_version == "2.0" || d.model.is_fmi3() {
                    out.extend(declaration_problems(&d.model));
                }
            }
            out
        }
    }
}

/// Every problem of the variables' declarations, in file order, each with its line.
fn declaration_problems(model: &ModelDescription) -> Vec<String> {
    let mut out = Vec::new();
    // FMI 3.0: a value reference names one variable (its aliases share it).
    let mut references: std::collections::HashMap<u32, &VarInfo> = Default::default();
    for v in &model.variables {
        // Its element's line and column (a variable built, not read, has neither).
        let at = |p: String| {
            format!(
                "modelDescription.xml, line {}, column {}: variable `{}`: {p}",
                v.line, v.column, v.name
            )
        };
        if let Some(p) = variable_problem(v) {
            out.push(at(p));
        }
        if v.alias_of.is_none() && is_parameter(v) && v.variability == "continuous" {
            out.push(at(format!(
                "a {} cannot have variability=\"continuous\" (only \"fixed\" or \"tunable\")",
                causality_name(v)
            )));
        }
        if model.is_fmi3() && v.alias_of.is_none() {
            if let Some(first) = references.insert(v.vr, v) {
                out.push(at(format!(
                    "value reference {} is that of variable `{}` (line {}) too",
                    v.vr, first.name, first.line
                )));
                references.insert(v.vr, first);
            }
        }
    }
    out
}

/// A parameter of any kind (its variability must be `fixed` or `tunable`).
fn is_parameter(v: &VarInfo) -> bool {
    use crate::VarCausality::*;
    matches!(
        v.causality,
        Parameter | CalculatedParameter | StructuralParameter
    )
}

/// A causality as the model description writes it (`structuralParameter`, …).
fn causality_name(v: &VarInfo) -> String {
    serde_json::to_value(v.causality)
        .ok()
        .and_then(|c| c.as_str().map(String::from))
        .unwrap_or_default()
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

/// The command that loads and instantiates one FMU in a child process — `savme fmu
/// validate-library`, the FMU's path appended — set once by the program that has one.
static LOAD_PROBE: std::sync::OnceLock<Vec<String>> = std::sync::OnceLock::new();

/// Sets the command [`probe_load`] runs (the first call wins): e.g. `["/usr/bin/savme", "fmu",
/// "validate-library"]`; the command runs [`load_problems`] on the path appended to it.
pub fn set_load_probe(command: Vec<String>) {
    let _ = LOAD_PROBE.set(command);
}

/// Runs `command FMU` (a library check in a child process) to its end: how it ended and its
/// standard output and error. What the child unpacked is removed once it has ended, also
/// after a crash.
pub fn run_probe(command: &[String], fmu: &Path) -> std::io::Result<std::process::Output> {
    let (program, args) = command
        .split_first()
        .ok_or_else(|| std::io::Error::other("an empty probe command"))?;
    let child = std::process::Command::new(program)
        .args(args)
        .arg(fmu)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()?;
    let pid = child.id();
    let out = child.wait_with_output();
    crate::file::remove_unpacked_of(pid);
    out
}

/// Before `fmu` is loaded in this process (a campaign without isolation): loads and
/// instantiates it in a child process first, when a probe command is set
/// ([`set_load_probe`]), so that a library that crashes (a constructor that dies, an
/// instantiation that segfaults) is [`FmuError::CrashedOnLoad`] — saying that `isolate = true`
/// contains it — rather than the silent end of this process. Any other outcome of the child
/// passes: this process's own loading reports its errors.
pub fn probe_load(fmu: &Path) -> Result<(), FmuError> {
    let Some(command) = LOAD_PROBE.get() else {
        return Ok(());
    };
    let out = run_probe(command, fmu).map_err(|e| FmuError::Io {
        what: format!("a test process loading {}", fmu.display()),
        source: e,
    })?;
    #[cfg(unix)]
    {
        use std::os::unix::process::ExitStatusExt;
        if out.status.signal().is_some() {
            return Err(FmuError::CrashedOnLoad {
                fmu: fmu.display().to_string(),
                status: crate::worker::describe(out.status),
            });
        }
    }
    Ok(())
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
