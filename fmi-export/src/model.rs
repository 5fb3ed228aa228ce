//! What a model declares: its variables (kind, causality, start value, bounds, unit) and how
//! it initialises from its parameters and steps ([`Model`]).

/// The type of a variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// `fmi2Real` (f64).
    Real,
    /// `fmi2Integer` (i32).
    Integer,
    /// `fmi2Boolean`.
    Boolean,
}

/// A variable's value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Scalar {
    /// A real.
    Real(f64),
    /// An integer.
    Integer(i32),
    /// A boolean.
    Boolean(bool),
}

impl Scalar {
    /// Its kind.
    pub fn kind(self) -> Kind {
        match self {
            Scalar::Real(_) => Kind::Real,
            Scalar::Integer(_) => Kind::Integer,
            Scalar::Boolean(_) => Kind::Boolean,
        }
    }

    /// As f64 (integers and booleans converted).
    pub fn as_f64(self) -> f64 {
        match self {
            Scalar::Real(x) => x,
            Scalar::Integer(i) => f64::from(i),
            Scalar::Boolean(b) => f64::from(u8::from(b)),
        }
    }

    /// As written in `modelDescription.xml` (a `start` attribute).
    pub(crate) fn xml(self) -> String {
        match self {
            Scalar::Real(x) => format!("{x:?}"),
            Scalar::Integer(i) => i.to_string(),
            Scalar::Boolean(b) => b.to_string(),
        }
    }
}

/// Who sets a variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Causality {
    /// Set before initialisation, fixed afterwards.
    Parameter,
    /// Computed by the model.
    Output,
}

/// One scalar variable; its value reference is its position in [`Model::variables`].
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    /// Unique name.
    pub name: String,
    /// Who sets it.
    pub causality: Causality,
    /// Start value (parameters); the initial value of an output.
    pub start: Scalar,
    /// Lower bound of a parameter, if any (Real and Integer only).
    pub min: Option<f64>,
    /// Upper bound of a parameter, if any.
    pub max: Option<f64>,
    /// Unit, if any (Real only).
    pub unit: Option<&'static str>,
    /// What it is.
    pub description: String,
}

impl Variable {
    /// A parameter with a start value.
    pub fn parameter(name: &str, start: Scalar, description: &str) -> Self {
        Variable {
            name: name.into(),
            causality: Causality::Parameter,
            start,
            min: None,
            max: None,
            unit: None,
            description: description.into(),
        }
    }

    /// An output, initially `start`.
    pub fn output(name: &str, start: Scalar, description: &str) -> Self {
        Variable {
            causality: Causality::Output,
            ..Variable::parameter(name, start, description)
        }
    }

    /// With bounds.
    pub fn range(mut self, min: f64, max: f64) -> Self {
        self.min = Some(min);
        self.max = Some(max);
        self
    }

    /// With a unit.
    pub fn unit(mut self, unit: &'static str) -> Self {
        self.unit = Some(unit);
        self
    }
}

/// A model to export.
pub trait Model: Sized + Clone + Send + 'static {
    /// `modelName`.
    const MODEL_NAME: &'static str;
    /// `modelIdentifier`: the shared library's file stem.
    const MODEL_IDENTIFIER: &'static str;
    /// `guid`, checked by `fmi2Instantiate`.
    const GUID: &'static str;
    /// What the model is.
    const DESCRIPTION: &'static str;
    /// `DefaultExperiment`: stop time and step size.
    const DEFAULT_EXPERIMENT: (f64, f64);

    /// The variables; value reference = index.
    fn variables() -> &'static [Variable];

    /// Builds the model from the parameter values (all variables, by value reference) at
    /// `fmi2ExitInitializationMode`; may write initial outputs.
    fn initialize(values: &mut [Scalar], start_time: f64) -> Result<Self, String>;

    /// Advances from `time` by `step`, writing outputs into `values`.
    fn do_step(&mut self, values: &mut [Scalar], time: f64, step: f64) -> Result<(), String>;
}
