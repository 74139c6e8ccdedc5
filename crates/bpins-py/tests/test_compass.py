"""The front door from Python: the same headings as the CLI and the Rust library,
in-place reading of strided arrays, the sun from a datetime, and the GIL released."""

import datetime
import json
import subprocess
import threading

import numpy as np
import pytest

import bpins


def frame_kwargs(f):
    return dict(
        sun_azimuth_deg=f["sun_azimuth_deg"],
        sun_elevation_deg=f["sun_elevation_deg"],
        tilt_x_deg=f.get("tilt_x_deg", 0.0),
        tilt_y_deg=f.get("tilt_y_deg", 0.0),
        tilt_sigma_deg=f.get("tilt_sigma_deg", 0.0),
        sun_sigma_deg=f.get("sun_sigma_deg", 0.0),
    )


def test_clean_sample_headings_equal_the_cli(samples, cli, tmp_path):
    cap = samples / "clean"
    out = tmp_path / "h.json"
    subprocess.run([cli, "heading", str(cap), "--extractor", "sun_vector", "--json", str(out)], check=True,
                   capture_output=True)
    want = [f for f in json.loads(out.read_text())["frames"] if f["extractor"] == "sun_vector"]
    meta, mosaics = bpins.read_capture(cap)
    compass = bpins.Compass.from_capture(cap)
    assert len(want) == len(mosaics) == len(meta["frames"]) == 8
    for f, m, w in zip(meta["frames"], mosaics, want):
        h = compass.heading(m.astype(np.uint16), **frame_kwargs(f))
        assert h.reason is None, h.reason
        assert abs(h.heading_deg - w["heading_deg"]) < 1e-9, (h, w)
        assert abs(h.sigma_deg - w["sigma_deg"]) < 1e-9
        err = (h.heading_deg - f["heading_deg"] + 180.0) % 360.0 - 180.0
        assert abs(err) < 3.0 * h.sigma_deg
        assert 0.5 < h.used_fraction <= 1.0 and h.zero_copy


def test_uint8_float32_and_strided_views_read_the_same():
    sim = bpins.simulate(heading_deg=30.0, seed=3)
    m16 = sim["mosaic"]
    c = bpins.Compass(612, 512, sim["focal_length_px"], bit_depth=12, black_level_dn=64.0)
    ref = c.heading(m16, sun_azimuth_deg=40.0, sun_elevation_deg=25.0)
    # float32 holds the same DN: the same heading to rounding.
    f = c.heading(m16.astype(np.float32), sun_azimuth_deg=40.0, sun_elevation_deg=25.0)
    assert abs(f.heading_deg - ref.heading_deg) < 1e-9
    # A crop of a larger buffer (row stride 700 px): read in place, the same heading.
    big = np.zeros((512, 700), dtype=np.uint16)
    big[:, :612] = m16
    view = big[:, :612]
    assert not view.flags["C_CONTIGUOUS"]
    v = c.heading(view, sun_azimuth_deg=40.0, sun_elevation_deg=25.0)
    assert v.zero_copy and v.heading_deg == ref.heading_deg
    # Columns not adjacent: copied, still the same.
    wide = np.zeros((512, 1224), dtype=np.uint16)
    wide[:, ::2] = m16
    w = c.heading(wide[:, ::2], sun_azimuth_deg=40.0, sun_elevation_deg=25.0)
    assert not w.zero_copy and w.heading_deg == ref.heading_deg
    # An 8-bit camera: DN scaled to 8 bits, a heading within its 1σ of the truth.
    c8 = bpins.Compass(612, 512, sim["focal_length_px"], bit_depth=8, black_level_dn=4.0)
    m8 = np.clip(np.round(m16 / 16.0), 0, 255).astype(np.uint8)
    h8 = c8.heading(m8, sun_azimuth_deg=40.0, sun_elevation_deg=25.0)
    assert abs((h8.heading_deg - 30.0 + 180) % 360 - 180) < 3 * h8.sigma_deg


