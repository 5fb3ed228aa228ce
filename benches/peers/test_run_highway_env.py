"""Unit tests of run_highway_env.py's bookkeeping (standard library only: numpy, VerifAI's
samplers and highway-env are stand-ins):

    python3 -m unittest discover -s benches/peers -p 'test_*.py'
"""
from __future__ import annotations

import datetime as dt
import json
import sys
import tempfile
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
    def _peer(self, split: str, progress=None):
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
                return run_highway_env.peer_seed("random", 1, spaces, 200, 100, split, progress)

    def test_equal_work_runs_every_scenario_for_the_same_work_in_each_part(self) -> None:
        search, deployed, _ = self._peer("work")
        for runs, budget in ((search, 200), (deployed, 100)):
            work = {name: sum(r[3] for r in runs if r[0] == name) for name in ("dear", "cheap")}
            self.assertGreaterEqual(sum(work.values()), budget)
            # each scenario within one dear run (10 wu) of the other
            self.assertLessEqual(abs(work["dear"] - work["cheap"]), 10, work)
        self.assertEqual(sum(r[0] == "cheap" for r in search), 100)

    def test_progress_sees_the_runs_so_far_and_a_partial_file_holds_them(self) -> None:
        seen = []
        with tempfile.TemporaryDirectory() as d:
            path = Path(d) / "p.partial.json"
            partial = run_highway_env.Partial(path, "random", 1, "t0", (200, 100))

            def progress(parts):
                seen.append([len(p) for p in parts])
                partial(parts)

            search, deployed, _ = self._peer("work", progress)
            saved = json.loads(path.read_text())
        self.assertEqual(seen[0], [1])
        self.assertEqual(seen[-1], [len(search), len(deployed)])
        # written at the first run and when the deployed part began (30 s apart otherwise)
        self.assertEqual((saved["row"], len(saved["search"]), len(saved["deployed"])),
                         ("random", len(search), 1))

    def test_equal_trials_visits_the_scenarios_in_turn(self) -> None:
        search, _, _ = self._peer("trials")
        names = [r[0] for r in search]
        self.assertEqual(names[:4], ["dear", "cheap", "dear", "cheap"])
        self.assertLessEqual(abs(names.count("dear") - names.count("cheap")), 1)


class Ratios(unittest.TestCase):
    def test_savme_is_compared_with_the_best_peer_of_each_split_per_metric(self) -> None:
        row = lambda a, b, c: [a, b, c, 100, 1, 1, 0.0]  # noqa: E731
        rows = {"savme": [row(2, 2, 4), row(2, 2, 4)], "bandit": [row(4, 1, 1), row(4, 1, 1)],
                "random": [row(1, 2, 2), row(1, 4, 2)], "random/trials": [row(1, 8, 8)] * 2}
        lines = run_highway_env.ratios(rows)
        self.assertEqual(lines[2], "| savme | equal work | 0.50× (bandit) | 0.67× (random) | 2.00× (random) |")
        self.assertEqual(lines[3], "| savme | equal trials | 2.00× (random) | 0.25× (random) | 0.50× (random) |")


def _write_runs(out: Path) -> None:
    """Three rows of one seed in runs/ and rows.jsonl, as run_rows writes them."""
    (out / "runs").mkdir(parents=True)
    run = lambda sc, x, fail, work: [sc, {"x": x}, fail, work, work, 0]  # noqa: E731
    rows = {
        "savme": ("22:00:00", "22:05:00", [run("dear", 0.05, True, 10), run("dear", 0.06, True, 10),
                                           run("cheap", 0.9, False, 1)], [run("dear", 0.1, True, 10)]),
        "bayesopt": ("22:05:00", "23:35:30", [run("cheap", 0.5, False, 1), run("dear", 0.95, True, 10)],
                     []),
        "bayesopt/trials": ("22:06:00", "22:07:00", [run("cheap", 0.01, True, 1)], []),
    }
    for row, (a, b, search, deployed) in rows.items():
        (out / "runs" / f"{row.replace('/', '-')}-seed-1.json").write_text(json.dumps(
            {"row": row, "seed": 1, "wall_s": 1.0, "cpu_s": 1.0, "started": f"2026-11-29T{a}+00:00",
             "finished": f"2026-11-29T{b}+00:00", "search": search, "deployed": deployed}))
    # a row in progress: its partial file is not a row
    (out / "runs" / "random-seed-1.partial.json").write_text(json.dumps(
        {"row": "random", "seed": 1, "search": [run("dear", 0.5, True, 10)], "deployed": []}))
    with open(out / "rows.jsonl", "w") as f:
        for row in rows:
            f.write(json.dumps({"method": row, "seed": 1, "row": [0, 0, 0, 1, 1, 1, 0.5]}) + "\n")


