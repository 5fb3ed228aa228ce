#!/usr/bin/env python3
"""Peer benchmark: savme's search against VerifAI's samplers on the same problem.

    python3 benches/peers/run.py --quick              # a few minutes: 1 seed, 2 scenarios
    python3 benches/peers/run.py                      # scenarios 1–8, 3 seeds, paper length
    python3 benches/peers/run.py --scenarios test     # the meta-testing scenarios 9–10
    python3 benches/peers/run.py --campaign examples/fmu/braking/campaign.toml

Same simulator (the bundled driving simulator, camera + lidar; or the FMU a campaign file
names, at its θ_HF), same φ-ranges (one VerifAI `Box` per φ variable), same budget in
deterministic work units (wu): each seed's savme search (`train@B` of a `savme reproduce --cost
work` campaign, or of `savme run --config FILE --cost work`; HF + LF runs charged) sets the
budget every peer gets on that seed; the deployed part likewise (savme's `screen@B` stage).
Everything runs in one invocation. See benches/peers/README.md.

The first run creates target/peers-venv (VerifAI from PyPI; GPyOpt for Bayesian optimisation
if it installs) and re-runs itself inside it; it also builds `savme` and the `peers_sim` (or,
with --campaign, `peers_fmu`) process (benches/peers/process, crate `savme-peers`) in release mode.
"""
from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import shlex
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict
from pathlib import Path

# One BLAS thread per process: the peers run `--jobs` processes on a shared machine, and
# GPyOpt's fits stall under oversubscribed BLAS threads.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

HERE = Path(__file__).resolve().parent
REPO = HERE.parent.parent
VENV = REPO / "target" / "peers-venv"
REQUIREMENTS = HERE / "requirements.txt"
OPTIONAL = HERE / "requirements-bayesopt.txt"

QUICK_SCENARIOS = ("7", "5")  # lead_vehicle_brakes, intruder_cuts_in (5 and 4 parameters)
BEGIN, END = "<!-- peers:begin -->", "<!-- peers:end -->"
# The savme rows without --savme-variant: the first sets every peer's budgets.
DEFAULT_VARIANTS = ("savme=--method tuned", "savme-paper=--method paper")


def in_venv() -> bool:
    return Path(sys.prefix).resolve() == VENV.resolve()


def ensure_venv() -> None:
    """Creates target/peers-venv on first use and re-executes this script inside it."""
    if in_venv():
        return
    py = VENV / "bin" / "python"
    if not (VENV / ".complete").exists():
        print(f"setting up {VENV} (VerifAI from PyPI) …", file=sys.stderr, flush=True)
        subprocess.run([sys.executable, "-m", "venv", str(VENV)], check=True)
        pip = [str(py), "-m", "pip", "install", "-q"]
        subprocess.run(pip + ["-r", str(REQUIREMENTS)], check=True)
        if subprocess.run(pip + ["-r", str(OPTIONAL)]).returncode != 0:
            print("GPyOpt did not install: Bayesian optimisation is left out", file=sys.stderr)
        (VENV / ".complete").write_text("ok\n")
    os.execv(str(py), [str(py), str(Path(__file__).resolve()), *sys.argv[1:]])


NO_BUILD = False  # `--no-build`: all.py built everything once before its families run


def build(profile_dir: Path, example: str) -> tuple[Path, Path]:
    """`savme` and the simulator process's example, release mode, at low priority (with
    `--no-build`: the ones already built, which must exist)."""
    savme_exe, sim_exe = profile_dir / "savme", profile_dir / example
    if NO_BUILD:
        missing = [str(p) for p in (savme_exe, sim_exe) if not p.exists()]
        if missing:
            raise SystemExit(f"--no-build: {', '.join(missing)} not built")
        return savme_exe, sim_exe
    cmd = ["nice", "-n", "10", "cargo", "build", "--release", "-p", "savme", "-p", "savme-peers",
           "--bin", "savme", "--bin", example]
    subprocess.run(cmd, check=True, cwd=REPO)
    return savme_exe, sim_exe


