#!/usr/bin/env bash
# The newcomer's first hour with bpins, walked as the README writes it (issue 35):
# the Quick start's commands, a closed pipe, the umask, the Python quickstart, the C
# example and the Slurm example. Each step says what it did, how long it took, and
# what to do when it failed; the end lists every step.
#
#   scripts/newcomer-walk.sh            # cheap: the binaries `cargo test --workspace
#                                       # --locked` built (target/debug), about a minute;
#                                       # .ci/run runs this after the tests
#   scripts/newcomer-walk.sh --fresh    # faithful: a fresh clone of HEAD in a temporary
#                                       # folder, the README's two commands with release
#                                       # builds, `pip install -v`, the C example's release
#                                       # library: about 30 min on two cores, with the
#                                       # time and the disk each step took
#
# A step whose tool is missing (no .venv, no C compiler, no Slurm or not root) is
# reported as skipped, with the install command; with CI set it fails instead.
set -uo pipefail

here="$(cd "$(dirname "$0")/.." && pwd)"
fresh=0
case "${1:-}" in
--fresh) fresh=1 ;;
"") ;;
-h | --help)
    sed -n '2,17p' "$0"
    exit 0
    ;;
*)
    echo "usage: $0 [--fresh]" >&2
    exit 2
    ;;
esac

work="$(mktemp -d "${TMPDIR:-/tmp}/bpins-walk.XXXXXX")"
cluster=""
cleanup() {
    if [ -n "$cluster" ]; then "$repo/examples/slurm/local-cluster.sh" stop "$cluster" >/dev/null 2>&1 || true; fi
    rm -rf "$work"
}
trap cleanup EXIT

results=()
failed=0
log="$work/step.log"

# step NAME HINT COMMAND...: runs COMMAND (a shell function), times it, records the result.
step() {
    local name="$1" hint="$2"
    shift 2
    echo "==> $name"
    local t0=$SECONDS
    "$@" >"$log" 2>&1
    local rc=$? dt=$((SECONDS - t0))
    sed 's/^/    /' "$log" | tail -n 15
    if [ "$rc" = 0 ]; then
        results+=("ok       ${dt} s  $name")
        echo "    ok (${dt} s)"
    elif [ "$rc" = 77 ]; then
        results+=("skipped  ${dt} s  $name: $(tail -n 1 "$log")")
        echo "    skipped (${dt} s)"
    else
        results+=("FAILED   ${dt} s  $name: $hint")
        failed=$((failed + 1))
        echo "    FAILED (${dt} s, exit $rc): $hint"
    fi
}

# skip WHY: a step that cannot run here (exit 77), or a failure with CI set.
skip() {
    if [ -n "${CI:-}" ]; then
        echo "CI is set and this step cannot run: $1"
        return 1
    fi
    echo "$1"
    return 77
}

if [ "$fresh" = 1 ]; then
    repo="$work/bpins"
    echo "==> a fresh clone of $(git -C "$here" rev-parse --short HEAD) in $repo (uncommitted changes are not in it)"
    git clone --quiet "$here" "$repo" || exit 1
    export CARGO_TARGET_DIR="$repo/target"
else
    repo="$here"
fi
cd "$repo" || exit 1
target="${CARGO_TARGET_DIR:-$repo/target}"

readme_commands() {
    # The README's two commands, and .ci/run running exactly the second.
    grep -qxF 'cargo run --release -p bpins-cli -- run' README.md || { echo "README lacks the first command"; return 1; }
    grep -qxF 'cargo test --workspace --locked' README.md || { echo "README lacks the test command"; return 1; }
    grep -qxF 'cargo test --workspace --locked' .ci/run || { echo ".ci/run does not run the README's test command"; return 1; }
    echo "the README's two commands are there, and .ci/run runs the second"
}
step "the README's commands" "README.md's Quick start must show both commands" readme_commands

if [ "$fresh" = 1 ]; then
    first_command() {
        cargo run --release -p bpins-cli -- run | tee "$work/table3.txt"
        grep -q "Azimuth error over the trials" "$work/table3.txt"
        echo "target/ after the first command: $(du -sh "$target" | cut -f1)"
    }
    step "cargo run --release -p bpins-cli -- run (build and 800 trials)" \
        "see the build error above; Rust 1.88 or newer is needed" first_command
    test_command() {
        cargo test --workspace --locked 2>&1 | tee "$work/tests.txt" | grep -E '^test result|ignored|^error' | tail -n 40
        local rc=${PIPESTATUS[0]}
        echo "tests: $(grep -c '^test result' "$work/tests.txt") test binaries; target/ now $(du -sh "$target" | cut -f1)"
        return "$rc"
    }
    step "cargo test --workspace --locked" "a test failed: its output is above" test_command
    B="$target/release/bpins"
else
    B="${BPINS:-$target/debug/bpins}"
    have_binary() {
        if [ ! -x "$B" ]; then
            echo "no $B: run \`cargo test --workspace --locked\` first (it builds it), or set BPINS"
            return 1
        fi
        "$B" --version
    }
    step "the binary the tests built" "build it with cargo test --workspace --locked" have_binary
    table3() {
        # The README's first command runs 800 trials on a release build; here the
        # tests' build and 2 trials per azimuth: the same table, seconds not minutes.
        "$B" run --trials-per-azimuth 2 | tee "$work/table3.txt"
        grep -q "Azimuth error over the trials" "$work/table3.txt"
    }
    step "Table 3 (bpins run, 2 trials per azimuth)" "bpins run failed: its message is above" table3
fi

