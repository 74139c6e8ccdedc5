"""Agreement with polanalyser on colour-polarization mosaics (Sony IMX250MYR), per
band, pixel by pixel.

The conversion is the mono one (test_polanalyser.py): the same analyzer mosaic
[[90, 45], [135, 0]], the same angle sense, polanalyser's AoLP in [0°, 180°) is bpins'
α modulo 180°. Both read the raw DN (no black level subtracted: bpins' default 0). polanalyser's `COLOR_PolarRGB` returns BGR images, so its band R is
channel 2, G channel 1, B channel 0; bpins' colour tiles are [["R", "G"], ["G", "B"]].

* `interpolation="opencv"` is polanalyser's two-stage demosaic (each analyzer's plane
  Bayer-demosaiced with OpenCV's BayerBG bilinear, then each colour's mosaic
  polarization-demosaiced, every average rounded to a whole DN): every pixel of
  every band agrees, border included, to float32 rounding of the angles.
* `interpolation="opencv_ea"` is polanalyser's `COLOR_PolarRGB_EA`: the same two
  stages through OpenCV's edge-aware Bayer demosaic (green between its sites from the
  pair of neighbours that differs less), every pixel agreeing as closely; it differs
  from "opencv" in G only.
* the default `"bilinear"` is the same two stages with the averages unrounded (and
  invalid samples NaN): it differs by that rounding, ≤ 1 DN per channel, a median of
  0.01°–0.02° AoP on the 12-bit colour sample.
* `"superpixel"` interpolates nothing: each band's Stokes vector from its own 4 or 8
  samples in each 4 × 4 superpixel; it is not compared pixel by pixel, only its
  band order (the R-only test below).
"""

import numpy as np
import pytest

import bpins

pa = pytest.importorskip("polanalyser")

IMX250MYR = (("R", "G"), ("G", "B"))
BGR = {"R": 2, "G": 1, "B": 0}


def polanalyser_colour_maps(raw, code=None):
    """polanalyser's per-band AoP (wrapped to (−90°, 90°]), DoLP and S0 (`code`:
    `COLOR_PolarRGB` unless given)."""
    imgs = [x.astype(np.float64) for x in pa.demosaicing(raw, code or pa.COLOR_PolarRGB)]
    stokes = pa.calcLinearStokes(imgs, np.deg2rad([0, 45, 90, 135]))  # (h, w, 3 colours, 3)
    aolp_deg = np.rad2deg(pa.cvtStokesToAoLP(stokes))
    maps = {}
    for band, c in BGR.items():
        maps[band] = (wrap90(aolp_deg[..., c]), pa.cvtStokesToDoLP(stokes)[..., c], stokes[..., c, 0])
    return maps


def wrap90(d):
    return (d + 90.0) % 180.0 - 90.0


def colour_frame(samples, k=0):
    _, frames = bpins.read_capture(samples / "colour-clear", frames=[k])
    raw = frames[0]
    assert np.all(raw == np.round(raw))
    return raw.astype(np.uint16)


@pytest.mark.parametrize("dtype", [np.uint16, np.uint8])
def test_opencv_colour_maps_are_polanalysers_colour_demosaic_at_every_pixel(samples, dtype):
    raw = colour_frame(samples)
    if dtype == np.uint8:
        raw = (raw >> 4).astype(np.uint8)  # OpenCV's 8-bit path, the 12-bit frame's top bits
    theirs = polanalyser_colour_maps(raw)
    ours = bpins.stokes_maps(raw, colour_tiles=IMX250MYR, interpolation="opencv")
    assert set(ours) == {"R", "G", "B"}
    for band, (aop_pa, dolp_pa, i_pa) in theirs.items():
        m = ours[band]
        assert m["aop_deg"].shape == raw.shape
        polarized = dolp_pa > 0.02
        assert polarized.mean() > 0.5, band
        # Measured: ≤ 6e-6° and ≤ 6e-8, S0 identical (the same whole-DN channels).
        assert np.max(np.abs(wrap90(aop_pa - m["aop_deg"]))[polarized]) < 1e-4, band
        assert np.max(np.abs(dolp_pa - m["dolp"])) < 1e-6, band
        assert np.max(np.abs(i_pa - m["intensity_dn"]) / np.maximum(i_pa, 1.0)) < 1e-6, band


