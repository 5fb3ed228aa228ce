//! `modelDescription.xml` of an FMI 2.0 or FMI 3.0 FMU, read with quick-xml into what savme
//! checks and shows: the co-simulation capabilities, the default experiment, the type
//! definitions (bounds, units, enumeration items) and every variable with its causality, type,
//! start value, `min` / `max`, unit and — for an enumeration — its items, and the outputs
//! `ModelStructure` lists. One parser for both schemas: FMI 2.0 wraps each variable in a
//! `ScalarVariable` (`<Real>`, `<Integer>`, …), FMI 3.0 names the type in the element
//! (`<Float64>`, `<Int32>`, `<UInt8>`, …, `<Enumeration>`, `<String>` with `<Start value>`),
//! and the two end in the same [`VarInfo`] — its [`Repr`] says which C type the FMU's
//! get/set functions take.
//!
//! (fmu-runner's parser, used before, keeps none of the bounds, units or enumeration items.)
//!
//! One file of ~740 lines because it is one streaming parser: the element handlers share the
//! reader state (the open variable, its type, the problems collected with their positions),
//! and FMI 2.0 and 3.0 differ element by element, so the two schemas are read side by side.

use quick_xml::events::{BytesStart, Event};
use serde::Serialize;
use std::collections::HashMap;

/// A variable's type, as savme binds it (the same for FMI 2.0 and 3.0; [`Repr`] has the exact
/// C type).
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum VarType {
    /// fmi2Real; FMI 3.0 Float64 or Float32.
    Real,
    /// fmi2Integer; FMI 3.0 Int8 … Int64, UInt8 … UInt64.
    Integer,
    /// fmi2Boolean / fmi3Boolean.
    Boolean,
    /// fmi2String / fmi3String (can be fixed, not searched).
    String,
    /// An enumeration (set through `fmi2SetInteger` / `fmi3SetInt64`, by item value or name).
    Enumeration,
    /// An FMI 3.0 type savme does not bind (Binary, Clock): shown, never set.
    Other,
}

/// The C type an FMU's get/set functions take for a variable: what `fmi2Get/SetReal` …
/// or `fmi3Get/SetFloat64` … are called with.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Repr {
    /// `double` (fmi2Real, fmi3Float64).
    Float64,
    /// `float` (fmi3Float32).
    Float32,
    /// `int8_t`.
    Int8,
    /// `int16_t`.
    Int16,
    /// `int32_t` (fmi2Integer and fmi2 enumerations, fmi3Int32).
    Int32,
    /// `int64_t` (fmi3Int64 and fmi3 enumerations).
    Int64,
    /// `uint8_t`.
    UInt8,
    /// `uint16_t`.
    UInt16,
    /// `uint32_t`.
    UInt32,
    /// `uint64_t`.
    UInt64,
    /// fmi2Boolean (`int`) or fmi3Boolean (`bool`).
    Boolean,
    /// A C string.
    String,
    /// Not bound by savme (an FMI 3.0 type savme does not name otherwise).
    Other,
    /// FMI 3.0 Binary (bytes): shown, not bound.
    Binary,
    /// FMI 3.0 Clock: shown, not bound.
    Clock,
}

impl Repr {
    /// The range of an integer type (`None` for the others).
    ///
    /// ```
    /// use savme_fmu::description::Repr;
    /// assert_eq!(Repr::UInt8.integer_range(), Some((0, 255)));
    /// assert_eq!(Repr::Float64.integer_range(), None);
    /// ```
    pub fn integer_range(self) -> Option<(i128, i128)> {
        Some(match self {
            Repr::Int8 => (i8::MIN.into(), i8::MAX.into()),
            Repr::Int16 => (i16::MIN.into(), i16::MAX.into()),
            Repr::Int32 => (i32::MIN.into(), i32::MAX.into()),
            Repr::Int64 => (i64::MIN.into(), i64::MAX.into()),
            Repr::UInt8 => (0, u8::MAX.into()),
            Repr::UInt16 => (0, u16::MAX.into()),
            Repr::UInt32 => (0, u32::MAX.into()),
            Repr::UInt64 => (0, u64::MAX.into()),
            _ => return None,
        })
    }

