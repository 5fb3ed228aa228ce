#!/usr/bin/env bash
# Builds the savme Python package and installs it (editable) into a virtual environment with
# pytest, mypy (for the stub check), numpy (numpy-bool results are tested) and Ray (the Ray
# executor's tests start a local Ray cluster: one ~80 MB wheel, ~30 s the first time), so that
# `cargo test --workspace` also runs the pytest suite (tests/it/python_package.rs).
# Run it once, and again after changing Rust code.
#
#   python/develop.sh            # debug build into $CARGO_TARGET_DIR/py-venv (or target/py-venv)
#   python/develop.sh --release  # optimised (benchmarks)
#   python/develop.sh --wheel    # build the wheel (debug) and pip-install it, as a user would
#                                # install a wheel: what scripts/test does, so that the tests
#                                # also check what the wheel contains
#
# SAVME_PY_VENV chooses another virtual environment. Needs python3 with venv and pip.
set -euo pipefail
cd "$(dirname "$0")/.."
target="${CARGO_TARGET_DIR:-$PWD/target}"
venv="${SAVME_PY_VENV:-$target/py-venv}"
if ! [ -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
"$venv/bin/pip" install -q --disable-pip-version-check -r python/requirements-test.txt
if [ "${1:-}" = "--wheel" ]; then
  shift
  wheels="$target/wheels/test"
  rm -rf "$wheels"
  "$venv/bin/maturin" build -q --profile dev --manifest-path python/Cargo.toml \
    --interpreter "$venv/bin/python" -o "$wheels" "$@"
  "$venv/bin/pip" install -q --disable-pip-version-check --force-reinstall --no-deps "$wheels"/savme-*.whl
else
  VIRTUAL_ENV="$venv" "$venv/bin/maturin" develop -q --manifest-path python/Cargo.toml "$@"
fi
echo "savme $("$venv/bin/python" -c 'import savme; print(savme.__version__)') installed in $venv"
