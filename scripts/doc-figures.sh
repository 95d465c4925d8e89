#!/usr/bin/env bash
# Writes a measuring script's latest figures into a marked region of a page
# (docs/performance.md), so the page shows what the scripts last measured.
#
#     scripts/doc-figures.sh PAGE NAME [--command TEXT] [--load-before LOAD] <figures.txt
#     scripts/doc-figures.sh --check PAGE NAME
#     scripts/doc-figures.sh --load
#
# The region is the lines between
#
#     <!-- figures: NAME -->
#     <!-- end figures: NAME -->
#
# Both marker lines stay; what is between them becomes a line saying when,
# at which commit and on what machine the figures were measured (its CPUs
# and load average; with --load-before, the load average when the run
# began, as `--load` printed it then; with --command, the command that
# measured them), and standard input as a text block. The rest of the page is left byte for byte as it was, and the page
# is replaced in one rename (a temporary file beside it), so a failed or
# interrupted run never leaves half a page. A page without the markers, or
# with either twice, is an error naming the marker; the page is not touched.
#
# `--check` only tells whether the page has the region (the same errors), so
# a measuring script can fail before its run rather than after it. `--load`
# prints the load average (1, 5 and 15 minutes).
#
# Used by scripts/compare-revisions.sh, scripts/compare-peers.sh and
# scripts/bench-figures.sh when UPDATE_DOCS=1; tested by tests/doc_figures.rs.
set -euo pipefail

load() {
    cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || uptime | sed 's/.*load averages*: //; s/,//g'
}

if [[ ${1:-} == --load ]]; then
    load
    exit 0
fi
usage="usage: doc-figures.sh PAGE NAME [--command TEXT] [--load-before LOAD] <figures"
check_only=0
if [[ ${1:-} == --check ]]; then
    check_only=1
    shift
fi
page=${1:?$usage}
name=${2:?$usage}
shift 2
command="" before=""
while (($#)); do
    case $1 in
        --command) command=${2:?--command needs a value}; shift 2 ;;
        --load-before) before=${2:?--load-before needs a value}; shift 2 ;;
        *) echo "doc-figures.sh: unknown option $1" >&2; exit 2 ;;
    esac
done

start_marker="<!-- figures: $name -->"
end_marker="<!-- end figures: $name -->"
[[ -f $page ]] || { echo "error: $page: no such page" >&2; exit 1; }

# The line number of the one line that is exactly $2; an error naming the
# marker when there is none or more than one.
marker_line() { # page marker
    local lines
    lines=$(grep -nxF -e "$2" -- "$1" | cut -d: -f1 || true)
    if [[ -z $lines ]]; then
        echo "error: $1 has no line \`$2\`: add it (and its pair) where these figures go" >&2
        return 1
    fi
    if [[ $lines == *$'\n'* ]]; then
        echo "error: $1 has \`$2\` more than once (lines $(echo "$lines" | paste -sd, -))" >&2
        return 1
    fi
    echo "$lines"
}
first=$(marker_line "$page" "$start_marker")
last=$(marker_line "$page" "$end_marker")
if ((last <= first)); then
    echo "error: $page: \`$end_marker\` (line $last) comes before \`$start_marker\` (line $first)" >&2
    exit 1
fi

((check_only)) && exit 0

figures=$(cat)
root=$(cd "$(dirname "$0")/.." && pwd)
commit=$(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo unknown)
if [[ $commit != unknown && -n $(git -C "$root" status --porcelain --untracked-files=no 2>/dev/null) ]]; then
    commit+=" with uncommitted changes"
fi
cpus=$(nproc 2>/dev/null || getconf _NPROCESSORS_ONLN)
stamp="Last run $(date -u '+%Y-%m-%d %H:%M UTC'), commit $commit, $cpus CPUs, load average"
if [[ -n $before ]]; then
    stamp+=" $before at the start, $(load) at the end"
else
    stamp+=" $(load) at the end"
fi
[[ -z $command ]] || stamp+=", by \`$command\`"

dir=$(dirname "$page")
tmp=$(mktemp "$dir/.$(basename "$page").XXXXXX")
trap 'rm -f "$tmp"' EXIT
{
    head -n "$first" -- "$page"
    printf '%s:\n\n```text\n%s\n```\n' "$stamp" "$figures"
    tail -n +"$last" -- "$page"
} >"$tmp"
chmod --reference="$page" "$tmp" 2>/dev/null || chmod 644 "$tmp"
mv -f "$tmp" "$page"
trap - EXIT
