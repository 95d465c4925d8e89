#!/usr/bin/env bash
# Renders the benchmark scenes with tslc and with the established renderers,
# then prints image differences and whole-process times.
#
#   scripts/compare-peers.sh [cornell|whitted|procedural|glossy|envlight|spectral|normal_map|bump|materials|metals|speed|all]
#
# cornell     tslc and Mitsuba 3 at 64 spp against a REF_SPP Mitsuba reference:
#             RMSE and mean, whole image and per object; whole-process times.
# whitted,    tslc against POV-Ray 3.7 (10 camera rays per pixel, and 1):
# procedural  RMSE and mean (whitted), whole-process times.
# glossy      the Cornell box with rough-conductor spheres and floor
#             (examples/glossy.tsl, scripts/peers/glossy.xml);
# envlight    spheres lit only by an HDR sky (examples/envlight.tsl,
#             scripts/peers/envlight.xml, examples/textures/sky.exr). For both:
#             - at 64 spp, RMSE and mean of tslc and of Mitsuba against the
#               reference, whole image and per object (masks from the `object`
#               layer of `tslc render --aov`), and the RMSE ratio tslc/Mitsuba;
#             - tslc and Mitsuba at HIGH_SPP: per-object means against the
#               reference (Mitsuba's shows what an unbiased renderer reaches);
#             - equal time: both renderers at LADDER spp, each process timed,
#               RMSE against time fitted on log-log axes, the RMSE ratio at a
#               common time and the time ratio at a common RMSE, with whole
#               processes and with Mitsuba's start-up (Python, import, scene
#               load) left out (scripts/peers/equal_time.py).
#             Until tslc renders a scene (its materials are issue 10's), the
#             Mitsuba figures are printed alone.
# spectral    the Cornell box in Mitsuba 3's scalar_spectral at SPECTRAL_SPP
#             (default 1024) against tslc's color models at the same spp
#             (spectral = hero, spectral64, spectral16, smits16, rgb): each wall's and
#             block's per-channel mean relative to Mitsuba's; whole-process
#             times; then Mitsuba itself and hero and spectral64 against
#             Mitsuba with the red wall's spectrum fitted exactly
#             (scripts/peers/exact_reflectance.py). Not part of `all`
#             (minutes of rendering).
# normal_map  normal_map against Mitsuba 3's normalmap on a diffuse square
#             (examples/textures/bricks_normal.png; OpenGL, DirectX, strength
#             0.5, and no map): means, mean |difference| and RMSE relative to
#             Mitsuba's mean (scripts/peers/normal_map.py). Not part of `all`.
# bump        bump from a height image against Mitsuba 3's bumpmap on the
#             same square (examples/textures/tiles_height.png; amounts 0.02
#             and 0.1, and no bump): means, mean |difference| and RMSE
#             relative to Mitsuba's mean (scripts/peers/bump.py). Not part of
#             `all`.
# materials   each stdlib physically based material on one sphere under the
#             sky against its Mitsuba 3 plugin: per-channel means at 1024 spp
#             against a 2048-spp Mitsuba reference (REF_SPP and HIGH_SPP
#             there), RMSE of both at 64 spp over four seeds and their ratio
#             (scripts/peers/materials.py; the reference is kept in
#             target/peers/materials). Not part of `all` (ten minutes).
# metals      the stdlib's measured metals (stdlib/metals.tsl: gold, copper,
#             silver, aluminium; smooth and GGX alpha 0.2) in tslc's rgb,
#             spectral and spectral64 models and in Mitsuba's scalar_rgb,
#             per-channel means against Mitsuba's scalar_spectral
#             (scripts/peers/metals.py; SPP there, default 256). Not part of
#             `all` (eight minutes).
#
# speed       issue 33's race: the Cornell box at 512x512, 256 spp, whole
#             processes on THREADS threads, tslc against Mitsuba 3's
#             scalar_rgb and its vectorised llvm_ad_rgb (which JIT-compiles
#             the path tracer into 8-wide kernels), SPEED_RUNS alternating
#             runs each (default 3), medians and ratios; SPEED_RES and
#             SPEED_SPP change the size and samples. Not part of `all`.
#
# Needs: POV-Ray 3.7 (`apt-get install povray`) for whitted and procedural,
# Mitsuba 3 (`pip install mitsuba numpy`) for the others and for reading EXRs;
# its llvm variants need a shared libLLVM 17 or newer, which the speed case
# installs (Debian's libllvm19, when run as root) and points DRJIT_LIBLLVM_PATH at.
# SCENES points at the scene folder (default ../shared/scenes); REF_SPP sets
# the Mitsuba references' samples per pixel (default 4096; each is rendered
# once and kept in target/peers/, delete it to render again); HIGH_SPP the
# tslc high-sample render (default 1024); LADDER the equal-time rungs
# (default "4 8 16 32 64 128 256"); REPEAT how many times each rung runs, the
# least wall time counting (default 3); THREADS the threads of both renderers
# (default 2). Output goes to target/peers/; each ladder's times are in
# target/peers/NAME_ladder.tsv (renderer, spp, wall, render, cpu seconds, image).
#
# UPDATE_DOCS=1 also writes what each scene's comparison printed into its
# region of docs/performance.md (`<!-- figures: compare-peers NAME -->`), with
# the date, the commit and the machine's load (scripts/doc-figures.sh); the
# rest of the page is left as it is.
set -euo pipefail
shopt -s inherit_errexit
cd "$(dirname "$0")/.."
SCENES=${SCENES:-../shared/scenes}
REF_SPP=${REF_SPP:-4096}
HIGH_SPP=${HIGH_SPP:-1024}
LADDER=${LADDER:-"4 8 16 32 64 128 256"}
REPEAT=${REPEAT:-3}
THREADS=${THREADS:-2}
export MITSUBA_THREADS=$THREADS
OUT=target/peers
mkdir -p "$OUT"
which=${1:-all}
case $which in
    cornell | whitted | procedural | glossy | envlight | spectral | normal_map | bump | materials | metals | speed | all) ;;
    *) echo "usage: $0 [cornell|whitted|procedural|glossy|envlight|spectral|normal_map|bump|materials|metals|speed|all]" >&2; exit 2 ;;
