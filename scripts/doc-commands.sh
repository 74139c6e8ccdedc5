#!/usr/bin/env bash
# Runs every shell command the docs show (issue 49): each fenced ```sh, ```bash,
# ```shell and ```console block of README.md and docs/*.md, as written, so that a
# doc cannot drift from the program. .ci/run runs it after the tests, on the
# binaries `cargo test --workspace --locked` built.
#
#   scripts/doc-commands.sh                 # every block of README.md and docs/*.md
#   scripts/doc-commands.sh docs/ros2.md    # the blocks of the files named
#   scripts/doc-commands.sh --list          # the commands and what runs for each; runs nothing
#
# Each file's blocks run in order, as a reader runs them, each block in a bash of
# its own (`set -o pipefail`), from a scratch copy of the repository root (a folder
# of links to its files, so relative outputs such as `--out cal` land there):
#   - `bpins` (on PATH) and `$B` are the tests' binary (target/debug/bpins, or $BPINS);
#   - target/release/ is a stand-in for the release build that CI does not make:
#     its bpins, libbpins.a and libbpins.so are the tests' (target/debug);
#   - /tmp/… in a command is a fresh folder of the file's own;
#   - `cargo` runs in the repository itself.
# A command is a line with its `\` continuations; a console block's commands are its
# `$ ` lines. `bpins run --backend gpu` and `bpins agree` need a GPU adapter (where
# there is none, lavapipe: apt-get install mesa-vulkan-drivers libvulkan1, as .ci/run
# does). About 5 min on two cores. Each block reports ok or FAILED
# with its file and line, a failing command its line and its output's tail; the
# walk ends with the list, and fails if any block failed.
#
# A command that cannot run here by its nature is listed below in EXCEPTIONS by its
# exact text (its trailing `# comment` dropped, continuation lines joined, runs of
# spaces as one), with what runs instead (or nothing) and why. Any other command,
# a new one included, runs as written. An exception that no doc holds any more fails
# the walk, so that the list stays exactly the docs' exceptions.
set -uo pipefail

here="$(cd "$(dirname "$0")/.." && pwd)"
cd "$here" || exit 1

list=0
files=()
for a in "$@"; do
    case "$a" in
    --list) list=1 ;;
    -h | --help)
        sed -n '2,30p' "$0"
        exit 0
        ;;
    -*)
        echo "usage: $0 [--list] [FILE.md...]" >&2
        exit 2
        ;;
    *) files+=("$a") ;;
    esac
