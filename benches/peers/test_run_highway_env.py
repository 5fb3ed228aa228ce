"""Unit tests of run_highway_env.py's bookkeeping (standard library only: numpy, VerifAI's
samplers and highway-env are stand-ins):

    python3 -m unittest discover -s benches/peers -p 'test_*.py'
"""
from __future__ import annotations

import sys
import types
import unittest
from pathlib import Path
from unittest import mock

sys.path.insert(0, str(Path(__file__).resolve().parent))

import run_highway_env  # noqa: E402
from simulator import ScenarioSpace, Variable  # noqa: E402


class _Sample:
    def __init__(self, x: float) -> None:
        self.x = (x,)


class _Sampler:
    """A VerifAI sampler's interface: getSample() → (sample, info); update(sample, info, ρ)."""

    def __init__(self) -> None:
        self.n = 0

    def getSample(self):  # noqa: N802 (VerifAI's name)
        self.n += 1
        return _Sample(0.5), None

    def update(self, sample, info, rho) -> None:
        pass


def _highway_env_stub(work: dict) -> types.ModuleType:
    """savme.integrations.highway_env with a `simulate` whose run costs `work[scenario]`; a run
    fails when φ's x is below 0.25 (never here)."""
    hw = types.ModuleType("savme.integrations.highway_env")
    hw.simulate = lambda scenario, phi: {"failure": phi["x"] < 0.25, "robustness": phi["x"],
                                         "work": work[scenario]}
    savme = types.ModuleType("savme")
    integrations = types.ModuleType("savme.integrations")
    savme.integrations, integrations.highway_env = integrations, hw
    return {"savme": savme, "savme.integrations": integrations,
            "savme.integrations.highway_env": hw}


class PeerSplit(unittest.TestCase):
    def _peer(self, split: str):
        numpy = types.ModuleType("numpy")
        numpy.random = types.SimpleNamespace(seed=lambda s: None)
        domain_sampler = types.ModuleType("verifai.samplers.domain_sampler")
        domain_sampler.TerminationException = type("TerminationException", (Exception,), {})
        verifai = {"verifai": types.ModuleType("verifai"),
                   "verifai.samplers": types.ModuleType("verifai.samplers"),
                   "verifai.samplers.domain_sampler": domain_sampler}
        spaces = [ScenarioSpace(name, i, (Variable("x", 0.0, 1.0, 6),))
                  for i, name in enumerate(["dear", "cheap"])]
        with mock.patch.dict(sys.modules, {"numpy": numpy, **verifai, **_highway_env_stub(
                {"dear": 10, "cheap": 1})}):
            sys.modules.pop("verifai_peers", None)
            import verifai_peers

            with mock.patch.object(verifai_peers, "make_sampler", lambda m, s: _Sampler()):
                return run_highway_env.peer_seed("random", 1, spaces, 200, 100, split)

    def test_equal_work_runs_every_scenario_for_the_same_work_in_each_part(self) -> None:
        search, deployed, _ = self._peer("work")
        for runs, budget in ((search, 200), (deployed, 100)):
            work = {name: sum(r[3] for r in runs if r[0] == name) for name in ("dear", "cheap")}
            self.assertGreaterEqual(sum(work.values()), budget)
            # each scenario within one dear run (10 wu) of the other
            self.assertLessEqual(abs(work["dear"] - work["cheap"]), 10, work)
        self.assertEqual(sum(r[0] == "cheap" for r in search), 100)

    def test_equal_trials_visits_the_scenarios_in_turn(self) -> None:
        search, _, _ = self._peer("trials")
        names = [r[0] for r in search]
        self.assertEqual(names[:4], ["dear", "cheap", "dear", "cheap"])
        self.assertLessEqual(abs(names.count("dear") - names.count("cheap")), 1)


if __name__ == "__main__":
    unittest.main()


class Ratios(unittest.TestCase):
    def test_savme_is_compared_with_the_best_peer_of_each_split_per_metric(self) -> None:
        row = lambda a, b, c: [a, b, c, 100, 1, 1, 0.0]  # noqa: E731
        rows = {"savme": [row(2, 2, 4), row(2, 2, 4)], "bandit": [row(4, 1, 1), row(4, 1, 1)],
                "random": [row(1, 2, 2), row(1, 4, 2)], "random/trials": [row(1, 8, 8)] * 2}
        lines = run_highway_env.ratios(rows)
        self.assertEqual(lines[2], "| savme | equal work | 0.50× (bandit) | 0.67× (random) | 2.00× (random) |")
        self.assertEqual(lines[3], "| savme | equal trials | 2.00× (random) | 0.25× (random) | 0.50× (random) |")
