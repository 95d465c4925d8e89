#!/usr/bin/env bash
# Renders the benchmark scenes with tslc and with the established renderers,
# then prints image differences and whole-process times.
#
#   scripts/compare-peers.sh [cornell|whitted|procedural|all]
#
# Needs: POV-Ray 3.7 (`apt-get install povray`) for whitted and procedural,
# Mitsuba 3 (`pip install mitsuba numpy`) for cornell and for reading EXRs.
# SCENES points at the scene folder (default ../shared/scenes); REF_SPP sets
# the Mitsuba reference's samples per pixel for cornell (default 4096).
# Output goes to target/peers/.
set -euo pipefail
cd "$(dirname "$0")/.."
SCENES=${SCENES:-../shared/scenes}
REF_SPP=${REF_SPP:-4096}
OUT=target/peers
mkdir -p "$OUT"
which=${1:-all}

cargo build --release --quiet
TSLC=$PWD/target/release/tslc

# Wall-clock seconds of a command (whole process).
timed() {
    local start end
    start=$(date +%s.%N)
    "$@" >/dev/null 2>&1
    end=$(date +%s.%N)
    echo "$end - $start" | bc
}

mitsuba_render() { # scene.xml out.exr spp seed
    python3 - "$@" <<'PY'
import sys, mitsuba as mi
mi.set_variant("scalar_rgb")
scene = mi.load_file(sys.argv[1], spp=sys.argv[3], seed=sys.argv[4])
mi.Bitmap(mi.render(scene)).write(sys.argv[2])
PY
}

if [[ $which == all || $which == cornell ]]; then
    echo "== cornell (path tracing, 64 spp, against a ${REF_SPP}-spp Mitsuba 3 reference)"
    ref=$OUT/cornell_ref_${REF_SPP}.exr
    [[ -f $ref ]] || mitsuba_render "$SCENES/cornell/scene.xml" "$ref" "$REF_SPP" 0
    t_mi=$(timed mitsuba_render "$SCENES/cornell/scene.xml" "$OUT/cornell_mitsuba64.exr" 64 1)
    t_tsl=$(timed "$TSLC" render examples/cornell.tsl -o "$OUT/cornell_tsl64.exr" --spp 64 --seed 1 --quiet)
    python3 scripts/compare_images.py "$ref" "$OUT/cornell_mitsuba64.exr" "$OUT/cornell_tsl64.exr"
    echo "time: mitsuba ${t_mi}s, tslc ${t_tsl}s"
fi

pov() { # scene dir, out, extra options
    local dir=$1 out=$2
    shift 2
    (cd "$dir" && povray +Iscene.pov +W512 +H512 +WT2 -D "$@" +O"$out")
}

for scene in whitted procedural; do
    [[ $which == all || $which == "$scene" ]] || continue
    echo "== $scene (Whitted, POV-Ray 3.7 +A0.0 +AM1 +R3 -J: 10 camera rays per pixel; tslc --spp 10)"
    out=$PWD/$OUT
    t_pov=$(timed pov "$SCENES/$scene" "$out/${scene}_povray.exr" +FE +A0.0 +AM1 +R3 -J)
    t_tsl=$(timed "$TSLC" render "examples/$scene.tsl" -o "$OUT/${scene}_tsl.exr" --spp 10 --quiet)
    t_pov1=$(timed pov "$SCENES/$scene" "$out/${scene}_povray_1spp.exr" +FE -A)
    t_tsl1=$(timed "$TSLC" render "examples/$scene.tsl" -o "$OUT/${scene}_tsl_1spp.exr" --spp 1 --quiet)
    if [[ $scene == whitted ]]; then
        python3 scripts/compare_images.py "$OUT/${scene}_povray.exr" "$OUT/${scene}_tsl.exr"
    fi
    echo "time, 10 rays/pixel: povray ${t_pov}s, tslc ${t_tsl}s (povray/tslc $(echo "scale=2; $t_pov / $t_tsl" | bc)x)"
    echo "time, 1 ray/pixel:   povray ${t_pov1}s, tslc ${t_tsl1}s (povray/tslc $(echo "scale=2; $t_pov1 / $t_tsl1" | bc)x)"
done