def parse_args() -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="1 seed, scenarios 7 and 5, 40 iterations")
    ap.add_argument("--scenarios", default="train",
                    help="train (1–8 / the campaign file's role = train), test (9–10 / role = test) or a list: 7,5")
    ap.add_argument("--campaign", type=Path, default=None, metavar="FILE",
                    help="a campaign file with an FMU instead of the bundled simulator (savme run --config FILE)")
    ap.add_argument("--rho-output", default=None, metavar="OUTPUT",
                    help="with --campaign and a Boolean [failure]: the output whose smallest value is ρ "
                         "(default: the file's [failure] robustness output, e.g. distance)")
    ap.add_argument("--seeds", type=int, default=None, help="number of seeds (default 3; quick 1)")
    ap.add_argument("--first-seed", type=int, default=1)
    ap.add_argument("--iterations", type=int, default=None, help="savme search iterations (default 500; quick 40)")
    ap.add_argument("--screen-iterations", type=int, default=None, help="savme deployed trials (default 300; quick 30)")
    ap.add_argument("--budget", type=float, default=0.3, help="savme's C_budget")
    ap.add_argument("--methods", default=None, help="VerifAI peers, comma-separated (default: all that installed)")
    ap.add_argument("--savme-variant", action="append", default=None, metavar="NAME[=FLAGS]",
                    help="a savme row: name and extra `savme reproduce` flags (repeatable; default: "
                         "savme=--method tuned, savme-paper=--method paper)")
    ap.add_argument("--peer-split", default="work", type=peer_splits,
                    help="how each peer splits its budget over the scenarios: equal work per scenario "
                         "(default: a VerifAI user's even split of the budget), equal trials, or both "
                         "(`work,trials`: every peer runs once per split; the trials split's rows are "
                         "named `VerifAI <peer>, by trials`)")
    ap.add_argument("--jobs", type=int, default=2, help="processes at once (savme --jobs, peer runs in parallel)")
    ap.add_argument("--out", type=Path, default=None, help="default target/peers/<mode>")
    ap.add_argument("--no-build", action="store_true",
                    help="use target/release's savme and simulator process as they are (all.py "
                         "builds them once: one cargo per family would wait on cargo's locks)")
    ap.add_argument("--setup-only", action="store_true",
                    help="create target/peers-venv (if missing) and stop (all.py uses it)")
    ap.add_argument("--results-md", type=Path, default=None,
                    help="also write the tables into this markdown file between the peers markers")
    return ap.parse_args()


def peer_splits(text: str) -> tuple[str, ...]:
    """`--peer-split`: `work`, `trials` or both, comma-separated (the first is the main view)."""
    splits = tuple(dict.fromkeys(t.strip() for t in text.split(",") if t.strip()))
    bad = [t for t in splits if t not in ("work", "trials")]
    if not splits or bad:
        raise argparse.ArgumentTypeError(f"{text!r}: give work, trials or work,trials")
    return splits


def peer_label(method: str, split: str) -> str:
    """A peer's row: `VerifAI <peer>` split by equal work, `VerifAI <peer>, by trials` by trials."""
    return f"VerifAI {method}" + ("" if split == "work" else ", by trials")


def scenario_keys(arg: str, quick: bool, sets, bundled: bool) -> tuple[str, ...]:
    """The scenarios of `--scenarios`: a set the simulator process names (`train`, `test`;
    `--quick` on the bundled simulator: scenarios 7 and 5) or a comma-separated list."""
    if arg == "train":
        return QUICK_SCENARIOS if quick and bundled else sets.train
    if arg == "test":
        return sets.test
    return tuple(s.strip() for s in arg.split(",") if s.strip())


def backend_of(args: argparse.Namespace, profile_dir: Path):
    """The simulator process and savme's campaign: the bundled simulator, or `--campaign`'s FMU
    (both built here)."""
    from simulator import Backend

    if args.campaign is None:
        if args.rho_output:
            raise SystemExit("--rho-output: only with --campaign (the bundled simulator's ρ is its minimum distance)")
        savme_exe, sim_exe = build(profile_dir, "peers_sim")
        return savme_exe, Backend.driving(sim_exe)
    config = args.campaign.resolve()
    if not config.is_file():
        raise SystemExit(f"--campaign {args.campaign}: no such file")
    ensure_fmus(config)
    savme_exe, sim_exe = build(profile_dir, "peers_fmu")
    return savme_exe, Backend.campaign(sim_exe, config, args.rho_output)


def ensure_fmus(config: Path) -> None:
    """Runs the `build.sh` next to a campaign file when an FMU its `[fmu]` names is missing
    (examples/fmu/braking: the FMU is compiled for this machine from its C source, not shipped)."""
    import tomllib

    with open(config, "rb") as f:
        fmu = tomllib.load(f).get("fmu", {})
    missing = [p for p in (fmu.get("hf"), fmu.get("lf")) if p and not (config.parent / p).exists()]
    script = config.parent / "build.sh"
    if missing and script.exists():
        log(f"{', '.join(missing)} missing: running {script.relative_to(REPO) if script.is_relative_to(REPO) else script}")
        subprocess.run([str(script)], check=True)


