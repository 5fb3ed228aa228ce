#!/usr/bin/env python3
"""The Ray executor's benchmark (issue 28 item 6, issue 41 item 4): campaigns on a local Ray
cluster (a head and a worker node on this machine, 2 + 2 CPUs) with 1 and with 4 runs at once,
on a simulator that only sleeps (so that 4 workers on a 2-core machine scale as they would on 4
cores) — the default (tasks, two handed per slot), one run per slot, and actors; and the
executor's overhead per run on a simulator that returns at once, against the same campaign on
one local thread.

    target/py-venv/bin/python python/bench_ray.py --bench                  # docs/BENCHMARKS.md
    target/py-venv/bin/python python/bench_ray.py --bench --quick          # one repetition
    target/py-venv/bin/python python/bench_ray.py --bench --scale 4 --only "1 Ray" --only default

Each sleeping run appends its start and end to a trace file per worker process, so the table
also says where the workers' time went: running, idle between two runs (waiting for the
driver or for Ray's dispatch), and before the first / after the last run (the campaign's own
start and its outputs). Needs the savme package and Ray in the interpreter's environment
(python/develop.sh). Prints Markdown tables: medians over the repetitions.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import shutil
import statistics
import sys
import tempfile
import time

HERE = pathlib.Path(__file__).resolve().parent
# The installed savme, not the source folder beside this script when it lacks the extension
# (`python/develop.sh` without --wheel builds it in place).
if not list((HERE / "savme").glob("_savme*.so")):
    sys.path = [p for p in sys.path if pathlib.Path(p or ".").resolve() != HERE]
sys.path.insert(0, str(HERE / "tests"))

import ray  # noqa: E402

import savme  # noqa: E402
from ray_cluster import LocalRayCluster  # noqa: E402
from ray_sims import TracedSleeper  # noqa: E402
from test_campaign import problem  # noqa: E402


def protocol(seed: int, scale: int, window: int) -> savme.Protocol:
    return savme.Protocol(["stopped", "braking"], ["cut_in"], preset="quick", seed=seed,
                          cost="work", budgets=[0.3], train_iterations=40 * scale,
                          eval_iterations=10 * scale, test_iterations=20 * scale,
                          baseline_train_iterations=25 * scale,
                          baseline_test_iterations=15 * scale, simulator="python-bench",
                          window=window)


def runs_of(result: savme.CampaignResult) -> int:
    n = 0
    for line in pathlib.Path(result.files["trials"]).read_text().splitlines():
        d = json.loads(line)
        n += sum(isinstance(d.get(r), dict) for r in ("hf", "lf"))
    return n


def where_time_went(trace: pathlib.Path, t0: float, t1: float, slots: int) -> dict:
    """From the trace files: seconds of runs, of gaps between two runs of one worker process,
    and of the campaign before its first and after its last run."""
    spans = []
    idle = 0.0
    for f in trace.iterdir():
        runs = sorted(tuple(map(float, line.split())) for line in f.read_text().splitlines())
        spans += runs
        idle += sum(b[0] - a[1] for a, b in zip(runs, runs[1:]))
    first, last = min(s for s, _ in spans), max(e for _, e in spans)
    busy = sum(e - s for s, e in spans)
    return {"busy": busy, "gaps": idle, "before": first - t0, "after": t1 - last,
            "utilisation": busy / (slots * (last - first))}


def campaign(out: pathlib.Path, seed: int, sleep: float, args, executor=None, jobs=None):
    trace = out.with_name(out.name + "-trace")
    shutil.rmtree(trace, ignore_errors=True)
    trace.mkdir()
    sim = TracedSleeper(sleep, str(trace))
    kw = {"executor": executor} if executor is not None else {"jobs": jobs}
    shutil.rmtree(out, ignore_errors=True)
    start = time.time()
    result = savme.Campaign(protocol(seed, args.scale, args.window), problem(), out=out, **kw).run(sim)
    end = time.time()
    return end - start, result, (trace, start, end)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bench", action="store_true", help="run the benchmark")
    ap.add_argument("--quick", action="store_true", help="one repetition")
    ap.add_argument("--sleep", type=float, default=0.05, help="seconds a sleeping run takes (0.05)")
    ap.add_argument("--scale", type=int, default=2, help="stage lengths × this (2: 260 trials)")
    ap.add_argument("--window", type=int, default=8, help="trials in flight (8)")
    ap.add_argument("--only", action="append", default=[],
                    help="run only the rows whose label contains this (repeatable)")
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
        # Warm up: Ray's worker processes start once.
        campaign(tmp / "warm", 9, 0.0, args, executor=savme.RayExecutor())
        for label, sleep, slots, make in [
            ("sleeping, 1 Ray worker (workers=1)", args.sleep, 1,
             lambda: savme.RayExecutor(workers=1)),
            ("sleeping, 1 Ray actor (actors=1)", args.sleep, 1, lambda: savme.RayExecutor(actors=1)),
            ("sleeping, 4 Ray workers (the whole cluster, default)", args.sleep, 4,
             lambda: savme.RayExecutor()),
            ("sleeping, 4 Ray workers, one run per slot (workers=4)", args.sleep, 4,
             lambda: savme.RayExecutor(workers=4)),
            ("sleeping, 4 Ray actors (actors=4)", args.sleep, 4, lambda: savme.RayExecutor(actors=4)),
            ("null, 1 local thread", 0.0, 1, None),
            ("null, 1 Ray worker (workers=1)", 0.0, 1, lambda: savme.RayExecutor(workers=1)),
            ("null, 4 Ray workers (default)", 0.0, 4, lambda: savme.RayExecutor()),
        ]:
            if args.only and not any(o in label for o in args.only):
                continue
            times, trials, runs, split = [], 0, 0, []
            for seed in seeds:
                load = os.getloadavg()[0]
                if make is None:
                    wall, result, traced = campaign(tmp / "run", seed, sleep, args, jobs=1)
                else:
                    wall, result, traced = campaign(tmp / "run", seed, sleep, args, executor=make())
                times.append(wall)
                trials, runs = result.ran, runs_of(result)
                split.append(where_time_went(*traced, slots))
                print(f"{label}, seed {seed}: {wall:.2f} s (load {load:.1f} → "
                      f"{os.getloadavg()[0]:.1f}) {split[-1]}", file=sys.stderr, flush=True)
            rows.append((label, statistics.median(times), trials, runs,
                         {k: statistics.median(s[k] for s in split) for k in split[0]}))
        ray.shutdown()
    shutil.rmtree(tmp, ignore_errors=True)
    by = {r[0]: r for r in rows}
    print("| campaign | wall s (median) | trials | runs | ms per run | runs s | gaps between runs s | before first run s | after last run s | worker utilisation |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for label, wall, trials, runs, w in rows:
        print(f"| {label} | {wall:.2f} | {trials} | {runs} | {1000 * wall / runs:.1f} | "
              f"{w['busy']:.2f} | {w['gaps']:.2f} | {w['before']:.2f} | {w['after']:.2f} | "
              f"{100 * w['utilisation']:.0f} % |")
    ones = {k: v[1] for k, v in by.items() if k.startswith("sleeping, 1 ")}
    if not ones:
        return
    best_one = min(ones.values())
    for label in [k for k in by if k.startswith("sleeping, 4 ")]:
        print(f"\nspeed-up, {label[10:]} over the faster 1-worker row ({best_one:.2f} s): "
              f"{best_one / by[label][1]:.2f}×")
    local = by.get("null, 1 local thread")
    for label in [k for k in ("null, 1 Ray worker (workers=1)", "null, 4 Ray workers (default)")
                  if local and k in by]:
        wall, trials, runs = by[label][1:4]
        print(f"executor overhead, {label}: {1000 * (wall - local[1]) / runs:.1f} ms per run "
              f"(vs 1 local thread)")


if __name__ == "__main__":
    main()