more_commands() {
    "$B" effects >/dev/null &&
        "$B" simulate --out "$work/cap" --effect array_rotation.dtheta_deg=0.3 &&
        "$B" heading "$work/cap" --extractor all --json "$work/heading.json" | tail -n 3 &&
        "$B" heading samples/clean | tail -n 2 &&
        test -s "$work/heading.json"
}
step "the README's \"More\" commands (effects, simulate, heading)" "the failing command's message is above" more_commands

closed_pipe() {
    local cmd
    for cmd in "effects" "heading samples/clean" "effects --json"; do
        # shellcheck disable=SC2086 # the words of cmd are its arguments
        "$B" $cmd 2>"$work/pipe.err" | head -n 1 >/dev/null
        local rc=${PIPESTATUS[0]}
        if [ "$rc" != 0 ] || grep -q -e panicked -e "Broken pipe" "$work/pipe.err"; then
            echo "bpins $cmd | head: exit $rc"
            cat "$work/pipe.err"
            return 1
        fi
        echo "bpins $cmd | head -n 1: exit 0, nothing on stderr about the pipe"
    done
}
step "a closed pipe (bpins … | head)" "a command panicked or failed under a closed pipe" closed_pipe

umask_modes() {
    (umask 022 && "$B" simulate --out "$work/u022" --width-px 100 --height-px 80 --headings-deg 0) || return 1
    local mode
    mode="$(stat -c %a "$work/u022/capture.toml")"
    echo "under umask 022 capture.toml has mode $mode"
    [ "$mode" = 644 ]
}
step "outputs honour the umask" "outputs must get 0666 less the umask" umask_modes

python_quickstart() {
    local py="$repo/.venv/bin/python"
    if [ "$fresh" = 1 ]; then
        python3 -m venv "$work/venv" || return 1
        py="$work/venv/bin/python"
        local t0=$SECONDS
        "$py" -m pip install -q --upgrade pip && "$py" -m pip install -v ./crates/bpins-py >"$work/pip.txt" 2>&1 || {
            tail -n 30 "$work/pip.txt"
            return 1
        }
        echo "pip install -v ./crates/bpins-py: $((SECONDS - t0)) s ($(grep -c 'Compiling' "$work/pip.txt") crates compiled, each shown with -v)"
    elif [ ! -x "$py" ] || ! "$py" -c "import bpins" 2>/dev/null; then
        skip "no bpins in .venv (cargo test's python.rs installs it there; make .venv with: python3 -m venv .venv && .venv/bin/pip install -r crates/bpins-py/requirements-test.txt)"
        return
    fi
    "$py" examples/python/quickstart.py | tee "$work/quickstart.txt"
    grep -q "truth 30°" "$work/quickstart.txt"
}
step "the Python quickstart" "see the Python error above; the README's From Python section installs the package" python_quickstart

c_example() {
    if ! command -v "${CC:-cc}" >/dev/null 2>&1; then
        skip "no C compiler (apt-get install -y gcc libc6-dev)"
        return
    fi
    if [ "$fresh" = 1 ]; then
        examples/c/run.sh | tee "$work/c.txt" || return 1
        echo "libbpins.a: $(du -h "$target/release/libbpins.a" | cut -f1), libbpins.so: $(du -h "$target/release/libbpins.so" | cut -f1)"
    else
        local lib
        lib="$(ls -t "$target"/debug/deps/libbpins*.a "$target"/debug/libbpins.a 2>/dev/null | head -n 1)"
        if [ -z "$lib" ]; then
            echo "no libbpins.a under $target/debug: cargo test --workspace --locked builds it"
            return 1
        fi
        LIB="$lib" examples/c/run.sh | tee "$work/c.txt" || return 1
    fi
    grep -q "^heading_deg " "$work/c.txt"
}
step "the C example (examples/c/run.sh on the shipped frame)" "see the compiler's or the example's message above" c_example

slurm_example() {
    local b
    for b in munged slurmctld slurmd sbatch squeue; do
        if ! command -v "$b" >/dev/null 2>&1 && [ ! -x "/usr/sbin/$b" ]; then
            skip "no $b (apt-get install -y slurm-wlm munge)"
            return
        fi
    done
    if [ "$(id -u)" != 0 ]; then
        skip "the local cluster runs its daemons as root"
        return
    fi
    cluster="$work/cluster"
    local port=$((21000 + RANDOM % 4000 * 2)) conf
    conf="$(examples/slurm/local-cluster.sh start "$cluster" "$port")" || return 1
    export SLURM_CONF="${conf#export SLURM_CONF=}"
    # As the README writes it: no BPINS, and no bpins on PATH; submit.sh finds this
    # clone's build.
    local ids
    ids="$(env -u BPINS PATH=/usr/sbin:/usr/bin:/bin examples/slurm/submit.sh examples/sweeps/tiny.toml "$work/slurm" 3)" || return 1
    echo "$ids"
    local job
    job="$(echo "$ids" | awk '{print $2 "," $4}')"
    local i
    for i in $(seq 240); do
        [ -z "$(squeue -h -j "$job" 2>/dev/null)" ] && break
        sleep 0.5
    done
    if [ ! -s "$work/slurm/merged/summary.json" ]; then
        echo "no merged summary; the jobs' logs:"
        tail -n 5 "$work/slurm"/*.log
        return 1
    fi
    echo "3 slices and their merge ran; $work/slurm/merged/summary.json written"
}
step "the Slurm example (local-cluster.sh, submit.sh)" "see the jobs' logs above" slurm_example

echo
echo "newcomer walk ($([ "$fresh" = 1 ] && echo "fresh clone, release builds" || echo "the tests' binaries")):"
printf '  %s\n' "${results[@]}"
if [ "$failed" != 0 ]; then
    echo "newcomer walk: $failed step(s) failed"
    exit 1
fi
echo "newcomer walk: every step ok or skipped as listed"
