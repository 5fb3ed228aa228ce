#!/usr/bin/env python3
"""The whole peer benchmark in one command: savme (its defaults) against VerifAI's samplers on
every simulator family, then the per-family and aggregated tables.

    python3 benches/peers/all.py --quick     # a smoke run of every family: seed 1, short searches
    python3 benches/peers/all.py             # seeds 1–3, the lengths below; rewrites docs/RESULTS.md's block

From a fresh clone it builds `savme` and the simulator processes (release), the FMUs (the
braking example, the Reference FMU BouncingBall) and target/peers-venv (VerifAI from PyPI), then
runs `run.py` once per family — every family in the same time window, `--parallel` at a time —
with the peers split by equal work per scenario and, as a second view, by equal trials
(`--peer-split work,trials`), and `families.py` over the outputs. savme's row is savme with its
defaults (`--method tuned`); it sets each seed's budgets in work units.

Outputs: target/peers/<quick|full>-all/<family>/ (each run.py output: table.md, outcomes.json,
the peers' runs, savme's campaigns) and target/peers/<quick|full>-all/summary.md. The full mode
also writes summary.md between the `peers-all` markers of docs/RESULTS.md and copies each
family's table.md and outcomes.json to docs/results-peers-all/ (`--no-docs`: neither).
See benches/peers/README.md.
"""
from __future__ import annotations

import argparse
import datetime as dt
import os
import re
import shlex
import shutil
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent.parent
BEGIN, END = "<!-- peers-all:begin -->", "<!-- peers-all:end -->"
BRAKING = "examples/fmu/braking/campaign.toml"
BALL = "examples/fmu/bouncing_ball/campaign.toml"


@dataclass(frozen=True)
class Family:
    """One simulator family: its name in the tables, its directory and run.py's arguments in
    the full mode (the quick mode adds `--quick`, which shortens them)."""

    name: str
    slug: str
    args: tuple[str, ...]
    full: tuple[str, ...]  # the full mode's lengths
    unit: float  # the unit of its rates in the tables (work units)
    script: str = "run.py"  # its runner in benches/peers/
    quick: bool = True  # in --quick's default set (every family is in the full mode's)


FAMILIES = (
    Family("bundled 1–8", "bundled-train", ("--scenarios", "train"),
           ("--iterations", "300", "--screen-iterations", "180"), 1e9),
    Family("bundled 9–10", "bundled-test", ("--scenarios", "test"),
           ("--iterations", "150", "--screen-iterations", "90"), 1e9),
    Family("braking FMU, dry+wet", "braking-train",
           ("--campaign", BRAKING, "--scenarios", "train"),
           ("--iterations", "200", "--screen-iterations", "120"), 1e3),
    Family("braking FMU, icy", "braking-test",
           ("--campaign", BRAKING, "--scenarios", "test"),
           ("--iterations", "150", "--screen-iterations", "90"), 1e3),
    Family("Reference FMU BouncingBall, earth+mars", "ball-train",
           ("--campaign", BALL, "--scenarios", "train"),
           ("--iterations", "200", "--screen-iterations", "120"), 1e3),
    Family("Reference FMU BouncingBall, moon", "ball-test",
           ("--campaign", BALL, "--scenarios", "test"),
           ("--iterations", "150", "--screen-iterations", "90"), 1e3),
    # highway-env (run_highway_env.py: its own venv with savme's wheel built from this
    # checkout): 150 search trials a seed is the length that ranks methods (issue 42);
    # Bayesian optimisation (GPyOpt's fit per sample) runs last: ≈ 40 min of CPU a seed when
    # its BLAS threads fought each other (38 min measured), ≈ 5 min with one thread a process
    # (run_highway_env.py sets it since 2026-11-30: 434–514 ms of sampler time a run); --quick leaves it out unless named (its venv and the wheel's debug build
    # are most of a fresh clone's quick run: README.md).
    Family("highway-env, merge+roundabout", "highway", ("--scenarios", "merge", "roundabout"),
           ("--iterations", "150", "--screen-iterations", "90"), 1e6,
           script="run_highway_env.py", quick=False),
)
HIGHWAY = "run_highway_env.py"


def choose(families: str | None, quick: bool) -> list[Family]:
    """The families `--families` names (in FAMILIES' order), or the default set: every family,
    but --quick leaves out those not marked `quick` (highway-env)."""
    if families is None:
        return [f for f in FAMILIES if f.quick or not quick]
    names = [n.strip() for n in families.split(",") if n.strip()]
    unknown = [n for n in names if n not in {f.slug for f in FAMILIES}]
    if unknown or not names:
        sys.exit(f"--families {families}: {', '.join(unknown) or 'nothing'} is not one of "
                 + ", ".join(f.slug for f in FAMILIES))
    return [f for f in FAMILIES if f.slug in names]


