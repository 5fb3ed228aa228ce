#!/usr/bin/env python3
"""Each fidelity setting's cost and how often it flips an outcome, on highway-env: for N
random φ per scenario (seeded), one run at θ_HF and one at each setting that differs from θ_HF
in one variable (and at the cheapest θ in all variables). Prints a Markdown table: per setting,
the mean work and wall-clock time relative to θ_HF, and the share of φ whose failure flag
differs from θ_HF's (flips; HF failures missed / false alarms in brackets).

    python examples/python/highway_env/fidelity_effects.py --n 12 --seed 1
"""

import argparse
import random
import statistics

from savme.integrations import highway_env as hw


def settings():
    """(label, θ): θ_HF, each one-variable deviation, and the cheapest θ."""
    out = [("θ_HF", dict(hw.THETA_HF))]
    for name, values, hf, _ in hw.FIDELITY_VARIABLES:
        out += [(f"{name}={v}", dict(hw.THETA_HF, **{name: v})) for v in values if v != hf]
    out.append(("cheapest (all lowest)", {n: min(vs) for n, vs, _, _ in hw.FIDELITY_VARIABLES}))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=12, help="random φ per scenario")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--scenarios", nargs="+", default=list(hw.SCENARIOS))
    a = ap.parse_args()
    rng = random.Random(a.seed)
    rows = {label: {"work": [], "wall": [], "missed": 0, "false": 0} for label, _ in settings()}
    hf_failures = 0
    for scenario in a.scenarios:
        for _ in range(a.n):
            phi = {name: (rng.randint(int(lo), int(hi)) if integer else rng.uniform(lo, hi))
                   for name, lo, hi, integer, _ in hw.SCENARIOS[scenario].variables}
            hf = None
            for label, theta in settings():
                r = hw.simulate(scenario, phi, theta)
                hf = hf or r
                row = rows[label]
                row["work"].append(r["work"] / hf["work"])
                row["wall"].append(r["wall_seconds"] / hf["wall_seconds"])
                row["missed"] += hf["failure"] and not r["failure"]
                row["false"] += r["failure"] and not hf["failure"]
            hf_failures += hf["failure"]
        print(f"{scenario}: done", flush=True)
    total = a.n * len(a.scenarios)
    print(f"\n{total} φ ({a.n} per scenario: {', '.join(a.scenarios)}; seed {a.seed}); "
          f"{hf_failures} fail at θ_HF\n")
    print("| setting | work / HF (mean) | wall / HF (median) | flips (missed / false) |")
    print("|---|---:|---:|---:|")
    for label, row in rows.items():
        flips = row["missed"] + row["false"]
        print(f"| {label} | {statistics.mean(row['work']):.2f} | {statistics.median(row['wall']):.2f} | "
              f"{flips}/{total} = {flips / total:.0%} ({row['missed']} / {row['false']}) |")


if __name__ == "__main__":
    main()