    /// The FMI 3.0 element of a type (`Float64`, `Int8`, …; `None` for Binary and Clock).
    fn fmi3(tag: &str) -> Option<(VarType, Repr)> {
        Some(match tag {
            "Float64" => (VarType::Real, Repr::Float64),
            "Float32" => (VarType::Real, Repr::Float32),
            "Int8" => (VarType::Integer, Repr::Int8),
            "Int16" => (VarType::Integer, Repr::Int16),
            "Int32" => (VarType::Integer, Repr::Int32),
            "Int64" => (VarType::Integer, Repr::Int64),
            "UInt8" => (VarType::Integer, Repr::UInt8),
            "UInt16" => (VarType::Integer, Repr::UInt16),
            "UInt32" => (VarType::Integer, Repr::UInt32),
            "UInt64" => (VarType::Integer, Repr::UInt64),
            "Boolean" => (VarType::Boolean, Repr::Boolean),
            "String" => (VarType::String, Repr::String),
            "Enumeration" => (VarType::Enumeration, Repr::Int64),
            "Binary" => (VarType::Other, Repr::Binary),
            "Clock" => (VarType::Other, Repr::Clock),
            _ => return None,
        })
    }

    /// The FMI 2.0 element of a type (`Real`, `Integer`, …).
    fn fmi2(tag: &str) -> Option<(VarType, Repr)> {
        Some(match tag {
            "Real" => (VarType::Real, Repr::Float64),
            "Integer" => (VarType::Integer, Repr::Int32),
            "Boolean" => (VarType::Boolean, Repr::Boolean),
            "String" => (VarType::String, Repr::String),
            "Enumeration" => (VarType::Enumeration, Repr::Int32),
            _ => return None,
        })
    }
}

/// A variable's causality.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub enum VarCausality {
    /// Parameter: settable before initialisation.
    Parameter,
    /// Calculated parameter: computed by the FMU, not settable.
    CalculatedParameter,
    /// Input.
    Input,
    /// Output.
    Output,
    /// Local.
    Local,
    /// The independent variable (time).
    Independent,
    /// FMI 3.0 structural parameter (array sizes, model structure): set in configuration mode.
    StructuralParameter,
}

impl VarCausality {
    fn parse(s: &str) -> Option<VarCausality> {
        Some(match s {
            "parameter" => VarCausality::Parameter,
            "calculatedParameter" => VarCausality::CalculatedParameter,
            "input" => VarCausality::Input,
            "output" => VarCausality::Output,
            "local" => VarCausality::Local,
            "independent" => VarCausality::Independent,
            "structuralParameter" => VarCausality::StructuralParameter,
            _ => return None,
        })
    }
}

/// An item of an enumeration type.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct EnumItem {
    /// Its name.
    pub name: String,
    /// Its value (what `fmi2SetInteger` sets).
    pub value: i64,
}

/// A variable of the FMU.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VarInfo {
    /// The 1-based line of its declaring element in `modelDescription.xml` (0: not parsed
    /// from a file).
    pub line: usize,
    /// The 1-based column of its declaring element on that line (0: not parsed from a file).
    #[serde(skip)]
    pub column: usize,
    /// Its name.
    pub name: String,
    /// Its value reference.
    pub vr: u32,
    /// Its type.
    pub kind: VarType,
    /// The C type of its get/set functions (`Float64` for an FMI 2.0 Real, …).
    pub repr: Repr,
    /// An FMI 3.0 array (it has `<Dimension>` elements): shown, not bound.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub array: bool,
    /// An FMI 3.0 `<Alias>`: the variable it names (this entry has its value reference, type
    /// and bounds, and its own name and description).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub alias_of: Option<String>,
    /// Its causality.
    pub causality: VarCausality,
    /// Its variability as written (`continuous` when not given).
    pub variability: String,
    /// Its `initial` attribute as written (`exact`, `approx`, `calculated`), if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub initial: Option<String>,
    /// Its description, if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// Its start value as written, if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub start: Option<String>,
    /// Its lower bound (its own or its declared type's), if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min: Option<f64>,
    /// Its upper bound, if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max: Option<f64>,
    /// Its unit (its own or its declared type's), if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unit: Option<String>,
    /// Its declared type, if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub declared_type: Option<String>,
    /// An enumeration's items.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub items: Vec<EnumItem>,
}