def parse_args() -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="every family with run.py --quick (seed 1)")
    ap.add_argument("--seeds", type=int, default=None, help="seeds 1..N (default 3; quick 1)")
    ap.add_argument("--families", default=None,
                    help="a comma-separated subset of: " + ", ".join(f.slug for f in FAMILIES)
                    + " (default: all; --quick: all but highway)")
    ap.add_argument("--parallel", type=int, default=2, help="families run at once (default 2)")
    ap.add_argument("--jobs", type=int, default=1, help="each run.py's --jobs (default 1)")
    ap.add_argument("--out", type=Path, default=None, help="default target/peers/<quick|full>-all")
    ap.add_argument("--no-docs", action="store_true", help="full mode: leave docs/ alone")
    ap.add_argument("--no-build", action="store_true",
                    help="no cargo build: target/release's binaries as they are (they must exist)")
    ap.add_argument("--report-only", action="store_true",
                    help="run nothing: the summary (and, full mode, docs) of the families' outputs "
                         "already in --out (e.g. families run by several all.py invocations)")
    return ap.parse_args()


def log(msg: str) -> None:
    print(f"[{dt.datetime.now(dt.timezone.utc):%H:%M:%S}] {msg}", file=sys.stderr, flush=True)


def prepare(chosen: list[Family], build: bool = True) -> tuple[float, float]:
    """What the chosen families need, once before they run in parallel: for run.py's, its
    venv, the release build and the FMUs their campaign files name; for highway-env's, its
    venv and savme's wheel (`run_highway_env.py --setup-only`). The builds run while pip
    installs the venvs (one is downloads, the other CPU). Returns the seconds until run.py's
    venv was ready, then until the builds, FMUs and highway-env's set-up were."""
    sys.path.insert(0, str(HERE))
    import run

    t0 = time.monotonic()
    bundled = [f for f in chosen if f.script != HIGHWAY]
    started = []
    if build and bundled:
        started.append(("the release build", subprocess.Popen(
            ["nice", "-n", "10", "cargo", "build", "--release", "-p", "savme", "-p", "savme-peers",
             "--bin", "savme", "--bin", "peers_sim", "--bin", "peers_fmu"], cwd=REPO)))
    if len(bundled) < len(chosen):
        started.append(("highway-env's venv and savme's wheel", subprocess.Popen(
            [sys.executable, str(HERE / HIGHWAY), "--setup-only", *([] if build else ["--no-build"])],
            cwd=REPO)))
    try:
        if bundled and not (run.VENV / ".complete").exists():
            subprocess.run([sys.executable, str(HERE / "run.py"), "--setup-only"], check=True)
    except BaseException:
        for _, p in started:
            p.kill()
        raise
    t1 = time.monotonic()
    for what, p in started:
        if p.wait() != 0:
            raise SystemExit(f"all.py: {what} failed (exit {p.returncode})")
    for config in dict.fromkeys(f.args[f.args.index("--campaign") + 1] for f in bundled
                                if "--campaign" in f.args):
        run.ensure_fmus(REPO / config)
    return t1 - t0, time.monotonic() - t1


def family_command(f: Family, args: argparse.Namespace, out: Path) -> list[str]:
    """The family's runner command: run.py with both peer splits (`--peer-split work,trials`)
    and `--jobs`; run_highway_env.py runs both splits by default (rows `SAMPLER/trials`) and
    one campaign trial at a time."""
    split = ([] if f.script == HIGHWAY else
             ["--peer-split", "work,trials", "--jobs", str(args.jobs)])
    return ["python3", f"benches/peers/{f.script}", *f.args,
            *(["--quick"] if args.quick else f.full),
            *(["--seeds", str(args.seeds)] if args.seeds else []), *split, "--no-build",
            "--out", str((out / f.slug).relative_to(REPO) if out.is_relative_to(REPO) else out / f.slug)]


def run_window(table: Path) -> tuple[dt.datetime, dt.datetime, float]:
    """When a family's run.py ran (its table.md's first line: `Run 2026-11-29 10:41–11:52 UTC
    (71 min wall)`): start, end and wall minutes."""
    m = re.match(r"Run (\d{4}-\d\d-\d\d) (\d\d:\d\d)–(\d\d:\d\d) UTC \((\d+) min wall\)",
                 table.read_text())
    if not m:
        raise SystemExit(f"{table}: no `Run … UTC (N min wall)` line: not a run.py table")
    day, a, b, wall = m.groups()
    start = dt.datetime.fromisoformat(f"{day}T{a}+00:00")
    end = dt.datetime.fromisoformat(f"{day}T{b}+00:00")
    return start, end + (dt.timedelta(days=1) if end < start else dt.timedelta()), float(wall)


def table_commands(table: Path) -> list[list[str]]:
    """The commands a family's table.md says it ran: run.py's one command line, or every
    run_highway_env.py invocation that added rows (its table lists them)."""
    def command(line: str) -> list[str] | None:
        """The line's words if it runs run.py or run_highway_env.py (after any NAME=VALUE
        settings of its environment, e.g. OMP_NUM_THREADS=1), else None."""
        words = line.split()
        env = next((i for i, w in enumerate(words) if not re.fullmatch(r"[A-Z_][A-Z0-9_]*=\S*", w)),
                   len(words))
        script = words[env:env + 2]
        if script in (["python3", "benches/peers/run.py"], ["python3", f"benches/peers/{HIGHWAY}"]):
            return shlex.split(line)
        return None

    found = [c for c in map(command, table.read_text().splitlines()) if c is not None]
    if not found:
        raise SystemExit(f"{table}: no run.py or run_highway_env.py command in it")
    return found if any(w.endswith(HIGHWAY) for w in found[0]) else found[:1]


