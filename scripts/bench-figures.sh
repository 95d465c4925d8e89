#!/usr/bin/env bash
# Runs one of the benches and writes its summary into docs/performance.md.
#
#     scripts/bench-figures.sh shading            # cargo bench --bench shading
#     scripts/bench-figures.sh render
#     scripts/bench-figures.sh check
#     scripts/bench-figures.sh shading batch      # a filter: its own region
#
# What the bench prints on standard output (its figures and ratios: cargo's
# own messages go to standard error) replaces the region
# `<!-- figures: bench NAME [FILTER...] -->` of docs/performance.md, with the
# date, the commit and the machine's load (scripts/doc-figures.sh); the rest
# of the page is left as it is. A bench without a region there is refused
# before it runs: add the two marker lines where its figures belong.
# UPDATE_DOCS=0 runs the bench without writing the page.
set -euo pipefail
cd "$(dirname "$0")/.."
bench=${1:?usage: bench-figures.sh BENCH [FILTER...]}
shift
name="bench $bench${*:+ $*}"
page=docs/performance.md
update=${UPDATE_DOCS:-1}
[[ $update != 1 ]] || scripts/doc-figures.sh --check "$page" "$name"
out=$(mktemp)
trap 'rm -f "$out"' EXIT
load=$(scripts/doc-figures.sh --load)
cargo bench --bench "$bench" -- "$@" | tee "$out"
if [[ $update == 1 ]]; then
    scripts/doc-figures.sh "$page" "$name" --load-before "$load" \
        --command "cargo bench --bench $bench${*:+ -- $*}" <"$out"
fi
