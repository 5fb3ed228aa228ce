"""The interop tests run in the interop environment (target/interop-venv: verifai, scenic,
scenariogeneration and the savme wheel), started by tests/it/interop.rs."""

import pathlib

HERE = pathlib.Path(__file__).parent
