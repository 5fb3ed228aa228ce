//! The value one variable takes in a trial, and named collections of them.

use serde::de::{MapAccess, Visitor};
use serde::ser::SerializeMap;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::fmt;
use std::sync::Arc;

/// A value of a scenario parameter or fidelity setting.
///
/// Serialises to plain JSON: `true`, `10`, `0.58`, `"high"`. JSON integers read back as
/// [`Value::Int`], JSON numbers with a fraction or exponent as [`Value::Real`].
///
/// ```
/// use savme_kernel::Value;
/// assert_eq!(Value::from(10), Value::Int(10));
/// assert_eq!(Value::from("low").to_string(), "low");
/// assert!(Value::Int(2).same_as(&Value::Real(2.0)));
/// ```
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Value {
    /// A boolean, e.g. a "disable shadows" switch.
    Bool(bool),
    /// An integer, e.g. a simulation rate in Hz or a ray-tracing bounce count.
    Int(i64),
    /// A real number, e.g. a view distance drawn inside a bin.
    Real(f64),
    /// A label, e.g. a bloom level `"high"`.
    Label(Arc<str>),
}

impl Value {
    /// The value as a real number, when it is numeric (`Int` or `Real`).
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Value::Int(i) => Some(*i as f64),
            Value::Real(x) => Some(*x),
            _ => None,
        }
    }

    /// The value as a boolean, when it is one.
    pub fn as_bool(&self) -> Option<bool> {
        match self {
            Value::Bool(b) => Some(*b),
            _ => None,
        }
    }

    /// The value as a label, when it is one.
    pub fn as_label(&self) -> Option<&str> {
        match self {
            Value::Label(s) => Some(s),
            _ => None,
        }
    }

    /// Equality that treats `Int(2)` and `Real(2.0)` as the same number, so that a value typed
    /// by hand (or read from JSON) matches the discrete value it names.
    /// Integers compare exactly: `Int(2⁵³ + 1)` is not `Int(2⁵³)` (their doubles are equal),
    /// nor `Real(2⁵³)`.
    ///
    /// ```
    /// use savme_kernel::Value;
    /// assert!(!Value::Int(9_007_199_254_740_993).same_as(&Value::Int(9_007_199_254_740_992)));
    /// assert!(!Value::Int(9_007_199_254_740_993).same_as(&Value::Real(9_007_199_254_740_992.0)));
    /// assert!(Value::Int(-4).same_as(&Value::Real(-4.0)));
    /// ```
    pub fn same_as(&self, other: &Value) -> bool {
        match (self, other) {
            (Value::Int(i), Value::Real(x)) | (Value::Real(x), Value::Int(i)) => {
                // Exact: the double must be the integer itself (`as` is exact for an integral
                // double inside ±2¹²⁶, and no i64 lies outside).
                x.fract() == 0.0 && x.abs() < 8.5e37 && *x as i128 == i128::from(*i)
            }
            (Value::Real(a), Value::Real(b)) => a == b,
            _ => self == other,
        }
    }

    /// True for NaN or infinite reals; every other value is finite.
    pub(crate) fn is_non_finite(&self) -> bool {
        matches!(self, Value::Real(x) if !x.is_finite())
    }
}

/// A number as savme shows it to a user: as Rust writes it (`30`, `0.25`, shortest round
/// trip), except very large or very small magnitudes in exponent form (`1e308`, not 309
/// digits; `2.5e-9`, not ten zeros first).
///
/// ```
/// use savme_kernel::Num;
/// assert_eq!(Num(1e308).to_string(), "1e308");
/// assert_eq!(Num(-2.5e-9).to_string(), "-2.5e-9");
/// assert_eq!(Num(30.0).to_string(), "30");
/// assert_eq!(Num(0.125).to_string(), "0.125");
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Num(pub f64);

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let x = self.0;
        let a = x.abs();
        if x.is_finite() && (a >= 1e16 || (a != 0.0 && a < 1e-6)) {
            write!(f, "{x:e}")
        } else {
            write!(f, "{x}")
        }
    }
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Bool(b) => write!(f, "{b}"),
            Value::Int(i) => write!(f, "{i}"),
            Value::Real(x) => write!(f, "{}", Num(*x)),
            Value::Label(s) => f.write_str(s),
        }
    }
}

impl From<bool> for Value {
    fn from(b: bool) -> Self {
        Value::Bool(b)
    }
}
impl From<i64> for Value {
    fn from(i: i64) -> Self {
        Value::Int(i)
    }
}
impl From<i32> for Value {
    fn from(i: i32) -> Self {
        Value::Int(i64::from(i))
    }
}
impl From<f64> for Value {
    fn from(x: f64) -> Self {
        Value::Real(x)
    }
}
impl From<&str> for Value {
    fn from(s: &str) -> Self {
        Value::Label(Arc::from(s))
    }
}

/// Named values in a fixed order: one trial's φ or θ, or the high-fidelity settings θ_HF.
///
/// The kernel hands out assignments in the order of their [`crate::Space`]. Serialises as a
/// JSON object (`{"speed": 12.5, "rate": 10}`) that keeps that order.
///
/// ```
/// use savme_kernel::Assignment;
/// let a = Assignment::new().with("rate", 10).with("bloom", "low");
/// assert_eq!(a.get_f64("rate"), Some(10.0));
/// assert_eq!(a.get("bloom").and_then(|v| v.as_label()), Some("low"));
/// assert_eq!(a.to_string(), "rate=10, bloom=low");
/// ```
#[derive(Debug, Clone, Default)]
pub struct Assignment {
    /// Names, shared with the space the assignment was drawn from (cloning is cheap).
    names: Arc<Vec<Arc<str>>>,
    /// Values, shared between clones until one of them is changed.
    values: Arc<Vec<Value>>,
}