def test_simulate_then_heading_round_trip_with_tilt():
    sim = bpins.simulate(heading_deg=250.0, tilt_x_deg=4.0, tilt_y_deg=-3.0, seed=5, sun_elevation_deg=35.0)
    c = bpins.Compass(612, 512, sim["focal_length_px"], black_level_dn=64.0, extractor="meridian_line")
    h = c.heading(sim["mosaic"], sun_azimuth_deg=40.0, sun_elevation_deg=35.0, tilt_x_deg=4.0, tilt_y_deg=-3.0)
    assert h.extractor == "meridian_line"
    assert abs((h.heading_deg - 250.0 + 180) % 360 - 180) < 3 * h.sigma_deg
    assert set(h.sigma_parts_deg) == {"fit_deg", "jackknife_deg", "coherent_deg", "misfit_deg", "cross_deg", "tilt_deg", "sun_deg", "floor_deg"}


def test_sun_from_a_datetime_equals_the_sun_from_its_angles(samples):
    # The sun at a time and place (NREL SPA) gives the same heading as that sun's angles.
    t = datetime.datetime(2026, 6, 21, 9, 0, tzinfo=datetime.timezone.utc)
    meta, mosaics = bpins.read_capture(samples / "clean", frames=[0])
    c = bpins.Compass.from_capture(samples / "clean")
    by_time = c.heading(mosaics[0], time_utc=t, latitude_deg=36.07, longitude_deg=120.38)
    assert by_time.reason is None or "sun" in by_time.reason
    with pytest.raises(ValueError, match="timezone"):
        c.heading(mosaics[0], time_utc=datetime.datetime(2026, 6, 21, 9, 0), latitude_deg=36.07, longitude_deg=120.38)


def test_a_moonlit_frame_read_from_its_clock_names_the_moon_and_a_dark_night_is_refused(moonlit_capture):
    # `bpins simulate` renders the sky of 2026-06-29T16:00:00Z at 20° N 120.38° E: the
    # full moon at 41.6° (docs/night.md). Read from the same clock and place, the
    # compass takes the moon, says so, and reads the heading within 2σ.
    out = moonlit_capture
    meta, mosaics = bpins.read_capture(out)
    c = bpins.Compass.from_capture(out)
    t = datetime.datetime(2026, 6, 29, 16, 0, tzinfo=datetime.timezone.utc)
    h = c.heading(mosaics[0], time_utc=t, latitude_deg=20.0, longitude_deg=120.38)
    assert h.reason is None, h.reason
    assert h.source == "moon" and h.moon_share > 0.99 and abs(h.sun_share + h.moon_share - 1.0) < 1e-12, h
    err = (h.heading_deg - meta["frames"][0]["heading_deg"] + 180.0) % 360.0 - 180.0
    assert abs(err) < 2.0 * h.sigma_deg, (h, err)
    assert h.sigma_parts_deg["sun_deg"] > 0.0  # the moon ephemeris's 0.005°, propagated
    # Given angles: the caller's source.
    g = c.heading(mosaics[0], sun_azimuth_deg=40.0, sun_elevation_deg=25.0)
    assert g.source == "given" and g.sun_share is None
    # Midnight at Qingdao a day after the new moon: no source lights the sky.
    dark = datetime.datetime(2026, 7, 14, 16, 0, tzinfo=datetime.timezone.utc)
    d = c.heading(mosaics[0], time_utc=dark, latitude_deg=36.07, longitude_deg=120.38)
    assert d.heading_deg is None and d.source == "sun", d
    assert d.reason.startswith("not yet: the moon is at"), d.reason


