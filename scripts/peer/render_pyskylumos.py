#!/usr/bin/env python3
"""Render bpins captures of skies computed by another simulator, PySkyLumos.

What: DoFP captures (docs/spec/CAPTURE.md) of PySkyLumos's sky models, with a
camera and sensor written here from docs/spec/CONVENTIONS.md alone, so that bpins
is tested on radiance, AoP and DoLP it did not compute itself (issue 31). Nothing
here calls bpins, and nothing of PySkyLumos is copied: it is imported and asked
for the sky at each pixel's ray.

PySkyLumos (PyPI `pyskylumos`, MIT, T.-A. Ciochirca et al., Univ. of Liverpool)
gives, per world direction (AltAz: azimuth from North toward East, altitude),
the sky's degree of polarization, its angle of polarization in radians in its
"fixed world chart" (the zenith-centred stereographic chart xi = tan(zenith/2)
e^{i azimuth}, angle counted from North toward East; README section 10), and a
relative CIE radiance. Its direct sky models (`Rayleigh`, `Berry`) are used with
an explicit sun position, so no ephemeris is involved.

Chain, per frame (each mosaic pixel at its own ray, CONVENTIONS "Pixels"):

1. Ray of pixel (u, v): pinhole, x_n = (u - c_x)/f_px, y_n = (v - c_y)/f_px,
   centres at integer coordinates, c = ((W-1)/2, (H-1)/2).
2. World (ENU) direction: level camera at heading psi, world_from_camera
   columns x_c = (-cos psi, sin psi, 0), y_c = (-sin psi, -cos psi, 0),
   z_c = (0, 0, 1); azimuth = atan2(E, N), altitude = asin(U).
3. PySkyLumos: DoLP d_psl, chart AoP chi, radiance L at those directions.
4. Image AoP (CONVENTIONS "Angles in the image"): the chart and the displayed
   image are both the sky seen from below, with angles counter-clockwise as
   displayed, and both keep the angle to the local meridian (the chart is
   conformal; the ideal lens keeps p and s). So the AoE is phi = chi - azimuth,
   and alpha = phi + beta with beta = atan2(-(v - c_y), u - c_x). Checked
   against an independent E-vector = sun x view construction on the Rayleigh
   sky (`check_rayleigh_aop`), and against the repository's samples/clean
   (`--check-samples`).
5. DoLP d = D_MAX * d_psl (PySkyLumos's Rayleigh and Berry peak at 1; a real
   clear sky's peak is about 0.6, the samples' value).
6. Analyzer theta of the DoFP mosaic [[90, 45], [135, 0]] (deg, by tile row and
   column): I_theta = 1/2 (I + Q cos 2 theta + U sin 2 theta), Q = I d cos 2 alpha,
   U = I d sin 2 alpha (CONVENTIONS "Stokes and Mueller", ideal analyzers).
7. Sensor (EMVA 1288, CONVENTIONS "Sensor response"): signal S = g I_theta in DN,
   g set per frame so the brightest pixel's expected DN is PEAK_FRACTION of full
   scale (auto exposure); shot noise K * Poisson(S / K) at system gain K DN/e-,
   read noise N(0, READ_NOISE_DN), black level b, rounding, clipping to
   [0, 2^bits - 1]; a frame that is the mean of n exposures has K/n and
   READ_NOISE_DN/sqrt(n), rounded once. One numpy Generator seeded from --seed
   and the capture's index.

Usage (Python 3.12-3.14, as PySkyLumos needs):

    python3.12 -m venv /tmp/peer && /tmp/peer/bin/pip install pyskylumos==0.1.3 pillow
    /tmp/peer/bin/python scripts/peer/render_pyskylumos.py --out tests/data/peer-pyskylumos
    /tmp/peer/bin/python scripts/peer/render_pyskylumos.py --check-samples samples/clean

Output: OUT/<sky>/capture.toml and OUT/<sky>/frames/fNNN.png (16-bit PNG, DN),
the reference heading of each frame being the truth it was rendered at.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

import astropy.units as u
from astropy.coordinates import AltAz, EarthLocation, SkyCoord
from astropy.time import Time

import pyskylumos
from pyskylumos.sky_models import Berry, Rayleigh

PYSKYLUMOS_VERSION = "0.1.3"

# The camera and sensor (CAPTURE.md keys). 306 x 256 at 27.6 um behind 8 mm: the
# field of view of the samples' 612 x 512 at 13.8 um, a quarter of the pixels.
WIDTH_PX = 306
HEIGHT_PX = 256
PIXEL_PITCH_UM = 27.6
FOCAL_LENGTH_MM = 8.0
BIT_DEPTH = 12
BLACK_LEVEL_DN = 64.0
MOSAIC_DEG = ((90, 45), (135, 0))  # analyzer angle by tile (row, column), image frame
READ_NOISE_DN = 1.0  # 1 sigma
SYSTEM_GAIN_DN_PER_E = 0.1  # K
PEAK_FRACTION = 0.7  # brightest expected DN / full scale
D_MAX = 0.6  # peak DoLP: scales PySkyLumos's DoLP (which peaks at 1)
CIE_SKY_TYPE = 12  # CIE Standard Clear Sky, low turbidity

# Sun (azimuth, elevation) of each frame, degrees: elevations 20-50 deg keep the
# sun out of the +-34.5 deg (corner) field of view while the Berry sky's
# above-sun neutral point, 15 deg above the sun, crosses it.
SUNS_DEG = (
    (40.0, 25.0),
    (130.0, 35.0),
    (220.0, 45.0),
    (310.0, 50.0),
    (75.0, 30.0),
    (165.0, 40.0),
    (255.0, 50.0),
    (345.0, 20.0),
)

# The captures: folder name, PySkyLumos model class, exposures averaged per frame,
# what it is. The stacked capture lowers the noise variance 16-fold (shot and read
# noise / 16, still rounded to whole DN once): the same information as 16 times the
# pixels, where the CIE radiance's departure from the fit's radiance nuisance starts
# to show in single frames.
SKIES = (
    ("rayleigh", Rayleigh, 1, "PySkyLumos Rayleigh: DoLP sin^2 g/(1+cos^2 g), E-vector normal to the scattering plane"),
    ("berry", Berry, 1, "PySkyLumos Berry (2004, eq. 4.2): DoLP |omega|, neutral points 15 deg above/below sun and anti-sun (30 deg apart)"),
    ("rayleigh-stack16", Rayleigh, 16, "PySkyLumos Rayleigh, other headings and noise"),
)

# Any place and time: with an explicit sun position PySkyLumos uses them only to
# build its AltAz frame.
PLACE = EarthLocation(lat=53.4 * u.deg, lon=-2.96 * u.deg, height=50 * u.m)
TIME = Time(["2026-06-21T12:00:00"], scale="utc")


@dataclass
class Camera:
    """Pixel grid and pinhole rays of a WIDTH x HEIGHT sensor, camera frame (CONVENTIONS)."""

    width_px: int
    height_px: int
    pixel_pitch_um: float
    focal_length_mm: float

    def grids(self):
        """(u, v) pixel centres, unit rays (H, W, 3) and beta (rad), the image angle of
        the radial line from the principal point, counter-clockwise as displayed."""
        f_px = self.focal_length_mm * 1000.0 / self.pixel_pitch_um
        cx, cy = (self.width_px - 1) / 2.0, (self.height_px - 1) / 2.0
        v, uu = np.mgrid[0 : self.height_px, 0 : self.width_px].astype(np.float64)
        xn, yn = (uu - cx) / f_px, (v - cy) / f_px
        ray = np.stack([xn, yn, np.ones_like(xn)], axis=-1)
        ray /= np.linalg.norm(ray, axis=-1, keepdims=True)
        beta = np.arctan2(-(v - cy), uu - cx)
        return uu, v, ray, beta


def world_from_camera(heading_deg: float) -> np.ndarray:
    """Level camera at heading psi (CONVENTIONS "Frames"): columns x_c, y_c, z_c in ENU."""
    p = np.radians(heading_deg)
    return np.array(
        [
            [-np.cos(p), -np.sin(p), 0.0],
            [np.sin(p), -np.cos(p), 0.0],
            [0.0, 0.0, 1.0],
        ]
    )


def enu_direction(az_deg: float, el_deg: float) -> np.ndarray:
    """Unit ENU vector of azimuth (from North toward East) and elevation, degrees."""
    a, h = np.radians(az_deg), np.radians(el_deg)
    return np.array([np.sin(a) * np.cos(h), np.cos(a) * np.cos(h), np.sin(h)])


def wrap_axis(x_rad: np.ndarray) -> np.ndarray:
    """An axial angle wrapped to (-pi/2, pi/2]."""
    return -((-x_rad + np.pi / 2) % np.pi - np.pi / 2)


def ask_pyskylumos(model, az_deg, alt_deg, sun_az_deg, sun_el_deg, cie_sky_type=CIE_SKY_TYPE):
    """PySkyLumos's sky at the world directions (az_deg, alt_deg) (each (H, W)):
    DoLP, chart AoP (rad), radiance and scattering angle (rad), each (H, W)."""
    frame = AltAz(obstime=TIME, location=PLACE)
    sky = model(times=TIME, observation_location=PLACE, azimuths=az_deg, altitudes=alt_deg)
    sun = SkyCoord(alt=[sun_el_deg] * u.deg, az=[sun_az_deg] * u.deg, frame=frame)
    values = sky.simulate_sky(cie_sky_type=cie_sky_type, sun_position=sun)
    out = dict(zip(sky.parameters_simulated, values))
    # The sun it used is the one asked for (no ephemeris, no frame change).
    got_az = np.degrees(float(np.ravel(out["sun azimuth"])[0]))
    got_el = np.degrees(float(np.ravel(out["sun elevation"])[0]))
    assert abs((got_az - sun_az_deg + 180) % 360 - 180) < 1e-9 and abs(got_el - sun_el_deg) < 1e-9, (got_az, got_el)
    pick = lambda k: np.asarray(out[k], dtype=np.float64)[0]  # noqa: E731 (one time)
    return pick("degree of polarization"), pick("angle of polarization"), pick("radiance"), pick("scattering angle")


@dataclass
class Sky:
    """The sky seen by one frame's pixels: intensity, DoLP and image AoP (rad)."""

    intensity: np.ndarray
    dolp: np.ndarray
    aop_rad: np.ndarray


