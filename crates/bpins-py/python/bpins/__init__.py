"""bpins: a heading from the sky's polarization, with an honest 1σ.

The front door is :class:`Compass` (built once from the camera, the sensor and a
calibration; per frame a raw numpy mosaic, the sun and the attitude in, a
:class:`Heading` out). :func:`simulate` makes frames with their truth,
:func:`read_capture` and :func:`write_capture` move capture folders to and from
arrays, :func:`stokes_maps` gives AoP and DoLP of a raw mosaic, :func:`fit` and
:func:`diagnose` fit the model to a capture folder and search the catalog for what
it misses (returning the data of the CLI's fit.json and diagnosis.json),
:func:`effects` the effect catalog, :func:`locate` north and the place from frames
over time when GNSS is gone.

Angles are degrees. In-image angles (analyzer orientation, angle of polarization)
are measured from image +x toward image −y: counter-clockwise as displayed
(docs/spec/CONVENTIONS.md). The heading is the azimuth of the image top, from North
toward East, in [0°, 360°).
"""

from ._bpins import (
    Compass,
    Heading,
    __version__,
    diagnose,
    effects,
    fit,
    locate,
    read_capture,
    simulate,
    stokes_maps,
    write_capture,
)

__all__ = [
    "Compass",
    "Heading",
    "__version__",
    "diagnose",
    "effects",
    "fit",
    "locate",
    "read_capture",
    "simulate",
    "stokes_maps",
    "write_capture",
]
