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


def savme_seed(args, seed, out):
    """savme's search and deployed runs on one seed, read from its trials.jsonl."""
    import savme
    from savme.integrations import highway_env as hw

    test = [s for s in ["intersection", "highway", "roundabout", "merge"] if s not in args.scenarios][:1]
    protocol = savme.Protocol(
        args.scenarios, test, preset="quick", simulator="highway-env", cost="work", seed=seed,
        budgets=[args.budget], train_iterations=args.iterations, eval_iterations=1,
        test_iterations=1, baseline_train_iterations=1, baseline_test_iterations=1,
        screen_iterations=max(args.screen_iterations, 1), audit_fraction=0.0)
    resume = (out / "protocol.json").exists()
    savme.Campaign(None if resume else protocol, hw.problem(args.scenarios + test), out=out,
                   resume=resume, jobs=1).run(hw.campaign_simulator())
    search, deployed = [], []
    for line in (out / "trials.jsonl").read_text().splitlines():
        t = json.loads(line)
        if "protocol" in t:  # the store's first record: the campaign's protocol
            continue
        work = t["hf"]["work"] if t.get("hf") else 0
        work += t["lf"]["work"] if t.get("lf") else 0
        if t["stage"] == f"train@{args.budget}":
            search.append((t["scenario"], t["phi"], t["hf"]["failure"], work))
        elif t["stage"] == f"screen@{args.budget}":
            deployed.append((t["scenario"], t["phi"], bool(t.get("hf") and t["hf"]["failure"]), work))
    return search, deployed


def peer_seed(method, seed, sp, search_budget, deployed_budget):
    """One VerifAI sampler on one seed: HF runs until each budget is spent."""
    import numpy as np
    from verifai_peers import _Scenarios, annealing_started, phi_of
    from savme.integrations import highway_env as hw

    random.seed(seed)
    np.random.seed(seed)
    state, overhead, parts = _Scenarios(method, sp), 0.0, []
    for budget in (search_budget, deployed_budget):
        runs, spent = [], 0
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
            runs.append((sp[k].name, phi, r["failure"], r["work"]))
            spent += r["work"]
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


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenarios", nargs="+", default=["merge", "roundabout"])
    ap.add_argument("--seeds", type=int, default=2, help="seeds 1..N")
    ap.add_argument("--report", action="store_true", help="only the table of the rows in --out")
    ap.add_argument("--seed-list", type=int, nargs="+", help="these seeds instead (e.g. one per process)")
    ap.add_argument("--iterations", type=int, default=30, help="savme's search trials")
    ap.add_argument("--screen-iterations", type=int, default=30, help="savme's deployed trials")
    ap.add_argument("--budget", type=float, default=0.3)
    ap.add_argument("--peers", nargs="+", default=None,
                    help="VerifAI samplers (default: all six; bayesopt only if GPyOpt is installed)")
    ap.add_argument("--out", default=str(REPO / "target" / "peers" / "highway-env"))
    args = ap.parse_args()
    ensure_venv()
    sys.path.insert(0, str(HERE))
    if args.peers is None:
        from verifai_peers import PEERS, bayesopt_available

        args.peers = [m for m in PEERS if m != "bayesopt" or bayesopt_available()]
    sp = spaces(args.scenarios)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    seeds = [] if args.report else args.seed_list or list(range(1, args.seeds + 1))
    done = out / "rows.jsonl"  # one line per (method, seed): several processes may add to it
    for seed in seeds:
        t0 = time.perf_counter()
        search, deployed = savme_seed(args, seed, out / f"savme-seed-{seed}")
        sw, dw = sum(r[3] for r in search), sum(r[3] for r in deployed)
        f, c, n = rates(search, sp)
        confirmed = 1e6 * sum(r[2] for r in deployed) / max(dw, 1)
        record(done, "savme", seed, (f, c, confirmed, n, sw, dw, 0.0))
        print(f"seed {seed}: savme {n} trials, search {sw} wu, deployed {dw} wu "
              f"({time.perf_counter() - t0:.0f} s)", flush=True)
        for method in args.peers:
            t0 = time.perf_counter()
            s_runs, d_runs, overhead = peer_seed(method, seed, sp, sw, dw)
            f, c, n = rates(s_runs, sp)
            confirmed = 1e6 * sum(r[2] for r in d_runs) / max(sum(r[3] for r in d_runs), 1)
            record(done, method, seed, (f, c, confirmed, n, sw, dw,
                                        1e3 * overhead / max(len(s_runs) + len(d_runs), 1)))
            print(f"seed {seed}: {method} {n} HF runs ({time.perf_counter() - t0:.0f} s)", flush=True)
    rows = {}
    for line in done.read_text().splitlines():
        r = json.loads(line)
        rows.setdefault(r["method"], {})[r["seed"]] = r["row"]
    rows = {m: [by_seed[s] for s in sorted(by_seed)] for m, by_seed in rows.items()}
    lines = [
        f"highway-env scenarios {', '.join(args.scenarios)}; seeds: {len(rows['savme'])} "
        f"(rows of {done}); savme "
        f"{rows['savme'][0][3]} search trials (deployed: --screen-iterations) at budget {args.budget}; "
        "per 10⁶ work units, mean ± sd over seeds",
        "",
        "| method | HF failures, search | distinct failing cells, search | confirmed failures, deployed "
        "| search runs (trials) | sampler overhead ms/run |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for method, rs in rows.items():
        cols = [fmt([r[i] for r in rs]) for i in range(3)]
        lines.append(f"| {method} | {' | '.join(cols)} | {statistics.mean(r[3] for r in rs):.0f} "
                     f"| {'—' if method == 'savme' else f'{statistics.mean(r[6] for r in rs):.2f}'} |")
    table = "\n".join(lines)
    (out / "table.md").write_text(table + "\n")
    print("\n" + table)


if __name__ == "__main__":
    main()
