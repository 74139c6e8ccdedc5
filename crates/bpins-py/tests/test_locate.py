"""locate from Python (issue 33): the same answer as `bpins locate`, the site file
it writes serving the Compass in place of a GNSS position, and "not yet" raised."""

import datetime
import json
import subprocess

import pytest

import bpins

SERIES = [
    "--width-px", "306", "--height-px", "256", "--pixel-pitch-um", "27.6",
    "--time-utc", "2026-06-21T01:00:00Z", "--latitude-deg", "36.07", "--longitude-deg", "120.38",
    "--headings-deg", "30",
]


@pytest.fixture(scope="module")
def series(cli, tmp_path_factory):
    out = tmp_path_factory.mktemp("locate") / "series"
    subprocess.run([cli, "simulate", "--out", str(out), "--every-min", "5", "--span-min", "60", *SERIES],
                   check=True, capture_output=True)
    return out


def test_locate_gives_the_cli_answer_and_a_site_the_compass_takes(series, cli, tmp_path):
    site = tmp_path / "site.toml"
    got = bpins.locate(series, site_out=site)
    js = tmp_path / "locate.json"
    subprocess.run([cli, "locate", str(series), "--json", str(js)], check=True, capture_output=True)
    want = json.loads(js.read_text())["located"]
    for key in ["heading_deg", "latitude_deg", "longitude_deg", "heading_sigma_deg"]:
        assert got[key] == pytest.approx(want[key], abs=1e-9), key
    assert (got["route"], got["frames_used"]) == (want["route"], want["frames_used"]) == ("stamped", 13)
    assert abs(got["latitude_deg"] - 36.07) < 2 * got["latitude_sigma_deg"] + 1e-3
    assert len(got["frames"]) == 13 and "bearing_deg" in got["frames"][0]["sun"]
    # The last frame read with the site in place of a GNSS fix: the camera faces 30°.
    _, frames = bpins.read_capture(series)
    c = bpins.Compass(306, 256, 8000.0 / 27.6, bit_depth=12, black_level_dn=64.0)
    t = datetime.datetime(2026, 6, 21, 2, 0, tzinfo=datetime.timezone.utc)
    h = c.heading(frames[-1], time_utc=t, site=site)
    assert abs(h.heading_deg - 30.0) < max(3 * h.sigma_deg, 0.05)
    with pytest.raises(ValueError, match="site"):
        c.heading(frames[-1], time_utc=t, site=site, latitude_deg=36.0)


def test_a_span_too_short_for_the_bounds_raises_not_yet(series):
    with pytest.raises(ValueError, match="not yet"):
        bpins.locate(series, max_longitude_sigma_deg=1e-4)
