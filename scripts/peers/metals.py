#!/usr/bin/env python3
"""The stdlib's measured metals in each color model against Mitsuba 3's
spectral render, for compare-peers.sh.

    metals.py TSLC OUT_DIR SKY_MITSUBA.exr [METAL...]

The scene of scripts/peers/materials.py (one unit sphere under the sky of
examples/textures/sky.exr, 128 x 128, path traced to depth 8). For each of
gold, copper, silver and aluminium (stdlib/metals.tsl's AU_ETA, AU_K, ...;
Mitsuba's `material: "Au"` ..., the same luxpop tables), a smooth conductor
and a rough one (GGX, alpha 0.2), the mean per channel over the sphere's
pixels of

- tslc `--color-model rgb`, `spectral` (hero wavelengths) and `spectral64`;
- Mitsuba `scalar_rgb` (which takes the curves' CIE XYZ straight to sRGB);

each against Mitsuba `scalar_spectral` (the spectral integral: the
physically right answer) at SPP (default 256; Mitsuba's spectral render at
twice that). "noise" is two standard errors of tslc's mean, estimated from
two seeds' difference. A smooth sphere mirrors the sun in a handful of
pixels whose sub-pixel coverage alone gives 2.5% noise at 256 spp: its means
leave out the pixels brighter than SUN_LEVEL in any render (the sun's image,
9 of 10184 pixels), so they compare the metal's colour under the sky. The
rest of a mirror has no noise but the pixel filter's (0.01% at 256 spp), so
smooth spheres are rendered at a quarter of SPP. Prints one line per
renderer and case; about eight minutes on two cores.
"""
import math
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from materials import mitsuba_render, sphere_mask, tsl_scene  # noqa: E402

METALS = {"gold": "Au", "copper": "Cu", "silver": "Ag", "aluminium": "Al"}
ROUGH_ALPHA = 0.2
TSL_MODELS = ["rgb", "spectral", "spectral64"]
# Above the sky as these metals mirror it (gold's brightest sky pixel: 1.7);
# the sun's image reaches 600.
SUN_LEVEL = 3.0


def cases(metal, symbol):
    """(name, TSL material, Mitsuba BSDF) for the smooth and the rough sphere."""
    prefix = symbol.upper()
    eta_k = f"eta: {prefix}_ETA, k: {prefix}_K"
    yield f"{metal}", f"conductor({eta_k})", {"type": "conductor", "material": symbol}
    yield (
        f"{metal}_rough",
        f'rough_conductor(alpha: {ROUGH_ALPHA}, distribution: "ggx", {eta_k})',
        {"type": "roughconductor", "material": symbol, "alpha": ROUGH_ALPHA, "distribution": "ggx"},
    )


def main(argv):
    if len(argv) < 4:
        print(__doc__, file=sys.stderr)
        return 2
    import drjit as dr
    import mitsuba as mi
    import numpy as np

    threads = os.environ.get("MITSUBA_THREADS", "2")
    mi.set_variant("scalar_rgb")
    dr.set_thread_count(int(threads))
    tslc, out, sky_mitsuba = argv[1], argv[2], argv[3]
    metals = argv[4:] or list(METALS)
    spp = int(os.environ.get("SPP", "256"))
    os.makedirs(out, exist_ok=True)
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    sky = os.path.join(root, "examples/textures/sky.exr")
    mask = sphere_mask(np)

    def read(image):
        return np.array(mi.Bitmap(image), dtype=np.float64)[..., :3]

    def tsl(scene, name, model, seed, samples):
        image = os.path.join(out, f"{name}_tsl_{model}{samples}_{seed}.exr")
        command = [tslc, "render", scene, "-o", image, "--spp", str(samples), "--seed", str(seed)]
        command += ["--color-model", model, "--threads", threads, "--quiet"]
        subprocess.run(command, check=True)
        return read(image)

    def mitsuba(bsdf, name, variant, samples):
        image = os.path.join(out, f"{name}_mitsuba_{variant}{samples}.exr")
        if not os.path.exists(image):
            mi.set_variant(variant)
            mi.Bitmap(mitsuba_render(mi, bsdf, sky_mitsuba, samples, 1)).write(image)
        return read(image)

    def means(image, pixels):
        return np.array([image[..., c][pixels].mean() for c in range(3)])

    print(f"one sphere under the sky, depth 8, over the sphere's {mask.sum()} pixels: mean per channel")
    print(f"against Mitsuba scalar_spectral at twice the others' spp (the spectral integral): {spp}, smooth {spp // 4}")
    print(f"{'case':16} {'renderer':22} {'R':>7} {'G':>7} {'B':>7} {'noise':>6}")
    for metal in metals:
        for name, material, bsdf in cases(metal, METALS[metal]):
            scene = os.path.join(out, f"{name}.tsl")
            with open(scene, "w") as f:
                f.write(tsl_scene(material, sky))
            smooth = bsdf["type"] == "conductor"
            samples = spp // 4 if smooth else spp
            reference = mitsuba(bsdf, name, "scalar_spectral", 2 * samples)
            rows = [("mitsuba scalar_rgb", mitsuba(bsdf, name, "scalar_rgb", samples), None)]
            pixels = mask
            for model in TSL_MODELS:
                first, second = tsl(scene, name, model, 1, samples), tsl(scene, name, model, 2, samples)
                rows.append((f"tslc {model}", first, second))
            if smooth:
                images = [reference] + [row[1] for row in rows] + [row[2] for row in rows[1:]]
                pixels = mask & (np.max([image.max(-1) for image in images], axis=0) < SUN_LEVEL)
            ref = means(reference, pixels)
            print(f"{name:16} {'mitsuba scalar_spectral':22} " + " ".join(f"{v:7.4f}" for v in ref), end="")
            print(f"  ({mask.sum() - pixels.sum()} pixels of the sun left out)" if pixels is not mask else "")
            for label, first, second in rows:
                image, noise = first, ""
                if second is not None:
                    image = (first + second) / 2
                    # The seeds' difference has twice one render's variance;
                    # their mean, half of it: its standard error is the
                    # difference's over two.
                    error = (first - second)[pixels].std() / 2 / math.sqrt(pixels.sum())
                    noise = f" {2 * error / ref.mean():6.2%}"
                cells = " ".join(f"{m:+7.2%}" for m in means(image, pixels) / ref - 1)
                print(f"{name:16} {label:22} {cells}{noise}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
