//! `savme.Space` and its variables: `Discrete`, `Boolean`, `Continuous`.

use crate::convert;
use crate::errors;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyList;
use savme_kernel::{Domain, Scale, Space, Variable};

/// One named variable of a space (made by `Discrete`, `Boolean` or `Continuous`).
#[pyclass(name = "Variable", module = "savme", frozen)]
#[derive(Clone)]
pub struct PyVariable {
    pub variable: Variable,
}

impl PyVariable {
    /// Checks the variable on its own (so that a bad one is refused where it is made, naming it).
    fn checked(variable: Variable) -> PyResult<Self> {
        Space::new(vec![variable.clone()]).map_err(errors::value)?;
        Ok(PyVariable { variable })
    }
}

#[pymethods]
impl PyVariable {
    /// The variable's name.
    #[getter]
    fn name(&self) -> &str {
        &self.variable.name
    }

    /// `"discrete"` or `"continuous"`.
    #[getter]
    fn kind(&self) -> &'static str {
        match self.variable.domain {
            Domain::Discrete { .. } => "discrete",
            Domain::Continuous { .. } => "continuous",
        }
    }

    /// The number of arms (values, or bins).
    #[getter]
    fn arms(&self) -> usize {
        self.variable.arms()
    }

    /// The values of a discrete variable (None for a continuous one).
    #[getter]
    fn values<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyList>>> {
        match &self.variable.domain {
            Domain::Discrete { values } => {
                let items = values
                    .iter()
                    .map(|v| convert::to_py(py, v))
                    .collect::<PyResult<Vec<_>>>()?;
                Ok(Some(PyList::new(py, items)?))
            }
            Domain::Continuous { .. } => Ok(None),
        }
    }

    /// `(lo, hi, bins, scale)` of a continuous variable (None for a discrete one).
    #[getter]
    fn range(&self) -> Option<(f64, f64, u32, &'static str)> {
        match self.variable.domain {
            Domain::Continuous {
                lo,
                hi,
                bins,
                scale,
            } => Some((lo, hi, bins, scale_name(scale))),
            Domain::Discrete { .. } => None,
        }
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<PyVariable>()
            .is_ok_and(|o| o.get().variable == self.variable)
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let name = &self.variable.name;
        Ok(match &self.variable.domain {
            Domain::Discrete { .. } => match self.values(py)? {
                Some(values) => format!("Discrete({name:?}, {})", values.repr()?),
                None => String::new(),
            },
            Domain::Continuous {
                lo,
                hi,
                bins,
                scale,
            } => format!(
                "Continuous({name:?}, {lo}, {hi}, bins={bins}, scale={:?})",
                scale_name(*scale)
            ),
        })
    }
}

fn scale_name(s: Scale) -> &'static str {
    s.name()
}

/// A discrete variable: one arm per value (bools, ints, floats or strings).
#[pyfunction]
#[pyo3(name = "Discrete")]
pub fn discrete(name: &str, values: &Bound<'_, PyAny>) -> PyResult<PyVariable> {
    if values.is_instance_of::<pyo3::types::PyString>() {
        return Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "Discrete({name:?}): values must be a list of values, got the str {values:?}; \
             a str is not split into its characters: give [{values:?}] for one value"
        )));
    }
    let values = values
        .try_iter()?
        .enumerate()
        .map(|(i, v)| convert::value(&format!("Discrete({name:?}) value {i}"), &v?))
        .collect::<PyResult<Vec<_>>>()?;
    PyVariable::checked(Variable::discrete(name, values))
}

/// A boolean variable: arms False and True.
#[pyfunction]
#[pyo3(name = "Boolean")]
pub fn boolean(name: &str) -> PyResult<PyVariable> {
    PyVariable::checked(Variable::boolean(name))
}

/// A continuous variable on [lo, hi] cut into `bins` arms, linear or log scale.
#[pyfunction]
#[pyo3(name = "Continuous", signature = (name, lo, hi, bins = 10, scale = "linear"))]
pub fn continuous(name: &str, lo: f64, hi: f64, bins: i128, scale: &str) -> PyResult<PyVariable> {
    let bins = convert::whole(&format!("continuous variable `{name}`: bins"), bins)?;
    let Some(scale) = Scale::from_name(scale) else {
        return Err(PyValueError::new_err(format!(
            "continuous variable `{name}`: scale must be \"linear\", \"log\" or \"shifted-log\", got {scale:?}"
        )));
    };
    PyVariable::checked(Variable::continuous(name, lo, hi, bins, scale))
}

/// An ordered, validated list of variables.
#[pyclass(name = "Space", module = "savme", frozen)]
#[derive(Clone)]
pub struct PySpace {
    pub space: Space,
}

#[pymethods]
impl PySpace {
    #[new]
    fn new(variables: &Bound<'_, PyAny>) -> PyResult<Self> {
        let vars = variables
            .try_iter()?
            .map(|v| Ok(v?.cast::<PyVariable>()?.get().variable.clone()))
            .collect::<PyResult<Vec<_>>>()?;
        Ok(PySpace {
            space: Space::new(vars).map_err(errors::value)?,
        })
    }

    /// The variables' names, in order.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.space
            .variables()
            .iter()
            .map(|v| v.name.to_string())
            .collect()
    }

    /// The variables, in order.
    #[getter]
    fn variables(&self) -> Vec<PyVariable> {
        self.space
            .variables()
            .iter()
            .map(|v| PyVariable {
                variable: v.clone(),
            })
            .collect()
    }

    /// The space as JSON (the format of the kernel configuration's spaces).
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string(&self.space).map_err(errors::value)
    }

    /// A space from `to_json()` output; errors name the variable.
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Self> {
        Ok(PySpace {
            space: serde_json::from_str(text).map_err(errors::value)?,
        })
    }

    fn __len__(&self) -> usize {
        self.space.len()
    }

    fn __getitem__(&self, name: &str) -> PyResult<PyVariable> {
        self.space
            .variable(name)
            .map(|v| PyVariable {
                variable: v.clone(),
            })
            .ok_or_else(|| convert::unknown("variable", name, self.names()))
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<PySpace>()
            .is_ok_and(|o| o.get().space == self.space)
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let vars = self
            .variables()
            .iter()
            .map(|v| v.__repr__(py))
            .collect::<PyResult<Vec<_>>>()?;
        Ok(format!("Space([{}])", vars.join(", ")))
    }
}
