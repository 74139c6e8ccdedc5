"""Shared fixtures: where the samples and the bpins CLI are (set by the Rust test
that runs pytest, tests/python.rs; defaults for a manual run from
the repository root)."""

import os
import pathlib

import pytest

REPO = pathlib.Path(__file__).resolve().parents[3]


@pytest.fixture(scope="session")
def samples() -> pathlib.Path:
    return pathlib.Path(os.environ.get("BPINS_SAMPLES", REPO / "samples"))


@pytest.fixture(scope="session")
def cli() -> str:
    path = os.environ.get("BPINS_CLI")
    if not path:
        pytest.skip("BPINS_CLI is not set (the Rust test python.rs sets it)")
    return path
