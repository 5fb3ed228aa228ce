"""savme.integrations.highway_env without highway-env: its spaces and problem, and the clear
error when a simulation needs highway-env (tests/it/highway_env.rs runs it on the real thing)."""

import sys

import pytest

import savme
from savme.integrations import highway_env as hw


def test_the_problem_has_the_four_environments_and_theta_hf_is_in_the_fidelity_space():
    problem = hw.problem()
    assert sorted(problem.scenarios) == ["highway", "intersection", "merge", "roundabout"]
    space = hw.fidelity_space()
    assert space.names == [name for name, *_ in hw.FIDELITY_VARIABLES]
    for name, value in hw.THETA_HF.items():
        assert value in space[name].values
    phi = hw.phi_space("highway")
    assert phi["vehicles"].kind == "discrete" and phi["time_gap"].range[:2] == (0.5, 2.5)
    # A kernel accepts the problem's pieces as they are.
    kernel = savme.Kernel(fidelity=space, theta_hf=hw.THETA_HF,
                          scenarios={"merge": hw.phi_space("merge")}, budget=0.3, seed=1)
    trial = kernel.ask()
    assert set(trial.phi) == set(hw.nominal_phi("merge"))


def test_without_highway_env_a_simulation_says_what_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "highway_env", None)  # import highway_env now fails
    with pytest.raises(hw.MissingDependency, match="pip install 'highway-env>=1.12'"):
        hw.simulate("merge", hw.nominal_phi("merge"))
    with pytest.raises(ImportError):  # MissingDependency is an ImportError
        hw.campaign_simulator()("merge", hw.nominal_phi("merge"), dict(hw.THETA_HF))


def test_bad_names_are_refused_before_highway_env_is_needed(monkeypatch):
    monkeypatch.setitem(sys.modules, "highway_env", None)
    with pytest.raises(KeyError, match="unknown highway-env scenario 'parking'.*highway, merge"):
        hw.phi_space("parking")
    with pytest.raises(KeyError, match="φ must set exactly"):
        hw.simulate("merge", {"ego_speed": 25.0})
    with pytest.raises(ValueError, match="cost must be 'work' or 'wall'"):
        hw.campaign_simulator(cost="cpu")