done
all_files=0
if [ "${#files[@]}" = 0 ]; then
    files=(README.md docs/*.md)
    all_files=1
fi

# ---------------------------------------------------------------------------------
# EXCEPTIONS: exception 'EXACT COMMAND' 'WHAT RUNS INSTEAD (empty: nothing)' 'WHY'
declare -A instead=() why=() used=()
exception() {
    instead["$1"]="$2"
    why["$1"]="$3"
}
# The Quick start (README.md, docs/install.md).
exception 'cargo run --release -p bpins-cli -- run' \
    '$B run --trials-per-azimuth 2' \
    "the release build is CI's own step in another profile, and 800 trials take minutes; the same Table 3 on the tests' binary with 2 trials per azimuth (newcomer-walk.sh does the same)"
exception 'cargo test --workspace --locked' '' \
    '.ci/run ran it just before this walk'
# Release builds: the tests' build stands in for them (target/release/ above).
exception 'cargo build --release -p bpins-capi' '' \
    "a release build of the C library (minutes); target/release/libbpins.a and libbpins.so are the tests' libraries"
exception 'cargo build --release -p bpins-cli' '' \
    "a release build (minutes); target/release/bpins is the tests' binary"
exception 'examples/c/run.sh' \
    'LIB=target/release/libbpins.a examples/c/run.sh' \
    "run.sh first builds the release library (minutes); LIB gives it the tests' library, as its header shows"
exception 'BPINS_FUZZ_CASES=20000 cargo test --release -p bpins-core --test fuzz_inputs' \
    'BPINS_FUZZ_CASES=20000 cargo test --workspace --locked --test fuzz_inputs' \
    "a release build of bpins-core's tests (minutes); the same cases on the tests' build (--workspace: the tests' features, nothing rebuilt), about a minute"
# What needs something CI does not have.
exception 'pip install -v ./crates/bpins-py' '' \
    "builds a wheel from PyPI's build dependencies; tests/python.rs builds and installs the package into .venv (maturin) and runs its tests, newcomer-walk.sh its quickstart"
exception 'ros2 bag record /cam/image_raw /cam/camera_info /imu/data /gnss/fix -o run1' \
    'bpins simulate --out run1_sim --bag-out run1 --time-utc 2026-06-21T02:30:00Z --latitude-deg 36.07 --longitude-deg 120.38' \
    "needs ROS 2 and a camera; docs/ros2.md's simulated bag has the same topics"
exception 'ros2 bag play run1 run1_bpins' '' \
    'needs ROS 2 (tests/ros.rs reads the bags bpins writes with rosbags)'
exception 'ros2 run rmw_zenoh_cpp rmw_zenohd' '' \
    "needs ROS 2's rmw_zenoh router; tests/ros_node.rs starts a Zenoh router from eclipse-zenoh instead"
exception 'bpins node --bit-depth 12 --black-level-dn 64' '' \
    "runs until stopped, on a robot's graph; tests/ros_node.rs runs it against a router and zenoh-ros2-sdk's publishers and subscriber"
exception 'bpins node --connect tcp/192.168.1.10:7447 --domain-id 3 --sensor sensor.toml --sun-azimuth-deg 140 --sun-elevation-deg 35 --calibration calibration.toml' '' \
    "needs a router at that address and the user's sensor and calibration files; tests/ros_node.rs runs the node on CameraInfo from the graph"
exception 'examples/slurm/submit.sh examples/sweeps/paper-table3.toml /scratch/table3 8' '' \
    "needs a Slurm cluster; tests/slurm.rs and newcomer-walk.sh's Slurm step run submit.sh on a local one-node cluster"
exception 'examples/slurm/submit.sh examples/sweeps/paper-table3.toml /scratch/table3 8 3' '' \
    'needs a Slurm cluster and a failed task to resubmit (tests/slurm.rs resubmits one)'
# ---------------------------------------------------------------------------------

# The exact text of a command: its trailing comment dropped, continuation lines
# joined, runs of blanks as one space.
key_of() {
    printf '%s' "$1" | sed -E ':a;N;$!ba;s/\\\n[[:space:]]*/ /g' |
        sed -E 's/[[:space:]]+#([[:space:]].*)?$//; s/[[:space:]]+/ /g; s/^ //; s/ $//'
}

