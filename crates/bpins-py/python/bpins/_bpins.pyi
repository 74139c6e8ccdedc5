"""Type stubs of the native module (crates/bpins-py/src). Units are in the names."""

import datetime
import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

_Path = Union[str, "os.PathLike[str]"]
_Mosaic = Union[npt.NDArray[np.uint8], npt.NDArray[np.uint16], npt.NDArray[np.float32]]
_Layout = Sequence[Sequence[float]]

class Heading:
    """The heading of one frame, or why there is none."""

    heading_deg: Optional[float]
    """Azimuth of the image top, degrees from North toward East, in [0, 360); None without a heading."""
    sigma_deg: Optional[float]
    """1σ of the heading, degrees."""
    sigma_parts_deg: Optional[Dict[str, float]]
    """The parts of the 1σ: fit_deg, jackknife_deg, coherent_deg, misfit_deg, cross_deg, tilt_deg, sun_deg, floor_deg."""
    used_fraction: float
    """Fraction of the image the heading rests on (0…1)."""
    cloud_fraction: float
    """Fraction of the observed sky taken for cloud (0…1)."""
    residual_rms_deg: float
    """Weighted RMS angle residual of the used sky, degrees."""
    reason: Optional[str]
    """Why there is no heading; None where there is one."""
    extractor: str
    source: str
    """Which source lit the sky: "given" (angles given), or from time_utc and the place
    "sun" (by day, or a twilight it dominates) or "moon" (at night where it is up and its
    sky the brighter)."""
    sun_share: Optional[float]
    """The sun's share of the sky's light at the zenith (0…1); None for given angles."""
    moon_share: Optional[float]
    """The moon's share (1 − sun_share); None for given angles."""
    cells_total: int
    cells_used: int
    zero_copy: bool
    """Whether the mosaic was read in place (False: columns not adjacent, copied)."""

class Compass:
    """The front door: live mosaics in, headings with an honest 1σ out. One per camera;
    threads may share one (it reads one frame at a time), or each have its own to read
    frames in parallel."""

    def __init__(
        self,
        width_px: int,
        height_px: int,
        focal_length_px: float,
        *,
        principal_point_px: Optional[Tuple[float, float]] = None,
        projection: str = "pinhole",
        bit_depth: int = 12,
        black_level_dn: float = 0.0,
        mosaic: _Layout = ((90, 45), (135, 0)),
        calibration: Optional[_Path] = None,
        extractor: str = "sun_vector",
        horizon_margin_deg: Optional[float] = None,
        colour_tiles: Optional[Sequence[Sequence[str]]] = None,
    ) -> None:
        """`colour_tiles` (e.g. [["R", "G"], ["G", "B"]], the IMX250MYR's): a colour-polarization
        sensor, each band read from its own pixels; `heading` is then the bands' fused heading."""
    @staticmethod
    def from_capture(path: _Path, *, calibration: Optional[_Path] = None, extractor: str = "sun_vector") -> "Compass": ...
    @property
    def shape(self) -> Tuple[int, int]:
        """(height_px, width_px)."""
    def heading(
        self,
        mosaic: _Mosaic,
        *,
        sun_azimuth_deg: Optional[float] = None,
        sun_elevation_deg: Optional[float] = None,
        time_utc: Optional[datetime.datetime] = None,
        latitude_deg: Optional[float] = None,
        longitude_deg: Optional[float] = None,
        site: Optional[_Path] = None,
        sun_sigma_deg: float = 0.0,
        tilt_x_deg: float = 0.0,
        tilt_y_deg: float = 0.0,
        tilt_sigma_deg: float = 0.0,
    ) -> Heading:
        """The heading of one raw mosaic (2-D, the sensor's shape; uint8, uint16 or float32 DN).

        The sun as angles (degrees) or as a timezone-aware datetime and a place (NREL SPA).
        The GIL is released while it computes; the mosaic is not copied.
        """
    def band_headings(
        self,
        mosaic: _Mosaic,
        *,
        sun_azimuth_deg: Optional[float] = None,
        sun_elevation_deg: Optional[float] = None,
        time_utc: Optional[datetime.datetime] = None,
        latitude_deg: Optional[float] = None,
        longitude_deg: Optional[float] = None,
        site: Optional[_Path] = None,
        sun_sigma_deg: float = 0.0,
        tilt_x_deg: float = 0.0,
        tilt_y_deg: float = 0.0,
        tilt_sigma_deg: float = 0.0,
    ) -> Dict[str, Heading]:
        """A colour-polarization compass's headings: {"fused": …, "R": …, "G": …, "B": …}, each
        band's from its own pixels. The arguments are `heading`'s; a monochrome compass raises ValueError."""

def simulate(
    width_px: int = 612,
    height_px: int = 512,
    *,
    heading_deg: float = 0.0,
    sun_azimuth_deg: float = 40.0,
    sun_elevation_deg: float = 25.0,
    tilt_x_deg: float = 0.0,
    tilt_y_deg: float = 0.0,
    effects: Optional[Dict[str, Dict[str, float]]] = None,
    seed: int = 1,
    focal_length_mm: float = 8.0,
    pixel_pitch_um: float = 13.8,
    projection: str = "pinhole",
    bit_depth: int = 12,
    black_level_dn: float = 64.0,
    mosaic: _Layout = ((90, 45), (135, 0)),
    peak_fraction: float = 0.7,
    read_noise_dn: float = 1.0,
    system_gain_dn_per_e: float = 0.1,
    dmax: float = 0.6,
) -> Dict[str, Any]:
    """One simulated DoFP frame ("mosaic", uint16 DN) and its noise-free truth
    ("aop_deg", "dolp", "aoe_deg", "intensity_dn", float32), with "focal_length_px"
    and "principal_point_px"."""