/// The `CoSimulation` element's attributes.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct CoSimulation {
    /// The shared library's file stem.
    pub model_identifier: String,
    /// `needsExecutionTool`.
    pub needs_execution_tool: bool,
    /// `canHandleVariableCommunicationStepSize`.
    pub can_handle_variable_communication_step_size: bool,
    /// `canInterpolateInputs`.
    pub can_interpolate_inputs: bool,
    /// `canRunAsynchronuously`.
    pub can_run_asynchronuously: bool,
    /// `canBeInstantiatedOnlyOncePerProcess`: savme then runs it in worker processes only.
    pub can_be_instantiated_only_once_per_process: bool,
    /// `canNotUseMemoryManagementFunctions`.
    pub can_not_use_memory_management_functions: bool,
    /// `canGetAndSetFMUstate`.
    pub can_get_and_set_fmu_state: bool,
    /// `canSerializeFMUstate`.
    pub can_serialize_fmu_state: bool,
    /// `providesDirectionalDerivative` (3.0: `providesDirectionalDerivatives`).
    pub provides_directional_derivative: bool,
    /// FMI 3.0 `canReturnEarlyAfterIntermediateUpdate`.
    pub can_return_early_after_intermediate_update: bool,
    /// FMI 3.0 `hasEventMode`.
    pub has_event_mode: bool,
}

/// `DefaultExperiment`.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct DefaultExperiment {
    /// `startTime`.
    pub start_time: Option<f64>,
    /// `stopTime`.
    pub stop_time: Option<f64>,
    /// `tolerance`.
    pub tolerance: Option<f64>,
    /// `stepSize`.
    pub step_size: Option<f64>,
}

/// A parsed `modelDescription.xml`.
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct ModelDescription {
    /// `fmiVersion`.
    pub fmi_version: String,
    /// `modelName`.
    pub model_name: String,
    /// `guid` (FMI 2.0) / `instantiationToken` (FMI 3.0).
    pub guid: String,
    /// `description`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// `generationTool`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub generation_tool: Option<String>,
    /// The co-simulation interface, if declared.
    pub co_simulation: Option<CoSimulation>,
    /// The model-exchange interface's model identifier, if declared.
    pub model_exchange: Option<String>,
    /// The FMI 3.0 scheduled-execution interface's model identifier, if declared.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scheduled_execution: Option<String>,
    /// `DefaultExperiment`.
    pub default_experiment: DefaultExperiment,
    /// The variables in file order.
    pub variables: Vec<VarInfo>,
    /// The value references of the outputs `ModelStructure` lists (FMI 2.0's `Unknown index`
    /// turned into the variable's value reference).
    pub structure_outputs: Vec<u32>,
}

impl ModelDescription {
    /// FMI 3.0 (`fmiVersion` 3.x).
    pub fn is_fmi3(&self) -> bool {
        self.fmi_version.starts_with("3.")
    }
}

/// A type of `TypeDefinitions` (`SimpleType`).
#[derive(Debug, Clone, Default)]
struct SimpleType {
    min: Option<f64>,
    max: Option<f64>,
    unit: Option<String>,
    items: Vec<EnumItem>,
}

/// The attributes of an element, unescaped, by name.
fn attributes(e: &BytesStart) -> Result<HashMap<String, String>, String> {
    let mut out = HashMap::new();
    for a in e.attributes() {
        let a = a.map_err(|e| e.to_string())?;
        let key = String::from_utf8_lossy(a.key.as_ref()).into_owned();
        let value = a.unescape_value().map_err(|e| e.to_string())?.into_owned();
        out.insert(key, value);
    }
    Ok(out)
}

fn flag(a: &HashMap<String, String>, key: &str) -> bool {
    a.get(key).is_some_and(|v| v == "true" || v == "1")
}

fn number(a: &HashMap<String, String>, key: &str, what: &str) -> Result<Option<f64>, String> {
    a.get(key)
        .map(|v| {
            v.trim()
                .parse::<f64>()
                .map_err(|_| format!("{what}: {key}=\"{v}\" is not a number"))
        })
        .transpose()
}

