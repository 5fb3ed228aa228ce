#!/usr/bin/env python3
"""The Python package's and `savme serve`'s per-call regression guards (issue 39 item 6).

- The package: ask + read φ and θ_LF + tell through the `savme` package on the paper's space
  with the paper's method, after 1,000 told (the space and outcome of
  `benches/python_ask_tell.py`), timed as a ratio to a fixed pure-Python reference loop.
- `savme serve`: the same trial as one ask and one tell request line to a server and their
  responses read back (1,000 told first), timed as a ratio to the same lines' round trips
  through `cat` (an echo process: the pipes, the wake-ups and Python's JSON work, without the
  server's), so what the machine does to a round trip between two processes moves both.

Each pair is measured in interleaved batches of the same run (the fastest batch of each side
kept: a shared, noisy machine moves both) and compared with the ratio recorded in
`benches/python_guard.json`. Exits 1 when a ratio is more than 10 % above its record.

    SAVME_PY_VENV=target/bench-venv python/develop.sh --release   # the package, release build
    cargo build --release --bin savme                               # the server
    target/bench-venv/bin/python benches/python_guard.py            # check both
    target/bench-venv/bin/python benches/python_guard.py --record   # rewrite the records
    target/bench-venv/bin/python benches/python_guard.py --savme PATH   # another savme binary
"""

import argparse
import json
import math
import os
import random
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from python_ask_tell import FIDELITY, PHI, THETA_HF, outcome  # noqa: E402  (the same space)

import savme  # noqa: E402

TOLERANCE = 1.10
# Many short interleaved batches (~3 ms), the fastest of each side kept: on a shared machine
# the least disturbed batch is the one that measures the code.
BATCHES = 201
TRIALS = 500
UNITS = 500
RECORD = os.path.join(os.path.dirname(os.path.abspath(__file__)), "python_guard.json")
NAME = "package_ask_read_tell"
SERVE = "serve_round_trip"
# Round trips take ~100 µs: fewer, longer batches than the package's.
SERVE_BATCHES = 101
SERVE_TRIALS = 40
KEYS = [f"k{i}" for i in range(20)]


def reference_unit(rng):
    """A fixed unit of harness-like Python work: 20 draws into a dict, `exp`, look-ups."""
    d = {k: rng.random() for k in KEYS}
    return sum(math.exp(-d[k] * d[k]) for k in ("k1", "k5", "k9", "k13")) + len(d)


def kernel():
    """The paper's method (its cost per call does not grow with the history; the tuned
    method's elite search does, up to full archives), warmed with 1,000 told trials as the
    kernel's own guard is."""
    phi = savme.Space([savme.Continuous(n, 1.0, 30.0, bins=10) for n in PHI])
    k = savme.Kernel(fidelity=savme.Space(FIDELITY), theta_hf=THETA_HF,
                     scenarios={"lead_vehicle": phi}, budget=0.3, seed=1, method="paper")
    for _ in range(1_000):
        t = k.ask()
        hf, lf = outcome(t.phi, t.theta_lf)
        k.tell(t, hf=hf, lf=lf)
    return k


def measure():
    """Seconds per trial of the package and per reference unit: the fastest of interleaved
    batches."""
    k = kernel()
    rng = random.Random(7)
    per_trial, per_unit = [], []
    for _ in range(BATCHES):
        t0 = time.perf_counter()
        for _ in range(UNITS):
            reference_unit(rng)
        per_unit.append((time.perf_counter() - t0) / UNITS)
        t0 = time.perf_counter()
        for _ in range(TRIALS):
            t = k.ask()
            hf, lf = outcome(t.phi, t.theta_lf)
            k.tell(t, hf=hf, lf=lf)
        per_trial.append((time.perf_counter() - t0) / TRIALS)
    return min(per_trial), min(per_unit)


def serve_trial(proc, echo):
    """One trial through `savme serve` (`echo` None) or the same lines through `cat`: an ask
    request and the server's answer, a tell request and its answer. The echo's lines are the
    server's own (recorded by `serve_lines`), so both sides write, read and parse the same
    JSON."""
    if echo is None:
        proc.stdin.write('{"op":"ask"}\n')
        t = json.loads(proc.stdout.readline())["trials"][0]
    else:
        proc.stdin.write(echo[0])
        t = json.loads(proc.stdout.readline())["trials"][0]
    hf, lf = outcome(t["phi"], t["theta_lf"])
    obs = {"paired": {"hf": {"failure": hf[0], "runtime": hf[1]},
                      "lf": {"failure": lf[0], "runtime": lf[1]}}}
    proc.stdin.write(json.dumps({"op": "tell", "id": t["id"], "observation": obs}) + "\n")
    r = json.loads(proc.stdout.readline())
    if echo is None and not r.get("ok"):
        raise RuntimeError(f"savme serve refused a tell: {r}")


