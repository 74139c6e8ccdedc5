#!/usr/bin/env bash
# Clouds by colour (issue 45 item 3): the same partly cloudy skies seen by a colour-
# polarization camera (IMX250MYR tiles, RGGB) and by a monochrome one of the same pixel
# count, 612 × 512 px of 3.45 µm behind the default lens, eight headings × scene seeds
# 1–3 per row. The colour sky is a clear blue one (samples/colour-clear's sky and
# sensor), its clouds white; the mono camera sees the green band's sky.
#
#   examples/colour/clouds.sh [BPINS]     (BPINS: the binary; default `bpins`)
#
# Prints a Markdown table (docs/colour.md, "Clouds by colour"); a few minutes on two
# cores with the release build.
set -euo pipefail
B="${1:-bpins}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
colour=(--colour-tiles RGGB
    --effect sky_spectrum.radiance_r=0.625 --effect sky_spectrum.radiance_b=1.25
    --effect sky_spectrum.dmax_r=1.0571 --effect sky_spectrum.dmax_b=0.8857
    --effect band_response.qe_r=0.8 --effect band_response.qe_b=0.6667
    --effect band_response.eps_r=0.005 --effect band_response.eps_g=0.004 --effect band_response.eps_b=0.0083)
# name | sun azimuth | scene flags
conditions=(
    "bright clouds (defaults)|40|--scene clouds"
    "dim, polarized, turning together|40|--scene clouds.count=6 --scene clouds.coherence=1 --scene clouds.rim=0.5 --scene clouds.min_elevation_deg=45 --scene clouds.radius_min_deg=8 --scene clouds.radius_max_deg=20 --scene clouds.dolp_factor=0.6"
    "bright turned rims, sun at 120°|120|--scene clouds.count=6 --scene clouds.coherence=1 --scene clouds.rim=1 --scene clouds.min_elevation_deg=45 --scene clouds.radius_min_deg=8 --scene clouds.radius_max_deg=20 --scene clouds.dolp_factor=0.6"
    "thin haze-like clouds (×1.1, DoLP ×0.8)|40|--scene clouds.count=10 --scene clouds.brightness=1.1 --scene clouds.dolp_factor=0.8 --scene clouds.coherence=0.9 --scene clouds.min_elevation_deg=30 --scene clouds.radius_min_deg=10 --scene clouds.radius_max_deg=25"
)
echo "| clouds | camera | answered | RMS error (°) | median 1σ (°) | within 2σ | worst \|err\|/σ | cloud cells (median %) |"
echo "|---|---|---:|---:|---:|---:|---:|---:|"
for cond in "${conditions[@]}"; do
    IFS='|' read -r name az flags <<<"$cond"
    for camera in mono colour; do
        files=()
        for seed in 1 2 3; do
            cap="$work/$camera-$seed"
            rm -rf "$cap"
            extra=()
            if [ "$camera" = colour ]; then extra=("${colour[@]}"); fi
            # shellcheck disable=SC2086
            "$B" simulate --out "$cap" --scene-seed "$seed" --seed "$seed" --width-px 612 --height-px 512 \
                --sun-azimuth-deg "$az" --sun-elevation-deg 25 --headings-deg 0,40,80,120,160,200,240,280 \
                $flags "${extra[@]}" >/dev/null 2>"$work/simulate.txt" || { cat "$work/simulate.txt" >&2; exit 1; }
            "$B" heading "$cap" --json "$cap.json" >/dev/null 2>"$work/heading.txt" ||
                { cat "$work/heading.txt" >&2; exit 1; }
            files+=("$cap.json")
        done
        python3 - "$name" "$camera" "${files[@]}" <<'PY'
import json, statistics, sys
name, camera, files = sys.argv[1], sys.argv[2], sys.argv[3:]
rows = [f for p in files for f in json.load(open(p))["frames"]]
# A colour capture's JSON has a row per band and the fused one: the fused is the heading.
rows = [f for f in rows if f.get("band") in (None, "fused")]
ok = [f for f in rows if f["heading_deg"] is not None]
cloud = statistics.median(100 * f["cloud_fraction"] for f in rows if f.get("cloud_fraction") is not None)
if ok:
    rms = (sum(f["error_deg"] ** 2 for f in ok) / len(ok)) ** 0.5
    within = sum(abs(f["error_deg"]) <= 2 * f["sigma_deg"] for f in ok)
    worst = max(abs(f["error_deg"]) / f["sigma_deg"] for f in ok)
    med = statistics.median(f["sigma_deg"] for f in ok)
    print(f"| {name} | {camera} | {len(ok)}/{len(rows)} | {rms:.3f} | {med:.3f} | {within}/{len(ok)} | {worst:.1f} | {cloud:.0f} |")
else:
    print(f"| {name} | {camera} | 0/{len(rows)} | — | — | — | — | {cloud:.0f} |")
PY
    done
done
