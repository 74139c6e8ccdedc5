#!/usr/bin/env bash
# The C library as a C or C++ user links it: `libbpins.a`, `libbpins.so` and
# `bpins.h` in dist/c/ (or the folder given), with the debug information split off
# into debug/libbpins.so.debug instead of inside what the user links.
#
#   scripts/c-dist.sh [OUT_DIR]      # default dist/c; about 3 min on two cores the first time
#
# Why: the release profile keeps line tables (`debug = 1`, for `perf`), and a static
# library carries the Rust standard library's debug information too, so the raw
# target/release/libbpins.a is over 100 MB and a program linked against it tens of
# MB. Here each file is stripped of its debug sections (`strip --strip-debug`: the
# symbols stay, so a backtrace still names functions); the shared library also gets a
# `.gnu_debuglink` to its `.debug` file, which gdb and perf find beside it. Prints the
# sizes before and after.
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-dist/c}"
target="${CARGO_TARGET_DIR:-target}"
for tool in strip objcopy; do
    if ! command -v "$tool" >/dev/null 2>&1; then
        echo "error: $tool not found (binutils; Debian: apt-get install -y binutils)" >&2
        exit 1
    fi
done
echo "building the release library (cargo build --release -p bpins-capi; minutes the first time)..." >&2
cargo build --release --locked -p bpins-capi >&2
mkdir -p "$out/lib" "$out/include" "$out/debug"
cp crates/bpins-capi/include/bpins.h "$out/include/"
size() { du -h "$1" | cut -f1; }
# The static library: its members stripped (a program linked against it carries no
# bpins or std debug information; link target/release/libbpins.a to debug into bpins).
strip --strip-debug -o "$out/lib/libbpins.a" "$target/release/libbpins.a"
echo "libbpins.a: $(size "$target/release/libbpins.a") in $target/release, $(size "$out/lib/libbpins.a") in $out/lib"
# The shared library: stripped, its debug information split into debug/libbpins.so.debug.
objcopy --only-keep-debug "$target/release/libbpins.so" "$out/debug/libbpins.so.debug"
strip --strip-debug -o "$out/lib/libbpins.so" "$target/release/libbpins.so"
(cd "$out/lib" && objcopy --add-gnu-debuglink="../debug/libbpins.so.debug" libbpins.so)
echo "libbpins.so: $(size "$target/release/libbpins.so") in $target/release, $(size "$out/lib/libbpins.so") in $out/lib (debug information: $(size "$out/debug/libbpins.so.debug") in $out/debug)"
