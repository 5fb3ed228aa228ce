#!/usr/bin/env python3
"""Drive the savme kernel from Python through `savme serve` (JSON lines on stdin/stdout).

    cargo build --release
    target/release/savme example-config > kernel.json      # edit to your spaces
    python3 examples/python/serve_harness.py --savme target/release/savme --config kernel.json

The simulators here are a stand-in written in Python for the toy problem's variables (see
`savme example-config`): replace `run_simulator` with calls into your own HF and LF simulators.
Standard library only.
"""
import argparse
import json
import math
import random
import subprocess
import sys
import time


class Savme:
    """A savme kernel in a child process."""

    def __init__(self, exe, config, journal=None):
        cmd = [exe, "serve", "--config", config]
        if journal:
            cmd += ["--journal", journal]
        self.proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)

    def call(self, **request):
        self.proc.stdin.write(json.dumps(request) + "\n")
        self.proc.stdin.flush()
        line = self.proc.stdout.readline()
        if not line:
            raise RuntimeError("savme serve exited")
        response = json.loads(line)
        if not response["ok"]:
            raise RuntimeError(response["error"])
        return response

    def close(self):
        self.proc.stdin.close()
        return self.proc.wait()


def run_simulator(scenario, phi, theta):
    """A stand-in simulator: failure flag and measured runtime. Cheaper settings do less work
    and are less faithful (fewer integration steps, a shorter horizon)."""
    start = time.perf_counter()
    rate = theta["rate_hz"]
    horizon = theta["horizon_s"]
    dt = 1.0 / rate
    v = phi["ego_speed"]
    gap = phi.get("gap", phi.get("headway", 50.0))
    lead_decel = phi.get("lead_decel", 0.0)
    lead_v = v if scenario == "braking_lead" else 0.0
    braking, t, failure = False, 0.0, False
    while t < horizon:
        if lead_v > 0 and t >= 1.0:
            lead_v = max(0.0, lead_v - lead_decel * dt)
        closing = v - lead_v
        if closing > 0 and gap / closing < 2.0:
            braking = True
        if braking:
            v = max(0.0, v - 7.0 * dt)
        gap -= (v - lead_v) * dt
        if gap <= 0:
            failure = True
            break
        t += dt
    return failure, time.perf_counter() - start


def trial_runs(savme_kernel, theta_hf, trial):
    hf_fail, hf_time = run_simulator(trial["scenario"], trial["phi"], theta_hf)
    hf = {"failure": hf_fail, "runtime": hf_time}
    if trial["theta_lf"] is None:
        return {"hf_only": hf}
    lf_fail, lf_time = run_simulator(trial["scenario"], trial["phi"], trial["theta_lf"])
    return {"paired": {"hf": hf, "lf": {"failure": lf_fail, "runtime": lf_time}}}


def run_phase(kernel, theta_hf, phase, n, batch=8):
    kernel.call(op="phase", phase=phase)
    records = []
    while len(records) < n:
        trials = kernel.call(op="ask", n=min(batch, n - len(records)))["trials"]
        random.shuffle(trials)  # tell in any order
        for t in trials:
            obs = trial_runs(kernel, theta_hf, t)
            records.append(kernel.call(op="tell", id=t["id"], observation=obs)["record"])
    return records


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--savme", default="target/release/savme", help="path of the savme binary")
    ap.add_argument("--config", required=True, help="kernel configuration JSON")
    ap.add_argument("--journal", help="journal file (resumable)")
    ap.add_argument("--iterations", type=int, default=300)
    args = ap.parse_args()
    with open(args.config) as f:
        theta_hf = json.load(f)["theta_hf"]
    random.seed(0)
    kernel = Savme(args.savme, args.config, args.journal)
    baseline = run_phase(kernel, theta_hf, "baseline", args.iterations)
    training = run_phase(kernel, theta_hf, "train", args.iterations)
    evaluation = run_phase(kernel, theta_hf, "evaluate", 100)
    theta_star = kernel.call(op="estimate")["theta_lf"]
    kernel.close()

    base_rate = sum(r["observation"]["hf_only"]["failure"] for r in baseline) / len(baseline)
    tp = sum(r["outcome"] == "TP" for r in evaluation) / len(evaluation)
    cost = sum(r["cost_ratio"] for r in evaluation) / len(evaluation)
    train_fail = sum(r["observation"]["paired"]["hf"]["failure"] for r in training)
    print(f"learned θ_LF*: {json.dumps(theta_star)}")
    print(f"baseline failure rate {base_rate:.2f}; training found {train_fail} failures in {len(training)} trials")
    speedup = (tp / cost) / base_rate if cost > 0 and base_rate > 0 else math.nan
    print(f"evaluation: TP-rate {tp:.2f}, mean LF cost {cost:.2f}, speedup {speedup:.2f}")
    if not (0 <= tp <= 1 and len(training) == args.iterations):
        sys.exit("inconsistent results")


if __name__ == "__main__":
    main()
