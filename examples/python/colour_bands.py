"""The three bands' AoP and DoLP maps of one frame of samples/colour-clear, as
docs/colour_bands.png (docs/colour.md). Each band from its own pixels
(`bpins.stokes_maps(..., colour_tiles=...)`, polanalyser's COLOR_PolarRGB demosaic
exactly: "opencv").

    .venv/bin/python examples/python/colour_bands.py [samples/colour-clear] [docs/colour_bands.png]
"""

import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import bpins  # noqa: E402

REPO = pathlib.Path(__file__).resolve().parents[2]


def main(capture: pathlib.Path, out: pathlib.Path, frame: int = 0) -> None:
    meta, frames = bpins.read_capture(capture, frames=[frame])
    sensor = meta["sensor"]
    raw = frames[0].astype(np.uint16)
    tiles = tuple(tuple(row) for row in sensor["colour_tiles"])
    maps = bpins.stokes_maps(
        raw,
        black_level_dn=float(sensor["black_level_dn"]),
        mosaic_layout=sensor["mosaic"],
        colour_tiles=tiles,
        interpolation="opencv",
    )
    heading = meta["frames"][frame].get("heading_deg")
    fig, axes = plt.subplots(2, 3, figsize=(11.0, 6.4), constrained_layout=True)
    for col, band in enumerate(("R", "G", "B")):
        m = maps[band]
        a = axes[0, col].imshow(m["aop_deg"], cmap="twilight", vmin=-90.0, vmax=90.0)
        axes[0, col].set_title(f"{band}: AoP (°)")
        d = axes[1, col].imshow(m["dolp"], cmap="viridis", vmin=0.0, vmax=0.8)
        axes[1, col].set_title(f"{band}: DoLP (median {np.nanmedian(m['dolp']):.3f})")
        for ax in axes[:, col]:
            ax.set_xticks([])
            ax.set_yticks([])
    fig.colorbar(a, ax=axes[0, :], shrink=0.85, label="AoP (°, image frame)")
    fig.colorbar(d, ax=axes[1, :], shrink=0.85, label="DoLP")
    fig.suptitle(
        f"{capture.name}, frame {frame} (true heading {heading}°): each band's maps from its own pixels"
    )
    fig.savefig(out, dpi=80)
    print(f"wrote {out}")


if __name__ == "__main__":
    cap = pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else REPO / "samples/colour-clear"
    dst = pathlib.Path(sys.argv[2]) if len(sys.argv) > 2 else REPO / "docs/colour_bands.png"
    main(cap, dst)
