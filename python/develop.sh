#!/usr/bin/env bash
# Builds the savme Python package and installs it (editable) into a virtual environment with
# pytest and mypy (for the stub check), so that `cargo test --workspace` also runs the pytest suite (tests/python_package.rs).
# Run it once, and again after changing Rust code.
#
#   python/develop.sh            # debug build into $CARGO_TARGET_DIR/py-venv (or target/py-venv)
#   python/develop.sh --release  # optimised (benchmarks)
#
# SAVME_PY_VENV chooses another virtual environment. Needs python3 with venv and pip.
set -euo pipefail
cd "$(dirname "$0")/.."
target="${CARGO_TARGET_DIR:-$PWD/target}"
venv="${SAVME_PY_VENV:-$target/py-venv}"
if ! [ -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
"$venv/bin/pip" install -q --disable-pip-version-check "maturin>=1.9,<2" "pytest>=7" "mypy>=1.18"
VIRTUAL_ENV="$venv" "$venv/bin/maturin" develop -q --manifest-path python/Cargo.toml "$@"
echo "savme $("$venv/bin/python" -c 'import savme; print(savme.__version__)') installed in $venv"
