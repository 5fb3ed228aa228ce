"""The examples in examples/python/ run on the package (short settings)."""

import subprocess
import sys

from conftest import REPO

EXAMPLES = REPO / "examples" / "python"


def run(*args, cwd):
    out = subprocess.run([sys.executable, *map(str, args)], capture_output=True, text=True, cwd=cwd, timeout=300)
    assert out.returncode == 0, out.stderr
    return out.stdout


def test_the_harness_runs_and_resumes_its_journal(tmp_path):
    journal = tmp_path / "train.journal"
    first = run(EXAMPLES / "harness.py", "--journal", journal, "--iterations", 60, cwd=tmp_path)
    assert "meta-training: {'asked': 60, 'told': 60" in first and "meta-testing:" in first
    again = run(EXAMPLES / "harness.py", "--journal", journal, "--iterations", 200, cwd=tmp_path)
    # The journal holds the 60 training trials only (the evaluation ran on a copy): the rerun
    # continues training to 200 told, and a third run trains no more.
    assert "meta-training: {'asked': 200, 'told': 200" in again
    third = run(EXAMPLES / "harness.py", "--journal", journal, "--iterations", 200, cwd=tmp_path)
    assert "meta-training: {'asked': 200, 'told': 200" in third
    assert third.splitlines()[1:] == again.splitlines()[1:], "the same evaluation and meta-testing"


def test_the_campaign_example_writes_the_outputs_and_resumes(tmp_path):
    out = run(EXAMPLES / "campaign.py", "--out", tmp_path / "r", "--iterations", 16, "--jobs", 2, cwd=tmp_path)
    assert "TP-rate" in out and "0 replayed" in out
    assert (tmp_path / "r" / "summary.json").exists() and (tmp_path / "r" / "breakeven.png").exists()
