"""What the window costs: HF failures found per million work units of compute, per stage,
for several windows and seeds (docs/DISTRIBUTED.md, "The window").

    python3 benches/window_tradeoff.py SAVME WINDOWS SEEDS [extra savme toy flags...]

e.g. `python3 benches/window_tradeoff.py target/debug/savme 1,4,16,64,256 10` and
`python3 benches/window_tradeoff.py target/debug/savme 4,16,64 5 --iterations 1000
--test-iterations 1000`. Prints, per window, mean ± standard deviation over the seeds.
"""

import json
import shutil
import statistics
import subprocess
import sys
import tempfile

STAGES = ["train@0.3", "test-learned@0.3", "test-uniform@0.3", "baseline-test"]


def rates(exe, window, seed, extra, out):
    shutil.rmtree(out, ignore_errors=True)
    subprocess.run(
        [exe, "toy", "--out", out, "--window", str(window), "--seed", str(seed),
         "--cost", "work", "--quiet", *extra],
        check=True, stdout=subprocess.DEVNULL)
    acc = {k: [0, 0.0] for k in STAGES}
    with open(f"{out}/trials.jsonl") as f:
        for line in f:
            t = json.loads(line)
            if t.get("stage") in acc:  # (the store's first record is the protocol)
                a = acc[t["stage"]]
                a[0] += bool(t["hf"]["failure"])
                a[1] += t["hf"]["runtime"] + (t["lf"]["runtime"] if t.get("lf") else 0.0)
    shutil.rmtree(out, ignore_errors=True)
    return {k: f / c * 1e6 for k, (f, c) in acc.items()}


def main():
    exe, windows, seeds, extra = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4:]
    out = tempfile.mkdtemp(prefix="savme-window-")
    print("| window | " + " | ".join(STAGES) + " |")
    print("|---" * (len(STAGES) + 1) + "|")
    for w in [int(x) for x in windows.split(",")]:
        per = [rates(exe, w, s, extra, out + "/run") for s in range(1, seeds + 1)]
        cells = [f"{statistics.mean(p[k] for p in per):.1f} ± {statistics.stdev(p[k] for p in per):.1f}"
                 for k in STAGES]
        print(f"| {w} | " + " | ".join(cells) + " |", flush=True)
    shutil.rmtree(out, ignore_errors=True)


if __name__ == "__main__":
    main()
