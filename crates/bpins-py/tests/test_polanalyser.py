"""Agreement with polanalyser (the field's Python package), stated pixel by pixel.

The conversion: the same mosaic (polanalyser's `COLOR_PolarMono` is bpins' default
[[90, 45], [135, 0]]), the same sign (both count counter-clockwise as displayed, from
image +x toward image −y), and polanalyser's AoLP in [0°, 180°) is bpins' α in
(−90°, 90°] taken modulo 180°. Both compute the Stokes vector the same way (the
pseudo-inverse of the four analyzers is I = ½ΣI_k, Q = I0 − I90, U = I45 − I135).

Where they differ, the demosaic alone is why:

* `interpolation="opencv"` is polanalyser's demosaic (OpenCV's Bayer bilinear): every
  pixel agrees, border included, to float32 rounding (≤ 1e-4°, DoLP ≤ 1e-6).
* `interpolation="opencv_ea"` is polanalyser's `COLOR_PolarMono_EA` (OpenCV's
  edge-aware Bayer demosaic): it keeps the demosaic's blue and red, which the
  edge-aware one computes as the bilinear one does, so it agrees as closely, and
  with "opencv" bit for bit.
* the default `"bilinear"` has the same weights in the interior but keeps the
  averages unrounded, where OpenCV rounds each to a whole DN (half up): the
  difference is that rounding, ≤ 0.5 DN per channel, so AoP differs by about
  0.5 DN / (2·I·DoLP) rad; on the border row and column OpenCV copies the next
  row or column inwards, bpins clamps each channel's own lattice, so they differ
  there by up to the pattern's change over one pixel.
"""

import numpy as np
import pytest

import bpins

pa = pytest.importorskip("polanalyser")


def polanalyser_maps(raw, code=None):
    i0, i45, i90, i135 = (x.astype(np.float64) for x in pa.demosaicing(raw, code or pa.COLOR_PolarMono))
    stokes = pa.calcLinearStokes([i0, i45, i90, i135], np.deg2rad([0, 45, 90, 135]))
    aolp_deg = np.rad2deg(pa.cvtStokesToAoLP(stokes))
    return (aolp_deg + 90.0) % 180.0 - 90.0, pa.cvtStokesToDoLP(stokes), stokes[..., 0]


def wrap90(d):
    return (d + 90.0) % 180.0 - 90.0


@pytest.mark.parametrize("heading_deg", [20.0, 155.0])
def test_opencv_interpolation_is_polanalysers_demosaic_at_every_pixel(heading_deg):
    sim = bpins.simulate(heading_deg=heading_deg, tilt_x_deg=5.0, black_level_dn=0.0, seed=9)
    raw = sim["mosaic"]
    aop_pa, dolp_pa, i_pa = polanalyser_maps(raw)
    ours = bpins.stokes_maps(raw, interpolation="opencv")
    polarized = dolp_pa > 0.01
    assert polarized.mean() > 0.9
    assert np.max(np.abs(wrap90(aop_pa - ours["aop_deg"]))[polarized]) < 1e-4
    assert np.max(np.abs(dolp_pa - ours["dolp"])) < 1e-6
    assert np.max(np.abs(i_pa - ours["intensity_dn"]) / i_pa) < 1e-6


@pytest.mark.parametrize("dtype", [np.uint16, np.uint8])
def test_opencv_ea_interpolation_is_polanalysers_edge_aware_demosaic_at_every_pixel(dtype):
    sim = bpins.simulate(heading_deg=70.0, tilt_x_deg=5.0, black_level_dn=0.0, seed=9)
    raw = sim["mosaic"]
    if dtype == np.uint8:
        raw = (raw >> 4).astype(np.uint8)
    aop_pa, dolp_pa, i_pa = polanalyser_maps(raw, pa.COLOR_PolarMono_EA)
    ours = bpins.stokes_maps(raw, interpolation="opencv_ea")
    polarized = dolp_pa > 0.01
    assert polarized.mean() > 0.9
    assert np.max(np.abs(wrap90(aop_pa - ours["aop_deg"]))[polarized]) < 1e-4
    assert np.max(np.abs(dolp_pa - ours["dolp"])) < 1e-6
    np.testing.assert_array_equal(ours["intensity_dn"], i_pa.astype(np.float32))
    ocv = bpins.stokes_maps(raw, interpolation="opencv")
    for k in ("aop_deg", "dolp", "intensity_dn"):
        np.testing.assert_array_equal(ours[k], ocv[k])


@pytest.mark.parametrize("heading_deg", [20.0, 155.0])
def test_bilinear_differs_from_polanalyser_by_its_rounding_and_its_border(heading_deg):
    sim = bpins.simulate(heading_deg=heading_deg, tilt_x_deg=5.0, black_level_dn=0.0, seed=9)
    raw = sim["mosaic"]
    aop_pa, dolp_pa, i_pa = polanalyser_maps(raw)
    ours = bpins.stokes_maps(raw)
    inner = (slice(1, -1), slice(1, -1))
    d = np.abs(wrap90(aop_pa - ours["aop_deg"]))[inner]
    # The bound from rounding: each channel ≤ 0.5 DN off, so |ΔQ|, |ΔU| ≤ 1 DN and
    # |Δα| ≤ (|ΔQ| + |ΔU|) / (2·√(Q² + U²)) rad = 1 / (I·DoLP) rad.
    bound_deg = np.rad2deg(1.0 / (ours["intensity_dn"] * ours["dolp"]))[inner]
    polarized = ours["dolp"][inner] > 0.05
    assert np.all(d[polarized] <= bound_deg[polarized] * 1.001 + 1e-4)
    # …which on this frame is a median of a few thousandths of a degree.
    assert np.median(d[polarized]) < 0.01
    # A sign or a 90° offset would show as tens of degrees.
    wrong = np.abs(wrap90(-aop_pa - ours["aop_deg"]))[inner]
    assert np.sqrt(np.mean(wrong[polarized] ** 2)) > 10.0

def test_outputs_can_be_reused_and_superpixels_are_half_size():
    sim = bpins.simulate(heading_deg=40.0, black_level_dn=64.0, seed=3)
    raw = sim["mosaic"]
    h, w = raw.shape
    out = {k: np.empty((h, w), np.float32) for k in ("aop_deg", "dolp", "intensity_dn", "aoe_deg")}
    got = bpins.stokes_maps(raw, black_level_dn=64.0, aoe=True, out=out)
    assert got is out
    fresh = bpins.stokes_maps(raw, black_level_dn=64.0, aoe=True)
    for k in out:
        np.testing.assert_array_equal(out[k], fresh[k])
    sp = bpins.stokes_maps(raw, black_level_dn=64.0, interpolation="superpixel")
    assert sp["aop_deg"].shape == (h // 2, w // 2)
    with pytest.raises(ValueError, match="aop_deg"):
        bpins.stokes_maps(raw, out={"aop_deg": np.empty((h, w - 1), np.float32)})
    with pytest.raises(ValueError, match="interpolation"):
        bpins.stokes_maps(raw, interpolation="cubic")
