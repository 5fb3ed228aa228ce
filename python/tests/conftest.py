"""Shared fixtures: the `savme` binary (for the CLI interoperability tests), temp journals.

The CLI tests need the `savme` binary built from the same sources (`cargo build --bin savme`).
It is found through $SAVME_BIN, else in $CARGO_TARGET_DIR/debug, else in the repository's
target/debug. Without it those tests skip loudly; with SAVME_REQUIRE_PYTHON_PACKAGE=1 (set by
.ci/run) they fail instead.
"""

import json
import os
import pathlib
import subprocess
import sys

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


def _candidates():
    if os.environ.get("SAVME_BIN"):
        yield pathlib.Path(os.environ["SAVME_BIN"])
    if os.environ.get("CARGO_TARGET_DIR"):
        yield pathlib.Path(os.environ["CARGO_TARGET_DIR"]) / "debug" / "savme"
    yield REPO / "target" / "debug" / "savme"


@pytest.fixture(scope="session")
def savme_bin():
    for path in _candidates():
        if path.is_file() and os.access(path, os.X_OK):
            return str(path)
    message = (
        "the savme binary was not found (set SAVME_BIN, or run `cargo build --bin savme`): "
        "SKIPPING the tests against the CLI"
    )
    if os.environ.get("SAVME_REQUIRE_PYTHON_PACKAGE") == "1":
        pytest.fail(message + " — but SAVME_REQUIRE_PYTHON_PACKAGE=1 requires them")
    print("\n*** " + message + " ***", file=sys.stderr)
    pytest.skip(message)


@pytest.fixture(scope="session")
def example_config(savme_bin):
    """The toy kernel configuration `savme example-config` prints (JSON text)."""
    return subprocess.run(
        [savme_bin, "example-config"], check=True, capture_output=True, text=True
    ).stdout


def serve(savme_bin, requests, *args):
    """Runs `savme serve ARGS` on the request dicts; returns the responses (dicts)."""
    text = "".join(json.dumps(r) + "\n" for r in requests)
    out = subprocess.run(
        [savme_bin, "serve", *args], input=text, capture_output=True, text=True, timeout=60
    )
    assert out.returncode == 0, out.stderr
    responses = [json.loads(line) for line in out.stdout.splitlines()]
    assert len(responses) == len(requests), out.stderr
    return responses


def paired(failure_hf, failure_lf, t_hf=1.0, t_lf=0.2):
    """A serve tell observation of two runs."""
    return {
        "paired": {
            "hf": {"failure": failure_hf, "runtime": t_hf},
            "lf": {"failure": failure_lf, "runtime": t_lf},
        }
    }
