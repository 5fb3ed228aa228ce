#!/usr/bin/env python3
"""The peer benchmark on highway-env (issue 29): savme's paired HF/LF search against VerifAI's
samplers on the same highway-env φ-spaces, the same work-unit budget and the same seeds.

    python3 benches/peers/run_highway_env.py --quick       # a smoke run: seed 1, 16 + 8 trials
    python3 benches/peers/run_highway_env.py --seeds 3 --iterations 150 --screen-iterations 90
    python3 benches/peers/all.py --families highway        # the same as a family of all.py

It sets up target/highway-peers-venv (requirements-highway.txt: highway-env, gymnasium,
maturin; requirements.txt: VerifAI 2.2.0; requirements-bayesopt.txt: GPyOpt if it installs;
reinstalled when a requirement file changes), builds savme's wheel from this checkout into
target/wheels/highway-peers (maturin, the dev profile, as python/develop.sh --wheel; `--no-build`:
the newest wheel there or in target/wheels/test), installs it when it changed, and re-runs
itself inside the venv. Outputs in --out: rows.jsonl, runs/, table.md (its first line the run's
window, then the commands), per-seed.json and outcomes.json (benches/peers/run.py's format,
which families.py and all.py read).

As benches/peers/run.py on the bundled simulator (see README.md there), on seed s:
- savme runs first: its search is the meta-training stage train@B of a savme.Campaign (cost =
  the adapter's deterministic work units, HF and LF runs both charged); its deployed search is
  the screening stage screen@B (φ ~ p_ψ, an LF run with θ_LF*, each LF failure re-run on HF and
  counted only if HF fails too; audit fraction 0). The other stages get one trial each.
- every peer (VerifAI's random, halton, cross-entropy, bandit, simulated annealing samplers and
  Bayesian optimisation when GPyOpt installs; one
  Box feature per φ variable, one sampler per scenario, the budget split by equal work per
  scenario; ρ = the run's
  robustness: smallest bumper gap, < 0 exactly on a crash) spends the same work on HF runs for
  the search, then the deployed work going on sampling.
Metrics per 10⁶ work units, mean ± sd over seeds: HF failures in the search, distinct failing
cells (scenario × 6 linear bins per φ variable, savme's arms) in the search, confirmed
failures of the deployed search.
"""
from __future__ import annotations

import argparse
import datetime as dt
import hashlib
import json
import os
import random
import shlex
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

# One BLAS thread per process, as run.py: with GPyOpt's default threads, three Bayesian
# optimisation seeds on 2 cores took 4,631 ms of sampler time a run against 434–514 ms with one
# thread each (docs/RESULTS.md, "Every family on today's defaults").
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
VENV = REPO / "target" / "highway-peers-venv"
BINS = 6


REQUIREMENTS = (HERE / "requirements-highway.txt", HERE / "requirements.txt")
OPTIONAL = HERE / "requirements-bayesopt.txt"  # GPyOpt: Bayesian optimisation, if it installs
WHEELS = REPO / "target" / "wheels" / "highway-peers"  # savme's wheel, built from this checkout
TEST_WHEELS = REPO / "target" / "wheels" / "test"  # python/develop.sh --wheel's


def requirements_key() -> str:
    """The venv's key: sha256 over its requirement files (a change to any reinstalls them)."""
    h = hashlib.sha256()
    for path in (*REQUIREMENTS, OPTIONAL):
        h.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()


def file_sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def build_wheel() -> Path:
    """savme's wheel from this checkout, as `python/develop.sh --wheel` builds it (maturin,
    the dev profile), into target/wheels/highway-peers; cargo rebuilds only what changed."""
    if WHEELS.exists():
        shutil.rmtree(WHEELS)
    subprocess.run(["nice", "-n", "10", str(VENV / "bin" / "maturin"), "build", "-q", "--profile",
                    "dev", "--manifest-path", str(REPO / "python" / "Cargo.toml"), "--interpreter",
                    str(VENV / "bin" / "python"), "-o", str(WHEELS)], check=True, cwd=REPO)
    return newest_wheel()


