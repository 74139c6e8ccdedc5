"""Agreement with polanalyser (the field's Python package): the same raw IMX250MZR
mosaic through polanalyser's demosaicing and Stokes and through bpins gives the same
AoLP and DoLP after the conversion the README states: same mosaic (polanalyser's
`COLOR_PolarMono` is bpins' default [[90, 45], [135, 0]]), same sign (both count
counter-clockwise as displayed, from image +x toward image −y), and polanalyser's
AoLP in [0°, 180°) is bpins' α in (−90°, 90°] taken modulo 180°."""

import numpy as np
import pytest

import bpins

pa = pytest.importorskip("polanalyser")


@pytest.mark.parametrize("heading_deg", [20.0, 155.0])
def test_aolp_and_dolp_agree_with_polanalyser(heading_deg):
    sim = bpins.simulate(heading_deg=heading_deg, tilt_x_deg=5.0, black_level_dn=0.0, seed=9)
    raw = sim["mosaic"]
    i0, i45, i90, i135 = (x.astype(np.float64) for x in pa.demosaicing(raw, pa.COLOR_PolarMono))
    stokes = pa.calcLinearStokes([i0, i45, i90, i135], np.deg2rad([0, 45, 90, 135]))
    aolp_pa_deg = np.rad2deg(pa.cvtStokesToAoLP(stokes))
    dolp_pa = pa.cvtStokesToDoLP(stokes)
    ours = bpins.stokes_maps(raw, black_level_dn=0.0)
    inner = (slice(8, -8), slice(8, -8))
    # The conversion: α_bpins = AoLP_polanalyser wrapped into (−90°, 90°].
    converted = (aolp_pa_deg + 90.0) % 180.0 - 90.0
    d = (converted[inner] - ours["aop_deg"][inner] + 90.0) % 180.0 - 90.0
    polarized = ours["dolp"][inner] > 0.1
    # Both demosaic bilinearly (OpenCV's Bayer kernels vs bpins' per-channel
    # lattice), so the maps differ by interpolation alone, far below the noise.
    assert np.sqrt(np.mean(d[polarized] ** 2)) < 0.05
    assert np.mean(np.abs(dolp_pa[inner] - ours["dolp"][inner])) < 1e-3
    # A sign or a 90° offset would show as tens of degrees.
    wrong = (-converted[inner] - ours["aop_deg"][inner] + 90.0) % 180.0 - 90.0
    assert np.sqrt(np.mean(wrong[polarized] ** 2)) > 10.0
