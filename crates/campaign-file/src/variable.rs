//! A variable's table (`[[fidelity.variable]]`, `[[scenario.phi]]`): a savme variable, checked as
//! the kernel checks it, and the simulator variable it binds to. An error names the part of the
//! table at fault (`….range`, `….bins`, …) at its line.

use crate::{ConfigError, Source};
use savme_kernel::{Assignment, Scale, Space, SpaceError, Value, Variable};
use std::ops::Range;
use toml::Spanned;

/// A variable's table as serde reads it.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct VarSection {
    pub name: Spanned<String>,
    /// The simulator variable it binds to (default: its own name). The key is named after the
    /// FMU adapter, the first adapter with bindings.
    pub fmu: Option<Spanned<String>>,
    pub values: Option<Spanned<Vec<toml::Value>>>,
    /// `[lo, hi]`; a list, not `[f64; 2]`: serde's arrays ignore a third number.
    pub range: Option<Spanned<Vec<f64>>>,
    /// Default 10.
    pub bins: Option<Spanned<u32>>,
    /// Default linear.
    pub scale: Option<Spanned<ScaleSection>>,
    pub hf: Option<Spanned<toml::Value>>,
    /// A fidelity variable that is the step size or the tolerance, bound to no simulator
    /// variable.
    pub drives: Option<Spanned<Drives>>,
}

/// What a fidelity setting with `drives` is: the simulator's step size or its tolerance.
#[derive(Debug, serde::Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Drives {
    /// `drives = "step_size"`: every value is a step in seconds.
    StepSize,
    /// `drives = "tolerance"`.
    Tolerance,
}

impl Drives {
    /// "the step size" / "the tolerance".
    pub fn what(self) -> &'static str {
        match self {
            Drives::StepSize => "the step size",
            Drives::Tolerance => "the tolerance",
        }
    }
}

/// `scale`.
#[derive(Debug, serde::Deserialize, Default, Clone, Copy)]
#[serde(rename_all = "lowercase")]
pub(crate) enum ScaleSection {
    #[default]
    Linear,
    Log,
    /// The authors' SAVME code's log bins (any range): `savme_kernel::Scale::ShiftedLog`.
    #[serde(rename = "shifted-log")]
    ShiftedLog,
}

/// A simulator variable named in the file, with the line and the key that name it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Named {
    /// The simulator variable.
    pub name: String,
    /// The 1-based line of the key.
    pub line: usize,
    /// The key (`scenario[0].phi[1].fmu`, else `….name`).
    pub key: String,
}

/// The simulator variable `sv` binds to — its `fmu` key, else its own name — with the line
/// and the key that name it (`….fmu`, else `….name`).
pub(crate) fn binding(src: &Source, sv: &VarSection, key: &str) -> Named {
    let (name, span, key) = match &sv.fmu {
        Some(f) => (f.get_ref(), f.span(), format!("{key}.fmu")),
        None => (sv.name.get_ref(), sv.name.span(), format!("{key}.name")),
    };
    Named {
        name: name.clone(),
        line: src.line(span),
        key,
    }
}

/// θ_HF of a fidelity variable: its `hf` value, which must lie inside the variable.
pub(crate) fn theta_hf_value(
    src: &Source,
    key: &str,
    sv: &Spanned<VarSection>,
    var: &Variable,
) -> Result<Value, ConfigError> {
    let hf = sv
        .get_ref()
        .hf
        .as_ref()
        .and_then(|h| toml_value(h.get_ref()));
    let hf = hf.ok_or_else(|| {
        var_error(
            src,
            key,
            sv,
            Part::Hf,
            "θ_HF value missing or not a number/boolean/string",
        )
    })?;
    let one = Assignment::new().with(&var.name, hf.clone());
    Space::new(vec![var.clone()])
        .and_then(|s| s.arms_of(&one))
        .map_err(|e| var_error(src, key, sv, Part::Hf, format!("θ_HF: {e}")))?;
    Ok(hf)
}

/// The variables of `[[fidelity.variable]]` or of a scenario's `[[scenario.phi]]` tables (keys
/// `{prefix}[j]`): each checked as the kernel checks it, no name twice.
pub(crate) fn variables(
    src: &Source,
    prefix: &str,
    list: &[Spanned<VarSection>],
) -> Result<Vec<Variable>, ConfigError> {
    let mut vars: Vec<Variable> = Vec::new();
    for (j, sv) in list.iter().enumerate() {
        let key = format!("{prefix}[{j}]");
        let var = variable(sv.get_ref()).map_err(|(part, m)| var_error(src, &key, sv, part, m))?;
        if vars.iter().any(|w| w.name == var.name) {
            let message = format!("variable `{}` is defined twice", var.name);
            return Err(var_error(src, &key, sv, Part::Name, message));
        }
        vars.push(var);
    }
    Ok(vars)
}

/// The part of a variable's table an error is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Part {
    /// The table as a whole.
    Table,
    Name,
    Values,
    Range,
    Bins,
    Scale,
    Hf,
}

