#!/usr/bin/env python3
"""Every stdlib physically based material against its Mitsuba 3 plugin, for
compare-peers.sh.

    materials.py TSLC OUT_DIR SKY_MITSUBA.exr [NAME...]

One unit sphere at the origin under the HDR sky of examples/textures/sky.exr
(a small, very bright sun above a blue sky; SKY_MITSUBA.exr is its copy in
Mitsuba's lat-long convention, scripts/peers/envmap_for_mitsuba.py), seen
from (0, 0.3, 3.2), 128 x 128, path traced to depth 8, 2 threads each. Each
material is given the same parameters on both sides (gold as Mitsuba's RGB
variants hold it). For each:

- the reference: Mitsuba at REF_SPP (default 2048), kept in OUT_DIR;
- mean: tslc at HIGH_SPP (default 1024) against the reference, per channel,
  over the sphere's pixels (those whose corners all see the sphere), the
  issue's goal being within 1%; "noise" is two standard errors of that
  difference, estimated from both renderers' 64-spp errors scaled to the
  sample counts (a sun mirrored by a delta lobe chosen at random makes a
  few pixels carry most of the variance: then only more samples tell);
- rmse: tslc and Mitsuba at 64 spp against the reference over the sphere,
  the root of the mean squared error over SEEDS renders each (default 4: a
  sun's glossy highlight puts most of the error in a dozen pixels, so one
  render's RMSE varies by 20% from seed to seed), and their ratio
  tslc/Mitsuba (the goal: at most 1.2).

Materials with a smooth lobe chosen at random (plastic, conductor, glass)
render both at SMOOTH_FACTOR (8) times those counts, and their RMSE over
SMOOTH_FACTOR times the seeds: a sun mirrored by a delta lobe puts nearly
all their variance in a handful of pixels (the conductor's in 4: one
render's squared error varies 30-fold from seed to seed), so at the
default counts the means' noise is 1-2% and four seeds' RMSE ratio
anywhere in 0.6-1.4 (measured: the conductor 1.38 over seeds 1-4, 0.97
over 1-32).

NAME picks materials (default: all). Prints one line per material.
"""
import hashlib
import json
import math
import os
import subprocess
import sys

SIZE = 128
FOV = 40.0
EYE = (0.0, 0.3, 3.2)
GOLD_ETA = (0.143036, 0.375307, 1.44205)
GOLD_K = (3.983, 2.38556, 1.60336)
RED = (0.7, 0.3, 0.2)
DEPTH = int(os.environ.get("DEPTH", "8"))
SEEDS = int(os.environ.get("SEEDS", "4"))
SMOOTH_FACTOR = 8
# Materials whose delta lobe mirrors the sun (see the module's docs).
SMOOTH = {"plastic", "plastic_nonlinear", "conductor", "glass", "open_pbr_thin_walled"}


def rgb(c):
    return f"rgb({c[0]}, {c[1]}, {c[2]})"


def mi_rgb(c):
    return {"type": "rgb", "value": list(c)}


