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
import run  # noqa: E402
import savme_rows  # noqa: E402
import simulator  # noqa: E402


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

    def test_the_protocol_record_heading_a_campaign_is_skipped(self) -> None:
        lines = [{"v": 1, "protocol": {"seed": 1}, "c": "x"}, _trial("train@0.3", "a", True, 10, 3)]
        with tempfile.TemporaryDirectory() as d:
            p = Path(d) / "trials.jsonl"
            p.write_text("\n".join(json.dumps(x) for x in lines) + "\n")
            s = savme_rows.read_seed(p, "savme", 1, 0.3)
        self.assertEqual(s.search_work, {"a": 13})

    def test_a_campaign_file_runs_savme_run_with_the_same_protocol_values(self) -> None:
        v = savme_rows.Variant.parse("e=--search elite --window 1")
        bundled = savme_rows.Protocol((1, 2, 3), 500, 300, 0.3, ("7", "5"), 2)
        filed = savme_rows.Protocol((1, 2, 3), 500, 300, 0.3, ("7", "5"), 2, Path("c.toml"))
        a = savme_rows.command(Path("savme"), v, bundled, Path("out"))
        b = savme_rows.command(Path("savme"), v, filed, Path("out"))
        self.assertEqual(a[:6], ["savme", "reproduce", "--cost", "work", "--perception", "sensors"])
        self.assertEqual(b[:6], ["savme", "run", "--config", "c.toml", "--cost", "work"])
        self.assertEqual(a[6:], b[6:])  # every protocol value and the variant's flags, alike
        self.assertIn("--train-scenarios", b)
        self.assertEqual(b[b.index("--train-scenarios") + 1], "7,5")
        self.assertEqual(b[-4:], ["--search", "elite", "--window", "1"])
        self.assertEqual(savme_rows.resume_command(Path("savme"), filed, Path("o"))[:6],
                         ["savme", "run", "--config", "c.toml", "--resume", "o"])
        self.assertEqual(savme_rows.resume_command(Path("savme"), bundled, Path("o"))[:4],
                         ["savme", "reproduce", "--resume", "o"])

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


class Backends(unittest.TestCase):
    def test_a_run_answer_needs_rho_below_zero_exactly_on_a_failure(self) -> None:
        a = {"scenario": "dry_road", "arms": [9, 0], "failure": True, "rho": -1.0, "work": 41}
        r = simulator.parse_run("dry_road", {"speed0": 25.0}, a)
        self.assertEqual((r.failure, r.rho, r.work, r.arms), (True, -1.0, 41, (9, 0)))
        for bad in ({**a, "rho": 0.0}, {**a, "failure": False}, {**a, "work": None}):
            with self.assertRaises(ValueError):
                simulator.parse_run("dry_road", {}, bad)

    def test_a_refusing_or_exiting_simulator_process_is_a_simulator_error_naming_it(self) -> None:
        refuses = "import sys; sys.stdin.readline(); print('{\"error\": \"unknown scenario `x`\"}', flush=True)"
        with simulator.Simulator([sys.executable, "-c", refuses]) as sim:
            with self.assertRaisesRegex(simulator.SimulatorError, "unknown scenario `x`"):
                sim.space("x")
        exits = "import sys; sys.stderr.write('bad file\\n'); sys.exit(2)"
        with simulator.Simulator([sys.executable, "-c", exits]) as sim:
            with self.assertRaisesRegex(simulator.SimulatorError, "exited \\(status 2"):
                sim.sets()

    def test_the_two_back_ends_start_their_processes(self) -> None:
        d = simulator.Backend.driving(Path("peers_sim"))
        self.assertEqual((d.tag, d.sim_command, d.config), ("", ("peers_sim",), None))
        c = simulator.Backend.campaign(Path("peers_fmu"), Path("x/braking/campaign.toml"), "distance")
        self.assertEqual(c.sim_command, ("peers_fmu", "x/braking/campaign.toml", "--rho-output", "distance"))
        self.assertEqual(c.tag, "braking")
        self.assertEqual(simulator.campaign_tag(Path("x/other.toml")), "other")
        self.assertEqual(simulator.Backend.campaign(Path("f"), Path("c.toml"), None).sim_command, ("f", "c.toml"))

    def test_scenario_sets_come_from_the_process_and_quick_only_narrows_the_bundled_one(self) -> None:
        sets = simulator.Sets(("dry_road", "wet_road"), ("icy_road",), "fmu:…", "…")
        self.assertEqual(run.scenario_keys("train", True, sets, False), ("dry_road", "wet_road"))
        self.assertEqual(run.scenario_keys("test", False, sets, False), ("icy_road",))
        self.assertEqual(run.scenario_keys("wet_road, dry_road", False, sets, False), ("wet_road", "dry_road"))
        driving = simulator.Sets(tuple("12345678"), ("9", "10"), "savme-sim/sensors", "…")
        self.assertEqual(run.scenario_keys("train", True, driving, True), run.QUICK_SCENARIOS)
        self.assertEqual(run.scenario_keys("train", False, driving, True), tuple("12345678"))