def start(cmd):
    return subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                            bufsize=1)


def measure_serve(savme_bin):
    """Seconds per trial through `savme serve` and per echoed trial through `cat`: the fastest
    of interleaved batches."""
    # Both sides on one core (the children inherit it): on an idle machine a wake-up on
    # another core costs savme serve's round trip ~120 µs more and `cat`'s nothing (190 against
    # 70 µs, measured 2026-11-30), which would measure the machine's idle states, not the code.
    cpus = os.sched_getaffinity(0)
    os.sched_setaffinity(0, {min(cpus)})
    try:
        return _measure_serve(savme_bin)
    finally:
        os.sched_setaffinity(0, cpus)


def _measure_serve(savme_bin):
    with tempfile.TemporaryDirectory() as d:
        cfg = os.path.join(d, "kernel.json")
        with open(cfg, "w", encoding="utf-8") as f:
            f.write(kernel_config())
        server, echo = start([savme_bin, "serve", "--config", cfg]), start(["cat"])
        try:
            for _ in range(1_000):
                serve_trial(server, None)
            server.stdin.write('{"op":"ask"}\n')
            ask = server.stdout.readline()  # a real answer, for the echo to carry
            lines = (ask,)
            per_trial, per_echo = [], []
            for _ in range(SERVE_BATCHES):
                t0 = time.perf_counter()
                for _ in range(SERVE_TRIALS):
                    serve_trial(echo, lines)
                per_echo.append((time.perf_counter() - t0) / SERVE_TRIALS)
                t0 = time.perf_counter()
                for _ in range(SERVE_TRIALS):
                    serve_trial(server, None)
                per_trial.append((time.perf_counter() - t0) / SERVE_TRIALS)
        finally:
            for p in (server, echo):
                p.stdin.close()
                p.wait()
    return min(per_trial), min(per_echo)


def kernel_config():
    """The guard's kernel (the paper's method) as a `savme serve` configuration."""
    phi = savme.Space([savme.Continuous(n, 1.0, 30.0, bins=10) for n in PHI])
    return savme.Kernel(fidelity=savme.Space(FIDELITY), theta_hf=THETA_HF,
                        scenarios={"lead_vehicle": phi}, budget=0.3, seed=1,
                        method="paper").config_json()


def check(name, ratio, records, record):
    """Records `ratio` under `name`, or compares it with the record: True on a regression."""
    if record:
        records[name] = ratio
        return False
    if name not in records:
        print(f"{RECORD}: no `{name}` record; run with --record first", file=sys.stderr)
        return True
    regressed = ratio > records[name] * TOLERANCE
    print(f"{name}: ratio {ratio:.3f} against {records[name]:.3f} recorded: "
          f"{'REGRESSION' if regressed else 'ok'}")
    return regressed


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--record", action="store_true", help="rewrite the records")
    ap.add_argument("--savme", default="target/release/savme",
                    help="the savme binary for `savme serve` (default target/release/savme)")
    a = ap.parse_args()
    if not os.access(a.savme, os.X_OK):
        print(f"--savme {a.savme}: not an executable file (cargo build --release --bin savme)",
              file=sys.stderr)
        return 2
    try:
        with open(RECORD, encoding="utf-8") as f:
            records = json.load(f)
    except OSError as e:
        if not a.record:
            print(f"{RECORD}: {e}; run with --record first", file=sys.stderr)
            return 2
        records = {}
    trial, unit = measure()
    print(f"{NAME}: {trial * 1e6:.2f} µs per ask+read+tell, reference {unit * 1e6:.2f} µs: "
          f"ratio {trial / unit:.3f}")
    served, echoed = measure_serve(a.savme)
    print(f"{SERVE}: {served * 1e6:.2f} µs per ask+tell through savme serve, the same lines "
          f"through cat {echoed * 1e6:.2f} µs: ratio {served / echoed:.3f}")
    regressed = [check(NAME, trial / unit, records, a.record),
                 check(SERVE, served / echoed, records, a.record)]
    if a.record:
        with open(RECORD, "w", encoding="utf-8") as f:
            json.dump(records, f, indent=2)
            f.write("\n")
        print(f"recorded in {RECORD}")
        return 0
    return 1 if any(regressed) else 0


if __name__ == "__main__":
    sys.exit(main())
