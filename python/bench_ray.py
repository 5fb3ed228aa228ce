#!/usr/bin/env python3
"""The Ray executor's benchmark (issue 28, item 6): campaigns on a local Ray cluster (a head and
a worker node on this machine, 2 + 2 CPUs) with 1 and with 4 runs at once, on a simulator that
only sleeps; and the executor's overhead per trial on a simulator that returns at once, against
the same campaign on one local thread.

    target/py-venv/bin/python python/bench_ray.py --bench            # the figures of docs/BENCHMARKS.md
    target/py-venv/bin/python python/bench_ray.py --bench --quick    # one repetition, shorter

Needs the savme package and Ray in the interpreter's environment (python/develop.sh, then
pip install ray). Prints a Markdown table: medians over the repetitions.
"""

from __future__ import annotations

import argparse
import pathlib
import shutil
import statistics
import sys
import tempfile
import time

HERE = pathlib.Path(__file__).resolve().parent
# The installed savme, not the source folder beside this script (it lacks the extension).
sys.path = [p for p in sys.path if pathlib.Path(p or ".").resolve() != HERE]
sys.path.insert(0, str(HERE / "tests"))

import ray  # noqa: E402

import savme  # noqa: E402
from ray_cluster import LocalRayCluster  # noqa: E402
from ray_sims import Sleeper  # noqa: E402
from test_campaign import problem  # noqa: E402


def protocol(seed: int) -> savme.Protocol:
    return savme.Protocol(["stopped", "braking"], ["cut_in"], preset="quick", seed=seed,
                          cost="work", budgets=[0.3], train_iterations=40, eval_iterations=10,
                          test_iterations=20, baseline_train_iterations=25,
                          baseline_test_iterations=15, simulator="python-bench")


def runs_of(result: savme.CampaignResult) -> int:
    import json
    n = 0
    for line in pathlib.Path(result.files["trials"]).read_text().splitlines():
        d = json.loads(line)
        n += sum(isinstance(d.get(r), dict) for r in ("hf", "lf"))
    return n


def campaign(out: pathlib.Path, seed: int, sleep: float, executor=None, jobs=None):
    sim = Sleeper(sleep)
    kw = {"executor": executor} if executor is not None else {"jobs": jobs}
    shutil.rmtree(out, ignore_errors=True)
    start = time.perf_counter()
    result = savme.Campaign(protocol(seed), problem(), out=out, **kw).run(sim)
    return time.perf_counter() - start, result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bench", action="store_true", help="run the benchmark")
    ap.add_argument("--quick", action="store_true", help="one repetition")
    ap.add_argument("--sleep", type=float, default=0.5, help="seconds a sleeping run takes (0.5)")
    args = ap.parse_args()
    if not args.bench:
        ap.print_help()
        return
    seeds = [1] if args.quick else [1, 2, 3]
    tmp = pathlib.Path(tempfile.mkdtemp(prefix="savme-bench-ray-"))
    rows = []
    with LocalRayCluster(head_cpus=2, worker_cpus=[2], pythonpath=str(HERE / "tests")) as c:
        ray.init(address=c.address, logging_level="warning", log_to_driver=False)
        print(f"cluster: {ray.cluster_resources().get('CPU')} CPUs on "
              f"{len([n for n in ray.nodes() if n['Alive']])} nodes", file=sys.stderr)
        # Warm up: the worker processes start once.
        campaign(tmp / "warm", 9, 0.0, executor=savme.RayExecutor(workers=4))
        for label, sleep, make in [
            ("sleeping, 1 Ray worker", args.sleep, lambda: savme.RayExecutor(workers=1)),
            ("sleeping, 4 Ray workers", args.sleep, lambda: savme.RayExecutor(workers=4)),
            ("sleeping, 4 Ray actors", args.sleep, lambda: savme.RayExecutor(actors=4)),
            ("null, 1 local thread", 0.0, None),
            ("null, 1 Ray worker", 0.0, lambda: savme.RayExecutor(workers=1)),
            ("null, 4 Ray workers", 0.0, lambda: savme.RayExecutor(workers=4)),
        ]:
            times, trials, runs = [], 0, 0
            for seed in seeds:
                if make is None:
                    wall, result = campaign(tmp / "run", seed, sleep, jobs=1)
                else:
                    wall, result = campaign(tmp / "run", seed, sleep, executor=make())
                times.append(wall)
                trials, runs = result.ran, runs_of(result)
            rows.append((label, statistics.median(times), trials, runs))
            print(f"{label}: {times}", file=sys.stderr)
        ray.shutdown()
    shutil.rmtree(tmp, ignore_errors=True)
    by = {r[0]: r for r in rows}
    print("| campaign | wall s (median) | trials | runs | trials/s | ms per trial |")
    print("|---|---|---|---|---|---|")
    for label, wall, trials, runs in rows:
        print(f"| {label} | {wall:.2f} | {trials} | {runs} | {trials / wall:.1f} | {1000 * wall / trials:.1f} |")
    one, four = by["sleeping, 1 Ray worker"][1], by["sleeping, 4 Ray workers"][1]
    print(f"\nspeed-up, 4 Ray workers over 1 (sleeping {args.sleep} s): {one / four:.2f}×")
    print(f"speed-up, 4 Ray actors over 1 worker: {one / by['sleeping, 4 Ray actors'][1]:.2f}×")
    local = by["null, 1 local thread"]
    for label in ("null, 1 Ray worker", "null, 4 Ray workers"):
        wall, trials, runs = by[label][1:]
        print(f"executor overhead, {label}: {1000 * (wall - local[1]) / trials:.1f} ms per trial, "
              f"{1000 * (wall - local[1]) / runs:.1f} ms per run (vs 1 local thread)")


if __name__ == "__main__":
    main()
