#!/usr/bin/env python3
"""Render a bpins capture entirely with PySkyLumos's own `Engine` (issue 46, item 3).

What: a DoFP capture (docs/spec/CAPTURE.md) whose lens, sky, micro-polarizer and
sensor chip are all PySkyLumos 0.1.3's (`pyskylumos.engine.Engine`): its thin-lens
optical conjugator maps every pixel to a ray, its pose path turns the rays to the
frame's heading and transports the AoP into the sensor's analyzer frame, its
Rayleigh sky under CIE sky type 12 gives DoLP, AoP and radiance, its
micro-polarizer applies Malus's law per mosaic pixel and its sensor chip exposes,
adds noise and quantizes. This script only chooses the parameters, converts the
conventions at the boundary (below) and writes the raw counts the Engine's Stokes
step receives into 16-bit PNG files. Nothing here calls bpins; nothing of
PySkyLumos is copied (it is imported).

PySkyLumos's conventions (read from its source, engine/Engine.py,
engine/_geometry.py, sensor/OpticalConjugator.py, sensor/MicroPolarizer.py,
sensor/SensorChip.py) and their bpins equivalents (docs/spec/CONVENTIONS.md):

- Pixels: OpticalConjugator puts pixel (row r, column c) at
  x = pitch (c - (W-1)/2), y = pitch ((H-1)/2 - r): centres at integer
  coordinates, principal point at the image centre, row 0 at the top (y up).
  Same as CONVENTIONS "Pixels" with c = ((W-1)/2, (H-1)/2).
- Lens "thin": altitude = 90 deg - atan(|x + iy| / f): the pinhole r = f tan(theta).
- Sensor-local azimuth = arg(x + iy), counter-clockwise as displayed from image
  right: image right is local North, image top local East (from North toward
  East). That is beta of CONVENTIONS "Angles in the image" (the image angle of the
  radial line). For a bpins level camera at heading psi the world azimuth of image
  angle beta is psi - 90 deg + beta (image top = psi, image right = psi - 90 deg,
  the sky from below). So the Engine's pose is a rotation about Up by
  a = psi - 90 deg, `sensor_to_world_rotation_matrix` R with v_world = R v_sensor in
  North-East-Up.
- AoP: PySkyLumos's zenith-centred stereographic chart, angle from the chart's u
  (North) toward v (East); with a pose, Engine transports it into the sensor's
  chart, whose u is image right and v image top: counter-clockwise as displayed
  from image +x, CONVENTIONS's alpha. The chart is conformal and keeps the angle
  to the radial line, which the ideal lens keeps too (p and s), so chart angle =
  image alpha.
- Analyzers: MicroPolarizer's angle map is in the same sensor frame,
  I = 1/2 L (1 + e d cos 2(alpha - theta)), by {angle: SlicingPattern(start_row,
  start_column, 2)}: CONVENTIONS's mosaic [[90, 45], [135, 0]] is
  {90: (0, 0), 45: (0, 1), 135: (1, 0), 0: (1, 1)}. e is the Engine's
  `extinction_ratio` (a DoLP factor, not bpins's ER = 1/epsilon).
- Sensor chip: counts = clip(floor(g S (1 + N(0, 1)/SNR)), 0, 2^bits - 1) with
  g = (2^bits - 1)/(fraction * max S): no black level, multiplicative Gaussian
  noise (not shot and read noise), floor (not rounding): a mean offset of
  -0.5 DN against CONVENTIONS's rounding.

`--check` verifies the mapping without bpins: the Engine's world rays against
CONVENTIONS's pinhole rays through world_from_camera(psi), and its sensor-frame
Rayleigh AoP against an E-vector along sun x view turned into alpha by
CONVENTIONS alone (both to 1e-6 deg).

Usage (Python 3.12-3.14, as PySkyLumos needs):

    python3.12 -m venv /tmp/peer312 && /tmp/peer312/bin/pip install pyskylumos==0.1.3 pillow
    /tmp/peer312/bin/python scripts/peer/render_pyskylumos_engine.py \
        --out tests/data/peer-pyskylumos-engine --seed 46 --check

Variants for sensitivity studies (written to another folder, never committed;
tests/data/peer-pyskylumos-engine/README.md lists what each did): `--lens` (any
Engine conjugation bpins also knows), `--dolp-scale`, `--snr`,
`--polarizer-tolerance-rad`, `--extinction-ratio`, `--saturation-fraction`,
`--sensor`, `--engine-per-frame`, `--sun-from-time` (the Engine's own astropy
sun, the capture giving time and place), and what capture.toml declares with the
rendering unchanged: `--declare-principal-point`, `--declare-black-level`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from PIL import Image

import astropy.units as u
from astropy.coordinates import AltAz, EarthLocation, SkyCoord
from astropy.time import Time

import pyskylumos
from pyskylumos.engine import Engine
from pyskylumos.sensor import SlicingPattern

PYSKYLUMOS_VERSION = "0.1.3"

# Camera (CAPTURE.md keys): the earlier peer capture's 306 x 256 at 27.6 um behind
# 8 mm (+-27.7 deg across, 34.5 deg to a corner).
WIDTH_PX = 306
HEIGHT_PX = 256
PIXEL_PITCH_UM = 27.6
FOCAL_LENGTH_MM = 8.0
BIT_DEPTH = 12
MOSAIC_DEG = ((90, 45), (135, 0))  # analyzer angle by tile (row, column), image frame
# Engine lens names that bpins also has, and bpins's name for each.
LENSES = {"thin": "pinhole", "stereographic": "stereographic", "equi_angle": "equidistant", "equi_solid_angle": "equisolid"}

# Engine parameters (its README's quick start, except where noted).
EXTINCTION_RATIO = 0.99  # Engine's DoLP factor e (README value)
POLARIZER_TOLERANCE_RAD = 0.0  # no random per-pixel analyzer defects (README value)
SATURATION_FRACTION = 1.0  # full scale at the brightest noiseless pixel (README: 0.9, clips a sky region)
# Multiplicative noise SNR: 1/SNR = 0.6 %, about the shot noise of the earlier peer
# capture (K = 0.1 DN/e- at ~2 000 DN).
NOISE_SNR = 170.0
CIE_SKY_TYPE = 12  # CIE Standard Clear Sky, low turbidity
SKY_MODEL = "RAYLEIGH"

# The earlier peer capture's suns (azimuth, elevation), deg: out of view.
SUNS_DEG = ((40.0, 25.0), (130.0, 35.0), (220.0, 45.0), (310.0, 50.0), (75.0, 30.0), (165.0, 40.0), (255.0, 50.0), (345.0, 20.0))

# Any place and time: with an explicit sun position they only build the AltAz frame.
PLACE = EarthLocation(lat=53.4 * u.deg, lon=-2.96 * u.deg, height=50 * u.m)
TIME = Time(["2026-06-21T12:00:00"], scale="utc")
# With --sun-from-time: each frame's UTC time at PLACE (the sun 21-43 deg high, out of view).
SUN_TIMES_UTC = ("2026-06-21T06:30:00", "2026-06-21T07:00:00", "2026-06-21T07:30:00", "2026-06-21T08:30:00", "2026-06-21T15:30:00", "2026-06-21T16:30:00", "2026-06-21T17:00:00", "2026-06-21T17:30:00")


def slicing() -> dict[int, SlicingPattern]:
    """CONVENTIONS's mosaic as the Engine's slicing patterns."""
    out = {}
    for r, row in enumerate(MOSAIC_DEG):
        for c, angle in enumerate(row):
            out[angle] = SlicingPattern(start_row=r, start_column=c, step=2)
    return out


def engine_pose(heading_deg: float) -> np.ndarray:
    """Engine's sensor-to-world rotation (North-East-Up) for a bpins level camera at
    heading psi: about Up by a = psi - 90 deg (world azimuth = local azimuth + a)."""
    a = np.radians(heading_deg - 90.0)
    return np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])


def make_engine(a, seed: int) -> Engine:
    return Engine(
        sensor_pixel_pitch_micrometers=PIXEL_PITCH_UM,
        lens_conjugation_type=a.lens,
        number_pixels_vertical=HEIGHT_PX,
        number_pixels_horizontal=WIDTH_PX,
        lens_focal_length_micrometers=FOCAL_LENGTH_MM * 1000.0,
        polarizer_tolerance_radians=a.polarizer_tolerance_rad,
        extinction_ratio=a.extinction_ratio,
        auto_exposure_saturation_fraction=a.saturation_fraction,
        adc_resolution_bits=BIT_DEPTH,
        multiplicative_noise_snr=a.snr,
        wire_grid_orientations_slicing=slicing(),
        random_seed=seed,
    )


def render_frame(eng: Engine, heading_deg: float, sun_az_deg, sun_el_deg, dolp_scale: float, time: Time = TIME):
    """One frame through the Engine: (raw counts (H, W) uint16, sky dict, local az/alt grids).
    With sun_az_deg None the Engine finds the sun itself (astropy's get_sun at `time`)."""
    az, alt = eng.get_initial_azimuth_altitude()
    sun = None
    if sun_az_deg is not None:
        sun = SkyCoord(alt=[sun_el_deg] * u.deg, az=[sun_az_deg] * u.deg, frame=AltAz(obstime=time, location=PLACE))
    values, names = eng.simulate_sky_polarization(
        sky_model=SKY_MODEL,
        observation_location=PLACE,
        times=time,
        cie_sky_type=CIE_SKY_TYPE,
        altitudes=alt,
        azimuths=az,
        sun_position=sun,
        sensor_to_world_rotation_matrix=engine_pose(heading_deg),
    )
    sky = dict(zip(names, values))
    got = np.degrees([float(np.ravel(sky["sun azimuth"])[0]), float(np.ravel(sky["sun elevation"])[0])])
    if sun is None:
        return None, sky, got
    assert abs((got[0] - sun_az_deg + 180) % 360 - 180) < 1e-9 and abs(got[1] - sun_el_deg) < 1e-9, got
    # The raw counts are what the Engine's own pipeline hands its Stokes step:
    # catch them there, on this Engine instance only (its measurement API returns
    # only the reconstructed DoP and AoP).
    stokes = eng._Engine__stokes_calculator  # noqa: SLF001 (read-only tap)
    caught = {}
    inner = stokes.simulate_measurements

    def tap(bits_intensity):
        caught["bits"] = np.array(bits_intensity, copy=True)
        return inner(bits_intensity=bits_intensity)

    stokes.simulate_measurements = tap
    try:
        eng.simulate_measurement(
            degree_of_polarization=np.asarray(sky["degree of polarization"]) * dolp_scale,
            angle_of_polarization=sky["angle of polarization"],
            radiance=sky["radiance"],
        )
    finally:
        del stokes.simulate_measurements
    bits = caught["bits"][0]
    assert np.all(np.isfinite(bits)), "masked pixels in a frame"
    return bits.astype(np.uint16), sky, az, alt


def check_mapping(sky, az_local, alt_local, heading_deg, sun_az_deg, sun_el_deg) -> tuple[float, float]:
    """Worst differences (deg) between the Engine and CONVENTIONS built from the spec
    alone: world rays (pinhole, world_from_camera(psi)) and Rayleigh image AoP
    (E-vector along sun x view, angle to the meridian p toward s, plus beta)."""
    v, uu = np.mgrid[0:HEIGHT_PX, 0:WIDTH_PX].astype(np.float64)
    f_px = FOCAL_LENGTH_MM * 1000.0 / PIXEL_PITCH_UM
    cx, cy = (WIDTH_PX - 1) / 2.0, (HEIGHT_PX - 1) / 2.0
    ray = np.stack([(uu - cx) / f_px, (v - cy) / f_px, np.ones_like(uu)], axis=-1)
    ray /= np.linalg.norm(ray, axis=-1, keepdims=True)
    p = np.radians(heading_deg)
    wfc = np.array([[-np.cos(p), -np.sin(p), 0.0], [np.sin(p), -np.cos(p), 0.0], [0.0, 0.0, 1.0]])  # ENU
    d = ray @ wfc.T
    # The Engine's world ray of each pixel: its local grid through its pose, as ENU.
    al, aa = np.radians(alt_local), np.radians(az_local)
    neu = np.stack([np.cos(al) * np.cos(aa), np.cos(al) * np.sin(aa), np.sin(al)], axis=-1) @ engine_pose(heading_deg).T
    enu = neu[..., [1, 0, 2]]
    ray_err = np.degrees(np.arctan2(np.linalg.norm(np.cross(enu, d), axis=-1), (enu * d).sum(-1))).max()
    # Rayleigh AoP from the conventions.
    a, h = np.radians(sun_az_deg), np.radians(sun_el_deg)
    sun = np.array([np.sin(a) * np.cos(h), np.cos(a) * np.cos(h), np.sin(h)])
    e_c = np.cross(np.broadcast_to(sun, d.shape), d) @ wfc  # camera frame
    beta = np.arctan2(-(v - cy), uu - cx)
    pm = ray * ray[..., 2:3] - np.array([0.0, 0.0, 1.0])
    pm /= np.linalg.norm(pm, axis=-1, keepdims=True)
    s = np.stack([-np.sin(beta), -np.cos(beta), np.zeros_like(beta)], axis=-1)
    alpha = np.arctan2((e_c * s).sum(-1), (e_c * pm).sum(-1)) + beta
    diff = np.asarray(sky["angle of polarization"])[0] - alpha
    diff = (diff + np.pi / 2) % np.pi - np.pi / 2
    return float(ray_err), float(np.degrees(np.abs(diff).max()))


def capture_toml(a, frames) -> str:
    lines = [
        'format = "bpins-capture/1"',
        "",
        "[sensor]",
        'layout = "dofp"',
        f"width_px = {WIDTH_PX}",
        f"height_px = {HEIGHT_PX}",
        f"pixel_pitch_um = {PIXEL_PITCH_UM}",
        f"bit_depth = {BIT_DEPTH}",
        f"black_level_dn = {a.declare_black_level}",
        f"mosaic = [[{MOSAIC_DEG[0][0]}, {MOSAIC_DEG[0][1]}], [{MOSAIC_DEG[1][0]}, {MOSAIC_DEG[1][1]}]]",
        "",
        "[lens]",
        f'projection = "{LENSES[a.lens]}"',
        f"focal_length_mm = {FOCAL_LENGTH_MM}",
    ]
    if a.declare_principal_point:
        x, y = a.declare_principal_point
        lines.append(f"principal_point_px = [{x}, {y}]")
    for file, sun_az, sun_el, heading in frames:
        if sun_el is None:  # sun_az holds the frame's UTC time
            sun = [f'time_utc = "{sun_az}Z"', f"latitude_deg = {PLACE.lat.deg:.6f}", f"longitude_deg = {PLACE.lon.deg:.6f}"]
        else:
            sun = [f"sun_azimuth_deg = {sun_az}", f"sun_elevation_deg = {sun_el}"]
        lines += ["", "[[frames]]", f'file = "{file}"', *sun, f"heading_deg = {heading}"]
    return "\n".join(lines) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, required=True, help="capture folder to write")
    ap.add_argument("--seed", type=int, default=46, help="seed of the headings and the Engine's noise (default 46)")
    ap.add_argument("--check", action="store_true", help="check the convention mapping on every frame")
    ap.add_argument("--lens", choices=sorted(LENSES), default="thin")
    ap.add_argument("--dolp-scale", type=float, default=1.0, help="factor on the sky's DoLP before the micro-polarizer")
    ap.add_argument("--snr", type=float, default=NOISE_SNR)
    ap.add_argument("--polarizer-tolerance-rad", type=float, default=POLARIZER_TOLERANCE_RAD, help="Engine's largest per-pixel analyzer angle defect (uniform, fixed for the camera)")
    ap.add_argument("--extinction-ratio", type=float, default=EXTINCTION_RATIO)
    ap.add_argument("--saturation-fraction", type=float, default=SATURATION_FRACTION)
    ap.add_argument("--declare-principal-point", type=float, nargs=2, metavar=("X", "Y"), help="principal_point_px written (rendering unchanged)")
    ap.add_argument("--declare-black-level", type=float, default=0.0, help="black_level_dn written (default 0: the Engine has none)")
    ap.add_argument("--sun-from-time", action="store_true", help="the Engine's own sun (astropy) at SUN_TIMES_UTC; capture.toml gets time and place (bpins: NREL SPA)")
    ap.add_argument("--engine-per-frame", action="store_true", help="a new Engine for each frame (random_seed SEED*1000 + frame): other noise, as the README's starred rows")
    ap.add_argument("--sensor", type=float, nargs=3, metavar=("W", "H", "PITCH_UM"), help="another sensor size and pitch (default 306 256 27.6)")
    a = ap.parse_args()
    if a.sensor:
        global WIDTH_PX, HEIGHT_PX, PIXEL_PITCH_UM
        WIDTH_PX, HEIGHT_PX, PIXEL_PITCH_UM = int(a.sensor[0]), int(a.sensor[1]), a.sensor[2]
    if pyskylumos.__version__ != PYSKYLUMOS_VERSION:
        print(f"note: PySkyLumos {pyskylumos.__version__}, this capture was made with {PYSKYLUMOS_VERSION}", file=sys.stderr)
    rng = np.random.default_rng(a.seed)
    headings = np.round(rng.uniform(0.0, 360.0, len(SUNS_DEG)), 3)
    (a.out / "frames").mkdir(parents=True, exist_ok=True)
    frames = []
    # One camera for every frame: the Engine's micro-polarizer defects (if any) are
    # drawn once and kept, its sensor noise stream runs on.
    eng = make_engine(a, seed=a.seed)
    for j, ((sun_az, sun_el), heading) in enumerate(zip(SUNS_DEG, headings)):
        if a.engine_per_frame:
            eng = make_engine(a, seed=a.seed * 1000 + j)
        time = TIME
        if a.sun_from_time:
            # The Engine's own sun at this time (astropy, no refraction); the capture
            # gives bpins the time and place instead (NREL SPA, standard refraction).
            time = Time([SUN_TIMES_UTC[j]], scale="utc")
            _, _, (sun_az, sun_el) = render_frame(eng, float(heading), None, None, a.dolp_scale, time)
            sun_az, sun_el = float(sun_az) % 360.0, float(sun_el)
        dn, sky, az, alt = render_frame(eng, float(heading), sun_az, sun_el, a.dolp_scale, time)
        file = f"frames/f{j:03d}.png"
        Image.fromarray(dn).save(a.out / file, optimize=True)
        frames.append((file, SUN_TIMES_UTC[j] if a.sun_from_time else sun_az, None if a.sun_from_time else sun_el, float(heading)))
        note = ""
        if a.check and a.lens == "thin":
            ray_err, aop_err = check_mapping(sky, az, alt, float(heading), sun_az, sun_el)
            assert ray_err < 1e-6 and aop_err < 1e-6, (ray_err, aop_err)
            note = f", rays within {ray_err:.1e} deg, AoP within {aop_err:.1e} deg of CONVENTIONS"
        print(f"{file}: heading {heading:7.3f} deg, DN {dn.min()}..{dn.max()}, saturated {(dn == 2**BIT_DEPTH - 1).sum()}{note}")
    (a.out / "capture.toml").write_text(capture_toml(a, frames))
    return 0


if __name__ == "__main__":
    sys.exit(main())
