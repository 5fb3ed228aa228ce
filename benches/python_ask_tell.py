#!/usr/bin/env python3
"""Ask+tell per trial from Python on the paper's space, four ways, in one run:

1. the `savme` package (in memory, and journaled to a file),
2. `savme serve` over JSON lines (a subprocess, one ask and one tell request per trial),
3. Optuna's RandomSampler and TPESampler (ask/tell with a null objective).

The space: Table I's 16 fidelity settings (continuous ones in 10 log bins) and one scenario of
4 continuous parameters in 10 bins — the same as `cargo bench -p savme-kernel --bench ask_tell`.
Each savme trial reads φ and θ_LF (as a harness must) and tells a synthetic outcome.

    SAVME_PY_VENV=target/bench-venv python/develop.sh --release
    target/bench-venv/bin/pip install optuna
    cargo build --release --bin savme
    target/bench-venv/bin/python benches/python_ask_tell.py --savme target/release/savme

Prints a Markdown table of per-trial medians over blocks — wall-clock and CPU time — and the
ratio to the package's first row.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import savme

LOG = lambda name, lo, hi: savme.Continuous(name, lo, hi, bins=10, scale="log")
FIDELITY = [
    savme.Discrete("simulation_rate_hz", [2, 4, 6, 8, 10]),
    savme.Discrete("camera_bloom_level", ["high", "low"]),
    savme.Boolean("camera_disable_bloom"),
    savme.Boolean("camera_disable_lighting"),
    savme.Boolean("camera_disable_shadows"),
    savme.Boolean("camera_disable_lens_model"),
    savme.Boolean("camera_disable_depth_of_field"),
    savme.Boolean("camera_disable_shot_noise"),
    LOG("camera_view_distance_m", 10.0, 5000.0),
    LOG("camera_near_clipping_m", 0.2, 20.0),
    savme.Boolean("lidar_disable_shot_noise"),
    savme.Boolean("lidar_disable_ambient_effects"),
    savme.Boolean("lidar_disable_translucency"),
    savme.Discrete("lidar_subsample_count", [1, 2, 3, 4, 5]),
    savme.Discrete("lidar_raytracing_bounces", [0, 1, 2, 3, 4]),
    LOG("lidar_near_clipping_m", 0.2, 20.0),
]
THETA_HF = {
    "simulation_rate_hz": 10, "camera_bloom_level": "high", "camera_disable_bloom": False,
    "camera_disable_lighting": False, "camera_disable_shadows": False,
    "camera_disable_lens_model": False, "camera_disable_depth_of_field": False,
    "camera_disable_shot_noise": False, "camera_view_distance_m": 5000.0,
    "camera_near_clipping_m": 0.2, "lidar_disable_shot_noise": False,
    "lidar_disable_ambient_effects": False, "lidar_disable_translucency": False,
    "lidar_subsample_count": 5, "lidar_raytracing_bounces": 4, "lidar_near_clipping_m": 0.2,
}
PHI = ["ego_speed", "intruder_speed", "gap", "intruder_decel"]


METHOD = "paper"  # --method: the table in docs/BENCHMARKS.md was measured with the paper's


def kernel(journal=None):
    phi = savme.Space([savme.Continuous(n, 1.0, 30.0, bins=10) for n in PHI])
    return savme.Kernel(fidelity=savme.Space(FIDELITY), theta_hf=THETA_HF,
                        scenarios={"lead_vehicle": phi}, budget=0.3, seed=1, journal=journal,
                        method=METHOD)


def outcome(phi, theta):
    """The kernel bench's synthetic outcome: HF fails below a gap of 8; LF errs below 4 Hz."""
    hf = phi["gap"] < 8.0
    rate = theta["simulation_rate_hz"]
    return (hf, 1.0), (hf ^ (rate < 4), rate / 10.0)


