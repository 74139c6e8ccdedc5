"""Shared fixtures: where the samples and the bpins CLI are (set by the Rust test
that runs pytest, tests/python.rs; defaults for a manual run from
the repository root)."""

import os
import pathlib
import subprocess

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


@pytest.fixture(scope="session")
def moonlit_capture(cli, tmp_path_factory) -> pathlib.Path:
    """The full moon at 41.6° from 20° N 120.38° E at 2026-06-29T16:00:00Z
    (docs/night.md), one frame at heading 30°, rendered once by `bpins simulate` for
    every test that reads the moon."""
    out = tmp_path_factory.mktemp("moonlit") / "moon"
    subprocess.run([cli, "simulate", "--out", str(out), "--time-utc", "2026-06-29T16:00:00Z", "--latitude-deg", "20",
                    "--longitude-deg", "120.38", "--width-px", "256", "--height-px", "256", "--pixel-pitch-um", "27.6",
                    "--headings-deg", "30"], check=True, capture_output=True)
    return out