def stokes_maps(
    mosaic: _Mosaic,
    *,
    black_level_dn: float = 0.0,
    mosaic_layout: _Layout = ((90, 45), (135, 0)),
    interpolation: str = "bilinear",
    full_scale_dn: Optional[float] = None,
    aoe: bool = False,
    aoe_centre_px: Optional[Tuple[float, float]] = None,
    colour_tiles: Optional[Tuple[Tuple[str, str], Tuple[str, str]]] = None,
    out: Optional[Dict[str, Any]] = None,
) -> Dict[str, Any]:
    """AoP (degrees, image frame), DoLP, intensity (DN) and, with `aoe`, AoE of a raw
    mosaic read in place. `interpolation`: "bilinear", "superpixel" (half size),
    "opencv" (polanalyser's demosaicing, exactly) or "opencv_ea" (its edge-aware
    COLOR_PolarMono_EA / COLOR_PolarRGB_EA, exactly). `out`: preallocated float32 arrays,
    filled in place and returned. With `colour_tiles` (a colour-polarization mosaic,
    e.g. (("R", "G"), ("G", "B"))): one such dict per band, keyed "R", "G", "B", each
    band from its own pixels ("opencv": polanalyser's COLOR_PolarRGB, exactly;
    "superpixel": a quarter of the size)."""

def locate(
    capture: _Path,
    *,
    calibration: Optional[_Path] = None,
    pole: bool = False,
    max_heading_sigma_deg: float = 2.0,
    max_latitude_sigma_deg: float = 2.0,
    max_longitude_sigma_deg: float = 3.0,
    site_out: Optional[_Path] = None,
) -> Dict[str, Any]:
    """North, latitude and longitude (with 1σ, degrees) from a capture of frames over
    time stamped with time_utc and no place (docs/locate.md): "route", "heading_deg"
    (the camera's heading at the first frame), "latitude_deg", "longitude_deg" (None on
    the pole route), their "*_sigma_deg", "frames_used", "span_s", "chi2_per_dof",
    "frames" (per frame the sky's sun or why none). Raises ValueError ("not yet: …")
    when the sequence is too short or too cloudy for the bounds. `site_out` writes the
    site file that `Compass.heading(site=…)` and `bpins heading --site` take."""

def read_capture(path: _Path, frames: Optional[Sequence[int]] = None) -> Tuple[Dict[str, Any], List[npt.NDArray[np.float32]]]:
    """capture.toml as a dict and the frames' DN as float32 arrays."""

def write_capture(path: _Path, meta: Dict[str, Any], mosaics: Sequence[_Mosaic]) -> None:
    """A new capture folder from a capture.toml dict and one mosaic per frame."""

def effects() -> List[Dict[str, Any]]:
    """The effect catalog: name, summary, source, stage and params (name, unit, neutral, typical, min, max, doc)."""

def fit(
    capture: _Path,
    effects: Optional[Sequence[str]] = None,
    *,
    calibration: Optional[_Path] = None,
    fixed_dmax: Optional[float] = None,
    trust_reference: bool = False,
    rayleigh_radiance: bool = False,
    all_pixels: bool = False,
    sample_budget_px: Optional[int] = 524288,
) -> Dict[str, Any]:
    """Fits the named catalog effects (and each frame's heading, scale, radiance shape
    and d_max) to a capture folder's raw DN. Returns the data of the CLI's fit.json:
    "capture", "effects", "params" (each: name with unit suffix, value, sigma = 1σ,
    sigma_white = the white-noise 1σ, unit), "chi2_per_dof", "noise", "aop_rms_deg", "dolp_rms", "frames" (per frame:
    heading_deg, heading_sigma_deg, reference_deg, heading_error_deg, scale_dn, dmax,
    radiance, chi2_per_dof), ... `fixed_dmax` in [0, 1]; `calibration` a
    calibration.toml; `sample_budget_px` the most pixels read per frame (None: every
    pixel; "sample" in the result says what was read, "raised" where a parameter the
    sample could not tell from neutral made the fit read more pixels). Raises ValueError (bad argument, unknown effect, bad capture)
    or OSError (unreadable file). Releases the GIL."""

def diagnose(
    capture: _Path,
    effects: Optional[Sequence[str]] = None,
    *,
    max_added: int = 3,
    calibration: Optional[_Path] = None,
    fixed_dmax: Optional[float] = None,
    trust_reference: bool = False,
    rayleigh_radiance: bool = False,
    all_pixels: bool = False,
    sample_budget_px: Optional[int] = 524288,
) -> Dict[str, Any]:
    """Fits `effects` (kept), then adds the catalog effect the evidence names, at most
    `max_added` of them. Returns the data of the CLI's diagnosis.json: "selected",
    "steps" (each "model" beside fit.json's fields), "rankings" (candidates with
    delta_chi2, delta_bic), "inseparable" ([effect, reason]), "confusable",
    "unexplained" (bool) and "unexplained_summary". Releases the GIL."""