class Outputs(unittest.TestCase):
    SPACES = [ScenarioSpace(name, i, (Variable("x", 0.0, 1.0, 6),)) for i, name in enumerate(["dear", "cheap"])]

    def test_outcomes_are_run_py_s_per_method_seed_part_and_scenario(self) -> None:
        with tempfile.TemporaryDirectory() as d, \
                mock.patch.object(run_highway_env, "spaces", lambda names: self.SPACES):
            out = Path(d)
            _write_runs(out)
            args = types.SimpleNamespace(scenarios=["dear", "cheap"])
            got = {o["method"]: o for o in run_highway_env.outcomes(args, out)}
        self.assertEqual(sorted(got), ["VerifAI bayesopt", "VerifAI bayesopt, by trials", "savme"])
        savme = got["savme"]
        # two failures at x 0.05 and 0.06: one cell of 6 bins; the pass costs its work too
        self.assertEqual(savme["search"]["dear"], {"trials": 2, "failures": 2, "work": 20, "cells": 1})
        self.assertEqual(savme["search"]["cheap"], {"trials": 1, "failures": 0, "work": 1, "cells": 0})
        self.assertEqual(savme["deployed"]["dear"]["failures"], 1)
        self.assertEqual(got["VerifAI bayesopt"]["deployed"]["cheap"],
                         {"trials": 0, "failures": 0, "work": 0, "cells": 0})
        self.assertEqual(got["VerifAI bayesopt"]["overhead_ms"], 0.5)

    def test_outcomes_feed_families_py(self) -> None:
        import families

        with tempfile.TemporaryDirectory() as d, \
                mock.patch.object(run_highway_env, "spaces", lambda names: self.SPACES):
            out = Path(d)
            _write_runs(out)
            rows = run_highway_env.outcomes(types.SimpleNamespace(scenarios=["dear", "cheap"]), out)
        f = families.family(rows, "savme", "work")
        # savme: 2 failures in 21 wu; bayesopt (equal work): 1 in 11
        mine, peer, theirs = f["HF failures / wu, search"]
        self.assertEqual((peer, round(mine * 21), round(theirs * 11)), ("VerifAI bayesopt", 2, 1))
        self.assertEqual(families.family(rows, "savme", "trials")["HF failures / wu, search"][1],
                         "VerifAI bayesopt, by trials")

    def test_the_run_line_is_the_window_all_py_reads(self) -> None:
        import all as all_py

        with tempfile.TemporaryDirectory() as d:
            out = Path(d)
            _write_runs(out)
            (out / "table.md").write_text(run_highway_env.run_line(out) + "\n")
            start, end, wall = all_py.run_window(out / "table.md")
        self.assertEqual((start.hour, start.minute, end.hour, end.minute, wall), (22, 0, 23, 35, 96.0))

    def test_without_recorded_times_the_line_says_so(self) -> None:
        with tempfile.TemporaryDirectory() as d:
            (Path(d) / "runs").mkdir()
            self.assertIn("not recorded", run_highway_env.run_line(Path(d)))


class Schedule(unittest.TestCase):
    def test_bayesian_optimisation_runs_last_on_every_seed(self) -> None:
        got = run_highway_env.schedule([1, 2], ["savme", "bayesopt", "random", "bayesopt/trials",
                                                "random/trials"])
        self.assertEqual(got, [(1, "savme"), (1, "random"), (2, "savme"), (2, "random"),
                               (1, "random/trials"), (2, "random/trials"),
                               (1, "bayesopt"), (2, "bayesopt"), (1, "bayesopt/trials"),
                               (2, "bayesopt/trials")])

    def test_labels_are_run_py_s(self) -> None:
        self.assertEqual([run_highway_env.method_label(r) for r in ("savme-paper", "bandit", "bandit/trials")],
                         ["savme-paper", "VerifAI bandit", "VerifAI bandit, by trials"])


