#!/bin/sh
# Tests `tslc watch --serve` in headless Chromium: the page shows the image as
# it refines, shows the diagnostics of a broken edit while keeping the image,
# and shows the fixed render, all without reloading (server-sent events).
# Screenshots go to target/watch-serve/.
# Needs Debian's chromium (apt-get install chromium) and npm; playwright-core
# goes into scripts/watch-serve/node_modules (ignored). Not run in CI;
# tests/watch.rs tests the server's answers in cargo test.
# TSLC=path/to/tslc to test a given build (default: a release build).
set -eu
cd "$(dirname "$0")/.."
dir=scripts/watch-serve
if [ ! -d "$dir/node_modules/playwright-core" ]; then
    npm install --no-save --no-audit --no-fund --silent --prefix "$dir" playwright-core@1
fi
if [ -z "${TSLC:-}" ]; then
    cargo build --release --quiet --bin tslc
    TSLC=target/release/tslc
fi
TSLC="$(realpath "$TSLC")" CHROMIUM="${CHROMIUM:-/usr/bin/chromium}" exec node "$dir/test.js"
