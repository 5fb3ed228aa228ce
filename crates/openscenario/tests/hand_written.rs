//! Parameter value distribution files written by hand: every supported element read into the
//! φ-space and nominal it stands for, and every bad file refused naming its line and element.
//! (Files written by a third-party generator: tests/it/openscenario.rs at the workspace root.)

use savme_kernel::estimation::Nominal;
use savme_kernel::{Domain as KDomain, Value};
use savme_openscenario::{Domain, ParameterDistribution, Variation};

/// A file around `body` (the content of `<ParameterValueDistribution>`), its body starting on
/// line 5.
fn file(body: &str) -> String {
    format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<OpenSCENARIO>\n  <FileHeader revMajor=\"1\" revMinor=\"2\" date=\"2024-01-01T00:00:00\" description=\"\" author=\"\"/>\n  <ParameterValueDistribution>\n{body}\n  </ParameterValueDistribution>\n</OpenSCENARIO>\n"
    )
}

fn read(body: &str) -> ParameterDistribution {
    ParameterDistribution::parse(&file(body), "v.xosc").unwrap_or_else(|e| panic!("{e}"))
}

fn error(body: &str) -> String {
    ParameterDistribution::parse(&file(body), "v.xosc")
        .expect_err("a bad file")
        .to_string()
}

#[test]
fn deterministic_sets_and_ranges_become_discrete_variables_with_uniform_nominals() {
    let d = read(
        r#"    <ScenarioFile filepath="cut_in.xosc"/>
    <Deterministic>
      <DeterministicSingleParameterDistribution parameterName="Lane">
        <DistributionSet><Element value="1"/><Element value="2"/><Element value="3"/></DistributionSet>
      </DeterministicSingleParameterDistribution>
      <DeterministicSingleParameterDistribution parameterName="$Speed">
        <DistributionRange stepWidth="2.5"><Range lowerLimit="10" upperLimit="20"/></DistributionRange>
      </DeterministicSingleParameterDistribution>
      <DeterministicSingleParameterDistribution parameterName="Weather">
        <DistributionSet><Element value="dry"/><Element value="rain"/></DistributionSet>
      </DeterministicSingleParameterDistribution>
      <DeterministicSingleParameterDistribution parameterName="Gap">
        <DistributionSet><Element value="0.5"/><Element value="1"/></DistributionSet>
      </DeterministicSingleParameterDistribution>
    </Deterministic>"#,
    );
    assert_eq!(d.variation, Variation::Deterministic);
    assert_eq!(d.scenario_file.as_deref(), Some("cut_in.xosc"));
    let values = |name: &str| match &d.parameter(name).expect(name).domain {
        Domain::Values(v) => v.clone(),
        other => panic!("{other:?}"),
    };
    assert_eq!(
        values("Lane"),
        [Value::Int(1), Value::Int(2), Value::Int(3)]
    );
    let speeds: Vec<f64> = values("Speed").iter().filter_map(Value::as_f64).collect();
    assert_eq!(speeds, [10.0, 12.5, 15.0, 17.5, 20.0]);
    assert_eq!(values("Weather"), [Value::from("dry"), Value::from("rain")]);
    assert_eq!(values("Gap"), [Value::Real(0.5), Value::Real(1.0)]);
    assert!(d.nominal().is_empty(), "{:?}", d.nominal());
    let space = d.space(10).unwrap();
    let names: Vec<&str> = space.variables().iter().map(|v| v.name.as_ref()).collect();
    assert_eq!(names, ["Lane", "Speed", "Weather", "Gap"]);
    assert_eq!(d.parameter("Lane").unwrap().line, 8);
}