/// What the parser is inside of.
#[derive(Debug, Default)]
struct Parser {
    md: ModelDescription,
    types: HashMap<String, SimpleType>,
    /// The `SimpleType` (2.0) or `…Type` (3.0) being read.
    simple_type: Option<(String, SimpleType)>,
    /// The `ScalarVariable` being read (2.0): its attributes.
    variable: Option<HashMap<String, String>>,
    /// Inside an FMI 3.0 variable element (its `<Start>`, `<Dimension>` and `<Alias>`
    /// children).
    in_variable3: bool,
    /// The `<Alias>` names (and descriptions) of the FMI 3.0 variable being read, added as
    /// variables when it ends.
    aliases: Vec<(String, Option<String>, (usize, usize))>,
    /// Inside `ModelVariables`, `TypeDefinitions`, `ModelStructure/Outputs` (2.0).
    in_variables: bool,
    in_types: bool,
    in_outputs: bool,
    /// `ModelStructure` outputs of FMI 2.0, by 1-based variable index, and of FMI 3.0, by
    /// value reference, each with the line and column of its element (resolved at the end).
    output_indices: Vec<(usize, (usize, usize))>,
    output_references: Vec<(u32, (usize, usize))>,
    seen_root: bool,
    /// The line and column of the element being read, and of the variable being read.
    line: usize,
    column: usize,
    variable_line: usize,
    variable_column: usize,
}

impl Parser {
    // Long because it is the one dispatch over every element of both schemas.
    fn element(&mut self, e: &BytesStart) -> Result<(), String> {
        let name = e.name();
        let name = String::from_utf8_lossy(name.as_ref()).into_owned();
        let a = attributes(e)?;
        let fmi3 = self.md.is_fmi3();
        match name.as_str() {
            "fmiModelDescription" => self.root(&a),
            "CoSimulation" => self.co_simulation(&a),
            "ModelExchange" => {
                self.md.model_exchange = Some(a.get("modelIdentifier").cloned().unwrap_or_default())
            }
            "ScheduledExecution" => {
                self.md.scheduled_execution =
                    Some(a.get("modelIdentifier").cloned().unwrap_or_default())
            }
            "DefaultExperiment" => {
                let d = &mut self.md.default_experiment;
                d.start_time = number(&a, "startTime", "DefaultExperiment")?;
                d.stop_time = number(&a, "stopTime", "DefaultExperiment")?;
                d.tolerance = number(&a, "tolerance", "DefaultExperiment")?;
                d.step_size = number(&a, "stepSize", "DefaultExperiment")?;
            }
            "ModelVariables" => self.in_variables = true,
            "TypeDefinitions" => self.in_types = true,
            "Outputs" => self.in_outputs = true,
            "Unknown" if self.in_outputs => {
                let index = a.get("index").and_then(|i| i.trim().parse::<usize>().ok());
                let index = index.ok_or_else(|| {
                    "ModelStructure: an output Unknown without a valid index".to_string()
                })?;
                self.output_indices.push((index, (self.line, self.column)));
            }
            "Output" if fmi3 => {
                let vr = a.get("valueReference").and_then(|r| r.trim().parse().ok());
                let vr = vr.ok_or_else(|| {
                    "ModelStructure: an Output without a valid valueReference".to_string()
                })?;
                self.output_references.push((vr, (self.line, self.column)));
            }
            "SimpleType" => {
                let n = a.get("name").cloned().unwrap_or_default();
                self.simple_type = Some((n, SimpleType::default()));
            }
            t if fmi3 && self.in_types && t.ends_with("Type") => {
                let n = a.get("name").cloned().unwrap_or_default();
                let st = SimpleType::default();
                self.simple_type = Some((n, st));
                self.bounds(&a)?;
            }
            "Item" => self.item(&a)?,
            "ScalarVariable" => {
                self.variable = Some(a);
                (self.variable_line, self.variable_column) = (self.line, self.column);
            }
            "Start" if self.in_variable3 => {
                if let (Some(v), Some(value)) = (self.md.variables.last_mut(), a.get("value")) {
                    v.start.get_or_insert_with(|| value.clone());
                }
            }
            "Dimension" if self.in_variable3 => {
                if let Some(v) = self.md.variables.last_mut() {
                    v.array = true;
                }
            }
            "Alias" if self.in_variable3 => self.alias(&a)?,
            t if fmi3 && self.in_variables => {
                if let Some((kind, repr)) = Repr::fmi3(t) {
                    (self.variable_line, self.variable_column) = (self.line, self.column);
                    self.push_variable(&a, &a, kind, repr)?;
                    self.in_variable3 = true;
                }
            }
            t if !fmi3 => {
                if let Some((kind, repr)) = Repr::fmi2(t) {
                    self.typed(kind, repr, &a)?;
                }
            }
            _ => {}
        }
        Ok(())
    }

