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
    // An integer type's bounds exactly (i64::MAX, not the double above it).
    let (lo, hi) = match var.repr.integer_range() {
        Some((tlo, thi)) if var.kind == VarType::Integer => {
            let exact = |b: Option<f64>, t: i128, max: bool| match b {
                Some(b) if b.fract() == 0.0 && b.abs() < 8.5e37 => {
                    let b = b as i128;
                    (if max { b.min(t) } else { b.max(t) }).to_string()
                }
                Some(b) => show(b),
                None => t.to_string(),
            };
            (exact(var.min, tlo, false), exact(var.max, thi, true))
        }
        _ => (show(lo), show(hi)),
    };
    // A bound missing from the declaration comes from the integer type's range.
    let typed = match var.repr.integer_range() {
        Some(_) if var.kind == VarType::Integer && (var.min.is_none() || var.max.is_none()) => {
            format!(", and the range of {:?}", var.repr)
        }
        _ => String::new(),
    };
    format!("is declared in [{lo}, {hi}] (min/max{typed})")
}

fn items(var: &VarInfo) -> String {
    var.items
        .iter()
        .map(|i| format!("{} = {}", i.name, i.value))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The integer a number is, exactly: an `Int` as it is (never through a double: 2⁵³ + 1 stays
/// odd), an integral `Real` as the integer it holds (a UInt64 above 2⁶³ − 1 can only be written
/// so); `None` for a fraction, a non-finite number or anything else.
///
/// ```
/// use savme_fmu::declared::exact_integer;
/// use savme_kernel::Value;
/// assert_eq!(exact_integer(&Value::Int(9_007_199_254_740_993)), Some(9_007_199_254_740_993));
/// assert_eq!(exact_integer(&Value::Real(1.5e19)), Some(15_000_000_000_000_000_000));
/// assert_eq!(exact_integer(&Value::Real(0.5)), None);
/// ```
pub fn exact_integer(value: &Value) -> Option<i128> {
    match value {
        Value::Int(i) => Some(i128::from(*i)),
        // Within ±2¹²⁶ a double's `as` cast to i128 is exact.
        Value::Real(f) if f.fract() == 0.0 && f.abs() < 8.5e37 => Some(*f as i128),
        _ => None,
    }
}

/// The integer `value` sets on `var` (an Integer or an Enumeration): an enumeration item by
/// name or value, a label by its position in `labels`, an integral number (exactly, see
/// [`exact_integer`]); `None` if it sets none or it lies outside the range of the variable's C
/// type.
pub(crate) fn integer_of(var: &VarInfo, value: &Value, labels: Option<&[String]>) -> Option<i128> {
    let i = match (var.kind, value, labels) {
        (VarType::Enumeration, Value::Label(l), _) => {
            i128::from(var.items.iter().find(|i| *i.name == **l)?.value)
        }
        (VarType::Integer, Value::Label(l), Some(labels)) => {
            labels.iter().position(|x| **x == **l)? as i128
        }
        _ => exact_integer(value)?,
    };
    if var.kind == VarType::Enumeration && !var.items.iter().any(|x| i128::from(x.value) == i) {
        return None;
    }
    let (lo, hi) = var.repr.integer_range()?;
    (lo..=hi).contains(&i).then_some(i)
}

/// Whether integer `i` lies inside `var`'s declared `min` / `max`, compared exactly (a bound
/// is a double: an integral one is compared as the integer it is).
fn inside_declared(var: &VarInfo, i: i128) -> bool {
    let below = |bound: f64| {
        if bound.fract() == 0.0 && bound.abs() < 8.5e37 {
            i < bound as i128
        } else {
            (i as f64) < bound
        }
    };
    let above = |bound: f64| {
        if bound.fract() == 0.0 && bound.abs() < 8.5e37 {
            i > bound as i128
        } else {
            (i as f64) > bound
        }
    };
    !(var.min.is_some_and(below) || var.max.is_some_and(above))
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
        // An integer is checked exactly, against its C type's range and its declared bounds:
        // what passes here is what the run sets (i64::MAX on an Int64 included).
        VarType::Integer if labels.is_some() || exact_integer(value).is_some() => {
            match integer_of(var, value, labels) {
                Some(i) if inside_declared(var, i) => Ok(()),
                _ => Err(error(
                    file,
                    var,
                    format!("{}; {what} lies outside", declared(var)),
                )),
            }
        }
        VarType::Real | VarType::Integer => {
            let x = value.as_f64();
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