def sky_in_image(model, cam: Camera, heading_deg, sun_az_deg, sun_el_deg, radiance="cie", check=False):
    """Steps 1-5 of the module doc. `radiance`: "cie" (PySkyLumos's CIE sky) or
    "rayleigh" (1 + cos^2 gamma, the samples' radiance)."""
    _, _, ray_c, beta = cam.grids()
    d = ray_c @ world_from_camera(heading_deg).T  # (H, W, 3) ENU
    az = np.arctan2(d[..., 0], d[..., 1])
    alt = np.arcsin(np.clip(d[..., 2], -1.0, 1.0))
    dolp, chi, lum, gamma = ask_pyskylumos(model, np.degrees(az) % 360.0, np.degrees(alt), sun_az_deg, sun_el_deg)
    aop = wrap_axis(chi - az + beta)
    if check:
        check_rayleigh_aop(aop, ray_c, d, enu_direction(sun_az_deg, sun_el_deg), heading_deg, beta)
    intensity = lum if radiance == "cie" else 1.0 + np.cos(gamma) ** 2
    assert np.all(np.isfinite(intensity)) and np.all(np.isfinite(aop)) and np.all(np.isfinite(dolp))
    return Sky(intensity=intensity, dolp=D_MAX * dolp, aop_rad=aop)


