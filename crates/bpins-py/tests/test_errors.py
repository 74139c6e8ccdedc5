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


def test_whole_number_arguments_are_named_when_negative():
    # Not PyO3's nameless "OverflowError: can't convert negative int to unsigned".
    with pytest.raises(ValueError, match="width_px = -5: expected a whole number ≥ 0"):
        bpins.Compass(-5, 48, 300.0)
    with pytest.raises(ValueError, match="bit_depth = -1: expected a whole number ≥ 0"):
        bpins.Compass(64, 48, 300.0, bit_depth=-1)
    with pytest.raises(ValueError, match="height_px = -2: expected a whole number ≥ 0"):
        bpins.simulate(64, -2)
    with pytest.raises(ValueError, match="seed = -1"):
        bpins.simulate(64, 48, seed=-1)


def test_missing_files_are_os_errors_saying_so(tmp_path, samples):
    # The README promises OSError for a file that cannot be read.
    with pytest.raises(FileNotFoundError, match="capture.toml: not found"):
        bpins.read_capture(tmp_path / "no-capture-here")
    with pytest.raises(OSError, match="not found"):
        bpins.Compass.from_capture(tmp_path / "no-capture-here")
    with pytest.raises(FileNotFoundError, match="calibration: .*no_such.toml: No such file or directory"):
        bpins.Compass(64, 48, 300.0, calibration=str(tmp_path / "no_such.toml"))
    with pytest.raises(ValueError, match=r"frames\[…\] = -1"):
        bpins.read_capture(samples / "clean", frames=[-1])


def test_bad_sun_and_attitude_name_the_range(compass):
    m = np.full((48, 64), 100, np.uint16)
    with pytest.raises(ValueError, match=r"sun: elevation 95° is outside \[−90, 90\]°"):
        compass.heading(m, sun_azimuth_deg=40.0, sun_elevation_deg=95.0)
    with pytest.raises(ValueError, match=r"attitude: tilt about x 95° is outside \(−90, 90\)°"):
        compass.heading(m, tilt_x_deg=95.0, **sun())
    with pytest.raises(ValueError, match="focal length -5 px must be a finite number > 0"):
        bpins.Compass(64, 48, -5.0)
