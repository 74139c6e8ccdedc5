#!/usr/bin/env bash
# Builds the C library, compiles heading.c against it and runs it on the shipped
# frame (f000.u16: samples/clean's frame 0), as the README's C section does.
#
#   examples/c/run.sh                        # release library (first build: minutes)
#   PROFILE=debug examples/c/run.sh          # a debug build (`cargo build -p bpins-capi`)
#   LIB=target/debug/deps/libbpins.a examples/c/run.sh   # a library already built: no cargo
#
# Prints the heading of the frame (truth 0°) with its 1σ.
set -euo pipefail
cd "$(dirname "$0")/../.."
profile="${PROFILE:-release}"
target="${CARGO_TARGET_DIR:-target}"
cc="${CC:-cc}"
if ! command -v "$cc" >/dev/null 2>&1; then
    echo "error: no C compiler \`$cc\` (\$CC or cc); Debian: apt-get install -y gcc libc6-dev" >&2
    exit 1
fi
lib="${LIB:-}"
if [ -z "$lib" ]; then
    flag=()
    if [ "$profile" = release ]; then flag=(--release); fi
    echo "building the C library (cargo build ${flag[*]} -p bpins-capi; the first build takes minutes)..." >&2
    cargo build "${flag[@]}" --locked -p bpins-capi >&2
    lib="$target/$profile/libbpins.a"
fi
if [ ! -f "$lib" ]; then
    echo "error: $lib does not exist; build it with \`cargo build --release -p bpins-capi\`" >&2
    exit 1
fi
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
# -Wl,--gc-sections drops the library's code the program never calls, -Wl,-S its
# debug information (the release library keeps line tables for perf, and the Rust
# standard library's): 56 MB -> 2 MB for this example.
"$cc" -std=c99 -O2 -Icrates/bpins-capi/include examples/c/heading.c "$lib" -lpthread -ldl -lm \
    -Wl,--gc-sections -Wl,-S -o "$out/heading"
echo "compiled $out/heading ($(du -h "$out/heading" | cut -f1)) against $lib ($(du -h "$lib" | cut -f1))" >&2
"$out/heading" examples/c/f000.u16 612 512 12 64 579.7101449275362 305.5 255.5 40 25 0 0 0
