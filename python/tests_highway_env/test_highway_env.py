"""savme.integrations.highway_env on the real highway-env (run with target/highway-venv, which
scripts/highway-env-venv fills; tests/it/highway_env.rs runs this file). A few dozen runs in all."""

import json
import math
import pathlib
import subprocess
import sys

import pytest

import savme
from savme.integrations import highway_env as hw

REPO = pathlib.Path(__file__).resolve().parents[2]
CHEAP = {"simulation_frequency": 5, "policy_frequency": 1, "lidar_cells": 8, "lidar_range": 30,
         "simulated_vehicles": 4}
# Found with the adapter (seed 0): slow (12 m/s), dense traffic starting close to the ego,
# where the lidar driver crashes at θ_HF; and the same φ at the cheapest θ, where it does not.
CRASH = {"vehicles": 9, "density": 1.44, "ego_spacing": 0.86, "others_speed": 12.36,
         "time_gap": 1.12, "politeness": 0.82}


def test_every_scenario_runs_at_theta_hf_deterministically():
    for scenario in hw.SCENARIOS:
        phi = hw.nominal_phi(scenario)
        first, again = hw.simulate(scenario, phi), hw.simulate(scenario, phi)
        keys = ["failure", "robustness", "min_gap", "min_ttc", "work", "steps", "time"]
        assert {k: first[k] for k in keys} == {k: again[k] for k in keys}, scenario
        assert first["wall_seconds"] > 0 and first["work"] > 0 and first["steps"] > 0
        assert first["failure"] == (first["robustness"] < 0), scenario
        if not first["failure"]:
            assert first["robustness"] == max(first["min_gap"], 0.0)


def test_lower_fidelity_costs_less_work_and_time_is_simulated_the_same():
    phi = hw.nominal_phi("merge")
    hf, lf = hw.simulate("merge", phi), hw.simulate("merge", phi, CHEAP)
    assert lf["work"] * 2 < hf["work"], (lf["work"], hf["work"])
    # A decision every 1/policy_frequency s: 5 Hz at θ_HF, 1 Hz at the cheap θ.
    assert hf["steps"] > 3 * lf["steps"]


def test_a_crash_is_a_failure_with_negative_robustness_and_fidelity_can_flip_it():
    hf = hw.simulate("highway", CRASH)
    assert hf["failure"] and hf["robustness"] <= -1.0 and hf["min_ttc"] < 1.0
    lf = hw.simulate("highway", CRASH, CHEAP)
    assert lf["failure"] != hf["failure"], "the cheapest θ flips this outcome"


def test_the_driver_sees_only_the_lidar():
    """A blind lidar (no returns within its range) makes the driver speed up into traffic."""
    driver = hw.LidarDriver()
    blind = [[30.0, 0.0]] * 8
    assert driver.decide(blind, 20.0, 0.0, ["IDLE", "FASTER", "SLOWER"]) == "FASTER"
    ahead = [[5.0, -10.0]] + [[30.0, 0.0]] * 7
    assert driver.decide(ahead, 20.0, 0.0, ["IDLE", "FASTER", "SLOWER"]) == "SLOWER"
    # Heading south (+y is to the right, π/2): the same return straight ahead is now cell 2.
    south = [[30.0, 0.0]] * 2 + [[5.0, -10.0]] + [[30.0, 0.0]] * 5
    assert driver.decide(south, 20.0, math.pi / 2, ["IDLE", "FASTER", "SLOWER"]) == "SLOWER"
    assert driver.decide(ahead, 20.0, math.pi / 2, ["IDLE", "FASTER", "SLOWER"]) == "FASTER"


def test_bad_phi_and_theta_are_named():
    phi = hw.nominal_phi("merge")
    with pytest.raises(KeyError, match="unknown fidelity setting.*lidar_beams"):
        hw.simulate("merge", phi, {"lidar_beams": 8})
    with pytest.raises(ValueError, match="simulation_frequency must be a positive number"):
        hw.simulate("merge", phi, {"simulation_frequency": 0})
    with pytest.raises(KeyError, match="missing \\['politeness'\\]"):
        hw.simulate("merge", {k: v for k, v in phi.items() if k != "politeness"})
    with pytest.raises(ValueError, match="φ ego_speed must be a finite number"):
        hw.simulate("merge", dict(phi, ego_speed=float("nan")))
    with pytest.raises(KeyError, match="unknown highway-env scenario 'parking'"):
        hw.simulate("parking", phi)


def test_a_small_campaign_runs_through_savmes_loop_and_resumes(tmp_path):
    problem = hw.problem(["merge", "roundabout", "intersection"])
    protocol = savme.Protocol(
        ["merge", "roundabout"], ["intersection"], preset="quick", simulator="highway-env",
        cost="work", budgets=[0.3], train_iterations=8, eval_iterations=2, test_iterations=4,
        baseline_train_iterations=4, baseline_test_iterations=4, seed=3)
    out = tmp_path / "hw"
    result = savme.Campaign(protocol, problem, out=out, jobs=1).run(hw.campaign_simulator())
    assert result.ran == protocol.total_trials and result.replayed == 0
    assert "TP-rate" in result.table_md
    trials = [json.loads(line) for line in (out / "trials.jsonl").read_text().splitlines()]
    trials = [t for t in trials if "protocol" not in t]  # the store's first record
    assert {t["scenario"] for t in trials} == {"merge", "roundabout", "intersection"}
    # cost="work": a run's cost is the adapter's deterministic work count, the same on a rerun.
    # (the first trial with an LF run: scouting runs a scenario's learning trials HF only until
    # its first failure, so a short test phase may have none)
    t = [t for t in trials if t.get("lf")][0]
    hf, lf = hw.simulate(t["scenario"], t["phi"]), hw.simulate(t["scenario"], t["phi"], t["theta_lf"])
    assert (t["hf"]["work"], t["hf"]["failure"]) == (hf["work"], hf["failure"])
    assert (t["lf"]["work"], t["lf"]["failure"]) == (lf["work"], lf["failure"])
    again = savme.Campaign(None, problem, out=out, resume=True, jobs=1).run(hw.campaign_simulator())
    assert again.ran == 0 and again.replayed == protocol.total_trials
    assert again.table_md == result.table_md


def test_the_example_campaign_runs_from_one_command(tmp_path):
    example = REPO / "examples" / "python" / "highway_env" / "campaign.py"
    out = subprocess.run(
        [sys.executable, str(example), "--out", str(tmp_path / "r"), "--iterations", "4",
         "--budgets", "0.3", "--train", "merge", "--test", "roundabout"],
        capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    assert "TP-rate" in out.stdout and (tmp_path / "r" / "summary.json").exists()