def newest_wheel() -> Path:
    """The newest savme wheel in target/wheels/highway-peers or target/wheels/test."""
    wheels = [*WHEELS.glob("savme-*.whl"), *TEST_WHEELS.glob("savme-*.whl")]
    if not wheels:
        sys.exit(f"no savme wheel in {WHEELS} or {TEST_WHEELS}: run without --no-build "
                 "(it builds one) or python/develop.sh --wheel")
    return max(wheels, key=lambda p: p.stat().st_mtime)


def setup(build: bool) -> None:
    """target/highway-peers-venv: created if missing; its requirements installed when their
    key (requirements_key) is not the one recorded in .complete; savme's wheel built (unless
    `build` is false: the newest one there is) and installed when its sha256 is not the one
    installed (recorded in .savme-wheel, so a process running in the venv is not disturbed)."""
    py = VENV / "bin" / "python"
    if not py.exists():
        subprocess.run([sys.executable, "-m", "venv", str(VENV)], check=True)
    pip = [str(py), "-m", "pip", "install", "-q", "--disable-pip-version-check"]
    key, done = requirements_key(), VENV / ".complete"
    if not done.exists() or done.read_text().strip() != key:
        print(f"setting up {VENV} (highway-env, VerifAI, maturin from PyPI) …", file=sys.stderr,
              flush=True)
        subprocess.run(pip + [a for r in REQUIREMENTS for a in ("-r", str(r))], check=True)
        if subprocess.run(pip + ["-r", str(OPTIONAL)]).returncode != 0:
            print("GPyOpt did not install: Bayesian optimisation is left out", file=sys.stderr)
        done.write_text(key + "\n")
    wheel = build_wheel() if build else newest_wheel()
    installed, digest = VENV / ".savme-wheel", file_sha256(wheel)
    if not installed.exists() or installed.read_text().strip() != digest:
        subprocess.run(pip + ["--force-reinstall", "--no-deps", str(wheel)], check=True)
        installed.write_text(digest + "\n")


def in_venv() -> bool:
    return Path(sys.prefix).resolve() == VENV.resolve()  # (its python is a link to python3)


def ensure_venv(build: bool) -> None:
    """Sets the venv up (setup) and re-runs this script inside it."""
    if in_venv():
        return
    setup(build)
    py = VENV / "bin" / "python"
    os.execv(str(py), [str(py), str(Path(__file__).resolve()), *sys.argv[1:]])


def spaces(scenarios):
    """The φ boxes as benches/peers' ScenarioSpace (savme's bins)."""
    from simulator import ScenarioSpace, Variable
    from savme.integrations import highway_env as hw

    return [ScenarioSpace(sc, i, tuple(Variable(n, lo, hi, BINS) for n, lo, hi, _, _ in
                                       hw.SCENARIOS[sc].variables))
            for i, sc in enumerate(scenarios)]


def cell(space, phi):
    return (space.name, tuple(min(int((phi[v.name] - v.lo) / (v.hi - v.lo) * v.bins), v.bins - 1)
                              for v in space.variables))


def rho_simulator(seed: int = 0):
    """hw.campaign_simulator's runs with the robustness ρ as a third value (what savme's ρ model
    reads; savme.integrations.highway_env's own simulator returns (failure, work) only)."""
    from savme.integrations import highway_env as hw

    def run(scenario, phi, theta):
        r = hw.simulate(scenario, phi, theta, seed=seed)
        return r["failure"], max(int(r["work"]), 1), float(r["robustness"])

    return run


def elite_parameters(text):
    """`--elite explore=0.1,tries=8` as the Protocol's `elite` dict (numbers as numbers)."""
    out = {}
    for pair in filter(None, (p.strip() for p in text.split(","))):
        key, eq, value = pair.partition("=")
        if not eq or not key:
            raise SystemExit(f"--elite `{pair}`: give key=value, e.g. tries=8")
        try:
            out[key] = int(value)
        except ValueError:
            try:
                out[key] = float(value)
            except ValueError:
                out[key] = {"true": True, "false": False}.get(value.lower(), value)
    return out