#[test]
fn stochastic_distributions_become_ranges_with_their_nominals() {
    let d = read(
        r#"    <Stochastic numberOfTestRuns="50" randomSeed="3">
      <StochasticDistribution parameterName="Speed">
        <NormalDistribution expectedValue="25" variance="16"><Range lowerLimit="15" upperLimit="35"/></NormalDistribution>
      </StochasticDistribution>
      <StochasticDistribution parameterName="Gap">
        <UniformDistribution><Range lowerLimit="5" upperLimit="40"/></UniformDistribution>
      </StochasticDistribution>
      <StochasticDistribution parameterName="Reaction">
        <LogNormalDistribution expectedValue="1.2" variance="0.09"><Range lowerLimit="0.3" upperLimit="3"/></LogNormalDistribution>
      </StochasticDistribution>
      <StochasticDistribution parameterName="Friction">
        <Histogram>
          <Bin weight="1"><Range lowerLimit="0.2" upperLimit="0.5"/></Bin>
          <Bin weight="3"><Range lowerLimit="0.6" upperLimit="1.0"/></Bin>
        </Histogram>
      </StochasticDistribution>
      <StochasticDistribution parameterName="Road">
        <ProbabilityDistributionSet>
          <Element value="dry" weight="0.7"/><Element value="wet" weight="0.3"/>
        </ProbabilityDistributionSet>
      </StochasticDistribution>
      <StochasticDistribution parameterName="Cars">
        <PoissonDistribution expectedValue="2"><Range lowerLimit="0" upperLimit="3"/></PoissonDistribution>
      </StochasticDistribution>
    </Stochastic>"#,
    );
    assert_eq!(
        d.variation,
        Variation::Stochastic {
            runs: Some(50),
            seed: Some(3.0)
        }
    );
    let n = d.nominal();
    assert_eq!(
        n["Speed"],
        Nominal::Normal {
            mean: 25.0,
            sd: 4.0
        }
    );
    assert!(!n.contains_key("Gap"), "uniform is the default nominal");
    // The log-normal's own mean and variance: E = exp(μ + σ²/2), Var = (exp(σ²) − 1)·E².
    let Nominal::LogNormal { mu, sigma } = n["Reaction"] else {
        panic!("{:?}", n["Reaction"])
    };
    let mean = (mu + sigma * sigma / 2.0).exp();
    let var = ((sigma * sigma).exp() - 1.0) * mean * mean;
    assert!((mean - 1.2).abs() < 1e-12 && (var - 0.09).abs() < 1e-12);
    // The gap between the histogram's bins is a bin without mass.
    assert_eq!(
        n["Friction"],
        Nominal::Histogram {
            edges: vec![0.2, 0.5, 0.6, 1.0],
            weights: vec![1.0, 0.0, 3.0]
        }
    );
    assert_eq!(
        d.parameter("Friction").unwrap().domain,
        Domain::Continuous { lo: 0.2, hi: 1.0 }
    );
    assert_eq!(
        n["Road"],
        Nominal::Weights {
            weights: vec![0.7, 0.3]
        }
    );
    let Nominal::Weights { weights } = &n["Cars"] else {
        panic!("{:?}", n["Cars"])
    };
    let expected = [1.0, 2.0, 2.0, 4.0 / 3.0].map(|w| w * (-2.0f64).exp());
    assert!(
        weights
            .iter()
            .zip(expected)
            .all(|(a, b)| (a - b).abs() < 1e-12),
        "{weights:?}"
    );
    let space = d.space(8).unwrap();
    match &space.variable("Speed").unwrap().domain {
        KDomain::Continuous { lo, hi, bins, .. } => assert_eq!((*lo, *hi, *bins), (15.0, 35.0, 8)),
        other => panic!("{other:?}"),
    }
}