impl PartialEq for Assignment {
    fn eq(&self, other: &Self) -> bool {
        self.values == other.values
            && (Arc::ptr_eq(&self.names, &other.names) || self.names == other.names)
    }
}

impl Assignment {
    /// An empty assignment.
    pub fn new() -> Self {
        Self::default()
    }

    /// Values for the given shared names, in order (one value per name).
    pub(crate) fn from_parts(names: Arc<Vec<Arc<str>>>, values: Vec<Value>) -> Self {
        debug_assert_eq!(names.len(), values.len());
        Assignment {
            names,
            values: Arc::new(values),
        }
    }

    /// Adds (or replaces) `name = value`, builder style.
    pub fn with(mut self, name: &str, value: impl Into<Value>) -> Self {
        self.set(name, value);
        self
    }

    /// Sets `name = value`, replacing an earlier value of the same name.
    pub fn set(&mut self, name: &str, value: impl Into<Value>) {
        let value = value.into();
        match self.position(name) {
            Some(i) => Arc::make_mut(&mut self.values)[i] = value,
            None => {
                Arc::make_mut(&mut self.names).push(Arc::from(name));
                Arc::make_mut(&mut self.values).push(value);
            }
        }
    }

    fn position(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| &**n == name)
    }

    /// The value of `name`, if present.
    pub fn get(&self, name: &str) -> Option<&Value> {
        self.position(name).map(|i| &self.values[i])
    }

    /// The numeric value of `name`, if present and numeric.
    pub fn get_f64(&self, name: &str) -> Option<f64> {
        self.get(name).and_then(Value::as_f64)
    }

    /// The boolean value of `name`, if present and boolean.
    pub fn get_bool(&self, name: &str) -> Option<bool> {
        self.get(name).and_then(Value::as_bool)
    }

    /// `(name, value)` pairs in order.
    pub fn iter(&self) -> impl Iterator<Item = (&str, &Value)> {
        self.names.iter().map(|n| &**n).zip(self.values.iter())
    }

    /// A hash of the names and values that is stable across runs, platforms and versions
    /// (FNV-1a over the bytes), salted with `salt`. Simulators seed per-trial noise with it, so
    /// that the HF and LF runs of one trial see the same random stream.
    ///
    /// ```
    /// use savme_kernel::Assignment;
    /// let a = Assignment::new().with("gap", 12.5);
    /// assert_eq!(a.stable_hash("s1"), a.clone().stable_hash("s1"));
    /// assert_ne!(a.stable_hash("s1"), a.stable_hash("s2"));
    /// assert_ne!(a.stable_hash("s1"), Assignment::new().with("gap", 12.6).stable_hash("s1"));
    /// ```
    pub fn stable_hash(&self, salt: &str) -> u64 {
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        let mut eat = |bytes: &[u8]| {
            for &b in bytes {
                h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
            }
        };
        eat(salt.as_bytes());
        for (name, value) in self.iter() {
            eat(name.as_bytes());
            match value {
                Value::Bool(b) => eat(&[u8::from(*b)]),
                Value::Int(i) => eat(&(*i as f64).to_bits().to_le_bytes()),
                Value::Real(x) => eat(&x.to_bits().to_le_bytes()),
                Value::Label(l) => eat(l.as_bytes()),
            }
        }
        h
    }

    /// Number of named values.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// True when no value is named.
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }
}

impl fmt::Display for Assignment {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, (n, v)) in self.iter().enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            write!(f, "{n}={v}")?;
        }
        Ok(())
    }
}

impl Serialize for Assignment {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut map = serializer.serialize_map(Some(self.len()))?;
        for (n, v) in self.iter() {
            map.serialize_entry(n, v)?;
        }
        map.end()
    }
}

/// An object of named values (`{"ego_speed": 20.0, "road": "wet"}`).
#[cfg(feature = "schema")]
impl schemars::JsonSchema for Assignment {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "Assignment".into()
    }

    fn json_schema(generator: &mut schemars::SchemaGenerator) -> schemars::Schema {
        let value = generator.subschema_for::<Value>();
        schemars::json_schema!({
            "description": "Values by variable name, in the space's order.",
            "type": "object",
            "additionalProperties": value
        })
    }
}

impl<'de> Deserialize<'de> for Assignment {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct OrderedMap;
        impl<'de> Visitor<'de> for OrderedMap {
            type Value = Assignment;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an object of named values")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut access: A) -> Result<Assignment, A::Error> {
                let mut names = Vec::new();
                let mut values = Vec::new();
                while let Some((name, value)) = access.next_entry::<String, Value>()? {
                    if names.iter().any(|n: &Arc<str>| **n == *name) {
                        return Err(serde::de::Error::custom(format!(
                            "variable `{name}` is named twice"
                        )));
                    }
                    names.push(Arc::from(name));
                    values.push(value);
                }
                Ok(Assignment::from_parts(Arc::new(names), values))
            }
        }
        deserializer.deserialize_map(OrderedMap)
    }
}