def main() -> int:
    args = parse_args()
    ensure_venv()
    if args.setup_only:
        return 0
    global NO_BUILD
    NO_BUILD = args.no_build
    sys.path.insert(0, str(HERE))
    import report
    import savme_rows
    import verifai_peers
    from simulator import Simulator

    started = dt.datetime.now(dt.timezone.utc)
    t0 = time.monotonic()
    savme_exe, backend = backend_of(args, REPO / "target" / "release")
    with Simulator(backend.sim_command) as sim:
        sets = sim.sets()
        keys = scenario_keys(args.scenarios, args.quick, sets, backend.config is None)
        spaces = [sim.space(k) for k in keys]
    names = [s.name for s in spaces]
    n_seeds = args.seeds or (1 if args.quick else 3)
    seeds = tuple(range(args.first_seed, args.first_seed + n_seeds))
    iterations = args.iterations or (40 if args.quick else 500)
    screen = args.screen_iterations if args.screen_iterations is not None else (30 if args.quick else 300)
    mode = "quick" if args.quick else "full"
    where = f"{mode}-{backend.tag}" if backend.tag else mode
    out = args.out or REPO / "target" / "peers" / f"{where}-{args.scenarios.replace(',', '_')}"
    out.mkdir(parents=True, exist_ok=True)
    # savme as a user gets it (`savme run`'s defaults: the tuned method), then the paper's SAVME.
    variants = [savme_rows.Variant.parse(v) for v in (args.savme_variant or list(DEFAULT_VARIANTS))]
    methods = [m for m in (args.methods.split(",") if args.methods else verifai_peers.PEERS)]
    if "bayesopt" in methods and not verifai_peers.bayesopt_available():
        print("GPyOpt is not installed: Bayesian optimisation left out", file=sys.stderr)
        methods.remove("bayesopt")

    protocol = savme_rows.Protocol(seeds, iterations, screen, args.budget, keys, args.jobs, backend.config)

    # savme first: its search and deployment costs set every peer's budgets, seed by seed.
    outcomes: list[report.Outcome] = []
    commands: list[str] = [shlex.join(["python3", "benches/peers/run.py", *sys.argv[1:]])]
    budgets: dict[int, tuple[int, int]] = {}
    for v in variants:
        vdir = out / "savme" / v.name
        vdir.parent.mkdir(parents=True, exist_ok=True)
        log(f"savme `{v.name}`: seeds {seeds}, {iterations} iterations, {screen} screened")
        cmd = savme_rows.run_campaign(savme_exe, v, protocol, vdir, out / "savme.log")
        commands.append(shlex.join(cmd).replace(f"{REPO}/", ""))
        with Simulator(backend.sim_command) as sim:
            for seed in seeds:
                trials = vdir / f"seed-{seed}" / "trials.jsonl"
                if not trials.exists():  # one seed: the campaign may be written in vdir itself
                    trials = vdir / "trials.jsonl"
                s = savme_rows.read_seed(trials, v.name, seed, args.budget)
                outcomes.append(savme_outcome(s, sim, report))
                if v is variants[0]:
                    budgets[seed] = (sum(s.search_work.values()), sum(s.deployed_work.values()))

    # The peers: one process per (peer, seed), `--jobs` at once.
    log(f"VerifAI peers {methods} on seeds {seeds}; budgets (wu) {budgets}")
    jobs = [(m, seed, split) for split in args.peer_split for m in methods for seed in seeds]
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        futures = {
            job: pool.submit(verifai_peers.run_peer, job[0], job[1], spaces,
                             budgets[job[1]][0], budgets[job[1]][1], backend.sim_command,
                             job[2])
            for job in jobs
        }
        for (m, seed, split), f in futures.items():
            peer = f.result()
            tail = "" if split == "work" else "-by-trials"
            save_runs(out / "peers" / f"{m}{tail}-seed-{seed}.jsonl", peer)
            outcomes.append(peer_outcome(peer, report, verifai_peers, peer_label(m, split)))
            log(f"  {peer_label(m, split)} seed {seed}: {len(peer.search)} + {len(peer.deployed)} HF runs")

    finished = dt.datetime.now(dt.timezone.utc)
    text = render(report, outcomes, names, [v.name for v in variants], dict(
        mode=mode, seeds=seeds, iterations=iterations, screen=screen, budget=args.budget,
        budgets=budgets, started=started, finished=finished, wall=time.monotonic() - t0,
        split=args.peer_split,
        commands=commands, methods=methods, problem=problem_text(backend, sets),
        per=report.PER if backend.config is None else None,
    ))
    (out / "table.md").write_text(text)
    (out / "outcomes.json").write_text(json.dumps([outcome_json(o) for o in outcomes], indent=1))
    print(text)
    if args.results_md:
        write_section(args.results_md, text, args.scenarios, where)
    return 0


def log(msg: str) -> None:
    print(f"[{dt.datetime.now(dt.timezone.utc):%H:%M:%S}] {msg}", file=sys.stderr, flush=True)


