#!/usr/bin/env python3
"""The peer benchmark on highway-env (issue 29): savme's paired HF/LF search against VerifAI's
samplers on the same highway-env φ-spaces, the same work-unit budget and the same seeds.

    python/develop.sh --wheel                                      # savme's wheel, once
    python3 benches/peers/run_highway_env.py --seeds 2 --iterations 30 --screen-iterations 30

The first run creates target/highway-peers-venv (highway-env, VerifAI 2.2.0 from
requirements.txt, savme's wheel from target/wheels/test) and re-runs itself inside it.

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
import json
import os
import random
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
VENV = REPO / "target" / "highway-peers-venv"
BINS = 6


def ensure_venv() -> None:
    """Re-runs this script in the venv with highway-env, VerifAI and savme's wheel."""
    try:
        import highway_env  # noqa: F401
        import savme  # noqa: F401
        import verifai  # noqa: F401
        return
    except ImportError:
        pass
    py = VENV / "bin" / "python"
    if Path(sys.prefix).resolve() == VENV.resolve():  # (its python is a link to python3)
        sys.exit(f"{py}: highway-env, verifai or savme is missing; delete {VENV} and rerun")
    wheels = sorted((REPO / "target" / "wheels" / "test").glob("savme-*.whl"))
    if not wheels:
        sys.exit("no savme wheel in target/wheels/test: run python/develop.sh --wheel first")
    if not py.exists():
        subprocess.run([sys.executable, "-m", "venv", str(VENV)], check=True)
        pip = [str(VENV / "bin" / "pip"), "install", "-q", "--disable-pip-version-check"]
        subprocess.run(pip + ["highway-env==1.12.*", "-r", str(HERE / "requirements.txt")], check=True)
        if subprocess.run(pip + ["-r", str(HERE / "requirements-bayesopt.txt")]).returncode != 0:
            print("GPyOpt did not install: Bayesian optimisation is left out", file=sys.stderr)
    subprocess.run([str(VENV / "bin" / "pip"), "install", "-q", "--disable-pip-version-check",
                    "--force-reinstall", "--no-deps", str(wheels[-1])], check=True)
    os.execv(str(py), [str(py), __file__, *sys.argv[1:]])


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
        **({"method": "paper"} if variant == "savme-paper" else {}))
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


def peer_seed(method, seed, sp, search_budget, deployed_budget, split="work"):
    """One VerifAI sampler on one seed: HF runs until each budget is spent, the scenario to run
    next chosen by `split` (verifai_peers._Scenarios: "work" = the one that has cost least so
    far in this part, "trials" = in turn)."""
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
        parts.append(runs)
    return parts[0], parts[1], overhead


def rates(runs, sp):
    by_name = {s.name: s for s in sp}
    work = sum(r[3] for r in runs) or 1
    fails = [r for r in runs if r[2]]
    cells = {cell(by_name[r[0]], r[1]) for r in fails}
    return 1e6 * len(fails) / work, 1e6 * len(cells) / work, len(runs)


def record(path, method, seed, row):
    with open(path, "a") as f:
        f.write(json.dumps({"method": method, "seed": seed, "row": list(row)}) + "\n")


def fmt(xs):
    return f"{statistics.mean(xs):.2f} ± {statistics.stdev(xs):.2f}" if len(xs) > 1 else f"{xs[0]:.2f}"


DEFAULT_ROWS = ["savme", "cross-entropy", "bandit", "bayesopt", "random", "savme-rho", "halton",
                "annealing", "cross-entropy/trials", "bandit/trials", "bayesopt/trials",
                "random/trials", "halton/trials", "annealing/trials", "savme-paper"]


def run_rows(args, sp, out, seeds, rows):
    """Every row of every seed not yet in rows.jsonl; each row's runs go to runs/ROW-seed-S.json
    (scenario, φ, HF failure, work, HF work, LF work per run), its wall and CPU time with it."""
    done = out / "rows.jsonl"  # one line per (method, seed): several processes may add to it
    runs_dir = out / "runs"
    runs_dir.mkdir(exist_ok=True)
    have = set()
    if done.exists():
        have = {(r["method"], r["seed"]) for r in map(json.loads, done.read_text().splitlines())}
    for seed in seeds:
        budget = None
        for row in rows:
            if (row, seed) in have and row != "savme":
                continue
            t0, c0 = time.perf_counter(), time.process_time()
            if row.startswith("savme"):
                search, deployed = savme_seed(args, seed, out / f"{row}-seed-{seed}", row)
                overhead = 0.0
            else:
                if budget is None:
                    sys.exit("the savme row must come first: it sets every peer's budget")
                method, _, split = row.partition("/")
                search, deployed, overhead = peer_seed(method, seed, sp, *budget, split or "work")
            sw, dw = sum(r[3] for r in search), sum(r[3] for r in deployed)
            if row == "savme":
                budget = (sw, dw)
                if (row, seed) in have:
                    continue
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
            f, c, n = rates(search, sp)
            confirmed = 1e6 * sum(r[2] for r in deployed) / max(dw, 1)
            record(done, row, seed, (f, c, confirmed, n, sw, dw,
                                     1e3 * overhead / max(len(search) + len(deployed), 1)))
            (runs_dir / f"{row.replace('/', '-')}-seed-{seed}.json").write_text(json.dumps(
                {"row": row, "seed": seed, "wall_s": wall, "cpu_s": cpu, "search": search,
                 "deployed": deployed}))
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
    for f in sorted((out / "runs").glob("*.json")):
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
    for f in sorted((out / "runs").glob("*.json")):
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


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenarios", nargs="+", default=["merge", "roundabout"])
    ap.add_argument("--seeds", type=int, default=2, help="seeds 1..N")
    ap.add_argument("--report", action="store_true", help="only the table of the rows in --out")
    ap.add_argument("--seed-list", type=int, nargs="+", help="these seeds instead (e.g. one per process)")
    ap.add_argument("--iterations", type=int, default=30, help="savme's search trials")
    ap.add_argument("--screen-iterations", type=int, default=30, help="savme's deployed trials")
    ap.add_argument("--budget", type=float, default=0.3)
    ap.add_argument("--rows", nargs="+", default=None,
                    help="rows in the order run, savme first: savme (savme's defaults), savme-rho "
                         "(its simulator also returns ρ), savme-paper (method=\"paper\"), a VerifAI sampler (equal work per "
                         "scenario) or SAMPLER/trials (equal trials); default: "
                         + " ".join(DEFAULT_ROWS) + " (bayesopt only if GPyOpt is installed); "
                         "rows already in --out/rows.jsonl are skipped")
    ap.add_argument("--out", default=str(REPO / "target" / "peers" / "highway-env"))
    args = ap.parse_args()
    ensure_venv()
    sys.path.insert(0, str(HERE))
    if args.rows is None:
        from verifai_peers import bayesopt_available

        args.rows = [r for r in DEFAULT_ROWS if not r.startswith("bayesopt") or bayesopt_available()]
    sp = spaces(args.scenarios)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    seeds = [] if args.report else args.seed_list or list(range(1, args.seeds + 1))
    run_rows(args, sp, out, seeds, args.rows)
    text = table(args, out)
    (out / "table.md").write_text(text + "\n")
    (out / "per-seed.json").write_text(json.dumps(per_seed(args, out), indent=1) + "\n")
    print("\n" + text)


if __name__ == "__main__":
    main()