esac

UPDATE_DOCS=${UPDATE_DOCS:-0}
PAGE=docs/performance.md
cases=(cornell whitted procedural glossy envlight)
[[ $which == all ]] || cases=("$which")
if [[ $UPDATE_DOCS == 1 ]]; then
    # A page without a region fails now, not after the renders.
    for case in "${cases[@]}"; do
        scripts/doc-figures.sh --check "$PAGE" "compare-peers $case"
    done
fi

cargo build --release --quiet
TSLC=$PWD/target/release/tslc

# Runs one scene's comparison (a function of this script); with
# UPDATE_DOCS=1 what it prints also goes into its region of the page.
figures() { # case function [arguments...]
    local case=$1 load
    shift
    if [[ $UPDATE_DOCS != 1 ]]; then
        "$@"
        return
    fi
    load=$(scripts/doc-figures.sh --load)
    "$@" | tee "$OUT/$case.figures"
    scripts/doc-figures.sh "$PAGE" "compare-peers $case" --load-before "$load" \
        --command "scripts/compare-peers.sh $case" <"$OUT/$case.figures"
}

# Wall-clock seconds of a command (whole process).
timed() {
    local start end
    start=$(date +%s.%N)
    "$@" >/dev/null 2>&1
    end=$(date +%s.%N)
    echo "$end - $start" | bc
}

# Runs a command and prints "WALL RENDER CPU": the seconds of the whole
# process, of the renderer's own rendering (mitsuba_render.py's
# `render_seconds` line, or tslc's summary; "nan" when it printed neither),
# and the process's CPU time (user + system: steadier than wall time on a
# shared machine). Fails, showing the output, when the command fails.
run_timed() {
    local log=$OUT/.run.log times=$OUT/.run.times render wall user sys TIMEFORMAT="%R %U %S"
    if ! { time "$@" >"$log" 2>&1; } 2>"$times"; then
        cat "$log" >&2
        return 1
    fi
    render=$(sed -n -e 's/^render_seconds \([0-9.]*\)$/\1/p' \
        -e 's/.* in \([0-9.]*\) s on [0-9]* threads\{0,1\} .*/\1/p' "$log" | head -1)
    read -r wall user sys <"$times"
    echo "$wall ${render:-nan} $(echo "$user + $sys" | bc)"
}

# run_timed N times; prints the times of the run with the least wall time
# (each, separately, is the least disturbed by other work on the machine).
best_of() { # n command...
    local n=$1 k t best=""
    shift
    for ((k = 0; k < n; k++)); do
        t=$(run_timed "$@")
        if [[ -z $best ]] || (($(echo "${t%% *} < ${best%% *}" | bc))); then
            best=$t
        fi
    done
    echo "$best"
}