def proc_cpu(pid):
    """CPU seconds (user + system) process `pid` has used so far (Linux /proc)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def blocks(run_block, n, reps, server_pid=None):
    """Medians over `reps` blocks of `n` trials: wall-clock µs per trial, and CPU µs per trial
    (this process, plus the server's for `savme serve`). On a loaded machine the CPU time is
    the steadier figure: it leaves out the time the process waited for a core."""
    walls, cpus = [], []
    for _ in range(reps):
        c0 = time.process_time() + (proc_cpu(server_pid) if server_pid else 0.0)
        t0 = time.perf_counter()
        run_block(n)
        walls.append((time.perf_counter() - t0) / n * 1e6)
        c1 = time.process_time() + (proc_cpu(server_pid) if server_pid else 0.0)
        cpus.append((c1 - c0) / n * 1e6)
    return statistics.median(walls), statistics.median(cpus), walls


def package(k):
    def block(n):
        for _ in range(n):
            t = k.ask()
            hf, lf = outcome(t.phi, t.theta_lf)
            k.tell(t, hf=hf, lf=lf)
    return block


def package_null(k):
    def block(n):
        for _ in range(n):
            k.tell(k.ask(), hf=(False, 1.0), lf=(False, 0.2))
    return block


def served(binary, config_path):
    proc = subprocess.Popen([binary, "serve", "--config", config_path], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True, bufsize=1)

    def block(n):
        for _ in range(n):
            proc.stdin.write('{"op":"ask"}\n')
            t = json.loads(proc.stdout.readline())["trials"][0]
            hf, lf = outcome(t["phi"], t["theta_lf"])
            obs = {"paired": {"hf": {"failure": hf[0], "runtime": hf[1]},
                              "lf": {"failure": lf[0], "runtime": lf[1]}}}
            proc.stdin.write(json.dumps({"op": "tell", "id": t["id"], "observation": obs}) + "\n")
            r = json.loads(proc.stdout.readline())
            assert r["ok"], r
    return proc, block


def optuna_block(sampler_name):
    import optuna
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    D = optuna.distributions
    dists = {}
    for v in FIDELITY:
        if v.kind == "discrete":
            dists[v.name] = D.CategoricalDistribution(v.values)
        else:
            lo, hi, _, scale = v.range
            dists[v.name] = D.FloatDistribution(lo, hi, log=scale == "log")
    for n in PHI:
        dists[n] = D.FloatDistribution(1.0, 30.0)
    sampler = optuna.samplers.RandomSampler(seed=1) if sampler_name == "random" else optuna.samplers.TPESampler(seed=1)
    study = optuna.create_study(sampler=sampler)

    def block(n):
        for _ in range(n):
            trial = study.ask(dists)
            study.tell(trial, 0.0)
    return block


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--savme", default="target/release/savme", help="the savme binary for `serve`")
    ap.add_argument("--trials", type=int, default=20000, help="trials per block (package)")
    ap.add_argument("--reps", type=int, default=7, help="blocks per measurement")
    ap.add_argument("--json", help="also write the figures here")
    ap.add_argument("--method", choices=["paper", "tuned"], default="paper",
                    help="the kernel's method (default paper: per-call cost independent of the "
                         "history; the tuned default's elite search grows with its archives)")
    a = ap.parse_args()
    global METHOD
    METHOD = a.method
    results = []

    def record(name, wall, cpu, walls, n):
        results.append({"name": name, "median_wall_us": wall, "median_cpu_us": cpu,
                        "blocks_wall_us": walls, "trials_per_block": n})
        print(f"{name:62s} wall {wall:10.2f} µs   CPU {cpu:10.2f} µs", file=sys.stderr, flush=True)

    k = kernel()
    package(k)(2000)  # warm up (posteriors with evidence, caches)
    record("savme package: ask + read φ, θ_LF + tell", *blocks(package(k), a.trials, a.reps), a.trials)
    record("savme package: ask + tell (null objective)", *blocks(package_null(kernel()), a.trials, a.reps), a.trials)
    with tempfile.TemporaryDirectory() as d:
        kj = kernel(journal=os.path.join(d, "bench.journal"))
        record("savme package, journaled to a file", *blocks(package(kj), a.trials // 4, a.reps), a.trials // 4)
        kj.close()
        cfg = os.path.join(d, "kernel.json")
        with open(cfg, "w") as f:
            f.write(kernel().config_json())
        proc, block = served(a.savme, cfg)
        block(500)
        record("`savme serve` from Python (JSON lines; CPU of both processes)",
               *blocks(block, 5000, a.reps, server_pid=proc.pid), 5000)
        proc.stdin.close()
        proc.wait()
    try:
        record("Optuna RandomSampler ask/tell (null objective)", *blocks(optuna_block("random"), 200, a.reps), 200)
        tpe = optuna_block("tpe")
        # TPE's cost grows with the history: measure blocks 1–7 of 100 trials (trials 1–700).
        record("Optuna TPESampler ask/tell (null objective), trials 1–700", *blocks(tpe, 100, a.reps), 100)
    except ImportError:
        print("optuna is not installed: its rows are missing", file=sys.stderr)
    base = results[0]
    print("| path | wall per trial (median) | CPU per trial (median) | × the package (CPU) |")
    print("|---|---|---|---|")
    for r in results:
        print(f"| {r['name']} | {r['median_wall_us']:.2f} µs | {r['median_cpu_us']:.2f} µs "
              f"| {r['median_cpu_us'] / base['median_cpu_us']:.1f} |")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(results, f, indent=1)


if __name__ == "__main__":
    main()
