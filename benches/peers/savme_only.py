#!/usr/bin/env python3
"""savme's rows alone, over many seeds: what a change to savme's search does to the peer
benchmark's three rates (HF failures, distinct failing cells and confirmed deployed failures
per work unit) before the peers are run again — the tool behind docs/RESULTS.md's paired-seed
comparisons (issue 42, "More candidates per draw").

    python3 benches/peers/savme_only.py --scenarios train --seeds 20 -- --elite tries=8
    python3 benches/peers/savme_only.py --campaign examples/fmu/bouncing_ball/campaign.toml \\
        --iterations 200 --screen-iterations 120 --seeds 60 -- --elite tries=32

Everything after `--` goes to the savme command (`savme reproduce --method tuned` on the
bundled simulator, `savme run --config FILE` on a campaign file); each variant runs seeds
1..N, so two variants are compared seed for seed. The rates are the benchmark's own
(benches/peers/run.py's tallies, report.py's metrics), per 10⁹ wu on the bundled simulator and
per 10³ wu on a campaign file, mean and standard error over the seeds, then the search rate per
scenario. Uses target/release's savme and simulator process (`run.py --setup-only` builds
them); no VerifAI, no virtual environment.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent.parent
sys.path.insert(0, str(HERE))

import report  # noqa: E402
import run  # noqa: E402
import savme_rows  # noqa: E402
from simulator import Backend, Simulator  # noqa: E402

METRICS = ("search_failures", "search_cells", "deployed_failures")


def parse(argv: list[str]) -> tuple[argparse.Namespace, list[str]]:
    flags: list[str] = []
    if "--" in argv:
        at = argv.index("--")
        argv, flags = argv[:at], argv[at + 1:]
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--campaign", type=Path, help="a campaign file (default: the bundled simulator)")
    ap.add_argument("--scenarios", default="train",
                    help="train, test or comma-separated names (as run.py's --scenarios)")
    ap.add_argument("--iterations", type=int, default=300, help="search trials per seed")
    ap.add_argument("--screen-iterations", type=int, default=180, help="deployed trials per seed")
    ap.add_argument("--seeds", type=int, default=20, help="seeds 1..N")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", type=Path, default=REPO / "target" / "peers" / "savme-only")
    return ap.parse_args(argv), flags


def backend(args: argparse.Namespace) -> tuple[Path, Backend]:
    release = REPO / "target" / "release"
    savme = release / "savme"
    if args.campaign is None:
        sim = release / "peers_sim"
        b = Backend.driving(sim)
    else:
        sim = release / "peers_fmu"
        run.ensure_fmus(args.campaign.resolve())
        b = Backend.campaign(sim, args.campaign.resolve(), None)
    for exe in (savme, sim):
        if not exe.is_file():
            sys.exit(f"{exe}: missing — build it with `python3 benches/peers/run.py --setup-only`"
                     + ("" if args.campaign is None else f" --campaign {args.campaign}"))
    return savme, b


def main(argv: list[str]) -> int:
    args, flags = parse(argv)
    savme, b = backend(args)
    bundled = b.config is None
    if bundled and "--method" not in flags:
        flags = ["--method", "tuned", *flags]  # `savme reproduce` runs the paper's by default
    with Simulator(b.sim_command) as sim:
        keys = run.scenario_keys(args.scenarios, False, sim.sets(), bundled)
        seeds = tuple(range(1, args.seeds + 1))
        p = savme_rows.Protocol(seeds, args.iterations, args.screen_iterations, 0.3, keys,
                                args.jobs, b.config)
        out = args.out
        shutil.rmtree(out, ignore_errors=True)
        out.mkdir(parents=True)
        cmd = savme_rows.command(savme, savme_rows.Variant("savme", tuple(flags)), p, out)
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        outcomes = []
        for seed in seeds:
            s = savme_rows.read_seed(out / f"seed-{seed}" / "trials.jsonl", "savme", seed, 0.3)
            outcomes.append(run.savme_outcome(s, sim, report))
    per = 1e9 if bundled else 1e3
    m = report.metrics(outcomes, per)
    n = len(outcomes)
    print(f"{' '.join(flags) or '(defaults)'}: seeds 1–{n}, per {per:.0e} wu, mean ± s.e.")
    for k in METRICS:
        print(f"  {k}: {m[k][0]:.3f} ± {m[k][1] / n ** 0.5:.3f}")
    print("  search per scenario: " + ", ".join(
        f"{sc} {report.scenario_rates(outcomes, sc, per)[0]:.2f}"
        for sc in sorted(outcomes[0].search)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
