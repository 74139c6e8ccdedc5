#!/usr/bin/env bash
# The night's error budget (issue 48 item 4): the heading's 1σ and error against the
# moon's phase, the exposure and the night's own glow, for the IMX250MZR at f/1.4
# (bpins simulate's --exposure-s defaults) on 256 × 256 px of 3.45 µm behind a 1 mm
# lens (a 47° field), at 120.38°E. Eight headings × seeds 1–2 per row.
#
#   examples/night/sweep.sh [BPINS]     (BPINS: the binary; default `bpins`)
#
# The moon's elevation is an axis through the latitude (the same instant, so the same
# phase, the moon higher toward the south): LATITUDES (default "20", the table of
# docs/night.md) e.g. "40 20 0 -20". PHASES, GLOWS and EXPOSURES narrow the grid
# (defaults: full quarter crescent; 21.8 18.0; 0.1 0.25 0.5 1 2 4). CSV=FILE also
# writes every row as CSV, for examples/night/plot_budget.py (docs/night_budget.png).
#
# Prints a Markdown table (docs/night.md, "The night's error budget"); seconds on two
# cores per row with the release or the tests' build.
set -euo pipefail
B="${1:-bpins}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
LATITUDES="${LATITUDES:-20}"
PHASES="${PHASES:-full quarter crescent}"
GLOWS="${GLOWS:-21.8 18.0}"
EXPOSURES="${EXPOSURES:-0.1 0.25 0.5 1 2 4}"
CSV="${CSV:-}"
if [ -n "$CSV" ]; then
    echo "phase,lit,elevation_deg,glow_mag_arcsec2,exposure_s,electrons,read,frames,median_sigma_deg,rms_error_deg,reason" >"$CSV"
fi
echo "| moon (lit, elevation) | glow (mag/arcsec²) | exposure (s) | e⁻ per pixel at the zenith | read | median 1σ (°) | RMS error (°) | within 2σ | worst \|err\|/σ |"
echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|"
# Full, first quarter and a crescent, each near 40° (the crescent 30°: it sets soon after the sun).
declare -A TIMES=([full]=2026-06-29T16:00:00Z [quarter]=2026-07-21T12:00:00Z [crescent]=2026-07-19T12:00:00Z)
for lat in $LATITUDES; do
for phase in $PHASES; do
    time="${TIMES[$phase]}"
    for glow in $GLOWS; do
        for exposure in $EXPOSURES; do
            refused=0
            for seed in 1 2; do
                rm -rf "$work/cap"
                "$B" simulate --out "$work/cap" --seed "$seed" --time-utc "$time" \
                    --latitude-deg "$lat" --longitude-deg 120.38 --width-px 256 --height-px 256 \
                    --pixel-pitch-um 3.45 --focal-length-mm 1.0 --exposure-s "$exposure" --f-number 1.4 \
                    --scene night_background --scene "night_background.mag_arcsec2=$glow" \
                    >/dev/null 2>"$work/simulate.txt" || { refused=1; break; }
                # Twilight is modelled now (docs/night.md "Twilight"): a sky the sun lights is no moonlit row.
                grep -q 'sky lit by the moon' "$work/simulate.txt" ||
                    { echo "error: not a moonlit sky ($(grep -m1 -o 'sky lit by [^(]*' "$work/simulate.txt"))" >>"$work/simulate.txt"; refused=1; break; }
                "$B" heading "$work/cap" --json "$work/h$seed.json" >/dev/null 2>"$work/heading.txt" ||
                    { cat "$work/heading.txt" >&2; exit 1; }
            done
            if [ "$refused" = 1 ]; then
                # No moonlit sky at this place and time (twilight, or the moon down): said, skipped.
                echo "$phase at ${lat}°N: $(grep -m1 'error' "$work/simulate.txt")" >&2
                continue
            fi
            # The moon's photons at the zenith, as simulate says them.
            electrons="$(grep -o '[0-9.]* e⁻ per pixel' "$work/simulate.txt" | head -1 | cut -d' ' -f1)"
            python3 - "$phase" "$CSV" "$glow" "$exposure" "$electrons" "$work/h1.json" "$work/h2.json" <<'PY'
import json, re, statistics, sys
phase, csv, glow, exposure, electrons, files = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5], sys.argv[6:]
rows = [f for p in files for f in json.load(open(p))["frames"]]
src = rows[0]["sun"]
# The moon's lit fraction, wherever the source's text says it ("…, 50 % lit, …").
m = re.search(r"(\d+ % lit)", src)
lit = m.group(1) if m else "?"
moon = f"{lit}, {rows[0]['sun_elevation_deg']:.1f}°"
ok = [f for f in rows if f["heading_deg"] is not None]
if ok:
    rms = (sum(f["error_deg"] ** 2 for f in ok) / len(ok)) ** 0.5
    within = sum(abs(f["error_deg"]) <= 2 * f["sigma_deg"] for f in ok)
    worst = max(abs(f["error_deg"]) / f["sigma_deg"] for f in ok)
    med = statistics.median(f["sigma_deg"] for f in ok)
    print(f"| {moon} | {glow} | {exposure} | {electrons} | {len(ok)}/{len(rows)} | {med:.3f} | {rms:.3f} | {within}/{len(ok)} | {worst:.1f} |")
    why, med, rms = "", f"{med:.4f}", f"{rms:.4f}"
else:
    why = rows[0]["no_heading_reason"].split(":")[0]
    print(f"| {moon} | {glow} | {exposure} | {electrons} | 0/{len(rows)} ({why}) | — | — | — | — |")
    med = rms = ""
if csv:
    with open(csv, "a") as f:
        f.write(f"{phase},{lit},{rows[0]['sun_elevation_deg']:.1f},{glow},{exposure},{electrons},{len(ok)},{len(rows)},{med},{rms},{why}\n")
PY
        done
    done
done
done