def savme_seed(args, seed, out, variant="savme"):
    """savme's search and deployed runs on one seed, read from its trials.jsonl: (scenario, φ,
    HF failure, work, HF work, LF work) per trial. variant "savme": savme's defaults with the
    integration's simulator as shipped; "savme-rho": the same runs returning ρ too;
    "savme-paper": the paper's SAVME (method="paper")."""
    import savme
    from savme.integrations import highway_env as hw

    test = [s for s in ["intersection", "highway", "roundabout", "merge"] if s not in args.scenarios][:1]
    protocol = savme.Protocol(
        args.scenarios, test, preset="quick", simulator="highway-env", cost="work", seed=seed,
        budgets=[args.budget], train_iterations=args.iterations, eval_iterations=1,
        test_iterations=1, baseline_train_iterations=1, baseline_test_iterations=1,
        screen_iterations=max(args.screen_iterations, 1), audit_fraction=0.0,
        **({"method": "paper"} if variant == "savme-paper" else {}),
        **({"elite": elite_parameters(args.elite)} if args.elite and variant != "savme-paper" else {}))
    resume = (out / "protocol.json").exists()
    sim = rho_simulator() if variant == "savme-rho" else hw.campaign_simulator()
    savme.Campaign(None if resume else protocol, hw.problem(args.scenarios + test), out=out,
                   resume=resume, jobs=1).run(sim)
    search, deployed = [], []
    for line in (out / "trials.jsonl").read_text().splitlines():
        t = json.loads(line)
        if "protocol" in t:  # the store's first record: the campaign's protocol
            continue
        hf_work = t["hf"]["work"] if t.get("hf") else 0
        lf_work = t["lf"]["work"] if t.get("lf") else 0
        failed = bool(t.get("hf") and t["hf"]["failure"])
        row = (t["scenario"], t["phi"], failed, hf_work + lf_work, hf_work, lf_work)
        if t["stage"] == f"train@{args.budget}":
            search.append(row)
        elif t["stage"] == f"screen@{args.budget}":
            deployed.append(row)
    return search, deployed


def peer_seed(method, seed, sp, search_budget, deployed_budget, split="work", progress=None):
    """One VerifAI sampler on one seed: HF runs until each budget is spent, the scenario to run
    next chosen by `split` (verifai_peers._Scenarios: "work" = the one that has cost least so
    far in this part, "trials" = in turn). `progress(parts)`, if given, is called after every
    run with the runs so far (a list per part begun)."""
    import numpy as np
    from verifai_peers import _Scenarios, annealing_started, phi_of
    from savme.integrations import highway_env as hw

    random.seed(seed)
    np.random.seed(seed)
    state, overhead, parts = _Scenarios(method, sp, split), 0.0, []
    for budget in (search_budget, deployed_budget):
        runs, spent = [], 0
        state.work = [0.0] * len(sp)  # as verifai_peers._spend: equal work within each part
        while spent < budget:
            t0 = time.perf_counter()
            k, sample, info = state.next()
            overhead += time.perf_counter() - t0
            phi = phi_of(sample, sp[k])
            r = hw.simulate(sp[k].name, phi)
            t0 = time.perf_counter()
            state.samplers[k].update(sample, info, r["robustness"])
            if method == "annealing":
                annealing_started(state.samplers[k])
            overhead += time.perf_counter() - t0
            runs.append((sp[k].name, phi, r["failure"], r["work"], r["work"], 0))
            spent += r["work"]
            state.work[k] += r["work"]
            if progress is not None:
                progress([*parts, runs])
        parts.append(runs)
    return parts[0], parts[1], overhead


def rates(runs, sp):
    by_name = {s.name: s for s in sp}
    work = sum(r[3] for r in runs) or 1
    fails = [r for r in runs if r[2]]
    cells = {cell(by_name[r[0]], r[1]) for r in fails}
    return 1e6 * len(fails) / work, 1e6 * len(cells) / work, len(runs)


