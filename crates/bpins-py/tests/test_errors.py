"""Bad input raises ValueError or TypeError naming the argument and what was
expected; nothing crashes the interpreter."""

import numpy as np
import pytest

import bpins


@pytest.fixture(scope="module")
def compass():
    return bpins.Compass(64, 48, 300.0, black_level_dn=10.0)


def sun():
    return dict(sun_azimuth_deg=40.0, sun_elevation_deg=25.0)


def test_wrong_arrays(compass):
    with pytest.raises(ValueError, match=r"mosaic: a 3-D array of shape \[48, 64, 3\]; expected a 2-D mosaic"):
        compass.heading(np.zeros((48, 64, 3), np.uint16), **sun())
    with pytest.raises(TypeError, match="mosaic: dtype float64; expected uint8, uint16 or float32"):
        compass.heading(np.zeros((48, 64)), **sun())
    with pytest.raises(TypeError, match="mosaic: expected a 2-D numpy array"):
        compass.heading([[1, 2], [3, 4]], **sun())
    with pytest.raises(ValueError, match=r"mosaic: shape \(40, 64\); expected the sensor's .* = \(48, 64\)"):
        compass.heading(np.zeros((40, 64), np.uint16), **sun())


def test_bad_sun_and_attitude(compass):
    m = np.full((48, 64), 100, np.uint16)
    with pytest.raises(ValueError, match="sun_elevation_deg = NaN: expected a finite number"):
        compass.heading(m, sun_azimuth_deg=40.0, sun_elevation_deg=float("nan"))
    with pytest.raises(ValueError, match="the sun: give sun_azimuth_deg and sun_elevation_deg"):
        compass.heading(m, sun_azimuth_deg=40.0)
    with pytest.raises(ValueError, match="tilt_sigma_deg = -1: expected a 1σ ≥ 0"):
        compass.heading(m, tilt_sigma_deg=-1.0, **sun())
    with pytest.raises(TypeError, match="time_utc"):
        compass.heading(m, time_utc="noon", latitude_deg=1.0, longitude_deg=2.0)


def test_bad_configurations():
    with pytest.raises(ValueError, match="projection = \"fisheye\": expected one of pinhole"):
        bpins.Compass(64, 48, 300.0, projection="fisheye")
    with pytest.raises(ValueError, match="focal_length_px = inf"):
        bpins.Compass(64, 48, float("inf"))
    with pytest.raises(ValueError, match="mosaic: analyzer angle 30"):
        bpins.Compass(64, 48, 300.0, mosaic=((0, 30), (90, 135)))
    with pytest.raises(ValueError, match="bit depth 20"):
        bpins.Compass(64, 48, 300.0, bit_depth=20)
    with pytest.raises(OSError, match="calibration: .*no_such.toml"):
        bpins.Compass(64, 48, 300.0, calibration="no_such.toml")
    with pytest.raises(ValueError, match="effects\\[\"flux\"\\]"):
        bpins.simulate(64, 48, effects={"flux": {"x": 1.0}})
    with pytest.raises(ValueError, match="pixel_pitch_um = 1e9 is outside its range"):
        bpins.simulate(64, 48, pixel_pitch_um=1e9)


def test_a_frame_without_a_heading_is_a_result_not_an_exception(compass):
    # A black frame: no sky to read.
    h = compass.heading(np.zeros((48, 64), np.uint16), **sun())
    assert h.heading_deg is None and h.sigma_deg is None and h.reason
    assert "Heading(None" in repr(h)
