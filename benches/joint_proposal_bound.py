#!/usr/bin/env python3
"""How well can a joint (mixture) proposal do on a rare-event setting, given the failures?

The joint counterpart of benches/product_proposal_bound.py. Reads a plain Monte Carlo run
under the nominal, logged as an estimate with ε = 1 (every weight 1), e.g.

    cargo run --release --example estimate_check -- --out /tmp/mc --mc-runs 0 \\
        --epsilon 1 --target 0.000001 --max-runs 150000 --jobs 1 \\
        --nominal lead_vehicle_brakes.ego_speed=normal:12,2

then fits the joint proposal's family — a mixture of K components, each a product over the
variables of 10-bin histograms with the nominal's shape inside a bin, as the kernel's joint
proposal (kernel/src/estimation/joint.rs, joint_fit.rs: weighted EM from a k-means++ start,
each component's bins (1 − smoothing) × the fit + smoothing × the nominal's) — to HALF of
the Monte Carlo failures (an oracle: the zero-variance density's own samples, no pilot) and
evaluates the defensive mixture q = (1 − ε)·mixture + ε·p on the OTHER half: relative variance
E_p[w | failure]/P − 1 with w = p/q, and the gain over plain Monte Carlo ((1 − P)/P)/relvar.
Held-out, so it is not flattered by fitting the points it is tested on. It also prints where
the failures lie along each variable, and the share of the failures whose nearest
neighbours (in the unit cube) did not fail — how rough the failure set is.

    python3 benches/joint_proposal_bound.py /tmp/mc/estimate
"""
import json
import math
import random
import sys
from statistics import NormalDist

# lead_vehicle_brakes' φ-space (reference-sim/src/scenario.rs), linear scales.
RANGES = {
    "ego_speed": (10.0, 25.0),
    "lead_speed": (5.0, 20.0),
    "gap": (8.0, 28.0),
    "lead_decel": (4.0, 9.0),
    "brake_time": (0.5, 4.0),
}
NAMES = list(RANGES)


def unit(phi):
    return [(phi[v] - RANGES[v][0]) / (RANGES[v][1] - RANGES[v][0]) for v in NAMES]


BINS = 10


def arm(t):
    return min(int(t * BINS), BINS - 1)


def smooth(p, prior, share):
    total = sum(x for x, q in zip(p, prior) if q > 0)
    if total <= 0:
        return list(prior)
    m = [share * x / total + (1 - share) * q if q > 0 else 0.0 for x, q in zip(p, prior)]
    s = sum(m)
    return [x / s for x in m]


def cell_prob(mix, cell):
    return sum(a * math.prod(d[b] for d, b in zip(dims, cell)) for a, dims in mix)


def fit(cells, k, prior, smoothing, rng, iterations=50):
    """The kernel's fit (joint_fit.rs): k-means++ start, weighted EM (weights 1 here: plain
    Monte Carlo failures), each component's bins smoothed toward the nominal's."""
    centres = [rng.choice(cells)]
    while len(centres) < k:
        d2 = [min(sum(((a - b) / BINS) ** 2 for a, b in zip(p, c)) for c in centres) for p in cells]
        total = sum(d2)
        if total == 0:
            break
        r = rng.random() * total
        for p, d in zip(cells, d2):
            r -= d
            if r < 0:
                centres.append(p)
                break
    def onehot(b):
        v = [0.0] * BINS
        v[b] = 1.0
        return v
    mix = [(1 / len(centres), [smooth(onehot(b), pr, 0.5) for b, pr in zip(c, prior)])
           for c in centres]
    for _ in range(iterations):
        resp = []
        for p in cells:
            ls = [math.log(a) + sum(math.log(max(d[b], 1e-300)) for d, b in zip(dims, p))
                  for a, dims in mix]
            top = max(ls)
            e = [math.exp(l - top) for l in ls]
            s = sum(e)
            resp.append([x / s for x in e])
        new = []
        for j in range(len(mix)):
            a = sum(r[j] for r in resp)
            if a <= 1e-9:
                continue
            dims = []
            for i in range(len(NAMES)):
                counts = [0.0] * BINS
                for r, p in zip(resp, cells):
                    counts[p[i]] += r[j]
                dims.append(smooth(counts, prior[i], 1 - smoothing))
            new.append((a / len(cells), dims))
        mix = new
    return mix


def main(directory):
    settings = json.load(open(f"{directory}/estimate.json"))
    if settings["epsilon"] != 1:
        sys.exit("needs a plain Monte Carlo run: an estimate with --epsilon 1")
    nominal = settings["nominal"].get("lead_vehicle_brakes", {})
    lines = [json.loads(l) for l in open(f"{directory}/trials.jsonl")]
    pts = [(unit(l["phi"]), l["hf"]["failure"]) for l in lines]
    failures = [u for u, f in pts if f]
    p = len(failures) / len(pts)
    print(f"{len(pts)} runs, {len(failures)} failures, P = {p:.3e}")

    def bin_mass(v, k):
        lo, hi = RANGES[v]
        n = nominal.get(v)
        if n is None:
            return 1 / BINS
        d = NormalDist(n["mean"], n["sd"])
        w = (hi - lo) / BINS
        return (d.cdf(lo + (k + 1) * w) - d.cdf(lo + k * w)) / (d.cdf(hi) - d.cdf(lo))

    prior = [[bin_mass(v, k) for k in range(BINS)] for v in NAMES]

    for i, v in enumerate(NAMES):
        counts = [0] * 10
        for u in failures:
            counts[min(int(u[i] * 10), 9)] += 1
        print(f"{v:>11}: failures per tenth {counts}")
    # Roughness: of each failure's 5 nearest runs (among 20,000 runs around it), how many failed.
    rng = random.Random(1)
    sample = rng.sample(pts, min(20000, len(pts)))
    near = []
    for u in failures[:200]:
        d = sorted((sum((a - b) ** 2 for a, b in zip(u, w)), f) for w, f in sample if w != u)
        near.append(sum(f for _, f in d[:5]) / 5)
    print(f"share of failing runs among a failure's 5 nearest neighbours (of {len(sample)} runs): "
          f"mean {sum(near) / len(near):.2f}")
    cells = [tuple(arm(t) for t in u) for u in failures]
    rng.shuffle(cells)
    half = len(cells) // 2
    train, test = cells[:half], cells[half:]
    # The held-out E[w | failure] of q = (1 − ε)·mixture + ε·p; w is constant in a cell.
    for smoothing in (0.1, 0.3, 0.5):
        for k in (1, 2, 4, 8):
            mix = fit(train, k, prior, smoothing, random.Random(k))
            for eps in (0.1, 0.3):
                ws = [1 / ((1 - eps) * cell_prob(mix, c) / math.prod(prior[i][b] for i, b in enumerate(c)) + eps)
                      for c in test]
                relvar = sum(ws) / len(ws) / p - 1
                gain = (1 - p) / p / relvar
                print(f"smoothing {smoothing}, K {k}, ε {eps}: E[w | failure] = "
                      f"{sum(ws) / len(ws):.4f} (held out), gain over plain MC {gain:.1f}×",
                      flush=True)


if __name__ == "__main__":
    main(sys.argv[1])
