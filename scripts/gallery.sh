#!/usr/bin/env bash
# Renders the texturing examples into docs/gallery/ at the scenes' own
# settings: every scene of examples/techniques/ in RGB, the ones whose
# point is spectral also with --color-model spectral, the room in both, the
# texture tree and the physically based materials.
#
#   scripts/gallery.sh            # about two minutes on two cores
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
tslc=target/release/tslc
out=docs/gallery
mkdir -p "$out"

render() { # scene, output name, extra options
    local scene=$1 name=$2
    shift 2
    echo "$name"
    "$tslc" render "$scene" -o "$out/$name.png" --quiet "$@"
}

for scene in examples/techniques/*.tsl; do
    render "$scene" "$(basename "$scene" .tsl)"
done
for name in image_spectral spectral_perturbation smoked_glass rusted_steel; do
    render "examples/techniques/$name.tsl" "${name}_spectral" --color-model spectral
done
render examples/room.tsl room
render examples/room.tsl room_spectral --color-model spectral
render examples/texture_tree.tsl texture_tree
render examples/physical.tsl physical
render examples/open_pbr.tsl open_pbr
render examples/prism.tsl prism --color-model hero
