"""The night's error budget as a plot: the heading's median 1σ (lines) and RMS error
(markers) against the exposure, one panel per moon phase, one colour per moon
elevation, a dark site's glow solid and a city's dashed; the published DoFP night
compass (0.32° clear, Chinese Journal of Aeronautics 2022) as a line. Rows that read
no frame ("too dark", "ambiguous") have no point. Reads the CSV examples/night/sweep.sh
writes (CSV=FILE):

    LATITUDES="40 20 0 -20" CSV=docs/night_budget.csv examples/night/sweep.sh target/release/bpins
    .venv/bin/python examples/night/plot_budget.py [docs/night_budget.csv] [docs/night_budget.png]
"""

import csv
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

REPO = pathlib.Path(__file__).resolve().parents[2]
PUBLISHED_DEG = 0.32
PHASES = ("full", "quarter", "crescent")


def main(table: pathlib.Path, out: pathlib.Path) -> None:
    rows = list(csv.DictReader(open(table)))
    elevations = sorted({(r["phase"], r["elevation_deg"]) for r in rows}, key=lambda x: float(x[1]))
    cmap = plt.get_cmap("viridis")
    fig, axes = plt.subplots(1, 3, figsize=(13.0, 4.6), sharey=True, constrained_layout=True)
    for ax, phase in zip(axes, PHASES):
        mine = [r for r in rows if r["phase"] == phase]
        if not mine:
            ax.set_visible(False)
            continue
        lit = mine[0]["lit"]
        els = sorted({float(r["elevation_deg"]) for r in mine})
        ax.set_title(f"{phase} moon ({lit}) at " + ", ".join(f"{e:.0f}°" for e in els))
        for i, el in enumerate(els):
            colour = cmap(i / max(1, len(els) - 1) * 0.9)
            for glow, style in (("21.8", "-"), ("18.0", "--")):
                pts = [
                    (float(r["exposure_s"]), float(r["median_sigma_deg"]), float(r["rms_error_deg"]))
                    for r in mine
                    if float(r["elevation_deg"]) == el and r["glow_mag_arcsec2"] == glow and r["median_sigma_deg"]
                ]
                if not pts:
                    continue
                x, sigma, rms = zip(*pts)
                label = f"moon at {el:.0f}°" if glow == "21.8" else None
                ax.plot(x, sigma, style, marker=".", color=colour, label=label)
                ax.plot(x, rms, "o" if glow == "21.8" else "x", color=colour, ms=4)
        ax.axhline(PUBLISHED_DEG, color="crimson", lw=1.2)
        ax.text(0.11, PUBLISHED_DEG * 1.08, "published DoFP night compass, 0.32° (CJA 2022)", color="crimson", fontsize=8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(0.08, 5.0)
        ax.set_ylim(0.03, 5.0)
        ax.set_xlabel("exposure (s)")
        ax.grid(True, which="both", alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8, loc="upper right")
        else:
            ax.text(0.5, 0.7, "no frame read up to 4 s", transform=ax.transAxes, ha="center", fontsize=10)
    axes[0].set_ylabel("heading: median 1σ (lines), RMS error (markers), °")
    fig.suptitle(
        "IMX250MZR at f/1.4, 256 × 256 px of 3.45 µm, 1 mm lens (47° field), 8 headings × 2 seeds per point; "
        "dark site 21.8 (solid, ○), city 18.0 mag/arcsec² (dashed, ×); no point: no frame read",
        fontsize=9,
    )
    fig.savefig(out, dpi=80)
    print(f"wrote {out} ({len(rows)} rows, {len(elevations)} phase × elevation pairs)")


if __name__ == "__main__":
    args = sys.argv[1:]
    table = pathlib.Path(args[0]) if args else REPO / "docs/night_budget.csv"
    out = pathlib.Path(args[1]) if len(args) > 1 else REPO / "docs/night_budget.png"
    main(table, out)
