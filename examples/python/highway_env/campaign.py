#!/usr/bin/env python3
"""The paper's protocol on highway-env: meta-training on the highway, merge and roundabout
environments, meta-testing on the intersection, with a rule-based lidar driver as the system
under test (savme.integrations.highway_env). Writes savme run's outputs (table.md = Table III,
fidelity.md = Table IV, summary.json, trials.jsonl, plots) and prints both tables.

    python examples/python/highway_env/campaign.py --out hw-results            # run
    python examples/python/highway_env/campaign.py --out hw-results --resume   # continue

Needs highway-env (pip install highway-env; scripts/highway-env-venv makes a venv with it).
"""

import argparse
import pathlib

import savme
from savme.integrations import highway_env as hw


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="savme-highway-env")
    ap.add_argument("--resume", action="store_true", help="continue the campaign in --out")
    ap.add_argument("--iterations", type=int, default=40,
                    help="meta-training iterations (evaluation n/4, meta-testing n/2, "
                         "baselines n+n/4 and 3n/4, as the quick preset's proportions)")
    for stage, default in (("eval", "n/4"), ("test", "n/2"), ("baseline", "n+n/4"),
                           ("baseline-test", "3n/4")):
        ap.add_argument(f"--{stage}-iterations", type=int, default=None,
                        help=f"that stage's trials (default {default})")
    ap.add_argument("--budgets", type=float, nargs="+", default=[0.3],
                    help="cost budgets (fractions of the HF cost)")
    ap.add_argument("--train", nargs="+", default=["highway", "merge", "roundabout"])
    ap.add_argument("--test", nargs="+", default=["intersection"])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--cost", choices=["work", "wall"], default="work",
                    help="work: the adapter's deterministic work count (reproducible bit for "
                         "bit); wall: measured runtime")
    ap.add_argument("--jobs", type=int, default=1,
                    help="worker threads (highway-env is CPU-bound Python: 1 is as fast)")
    a = ap.parse_args()
    problem = hw.problem(a.train + [s for s in a.test if s not in a.train])
    n = a.iterations
    protocol = None if a.resume else savme.Protocol(
        a.train, a.test, preset="quick", simulator="highway-env", cost=a.cost, seed=a.seed,
        budgets=a.budgets, train_iterations=n,
        eval_iterations=a.eval_iterations or max(n // 4, 1),
        test_iterations=a.test_iterations or max(n // 2, 1),
        baseline_train_iterations=a.baseline_iterations or n + n // 4,
        baseline_test_iterations=a.baseline_test_iterations or max(3 * n // 4, 1))
    campaign = savme.Campaign(protocol, problem, out=a.out, resume=a.resume, jobs=a.jobs,
                              progress=True)
    result = campaign.run(hw.campaign_simulator(cost=a.cost))
    print("Table III (table.md)\n")
    print(result.table_md)
    print("Table IV (fidelity.md)\n")
    print(pathlib.Path(result.files["fidelity"]).read_text())
    print(f"{result.ran} trials run, {result.replayed} replayed in {result.elapsed_seconds:.0f} s; "
          f"outputs in {result.out}")


if __name__ == "__main__":
    main()