def check_rayleigh_aop(aop, ray_c, d_enu, sun_enu, heading_deg, beta):
    """Independent of PySkyLumos: the Rayleigh E-vector is along sun x view; its
    angle from the meridional direction p (away from the optical axis) toward the
    sagittal s (image direction beta + 90 deg), plus beta, is the image AoP."""
    e = np.cross(np.broadcast_to(sun_enu, d_enu.shape), d_enu)
    e_c = e @ world_from_camera(heading_deg)  # camera frame: R^T e
    z = np.array([0.0, 0.0, 1.0])
    p = ray_c * ray_c[..., 2:3] - z
    p /= np.linalg.norm(p, axis=-1, keepdims=True)
    s = np.stack([-np.sin(beta), -np.cos(beta), np.zeros_like(beta)], axis=-1)
    phi = np.arctan2((e_c * s).sum(-1), (e_c * p).sum(-1))
    diff = wrap_axis(phi + beta - aop)
    worst = np.degrees(np.abs(diff).max())
    assert worst < 1e-6, f"PySkyLumos's Rayleigh AoP differs from sun x view by up to {worst:.3g} deg"


def analyzer_map(cam: Camera) -> np.ndarray:
    """Analyzer angle (rad) of every mosaic pixel."""
    v, uu = np.mgrid[0 : cam.height_px, 0 : cam.width_px]
    return np.radians(np.array(MOSAIC_DEG, dtype=np.float64)[v % 2, uu % 2])


