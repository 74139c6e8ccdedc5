#!/usr/bin/env bash
# The diagnosis's heading margin against the field of view (issue 46 item 3,
# docs/diagnose.md "A heading 1σ that carries what the data cannot rule out").
#
#   examples/margin/fov.sh [BPINS] [OUT]   (BPINS: the binary, default target/release/bpins;
#                                           OUT: a new folder for the captures and diagnoses,
#                                           default a temporary one, removed at the end)
#
# For each field of view, SEEDS (default 1–48) clean captures of `samples/clean`'s
# setup (`bpins simulate`'s defaults: 612 × 512 DoFP, 13.8 µm, sun at 40°/25°, eight
# headings 0°…315° on a turntable, no effect: the model is exact) through one lens:
#   pinhole 8 mm       ±27.8° across, 34.5° to a corner (the default, samples/clean)
#   pinhole 4 mm       ±46.6° across, 54.0° to a corner
#   equidistant 3.6 mm ±67.2° across, 87.6° to a corner
#   equidistant 2.7 mm ±89.6° across (the corners, to 117°, below the horizon: masked)
# each diagnosed with `bpins diagnose` at its defaults, one run at a time; then the
# PySkyLumos peer captures of tests/data (one diagnosis each). Prints the table of
# examples/margin/fov_table.py. About 18 min on two cores shared with other builds
# (release build; a diagnosis 2–3 s on an idle core); an OUT given is resumed.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
B="${1:-$root/target/release/bpins}"
SEEDS="${SEEDS:-$(seq 1 48)}"
if [ -n "${2:-}" ]; then
    out="$2"
    mkdir -p "$out"
else
    out="$(mktemp -d)"
    trap 'rm -rf "$out"' EXIT
fi
fovs=(
    "pinhole-8mm:--projection pinhole --focal-length-mm 8"
    "pinhole-4mm:--projection pinhole --focal-length-mm 4"
    "equidistant-3.6mm:--projection equidistant --focal-length-mm 3.6"
    "equidistant-2.7mm:--projection equidistant --focal-length-mm 2.7"
)
# One diagnosis, its wall time (s) written beside its diagnosis.json.
diagnose() {
    local t0 t1
    t0=$(date +%s.%N)
    "$B" diagnose "$1" --out "$2" >"$2.log" 2>&1
    t1=$(date +%s.%N)
    echo "$t0 $t1" | awk '{printf "%.3f\n", $2 - $1}' >"$2/wall_s"
}
for fov in "${fovs[@]}"; do
    name="${fov%%:*}"
    read -r -a opts <<<"${fov#*:}"
    for seed in $SEEDS; do
        cap="$out/$name/seed$seed"
        [ -f "$cap.diag/diagnosis.json" ] && continue
        rm -rf "$cap" "$cap.diag"
        mkdir -p "$out/$name"
        "$B" simulate --seed "$seed" "${opts[@]}" --out "$cap" >"$cap.sim.log" 2>&1
        diagnose "$cap" "$cap.diag"
    done
done
for peer in peer-pyskylumos/rayleigh peer-pyskylumos/rayleigh-stack16 peer-pyskylumos-engine; do
    name="peer/${peer##*/}"
    [ -f "$out/$name.diag/diagnosis.json" ] && continue
    mkdir -p "$out/peer"
    rm -rf "$out/$name.diag"
    diagnose "$root/tests/data/$peer" "$out/$name.diag"
done
echo "machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) cores; load $(cut -d' ' -f1-3 /proc/loadavg); $(date -u +%Y-%m-%dT%H:%MZ)"
python3 "$root/examples/margin/fov_table.py" "$out"