mitsuba_render() { # scene.xml out.exr spp seed [name=value...]
    python3 scripts/peers/mitsuba_render.py "$@"
}

# The Mitsuba reference of a scene, rendered once (in the background of
# nothing else: it takes minutes).
reference() { # name scene.xml [name=value...]
    local name=$1 xml=$2 ref=$OUT/$1_ref_${REF_SPP}.exr
    shift 2
    if [[ ! -f $ref ]]; then
        echo "rendering the ${REF_SPP}-spp Mitsuba reference of $name (minutes)" >&2
        nice python3 scripts/peers/mitsuba_render.py "$xml" "$ref" "$REF_SPP" 0 "$@" >/dev/null
    fi
    echo "$ref"
}

cornell() {
    echo "== cornell (path tracing, 64 spp, against a ${REF_SPP}-spp Mitsuba 3 reference)"
    ref=$(reference cornell "$SCENES/cornell/scene.xml")
    t_mi=$(timed mitsuba_render "$SCENES/cornell/scene.xml" "$OUT/cornell_mitsuba64.exr" 64 1)
    t_tsl=$(timed "$TSLC" render examples/cornell.tsl -o "$OUT/cornell_tsl64.exr" --spp 64 --seed 1 --quiet)
    "$TSLC" render examples/cornell.tsl -o "$OUT/cornell_ids.exr" --spp 1 --aov --quiet
    python3 scripts/compare_images.py "$ref" "$OUT/cornell_mitsuba64.exr" "$OUT/cornell_tsl64.exr" \
        --objects "$OUT/cornell_ids.exr" --labels floor,ceiling,back,right,left,small_block,large_block,light
    echo "time: mitsuba ${t_mi}s, tslc ${t_tsl}s"
}
if [[ $which == all || $which == cornell ]]; then
    figures cornell cornell
fi

pov() { # scene dir, out, extra options
    local dir=$1 out=$2
    shift 2
    (cd "$dir" && povray +Iscene.pov +W512 +H512 +WT2 -D "$@" +O"$out")
}

against_povray() { # scene
    local scene=$1 out t_pov t_tsl t_pov1 t_tsl1
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
}
for scene in whitted procedural; do
    [[ $which == all || $which == "$scene" ]] || continue
    figures "$scene" against_povray "$scene"
done

# Fidelity and equal-time figures of a path-traced scene against Mitsuba.
against_mitsuba() { # name labels [mitsuba name=value...]
    local name=$1 labels=$2 xml=scripts/peers/$1.xml tsl=examples/$1.tsl ref
    shift 2
    echo "== $name (path tracing, against a ${REF_SPP}-spp Mitsuba 3 reference; $THREADS threads each)"
    ref=$(reference "$name" "$xml" "$@")
    local tsl_ok=1
    if ! "$TSLC" render "$tsl" -o "$OUT/${name}_ids.exr" --spp 1 --aov --quiet 2>"$OUT/.tsl.log"; then
        tsl_ok=0
        echo "tslc cannot render $tsl yet (first error below): Mitsuba's figures only"
        grep -m1 "error" "$OUT/.tsl.log" || true
    fi
    local t images=("$OUT/${name}_mitsuba64.exr") objects=()
    t=$(run_timed mitsuba_render "$xml" "$OUT/${name}_mitsuba64.exr" 64 1 "$@")
    read -r w r c <<<"$t"
    local times="mitsuba ${w}s (render ${r}s, cpu ${c}s)"
    if ((tsl_ok)); then
        t=$(run_timed "$TSLC" render "$tsl" -o "$OUT/${name}_tsl64.exr" --spp 64 --seed 1 --threads "$THREADS")
        read -r w r c <<<"$t"
        times+=", tslc ${w}s (render ${r}s, cpu ${c}s)"
        images+=("$OUT/${name}_tsl64.exr")
        objects=(--objects "$OUT/${name}_ids.exr" --labels "$labels")
    fi
    echo "-- 64 spp (seed 1) against the reference"
    python3 scripts/compare_images.py "$ref" "${images[@]}" "${objects[@]}"
    echo "time at 64 spp (whole process): $times"
    # Mitsuba's own render at HIGH_SPP (kept) shows how close an unbiased
    # renderer comes at that count: the noise of the means and of the reference.
    local high=("$OUT/${name}_mitsuba${HIGH_SPP}.exr")
    [[ -f ${high[0]} ]] || nice python3 scripts/peers/mitsuba_render.py "$xml" "${high[0]}" "$HIGH_SPP" 3 "$@" >/dev/null
    if ((tsl_ok)); then
        "$TSLC" render "$tsl" -o "$OUT/${name}_tsl${HIGH_SPP}.exr" --spp "$HIGH_SPP" --seed 3 --threads "$THREADS" --quiet
        high+=("$OUT/${name}_tsl${HIGH_SPP}.exr")
    fi
    echo "-- $HIGH_SPP spp (seed 3): means against the reference, whole image and per object"
    python3 scripts/compare_images.py "$ref" "${high[@]}" "${objects[@]}"
    echo "-- equal time: spp ladder $LADDER (seed 2; each time the least of $REPEAT runs)"
    local ladder=$OUT/${name}_ladder.tsv
    : >"$ladder"
    for spp in $LADDER; do
        if ((tsl_ok)); then
            t=$(best_of "$REPEAT" "$TSLC" render "$tsl" -o "$OUT/${name}_tsl_ladder$spp.exr" --spp "$spp" \
                --seed 2 --threads "$THREADS")
            echo "tslc $spp $t $OUT/${name}_tsl_ladder$spp.exr" >>"$ladder"
        fi
        t=$(best_of "$REPEAT" mitsuba_render "$xml" "$OUT/${name}_mitsuba_ladder$spp.exr" "$spp" 2 "$@")
        echo "mitsuba $spp $t $OUT/${name}_mitsuba_ladder$spp.exr" >>"$ladder"
    done
    python3 scripts/peers/equal_time.py "$ref" "$ladder"
}

