#!/bin/sh
# Drives `tslc lsp --stdio` as the VS Code extension does (vscode-jsonrpc, the
# JSON-RPC layer of vscode-languageclient) through the guide's editor
# walk-through: diagnostics appear and disappear, hover on fbm, completion of
# phong(, definition of wood_rings in the prelude, formatting, shutdown.
# Needs node and npm; the packages go into editors/test/node_modules (ignored).
# Not run in CI (CI has no npm step); tests/lsp.rs speaks the same protocol.
# TSLC=path/to/tslc overrides the binary (default: a release build).
set -eu
cd "$(dirname "$0")/.."
dir=editors/test
if [ ! -d "$dir/node_modules/vscode-jsonrpc" ]; then
    npm install --no-save --no-audit --no-fund --silent --prefix "$dir" vscode-jsonrpc@8
fi
if [ -z "${TSLC:-}" ]; then
    cargo build --release --quiet
    TSLC=target/release/tslc
fi
exec node "$dir/lsp.js" "$(realpath "$TSLC")" "$PWD"
