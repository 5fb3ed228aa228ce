//! `modelDescription.xml` of an FMI 2.0 FMU, read with quick-xml into what savme checks and
//! shows: the co-simulation capabilities, the default experiment, the type definitions
//! (bounds, units, enumeration items) and every scalar variable with its causality, type,
//! start value, `min` / `max`, unit and — for an enumeration — its items.
//!
//! (fmu-runner's parser, used before, keeps none of the bounds, units or enumeration items.)

use quick_xml::events::{BytesStart, Event};
use serde::Serialize;
use std::collections::HashMap;

/// A variable's type.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum VarType {
    /// fmi2Real.
    Real,
    /// fmi2Integer.
    Integer,
    /// fmi2Boolean.
    Boolean,
    /// fmi2String (can be fixed, not searched).
    String,
    /// An enumeration (set through `fmi2SetInteger`, by item value or name).
    Enumeration,
}

/// A variable's causality.
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
            _ => return None,
        })
    }
}

/// An item of an enumeration type.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct EnumItem {
    /// Its name.
    pub name: String,
    /// Its value (what `fmi2SetInteger` sets).
    pub value: i64,
}

/// A variable of the FMU.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VarInfo {
    /// Its name.
    pub name: String,
    /// Its value reference.
    pub vr: u32,
    /// Its type.
    pub kind: VarType,
    /// Its causality.
    pub causality: VarCausality,
    /// Its variability as written (`continuous` when not given).
    pub variability: String,
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
    /// `providesDirectionalDerivative`.
    pub provides_directional_derivative: bool,
}

/// `DefaultExperiment`.
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
    /// `DefaultExperiment`.
    pub default_experiment: DefaultExperiment,
    /// The variables in file order.
    pub variables: Vec<VarInfo>,
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
    /// The `SimpleType` being read.
    simple_type: Option<(String, SimpleType)>,
    /// The `ScalarVariable` being read: its attributes.
    variable: Option<HashMap<String, String>>,
    seen_root: bool,
}

impl Parser {
    fn element(&mut self, e: &BytesStart) -> Result<(), String> {
        let name = e.name();
        let name = String::from_utf8_lossy(name.as_ref()).into_owned();
        let a = attributes(e)?;
        match name.as_str() {
            "fmiModelDescription" => self.root(&a),
            "CoSimulation" => self.co_simulation(&a),
            "ModelExchange" => {
                self.md.model_exchange = Some(a.get("modelIdentifier").cloned().unwrap_or_default())
            }
            "DefaultExperiment" => {
                let d = &mut self.md.default_experiment;
                d.start_time = number(&a, "startTime", "DefaultExperiment")?;
                d.stop_time = number(&a, "stopTime", "DefaultExperiment")?;
                d.tolerance = number(&a, "tolerance", "DefaultExperiment")?;
                d.step_size = number(&a, "stepSize", "DefaultExperiment")?;
            }
            "SimpleType" => {
                let n = a.get("name").cloned().unwrap_or_default();
                self.simple_type = Some((n, SimpleType::default()));
            }
            "Item" => {
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
            }
            "ScalarVariable" => self.variable = Some(a),
            "Real" | "Integer" | "Boolean" | "String" | "Enumeration" => self.typed(&name, &a)?,
            _ => {}
        }
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
            can_get_and_set_fmu_state: flag(a, "canGetAndSetFMUstate"),
            can_serialize_fmu_state: flag(a, "canSerializeFMUstate"),
            provides_directional_derivative: flag(a, "providesDirectionalDerivative"),
        });
    }

    /// A type element: of a `SimpleType` (bounds, unit) or of a `ScalarVariable`.
    fn typed(&mut self, tag: &str, a: &HashMap<String, String>) -> Result<(), String> {
        if let Some((t, st)) = self.simple_type.as_mut() {
            let what = format!("type `{t}`");
            st.min = number(a, "min", &what)?;
            st.max = number(a, "max", &what)?;
            st.unit = a.get("unit").cloned();
            return Ok(());
        }
        let Some(v) = self.variable.take() else {
            return Ok(());
        };
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
        let kind = match tag {
            "Real" => VarType::Real,
            "Integer" => VarType::Integer,
            "Boolean" => VarType::Boolean,
            "String" => VarType::String,
            _ => VarType::Enumeration,
        };
        let declared = a.get("declaredType").and_then(|t| self.types.get(t));
        if kind == VarType::Enumeration && declared.is_none() {
            return Err(format!(
                "{what}: an Enumeration needs a declaredType of TypeDefinitions"
            ));
        }
        let inherited = declared.cloned().unwrap_or_default();
        self.md.variables.push(VarInfo {
            name,
            vr,
            kind,
            causality,
            variability: v
                .get("variability")
                .cloned()
                .unwrap_or_else(|| "continuous".into()),
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
        if name == b"SimpleType" {
            if let Some((n, t)) = self.simple_type.take() {
                self.types.insert(n, t);
            }
        }
    }
}

impl ModelDescription {
    /// Parses a `modelDescription.xml`; an error says what is wrong (and where, for XML
    /// syntax).
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
        let mut reader = quick_xml::Reader::from_str(xml);
        let mut p = Parser::default();
        loop {
            match reader.read_event() {
                Ok(Event::Start(e)) => p.element(&e)?,
                Ok(Event::Empty(e)) => {
                    p.element(&e)?;
                    p.end(e.name().as_ref());
                }
                Ok(Event::End(e)) => p.end(e.name().as_ref()),
                Ok(Event::Eof) => break,
                Ok(_) => {}
                Err(e) => return Err(format!("at byte {}: {e}", reader.buffer_position())),
            }
        }
        if !p.seen_root || p.md.fmi_version.is_empty() {
            return Err("no fmiModelDescription element with an fmiVersion attribute".into());
        }
        let mut names = std::collections::HashSet::new();
        for v in &p.md.variables {
            if !names.insert(v.name.as_str()) {
                return Err(format!("variable `{}` is declared twice", v.name));
            }
        }
        Ok(p.md)
    }
}
