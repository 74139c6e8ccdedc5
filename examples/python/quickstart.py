"""bpins from Python in a page: simulate a frame, read its heading through the front
door, then read a capture folder's frames the same way.

    python examples/python/quickstart.py [CAPTURE]      # default: samples/clean
"""

import pathlib
import sys

import numpy as np

import bpins

# A simulated 612 × 512 DoFP frame (12-bit, IMX250MZR mosaic, 8 mm lens, 13.8 µm
# pixels) of a camera heading 30° and tilted 2° about x, the sun at 40°/25°.
sim = bpins.simulate(heading_deg=30.0, tilt_x_deg=2.0, seed=7)
compass = bpins.Compass(612, 512, sim["focal_length_px"], bit_depth=12, black_level_dn=64.0)
h = compass.heading(sim["mosaic"], sun_azimuth_deg=40.0, sun_elevation_deg=25.0, tilt_x_deg=2.0, tilt_sigma_deg=0.1)
print(f"simulated: heading {h.heading_deg:.3f}° ± {h.sigma_deg:.3f}° (truth 30°), {100 * h.used_fraction:.0f} % of the sky used")

# A capture folder: the compass from its capture.toml, each frame's heading.
repo = pathlib.Path(__file__).resolve().parents[2]
cap = pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else repo / "samples" / "clean"
meta, mosaics = bpins.read_capture(cap)
compass = bpins.Compass.from_capture(cap)
errors = []
for f, m in zip(meta["frames"], mosaics):
    h = compass.heading(m.astype(np.uint16), sun_azimuth_deg=f["sun_azimuth_deg"], sun_elevation_deg=f["sun_elevation_deg"])
    if h.heading_deg is None:
        print(f"{f['file']}: no heading ({h.reason})")
        continue
    err = (h.heading_deg - f.get("heading_deg", h.heading_deg) + 180.0) % 360.0 - 180.0
    errors.append(err)
    print(f"{f['file']}: {h.heading_deg:8.3f}° ± {h.sigma_deg:.3f}°, error {err:+.4f}°")
print(f"{cap.name}: RMS error {np.sqrt(np.mean(np.square(errors))):.4f}° over {len(errors)} frames")
