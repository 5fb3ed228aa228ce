//! Values, assignments and JSON between Rust and Python.

use pyo3::exceptions::{PyKeyError, PyTypeError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyString};
use savme_kernel::{Assignment, Space, Value};

/// A failure flag: a Python `bool` or a numpy bool (`numpy.bool_`), nothing else — not `0`/`1`,
/// not a tuple or `None` (truthiness would record `(0.7, 1.0)` as a failure and `None` as a
/// pass). `Err` holds the type's name for the caller's message.
pub fn failure_flag(obj: &Bound<'_, PyAny>) -> Result<bool, String> {
    if obj.is_instance_of::<PyBool>() {
        return obj.is_truthy().map_err(|e| e.to_string());
    }
    let kind = obj.get_type();
    let module = kind.module().map(|m| m.to_string()).unwrap_or_default();
    let name = kind.name().map(|n| n.to_string()).unwrap_or_default();
    if module == "numpy" && (name == "bool_" || name == "bool") {
        return obj.is_truthy().map_err(|e| e.to_string());
    }
    Err(if module.is_empty() || module == "builtins" {
        name
    } else {
        format!("{module}.{name}")
    })
}

/// A Python value as a kernel [`Value`]: `bool`, `int`, `float`, `str` (and numpy scalars,
/// which convert to these); `what` names it in the error.
pub fn value(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<Value> {
    if obj.is_instance_of::<PyBool>() {
        return Ok(Value::Bool(obj.extract()?));
    }
    if obj.is_instance_of::<PyInt>() {
        return obj.extract::<i64>().map(Value::Int).map_err(|_| {
            pyo3::exceptions::PyOverflowError::new_err(format!(
                "{what}: the integer {obj} does not fit in 64 bits"
            ))
        });
    }
    if obj.is_instance_of::<PyFloat>() {
        return Ok(Value::Real(obj.extract()?));
    }
    if obj.is_instance_of::<PyString>() {
        return Ok(Value::from(obj.extract::<String>()?.as_str()));
    }
    if obj.hasattr("__index__")? {
        if let Ok(i) = obj.extract::<i64>() {
            return Ok(Value::Int(i));
        }
    }
    if let Ok(x) = obj.extract::<f64>() {
        return Ok(Value::Real(x));
    }
    let kind = obj.get_type().name()?;
    Err(PyTypeError::new_err(format!(
        "{what}: expected a bool, int, float or str, got {kind}"
    )))
}

/// A kernel value as a Python object.
pub fn to_py<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        Value::Bool(b) => PyBool::new(py, *b).to_owned().into_any(),
        Value::Int(i) => i.into_pyobject(py)?.into_any(),
        Value::Real(x) => PyFloat::new(py, *x).into_any(),
        Value::Label(s) => PyString::new(py, s).into_any(),
    })
}

/// An assignment as a dict, in its order (space order for the kernel's trials).
pub fn dict<'py>(py: Python<'py>, a: &Assignment) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (name, v) in a.iter() {
        d.set_item(name, to_py(py, v)?)?;
    }
    Ok(d)
}

/// A dict of named values as an assignment in `space`'s order when every name is the
/// space's (otherwise in the dict's order, so that the kernel's check names what is wrong).
pub fn assignment(what: &str, d: &Bound<'_, PyDict>, space: &Space) -> PyResult<Assignment> {
    let mut pairs = Vec::with_capacity(d.len());
    for (k, v) in d.iter() {
        let name: String = k.extract().map_err(|_| {
            PyTypeError::new_err(format!(
                "{what}: keys must be variable names (str), got {k}"
            ))
        })?;
        let value = value(&format!("{what}[{name:?}]"), &v)?;
        pairs.push((name, value));
    }
    let in_space =
        pairs.len() == space.len() && pairs.iter().all(|(n, _)| space.variable(n).is_some());
    if in_space {
        pairs.sort_by_key(|(n, _)| {
            space
                .variables()
                .iter()
                .position(|v| &*v.name == n.as_str())
        });
    }
    Ok(pairs
        .into_iter()
        .fold(Assignment::new(), |a, (n, v)| a.with(&n, v)))
}

/// A serialisable value as plain Python objects (dicts, lists, numbers, strings), through
/// the `json` module.
pub fn json_to_py<'py>(py: Python<'py>, v: &impl serde::Serialize) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(v).map_err(crate::errors::value)?;
    py.import("json")?.call_method1("loads", (text,))
}

/// `KeyError` for an unknown name.
pub fn unknown(kind: &str, name: &str, known: impl IntoIterator<Item = impl AsRef<str>>) -> PyErr {
    let known: Vec<String> = known.into_iter().map(|s| s.as_ref().to_string()).collect();
    PyKeyError::new_err(format!(
        "unknown {kind} `{name}` (known: {})",
        known.join(", ")
    ))
}

/// An unsigned integer type a Python argument converts to, with its largest value.
pub trait Unsigned: TryFrom<i128> + Copy {
    /// The largest value, as the error message states it.
    const MAX: i128;
}

impl Unsigned for u32 {
    const MAX: i128 = u32::MAX as i128;
}

impl Unsigned for u64 {
    const MAX: i128 = u64::MAX as i128;
}

impl Unsigned for usize {
    const MAX: i128 = usize::MAX as i128;
}

/// The integer argument `name` (taken from Python as an `i128`, so that a negative or too
/// large int reaches this check) as a `T`: a `ValueError` naming the argument, its range and
/// the value given, instead of PyO3's "can't convert negative int to unsigned".
pub fn whole<T: Unsigned>(name: &str, v: i128) -> PyResult<T> {
    T::try_from(v).map_err(|_| {
        pyo3::exceptions::PyValueError::new_err(format!(
            "{name} must be a whole number from 0 to {}, got {v}",
            T::MAX
        ))
    })
}