def test_a_mixed_twilight_reports_the_share_it_fitted_and_one_source_none(cli, tmp_path):
    # The sun at −12.4° and a 75 % moon at 35.5° give half the light each from Qingdao
    # at 2026-06-24T12:30:00Z (docs/night.md, "Twilight"): rendered with both skies and
    # read from the same clock and place with both sources. The sun's share of the
    # polarized radiance the fit found is near the one rendered (each sky's zenith
    # light over Rayleigh's zenith radiance ½(1 + sin²h) about its body), with its 1σ;
    # given angles (one source) have none.
    cap = tmp_path / "mixed"
    subprocess.run([cli, "simulate", "--out", str(cap), "--time-utc", "2026-06-24T12:30:00Z", "--latitude-deg",
                    "36.07", "--longitude-deg", "120.38", "--width-px", "128", "--height-px", "128",
                    "--pixel-pitch-um", "27.6", "--headings-deg", "20", "--scene", "twilight"],
                   check=True, capture_output=True)
    meta, mosaics = bpins.read_capture(cap)
    c = bpins.Compass.from_capture(cap)
    t = datetime.datetime(2026, 6, 24, 12, 30, tzinfo=datetime.timezone.utc)
    h = c.heading(mosaics[0], time_utc=t, latitude_deg=36.07, longitude_deg=120.38)
    assert h.reason is None, h.reason
    err = (h.heading_deg - meta["frames"][0]["heading_deg"] + 180.0) % 360.0 - 180.0
    assert abs(err) < 3.0 * h.sigma_deg, (h, err)
    u_sun = h.sun_share / (1.0 + np.sin(np.radians(-12.4)) ** 2)
    u_moon = h.moon_share / (1.0 + np.sin(np.radians(35.5)) ** 2)
    rendered = u_sun / (u_sun + u_moon)
    assert abs(h.fitted_sun_share - rendered) < 0.01, (h.fitted_sun_share, rendered)
    assert 0.0 < h.fitted_sun_share_sigma < 0.05, h.fitted_sun_share_sigma
    g = c.heading(mosaics[0], sun_azimuth_deg=40.0, sun_elevation_deg=25.0)
    assert g.fitted_sun_share is None and g.fitted_sun_share_sigma is None


def test_the_gil_is_released_while_a_compass_works():
    sim = bpins.simulate(width_px=1224, height_px=1024, seed=2)
    compasses = [bpins.Compass(1224, 1024, sim["focal_length_px"], black_level_dn=64.0) for _ in range(2)]
    ticks = []
    done = threading.Event()

    def ticker():
        while not done.is_set():
            ticks.append(1)
            done.wait(0.001)

    t = threading.Thread(target=ticker)
    t.start()
    results = []

    def work(c):
        for _ in range(5):
            results.append(c.heading(sim["mosaic"], sun_azimuth_deg=40.0, sun_elevation_deg=25.0).heading_deg)

    workers = [threading.Thread(target=work, args=(c,)) for c in compasses]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    done.set()
    t.join()
    assert len(results) == 10 and len(set(results)) == 1
    # The ticker ran while the compasses worked: the GIL was not held throughout.
    assert len(ticks) > 10


def test_a_sky_that_contradicts_the_claimed_sun_or_layout_is_refused_with_the_reason():
    # The sky's sun stands at 25°; a wrong clock claims −5° (it used to read 210.001° ± 0.016°
    # for a truth of 30°), and a mosaic read upside down (it used to read 183.5° ± 1.7°).
    sim = bpins.simulate(heading_deg=30.0, seed=5)
    m = sim["mosaic"]
    c = bpins.Compass(612, 512, sim["focal_length_px"], bit_depth=12, black_level_dn=64.0)
    good = c.heading(m, sun_azimuth_deg=40.0, sun_elevation_deg=25.0)
    assert good.reason is None and abs((good.heading_deg - 30.0 + 180.0) % 360.0 - 180.0) < 2 * good.sigma_deg
    assert 0.0 <= good.cloud_fraction < 0.05
    wrong_sun = c.heading(m, sun_azimuth_deg=40.0, sun_elevation_deg=-5.0)
    assert wrong_sun.heading_deg is None and "contradicts" in wrong_sun.reason, wrong_sun
    flipped = c.heading(np.ascontiguousarray(m[::-1]), sun_azimuth_deg=40.0, sun_elevation_deg=25.0)
    if flipped.heading_deg is not None:
        err = (flipped.heading_deg - 30.0 + 180.0) % 360.0 - 180.0
        assert abs(err) <= 2 * flipped.sigma_deg, flipped
    else:
        assert flipped.reason, flipped


