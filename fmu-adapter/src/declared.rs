//! The values a campaign may set, checked against what the model description declares before
//! the first run: `min` / `max` of Real and Integer variables, the items of an enumeration
//! (set by value or by item name). A φ range of [0, 100] on a variable declared 4..25 is
//! refused here, naming the variable and its bounds, instead of every affected trial failing
//! in `fmi2ExitInitializationMode`.

use crate::description::{VarInfo, VarType};
use crate::file::FmuDescription;
use crate::FmuError;
use savme_kernel::{Domain, Value, Variable};

fn error(file: &FmuDescription, var: &VarInfo, message: String) -> FmuError {
    FmuError::OutOfRange {
        fmu: file.path.display().to_string(),
        variable: var.name.clone(),
        message,
    }
}

/// `[min, max]` as declared (`-∞` / `∞` when absent), inside the range of an integer type
/// (an FMI 3.0 UInt8 takes 0..255 whatever it declares).
fn bounds(var: &VarInfo) -> (f64, f64) {
    let (lo, hi) = var
        .repr
        .integer_range()
        .map_or((f64::NEG_INFINITY, f64::INFINITY), |(lo, hi)| {
            (lo as f64, hi as f64)
        });
    (
        var.min.map_or(lo, |m| m.max(lo)),
        var.max.map_or(hi, |m| m.min(hi)),
    )
}

fn declared(var: &VarInfo) -> String {
    let (lo, hi) = bounds(var);
    let show = |x: f64| {
        if x.is_infinite() {
            if x < 0.0 { "-inf" } else { "inf" }.to_string()
        } else {
            x.to_string()
        }
    };
    // A bound missing from the declaration comes from the integer type's range.
    let typed = match var.repr.integer_range() {
        Some(_) if var.kind == VarType::Integer && (var.min.is_none() || var.max.is_none()) => {
            format!(", and the range of {:?}", var.repr)
        }
        _ => String::new(),
    };
    format!(
        "is declared in [{}, {}] (min/max{typed})",
        show(lo),
        show(hi)
    )
}

fn items(var: &VarInfo) -> String {
    var.items
        .iter()
        .map(|i| format!("{} = {}", i.name, i.value))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The integer `value` sets on `var` (an Integer or an Enumeration): an enumeration item by
/// name or value, a label by its position in `labels`, an integral number; `None` if it sets
/// none or it lies outside the range of the variable's C type.
pub(crate) fn integer_of(var: &VarInfo, value: &Value, labels: Option<&[String]>) -> Option<i64> {
    let i = match (var.kind, value, labels) {
        (VarType::Enumeration, Value::Label(l), _) => {
            var.items.iter().find(|i| *i.name == **l)?.value
        }
        (VarType::Integer, Value::Label(l), Some(labels)) => {
            labels.iter().position(|x| **x == **l)? as i64
        }
        _ => {
            let f = value.as_f64()?;
            // Beyond i64 (a UInt64 above 2⁶³ − 1) `as` would saturate: no integer here (the
            // caller sets such a value as a number).
            if f.fract() != 0.0
                || !(-9_223_372_036_854_775_808.0..9_223_372_036_854_775_808.0).contains(&f)
            {
                return None;
            }
            f as i64
        }
    };
    if var.kind == VarType::Enumeration && !var.items.iter().any(|x| x.value == i) {
        return None;
    }
    let (lo, hi) = var.repr.integer_range()?;
    (lo..=hi).contains(&i128::from(i)).then_some(i)
}

/// Checks one value (`what`: e.g. "the fixed value 30") that will be set on `var`.
pub(crate) fn check_value(
    file: &FmuDescription,
    var: &VarInfo,
    value: &Value,
    labels: Option<&[String]>,
    what: &str,
) -> Result<(), FmuError> {
    match var.kind {
        VarType::Enumeration if integer_of(var, value, labels).is_none() => Err(error(
            file,
            var,
            format!(
                "is an enumeration ({}); {what} is none of its items (give an item's name or value)",
                items(var)
            ),
        )),
        VarType::Real | VarType::Integer => {
            let x = match (var.kind, labels) {
                (VarType::Integer, Some(_)) => integer_of(var, value, labels).map(|i| i as f64),
                _ => value.as_f64(),
            };
            let (lo, hi) = bounds(var);
            match x {
                Some(x) if x < lo || x > hi => Err(error(
                    file,
                    var,
                    format!("{}; {what} lies outside", declared(var)),
                )),
                _ => Ok(()),
            }
        }
        _ => Ok(()),
    }
}

/// Checks every value savme variable `v` (`role`: "φ" or "θ") may set on `var`.
pub(crate) fn check_domain(
    file: &FmuDescription,
    var: &VarInfo,
    v: &Variable,
    labels: Option<&[String]>,
    role: &str,
) -> Result<(), FmuError> {
    match &v.domain {
        Domain::Continuous { lo, hi, .. } => {
            let (min, max) = bounds(var);
            if *lo < min || *hi > max {
                return Err(error(
                    file,
                    var,
                    format!(
                        "{}; {role} `{}` ranges over [{lo}, {hi}], outside it",
                        declared(var),
                        v.name
                    ),
                ));
            }
            Ok(())
        }
        Domain::Discrete { values } => {
            for x in values {
                let what = format!("{role} `{}` value {x}", v.name);
                check_value(file, var, x, labels, &what)?;
            }
            Ok(())
        }
    }
}
