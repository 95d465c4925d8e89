#!/bin/sh
# The editor walk-through of the guide (docs/book/src/tutorial/editors.md) in a real editor: headless Neovim (0.7 or
# newer; Debian's `apt-get install neovim`) with its built-in LSP client and
# `tslc lsp`, on examples/texture_tree.tsl (the buffer is never written).
# Diagnostics appear and clear as a line is edited, hover on `fbm`, completion
# and signature help in `phong(`, definition of `wood_rings` in the prelude,
# formatting. Not run in CI; tests/lsp.rs speaks the same JSON-RPC in cargo test.
# TSLC=path/to/tslc to test a given build (default: a release build).
set -eu
cd "$(dirname "$0")/.."
if [ -z "${TSLC:-}" ]; then
    cargo build --release --quiet --bin tslc
    TSLC=target/release/tslc
fi
TSLC="$(realpath "$TSLC")" TSL_FILE="$(realpath examples/texture_tree.tsl)" \
    exec nvim --headless -n -u NONE -c "luafile scripts/editor-nvim/walkthrough.lua"