class Setup(unittest.TestCase):
    def test_the_venv_key_changes_with_any_requirement_file(self) -> None:
        with tempfile.TemporaryDirectory() as d:
            files = [Path(d) / n for n in ("a.txt", "b.txt", "c.txt")]
            for f in files:
                f.write_text("x==1\n")
            with mock.patch.object(run_highway_env, "REQUIREMENTS", tuple(files[:2])), \
                    mock.patch.object(run_highway_env, "OPTIONAL", files[2]):
                before = run_highway_env.requirements_key()
                self.assertEqual(before, run_highway_env.requirements_key())
                files[2].write_text("x==2\n")
                self.assertNotEqual(before, run_highway_env.requirements_key())

    def test_quick_shortens_only_what_is_not_given(self) -> None:
        a = run_highway_env.parse_args(["--quick", "--iterations", "20"])
        self.assertEqual((a.seeds, a.iterations, a.screen_iterations), (1, 20, 8))
        b = run_highway_env.parse_args([])
        self.assertEqual((b.seeds, b.iterations, b.screen_iterations), (2, 30, 30))

    def test_the_default_rows_are_the_benchmark_s_both_splits_savme_first(self) -> None:
        rows = run_highway_env.DEFAULT_ROWS
        self.assertEqual(rows[0], "savme")
        peers = [r for r in rows if not r.startswith("savme")]
        self.assertEqual(sorted(p for p in peers if "/" not in p),
                         sorted(p.removesuffix("/trials") for p in peers if "/" in p))
        self.assertIn("bayesopt", peers)
        self.assertNotIn("savme-rho", rows)


class AllPy(unittest.TestCase):
    """all.py's highway family: chosen, its command, its table's command read back."""

    def test_highway_is_in_the_full_default_set_and_named_in_quick(self) -> None:
        import all as all_py

        self.assertIn("highway", [f.slug for f in all_py.choose(None, quick=False)])
        self.assertNotIn("highway", [f.slug for f in all_py.choose(None, quick=True)])
        self.assertEqual([f.slug for f in all_py.choose("highway", quick=True)], ["highway"])
        with self.assertRaises(SystemExit) as e:
            all_py.choose("highway,nowhere", quick=False)
        self.assertIn("nowhere", str(e.exception))

    def test_the_highway_command_runs_run_highway_env_with_its_lengths(self) -> None:
        import all as all_py

        f = all_py.choose("highway", quick=False)[0]
        args = types.SimpleNamespace(quick=False, seeds=3, jobs=1)
        cmd = all_py.family_command(f, args, all_py.REPO / "target" / "x")
        self.assertEqual(cmd[:2], ["python3", "benches/peers/run_highway_env.py"])
        self.assertEqual(cmd[cmd.index("--iterations") + 1], "150")
        self.assertNotIn("--peer-split", cmd)  # its rows SAMPLER/trials are the second view
        self.assertEqual(cmd[-2:], ["--out", "target/x/highway"])
        quick = all_py.family_command(f, types.SimpleNamespace(quick=True, seeds=None, jobs=1),
                                      all_py.REPO / "target" / "x")
        self.assertIn("--quick", quick)
        self.assertNotIn("--iterations", quick)

    def test_its_table_s_command_is_read_back(self) -> None:
        import all as all_py

        with tempfile.TemporaryDirectory() as d:
            table = Path(d) / "table.md"
            table.write_text("Run …\n\n```sh\npython3 benches/peers/run_highway_env.py --quick --out x\n"
                             "python3 benches/peers/run_highway_env.py --seed-list 2 --out x\n```\n")
            got = all_py.table_commands(table)
            self.assertEqual([c[2] for c in got], ["--quick", "--seed-list"])
            table.write_text("Run …\n```sh\npython3 benches/peers/run.py --quick\n```\n"
                             "python3 benches/peers/run.py --scenarios test\n")
            self.assertEqual(all_py.table_commands(table), [["python3", "benches/peers/run.py", "--quick"]])
            # An invocation run with settings of its environment keeps them; other lines that
            # merely mention the script are no commands.
            table.write_text("```sh\npython3 benches/peers/run_highway_env.py --seed-list 3 --out x\n"
                             "OMP_NUM_THREADS=1 python3 benches/peers/run_highway_env.py --seed-list 1\n"
                             "see python3 benches/peers/run_highway_env.py\n```\n")
            got = all_py.table_commands(table)
            self.assertEqual(got[1][:2], ["OMP_NUM_THREADS=1", "python3"])
            self.assertEqual(len(got), 2)