def run_family(f: Family, args: argparse.Namespace, out: Path) -> tuple[Family, float, list[str]]:
    cmd = family_command(f, args, out)
    log(f"{f.name}: {shlex.join(cmd)}")
    t0 = time.monotonic()
    with open(out / f"{f.slug}.log", "w") as logf:
        subprocess.run([sys.executable, *cmd[1:]], check=True, cwd=REPO, stdout=logf,
                       stderr=subprocess.STDOUT)
    wall = time.monotonic() - t0
    log(f"{f.name}: done in {wall / 60:.1f} min")
    return f, wall, [cmd]


def summary(args, out: Path, done, started, finished, setup) -> str:
    import families as fam

    loaded = [(f.name, fam.load(f"{f.name}={out / f.slug}")[1]) for f, _, _ in done]
    units = {f.name: f.unit for f, _, _ in done}
    mode = "quick" if args.quick else "full"
    cmd = shlex.join(["python3", "benches/peers/all.py", *sys.argv[1:]])
    lines = [
        f"Generated by `{cmd}` ({mode} mode) on {started:%Y-%m-%d}: every family run "
        f"{started:%H:%M}–{finished:%H:%M} UTC on one machine ({os.cpu_count()} cores). "
        + ("" if setup is None else f"Set-up before it: run.py's venv {setup[0] / 60:.1f} min (the "
           f"builds running beside it), then the builds, FMUs and highway-env's venv and wheel "
           f"(those chosen) {setup[1] / 60:.1f} min more. ")
        + "savme's row is savme with its defaults (`--method tuned`); every peer gets the same "
        "budgets in work units per seed, split over the scenarios by equal work (first table) "
        "and, as a second view, by equal trials. Per family, its command (run.py; "
        "run_highway_env.py for highway-env) and wall time:",
        "",
        "```sh",
        *(line for _, w, cs in done for line in
          [*map(shlex.join, cs[:-1]), f"{shlex.join(cs[-1])}   # {w / 60:.0f} min"]),
        "```",
        "",
        "savme (defaults) against the best VerifAI sampler per family and metric, **peers split "
        "by equal work per scenario**:",
        "",
        fam.ratio_table(loaded, "savme", "work"),
        "",
        "The rates behind it (mean ± sd over seeds, per the unit after each family's name):",
        "",
        fam.rates_table(loaded, "savme", "work", units),
        "",
        "The same with the **peers split by equal trials per scenario**:",
        "",
        fam.ratio_table(loaded, "savme", "trials"),
        "",
        "`savme-paper` (the paper's SAVME, `--method paper`) against the peers split by equal work:",
        "",
        fam.ratio_table(loaded, "savme-paper", "work"),
        "",
    ]
    return "\n".join(lines)


def write_docs(out: Path, text: str, done) -> None:
    """The summary into docs/RESULTS.md between the markers; each family's table and outcomes
    into docs/results-peers-all/<family>/."""
    md = REPO / "docs" / "RESULTS.md"
    doc = md.read_text()
    block = f"{BEGIN}\n{text}\n{END}"
    if BEGIN in doc and END in doc:
        head, rest = doc.split(BEGIN, 1)
        doc = head + block + rest.split(END, 1)[1]
    else:
        doc = doc.rstrip("\n") + "\n\n" + block + "\n"
    md.write_text(doc)
    for f, _, _ in done:
        dest = REPO / "docs" / "results-peers-all" / f.slug
        dest.mkdir(parents=True, exist_ok=True)
        for name in ("table.md", "outcomes.json"):
            shutil.copyfile(out / f.slug / name, dest / name)


def main() -> int:
    args = parse_args()
    chosen = choose(args.families, args.quick)
    out = (args.out or REPO / "target" / "peers" / ("quick-all" if args.quick else "full-all")).resolve()
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.monotonic()
    if args.report_only:
        setup = None
        done = [(f, 60 * run_window(out / f.slug / "table.md")[2], table_commands(out / f.slug / "table.md"))
                for f in chosen]
    else:
        setup = prepare(chosen, not args.no_build)
        with ThreadPoolExecutor(max_workers=args.parallel) as pool:
            done = list(pool.map(lambda f: run_family(f, args, out), chosen))
    windows = [run_window(out / f.slug / "table.md") for f in chosen]
    started, finished = min(w[0] for w in windows), max(w[1] for w in windows)
    sys.path.insert(0, str(HERE))
    text = summary(args, out, done, started, finished, setup)
    (out / "summary.md").write_text(text)
    print(text)
    if not args.quick and not args.no_docs:
        write_docs(out, text, done)
        log("docs/RESULTS.md (peers-all block) and docs/results-peers-all/ rewritten")
    if args.report_only:
        log(f"report of {len(done)} families' outputs in {out} (nothing run)")
    else:
        log(f"all families in {(time.monotonic() - t0) / 60:.1f} min (set-up included)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
