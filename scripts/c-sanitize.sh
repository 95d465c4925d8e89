#!/usr/bin/env bash
# The C programs of the C ABI (examples/c/host.c, tests/c/threads.c,
# tests/c/render.c) under valgrind's memcheck: no invalid read or write, no
# use of uninitialised memory, no definite leak. About a minute per
# program in a debug build (valgrind runs the JIT compiler too), so it is a
# script rather than a test; `cargo test --test c_host` runs the same
# programs under AddressSanitizer and UBSan in seconds.
#
#   scripts/c-sanitize.sh            # needs valgrind (apt-get install valgrind)
set -euo pipefail
cd "$(dirname "$0")/.."

command -v valgrind >/dev/null || { echo "valgrind is not installed (apt-get install valgrind)" >&2; exit 2; }
cargo build --lib --quiet
lib=$PWD/target/debug
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

status=0
run() {
    local source=$1 name=$2
    shift 2
    cc -std=c99 -g -pthread -Iinclude "$source" -L"$lib" -ltsl -Wl,-rpath,"$lib" -o "$out/$name"
    echo "== $source" >&2
    if ! valgrind --quiet --error-exitcode=9 --leak-check=full --errors-for-leak-kinds=definite --show-possibly-lost=no \
        "$out/$name" "$@" >"$out/$name.stdout"; then
        echo "FAILED: $source under valgrind" >&2
        status=1
    fi
}
run examples/c/host.c host
run tests/c/threads.c threads
run tests/c/render.c render examples/cornell.tsl
[ $status = 0 ] && echo "valgrind: all C programs clean" >&2
exit $status
