"""Capture folders to and from arrays, and the catalog as data."""

import numpy as np
import pytest

import bpins


def test_read_then_write_a_capture_round_trips(samples, tmp_path):
    meta, mosaics = bpins.read_capture(samples / "clean")
    assert meta["format"] == "bpins-capture/1" and meta["sensor"]["width_px"] == 612
    assert mosaics[0].shape == (512, 612) and mosaics[0].dtype == np.float32
    out = tmp_path / "copy"
    bpins.write_capture(out, meta, [m.astype(np.uint16) for m in mosaics])
    meta2, mosaics2 = bpins.read_capture(out)
    assert meta2 == meta
    for a, b in zip(mosaics, mosaics2):
        np.testing.assert_array_equal(a, b)
    # Never into an existing capture.
    with pytest.raises(ValueError, match="already exists"):
        bpins.write_capture(out, meta, [m.astype(np.uint16) for m in mosaics])


def test_a_simulated_frame_becomes_a_capture(tmp_path):
    sim = bpins.simulate(heading_deg=10.0)
    meta = {
        "format": "bpins-capture/1",
        "sensor": {"layout": "dofp", "width_px": 612, "height_px": 512, "pixel_pitch_um": 13.8, "bit_depth": 12,
                   "black_level_dn": 64.0},
        "lens": {"projection": "pinhole", "focal_length_mm": 8.0},
        "frames": [{"file": "frames/f000.png", "sun_azimuth_deg": 40.0, "sun_elevation_deg": 25.0,
                    "heading_deg": 10.0}],
    }
    bpins.write_capture(tmp_path / "sim", meta, [sim["mosaic"]])
    back, frames = bpins.read_capture(tmp_path / "sim")
    np.testing.assert_array_equal(frames[0], sim["mosaic"].astype(np.float32))
    bad = dict(meta, lens={"projection": "pinhole", "focal_length_mm": 8.0, "f_number": 2.0})
    with pytest.raises(ValueError, match="f_number"):
        bpins.write_capture(tmp_path / "bad", bad, [sim["mosaic"]])
    with pytest.raises(ValueError, match=r"mosaics: 2 arrays for 1 entries"):
        bpins.write_capture(tmp_path / "bad2", meta, [sim["mosaic"], sim["mosaic"]])


def test_simulate_gives_truth_maps_that_match_the_reconstruction():
    sim = bpins.simulate(heading_deg=0.0, read_noise_dn=0.0, system_gain_dn_per_e=0.0)
    assert sim["mosaic"].dtype == np.uint16 and sim["aop_deg"].shape == (512, 612)
    maps = bpins.stokes_maps(sim["mosaic"], black_level_dn=64.0)
    inner = (slice(8, -8), slice(8, -8))
    d = (maps["aop_deg"][inner] - sim["aop_deg"][inner] + 90.0) % 180.0 - 90.0
    # Demosaicing a noise-free, quantised frame: the AoP follows the truth to a
    # fraction of a degree where the sky is polarized.
    strong = sim["dolp"][inner] > 0.2
    assert np.sqrt(np.mean(d[strong] ** 2)) < 0.5


def test_the_catalog_as_data():
    cat = bpins.effects()
    names = [e["name"] for e in cat]
    assert "analyzer_angles" in names and "crosstalk" in names
    for e in cat:
        for p in e["params"]:
            assert p["min"] <= p["neutral"] <= p["max"] and p["unit"]