if [[ $which == all || $which == glossy ]]; then
    figures glossy against_mitsuba glossy floor,ceiling,back,right,left,gold,copper,steel,light
fi

if [[ $which == all || $which == envlight ]]; then
    [[ -f examples/textures/sky.exr ]] || cargo run --release --quiet --example make_sky
    # Mitsuba's lat-long convention differs: convert, and check the match.
    python3 scripts/peers/envmap_for_mitsuba.py examples/textures/sky.exr "$OUT/sky_mitsuba.exr"
    figures envlight against_mitsuba envlight ground,clay,gold,copper,steel "envmap=$PWD/$OUT/sky_mitsuba.exr"
fi

spectral() {
    local spp=${SPECTRAL_SPP:-1024} mi_ref t images image exact_xml exact_ref
    echo "== cornell, spectral (Mitsuba 3 scalar_spectral and tslc's color models, $spp spp)"
    mi_ref="$OUT/cornell_mitsuba_spectral$spp.exr"
    if [[ ! -f $mi_ref ]]; then
        t=$(MITSUBA_VARIANT=scalar_spectral timed mitsuba_render "$SCENES/cornell/scene.xml" "$mi_ref" "$spp" 1)
        echo "time: mitsuba scalar_spectral ${t}s"
    fi
    "$TSLC" render examples/cornell.tsl -o "$OUT/cornell_ids.exr" --spp 1 --aov --quiet
    images=()
    for model in spectral spectral64 spectral16 smits16 rgb; do
        image="$OUT/cornell_tsl_$model$spp.exr"
        t=$(timed "$TSLC" render examples/cornell.tsl -o "$image" --spp "$spp" --seed 1 --color-model "$model" --quiet)
        echo "time: tslc --color-model $model ${t}s"
        images+=("$image")
    done
    python3 scripts/compare_images.py "$mi_ref" "${images[@]}" --objects "$OUT/cornell_ids.exr" \
        --labels floor,ceiling,back,right,left,small_block,large_block,light --per-channel
    # Mitsuba's table lookup renders the saturated red wall's green and blue
    # 0.4% low (its spectrum is off that RGB): again against Mitsuba with
    # the red wall's spectrum fitted exactly in its own pipeline.
    echo "== against Mitsuba with the red wall's reflectance fitted exactly"
    exact_xml="$OUT/cornell_red_exact.xml" exact_ref="$OUT/cornell_mitsuba_spectral_red_exact$spp.exr"
    if [[ ! -f $exact_ref ]]; then
        python3 scripts/peers/exact_reflectance.py "$SCENES/cornell/scene.xml" "$exact_xml" "0.570068, 0.0430135, 0.0443706"
        MITSUBA_VARIANT=scalar_spectral mitsuba_render "$exact_xml" "$exact_ref" "$spp" 1 >/dev/null
    fi
    python3 scripts/compare_images.py "$exact_ref" "$mi_ref" "${images[@]:0:2}" --objects "$OUT/cornell_ids.exr" \
        --labels floor,ceiling,back,right,left,small_block,large_block,light --per-channel
}
if [[ $which == spectral ]]; then
    figures spectral spectral
