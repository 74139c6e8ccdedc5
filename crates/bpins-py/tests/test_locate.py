"""locate from Python (issue 33): the same answer as `bpins locate`, the site file
it writes serving the Compass in place of a GNSS position (its sky's source by the
readers' rule: the moon at night, a mixed twilight read with both sources, a dark
night refused), and
"not yet" raised."""

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
    assert h.source == "sun" and h.sun_share > 0.99, h
    with pytest.raises(ValueError, match="site"):
        c.heading(frames[-1], time_utc=t, site=site, latitude_deg=36.0)


def site_file(path, latitude_deg, longitude_deg):
    path.write_text(f"""format = "bpins-site/1"
route = "stamped"
latitude_deg = {latitude_deg}
latitude_sigma_deg = 0.01
longitude_deg = {longitude_deg}
longitude_sigma_deg = 0.01
heading_deg = 0.0
heading_sigma_deg = 0.1
""")
    return path


def test_a_site_reads_the_moon_at_night_and_a_mixed_twilight_with_both_sources_and_refuses_a_dark_night(moonlit_capture, tmp_path):
    # The site path reads the source by the rule `time_utc=` with a place does (issue
    # 48): the full moon at 41.6° from 20° N 120.38° E at 2026-06-29T16:00:00Z
    # (docs/night.md), rendered by `bpins simulate` and read with the site in place of
    # the place, is the moon's sky, within 2σ.
    out = moonlit_capture
    meta, mosaics = bpins.read_capture(out)
    c = bpins.Compass.from_capture(out)
    utc = datetime.timezone.utc
    h = c.heading(mosaics[0], time_utc=datetime.datetime(2026, 6, 29, 16, 0, tzinfo=utc),
                  site=site_file(tmp_path / "tropic.toml", 20.0, 120.38))
    assert h.reason is None, h.reason
    assert h.source == "moon" and h.moon_share > 0.99 and abs(h.sun_share + h.moon_share - 1.0) < 1e-12, h
    err = (h.heading_deg - meta["frames"][0]["heading_deg"] + 180.0) % 360.0 - 180.0
    assert abs(err) < 2.0 * h.sigma_deg, (h, err)
    assert h.sigma_parts_deg["sun_deg"] > 0.005  # the site's 0.01° place ⊕ the ephemeris's 0.005°
    # From Qingdao: the sun at −12.4° and a 75 % moon give half the light each (a
    # mixed twilight: read with both sources, not refused; this frame is the tropic's
    # moonlit one, so only the road is asked of it), and a day after the new moon no
    # source lights the midnight sky.
    qingdao = site_file(tmp_path / "qingdao.toml", 36.07, 120.38)
    m = c.heading(mosaics[0], time_utc=datetime.datetime(2026, 6, 24, 12, 30, tzinfo=utc), site=qingdao)
    assert "no single source" not in (m.reason or ""), m
    assert m.source == "sun" and 0.4 < m.sun_share < 0.6 and 0.4 < m.moon_share < 0.6, m
    d = c.heading(mosaics[0], time_utc=datetime.datetime(2026, 7, 14, 16, 0, tzinfo=utc), site=qingdao)
    assert d.heading_deg is None and d.source == "sun", d
    assert d.reason.startswith("not yet: the moon is at"), d.reason


def test_a_span_too_short_for_the_bounds_raises_not_yet(series):
    with pytest.raises(ValueError, match="not yet"):
        bpins.locate(series, max_longitude_sigma_deg=1e-4)
