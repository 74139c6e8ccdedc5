#!/usr/bin/env bash
# Queues a sweep as a Slurm job array of N slices and a merge that waits for them.
#
#   examples/slurm/submit.sh SWEEP.toml OUT_DIR N [INDICES]
#
# INDICES (default 0-(N-1)) is the array to (re)submit: after a task failed, pass
# only its index (e.g. `3`) to rerun that slice and merge again; the finished slices
# are not recomputed. TRIALS and BACKEND are passed through (see sweep-array.sbatch).
# Prints the array's and the merge's job ids.
#
# The bpins binary the jobs run: $BPINS if set, else `bpins` on PATH, else this
# clone's target/release/bpins (`cargo build --release -p bpins-cli`, about 5 min on
# two cores) or target/debug/bpins; its absolute path is handed to every job, so the
# compute node needs the same path (a shared file system), not bpins on its PATH.
set -euo pipefail
if [ $# -lt 3 ]; then
    echo "usage: $0 SWEEP.toml OUT_DIR N [INDICES]" >&2
    exit 2
fi
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
target="${CARGO_TARGET_DIR:-$repo/target}"
if [ -n "${BPINS:-}" ]; then
    if ! bpins_path="$(command -v "$BPINS")" || [ ! -x "$bpins_path" ]; then
        echo "error: BPINS=$BPINS is not an executable file; build it with \`cargo build --release -p bpins-cli\` (target/release/bpins) or fix the path" >&2
        exit 1
    fi
elif bpins_path="$(command -v bpins)"; then
    :
elif [ -x "$target/release/bpins" ]; then
    bpins_path="$target/release/bpins"
elif [ -x "$target/debug/bpins" ]; then
    bpins_path="$target/debug/bpins"
else
    echo "error: no bpins binary: not on PATH, and neither $target/release/bpins nor $target/debug/bpins exists." >&2
    echo "  build it from $repo with \`cargo build --release -p bpins-cli\` (about 5 min on two cores), or set BPINS=/path/to/bpins" >&2
    exit 1
fi
BPINS="$(cd "$(dirname "$bpins_path")" && pwd)/$(basename "$bpins_path")"
export BPINS
echo "jobs run $BPINS" >&2
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