    /// An `Item` of the enumeration type being defined.
    fn item(&mut self, a: &HashMap<String, String>) -> Result<(), String> {
        if let Some((t, st)) = self.simple_type.as_mut() {
            let item = a.get("name").cloned().unwrap_or_default();
            let value = a
                .get("value")
                .and_then(|v| v.trim().parse::<i64>().ok())
                .ok_or_else(|| {
                    format!("type `{t}`, item `{item}`: no integer `value` attribute")
                })?;
            st.items.push(EnumItem { name: item, value });
        }
        Ok(())
    }

    /// An FMI 3.0 `<Alias>` of the variable being read (added when its element ends).
    fn alias(&mut self, a: &HashMap<String, String>) -> Result<(), String> {
        let alias = a.get("name").cloned().ok_or_else(|| {
            let of = self.md.variables.last().map_or("", |v| v.name.as_str());
            format!("variable `{of}`: an Alias without a name")
        })?;
        let at = (self.line, self.column);
        self.aliases
            .push((alias, a.get("description").cloned(), at));
        Ok(())
    }

    fn root(&mut self, a: &HashMap<String, String>) {
        self.seen_root = true;
        self.md.fmi_version = a.get("fmiVersion").cloned().unwrap_or_default();
        self.md.model_name = a.get("modelName").cloned().unwrap_or_default();
        self.md.guid = a
            .get("guid")
            .or_else(|| a.get("instantiationToken"))
            .cloned()
            .unwrap_or_default();
        self.md.description = a.get("description").cloned();
        self.md.generation_tool = a.get("generationTool").cloned();
    }

    fn co_simulation(&mut self, a: &HashMap<String, String>) {
        self.md.co_simulation = Some(CoSimulation {
            model_identifier: a.get("modelIdentifier").cloned().unwrap_or_default(),
            needs_execution_tool: flag(a, "needsExecutionTool"),
            can_handle_variable_communication_step_size: flag(
                a,
                "canHandleVariableCommunicationStepSize",
            ),
            can_interpolate_inputs: flag(a, "canInterpolateInputs"),
            can_run_asynchronuously: flag(a, "canRunAsynchronuously"),
            can_be_instantiated_only_once_per_process: flag(
                a,
                "canBeInstantiatedOnlyOncePerProcess",
            ),
            can_not_use_memory_management_functions: flag(a, "canNotUseMemoryManagementFunctions"),
            can_get_and_set_fmu_state: flag(a, "canGetAndSetFMUstate")
                || flag(a, "canGetAndSetFMUState"),
            can_serialize_fmu_state: flag(a, "canSerializeFMUstate")
                || flag(a, "canSerializeFMUState"),
            provides_directional_derivative: flag(a, "providesDirectionalDerivative")
                || flag(a, "providesDirectionalDerivatives"),
            can_return_early_after_intermediate_update: flag(
                a,
                "canReturnEarlyAfterIntermediateUpdate",
            ),
            has_event_mode: flag(a, "hasEventMode"),
        });
    }

    /// The bounds and unit of the type being defined.
    fn bounds(&mut self, a: &HashMap<String, String>) -> Result<(), String> {
        if let Some((t, st)) = self.simple_type.as_mut() {
            let what = format!("type `{t}`");
            st.min = number(a, "min", &what)?;
            st.max = number(a, "max", &what)?;
            st.unit = a.get("unit").cloned();
        }
        Ok(())
    }