def utc_now() -> str:
    """The time now, UTC, ISO 8601 to the second (a row's start and end in runs/)."""
    return dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")


def record(path, method, seed, row):
    with open(path, "a") as f:
        f.write(json.dumps({"method": method, "seed": seed, "row": list(row)}) + "\n")


def fmt(xs):
    return f"{statistics.mean(xs):.2f} ± {statistics.stdev(xs):.2f}" if len(xs) > 1 else f"{xs[0]:.2f}"


# The benchmark's rows (all.py's highway family): savme with its defaults, the paper's SAVME,
# every VerifAI sampler split by equal work and, as a second view, by equal trials. `savme-rho`
# (savme on runs returning ρ too) is not among them: measured and not kept (docs/RESULTS.md).
DEFAULT_ROWS = ["savme", "cross-entropy", "bandit", "bayesopt", "random", "halton", "annealing",
                "cross-entropy/trials", "bandit/trials", "bayesopt/trials", "random/trials",
                "halton/trials", "annealing/trials", "savme-paper"]


def schedule(seeds, rows):
    """The (seed, row) pairs in the order run, seed by seed in each phase: savme's rows and the
    peers split by equal work, then the peers split by equal trials, then Bayesian optimisation
    (≈ 40 min of CPU a seed on highway-env: GPyOpt's fit per sample) by equal work, then by equal
    trials — so a run stopped for time has the main view on every seed first."""
    slow = [r for r in rows if r.split("/")[0] == "bayesopt"]
    # the equal-work view (savme's rows with it) on every seed before the equal-trials one
    phases = [[r for r in rows if r not in slow and not r.endswith("/trials")],
              [r for r in rows if r not in slow and r.endswith("/trials")],
              [r for r in slow if not r.endswith("/trials")], [r for r in slow if r.endswith("/trials")]]
    return [(s, r) for phase in phases for s in seeds for r in phase]


class Partial:
    """A peer row's runs so far in runs/ROW-seed-S.partial.json (rewritten at most every 30 s
    and when a part ends; removed when the row is done): what a row stopped for time (Bayesian
    optimisation) had run. Not read by the tables."""

    def __init__(self, path: Path, row: str, seed: int, started: str, budgets) -> None:
        self.path, self.row, self.seed, self.started, self.budgets = path, row, seed, started, budgets
        self.c0, self.last, self.parts = time.process_time(), 0.0, 0

    def __call__(self, parts) -> None:
        now = time.monotonic()
        if now - self.last < 30 and len(parts) == self.parts:
            return
        self.last, self.parts = now, len(parts)
        tmp = self.path.with_suffix(".tmp")
        tmp.write_text(json.dumps(
            {"row": self.row, "seed": self.seed, "started": self.started, "updated": utc_now(),
             "cpu_s": time.process_time() - self.c0, "budgets": list(self.budgets),
             "search": parts[0], "deployed": parts[1] if len(parts) > 1 else []}))
        tmp.replace(self.path)