def test_threads_sharing_one_compass_read_what_one_thread_reads():
    # One compass, four threads, frames of two headings interleaved: each result is
    # the one a lone call gives (the compass reads one frame at a time), no
    # "Already borrowed".
    sims = [bpins.simulate(width_px=306, height_px=256, heading_deg=h, seed=3) for h in (30.0, 200.0)]
    c = bpins.Compass(306, 256, sims[0]["focal_length_px"], black_level_dn=64.0)
    alone = [c.heading(s["mosaic"], sun_azimuth_deg=40.0, sun_elevation_deg=25.0).heading_deg for s in sims]
    results, errors = [], []

    def work(k):
        try:
            for i in range(6):
                s = (k + i) % 2
                h = c.heading(sims[s]["mosaic"], sun_azimuth_deg=40.0, sun_elevation_deg=25.0)
                results.append((s, h.heading_deg))
        except Exception as e:  # noqa: BLE001 - the test reports any exception
            errors.append(repr(e))

    workers = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    assert errors == []
    assert len(results) == 24
    assert all(h == alone[s] for s, h in results), (alone, results)


def test_a_colour_capture_reads_band_by_band_as_the_cli(samples, cli, tmp_path):
    """Issue 45: each band's heading from its own pixels and the fused one, the same
    numbers as `bpins heading` on the colour sample; `heading` is the fused one."""
    cap = samples / "colour-clear"
    out = tmp_path / "c.json"
    subprocess.run([cli, "heading", str(cap), "--json", str(out)], check=True, capture_output=True)
    rows = json.loads(out.read_text())["frames"]
    meta, mosaics = bpins.read_capture(cap)
    compass = bpins.Compass.from_capture(cap)
    for f, m in zip(meta["frames"], mosaics):
        bands = compass.band_headings(m.astype(np.uint16), **frame_kwargs(f))
        assert sorted(bands) == ["B", "G", "R", "fused"]
        want = {r["band"]: r for r in rows if r["file"] == f["file"] and r["extractor"] == "sun_vector"}
        for b, h in bands.items():
            assert abs(h.heading_deg - want[b]["heading_deg"]) < 1e-9, (b, h, want[b])
            assert abs(h.sigma_deg - want[b]["sigma_deg"]) < 1e-9
        assert compass.heading(m.astype(np.uint16), **frame_kwargs(f)).heading_deg == bands["fused"].heading_deg
    # The same sensor described by hand.
    s = meta["sensor"]
    by_hand = bpins.Compass(s["width_px"], s["height_px"], meta["lens"]["focal_length_mm"] * 1000.0 / s["pixel_pitch_um"],
                            bit_depth=s["bit_depth"], black_level_dn=s["black_level_dn"], mosaic=s["mosaic"],
                            colour_tiles=s["colour_tiles"])
    f, m = meta["frames"][0], mosaics[0]
    assert by_hand.band_headings(m.astype(np.uint16), **frame_kwargs(f))["G"].heading_deg == pytest.approx(
        compass.band_headings(m.astype(np.uint16), **frame_kwargs(f))["G"].heading_deg, abs=1e-9)
    with pytest.raises(ValueError, match="colour"):
        bpins.Compass.from_capture(samples / "clean").band_headings(np.zeros((512, 612), np.uint16),
                                                                   **frame_kwargs(f))
    with pytest.raises(ValueError, match="colour_tiles"):
        bpins.Compass(64, 64, 100.0, colour_tiles=[["R", "G"], ["G", "X"]])