fi
if [[ $which == normal_map ]]; then
    figures normal_map python3 scripts/peers/normal_map.py "$TSLC" "$OUT/normal_map" 64
fi
if [[ $which == bump ]]; then
    figures bump python3 scripts/peers/bump.py "$TSLC" "$OUT/bump" 64
fi
if [[ $which == materials ]]; then
    [[ -f examples/textures/sky.exr ]] || cargo run --release --quiet --example make_sky
    python3 scripts/peers/envmap_for_mitsuba.py examples/textures/sky.exr "$OUT/sky_mitsuba.exr"
    figures materials python3 scripts/peers/materials.py "$TSLC" "$OUT/materials" "$OUT/sky_mitsuba.exr"
fi
if [[ $which == metals ]]; then
    [[ -f examples/textures/sky.exr ]] || cargo run --release --quiet --example make_sky
    python3 scripts/peers/envmap_for_mitsuba.py examples/textures/sky.exr "$OUT/sky_mitsuba.exr"
    figures metals python3 scripts/peers/metals.py "$TSLC" "$OUT/metals" "$OUT/sky_mitsuba.exr"
fi

# A libLLVM for Mitsuba's llvm variants (Dr.Jit loads it at run time): the
# newest installed that is 17 or later; as root, Debian's libllvm19 when
# there is none.
llvm_library() {
    local lib
    lib=$(ls /usr/lib/*/libLLVM-{21,20,19,18,17}.so /usr/lib/*/libLLVM.so.{21,20,19,18,17}* 2>/dev/null | head -1 || true)
    if [[ -z $lib && $(id -u) == 0 ]] && apt-cache show libllvm19 >/dev/null 2>&1; then
        apt-get install -y --no-install-recommends libllvm19 >/dev/null
        lib=$(ls /usr/lib/*/libLLVM-19.so /usr/lib/*/libLLVM.so.19* 2>/dev/null | head -1 || true)
    fi
    [[ -n $lib ]] || { echo "error: Mitsuba's llvm_ad_rgb needs libLLVM >= 17 (apt-get install libllvm19)" >&2; return 1; }
    echo "$lib"
}

speed() {
    local res=${SPEED_RES:-512} spp=${SPEED_SPP:-256} runs=${SPEED_RUNS:-3} k t
    local -a tsl=() scalar=() llvm=()
    DRJIT_LIBLLVM_PATH=$(llvm_library)
    export DRJIT_LIBLLVM_PATH
    echo "== cornell ${res}x${res}, $spp spp, $THREADS threads: whole-process seconds, $runs alternating runs each"
    for ((k = 0; k < runs; k++)); do
        t=$(run_timed "$TSLC" render examples/cornell.tsl -o "$OUT/speed_tsl.exr" --res "${res}x${res}" \
            --spp "$spp" --seed 1 --threads "$THREADS")
        tsl+=("${t%% *}")
        t=$(MITSUBA_VARIANT=scalar_rgb run_timed mitsuba_render "$SCENES/cornell/scene.xml" "$OUT/speed_scalar.exr" \
            "$spp" 1 "res=$res")
        scalar+=("${t%% *}")
        t=$(MITSUBA_VARIANT=llvm_ad_rgb run_timed mitsuba_render "$SCENES/cornell/scene.xml" "$OUT/speed_llvm.exr" \
            "$spp" 1 "res=$res")
        llvm+=("${t%% *}")
    done
    median() { printf '%s\n' "$@" | sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
    local m_tsl m_scalar m_llvm
    m_tsl=$(median "${tsl[@]}") m_scalar=$(median "${scalar[@]}") m_llvm=$(median "${llvm[@]}")
    echo "tslc ${tsl[*]} s (median $m_tsl)"
    echo "mitsuba scalar_rgb ${scalar[*]} s (median $m_scalar)"
    echo "mitsuba llvm_ad_rgb ${llvm[*]} s (median $m_llvm)"
    echo "tslc / scalar_rgb: $(echo "scale=2; $m_tsl / $m_scalar" | bc)x, tslc / llvm_ad_rgb: $(echo "scale=2; $m_tsl / $m_llvm" | bc)x (goal: at most 0.80x)"
}
if [[ $which == speed ]]; then
    figures speed speed
fi