class FewerSeeds(unittest.TestCase):
    def test_a_best_peer_with_fewer_seeds_than_savme_is_marked(self) -> None:
        import families

        def row(method, seed, failures):
            return {"method": method, "seed": seed, "overhead_ms": 0.0,
                    "search": {"a": {"trials": 1, "failures": failures, "work": 10, "cells": failures}},
                    "deployed": {"a": {"trials": 1, "failures": failures, "work": 10, "cells": 0}}}

        rows = [row("savme", 1, 1), row("savme", 2, 1), row("VerifAI bayesopt", 1, 4),
                row("VerifAI random", 1, 0), row("VerifAI random", 2, 0)]
        table = families.ratio_table([("f", rows)], "savme", "work")
        self.assertIn("0.25× (bayesopt, 1 seed)", table)
        self.assertIn("(1 of the seeds)", families.rates_table([("f", rows)], "savme", "work", {"f": 1e6}))

    def test_a_family_without_the_split_s_peers_is_named_not_tabled(self) -> None:
        import families

        row = lambda m: {"method": m, "seed": 1, "overhead_ms": 0.0,  # noqa: E731
                         "search": {"a": {"trials": 1, "failures": 1, "work": 10, "cells": 1}},
                         "deployed": {"a": {"trials": 1, "failures": 1, "work": 10, "cells": 1}}}
        both = ("both", [row("savme"), row("VerifAI random"), row("VerifAI random, by trials")])
        work_only = ("work only", [row("savme"), row("VerifAI random")])
        table = families.ratio_table([both, work_only], "savme", "trials")
        self.assertIn("| both |", table)
        self.assertNotIn("| work only |", table)
        self.assertIn("peers split by equal trials in its outcomes): work only.", table)
        self.assertIn("| work only |", families.ratio_table([both, work_only], "savme", "work"))


class EliteParameters(unittest.TestCase):
    def test_elite_pairs_become_the_protocols_dict_and_bad_ones_are_named(self) -> None:
        got = run_highway_env.elite_parameters("tries=8, explore=0.1,per_cost=false")
        self.assertEqual(got, {"tries": 8, "explore": 0.1, "per_cost": False})
        self.assertIsInstance(got["tries"], int)
        self.assertEqual(run_highway_env.elite_parameters(""), {})
        with self.assertRaises(SystemExit) as e:
            run_highway_env.elite_parameters("tries")
        self.assertIn("--elite `tries`", str(e.exception))


if __name__ == "__main__":
    unittest.main()


class BlasThreads(unittest.TestCase):
    def test_both_runners_ask_for_one_blas_thread_unless_told(self) -> None:
        import os
        import subprocess

        here = Path(__file__).resolve().parent
        env = {k: v for k, v in os.environ.items()
               if k not in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")}
        for module in ("run_highway_env", "run"):
            code = (f"import sys; sys.path.insert(0, {str(here)!r}); import {module}, os; "
                    "print(os.environ['OMP_NUM_THREADS'], os.environ['OPENBLAS_NUM_THREADS'], "
                    "os.environ['MKL_NUM_THREADS'])")
            got = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                                 text=True, check=True).stdout.split()
            self.assertEqual(got, ["1", "1", "1"], module)
            told = subprocess.run([sys.executable, "-c", code], env={**env, "OMP_NUM_THREADS": "2"},
                                  capture_output=True, text=True, check=True).stdout.split()
            self.assertEqual(told[0], "2", module)
