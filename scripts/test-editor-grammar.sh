#!/bin/sh
# Tokenizes every example, stdlib file and accepted check fixture with
# vscode-textmate and the grammar in editors/tsl.tmLanguage.json, and fails if a
# keyword, type, number, string or comment gets no scope of its kind.
# Needs node and npm; the packages go into editors/test/node_modules (ignored).
# Not run in CI (CI has no npm step); tests/editor_grammar.rs is.
set -eu
cd "$(dirname "$0")/.."
dir=editors/test
if [ ! -d "$dir/node_modules/vscode-textmate" ] || [ ! -d "$dir/node_modules/vscode-oniguruma" ]; then
    npm install --no-save --no-audit --no-fund --silent --prefix "$dir" vscode-textmate@9 vscode-oniguruma@2
fi
exec node "$dir/tokenize.js" examples stdlib tests/check/ok