def run_rows(args, sp, out, seeds, rows):
    """Every row of every seed not yet in rows.jsonl, in `schedule`'s order; each row's runs go
    to runs/ROW-seed-S.json (scenario, φ, HF failure, work, HF work, LF work per run) with its
    wall and CPU time and its start and end (UTC). A seed's savme row (run, or read back from
    its finished campaign) sets that seed's peer budgets."""
    done = out / "rows.jsonl"  # one line per (method, seed): several processes may add to it
    runs_dir = out / "runs"
    runs_dir.mkdir(exist_ok=True)
    have = set()
    if done.exists():
        have = {(r["method"], r["seed"]) for r in map(json.loads, done.read_text().splitlines())}
    budgets: dict[int, tuple[int, int]] = {}
    for seed, row in schedule(seeds, rows):
        if (row, seed) in have:
            continue
        if not row.startswith("savme") and seed not in budgets:
            if "savme" not in rows:
                sys.exit("the savme row must be among --rows: it sets every peer's budget")
            search, deployed = savme_seed(args, seed, out / f"savme-seed-{seed}", "savme")
            budgets[seed] = (sum(r[3] for r in search), sum(r[3] for r in deployed))
        t0, c0 = time.perf_counter(), time.process_time()
        started = utc_now()
        if row.startswith("savme"):
            search, deployed = savme_seed(args, seed, out / f"{row}-seed-{seed}", row)
            overhead = 0.0
        else:
            method, _, split = row.partition("/")
            partial = Partial(runs_dir / f"{row.replace('/', '-')}-seed-{seed}.partial.json",
                              row, seed, started, budgets[seed])
            search, deployed, overhead = peer_seed(method, seed, sp, *budgets[seed],
                                                   split or "work", partial)
            partial.path.unlink(missing_ok=True)
        sw, dw = sum(r[3] for r in search), sum(r[3] for r in deployed)
        if row == "savme":
            budgets[seed] = (sw, dw)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        f, c, n = rates(search, sp)
        confirmed = 1e6 * sum(r[2] for r in deployed) / max(dw, 1)
        record(done, row, seed, (f, c, confirmed, n, sw, dw,
                                 1e3 * overhead / max(len(search) + len(deployed), 1)))
        (runs_dir / f"{row.replace('/', '-')}-seed-{seed}.json").write_text(json.dumps(
            {"row": row, "seed": seed, "wall_s": wall, "cpu_s": cpu, "started": started,
             "finished": utc_now(), "search": search, "deployed": deployed}))
        print(f"seed {seed}: {row} {n} search runs, {len(deployed)} deployed, search {sw} wu, "
              f"deployed {dw} wu ({wall:.0f} s wall, {cpu:.0f} s CPU)", flush=True)


