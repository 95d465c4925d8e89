#!/usr/bin/env bash
# Render times of this checkout against another revision, side by side in one
# run: each scene is rendered by both builds in turn, REPEATS times, and the
# medians of the render times tslc reports (scene build and compile apart)
# are printed with their ratio.
#
#     scripts/compare-revisions.sh ab5ced4            # the default scenes
#     REPEATS=5 scripts/compare-revisions.sh HEAD~3 "examples/cornell.tsl --spp 16"
#     OTHER_BIN=/tmp/tslc-old scripts/compare-revisions.sh old   # a build kept from before
#     UPDATE_DOCS=1 scripts/compare-revisions.sh ab5ced4          # and write docs/performance.md
#
# The other revision is built (release) in target/compare/REV, a git
# worktree; its build is kept for the next run. With UPDATE_DOCS=1 the table
# also replaces the `compare-revisions` region of docs/performance.md, with
# the date, the commits and the machine's load (scripts/doc-figures.sh).
set -euo pipefail
rev=${1:?usage: compare-revisions.sh REV [SCENE_ARGS...]}
shift
root=$(cd "$(dirname "$0")/.." && pwd)
repeats=${REPEATS:-3}
other="$root/target/compare/$rev"
other_bin=${OTHER_BIN:-$other/target/release/tslc}
if [ -z "${OTHER_BIN:-}" ]; then
    if [ ! -d "$other" ]; then
        mkdir -p "$root/target/compare"
        git -C "$root" worktree add --detach -f "$other" "$rev" >/dev/null
    fi
    # Inside this checkout, cargo would take the other revision for a member
    # of this workspace (whose root member "." covers every folder below it,
    # so `exclude` cannot help): a workspace table of its own keeps it apart.
    if ! grep -q '^\[workspace\]' "$other/Cargo.toml"; then
        printf '\n[workspace]\n' >> "$other/Cargo.toml"
    fi
    (cd "$other" && cargo build --release --quiet)
fi
(cd "$root" && cargo build --release --quiet)
# The scenes as given, for the docs' record of the command.
quoted=""
for scene in "$@"; do quoted+=" \"$scene\""; done
if [ "${UPDATE_DOCS:-0}" = 1 ]; then
    # A page without the region fails now, not after the renders.
    "$root/scripts/doc-figures.sh" --check "$root/docs/performance.md" compare-revisions
fi
if [ $# -eq 0 ]; then
    set -- \
        "examples/techniques/bump_procedural.tsl --res 320x180 --spp 8 --integrator path" \
        "examples/texture_tree.tsl --res 320x240 --spp 8 --integrator path" \
        "examples/room.tsl --res 320x240 --spp 8 --integrator path" \
        "examples/techniques/bump_procedural.tsl --res 320x180 --spp 8 --integrator whitted" \
        "examples/texture_tree.tsl --res 320x240 --spp 8" \
        "examples/cornell.tsl" \
        "examples/whitted.tsl" \
        "examples/procedural.tsl"
fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
seconds() { # BIN ARGS...: the render time tslc reports
    local bin=$1
    shift
    # shellcheck disable=SC2086
    (cd "$root" && "$bin" render $* -o "$out/x.png" 2>&1 | sed -n 's/.* in \([0-9.]*\) s on .*/\1/p')
}
median() { sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
table() {
    printf '%-78s %8s %8s %7s\n' "scene" "$rev" "now" "speed-up"
    for scene in "$@"; do
        before=() after=()
        for _ in $(seq "$repeats"); do
            before+=("$(seconds "$other_bin" "$scene")")
            after+=("$(seconds "$root/target/release/tslc" "$scene")")
        done
        b=$(printf '%s\n' "${before[@]}" | median)
        a=$(printf '%s\n' "${after[@]}" | median)
        printf '%-78s %7ss %7ss %6.2fx\n' "$scene" "$b" "$a" "$(echo "$b / $a" | bc -l)"
    done
}
if [ "${UPDATE_DOCS:-0}" = 1 ]; then
    load_before=$("$root/scripts/doc-figures.sh" --load)
    table "$@" | tee "$out/figures"
    # The revision by its commit, not HEAD~3; the scenes as given.
    described=$(git -C "$root" rev-parse --short "$rev" 2>/dev/null || echo "$rev")
    printf '%s\n' "$rev is $described; medians of $repeats render times each" >>"$out/figures"
    "$root/scripts/doc-figures.sh" "$root/docs/performance.md" compare-revisions --load-before "$load_before" \
        --command "REPEATS=$repeats scripts/compare-revisions.sh $rev$quoted" <"$out/figures"
else
    table "$@"
fi
