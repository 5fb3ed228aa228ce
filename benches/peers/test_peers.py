"""Unit tests of the benchmark's bookkeeping (standard library only, no VerifAI, no build):

    python3 -m unittest discover -s benches/peers -p 'test_*.py'
"""
from __future__ import annotations

import json
import math
import sys
import tempfile
import unittest
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import report  # noqa: E402
import savme_rows  # noqa: E402


def _trial(stage: str, scenario: str, hf_fail: bool, hf_work: int, lf_work: int | None) -> dict:
    lf = None if lf_work is None else {"failure": False, "runtime": 1.0, "work": lf_work}
    return {"stage": stage, "scenario": scenario, "phi": {"x": 1.5},
            "hf": {"failure": hf_fail, "runtime": 1.0, "work": hf_work}, "lf": lf}


def _screen(scenario: str, hf_fail: bool | None, lf_work: int, hf_work: int) -> dict:
    hf = None if hf_fail is None else {"failure": hf_fail, "runtime": 1.0, "work": hf_work}
    return {"stage": "screen@0.3", "scenario": scenario, "phi": {"x": 2.0}, "screen": "pass",
            "lf": {"failure": hf_fail is not None, "runtime": 1.0, "work": lf_work}, "hf": hf}


class SavmeRows(unittest.TestCase):
    def test_search_and_deployment_are_read_with_every_run_charged(self) -> None:
        direct = _screen("b", True, 0, 5)  # HF alone (`--screen-lf where-it-pays`): no LF run
        del direct["lf"]
        direct["screen"] = "direct"
        lines = [
            {"v": 1, "protocol": {"seed": 1}, "c": "00"},  # the store's first record
            _trial("baseline-train", "a", True, 100, None),  # not read
            _trial("train@0.3", "a", True, 10, 3),
            _trial("train@0.3", "b", False, 20, None),
            _screen("a", None, 2, 0),  # an LF pass: LF charged only
            _screen("a", True, 1, 7),  # confirmed
            _screen("b", False, 1, 9),  # a false LF alarm: both charged
            direct,
        ]
        with tempfile.TemporaryDirectory() as d:
            p = Path(d) / "trials.jsonl"
            p.write_text("\n".join(json.dumps(x) for x in lines) + "\n")
            s = savme_rows.read_seed(p, "savme", 1, 0.3)
        self.assertEqual(s.search_work, {"a": 13, "b": 20})
        self.assertEqual([h.failure for h in s.search_hf], [True, False])
        self.assertEqual(s.deployed_work, {"a": 10, "b": 15})
        self.assertEqual([h.failure for h in s.deployed_hf], [True, False, True])
        self.assertEqual(s.deployed_trials, {"a": 2, "b": 2})

    def test_a_campaign_without_work_units_is_refused(self) -> None:
        t = _trial("train@0.3", "a", True, 1, None)
        t["hf"]["work"] = None
        with tempfile.TemporaryDirectory() as d:
            p = Path(d) / "trials.jsonl"
            p.write_text(json.dumps(t) + "\n")
            with self.assertRaises(ValueError):
                savme_rows.read_seed(p, "savme", 1, 0.3)

    def test_variants_parse(self) -> None:
        self.assertEqual(savme_rows.Variant.parse("savme"), savme_rows.Variant("savme", ()))
        v = savme_rows.Variant.parse("joint=--search joint --window 2")
        self.assertEqual(v.flags, ("--search", "joint", "--window", "2"))


class Report(unittest.TestCase):
    def test_rates_are_per_billion_work_units_and_sd_over_seeds(self) -> None:
        def outcome(seed: int, failures: int) -> report.Outcome:
            t = report.Tally(trials=10, failures=failures, work=2 * 10**9,
                             cells={("a", (i,)) for i in range(failures)})
            return report.Outcome("m", seed, {"a": t}, {})
        m = report.metrics([outcome(1, 4), outcome(2, 8)])
        self.assertEqual(m["search_failures"][0], 3.0)
        self.assertAlmostEqual(m["search_failures"][1], math.sqrt(2.0))
        self.assertEqual(m["search_cells"][0], 3.0)
        self.assertTrue(math.isnan(m["deployed_failures"][0]))

    def test_peers_ahead_names_the_metric_and_the_ratio(self) -> None:
        def outcome(method: str, failures: int) -> report.Outcome:
            t = report.Tally(trials=1, failures=failures, work=10**9)
            return report.Outcome(method, 1, {"a": t}, {"a": t})
        lines = report.peers_ahead([outcome("savme", 2), outcome("VerifAI x", 3)], ["savme"])
        self.assertIn("HF failures per cost in the search: VerifAI x 3.0 > savme 2.0 (1.50×)", lines[0])


if __name__ == "__main__":
    unittest.main()
