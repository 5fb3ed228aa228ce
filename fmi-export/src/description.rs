//! `modelDescription.xml`: the model's variables, capabilities and structure as FMI 2.0 XML
//! ([`model_description`]) or FMI 3.0 XML ([`model_description3`]) — the same variables,
//! attributes and structure in each version's schema.

use crate::model::{Causality, Kind, Model, Variable};

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The XML declaration and the opening `fmiModelDescription` tag of FMI `version`, the model's
/// GUID as `token` (`guid` in 2.0, `instantiationToken` in 3.0), with `extra` attributes.
fn root<M: Model>(x: &mut String, version: &str, token: &str, extra: &str) {
    x.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    x.push_str(&format!(
        "<fmiModelDescription fmiVersion=\"{version}\" modelName=\"{}\" {token}=\"{}\" \
         description=\"{}\" generationTool=\"savme-fmi-export {}\" \
         variableNamingConvention=\"structured\"{extra}>\n",
        escape(M::MODEL_NAME),
        escape(M::GUID),
        escape(M::DESCRIPTION),
        env!("CARGO_PKG_VERSION"),
    ));
}

/// `DefaultExperiment`, the same in both versions.
fn default_experiment<M: Model>(x: &mut String) {
    let (stop, step) = M::DEFAULT_EXPERIMENT;
    x.push_str(&format!(
        "  <DefaultExperiment startTime=\"0.0\" stopTime=\"{stop:?}\" stepSize=\"{step:?}\"/>\n"
    ));
}

/// The FMI 3.0 `modelDescription.xml` of `M` (for a library exporting `export_fmi3!`): the
/// variables as `<Float64>`, `<Int32>`, `<Boolean>` elements with their value references, plus
/// the independent variable `time` (value reference = the number of variables), and
/// `ModelStructure` as `<Output>` / `<InitialUnknown>` by value reference.
///
/// ```
/// # use savme_fmi_export::{model_description3, Model, Scalar, Variable};
/// # #[derive(Clone)] struct M;
/// # impl Model for M {
/// #     const MODEL_NAME: &'static str = "m"; const MODEL_IDENTIFIER: &'static str = "m";
/// #     const GUID: &'static str = "{g}"; const DESCRIPTION: &'static str = "";
/// #     const DEFAULT_EXPERIMENT: (f64, f64) = (1.0, 0.1);
/// #     fn variables() -> &'static [Variable] {
/// #         static V: std::sync::OnceLock<Vec<Variable>> = std::sync::OnceLock::new();
/// #         V.get_or_init(|| vec![Variable::output("hit", Scalar::Boolean(false), "")])
/// #     }
/// #     fn initialize(_: &mut [Scalar], _: f64) -> Result<Self, String> { Ok(M) }
/// #     fn do_step(&mut self, _: &mut [Scalar], _: f64, _: f64) -> Result<(), String> { Ok(()) }
/// # }
/// let xml = model_description3::<M>();
/// assert!(xml.contains(r#"fmiVersion="3.0""#) && xml.contains(r#"instantiationToken="{g}""#));
/// assert!(xml.contains(r#"<Boolean name="hit" valueReference="0""#));
/// assert!(xml.contains(r#"<Output valueReference="0"/>"#));
/// ```
pub fn model_description3<M: Model>() -> String {
    let mut x = String::new();
    root::<M>(&mut x, "3.0", "instantiationToken", "");
    x.push_str(&format!(
        "  <CoSimulation modelIdentifier=\"{}\" canHandleVariableCommunicationStepSize=\"true\" \
         canGetAndSetFMUState=\"true\" canSerializeFMUState=\"false\" \
         providesDirectionalDerivatives=\"false\" providesAdjointDerivatives=\"false\" \
         hasEventMode=\"false\" canReturnEarlyAfterIntermediateUpdate=\"false\"/>\n",
        escape(M::MODEL_IDENTIFIER)
    ));
    unit_definitions(&mut x, M::variables());
    default_experiment::<M>(&mut x);
    x.push_str("  <ModelVariables>\n");
    x.push_str(&format!(
        "    <Float64 name=\"time\" valueReference=\"{}\" causality=\"independent\" \
         variability=\"continuous\" description=\"simulation time\"/>\n",
        M::variables().len()
    ));
    for (r, v) in M::variables().iter().enumerate() {
        let a = attributes(v);
        let tag = match v.start.kind() {
            Kind::Real => "Float64",
            Kind::Integer => "Int32",
            Kind::Boolean => "Boolean",
        };
        x.push_str(&format!(
            "    <{tag} name=\"{}\" valueReference=\"{r}\" description=\"{}\" \
             causality=\"{}\" variability=\"{}\" initial=\"{}\"{}/>\n",
            escape(&v.name),
            escape(&v.description),
            a.causality,
            a.variability,
            a.initial,
            a.type_attributes
        ));
    }
    x.push_str("  </ModelVariables>\n  <ModelStructure>\n");
    let outputs = outputs(M::variables());
    for (element, r) in ["Output", "InitialUnknown"]
        .iter()
        .flat_map(|e| outputs.iter().map(move |r| (e, r)))
    {
        x.push_str(&format!("    <{element} valueReference=\"{r}\"/>\n"));
    }
    x.push_str("  </ModelStructure>\n</fmiModelDescription>\n");
    x
}

