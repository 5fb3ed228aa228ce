#!/usr/bin/env python3
"""How well can ANY per-variable (product-form) proposal do on a rare-event setting?

Reads a plain Monte Carlo run under the nominal, logged as an estimate with ε = 1 (every
line's weight is 1), e.g.

    cargo run --release --example estimate_check -- --out /tmp/mc --mc-runs 0 \
        --epsilon 1 --target 0.000001 --max-runs 150000 --jobs 2 --nominal ...

then fits the best product-of-histograms proposal there is — each variable's 10-bin marginal
of the failures (the marginals of the zero-variance density p(φ)·1{failure}/P), mixed with the
nominal's bins by `smooth` — TO THE MONTE CARLO FAILURES THEMSELVES (an oracle no real pilot
has), and evaluates it on the same failures: relative variance E_p[w | failure]/P − 1 of the
defensive mixture q = (1 − ε)·q_product + ε·p, and the gain over plain Monte Carlo,
((1 − P)/P) / relvar. This is an optimistic bound for the family (fit and test on the same
points) — an indication of the ceiling of the family, not a proof. docs/BENCHMARKS.md
records what it printed.

    python3 benches/product_proposal_bound.py /tmp/mc/estimate
"""
import collections
import json
import sys
from statistics import NormalDist

# lead_vehicle_brakes' φ-space (reference-sim/src/scenario.rs), 10 linear bins each.
RANGES = {
    "ego_speed": (10.0, 25.0),
    "lead_speed": (5.0, 20.0),
    "gap": (8.0, 28.0),
    "lead_decel": (4.0, 9.0),
    "brake_time": (0.5, 4.0),
}
BINS = 10


def main(directory):
    settings = json.load(open(f"{directory}/estimate.json"))
    if settings["epsilon"] != 1:
        sys.exit("needs a plain Monte Carlo run: an estimate with --epsilon 1")
    nominal = settings["nominal"].get("lead_vehicle_brakes", {})
    lines = [json.loads(l) for l in open(f"{directory}/trials.jsonl")]
    failures = [l["phi"] for l in lines if l["hf"]["failure"]]
    p = len(failures) / len(lines)
    print(f"{len(lines)} runs, {len(failures)} failures, P = {p:.3e}")

    def arm(v, x):
        lo, hi = RANGES[v]
        return min(int((x - lo) / (hi - lo) * BINS), BINS - 1)

    def nominal_bin(v, k):
        lo, hi = RANGES[v]
        n = nominal.get(v)
        if n is None:
            return 1 / BINS
        d = NormalDist(n["mean"], n["sd"])
        w = (hi - lo) / BINS
        return (d.cdf(lo + (k + 1) * w) - d.cdf(lo + k * w)) / (d.cdf(hi) - d.cdf(lo))

    for v in RANGES:
        c = collections.Counter(arm(v, f[v]) for f in failures)
        print(f"{v:>11}: failures per bin {[c.get(k, 0) for k in range(BINS)]}")
    for smooth in (0.0, 0.1, 0.3):
        marg = {}
        for v in RANGES:
            c = collections.Counter(arm(v, f[v]) for f in failures)
            marg[v] = [
                (1 - smooth) * c.get(k, 0) / len(failures) + smooth * nominal_bin(v, k)
                for k in range(BINS)
            ]

        def ratio(phi):  # q_product(φ) / p(φ): inside a bin q follows the nominal
            r = 1.0
            for v in RANGES:
                k = arm(v, phi[v])
                r *= marg[v][k] / nominal_bin(v, k)
            return r

        for eps in (0.1, 0.3):
            mean_w = sum(1 / ((1 - eps) * ratio(f) + eps) for f in failures) / len(failures)
            relvar = mean_w / p - 1
            gain = (1 - p) / p / relvar
            print(f"smooth {smooth}, ε {eps}: E[w | failure] = {mean_w:.3f}, gain over plain MC {gain:.1f}×")


if __name__ == "__main__":
    main(sys.argv[1])