def savme_outcome(s, sim, report):
    """Tallies of a savme seed; failing cells by savme's own bins (the simulator's `arms`)."""
    def tallies(hits, work, trials):
        out = {sc: report.Tally(trials=trials[sc], work=work[sc]) for sc in work}
        for h in hits:
            if h.failure:
                out[h.scenario].failures += 1
                out[h.scenario].cells.add((h.scenario, sim.arms(h.scenario, h.phi)))
        return out

    return report.Outcome(
        s.method, s.seed,
        tallies(s.search_hf, s.search_work, s.search_trials),
        tallies(s.deployed_hf, s.deployed_work, s.deployed_trials),
    )


def peer_outcome(peer, report, verifai_peers, label=None):
    def tallies(runs):
        out = {}
        for r in runs:
            t = out.setdefault(r.scenario, report.Tally())
            t.trials += 1
            t.work += r.work
            if r.failure:
                t.failures += 1
                t.cells.add((r.scenario, r.arms))
        return out

    return report.Outcome(
        label or f"VerifAI {peer.method}", peer.seed, tallies(peer.search), tallies(peer.deployed),
        verifai_peers.overhead_ms(peer),
    )


def save_runs(path: Path, peer) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w") as f:
        for part in ("search", "deployed"):
            for r in getattr(peer, part):
                f.write(json.dumps({"part": part, **asdict(r)}) + "\n")


def outcome_json(o) -> dict:
    def part(d):
        return {sc: {"trials": t.trials, "failures": t.failures, "work": t.work, "cells": len(t.cells)}
                for sc, t in d.items()}

    return {"method": o.method, "seed": o.seed, "overhead_ms": o.overhead_ms,
            "search": part(o.search), "deployed": part(o.deployed)}


def problem_text(backend, sets) -> str:
    """What the runs simulate, for the table's heading."""
    if backend.config is None:
        return "camera + lidar"
    config = str(backend.config).replace(f"{REPO}/", "")
    label = sets.label.replace(f"{REPO}/", "")
    return f"the campaign file {config} ({label}) at its θ_HF; ρ for the peers: {sets.rho}"


def render(report, outcomes, names, savme_methods, info) -> str:
    # The bundled simulator's tables stay per 10⁹ wu (comparable across runs and with the issue);
    # a campaign file's FMU counts its own units, often a few hundred a run: a unit to fit.
    per = info["per"] or report.unit(b for pair in info["budgets"].values() for b in pair)
    u = report.UNITS[per]
    ahead = report.peers_ahead(outcomes, savme_methods, per)
    lines = [
        f"Run {info['started']:%Y-%m-%d %H:%M}–{info['finished']:%H:%M} UTC ({info['wall'] / 60:.0f} min wall), "
        f"mode {info['mode']}, seeds {', '.join(map(str, info['seeds']))}, scenarios {', '.join(names)}, "
        f"{info['problem']}. savme: C_budget {info['budget']}, {info['iterations']} search iterations, "
        f"{info['screen']} screened trials (`--audit-fraction 0`). Budgets per seed (search, deployed; "
        f"{u} wu): " + "; ".join(f"seed {s}: {a / per:.2f}, {b / per:.2f}" for s, (a, b) in info["budgets"].items())
        + ". Every VerifAI peer gets its seed's budgets on HF only, split over the scenarios by "
        + " and, as a second view, ".join({"work": "equal work", "trials": "equal trials"}[x]
                                          for x in info["split"])
        + (" (rows `…, by trials`)" if len(info["split"]) > 1 else "")
        + " (savme allocates its own).",
        "",
        "Commands:",
        "",
        "```sh",
        *info["commands"],
        "```",
        "",
        f"Per {u} work units, mean ± sd over seeds:",
        "",
        report.main_table(outcomes, per),
        "",
        f"HF failures per {u} wu in the search, per scenario (mean ± sd over seeds):",
        "",
        report.scenario_table(outcomes, names, savme_methods, per),
        "",
        "Where a peer is ahead of savme (means):",
        "",
        *(ahead or ["- nowhere"]),
        "",
    ]
    return "\n".join(lines)


def write_section(path: Path, text: str, scenarios: str, mode: str) -> None:
    """Replaces (or appends) the block between this mode's markers in `path`."""
    begin, end = f"{BEGIN[:-4]} {mode} {scenarios} -->", f"{END[:-4]} {mode} {scenarios} -->"
    doc = path.read_text() if path.exists() else ""
    block = f"{begin}\n{text}\n{end}"
    if begin in doc and end in doc:
        head, rest = doc.split(begin, 1)
        doc = head + block + rest.split(end, 1)[1]
    else:
        doc = doc.rstrip("\n") + "\n\n" + block + "\n"
    path.write_text(doc)


if __name__ == "__main__":
    sys.path.insert(0, str(HERE))
    from simulator import SimulatorError

    try:
        sys.exit(main())
    except SimulatorError as e:  # a bad campaign file, flag or request: said, not a traceback
        sys.exit(f"run.py: {e}")
