"""examples/python/quickstart.py runs and reads the clean sample to its 1σ."""

import pathlib
import subprocess
import sys

REPO = pathlib.Path(__file__).resolve().parents[3]


def test_quickstart_runs(samples):
    out = subprocess.run([sys.executable, str(REPO / "examples/python/quickstart.py"), str(samples / "clean")],
                         check=True, capture_output=True, text=True).stdout
    assert "truth 30°" in out
    rms = float(out.strip().splitlines()[-1].split("RMS error ")[1].split("°")[0])
    assert rms < 0.01, out
