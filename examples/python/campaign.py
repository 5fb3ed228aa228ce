#!/usr/bin/env python3
"""The paper's protocol (quick preset) on a Python simulator, through savme's campaign loop:
the same outputs as `savme run` (table.md, fidelity.md, summary.json, trials.jsonl, plots).

    python3 examples/python/campaign.py --out py-results          # run
    python3 examples/python/campaign.py --out py-results --resume # continue after a crash
"""

import argparse

import savme
from harness import FIDELITY, PHI, THETA_HF, simulate


def counted(scenario, phi, theta):
    """The harness's simulator with a deterministic cost: (failure, work units)."""
    fails, runtime = simulate(scenario, phi, theta)
    return fails, int(runtime * 1500)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="savme-py-results")
    ap.add_argument("--resume", action="store_true")
    ap.add_argument("--iterations", type=int, default=200, help="meta-training iterations")
    ap.add_argument("--jobs", type=int, default=None)
    a = ap.parse_args()
    problem = savme.Problem(fidelity=FIDELITY, theta_hf=THETA_HF,
                            scenarios={"dry_road": PHI, "highway": PHI, "wet_road": PHI})
    n = a.iterations
    protocol = None if a.resume else savme.Protocol(
        ["dry_road", "highway"], ["wet_road"], preset="quick", simulator="python-harness",
        cost="work", train_iterations=n, eval_iterations=n // 4, test_iterations=n // 2,
        baseline_train_iterations=n + n // 4, baseline_test_iterations=n // 2 + n // 4)
    campaign = savme.Campaign(protocol, problem, out=a.out, resume=a.resume, jobs=a.jobs, progress=True)
    result = campaign.run(counted)
    print(result.table_md)
    print(f"{result.ran} trials run, {result.replayed} replayed; outputs in {result.out}")


if __name__ == "__main__":
    main()
