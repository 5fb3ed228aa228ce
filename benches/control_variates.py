#!/usr/bin/env python3
"""Why LF control variates do not pay on setting A, from the calibration pairs of the
`joint-lf-cv` estimates that `benches/joint_proposal_ratio.py` wrote (docs/RESULTS.md, "LF runs
as control variates"):

    python3 benches/control_variates.py --out /tmp/mfcv/cv20

Per seed, over the 2,000 calibration pairs (φ ~ q run at HF and at θ_LF*): the correlation the
estimator uses, ρ(w·f_HF, w·f_LF); the best control of the form w·1{r_LF ≤ t} over thresholds
t of the LF run's robustness; the unweighted correlation of the two failure indicators; how
many HF failures the LF also fails, by count and by their share of Σ w² (the variance); and
the multi-fidelity Monte Carlo bound (√(1 − ρ²) + √(c ρ²))² at the measured cost ratio c (the
cost × variance of the best design over HF-only sampling, any ratio of LF to HF runs; ≥ 1:
the LF cannot pay).
"""
import argparse
import glob
import json
import os
import statistics


def corr(x, y):
    n = len(x)
    mx, my = sum(x) / n, sum(y) / n
    sxy = sum((a - mx) * (b - my) for a, b in zip(x, y))
    sxx = sum((a - mx) ** 2 for a in x)
    syy = sum((b - my) ** 2 for b in y)
    return sxy / (sxx * syy) ** 0.5 if sxx > 0 and syy > 0 else 0.0


def pairs(path):
    lines = [json.loads(l) for l in open(path)]
    cal = [l for l in lines if l.get("control") == "calibration"]
    for hf, lf in zip(cal[::2], cal[1::2]):
        assert hf["phi"] == lf["phi"] and "hf" in hf and "lf" in lf
        yield hf["weight"], hf["hf"]["failure"], lf["lf"]["failure"], lf["lf"]["robustness"], \
            hf["hf"]["runtime"], lf["lf"]["runtime"]


def main():
    a = argparse.ArgumentParser()
    a.add_argument("--out", required=True)
    o = a.parse_args()
    paths = glob.glob(os.path.join(o.out, "*-cv-*", "estimate", "trials.jsonl"))
    paths.sort(key=lambda p: int(p.split("-cv-")[1].split(os.sep)[0]))
    rows, mass = [], [0.0, 0.0, 0, 0, 0.0, 0.0]
    print("| seed | ρ(w·f_HF, w·f_LF) | best w·1{r_LF ≤ t} | ρ of the indicators | HF failures | LF failures | both | cost ratio c | MFMC bound |")
    print("|---|---|---|---|---|---|---|---|---|")
    for path in paths:
        seed = int(path.split("-cv-")[1].split(os.sep)[0])
        p = list(pairs(path))
        w = [x[0] for x in p]
        y_hf = [wi if h else 0.0 for wi, h, *_ in p]
        y_lf = [wi if l else 0.0 for wi, _, l, *_ in p]
        rho = corr(y_hf, y_lf)
        best = max((corr(y_hf, [wi if x[3] <= t else 0.0 for wi, x in zip(w, p)])
                    for t in (-2, -1, -0.5, 0, 0.5, 1, 2, 3, 4, 6, 8)), key=abs)
        best = max(best, rho, key=abs)
        ind = corr([float(x[1]) for x in p], [float(x[2]) for x in p])
        c = (sum(x[5] for x in p) / len(p)) / (sum(x[4] for x in p) / len(p))
        bound = ((1 - rho * rho) ** 0.5 + (c * rho * rho) ** 0.5) ** 2
        hf, lf, both = (sum(x[1] for x in p), sum(x[2] for x in p),
                        sum(x[1] and x[2] for x in p))
        for wi, h, l, *_ in p:
            if h:
                mass[0] += wi * wi
                mass[1] += wi * wi if l else 0.0
            if l:
                mass[4] += wi * wi
                mass[5] += wi * wi if h else 0.0
        mass[2] += hf
        mass[3] += both
        rows.append((rho, best, ind, c, bound))
        print(f"| {seed} | {rho:.3f} | {best:.3f} | {ind:.3f} | {hf} | {lf} | {both} | {c:.3f} | {bound:.3f} |")
    med = lambda i: statistics.median(r[i] for r in rows)
    print(f"\nmedians over {len(rows)} seeds: ρ {med(0):.3f} (range {min(r[0] for r in rows):.3f} to "
          f"{max(r[0] for r in rows):.3f}), best threshold control |ρ| {statistics.median(abs(r[1]) for r in rows):.3f}, indicators "
          f"{med(2):.3f}, cost ratio {med(3):.3f}, MFMC bound {med(4):.3f} "
          f"({min(r[4] for r in rows):.3f}–{max(r[4] for r in rows):.3f})")
    print(f"HF failures the LF also fails: {mass[3]} of {mass[2]} ({mass[3] / mass[2]:.0%}) by count, "
          f"{mass[1] / mass[0]:.0%} of their Σ w²; LF failures that are HF failures: "
          f"{mass[5] / mass[4]:.1%} of the LF failures' Σ w²")


if __name__ == "__main__":
    main()