/// (body, line, element, words of the message)
const BAD: &[(&str, usize, &str, &str)] = &[
    // A <Range> takes lowerLimit and upperLimit only: another attribute, or a misspelt one,
    // would be ignored.
    (
        r#"    <Deterministic>
      <DeterministicSingleParameterDistribution parameterName="Speed">
        <DistributionRange stepWidth="1">
          <Range lowerLimit="10" upperLimit="20" step="2"/>
        </DistributionRange>
      </DeterministicSingleParameterDistribution>
    </Deterministic>"#,
        8,
        "Range",
        "unknown attribute `step`: a <Range> has `lowerLimit` and `upperLimit` only",
    ),
    (
        r#"    <Stochastic>
      <StochasticDistribution parameterName="Speed">
        <UniformDistribution><Range lowerLimit="10" uperLimit="20"/></UniformDistribution>
      </StochasticDistribution>
    </Stochastic>"#,
        7,
        "Range",
        "unknown attribute `uperLimit`",
    ),
    (
        r#"    <Stochastic>
      <StochasticDistribution parameterName="Speed">
        <NormalDistribution expectedValue="25" variance="16"/>
      </StochasticDistribution>
    </Stochastic>"#,
        7,
        "NormalDistribution",
        "without a <Range>",
    ),
    (
        r#"    <Stochastic>
      <StochasticDistribution parameterName="Speed">
        <NormalDistribution expectedValue="$EgoSpeed" variance="16"><Range lowerLimit="1" upperLimit="2"/></NormalDistribution>
      </StochasticDistribution>
    </Stochastic>"#,
        7,
        "NormalDistribution",
        "parameter reference",
    ),
    (
        r#"    <Stochastic>
      <StochasticDistribution parameterName="Speed">
        <NormalDistribution expectedValue="500" variance="1"><Range lowerLimit="1" upperLimit="2"/></NormalDistribution>
      </StochasticDistribution>
    </Stochastic>"#,
        7,
        "NormalDistribution",
        "of its mass inside [1, 2]",
    ),
    (
        r#"    <Stochastic>
      <StochasticDistribution parameterName="Speed">
        <UniformDistribution>
          <Range lowerLimit="30" upperLimit="20"/>
        </UniformDistribution>
      </StochasticDistribution>
    </Stochastic>"#,
        8,
        "Range",
        "not below upperLimit",
    ),
    (
        r#"    <Stochastic>
      <StochasticDistribution parameterName="Speed">
        <UserDefinedDistribution type="measured">1 2 3</UserDefinedDistribution>
      </StochasticDistribution>
    </Stochastic>"#,
        7,
        "UserDefinedDistribution",
        "cannot be drawn from",
    ),
    (
        r#"    <Stochastic>
      <StochasticDistribution parameterName="Speed">
        <UniformDistribution><Range lowerLimit="1" upperLimit="2"/></UniformDistribution>
      </StochasticDistribution>
      <StochasticDistribution parameterName="Speed">
        <UniformDistribution><Range lowerLimit="1" upperLimit="3"/></UniformDistribution>
      </StochasticDistribution>
    </Stochastic>"#,
        10,
        "UniformDistribution",
        "varies twice (first at line 7)",
    ),
    (
        r#"    <Stochastic>
      <StochasticDistribution parameterName="Road">
        <ProbabilityDistributionSet>
          <Element value="dry" weight="0.7"/>
          <Element value="dry" weight="0.3"/>
        </ProbabilityDistributionSet>
      </StochasticDistribution>
    </Stochastic>"#,
        7,
        "ProbabilityDistributionSet",
        "`Road`",
    ),
    (
        r#"    <Stochastic>
      <StochasticDistribution parameterName="Road">
        <ProbabilityDistributionSet>
          <Element value="dry"/>
        </ProbabilityDistributionSet>
      </StochasticDistribution>
    </Stochastic>"#,
        8,
        "Element",
        "`weight` is missing",
    ),
    (
        r#"    <Stochastic>
      <StochasticDistribution parameterName="Mu">
        <Histogram>
          <Bin weight="1"><Range lowerLimit="0" upperLimit="2"/></Bin>
          <Bin weight="1"><Range lowerLimit="1" upperLimit="3"/></Bin>
        </Histogram>
      </StochasticDistribution>
    </Stochastic>"#,
        9,
        "Bin",
        "must ascend without overlapping",
    ),
    (
        r#"    <Deterministic>
      <DeterministicSingleParameterDistribution parameterName="Speed">
        <DistributionRange stepWidth="0"><Range lowerLimit="1" upperLimit="2"/></DistributionRange>
      </DeterministicSingleParameterDistribution>
    </Deterministic>"#,
        7,
        "DistributionRange",
        "stepWidth 0 is not positive",
    ),
    (
        r#"    <Deterministic>
      <DeterministicMultiParameterDistribution>
        <ValueSetDistribution/>
      </DeterministicMultiParameterDistribution>
    </Deterministic>"#,
        6,
        "DeterministicMultiParameterDistribution",
        "joint value sets",
    ),
    (
        r#"    <Deterministic>
      <DeterministicSingleParameterDistribution>
        <DistributionSet><Element value="1"/></DistributionSet>
      </DeterministicSingleParameterDistribution>
    </Deterministic>"#,
        6,
        "DeterministicSingleParameterDistribution",
        "`parameterName` is missing",
    ),
    (
        "    <Deterministic/>\n    <Stochastic/>",
        6,
        "Stochastic",
        "not both",
    ),
    (
        "    <ScenarioFile filepath=\"x.xosc\"/>",
        4,
        "ParameterValueDistribution",
        "neither <Deterministic> nor <Stochastic>",
    ),
];

#[test]
fn bad_files_are_refused_naming_the_file_line_and_element() {
    for (body, line, element, words) in BAD {
        let m = error(body);
        let at = format!("v.xosc, line {line}, element `{element}`: ");
        assert!(
            m.starts_with(&at) && m.contains(words),
            "expected {at}…{words}…, got {m}"
        );
    }
}

#[test]
fn files_that_are_no_variation_are_refused_naming_what_they_are() {
    let e = ParameterDistribution::parse(
        "<OpenSCENARIO>\n<FileHeader/>\n<Storyboard/>\n</OpenSCENARIO>",
        "s.xosc",
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.starts_with("s.xosc, line 1, element `OpenSCENARIO`: no <ParameterValueDistribution>"),
        "{e}"
    );
    let e = ParameterDistribution::parse("<Model/>", "m.xml")
        .unwrap_err()
        .to_string();
    assert!(e.contains("root element must be <OpenSCENARIO>"), "{e}");
    let e = ParameterDistribution::parse(
        "<OpenSCENARIO>\n<ParameterValueDistribution>\n</OpenSCENARIO>",
        "x.xosc",
    )
    .unwrap_err()
    .to_string();
    assert!(e.starts_with("x.xosc, line 3: "), "{e}");
    let e = ParameterDistribution::read("/nonexistent/v.xosc".as_ref())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("/nonexistent/v.xosc: "), "{e}");
}
