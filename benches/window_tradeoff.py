"""What the window costs: HF failures found per unit of work, per stage, for several windows and
seeds (docs/DISTRIBUTED.md, "The window"; docs/RESULTS.md, "Searching by cost").

    python3 benches/window_tradeoff.py SAVME WINDOWS SEEDS [extra savme flags...]
    python3 benches/window_tradeoff.py --reproduce SAVME WINDOWS SEEDS [extra flags...]
    python3 benches/window_tradeoff.py --run CONFIG SAVME WINDOWS SEEDS [extra flags...]
    python3 benches/window_tradeoff.py [--reproduce | --run CONFIG] --json FILE SAVME WINDOWS SEEDS [...]

(`--json FILE`: also writes every seed's rates, per window, to FILE.)

e.g. `python3 benches/window_tradeoff.py target/debug/savme 1,4,16,64,256 10` (the toy
simulator, `savme toy`, per 10⁶ wu) and `python3 benches/window_tradeoff.py --reproduce
target/release/savme 1,4,16 3 --method tuned --train-scenarios 1,2,3,4,5,6,7,8 --iterations 300
--screen-iterations 180` (the bundled camera + lidar simulator, `savme reproduce`, per 10⁹ wu:
the search `train@0.3` and the deployed search `screen@0.3`, whose HF failures are confirmed
ones); `--run CONFIG` the same two stages of `savme run --config CONFIG` (a campaign file,
e.g. an FMU's, per 10³ wu). Prints, per window, mean ± standard deviation over the seeds and the ratio of the means
to the first window's.
"""

import json
import shlex
import shutil
import statistics
import subprocess
import sys
import tempfile

TOY_STAGES = ["train@0.3", "test-learned@0.3", "test-uniform@0.3", "baseline-test"]
BUNDLED_STAGES = ["train@0.3", "screen@0.3"]


def cost(t):
    """Every run a line made (a screened line may lack its HF or its LF run)."""
    return sum((t.get(r) or {}).get("runtime", 0.0) for r in ("hf", "lf"))


def rates(cmd, stages, per, out):
    shutil.rmtree(out, ignore_errors=True)
    subprocess.run([*cmd, "--out", out], check=True, stdout=subprocess.DEVNULL)
    acc = {k: [0, 0.0] for k in stages}
    with open(f"{out}/trials.jsonl") as f:
        for line in f:
            t = json.loads(line)
            if t.get("stage") in acc:  # (the store's first record is the protocol)
                a = acc[t["stage"]]
                a[0] += bool((t.get("hf") or {}).get("failure"))
                a[1] += cost(t)
    shutil.rmtree(out, ignore_errors=True)
    return {k: f / c * per for k, (f, c) in acc.items()}


def main():
    args = sys.argv[1:]
    bundled = args[:1] == ["--reproduce"]
    if bundled:
        args = args[1:]
    config = None
    if args[:1] == ["--run"]:
        config, args = args[1], args[2:]
    dump = None
    if args[:1] == ["--json"]:
        dump, args = args[1], args[2:]
    exe, windows, seeds, extra = args[0], args[1], int(args[2]), args[3:]
    stages, per = (BUNDLED_STAGES, 1e9) if bundled else (TOY_STAGES, 1e6)
    if config:
        stages, per = BUNDLED_STAGES, 1e3
    out = tempfile.mkdtemp(prefix="savme-window-")
    print(f"per {per:.0e} wu; " + shlex.join([exe, *args[3:]]))
    print("| window | " + " | ".join(stages) + " |")
    print("|---" * (len(stages) + 1) + "|")
    first = None
    every = {}
    for w in [int(x) for x in windows.split(",")]:
        per_seed = []
        for s in range(1, seeds + 1):
            if config:
                cmd = [exe, "run", "--config", config, "--cost", "work", "--quiet", "--budgets", "0.3",
                       "--eval-iterations", "1", "--test-iterations", "1", "--baseline-iterations", "1",
                       "--baseline-test-iterations", "1", "--audit-fraction", "0",
                       "--window", str(w), "--seed", str(s), *extra]
            elif bundled:
                cmd = [exe, "reproduce", "--cost", "work", "--quiet", "--budgets", "0.3",
                       "--eval-iterations", "1", "--test-iterations", "1", "--baseline-iterations", "1",
                       "--baseline-test-iterations", "1", "--audit-fraction", "0",
                       "--window", str(w), "--seed", str(s), *extra]
            else:
                cmd = [exe, "toy", "--window", str(w), "--seed", str(s), "--cost", "work", "--quiet", *extra]
            per_seed.append(rates(cmd, stages, per, out + "/run"))
        every[w] = per_seed
        if dump:
            with open(dump, "w") as f:
                json.dump(every, f, indent=1)
        means = {k: statistics.mean(p[k] for p in per_seed) for k in stages}
        first = first or means
        cells = [f"{means[k]:.1f} ± {statistics.stdev(p[k] for p in per_seed) if seeds > 1 else 0.0:.1f}"
                 f" ({means[k] / first[k]:.2f}×)" if first[k] else f"{means[k]:.1f}" for k in stages]
        print(f"| {w} | " + " | ".join(cells) + " |", flush=True)
    shutil.rmtree(out, ignore_errors=True)


if __name__ == "__main__":
    main()
