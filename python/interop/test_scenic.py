"""savme.scenic.ScenicSearch against the installed Scenic: the paired HF/LF search on a Scenic
program run in Scenic's own Newtonian simulator (no external simulator), θ = its time step."""

import math

import pytest

import savme
from savme.scenic import ScenicSearch
from scenic.simulators.newtonian import NewtonianSimulator

from conftest import HERE

FIDELITY = savme.Space([savme.Discrete("timestep", [0.05, 0.2, 0.5])])
CLEARANCE = 1.5  # m between the car's and the pedestrian's centres


class Runs:
    """simulate(scene, θ) for the search: the closest approach Scenic's trajectory shows
    (sampled every time step: a coarse step can miss it), minus the clearance; the cost is the
    number of steps. Remembers which scene each run simulated."""

    def __init__(self):
        self.scenes = []

    def __call__(self, scene, theta):
        self.scenes.append(scene)
        dt = theta["timestep"]
        steps = int(round(5.0 / dt))
        result = NewtonianSimulator().simulate(scene, maxSteps=steps, timestep=dt)
        closest = min(math.dist(ego[:2], ped[:2]) for ego, ped in result.trajectory)
        return closest - CLEARANCE, float(steps)


def exact_closest(phi):
    """The continuous-time closest approach: the car (0, 10t), the pedestrian (x0 − v t, 32.5)."""
    x0, v = phi["ped_start"], phi["ped_speed"]
    # d²(t) = (x0 − v t)² + (10 t − 32.5)², minimised over t in [0, 5].
    t = min(max((x0 * v + 325) / (v * v + 100), 0.0), 5.0)
    return math.hypot(x0 - v * t, 10 * t - 32.5)


def search(program, seed=1, **kw):
    runs = Runs()
    s = ScenicSearch(str(HERE / program), fidelity=FIDELITY, theta_hf={"timestep": 0.05},
                     simulate=runs, budget=0.3, seed=seed, bins=5, **kw)
    return s, runs


def test_the_verifai_parameters_are_phi_and_each_trial_runs_one_scene_twice():
    s, runs = search("crossing.scenic")
    assert s.phi_space.names == ["ped_speed", "ped_start"]
    assert s.phi_space["ped_start"].range == (2.0, 12.0, 5, "linear")
    records = s.run(60)
    assert len(records) == 60 and not s.rejected
    # The HF and LF runs of a trial simulate the same scene (same φ, same random draws).
    assert all(runs.scenes[2 * i] is runs.scenes[2 * i + 1] for i in range(60))
    for r in records:
        assert runs.scenes[2 * records.index(r)].params["ped_start"] == pytest.approx(r.trial.phi["ped_start"])
        # HF (0.05 s: the car moves 0.5 m a step) fails exactly where the closest approach is
        # within the clearance, give or take half a step.
        closest = exact_closest(r.trial.phi)
        if r.hf[0]:
            assert closest < CLEARANCE + 0.3, (r.trial.phi, closest)
        else:
            assert closest > CLEARANCE - 0.3, (r.trial.phi, closest)
        told = r.to_dict()["observation"]["paired"]
        assert told["hf"]["failure"] == (told["hf"]["robustness"] <= 0)


def test_the_search_learns_which_time_step_agrees_and_where_it_fails():
    s, _ = search("crossing.scenic", seed=3)
    s.run(100)
    # 0.2 s costs 0.25 of 0.05 s (within the budget), 0.5 s 0.1; the coarsest steps skip the
    # closest approach (the car passes the pedestrian's line at 3.25 s, between the 0.5 s
    # steps at 3.0 and 3.5 s, 2.5 m away) and pass runs that fail.
    outcomes = [r.outcome for r in s.records]
    assert s.failures() and outcomes.count("FN") > 0
    assert s.kernel.estimate()["timestep"] in (0.2, 0.5)
    s.run(20, phase="evaluate")
    assert s.records[-1].trial.phase == "evaluate"


def test_global_parameters_drawn_from_ranges_are_phi_too():
    s, runs = search("crossing_globals.scenic")
    assert s.phi_space.names == ["ped_speed", "ped_start"]
    records = s.run(8)
    assert len(records) == 8
    for i, r in enumerate(records):
        assert runs.scenes[2 * i].params["ped_speed"] == pytest.approx(r.trial.phi["ped_speed"])


def test_a_program_without_parameters_to_search_is_refused(tmp_path):
    program = tmp_path / "fixed.scenic"
    program.write_text(
        "param render = False\nmodel scenic.simulators.newtonian.model\nego = new Object at (0, 0)\n"
    )
    with pytest.raises(ValueError, match="no parameter to search"):
        ScenicSearch(str(program), fidelity=FIDELITY, theta_hf={"timestep": 0.05}, simulate=Runs())


def test_a_simulation_that_raises_withdraws_its_trial(tmp_path):
    def broken(scene, theta):
        raise RuntimeError("the simulator crashed")

    s, _ = search("crossing.scenic")
    s.simulate = broken
    with pytest.raises(RuntimeError, match="crashed"):
        s.step()
    assert s.kernel.pending() == [] and s.kernel.stats()["told"] == 0
    s.simulate = Runs()
    assert s.step() is not None and s.kernel.stats()["told"] == 1
