"""Mosaic → AoP, DoLP and intensity maps at full resolution, measured side by side in
one process: bpins (`stokes_maps`, new arrays and reused `out=` arrays, each
interpolation) against polanalyser 3.0 + OpenCV (`demosaicing`, `calcLinearStokes`,
`cvtStokesToAoLP`, `cvtStokesToDoLP`), on the same 2448 × 2048 uint16 mosaic (black
level 64 DN). The Rust figure to set beside it is `cargo bench -p bpins-core --bench
maps` (BENCHMARKS.md, issue 36: Python within 1.2× of Rust, ≥ 4× faster than
polanalyser + OpenCV).

    python examples/python/bench_maps.py [REPEATS]
"""

import sys
import time

import numpy as np

import bpins

repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 20
sim = bpins.simulate(2448, 2048, heading_deg=30.0, tilt_x_deg=4.0, tilt_y_deg=-3.0, focal_length_mm=8.0,
                     pixel_pitch_um=3.45, seed=1)
raw = sim["mosaic"]


def clock(label, fn):
    for _ in range(3):
        fn()
    t = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        t.append((time.perf_counter() - t0) * 1e3)
    t = np.array(t)
    print(f"{label:<58} median {np.median(t):8.2f} ms  p10 {np.percentile(t, 10):8.2f}  p90 {np.percentile(t, 90):8.2f}")
    return float(np.median(t))


h, w = raw.shape
out = {k: np.empty((h, w), np.float32) for k in ("aop_deg", "dolp", "intensity_dn")}
results = {}
results["bilinear"] = clock("bpins.stokes_maps (bilinear, new arrays)", lambda: bpins.stokes_maps(raw, black_level_dn=64.0))
results["bilinear_out"] = clock("bpins.stokes_maps (bilinear, out= arrays)",
                                lambda: bpins.stokes_maps(raw, black_level_dn=64.0, out=out))
results["opencv"] = clock("bpins.stokes_maps (opencv, out= arrays)",
                          lambda: bpins.stokes_maps(raw, black_level_dn=64.0, interpolation="opencv", out=out))
half = {k: np.empty((h // 2, w // 2), np.float32) for k in out}
results["superpixel"] = clock("bpins.stokes_maps (superpixel, out= arrays)",
                              lambda: bpins.stokes_maps(raw, black_level_dn=64.0, interpolation="superpixel", out=half))
try:
    import polanalyser as pa

    def peer():
        # The field's usual script: black level off, demosaic, Stokes, angle maps.
        imgs = pa.demosaicing(raw, pa.COLOR_PolarMono)
        imgs = [i.astype(np.float32) - 64.0 for i in imgs]
        stokes = pa.calcLinearStokes(imgs, np.deg2rad([0, 45, 90, 135]))
        return pa.cvtStokesToAoLP(stokes), pa.cvtStokesToDoLP(stokes), stokes[..., 0]

    results["polanalyser"] = clock("polanalyser 3.0 + OpenCV (demosaicing, Stokes, AoLP, DoLP)", peer)
    print(f"polanalyser / bpins (bilinear, out=): {results['polanalyser'] / results['bilinear_out']:.1f}×; "
          f"(new arrays): {results['polanalyser'] / results['bilinear']:.1f}×")
except ImportError:
    print("polanalyser is not installed: pip install polanalyser==3.0.0 opencv-python-headless matplotlib")