def ideal_channels(sky: Sky, theta: np.ndarray) -> np.ndarray:
    """I_theta = 1/2 (I + Q cos 2 theta + U sin 2 theta), step 6."""
    q = sky.intensity * sky.dolp * np.cos(2 * sky.aop_rad)
    uu = sky.intensity * sky.dolp * np.sin(2 * sky.aop_rad)
    return 0.5 * (sky.intensity + q * np.cos(2 * theta) + uu * np.sin(2 * theta))


def expose(i_theta: np.ndarray, rng: np.random.Generator, stack: int) -> np.ndarray:
    """Step 7: DN (uint16) of one frame, the mean of `stack` exposures (rounded once):
    shot noise K/stack * Poisson(S * stack / K), read noise sigma/sqrt(stack)."""
    full_dn = 2**BIT_DEPTH - 1
    gain = (PEAK_FRACTION * full_dn - BLACK_LEVEL_DN) / i_theta.max()
    signal_dn = gain * i_theta
    k = SYSTEM_GAIN_DN_PER_E / stack
    shot_dn = k * rng.poisson(signal_dn / k)
    dn = shot_dn + BLACK_LEVEL_DN + rng.normal(0.0, READ_NOISE_DN / np.sqrt(stack), signal_dn.shape)
    return np.clip(np.rint(dn), 0, full_dn).astype(np.uint16)


def capture_toml(cam: Camera, frames: list[tuple[str, float, float, float]]) -> str:
    lines = [
        'format = "bpins-capture/1"',
        "",
        "[sensor]",
        'layout = "dofp"',
        f"width_px = {cam.width_px}",
        f"height_px = {cam.height_px}",
        f"pixel_pitch_um = {cam.pixel_pitch_um}",
        f"bit_depth = {BIT_DEPTH}",
        f"black_level_dn = {BLACK_LEVEL_DN}",
        f"mosaic = [[{MOSAIC_DEG[0][0]}, {MOSAIC_DEG[0][1]}], [{MOSAIC_DEG[1][0]}, {MOSAIC_DEG[1][1]}]]",
        "",
        "[lens]",
        'projection = "pinhole"',
        f"focal_length_mm = {cam.focal_length_mm}",
    ]
    for file, sun_az, sun_el, heading in frames:
        lines += [
            "",
            "[[frames]]",
            f'file = "{file}"',
            f"sun_azimuth_deg = {sun_az}",
            f"sun_elevation_deg = {sun_el}",
            f"heading_deg = {heading}",
        ]
    return "\n".join(lines) + "\n"


