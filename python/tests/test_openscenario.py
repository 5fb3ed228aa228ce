"""savme.openscenario: a hand-written OpenSCENARIO parameter variation as a kernel's φ-space
and an estimation's nominal; a bad file refused naming its line and element. (Files written
by scenariogeneration are tested in tests/it/openscenario.rs.)"""

import math

import pytest

import savme

VARIATION = """<?xml version="1.0" encoding="UTF-8"?>
<OpenSCENARIO>
  <FileHeader revMajor="1" revMinor="2" date="2024-01-01T00:00:00" description="cut-in" author="me"/>
  <ParameterValueDistribution>
    <ScenarioFile filepath="cut_in.xosc"/>
    <Stochastic numberOfTestRuns="100" randomSeed="5">
      <StochasticDistribution parameterName="EgoSpeed">
        <NormalDistribution expectedValue="25" variance="16">
          <Range lowerLimit="15" upperLimit="35"/>
        </NormalDistribution>
      </StochasticDistribution>
      <StochasticDistribution parameterName="Road">
        <ProbabilityDistributionSet>
          <Element value="dry" weight="3"/>
          <Element value="wet" weight="1"/>
        </ProbabilityDistributionSet>
      </StochasticDistribution>
    </Stochastic>
  </ParameterValueDistribution>
</OpenSCENARIO>
"""


def test_a_variation_is_a_space_and_a_nominal_the_estimation_weighs_by(tmp_path):
    path = tmp_path / "cut_in_variation.xosc"
    path.write_text(VARIATION)
    v = savme.openscenario.read(path)
    assert (v.variation, v.number_of_test_runs, v.scenario_file) == ("stochastic", 100, "cut_in.xosc")
    assert v.names == ["EgoSpeed", "Road"]
    assert v.declared_at["EgoSpeed"] == {"element": "NormalDistribution", "line": 8}
    space = v.space(bins=5)
    assert space["EgoSpeed"].range == (15.0, 35.0, 5, "linear") and space["Road"].values == ["dry", "wet"]
    assert v.nominal == {
        "EgoSpeed": {"distribution": "normal", "mean": 25.0, "sd": 4.0},
        "Road": {"distribution": "weights", "weights": [3.0, 1.0]},
    }
    k = savme.Kernel(
        fidelity=savme.Space([savme.Discrete("rate", [1, 10])]),
        theta_hf={"rate": 10},
        scenarios={"cut_in": space},
        seed=2,
    )
    est = k.estimation(epsilon=1.0, seed=4, nominal={"cut_in": v.nominal})
    roads = []
    for _ in range(4000):
        t = est.ask()
        roads.append(t["phi"]["Road"])
        # p(φ) = truncated normal density × the road's probability.
        speed = t["phi"]["EgoSpeed"]
        mass = math.erf(10 / (4 * math.sqrt(2)))
        pdf = math.exp(-((speed - 25) ** 2) / 32) / (4 * math.sqrt(2 * math.pi)) / mass
        assert t["p"] == pytest.approx(pdf * (0.75 if t["phi"]["Road"] == "dry" else 0.25))
        est.tell(t["id"], speed > 30)
    assert roads.count("dry") / len(roads) == pytest.approx(0.75, abs=0.03)
    # P(speed > 30) under the truncated normal: (Φ(2.5) − Φ(1.25)) / (Φ(2.5) − Φ(−2.5)).
    phi = lambda z: 0.5 * (1 + math.erf(z / math.sqrt(2)))
    exact = (phi(2.5) - phi(1.25)) / (phi(2.5) - phi(-2.5))
    total = est.estimate()["total"]
    assert total["lo"] <= exact <= total["hi"], (total, exact)


def test_a_bad_file_raises_value_error_naming_file_line_and_element(tmp_path):
    path = tmp_path / "bad.xosc"
    path.write_text(VARIATION.replace('<Range lowerLimit="15" upperLimit="35"/>', ""))
    with pytest.raises(ValueError) as e:
        savme.openscenario.read(path)
    assert str(e.value).startswith(f"{path}, line 8, element `NormalDistribution`: a normal distribution without a <Range>")
    with pytest.raises(ValueError, match="no <ParameterValueDistribution>"):
        (tmp_path / "scenario.xosc").write_text("<OpenSCENARIO><Storyboard/></OpenSCENARIO>")
        savme.openscenario.read(tmp_path / "scenario.xosc")
