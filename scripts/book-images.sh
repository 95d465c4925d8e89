#!/usr/bin/env bash
# Renders the user guide's pictures from the guide's own scenes:
# docs/book/src/scenes/NAME.tsl -> docs/book/src/images/NAME.png (each scene's
# render block keeps them small, ~256 px wide). A scene's first lines may say
# `// render: OPTIONS` for extra `tslc render` options (a colour model, a frame).
#
#   scripts/book-images.sh            # builds tslc (release) first
#   TSLC=path/to/tslc scripts/book-images.sh
set -euo pipefail
cd "$(dirname "$0")/.."

if [[ -z "${TSLC:-}" ]]; then
    cargo build --release --bin tslc
    TSLC="${CARGO_TARGET_DIR:-target}/release/tslc"
fi

mkdir -p docs/book/src/images
for scene in docs/book/src/scenes/*.tsl; do
    name=$(basename "$scene" .tsl)
    options=$(sed -n 's|^// render: ||p' "$scene" | head -n 1)
    # shellcheck disable=SC2086  # the options are words
    "$TSLC" render "$scene" -o "docs/book/src/images/$name.png" --quiet $options
    echo "docs/book/src/images/$name.png"
done
