#!/usr/bin/env python3
"""HF runs of `savme estimate` against plain Monte Carlo on the declared-nominal rare setting
(lead_vehicle_brakes, idealised perception, ego speed ~ N(12, 2) truncated to [10, 25], the rest
uniform; P ≈ 2e-3), for the product (per-variable) and the joint proposal, several seeds, in
one window. docs/BENCHMARKS.md ("Joint proposal") records what it printed.

    cargo build --release --example estimate_check
    nice -n 10 python3 benches/joint_proposal_ratio.py --out /tmp/jp

Each run: `estimate_check` trains the same campaign (200 iterations at C = 0.3, seed 1), then
estimates to ±10 % (or --max-runs) with the estimate seed s. One more run computes a long
plain Monte Carlo reference (--mc-runs, the example's own sampler). For every estimate: the
HF runs it made (training + pilot + estimate), the HF runs plain Monte Carlo needs for the same
relative width at the reference P, z²(1 − P)/(t² P), their ratio, and whether the 95 %
interval covers the reference.

Variants `product-lf` and `joint-lf` are the multi-fidelity estimator (`--pilot-fidelity lf`):
the pilot rounds run LF at the campaign's learned θ_LF*, the estimate HF; their runs are
charged in HF runs of equal cost (`charged_runs` in the example's check.json: every run at its
work-unit cost, each training trial as 2 HF runs). docs/RESULTS.md ("Failure probability from
cheap runs") records what it printed.

A `-cv` suffix (`joint-lf-cv`, `joint-cv`) adds LF runs as control variates for the HF estimate
(`--control-calibration`, docs/ESTIMATION.md), charged the same way; docs/RESULTS.md ("LF runs
as control variates") records what it printed.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from statistics import NormalDist

NOMINAL = "lead_vehicle_brakes.ego_speed=normal:12,2"


def run(exe, out, args):
    cmd = [exe, "--out", out, "--nominal", NOMINAL, "--tilt", "nominal-weighted"] + args
    t = time.time()
    p = subprocess.run(cmd, capture_output=True, text=True)
    # The example exits 1 when its interval misses its own MC value; the check is still written.
    path = os.path.join(out, "check.json")
    if not os.path.exists(path):
        sys.exit(f"{' '.join(cmd)} failed:\n{p.stderr}")
    with open(path) as f:
        check = json.load(f)
    return check, time.time() - t, " ".join(cmd)


def main():
    a = argparse.ArgumentParser()
    a.add_argument("--out", required=True)
    a.add_argument("--exe", default="target/release/examples/estimate_check")
    a.add_argument("--seeds", default="1,2,3,4")
    a.add_argument("--variants", default="product,joint")
    a.add_argument("--mc-runs", type=int, default=400000)
    a.add_argument("--mc-reference", help="P,RUNS of an earlier reference instead of --mc-runs")
    a.add_argument("--rounds", type=int, default=4)
    a.add_argument("--runs", type=int, default=3000)
    a.add_argument("--components", type=int, default=8)
    a.add_argument("--max-runs", type=int, default=200000)
    a.add_argument("--jobs", type=int, default=1)
    a.add_argument("--calibration", type=int, default=2000,
                   help="control-variate calibration pairs of the `-cv` variants")
    a.add_argument("--control-extra", type=int,
                   help="force this many extra LF runs per pair (`-cv` variants)")
    o = a.parse_args()
    os.makedirs(o.out, exist_ok=True)
    load = [os.getloadavg()[0]]
    z = NormalDist().inv_cdf(0.975)
    common = ["--target", "0.1", "--max-runs", str(o.max_runs), "--jobs", str(o.jobs),
              "--refine-rounds", str(o.rounds), "--refine-runs", str(o.runs)]
    # The reference's own (small, unused) estimate runs without a pilot.
    reference = ["--target", "0.1", "--max-runs", "1000", "--jobs", str(o.jobs)]
    if o.mc_reference:
        p_ref, n_ref = (float(x) for x in o.mc_reference.split(","))
    else:
        check, secs, cmd = run(o.exe, os.path.join(o.out, "mc"),
                               reference + ["--mc-runs", str(o.mc_runs)])
        mc = check["monte_carlo"]
        p_ref, n_ref = mc["estimate"], mc["runs"]
        print(f"reference: {cmd}\n  P = {p_ref:.4e} [{mc['wilson_lo']:.4e}, {mc['wilson_hi']:.4e}]"
              f" from {mc['failures']} failures in {n_ref:.0f} runs, {secs:.0f} s")
    mc_needed = z * z * (1 - p_ref) / (0.1 ** 2 * p_ref)
    print(f"plain Monte Carlo needs {mc_needed:,.0f} HF runs for ±10 % at P = {p_ref:.4e}")
    rows = []
    for variant in o.variants.split(","):
        for seed in (int(s) for s in o.seeds.split(",")):
            extra = ["--estimate-seed", str(seed), "--mc-runs", "0"]
            if variant.startswith("joint"):
                extra += ["--proposal", "joint", "--joint-components", str(o.components)]
            if "-lf" in variant:
                extra += ["--pilot-fidelity", "lf"]
            if "-cv" in variant:
                extra += ["--control-calibration", str(o.calibration)]
                if o.control_extra is not None:
                    extra += ["--control-extra", str(o.control_extra)]
            check, secs, cmd = run(o.exe, os.path.join(o.out, f"{variant}-{seed}"), common + extra)
            is_ = check["importance_sampling"]
            if "-lf" in variant or "-cv" in variant:
                made = round(is_["charged_runs"])
            else:
                made = is_["hf_runs"] + is_["pilot_hf_runs"] - is_["pilot_hf_runs_reused"] \
                    + is_["training_hf_runs"]
            width = is_["relative_half_width"]
            need = z * z * (1 - p_ref) / (width ** 2 * p_ref)
            covers = is_["lo"] <= p_ref <= is_["hi"]
            rows.append((variant, seed, is_["estimate"], is_["lo"], is_["hi"], width, made,
                         need / made, covers, is_["failure_ess"], secs))
            print(f"{variant:>7} seed {seed}: {is_['estimate']:.4e} [{is_['lo']:.4e}, "
                  f"{is_['hi']:.4e}] ±{100 * width:.1f} %, {made:,} HF runs, "
                  f"ratio {need / made:.2f}×, covers {covers}, failure ESS "
                  f"{is_['failure_ess']:.0f}, {secs:.0f} s", flush=True)
            load.append(os.getloadavg()[0])
    print(f"\n| proposal | seed | estimate [95 % interval] | ± | HF(-equivalent) runs | ratio MC / IS | covers |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]:.3e} [{r[3]:.3e}, {r[4]:.3e}] | {100 * r[5]:.1f} % "
              f"| {r[6]:,} | {r[7]:.2f} × | {'yes' if r[8] else 'no'} |")
    for variant in o.variants.split(","):
        ratios = [r[7] for r in rows if r[0] == variant]
        print(f"{variant}: median ratio {statistics.median(ratios):.2f}× "
              f"(min {min(ratios):.2f}, max {max(ratios):.2f}); covered "
              f"{sum(r[8] for r in rows if r[0] == variant)} of {len(ratios)}")
    print(f"load average (1 min) during the runs: {min(load):.1f}–{max(load):.1f} on "
          f"{os.cpu_count()} cores")
    with open(os.path.join(o.out, "rows.json"), "w") as f:
        json.dump({"reference": [p_ref, n_ref], "rows": rows, "load": load}, f, indent=1)


if __name__ == "__main__":
    main()