    /// An FMI 2.0 type element: of a `SimpleType` (bounds, unit) or of a `ScalarVariable`.
    fn typed(
        &mut self,
        kind: VarType,
        repr: Repr,
        a: &HashMap<String, String>,
    ) -> Result<(), String> {
        if self.simple_type.is_some() {
            return self.bounds(a);
        }
        let Some(v) = self.variable.take() else {
            return Ok(());
        };
        self.push_variable(&v, a, kind, repr)
    }

    /// A variable: `v` holds its name, value reference, causality and variability (the
    /// `ScalarVariable` in 2.0, the variable element in 3.0), `a` its type's attributes.
    fn push_variable(
        &mut self,
        v: &HashMap<String, String>,
        a: &HashMap<String, String>,
        kind: VarType,
        repr: Repr,
    ) -> Result<(), String> {
        let name = v
            .get("name")
            .cloned()
            .ok_or_else(|| format!("variable #{}: no name", self.md.variables.len() + 1))?;
        let what = format!("variable `{name}`");
        let vr = v
            .get("valueReference")
            .and_then(|r| r.trim().parse::<u32>().ok())
            .ok_or_else(|| format!("{what}: no valid valueReference"))?;
        let causality = match v.get("causality") {
            None => VarCausality::Local,
            Some(c) => VarCausality::parse(c)
                .ok_or_else(|| format!("{what}: unknown causality \"{c}\""))?,
        };
        let declared = a.get("declaredType").and_then(|t| self.types.get(t));
        if kind == VarType::Enumeration && declared.is_none() {
            return Err(format!(
                "{what}: an Enumeration needs a declaredType of TypeDefinitions"
            ));
        }
        let inherited = declared.cloned().unwrap_or_default();
        let default_variability = if kind == VarType::Real || !self.md.is_fmi3() {
            "continuous"
        } else {
            "discrete"
        };
        self.md.variables.push(VarInfo {
            line: self.variable_line,
            column: self.variable_column,
            name,
            vr,
            kind,
            repr,
            array: false,
            alias_of: None,
            causality,
            variability: v
                .get("variability")
                .cloned()
                .unwrap_or_else(|| default_variability.into()),
            initial: v.get("initial").cloned(),
            description: v.get("description").cloned(),
            start: a.get("start").cloned(),
            min: number(a, "min", &what)?.or(inherited.min),
            max: number(a, "max", &what)?.or(inherited.max),
            unit: a.get("unit").cloned().or(inherited.unit),
            declared_type: a.get("declaredType").cloned(),
            items: inherited.items,
        });
        Ok(())
    }

    fn end(&mut self, name: &[u8]) {
        match name {
            b"ModelVariables" => self.in_variables = false,
            b"TypeDefinitions" => self.in_types = false,
            b"Outputs" => self.in_outputs = false,
            b"Start" | b"Dimension" | b"Alias" | b"Annotations" | b"Annotation" | b"Tool" => {}
            _ if self.in_variables && self.md.is_fmi3() => {
                self.in_variable3 = false;
                self.push_aliases();
            }
            _ => {}
        }
        let type_end = name == b"SimpleType" || (self.md.is_fmi3() && name.ends_with(b"Type"));
        if type_end {
            if let Some((n, t)) = self.simple_type.take() {
                self.types.insert(n, t);
            }
        }
    }

    /// The aliases of the FMI 3.0 variable just read: copies of it under their own names.
    fn push_aliases(&mut self) {
        let Some(of) = self.md.variables.last().cloned() else {
            return;
        };
        for (name, description, (line, column)) in std::mem::take(&mut self.aliases) {
            self.md.variables.push(VarInfo {
                name,
                line,
                column,
                description: description.or_else(|| of.description.clone()),
                alias_of: Some(of.name.clone()),
                ..of.clone()
            });
        }
    }