def table(args, out):
    """The overall table (rows.jsonl) and the per-scenario one (runs/), as markdown."""
    done = out / "rows.jsonl"
    rows = {}
    for line in done.read_text().splitlines():
        r = json.loads(line)
        rows.setdefault(r["method"], {})[r["seed"]] = r["row"]
    order = [m for m in DEFAULT_ROWS if m in rows] + [m for m in rows if m not in DEFAULT_ROWS]
    rows = {m: [rows[m][s] for s in sorted(rows[m])] for m in order}
    lines = [
        run_line(out),
        "",
        "Commands (each invocation that added rows to this output):",
        "",
        "```sh",
        *commands(out),
        "```",
        "",
        f"highway-env scenarios {', '.join(args.scenarios)}; seeds: {len(rows['savme'])} "
        f"(rows of {done}); savme "
        f"{rows['savme'][0][3]} search trials (deployed: --screen-iterations) at budget {args.budget}; "
        "per 10⁶ work units, mean ± sd over seeds; a peer's row: its split (/trials = equal "
        "trials per scenario, else equal work)",
        "",
        "| method | HF failures, search | distinct failing cells, search | confirmed failures, deployed "
        "| search runs (trials) | sampler overhead ms/run |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for method, rs in rows.items():
        cols = [fmt([r[i] for r in rs]) for i in range(3)]
        seeds = "" if len(rs) == len(rows["savme"]) else f" ({len(rs)} seeds)"
        lines.append(f"| {method}{seeds} | {' | '.join(cols)} | {statistics.mean(r[3] for r in rs):.0f} "
                     f"| {'—' if method.startswith('savme') else f'{statistics.mean(r[6] for r in rs):.2f}'} |")
    lines += ["", *ratios(rows), "", *per_scenario(args, out, order)]
    return "\n".join(lines)


def row_files(out: Path) -> list[Path]:
    """The finished rows' runs/ROW-seed-S.json (not a row in progress's .partial.json)."""
    return [f for f in sorted((out / "runs").glob("*.json")) if not f.name.endswith(".partial.json")]


COMMANDS = "commands.txt"  # in --out: one line per invocation that ran rows


def commands(out: Path) -> list[str]:
    path = out / COMMANDS
    return path.read_text().splitlines() if path.exists() else []


def run_times(out: Path) -> list[tuple[dt.datetime, dt.datetime]]:
    """Each row's start and end (UTC) as runs/ records them (rows run before they were
    recorded have none)."""
    times = []
    for f in row_files(out):
        r = json.loads(f.read_text())
        if "started" in r and "finished" in r:
            times.append((dt.datetime.fromisoformat(r["started"]),
                          dt.datetime.fromisoformat(r["finished"])))
    return times


def run_line(out: Path) -> str:
    """The table's first line, as benches/peers/run.py writes it (all.py reads it): `Run
    YYYY-MM-DD HH:MM–HH:MM UTC (N min wall)` from the first row's start to the last one's end."""
    times = run_times(out)
    if not times:
        return "Run times not recorded (rows run before run_highway_env.py recorded them)."
    start, end = min(t[0] for t in times), max(t[1] for t in times)
    return (f"Run {start:%Y-%m-%d %H:%M}–{end:%H:%M} UTC ({(end - start).total_seconds() / 60:.0f} "
            f"min wall), {len(times)} rows; per row, wall and CPU time in per-seed.json.")


def method_label(row: str) -> str:
    """A row's method in outcomes.json, as benches/peers/run.py names it: savme's rows as they
    are, `VerifAI <peer>` (equal work) and `VerifAI <peer>, by trials`."""
    if row.startswith("savme"):
        return row
    peer, _, split = row.partition("/")
    return f"VerifAI {peer}" + (", by trials" if split == "trials" else "")


def outcomes(args, out: Path) -> list[dict]:
    """runs/ and rows.jsonl as benches/peers/run.py's outcomes.json (families.py reads it): per
    method and seed, per part (search, deployed) and scenario, the runs (trials), HF failures,
    work and distinct failing cells (scenario × BINS bins per φ variable); the sampler's
    overhead per run in ms."""
    sp = {s.name: s for s in spaces(args.scenarios)}
    overhead = {}
    if (out / "rows.jsonl").exists():
        for line in (out / "rows.jsonl").read_text().splitlines():
            r = json.loads(line)
            overhead[(r["method"], r["seed"])] = r["row"][6]
    result = []
    for f in row_files(out):
        r = json.loads(f.read_text())

        def part(xs):
            return {name: {"trials": sum(1 for x in xs if x[0] == name),
                           "failures": sum(1 for x in xs if x[0] == name and x[2]),
                           "work": sum(x[3] for x in xs if x[0] == name),
                           "cells": len({cell(sp[name], x[1]) for x in xs if x[0] == name and x[2]})}
                    for name in args.scenarios}

        result.append({"method": method_label(r["row"]), "seed": r["seed"],
                       "overhead_ms": overhead.get((r["row"], r["seed"]), 0.0),
                       "search": part(r["search"]), "deployed": part(r["deployed"])})
    result.sort(key=lambda o: (o["seed"], o["method"]))
    return result


def ratios(rows):
    """Each savme row's mean over the best peer's mean per metric, for each split of the peers
    (each mean over that row's seeds: the table marks a row with fewer seeds than savme's)."""
    metrics = ["HF failures, search", "distinct failing cells, search", "confirmed failures, deployed"]
    lines = ["| savme row / best peer | peers' split | " + " | ".join(metrics) + " |",
             "|---|---|---:|---:|---:|"]
    for me in (m for m in rows if m.startswith("savme")):
        for split in ("work", "trials"):
            peers = {m: rs for m, rs in rows.items() if not m.startswith("savme")
                     and (m.endswith("/trials") == (split == "trials"))}
            if not peers:
                continue
            cols = []
            for i in range(3):
                best = max(peers, key=lambda m: statistics.mean(r[i] for r in peers[m]))
                ratio = statistics.mean(r[i] for r in rows[me]) / max(
                    statistics.mean(r[i] for r in peers[best]), 1e-12)
                cols.append(f"{ratio:.2f}× ({best.split('/')[0]})")
            lines.append(f"| {me} | equal {split} | {' | '.join(cols)} |")
    return lines


def per_scenario(args, out, order):
    """Per scenario: share of the search's work, HF failures and failing cells per 10⁶ wu of
    that scenario's search work, confirmed failures per 10⁶ wu of its deployed work; savme's
    rows also the LF share of their search work. Mean over seeds (of the seeds' rates)."""
    sp = {s.name: s for s in spaces(args.scenarios)}
    runs = {}
    for f in row_files(out):
        r = json.loads(f.read_text())
        runs.setdefault(r["row"], []).append(r)
    means = {}
    lines = ["| method | scenario | search work share | HF failures, search | failing cells, search "
             "| confirmed, deployed | deployed work share | search runs | LF share of search work |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for method in order:
        for name in args.scenarios:
            vals = []
            for r in runs.get(method, []):
                s = [x for x in r["search"] if x[0] == name]
                d = [x for x in r["deployed"] if x[0] == name]
                sw, dw = sum(x[3] for x in s), sum(x[3] for x in d)
                cells = {cell(sp[name], x[1]) for x in s if x[2]}
                vals.append((sw / max(sum(x[3] for x in r["search"]), 1),
                             1e6 * sum(x[2] for x in s) / max(sw, 1), 1e6 * len(cells) / max(sw, 1),
                             1e6 * sum(x[2] for x in d) / max(dw, 1),
                             dw / max(sum(x[3] for x in r["deployed"]), 1), len(s),
                             sum(x[5] for x in s) / max(sw, 1)))
            if not vals:
                continue
            m = [statistics.mean(v[i] for v in vals) for i in range(7)]
            means[(method, name)] = m
            lines.append(f"| {method} | {name} | {m[0]:.2f} | {m[1]:.2f} | {m[2]:.2f} | {m[3]:.2f} "
                         f"| {m[4]:.2f} | {m[5]:.0f} | {m[6]:.2f} |")
    lines += ["", "| savme row / best peer (equal work), per scenario | scenario | HF failures, search "
              "| failing cells, search | confirmed, deployed |", "|---|---|---:|---:|---:|"]
    peers = [m for m in order if not m.startswith("savme") and "/" not in m]
    for me in (m for m in order if m.startswith("savme")):
        for name in args.scenarios:
            if (me, name) not in means or not peers:
                continue
            cols = []
            for i in (1, 2, 3):
                best = max(peers, key=lambda p: means.get((p, name), [0.0] * 7)[i])
                top = means.get((best, name), [0.0] * 7)[i]
                cols.append(f"{means[(me, name)][i] / top:.2f}× ({best})" if top > 0 else
                            f"{means[(me, name)][i]:.2f} vs 0")
            lines.append(f"| {me} | {name} | {' | '.join(cols)} |")
    return lines


def per_seed(args, out):
    """Per row, seed, part (search, deployed) and scenario: runs, HF failures, failing cells,
    work, HF and LF work, mean HF work of a failing and of a passing run, the mean φ of the
    failures; with each row's wall and CPU seconds (a small summary of runs/)."""
    sp = {s.name: s for s in spaces(args.scenarios)}
    rows = []
    for f in row_files(out):
        r = json.loads(f.read_text())
        parts = {}
        for part in ("search", "deployed"):
            for name in args.scenarios:
                xs = [x for x in r[part] if x[0] == name]
                fails = [x for x in xs if x[2]]
                passes = [x for x in xs if not x[2] and x[4]]
                parts[f"{part}/{name}"] = {
                    "runs": len(xs), "hf_failures": len(fails),
                    "failing_cells": len({cell(sp[name], x[1]) for x in fails}),
                    "work": sum(x[3] for x in xs), "hf_work": sum(x[4] for x in xs),
                    "lf_work": sum(x[5] for x in xs),
                    "hf_work_per_failure": statistics.mean(x[4] for x in fails) if fails else None,
                    "hf_work_per_pass": statistics.mean(x[4] for x in passes) if passes else None,
                    "failure_phi_mean": {k: statistics.mean(x[1][k] for x in fails)
                                         for k in fails[0][1]} if fails else None}
        rows.append({"row": r["row"], "seed": r["seed"], "wall_s": r["wall_s"],
                     "cpu_s": r["cpu_s"], "parts": parts})
    return rows


QUICK = {"seeds": 1, "iterations": 16, "screen_iterations": 8}  # --quick: a smoke run
DEFAULTS = {"seeds": 2, "iterations": 30, "screen_iterations": 30}


def parse_args(argv=None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenarios", nargs="+", default=["merge", "roundabout"])
    ap.add_argument("--quick", action="store_true",
                    help="a smoke run: seed 1, 16 search trials, 8 deployed (unless given)")
    ap.add_argument("--seeds", type=int, default=None, help="seeds 1..N (default 2; --quick 1)")
    ap.add_argument("--report", action="store_true", help="only the table of the rows in --out")
    ap.add_argument("--seed-list", type=int, nargs="+", help="these seeds instead (e.g. one per process)")
    ap.add_argument("--iterations", type=int, default=None,
                    help="savme's search trials (default 30; --quick 16)")
    ap.add_argument("--screen-iterations", type=int, default=None,
                    help="savme's deployed trials (default 30; --quick 8)")
    ap.add_argument("--budget", type=float, default=0.3)
    ap.add_argument("--elite", default="",
                    help="the savme rows' elite search parameters, e.g. tries=8 (the others keep "
                         "their defaults; savme-paper has none); for paired-seed comparisons")
    ap.add_argument("--rows", nargs="+", default=None,
                    help="rows to run, savme among them: savme (savme's defaults), savme-rho "
                         "(its simulator also returns ρ), savme-paper (method=\"paper\"), a VerifAI "
                         "sampler (equal work per scenario) or SAMPLER/trials (equal trials); "
                         "default: " + " ".join(DEFAULT_ROWS) + "; bayesopt rows are left out "
                         "if GPyOpt is not installed, and run last (schedule); rows already in "
                         "--out/rows.jsonl are skipped")
    ap.add_argument("--out", default=str(REPO / "target" / "peers" / "highway-env"))
    ap.add_argument("--no-build", action="store_true",
                    help="no wheel build: the newest savme wheel in target/wheels/highway-peers "
                         "or target/wheels/test")
    ap.add_argument("--setup-only", action="store_true",
                    help="set the venv up (and build the wheel), run nothing")
    args = ap.parse_args(argv)
    for key, value in (QUICK if args.quick else DEFAULTS).items():
        if getattr(args, key) is None:
            setattr(args, key, value)
    return args


def main():
    args = parse_args()
    if args.setup_only:
        setup(not args.no_build)
        return
    ensure_venv(not args.no_build)
    sys.path.insert(0, str(HERE))
    from verifai_peers import bayesopt_available

    rows = args.rows or DEFAULT_ROWS
    if not bayesopt_available() and any(r.split("/")[0] == "bayesopt" for r in rows):
        print("GPyOpt is not installed: the bayesopt rows are left out", file=sys.stderr)
        rows = [r for r in rows if r.split("/")[0] != "bayesopt"]
    args.rows = rows
    sp = spaces(args.scenarios)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    seeds = [] if args.report else args.seed_list or list(range(1, args.seeds + 1))
    if seeds:
        with open(out / COMMANDS, "a") as f:
            f.write(shlex.join(["python3", "benches/peers/run_highway_env.py", *sys.argv[1:]]) + "\n")
    run_rows(args, sp, out, seeds, args.rows)
    text = table(args, out)
    (out / "table.md").write_text(text + "\n")
    (out / "outcomes.json").write_text(json.dumps(outcomes(args, out), indent=1) + "\n")
    (out / "per-seed.json").write_text(json.dumps(per_seed(args, out), indent=1) + "\n")
    print("\n" + text)


if __name__ == "__main__":
    main()