impl Part {
    /// The part's key below the table's (`""` for the table) and its span in `v`, if written.
    fn locate(self, v: &VarSection) -> (&'static str, Option<Range<usize>>) {
        fn span<T>(x: &Option<Spanned<T>>) -> Option<Range<usize>> {
            x.as_ref().map(Spanned::span)
        }
        match self {
            Part::Table => ("", None),
            Part::Name => (".name", Some(v.name.span())),
            Part::Values => (".values", span(&v.values)),
            Part::Range => (".range", span(&v.range)),
            Part::Bins => (".bins", span(&v.bins)),
            Part::Scale => (".scale", span(&v.scale)),
            Part::Hf => (".hf", span(&v.hf)),
        }
    }

    /// The part a kernel error about a single variable `v` is about.
    fn of(e: &SpaceError, v: &VarSection) -> Part {
        match e {
            SpaceError::EmptyName => Part::Name,
            SpaceError::NoValues { .. }
            | SpaceError::DuplicateValue { .. }
            | SpaceError::NonFiniteValue { .. } => Part::Values,
            SpaceError::NonFiniteBound { .. }
            | SpaceError::EmptyRange { .. }
            | SpaceError::RangeNotRepresentable { .. } => Part::Range,
            SpaceError::TooManyArms { .. } if v.values.is_some() => Part::Values,
            SpaceError::ZeroBins { .. } | SpaceError::TooManyArms { .. } => Part::Bins,
            SpaceError::LogRangeNotPositive { .. } => Part::Scale,
            _ => Part::Table,
        }
    }
}

/// An error about `part` of the variable table `sv` at `key`: named `{key}.{part}`, at the
/// part's line when the file gives the part, else at the table's.
pub(crate) fn var_error(
    src: &Source,
    key: &str,
    sv: &Spanned<VarSection>,
    part: Part,
    message: impl Into<String>,
) -> ConfigError {
    let (suffix, span) = part.locate(sv.get_ref());
    let line = src.line(span.unwrap_or_else(|| sv.span()));
    src.err(Some(line), Some(&format!("{key}{suffix}")), message)
}

/// A savme variable from its TOML section, checked as the kernel checks it; an error names the
/// part of the section at fault.
fn variable(v: &VarSection) -> Result<Variable, (Part, String)> {
    let name = v.name.get_ref();
    let var = match (&v.values, &v.range) {
        (Some(values), None) => {
            let values: Option<Vec<Value>> = values.get_ref().iter().map(toml_value).collect();
            let values = values.ok_or_else(|| {
                (
                    Part::Values,
                    "`values` must be numbers, booleans or strings".to_string(),
                )
            })?;
            if values.is_empty() {
                return Err((Part::Values, "`values` is empty".into()));
            }
            Variable::discrete(name, values)
        }
        (None, Some(range)) => match range.get_ref()[..] {
            [lo, hi] => continuous(v, [lo, hi])?,
            ref other => {
                return Err((
                    Part::Range,
                    format!("`range` must be [lo, hi], got {} numbers", other.len()),
                ))
            }
        },
        _ => {
            return Err((
                Part::Table,
                "give either `values` (discrete) or `range` (continuous)".into(),
            ))
        }
    };
    Space::new(vec![var.clone()]).map_err(|e| (Part::of(&e, v), e.to_string()))?;
    Ok(var)
}

/// A continuous savme variable over `[lo, hi]` with the section's bins (default 10) and scale.
fn continuous(v: &VarSection, [lo, hi]: [f64; 2]) -> Result<Variable, (Part, String)> {
    if lo.partial_cmp(&hi) != Some(std::cmp::Ordering::Less) {
        return Err((Part::Range, format!("`range` = [{lo}, {hi}] is empty")));
    }
    let bins = v.bins.as_ref().map_or(10, |b| *b.get_ref());
    if bins == 0 {
        return Err((Part::Bins, "`bins` must be at least 1".into()));
    }
    let scale = match v.scale.as_ref().map(|s| *s.get_ref()).unwrap_or_default() {
        ScaleSection::Linear => Scale::Linear,
        ScaleSection::ShiftedLog => Scale::ShiftedLog,
        ScaleSection::Log if lo > 0.0 => Scale::Log,
        ScaleSection::Log => {
            return Err((
                Part::Scale,
                format!("a log scale needs 0 < lo (range [{lo}, {hi}])"),
            ))
        }
    };
    Ok(Variable::continuous(v.name.get_ref(), lo, hi, bins, scale))
}

/// A savme value from a TOML scalar (None for arrays, tables and dates).
pub fn toml_value(v: &toml::Value) -> Option<Value> {
    Some(match v {
        toml::Value::Boolean(b) => Value::Bool(*b),
        toml::Value::Integer(i) => Value::Int(*i),
        toml::Value::Float(f) => Value::Real(*f),
        toml::Value::String(s) => Value::from(s.as_str()),
        _ => return None,
    })
}