    /// The `ModelStructure` outputs as value references (FMI 2.0's by index): the problems
    /// of those that name no variable, each at its element's line and column.
    fn finish(&mut self) -> Vec<String> {
        let mut problems = Vec::new();
        let fmi2 = std::mem::take(&mut self.output_indices);
        for (i, (line, column)) in fmi2 {
            match i.checked_sub(1).and_then(|k| self.md.variables.get(k)) {
                Some(v) => self.md.structure_outputs.push(v.vr),
                None => problems.push(format!(
                    "line {line}, column {column}: ModelStructure: output index {i} names no variable"
                )),
            }
        }
        // An alias shares its variable's value reference: any one names it.
        let known: std::collections::HashSet<u32> =
            self.md.variables.iter().map(|v| v.vr).collect();
        for (vr, (line, column)) in std::mem::take(&mut self.output_references) {
            if known.contains(&vr) {
                self.md.structure_outputs.push(vr);
            } else {
                problems.push(format!(
                    "line {line}, column {column}: ModelStructure: Output valueReference=\"{vr}\" names no variable"
                ));
            }
        }
        problems
    }
}

/// Lines and columns of byte offsets of one text, read forwards: each byte is looked at once
/// however many positions are asked for (a description of 100,000 variables is not read
/// 100,000 times from its start).
struct Lines<'a> {
    text: &'a str,
    /// The last position asked for, its line, and where that line starts.
    pos: usize,
    line: usize,
    line_start: usize,
}

impl<'a> Lines<'a> {
    fn new(text: &'a str) -> Self {
        Lines {
            text,
            pos: 0,
            line: 1,
            line_start: 0,
        }
    }

    /// The 1-based line and column of byte `pos` (at or after the last one asked for; an
    /// earlier one is counted from the start).
    fn at(&mut self, pos: usize) -> (usize, usize) {
        let pos = pos.min(self.text.len());
        if pos < self.pos {
            *self = Lines::new(self.text);
        }
        let bytes = &self.text.as_bytes()[self.pos..pos];
        for (k, b) in bytes.iter().enumerate() {
            if *b == b'\n' {
                self.line += 1;
                self.line_start = self.pos + k + 1;
            }
        }
        self.pos = pos;
        let column = self
            .text
            .get(self.line_start..pos)
            .map_or(0, |l| l.chars().count())
            + 1;
        (self.line, column)
    }
}

impl ModelDescription {
    /// Parses a `modelDescription.xml`; an error lists what is wrong, one problem per line,
    /// each with its line and column.
    ///
    /// ```
    /// use savme_fmu::description::{ModelDescription, VarType};
    /// let md = ModelDescription::parse(r#"<fmiModelDescription fmiVersion="2.0" modelName="m" guid="g">
    ///   <CoSimulation modelIdentifier="m"/>
    ///   <ModelVariables>
    ///     <ScalarVariable name="v" valueReference="1" causality="parameter" variability="fixed">
    ///       <Real start="5" min="4" max="25" unit="m/s"/>
    ///     </ScalarVariable>
    ///   </ModelVariables>
    /// </fmiModelDescription>"#).unwrap();
    /// assert_eq!(md.variables[0].kind, VarType::Real);
    /// assert_eq!((md.variables[0].min, md.variables[0].max), (Some(4.0), Some(25.0)));
    /// ```
    pub fn parse(xml: &str) -> Result<ModelDescription, String> {
        let (md, problems) = ModelDescription::parse_all(xml)?;
        if problems.is_empty() {
            Ok(md)
        } else {
            Err(problems.join("\n"))
        }
    }

