#!/usr/bin/env python3
"""How well the adapter's deterministic work count tracks CPU time on highway-env: N runs at
random (scenario, φ, θ) (seeded), each timed with time.process_time(); prints the correlation
of work with CPU time, the median relative error of work as µs, and (--fit) the least-squares
weight of each counted term (how WORK_WEIGHTS and Scenario.frame_vehicle_us were set).

    python examples/python/highway_env/calibrate_work.py --n 30 --seed 5 --fit
"""

import argparse
import random
import statistics
import time

import numpy as np

from savme.integrations import highway_env as hw


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=30)
    ap.add_argument("--seed", type=int, default=5)
    ap.add_argument("--fit", action="store_true")
    a = ap.parse_args()
    rng = random.Random(a.seed)
    hw.simulate("highway", hw.nominal_phi("highway"))  # imports and first-use costs
    names = list(hw.SCENARIOS)
    rows, cpu, work = [], [], []
    for i in range(a.n):
        sc = names[i % len(names)]
        phi = {name: (rng.randint(int(lo), int(hi)) if integer else rng.uniform(lo, hi))
               for name, lo, hi, integer, _ in hw.SCENARIOS[sc].variables}
        theta = {name: rng.choice(values) for name, values, _, _ in hw.FIDELITY_VARIABLES}
        t = time.process_time()
        r = hw.simulate(sc, phi, theta)
        cpu.append(1e6 * (time.process_time() - t))
        work.append(r["work"])
        c = r["counts"]
        rows.append([c["runs"]] + [c["frame_vehicles"] if sc == s else 0 for s in names]
                    + [c["frame_pairs"], c["decision_vehicles"], c["lidar_cells"]])
    rel = [abs(w - c) / c for w, c in zip(work, cpu)]
    print(f"{a.n} runs (seed {a.seed}): Pearson r(work, CPU µs) = {statistics.correlation(work, cpu):.3f}; "
          f"median |work − CPU µs| / CPU µs = {statistics.median(rel):.2f}")
    if a.fit:
        w, *_ = np.linalg.lstsq(np.array(rows, float), np.array(cpu), rcond=None)
        terms = ["runs"] + [f"frame_vehicles ({s})" for s in names] + ["frame_pairs", "decision_vehicles", "lidar_cells"]
        for term, weight in zip(terms, w):
            print(f"  {term}: {weight:.1f} µs")


if __name__ == "__main__":
    main()