/// The value references of the outputs.
fn outputs(variables: &[Variable]) -> Vec<usize> {
    variables
        .iter()
        .enumerate()
        .filter(|(_, v)| v.causality == Causality::Output)
        .map(|(r, _)| r)
        .collect()
}

/// A variable's attributes, the same in both versions.
struct Attributes {
    causality: &'static str,
    variability: &'static str,
    initial: &'static str,
    /// ` unit="…" min="…" max="…" start="…"` as they apply.
    type_attributes: String,
}

fn attributes(v: &Variable) -> Attributes {
    let (causality, variability, initial) = match (v.causality, v.start.kind()) {
        (Causality::Parameter, _) => ("parameter", "fixed", "exact"),
        (Causality::Output, Kind::Real) => ("output", "continuous", "calculated"),
        (Causality::Output, _) => ("output", "discrete", "calculated"),
    };
    let mut attrs = String::new();
    if let (Some(u), Kind::Real) = (v.unit, v.start.kind()) {
        attrs.push_str(&format!(" unit=\"{}\"", escape(u)));
    }
    if v.start.kind() != Kind::Boolean {
        let num = |y: f64| match v.start.kind() {
            Kind::Integer => format!("{}", y as i64),
            _ => format!("{y:?}"),
        };
        if let Some(m) = v.min {
            attrs.push_str(&format!(" min=\"{}\"", num(m)));
        }
        if let Some(m) = v.max {
            attrs.push_str(&format!(" max=\"{}\"", num(m)));
        }
    }
    if v.causality == Causality::Parameter {
        attrs.push_str(&format!(" start=\"{}\"", v.start.xml()));
    }
    Attributes {
        causality,
        variability,
        initial,
        type_attributes: attrs,
    }
}

/// The `modelDescription.xml` of `M`.
pub fn model_description<M: Model>() -> String {
    let mut x = String::new();
    header::<M>(&mut x);
    unit_definitions(&mut x, M::variables());
    default_experiment::<M>(&mut x);
    x.push_str("  <ModelVariables>\n");
    for (r, v) in M::variables().iter().enumerate() {
        scalar_variable(&mut x, r, v);
    }
    x.push_str("  </ModelVariables>\n");
    model_structure(&mut x, M::variables());
    x.push_str("</fmiModelDescription>\n");
    x
}

/// The XML declaration, the opening `fmiModelDescription` tag and the `CoSimulation`
/// capabilities.
fn header<M: Model>(x: &mut String) {
    root::<M>(x, "2.0", "guid", " numberOfEventIndicators=\"0\"");
    x.push_str(&format!(
        "  <CoSimulation modelIdentifier=\"{}\" canHandleVariableCommunicationStepSize=\"true\" \
         canGetAndSetFMUstate=\"true\" canSerializeFMUstate=\"false\" \
         providesDirectionalDerivative=\"false\" canInterpolateInputs=\"false\" \
         canNotUseMemoryManagementFunctions=\"true\"/>\n",
        escape(M::MODEL_IDENTIFIER)
    ));
}

/// `UnitDefinitions`: every unit used, sorted, once (nothing if no variable has a unit).
fn unit_definitions(x: &mut String, variables: &[Variable]) {
    let mut units: Vec<&str> = variables.iter().filter_map(|v| v.unit).collect();
    units.sort_unstable();
    units.dedup();
    if !units.is_empty() {
        x.push_str("  <UnitDefinitions>\n");
        for u in &units {
            x.push_str(&format!("    <Unit name=\"{}\"/>\n", escape(u)));
        }
        x.push_str("  </UnitDefinitions>\n");
    }
}

/// The `ScalarVariable` of value reference `r`.
fn scalar_variable(x: &mut String, r: usize, v: &Variable) {
    let a = attributes(v);
    x.push_str(&format!(
        "    <ScalarVariable name=\"{}\" valueReference=\"{r}\" description=\"{}\" \
         causality=\"{}\" variability=\"{}\" initial=\"{}\">\n",
        escape(&v.name),
        escape(&v.description),
        a.causality,
        a.variability,
        a.initial
    ));
    let tag = match v.start.kind() {
        Kind::Real => "Real",
        Kind::Integer => "Integer",
        Kind::Boolean => "Boolean",
    };
    x.push_str(&format!(
        "      <{tag}{}/>\n    </ScalarVariable>\n",
        a.type_attributes
    ));
}

/// `ModelStructure`: every output is an output and an initial unknown, depending on nothing.
fn model_structure(x: &mut String, variables: &[Variable]) {
    x.push_str("  <ModelStructure>\n    <Outputs>\n");
    let outputs: Vec<usize> = outputs(variables).iter().map(|r| r + 1).collect();
    for i in &outputs {
        x.push_str(&format!(
            "      <Unknown index=\"{i}\" dependencies=\"\"/>\n"
        ));
    }
    x.push_str("    </Outputs>\n    <InitialUnknowns>\n");
    for i in &outputs {
        x.push_str(&format!(
            "      <Unknown index=\"{i}\" dependencies=\"\"/>\n"
        ));
    }
    x.push_str("    </InitialUnknowns>\n  </ModelStructure>\n");
}
