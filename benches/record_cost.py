#!/usr/bin/env python3
"""What recording costs a campaign: `savme reproduce` (by default a 250-trial protocol: one
budget, 60 meta-training, 10 evaluation, 2 x 30 meta-testing, 80 + 40 baseline trials; `--quick`
for the 860-trial preset) with and without `--record FILE.rrd` (the default recording: the
campaign view, every 200th trial and up to 10 informative ones with frames), interleaved in one
run so that both see the same machine load.

    cargo build --release --features rerun --bin savme
    python3 benches/record_cost.py --savme $CARGO_TARGET_DIR/release/savme --pairs 3

The smaller protocol is the harder case: the 10 informative trials are a fixed cost, a larger
share of a shorter campaign.

Prints, per run, the wall seconds and the CPU seconds (user + system of the savme process and
its children, from getrusage), then the medians and the ratios recorded / plain (the target:
recording costs at most 10 %), the recording's size, and the load average before and after.
"""

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time


def run(savme, args, out):
    """One campaign; returns (wall seconds, CPU seconds)."""
    shutil.rmtree(out, ignore_errors=True)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    p = subprocess.run([savme, *args, "--out", out], capture_output=True, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        sys.exit(f"savme {' '.join(args)} failed:\n{p.stderr}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--savme", required=True, help="a savme built with --features rerun")
    ap.add_argument("--pairs", type=int, default=3, help="runs with and without recording each")
    ap.add_argument("--jobs", default="2", help="savme --jobs")
    ap.add_argument("--quick", action="store_true", help="the 860-trial --quick preset")
    a = ap.parse_args()
    base = ["reproduce", "--quiet", "--seed", "1", "--jobs", a.jobs]
    if a.quick:
        base.append("--quick")
    else:
        base += ["--budgets", "0.3", "--iterations", "60", "--eval-iterations", "10",
                 "--test-iterations", "30", "--baseline-iterations", "80",
                 "--baseline-test-iterations", "40"]
    tmp = tempfile.mkdtemp(prefix="savme-record-cost-")
    rrd = os.path.join(tmp, "campaign.rrd")
    print(f"load average before: {os.getloadavg()}")
    plain, recorded = [], []
    for k in range(a.pairs):
        # Alternate which goes first, so that a drift in load favours neither.
        order = [False, True] if k % 2 == 0 else [True, False]
        for rec in order:
            args = base + (["--record", rrd] if rec else [])
            wall, cpu = run(a.savme, args, os.path.join(tmp, "out"))
            (recorded if rec else plain).append((wall, cpu))
            kind = "recorded" if rec else "plain   "
            print(f"pair {k + 1} {kind}: wall {wall:7.2f} s  cpu {cpu:7.2f} s", flush=True)
    size = os.path.getsize(rrd)
    med = lambda xs, i: statistics.median(x[i] for x in xs)  # noqa: E731
    print(f"load average after: {os.getloadavg()}")
    print(f"recording: {size / 1e6:.1f} MB")
    for i, what in [(0, "wall"), (1, "cpu")]:
        p, r = med(plain, i), med(recorded, i)
        print(f"median {what}: plain {p:.2f} s, recorded {r:.2f} s, ratio {r / p:.3f} "
              f"(+{100 * (r / p - 1):.1f} %)")
    ratios = [r[1] / p[1] for p, r in zip(plain, recorded)]
    print("cpu ratio per pair: " + ", ".join(f"{x:.3f}" for x in ratios))
    shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
