"""savme's rows: a `savme reproduce --cost work` campaign per variant on the bundled simulator,
or a `savme run --config FILE --cost work` campaign on a campaign file (all seeds through
`--repeat`), read back from its own `trials.jsonl` — nothing of savme's search is re-implemented
here.

A variant is a name and extra `savme reproduce` flags, e.g. a kernel search mode added later:
`--savme-variant 'savme-joint=--search joint'` adds one more row.

The search is the meta-training stage `train@B` (each trial an HF run and, for a paired trial,
an LF run; both charged). The deployed search is the screening stage `screen@B`
(`--screen-iterations`: φ ~ p_ψ, an LF run with θ_LF*, every LF failure re-run on HF; both
charged; `--audit-fraction 0`, so no HF run is spent on auditing passes).
"""
from __future__ import annotations

import json
import shlex
import subprocess
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from simulator import Simulator


@dataclass(frozen=True)
class Variant:
    name: str
    flags: tuple[str, ...]

    @staticmethod
    def parse(text: str) -> "Variant":
        name, _, flags = text.partition("=")
        if not name:
            raise ValueError(f"--savme-variant `{text}`: expected NAME or NAME=FLAGS")
        return Variant(name, tuple(shlex.split(flags)))


@dataclass(frozen=True)
class Hit:
    """One HF run of a savme campaign, as the metrics need it."""

    scenario: str
    phi: dict[str, float]
    failure: bool


@dataclass
class SavmeSeed:
    """A savme variant on one seed: the search's and the deployment's HF runs and costs."""

    method: str
    seed: int
    search_hf: list[Hit] = field(default_factory=list)
    search_work: dict[str, int] = field(default_factory=dict)  # per scenario, HF + LF
    search_trials: dict[str, int] = field(default_factory=dict)
    deployed_hf: list[Hit] = field(default_factory=list)
    deployed_work: dict[str, int] = field(default_factory=dict)
    deployed_trials: dict[str, int] = field(default_factory=dict)


@dataclass(frozen=True)
class Protocol:
    """What the campaign runs; the stages the benchmark does not read get one trial each."""

    seeds: tuple[int, ...]
    iterations: int
    screen_iterations: int
    budget: float
    train_scenarios: tuple[str, ...]
    jobs: int
    config: Path | None = None  # a campaign file (`savme run --config`); None: `savme reproduce`


def command(exe: Path, variant: Variant, p: Protocol, out: Path) -> list[str]:
    """The `savme reproduce` (or, with a campaign file, `savme run --config`) command line of a
    variant: the same protocol values either way."""
    if p.config is None:
        head = [str(exe), "reproduce", "--cost", "work", "--perception", "sensors"]
    else:
        head = [str(exe), "run", "--config", str(p.config), "--cost", "work"]
    return [
        *head,
        "--seed", str(p.seeds[0]), "--repeat", str(len(p.seeds)),
        "--budgets", str(p.budget),
        "--iterations", str(p.iterations),
        "--train-scenarios", ",".join(p.train_scenarios),
        "--eval-iterations", "1", "--test-iterations", "1",
        "--baseline-iterations", "1", "--baseline-test-iterations", "1",
        "--screen-iterations", str(max(1, p.screen_iterations)), "--audit-fraction", "0",
        "--jobs", str(p.jobs), "--quiet", "--out", str(out),
        *variant.flags,
    ]  # fmt: skip


def run_campaign(exe: Path, variant: Variant, p: Protocol, out: Path, log: Path) -> list[str]:
    """Runs the campaign (or resumes it if `out` exists) and returns the command run."""
    cmd = command(exe, variant, p, out)
    if (out / "protocol.json").exists() or (out / f"seed-{p.seeds[0]}").exists():
        cmd = resume_command(exe, p, out)
    with open(log, "a") as f:
        f.write("$ " + shlex.join(cmd) + "\n")
        f.flush()
        subprocess.run(cmd, check=True, stdout=f, stderr=subprocess.STDOUT)
    return cmd


def resume_command(exe: Path, p: Protocol, out: Path) -> list[str]:
    """The command that continues the campaign in `out` (its protocol is stored with it)."""
    config = [] if p.config is None else ["--config", str(p.config)]
    verb = "reproduce" if p.config is None else "run"
    return [str(exe), verb, *config, "--resume", str(out), "--jobs", str(p.jobs), "--quiet"]


def _phi(value: dict[str, Any]) -> dict[str, float]:
    """φ as written in trials.jsonl (plain numbers, or tagged values)."""
    out: dict[str, float] = {}
    for k, v in value.items():
        if isinstance(v, dict):
            v = next(iter(v.values()))
        out[k] = float(v)
    return out


def _work(run: dict[str, Any] | None) -> int:
    if not run:
        return 0
    w = run.get("work")
    if w is None:
        raise ValueError("a run without work units: was the campaign run with --cost work?")
    return int(w)


def _add(d: dict[str, int], key: str, n: int) -> None:
    d[key] = d.get(key, 0) + n


def read_seed(trials: Path, method: str, seed: int, budget: float) -> SavmeSeed:
    """The search (`train@B`) and deployed (`screen@B`) runs of one seed's trials.jsonl."""
    s = SavmeSeed(method, seed)
    train, screen = f"train@{budget}", f"screen@{budget}"
    for line in trials.read_text().splitlines():
        t = json.loads(line)
        if "protocol" in t and "stage" not in t:  # the campaign's first record: its protocol
            continue
        if "error" in t:
            raise ValueError(f"{trials}: a withdrawn trial: {t['error']}")
        sc = t["scenario"]
        if t["stage"] == train:
            s.search_hf.append(Hit(sc, _phi(t["phi"]), bool(t["hf"]["failure"])))
            _add(s.search_work, sc, _work(t["hf"]) + _work(t.get("lf")))
            _add(s.search_trials, sc, 1)
        elif t["stage"] == screen:
            if t.get("hf"):
                s.deployed_hf.append(Hit(sc, _phi(t["phi"]), bool(t["hf"]["failure"])))
            _add(s.deployed_work, sc, _work(t.get("hf")) + _work(t.get("lf")))
            _add(s.deployed_trials, sc, 1)
    if not s.search_hf:
        raise ValueError(f"{trials}: no `{train}` trials")
    return s


def cells(sim: Simulator, hits: list[Hit]) -> set[tuple[str, tuple[int, ...]]]:
    """The distinct joint cells (savme's bins of φ, per scenario) of the failing runs."""
    return {(h.scenario, sim.arms(h.scenario, h.phi)) for h in hits if h.failure}