@pytest.mark.parametrize("dtype", [np.uint16, np.uint8])
def test_opencv_ea_colour_maps_are_polanalysers_edge_aware_colour_demosaic_at_every_pixel(samples, dtype):
    raw = colour_frame(samples)
    if dtype == np.uint8:
        raw = (raw >> 4).astype(np.uint8)
    theirs = polanalyser_colour_maps(raw, pa.COLOR_PolarRGB_EA)
    ours = bpins.stokes_maps(raw, colour_tiles=IMX250MYR, interpolation="opencv_ea")
    bilinear_ocv = bpins.stokes_maps(raw, colour_tiles=IMX250MYR, interpolation="opencv")
    for band, (aop_pa, dolp_pa, i_pa) in theirs.items():
        m = ours[band]
        polarized = dolp_pa > 0.02
        assert polarized.mean() > 0.5, band
        assert np.max(np.abs(wrap90(aop_pa - m["aop_deg"]))[polarized]) < 1e-4, band
        assert np.max(np.abs(dolp_pa - m["dolp"])) < 1e-6, band
        # Measured: ≤ 6e-6° and ≤ 6e-8; S0 identical (half the sum of whole-DN channels).
        np.testing.assert_array_equal(m["intensity_dn"], i_pa.astype(np.float32), err_msg=band)
        # Only G is edge-aware (R and B are OpenCV's bilinear ones in both demosaics).
        same = np.array_equal(m["intensity_dn"], bilinear_ocv[band]["intensity_dn"])
        assert same == (band != "G"), band


def test_colour_bilinear_differs_from_polanalyser_by_its_rounding(samples):
    # The same two stages unrounded: each stage-2 channel ≤ ~1 DN off, so on this
    # 12-bit frame AoP differs by hundredths of a degree (median), never by a band swap.
    raw = colour_frame(samples)
    theirs = polanalyser_colour_maps(raw)
    ours = bpins.stokes_maps(raw, colour_tiles=IMX250MYR)
    for band, (aop_pa, dolp_pa, _) in theirs.items():
        d = np.abs(wrap90(aop_pa - ours[band]["aop_deg"]))[dolp_pa > 0.02]
        assert 1e-4 < np.median(d) < 0.05 and d.max() < 0.5, (band, np.median(d), d.max())


def test_a_polarized_red_tile_shows_in_the_red_band_only_in_both():
    # Pins the tile order: only pixels under R (tile row 0, column 0 of each 4 × 4
    # superpixel) see polarized light (DoLP 0.5, AoP 30°); G and B see unpolarized light.
    h, w = 64, 80
    v, u = np.mgrid[0:h, 0:w]
    theta = np.deg2rad(np.array([[90, 45], [135, 0]])[v % 2, u % 2])
    red = ((v // 2) % 2 == 0) & ((u // 2) % 2 == 0)
    dolp = np.where(red, 0.5, 0.0)
    raw = np.round(0.5 * 2000.0 * (1.0 + dolp * np.cos(2.0 * (theta - np.deg2rad(30.0))))).astype(np.uint16)
    theirs = polanalyser_colour_maps(raw)
    inner = (slice(4, -4), slice(4, -4))
    for route in ("opencv", "superpixel", "bilinear"):
        ours = bpins.stokes_maps(raw, colour_tiles=IMX250MYR, interpolation=route)
        assert np.median(ours["R"]["dolp"]) == pytest.approx(0.5, abs=2e-3), route
        assert np.median(np.abs(wrap90(ours["R"]["aop_deg"] - 30.0))) < 0.1, route
        for band in ("G", "B"):
            assert np.max(ours[band]["dolp"]) < 2e-3, (route, band)
    for band, (_, dolp_pa, _) in theirs.items():
        expected = 0.5 if band == "R" else 0.0
        assert np.median(dolp_pa[inner]) == pytest.approx(expected, abs=2e-3), band


def test_colour_outputs_can_be_reused_and_superpixels_are_a_quarter():
    raw = (np.arange(48 * 64).reshape(48, 64) * 37 % 1500 + 300).astype(np.uint16)
    out = {b: {k: np.empty((48, 64), np.float32) for k in ("aop_deg", "dolp", "intensity_dn")} for b in "RGB"}
    got = bpins.stokes_maps(raw, colour_tiles=IMX250MYR, interpolation="opencv", out=out)
    assert got is out
    fresh = bpins.stokes_maps(raw, colour_tiles=IMX250MYR, interpolation="opencv")
    for b in "RGB":
        np.testing.assert_array_equal(out[b]["dolp"], fresh[b]["dolp"])
    sp = bpins.stokes_maps(raw, colour_tiles=IMX250MYR, interpolation="superpixel", aoe=True)
    assert {k: v.shape for k, v in sp["G"].items()} == {k: (12, 16) for k in ("aop_deg", "dolp", "intensity_dn", "aoe_deg")}
    with pytest.raises(ValueError, match="colour_tiles"):
        bpins.stokes_maps(raw, colour_tiles=(("R", "G"), ("G", "Y")))
