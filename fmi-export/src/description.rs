//! `modelDescription.xml`: the model's variables, capabilities and structure as FMI 2.0 XML.

use crate::model::{Causality, Kind, Model, Variable};

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The `modelDescription.xml` of `M`.
pub fn model_description<M: Model>() -> String {
    let mut x = String::new();
    header::<M>(&mut x);
    unit_definitions(&mut x, M::variables());
    let (stop, step) = M::DEFAULT_EXPERIMENT;
    x.push_str(&format!(
        "  <DefaultExperiment startTime=\"0.0\" stopTime=\"{stop:?}\" stepSize=\"{step:?}\"/>\n"
    ));
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
    x.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    x.push_str(&format!(
        "<fmiModelDescription fmiVersion=\"2.0\" modelName=\"{}\" guid=\"{}\" description=\"{}\" \
         generationTool=\"savme-fmi-export {}\" variableNamingConvention=\"structured\" \
         numberOfEventIndicators=\"0\">\n",
        escape(M::MODEL_NAME),
        escape(M::GUID),
        escape(M::DESCRIPTION),
        env!("CARGO_PKG_VERSION"),
    ));
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
    let (causality, variability, initial) = match (v.causality, v.start.kind()) {
        (Causality::Parameter, _) => ("parameter", "fixed", "exact"),
        (Causality::Output, Kind::Real) => ("output", "continuous", "calculated"),
        (Causality::Output, _) => ("output", "discrete", "calculated"),
    };
    x.push_str(&format!(
        "    <ScalarVariable name=\"{}\" valueReference=\"{r}\" description=\"{}\" \
         causality=\"{causality}\" variability=\"{variability}\" initial=\"{initial}\">\n",
        escape(&v.name),
        escape(&v.description)
    ));
    let tag = match v.start.kind() {
        Kind::Real => "Real",
        Kind::Integer => "Integer",
        Kind::Boolean => "Boolean",
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
    x.push_str(&format!("      <{tag}{attrs}/>\n    </ScalarVariable>\n"));
}

/// `ModelStructure`: every output is an output and an initial unknown, depending on nothing.
fn model_structure(x: &mut String, variables: &[Variable]) {
    x.push_str("  <ModelStructure>\n    <Outputs>\n");
    let outputs: Vec<usize> = variables
        .iter()
        .enumerate()
        .filter(|(_, v)| v.causality == Causality::Output)
        .map(|(r, _)| r + 1)
        .collect();
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