def render(out: Path, seed: int, stack_override: int | None = None) -> None:
    cam = Camera(WIDTH_PX, HEIGHT_PX, PIXEL_PITCH_UM, FOCAL_LENGTH_MM)
    theta = analyzer_map(cam)
    for k, (name, model, stack, what) in enumerate(SKIES):
        rng = np.random.default_rng([seed, k])
        # Headings: one per frame, uniform, to the millidegree (the value written is the
        # one rendered).
        headings = np.round(rng.uniform(0.0, 360.0, len(SUNS_DEG)), 3)
        n = stack_override or stack
        folder = out / name
        (folder / "frames").mkdir(parents=True, exist_ok=True)
        frames = []
        for j, ((sun_az, sun_el), heading) in enumerate(zip(SUNS_DEG, headings)):
            sky = sky_in_image(model, cam, float(heading), sun_az, sun_el, check=model is Rayleigh)
            dn = expose(ideal_channels(sky, theta), rng, n)
            file = f"frames/f{j:03d}.png"
            Image.fromarray(dn).save(folder / file, optimize=True)
            frames.append((file, sun_az, sun_el, float(heading)))
        (folder / "capture.toml").write_text(capture_toml(cam, frames))
        print(f"{name}: {len(frames)} frames, each the mean of {n} exposure(s), to {folder} ({what})")


def read_capture_frames(folder: Path):
    """(file, sun_az, sun_el, heading) of each frame of a capture.toml, and its sensor."""
    import tomllib

    t = tomllib.loads((folder / "capture.toml").read_text())
    frames = [(f["file"], f["sun_azimuth_deg"], f["sun_elevation_deg"], f["heading_deg"]) for f in t["frames"]]
    return t, frames


def check_samples(folder: Path) -> int:
    """Renders the repository's clean sample (another independent implementation of
    the spec: Rayleigh sky, d_max 0.6, radiance 1 + cos^2 gamma) without noise and
    compares it with the sample's DN: chi^2/dof ~ 1 where the conventions agree.
    The same with the AoP mirrored (alpha -> -alpha) shows that the test can fail."""
    t, frames = read_capture_frames(folder)
    s, lens = t["sensor"], t["lens"]
    assert tuple(map(tuple, s["mosaic"])) == MOSAIC_DEG and lens["projection"] == "pinhole"
    cam = Camera(s["width_px"], s["height_px"], s["pixel_pitch_um"], lens["focal_length_mm"])
    theta = analyzer_map(cam)
    worst = 0.0
    for file, sun_az, sun_el, heading in frames:
        dn = np.asarray(Image.open(folder / file), dtype=np.float64) - s["black_level_dn"]
        sky = sky_in_image(Rayleigh, cam, heading, sun_az, sun_el, radiance="rayleigh", check=True)
        row = []
        for label, aop in (("as rendered", sky.aop_rad), ("mirrored", -sky.aop_rad)):
            i_theta = ideal_channels(Sky(sky.intensity, sky.dolp, aop), theta)
            gain = (i_theta * dn).sum() / (i_theta * i_theta).sum()  # least-squares exposure
            model = gain * i_theta
            var = READ_NOISE_DN**2 + 1.0 / 12.0 + SYSTEM_GAIN_DN_PER_E * model
            row.append(f"{label} chi2/dof {((dn - model) ** 2 / var).mean():8.3f}")
            if label == "as rendered":
                worst = max(worst, ((dn - model) ** 2 / var).mean())
        print(f"{file}: heading {heading:6.1f} deg: " + ", ".join(row))
    ok = worst < 1.1
    print(f"worst chi2/dof as rendered {worst:.3f}: {'conventions agree' if ok else 'CONVENTIONS DISAGREE'}")
    return 0 if ok else 1


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, help="folder to write <sky>/capture.toml and frames into")
    ap.add_argument("--seed", type=int, default=31, help="seed of the headings and the noise (default 31)")
    ap.add_argument("--stack", type=int, metavar="N", help="every frame the mean of N exposures (default: each capture's own)")
    ap.add_argument("--check-samples", type=Path, metavar="DIR", help="compare with a clean sample capture instead")
    a = ap.parse_args()
    if pyskylumos.__version__ != PYSKYLUMOS_VERSION:
        print(f"note: PySkyLumos {pyskylumos.__version__}, these captures were made with {PYSKYLUMOS_VERSION}", file=sys.stderr)
    if a.check_samples:
        return check_samples(a.check_samples)
    if not a.out:
        ap.error("--out DIR or --check-samples DIR")
    render(a.out, a.seed, a.stack)
    return 0


if __name__ == "__main__":
    sys.exit(main())