# name -> (TSL material expression, Mitsuba BSDF dict)
MATERIALS = {
    "diffuse": (f"lambert(kd: {rgb(RED)})", {"type": "diffuse", "reflectance": mi_rgb(RED)}),
    "plastic": (
        f"plastic(diffuse_reflectance: {rgb(RED)})",
        {"type": "plastic", "diffuse_reflectance": mi_rgb(RED)},
    ),
    "plastic_nonlinear": (
        f"plastic(diffuse_reflectance: {rgb(RED)}, nonlinear: true)",
        {"type": "plastic", "diffuse_reflectance": mi_rgb(RED), "nonlinear": True},
    ),
    "rough_plastic_0.1": (
        f"rough_plastic(diffuse_reflectance: {rgb(RED)}, alpha: 0.1)",
        {"type": "roughplastic", "diffuse_reflectance": mi_rgb(RED), "alpha": 0.1, "distribution": "beckmann"},
    ),
    "rough_plastic_0.4_ggx_nl": (
        f'rough_plastic(diffuse_reflectance: {rgb(RED)}, alpha: 0.4, distribution: "ggx", nonlinear: true)',
        {
            "type": "roughplastic",
            "diffuse_reflectance": mi_rgb(RED),
            "alpha": 0.4,
            "distribution": "ggx",
            "nonlinear": True,
        },
    ),
    "conductor": (
        f"conductor(eta: {rgb(GOLD_ETA)}, k: {rgb(GOLD_K)})",
        {"type": "conductor", "eta": mi_rgb(GOLD_ETA), "k": mi_rgb(GOLD_K)},
    ),
    "rough_conductor": (
        f'rough_conductor(alpha: 0.2, distribution: "ggx", eta: {rgb(GOLD_ETA)}, k: {rgb(GOLD_K)})',
        {"type": "roughconductor", "alpha": 0.2, "distribution": "ggx", "eta": mi_rgb(GOLD_ETA), "k": mi_rgb(GOLD_K)},
    ),
    "rough_conductor_aniso": (
        f"rough_conductor(alpha_u: 0.05, alpha_v: 0.3, eta: {rgb(GOLD_ETA)}, k: {rgb(GOLD_K)})",
        {
            "type": "roughconductor",
            "alpha_u": 0.05,
            "alpha_v": 0.3,
            "distribution": "beckmann",
            "eta": mi_rgb(GOLD_ETA),
            "k": mi_rgb(GOLD_K),
        },
    ),
    "glass": ("glass(ior: gray(1.5))", {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0}),
    "rough_dielectric_0.1": (
        'rough_dielectric(alpha: 0.1, distribution: "ggx")',
        {"type": "roughdielectric", "alpha": 0.1, "distribution": "ggx"},
    ),
    "rough_dielectric_0.3": (
        "rough_dielectric(alpha: 0.3)",
        {"type": "roughdielectric", "alpha": 0.3, "distribution": "beckmann"},
    ),
    # open_pbr_surface's limiting cases: a white metal (F82 with both colors
    # white reflects everything, as Mitsuba's "none"), the base alone, and a
    # coat over the base (coat_darkening 1, the default: the light bouncing
    # inside the coat darkens the base, as roughplastic's `nonlinear`).
    "open_pbr_metal": (
        "open_pbr_surface(base_color: gray(1), base_metalness: 1, specular_roughness: 0.4472136)",
        {"type": "roughconductor", "alpha": 0.2, "distribution": "ggx", "material": "none"},
    ),
    # The translucent base alone: roughdielectric (alpha = roughness^2).
    "open_pbr_dielectric": (
        "open_pbr_surface(transmission_weight: 1, specular_roughness: 0.5477226)",
        {"type": "roughdielectric", "alpha": 0.3, "distribution": "ggx", "int_ior": 1.5, "ext_ior": 1.0},
    ),
    # A thin wall of the translucent base, smooth: a sheet with both
    # interfaces' bounces summed, as thindielectric.
    "open_pbr_thin_walled": (
        "open_pbr_surface(transmission_weight: 1, specular_roughness: 0, geometry_thin_walled: true)",
        {"type": "thindielectric", "int_ior": 1.5, "ext_ior": 1.0},
    ),
    "open_pbr_base_only": (
        f"open_pbr_surface(base_color: {rgb(RED)}, specular_weight: 0)",
        {"type": "diffuse", "reflectance": mi_rgb(RED)},
    ),
    "open_pbr_coat_over_base": (
        f"open_pbr_surface(base_color: {rgb(RED)}, specular_weight: 0, coat_weight: 1, coat_roughness: 0.3162278, "
        "coat_ior: 1.49)",
        {
            "type": "roughplastic",
            "diffuse_reflectance": mi_rgb(RED),
            "alpha": 0.1,
            "distribution": "ggx",
            "int_ior": 1.49,
            "ext_ior": 1.0,
            "nonlinear": True,
        },
    ),
}


def tsl_scene(material, sky):
    return f"""
material sample = {material};

scene {{
    camera {{ from {EYE}; to (0, 0, 0); up (0, 1, 0); fov {FOV}; }}
    render {{ width {SIZE}; height {SIZE}; max_depth {DEPTH}; integrator "path"; }}
    light environment {{ file "{sky}"; scale 1; }}
    object sphere {{ center (0, 0, 0); radius 1; material sample; }}
}}
"""


def mitsuba_render(mi, bsdf, sky, spp, seed):
    scene = mi.load_dict(
        {
            "type": "scene",
            "integrator": {"type": "path", "max_depth": DEPTH, "rr_depth": 5},
            "sensor": {
                "type": "perspective",
                "fov_axis": "x",
                "fov": FOV,
                "to_world": mi.ScalarTransform4f().look_at(origin=list(EYE), target=[0, 0, 0], up=[0, 1, 0]),
                "film": {"type": "hdrfilm", "width": SIZE, "height": SIZE, "rfilter": {"type": "box"}},
                "sampler": {"type": "independent", "sample_count": spp, "seed": seed},
            },
            # Mitsuba's lat-long map is TSL's turned half a turn about y
            # (scripts/peers/envlight.xml says why).
            "sky": {"type": "envmap", "filename": sky, "to_world": mi.ScalarTransform4f().rotate([0, 1, 0], 180)},
            # Poles on y as TSL's sphere has them (Mitsuba's are on z), so
            # dPdu, which orients anisotropic roughness, is the same.
            "ball": {"type": "sphere", "to_world": mi.ScalarTransform4f().rotate([1, 0, 0], -90), "bsdf": bsdf},
        }
    )
    return mi.render(scene)


