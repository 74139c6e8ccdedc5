"""The Python front door's cost per frame on a full 2448 × 2048 uint16 mosaic, to set
beside the Rust front door's criterion figure (`cargo bench -p bpins-core --bench
field -- 2048x2448_compass`; BENCHMARKS.md). The frame is simulated once; the clock
covers `Compass.heading` alone (argument checks, the in-place numpy borrow, the GIL
released, the compass).

    python examples/python/bench_front_door.py [REPEATS]
"""

import sys
import time

import numpy as np

import bpins

repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 200
# The Rust bench's frame: an IMX250MZR (3.45 µm pixels) behind an 8 mm lens, tilted
# 4°/−3°, the sun at 40°/25°.
sim = bpins.simulate(2448, 2048, heading_deg=30.0, tilt_x_deg=4.0, tilt_y_deg=-3.0, focal_length_mm=8.0,
                     pixel_pitch_um=3.45, seed=1)
frame = sim["mosaic"]
compass = bpins.Compass(2448, 2048, sim["focal_length_px"], bit_depth=12, black_level_dn=64.0)
kw = dict(sun_azimuth_deg=40.0, sun_elevation_deg=25.0, tilt_x_deg=4.0, tilt_y_deg=-3.0, tilt_sigma_deg=0.1)
for _ in range(10):
    h = compass.heading(frame, **kw)
assert h.zero_copy, "the mosaic was copied"
times_ms = []
for _ in range(repeats):
    t0 = time.perf_counter()
    compass.heading(frame, **kw)
    times_ms.append((time.perf_counter() - t0) * 1e3)
t = np.array(times_ms)
print(f"Python front door, 2448 × 2048 uint16, {repeats} frames: median {np.median(t):.3f} ms, "
      f"p10 {np.percentile(t, 10):.3f} ms, p90 {np.percentile(t, 90):.3f} ms; heading {h.heading_deg:.3f}° ± {h.sigma_deg:.3f}°")