    /// Parses a `modelDescription.xml` as far as it can be read: what could be read and every
    /// problem found (each with its line and column: a bad element, a `ModelStructure` output
    /// naming no variable, a variable declared twice). An error (every problem, one per line)
    /// only when nothing can be read: the text is not well-formed XML or has no
    /// `fmiModelDescription` with an `fmiVersion`.
    pub fn parse_all(xml: &str) -> Result<(ModelDescription, Vec<String>), String> {
        let mut reader = quick_xml::Reader::from_str(xml);
        reader.check_end_names(true);
        let mut p = Parser::default();
        // The open elements, to refuse a document that ends inside one.
        let mut open: Vec<String> = Vec::new();
        let mut lines = Lines::new(xml);
        let place = |(line, column): (usize, usize)| format!("line {line}, column {column}");
        // A bad element is a problem to report, not the end of the reading: every one is
        // listed (each with its line and column), as FMPy's validation lists them.
        let mut problems: Vec<String> = Vec::new();
        loop {
            (p.line, p.column) = lines.at(reader.buffer_position());
            let here = (p.line, p.column);
            let mut checked = |r: Result<(), String>| {
                if let Err(m) = r {
                    problems.push(format!("{}: {m}", place(here)));
                }
            };
            match reader.read_event() {
                Ok(Event::Start(e)) => {
                    checked(p.element(&e));
                    open.push(String::from_utf8_lossy(e.name().as_ref()).into_owned());
                }
                Ok(Event::Empty(e)) => {
                    checked(p.element(&e));
                    p.end(e.name().as_ref());
                }
                Ok(Event::End(e)) => {
                    open.pop();
                    p.end(e.name().as_ref());
                }
                Ok(Event::Eof) => break,
                Ok(_) => {}
                // Not well-formed: nothing after it can be read.
                Err(e) => {
                    let here = lines.at(reader.buffer_position());
                    problems.push(format!("{}: {e}", place(here)));
                    return Err(problems.join("\n"));
                }
            }
        }
        if let Some(unclosed) = open.last() {
            problems.push(format!(
                "{}: premature end of data: the element `{unclosed}` is not closed",
                place(lines.at(xml.len()))
            ));
        }
        if !p.seen_root || p.md.fmi_version.is_empty() {
            problems.push("no fmiModelDescription element with an fmiVersion attribute".into());
            return Err(problems.join("\n"));
        }
        problems.extend(p.finish());
        let mut names: HashMap<&str, &VarInfo> = HashMap::new();
        for v in &p.md.variables {
            if let Some(first) = names.insert(v.name.as_str(), v) {
                problems.push(format!(
                    "line {}, column {}: variable `{}` is declared twice (first at line {}, column {})",
                    v.line, v.column, v.name, first.line, first.column
                ));
            }
        }
        Ok((p.md, problems))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Positions asked for in order are counted on from the last (each byte looked at once);
    /// a column counts characters, not bytes; an earlier position is counted from the start.
    #[test]
    fn lines_and_columns_are_counted_forwards_in_characters() {
        let text = "ab\n\u{3c6}\u{3b8}<x/>\n\n  <y/>";
        let mut lines = Lines::new(text);
        let x = text.find("<x").unwrap();
        let y = text.find("<y").unwrap();
        assert_eq!(lines.at(0), (1, 1));
        assert_eq!(lines.at(x), (2, 3));
        assert_eq!(lines.at(y), (4, 3));
        assert_eq!(lines.pos, y, "counted on from the last position");
        assert_eq!(lines.at(x), (2, 3));
        assert_eq!(lines.at(text.len() + 5), (4, 7));
    }

    /// A large description parses in time linear in its size: 20,000 variables take less than
    /// 3.5 times what 10,000 take (the best of two runs each; lines were counted from the
    /// start for every element: quadratic).
    #[test]
    fn a_large_description_parses_in_linear_time() {
        let description = |n: usize| {
            let mut xml = String::from(
                "<fmiModelDescription fmiVersion=\"2.0\" modelName=\"m\" guid=\"g\">\n<CoSimulation modelIdentifier=\"m\"/>\n<ModelVariables>\n",
            );
            for k in 0..n {
                xml += &format!(
                    "<ScalarVariable name=\"v{k}\" valueReference=\"{k}\" causality=\"parameter\" variability=\"fixed\">\n  <Real start=\"1\"/>\n</ScalarVariable>\n"
                );
            }
            xml + "</ModelVariables>\n</fmiModelDescription>\n"
        };
        let time = |xml: &str| {
            let mut best = f64::INFINITY;
            let mut n = 0;
            for _ in 0..2 {
                let t = std::time::Instant::now();
                n = ModelDescription::parse(xml).unwrap().variables.len();
                best = best.min(t.elapsed().as_secs_f64());
            }
            (best, n)
        };
        let (small, big) = (description(10_000), description(20_000));
        let (a, n) = time(&small);
        let (b, m) = time(&big);
        assert_eq!((n, m), (10_000, 20_000));
        assert!(b < 3.5 * a, "10k variables: {a:.3} s, 20k: {b:.3} s");
    }
}