def sphere_mask(np):
    """Pixels whose four corners all see the unit sphere (no edge pixels)."""
    eye = np.array(EYE)
    forward = -eye / np.linalg.norm(eye)
    right = np.cross(forward, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    t = math.tan(math.radians(FOV) / 2)
    edges = np.linspace(-1.0, 1.0, SIZE + 1) * t
    x, y = np.meshgrid(edges, -edges)
    d = forward + x[..., None] * right + y[..., None] * up
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    b = d @ eye
    hits = b * b - (eye @ eye - 1.0) > 0
    return hits[:-1, :-1] & hits[1:, :-1] & hits[:-1, 1:] & hits[1:, 1:]


def main(argv):
    if len(argv) < 4:
        print(__doc__, file=sys.stderr)
        return 2
    import drjit as dr
    import mitsuba as mi
    import numpy as np

    mi.set_variant("scalar_rgb")
    dr.set_thread_count(int(os.environ.get("MITSUBA_THREADS", "2")))
    threads = os.environ.get("MITSUBA_THREADS", "2")
    tslc, out, sky_mitsuba = argv[1], argv[2], argv[3]
    names = argv[4:] or list(MATERIALS)
    ref_spp = int(os.environ.get("REF_SPP", "2048"))
    high_spp = int(os.environ.get("HIGH_SPP", "1024"))
    os.makedirs(out, exist_ok=True)
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    sky = os.path.join(root, "examples/textures/sky.exr")
    mask = sphere_mask(np)

    def tsl_render(scene, name, spp, seed):
        image = os.path.join(out, f"{name}_tsl{spp}_{seed}.exr")
        command = [tslc, "render", scene, "-o", image, "--spp", str(spp), "--seed", str(seed)]
        subprocess.run(command + ["--threads", threads, "--quiet"], check=True)
        return np.array(mi.Bitmap(image), dtype=np.float64)[..., :3]

    def mitsuba(bsdf, name, spp, seed):
        # The cached reference is named by its parameters too: a case whose
        # Mitsuba side changed renders a new one.
        key = hashlib.sha1(json.dumps(bsdf, sort_keys=True).encode()).hexdigest()[:10]
        image = os.path.join(out, f"{name}_mitsuba{spp}_{seed}_{key}.exr")
        if not (spp >= ref_spp and os.path.exists(image)):
            mi.Bitmap(mitsuba_render(mi, bsdf, sky_mitsuba, spp, seed)).write(image)
        return np.array(mi.Bitmap(image), dtype=np.float64)[..., :3]

    def mse(image, ref):
        return ((image - ref)[mask] ** 2).mean()

    print(f"one sphere under the sky, {SIZE}x{SIZE}, depth 8; over the sphere's {mask.sum()} pixels:")
    print(
        f"mean: tslc {high_spp} spp per channel against Mitsuba {ref_spp} spp, {SMOOTH_FACTOR} times both for "
        "plastic, conductor, glass and the thin wall (goal: within 1%)"
    )
    print("rmse: tslc and Mitsuba 64 spp against the reference, and tslc/Mitsuba (goal: at most 1.2)")
    print(
        f"{'material':26} {'mean R':>7} {'mean G':>7} {'mean B':>7} {'noise':>6} "
        f"{'rmse tslc':>10} {'mitsuba':>8} {'ratio':>6}"
    )
    for name in names:
        material, bsdf = MATERIALS[name]
        scene = os.path.join(out, f"{name}.tsl")
        with open(scene, "w") as f:
            f.write(tsl_scene(material, sky))
        factor = SMOOTH_FACTOR if name in SMOOTH else 1
        ref = mitsuba(bsdf, name, ref_spp * factor, 100)
        high = tsl_render(scene, name, high_spp * factor, 100)
        means = [high[..., c][mask].mean() / ref[..., c][mask].mean() - 1 for c in range(3)]
        seeds = range(1, SEEDS * factor + 1)
        tsl64 = math.sqrt(sum(mse(tsl_render(scene, name, 64, seed), ref) for seed in seeds) / len(seeds))
        mi64 = math.sqrt(sum(mse(mitsuba(bsdf, name, 64, seed), ref) for seed in seeds) / len(seeds))
        # Pixels are independent: the mean's variance is the pixels' over
        # their count, each pixel's the 64-spp one scaled by 64 / spp.
        variance = (tsl64**2 * 64 / high_spp + mi64**2 * 64 / ref_spp) / factor / mask.sum()
        noise = 2 * math.sqrt(variance) / ref[mask].mean()
        cells = " ".join(f"{m:+7.2%}" for m in means)
        print(f"{name:26} {cells} {noise:6.2%} {tsl64:10.5f} {mi64:8.5f} {tsl64 / mi64:6.2f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