class Report(unittest.TestCase):
    def test_the_unit_is_the_largest_power_of_a_thousand_the_smallest_budget_reaches(self) -> None:
        self.assertEqual(report.unit([5.9e9, 2.2e9, 1.3e9]), 1e9)
        self.assertEqual(report.unit([64_000, 26_000]), 1e3)
        self.assertEqual(report.unit([3e6, 0]), 1e6)  # a zero budget (no deployed part) is not a size
        self.assertEqual(report.unit([]), 1e9)
        t = report.Tally(trials=4, failures=2, work=4000, cells={("a", (1,)), ("a", (2,))})
        table = report.main_table([report.Outcome("m", 1, {"a": t}, {})], 1e3)
        self.assertIn("HF failures / 10³ wu, search", table)
        self.assertIn("| m | 0.50 | 0.50 |", table)  # two decimals below 10⁹ wu


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


    def test_families_compare_with_the_best_peer_per_metric_and_the_worst_scenario(self) -> None:
        import families

        def row(method: str, a: int, b: int, deployed: int) -> dict:
            part = {"a": {"failures": a, "work": 100, "cells": a}, "b": {"failures": b, "work": 100, "cells": b}}
            return {"method": method, "seed": 1, "search": part,
                    "deployed": {"a": {"failures": deployed, "work": 50, "cells": 0}}}

        rows = [row("savme", 8, 1, 10), row("VerifAI x", 2, 4, 5), row("VerifAI y", 4, 2, 1)]
        f = families.family(rows, "savme")
        mine, peer, theirs = f["HF failures / wu, search"]
        self.assertEqual((mine, peer, theirs), (9 / 200, "VerifAI x", 6 / 200))
        self.assertEqual(f["confirmed failures / wu, deployed"][1], "VerifAI x")
        ratio, scenario, best = f["worst scenario"]
        self.assertEqual((scenario, best), ("b", "VerifAI x"))
        self.assertAlmostEqual(ratio, 0.25)

    def test_families_compare_with_the_peers_of_the_split_asked_for(self) -> None:
        import families

        def row(method: str, a: int) -> dict:
            part = {"a": {"failures": a, "work": 100, "cells": a}}
            return {"method": method, "seed": 1, "search": part, "deployed": part}

        rows = [row("savme", 4), row("VerifAI x", 2), row("VerifAI x, by trials", 8)]
        self.assertEqual(families.family(rows, "savme", "work")["HF failures / wu, search"][1], "VerifAI x")
        by_trials = families.family(rows, "savme", "trials")["HF failures / wu, search"]
        self.assertEqual(by_trials, (0.04, "VerifAI x, by trials", 0.08))
        table = families.ratio_table([("f", rows)], "savme", "trials")
        self.assertIn("| f | 0.50× (x) |", table)
        with self.assertRaises(SystemExit):  # no peer of that split: said, not a wrong table
            families.family([row("savme", 4), row("VerifAI x", 2)], "savme", "trials")


class PeerSplit(unittest.TestCase):
    def test_both_splits_are_accepted_and_named(self) -> None:
        import argparse

        self.assertEqual(run.peer_splits("work,trials"), ("work", "trials"))
        self.assertEqual(run.peer_splits("trials"), ("trials",))
        with self.assertRaises(argparse.ArgumentTypeError):
            run.peer_splits("work,cost")
        self.assertEqual(run.peer_label("bandit", "work"), "VerifAI bandit")
        self.assertEqual(run.peer_label("bandit", "trials"), "VerifAI bandit, by trials")


if __name__ == "__main__":
    unittest.main()
