#!/usr/bin/env bash
# Queues a sweep as a Slurm job array of N slices and a merge that waits for them.
#
#   examples/slurm/submit.sh SWEEP.toml OUT_DIR N [INDICES]
#
# INDICES (default 0-(N-1)) is the array to (re)submit: after a task failed, pass
# only its index (e.g. `3`) to rerun that slice and merge again; the finished slices
# are not recomputed. BPINS, TRIALS, BACKEND are passed through (see
# sweep-array.sbatch). Prints the array's and the merge's job ids.
set -euo pipefail
if [ $# -lt 3 ]; then
    echo "usage: $0 SWEEP.toml OUT_DIR N [INDICES]" >&2
    exit 2
fi
here="$(cd "$(dirname "$0")" && pwd)"
sweep="$(cd "$(dirname "$1")" && pwd)/$(basename "$1")"
mkdir -p "$2"
out="$(cd "$2" && pwd)"
n="$3"
indices="${4:-0-$((n - 1))}"
export SWEEP="$sweep" OUT="$out" SHARDS="$n"
array="$(sbatch --parsable --chdir="$out" --array="$indices" --export=ALL "$here/sweep-array.sbatch")"
merge="$(sbatch --parsable --chdir="$out" --dependency="afterok:${array%%;*}" --kill-on-invalid-dep=yes \
    --export=ALL "$here/merge.sbatch")"
echo "array ${array%%;*} merge ${merge%%;*}"