# blocks FILE: per block "BLOCK<TAB>LINE<TAB>LANG", then per command
# "CMD<TAB>LINE<TAB>TEXT" (continuation lines joined by \037), in order.
blocks() {
    awk '
    function flush() { if (cmd != "") { gsub(/\t/, " ", cmd); print "CMD\t" cline "\t" cmd; cmd = "" } }
    !inb && /^```(sh|bash|shell|console)[[:space:]]*$/ {
        inb = 1; lang = substr($0, 4); sub(/[[:space:]]+$/, "", lang); print "BLOCK\t" NR "\t" lang; cmd = ""; cont = 0; next
    }
    inb && /^```/ { flush(); inb = 0; next }
    inb {
        line = $0
        if (cont) { cmd = cmd "\037" line }
        else {
            if (lang == "console") { if (line !~ /^\$ /) next; line = substr(line, 3) }
            if (line ~ /^[[:space:]]*(#.*)?$/) next
            cmd = line; cline = NR
        }
        cont = (line ~ /\\$/)
        if (!cont) flush()
    }' "$1"
}

if [ "$list" = 1 ]; then
    for f in "${files[@]}"; do
        while IFS=$'\t' read -r kind line text; do
            if [ "$kind" = BLOCK ]; then
                echo "$f:$line ($text)"
                continue
            fi
            cmd="${text//$'\037'/$'\n'}"
            key="$(key_of "$cmd")"
            if [ -n "${why[$key]+x}" ]; then
                if [ -n "${instead[$key]}" ]; then
                    echo "  $line  instead: ${instead[$key]}   ($key: ${why[$key]})"
                else
                    echo "  $line  not run: $key (${why[$key]})"
                fi
            else
                echo "  $line  $key"
            fi
        done < <(blocks "$f")
    done
    exit 0
fi

B="${BPINS:-$here/target/debug/bpins}"
if [ ! -x "$B" ]; then
    echo "no $B: run \`cargo test --workspace --locked\` first (it builds it), or set BPINS" >&2
    exit 1
fi
B="$(cd "$(dirname "$B")" && pwd)/$(basename "$B")"
debug="$(dirname "$B")"

work="$(mktemp -d "${TMPDIR:-/tmp}/bpins-docs.XXXXXX")"
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/bin"
ln -s "$B" "$work/bin/bpins"

# The tests' C library: cargo test leaves it beside the test binaries (deps/).
lib_a="$(ls -t "$debug"/libbpins.a "$debug"/deps/libbpins.a 2>/dev/null | head -n 1)"
lib_so="$(ls -t "$debug"/libbpins.so "$debug"/deps/libbpins.so 2>/dev/null | head -n 1)"

# scratch FILE: a fresh root for FILE's blocks (links to the repository's files, a
# target/ of the tests' build, a /tmp of its own); prints its path.
scratch() {
    local root
    root="$(mktemp -d "$work/root.XXXXXX")"
    local e
    for e in "$here"/* "$here"/.[!.]*; do
        case "$(basename "$e")" in
        target | .git | '.[!.]*') ;;
        *) ln -s "$e" "$root/" ;;
        esac
    done
    mkdir -p "$root/target/release" "$root/.tmp"
    ln -s "$debug" "$root/target/debug"
    ln -s "$B" "$root/target/release/bpins"
    [ -n "$lib_a" ] && ln -s "$lib_a" "$root/target/release/libbpins.a"
    [ -n "$lib_so" ] && ln -s "$lib_so" "$root/target/release/libbpins.so"
    echo "$root"
}

results=()
failed=0
t_walk=$SECONDS
check_stale=$all_files
for f in "${files[@]}"; do
    [ -f "$f" ] || {
        echo "no file $f" >&2
        exit 2
    }
    root="$(scratch "$f")"
    tmp="$root/.tmp"
    script=""
    bline=""
    run_block() {
        [ -n "$bline" ] || return 0
        echo "==> $f:$bline"
        local t0=$SECONDS log="$work/block.log"
        (
            cd "$root" &&
                env B="$B" PATH="$work/bin:$PATH" REPO="$here" CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$here/target}" \
                    timeout 1800 bash -c "$script"
        ) >"$log" 2>&1
        local rc=$? dt=$((SECONDS - t0))
        if [ "$rc" = 0 ]; then
            sed 's/^/    /' "$log" | grep -E '^    (\+ |    not run:)' | cut -c1-160
            results+=("ok       ${dt} s  $f:$bline")
            echo "    ok (${dt} s)"
        else
            sed 's/^/    /' "$log" | tail -n 25
            local at
            at="$(grep -o '^FAILED at line [0-9]*' "$log" | tail -n 1 | grep -o '[0-9]*$')"
            results+=("FAILED   ${dt} s  $f:$bline${at:+ (the command at line $at)}")
            failed=$((failed + 1))
            echo "    FAILED (${dt} s, exit $rc)"
        fi
    }
    while IFS=$'\t' read -r kind line text; do
        if [ "$kind" = BLOCK ]; then
            run_block
            bline="$line"
            script='set -o pipefail
cargo() { (cd "$REPO" && command cargo "$@"); }
'
            continue
        fi
        cmd="${text//$'\037'/$'\n'}"
        key="$(key_of "$cmd")"
        show="$key"
        if [ -n "${why[$key]+x}" ]; then
            used["$key"]=1
            if [ -z "${instead[$key]}" ]; then
                script+="echo $(printf '%q' "    not run: $key (${why[$key]})")"$'\n'
                continue
            fi
            cmd="${instead[$key]}"
            show="$cmd   (instead of: $key)"
        fi
        # /tmp/… → the file's own fresh folder.
        cmd="$(printf '%s' "$cmd" | sed -E "s#(^|[[:space:]=:\"'])/tmp/#\\1$tmp/#g")"
        script+="echo $(printf '%q' "+ line $line: $show")"$'\n'
        script+="$cmd"$'\n'
        script+='rc=$?; if [ $rc != 0 ]; then echo "FAILED at line '"$line"' (exit $rc)"; exit $rc; fi'$'\n'
    done < <(blocks "$f")
    run_block
done

if [ "$check_stale" = 1 ]; then
    for key in "${!why[@]}"; do
        if [ -z "${used[$key]+x}" ]; then
            results+=("FAILED   0 s  exception no doc holds any more: $key")
            failed=$((failed + 1))
        fi
    done
fi

echo
echo "the docs' commands ($((SECONDS - t_walk)) s):"
printf '  %s\n' "${results[@]}"
if [ "$failed" != 0 ]; then
    echo "doc commands: $failed FAILED"
    exit 1
fi
echo "doc commands: every block ran"
