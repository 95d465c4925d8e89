#!/usr/bin/env python3
"""TSL's normal_map against Mitsuba 3's `normalmap`, for compare-peers.sh.

    normal_map.py TSLC OUT_DIR [SPP]

One diffuse (reflectance 0.5) square, [-1, 1]^2 in the z = 0 plane, seen
straight on through a narrow perspective camera (a plane facing the camera
maps to the image linearly), lit by a directional light at 45 degrees from
the upper left; examples/textures/bricks_normal.png once over the square,
looked up bilinearly (Mitsuba's bitmap has no mip-maps), 256 x 256 pixels,
one pixel per texel. Cases:

- opengl: the map as stored; TSL's default convention.
- directx: TSL reads the same image with convention: "directx"; Mitsuba
  (which has no convention) reads a copy with green stored as 255 - g,
  which is what a DirectX map of the same relief holds.
- strength: TSL's strength 0.5; Mitsuba reads a copy whose red and green
  are scaled about 0.5 by half (its `normalmap` has no strength).
- flat: no map on either side (the baseline of the two renderers).

Mitsuba's bitmap puts v = 0 at the image's top row and TSL's at the
bottom; Mitsuba's texture gets `to_uv` = scale(1, -1) so both show the
picture upright. Its `normalmap` frame is then the same as TSL's (s along
dPdu, t = n x s along +v), and both weigh the light by the bump-terminator
shadowing of Conty Estevez et al. (TSL's `shadowing: true`, the default).
With `filter_type` nearest on both sides the two agree to 0.00% (RMSE
0.01%); what remains with bilinear lookups is the filters' difference. Prints, per case, the two images' means, the
mean of |TSL - Mitsuba| over the square relative to Mitsuba's mean, and
the RMSE relative to the mean.
"""
import math
import os
import subprocess
import sys

FOV = 2 * math.degrees(math.atan(1 / 100))
LIGHT = (1.0, -1.0, -1.0)
SIZE = 256


def tsl_scene(normal, extra):
    material = "lambert(kd: gray(0.5))"
    if normal:
        material = (
            f'normal_map(texture_vector("{normal}", filter: "bilinear"), {material}{extra})'
        )
    return f"""
scene {{
    camera {{ from (0, 0, 100); to (0, 0, 0); fov {FOV!r}; }}
    render {{ width {SIZE}; height {SIZE}; max_depth 2; integrator "path"; }}
    light directional {{ direction {LIGHT}; irradiance gray(3); }}
    object quad {{ corner (-1, -1, 0); edge1 (2, 0, 0); edge2 (0, 2, 0); material {material}; }}
}}
"""


def mitsuba_render(mi, normal, spp):
    bsdf = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.5, 0.5, 0.5]}}
    if normal:
        bsdf = {
            "type": "normalmap",
            "normalmap": {
                "type": "bitmap",
                "filename": normal,
                "raw": True,
                "filter_type": "bilinear",
                "to_uv": mi.ScalarTransform4f().scale([1, -1, 1]),
            },
            "bsdf": bsdf,
        }
    return render_square(mi, bsdf, spp)


def render_square(mi, bsdf, spp):
    """Mitsuba's render of the square with `bsdf` (shared with bump.py)."""
    scene = mi.load_dict(
        {
            "type": "scene",
            "integrator": {"type": "path", "max_depth": 2},
            "sensor": {
                "type": "perspective",
                "fov": FOV,
                "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 100], target=[0, 0, 0], up=[0, 1, 0]),
                "film": {"type": "hdrfilm", "width": SIZE, "height": SIZE, "rfilter": {"type": "box"}},
                "sampler": {"type": "independent", "sample_count": spp},
            },
            "light": {"type": "directional", "direction": list(LIGHT), "irradiance": {"type": "rgb", "value": 3.0}},
            "square": {"type": "rectangle", "bsdf": bsdf},
        }
    )
    return mi.render(scene)


def compare(mi, tslc, scene, mitsuba_image, stem, name, spp):
    """Renders `scene` with tslc, keeps both images as STEM_tsl.exr and
    STEM_mitsuba.exr, and prints the case's row (shared with bump.py)."""
    import numpy as np

    image = f"{stem}_tsl.exr"
    subprocess.run([tslc, "render", scene, "-o", image, "--spp", str(spp), "--quiet"], check=True)
    tsl = np.array(mi.Bitmap(image), dtype=np.float64)[..., :3]
    ref = np.array(mitsuba_image, dtype=np.float64)[..., :3]
    mi.Bitmap(ref.astype(np.float32)).write(f"{stem}_mitsuba.exr")
    diff = tsl - ref
    mean = ref.mean()
    print(
        f"{name:12} {tsl.mean():9.5f} {mean:9.5f} {np.abs(diff).mean() / mean:11.2%} "
        f"{math.sqrt((diff**2).mean()) / mean:8.2%}"
    )


def main(argv):
    if len(argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    import drjit as dr
    import mitsuba as mi
    import numpy as np

    mi.set_variant("scalar_rgb")
    dr.set_thread_count(int(os.environ.get("MITSUBA_THREADS", "2")))
    tslc, out = argv[1], argv[2]
    spp = int(argv[3]) if len(argv) > 3 else 64
    os.makedirs(out, exist_ok=True)
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    source = os.path.join(root, "examples/textures/bricks_normal.png")
    stored = np.array(mi.Bitmap(source), dtype=np.float64)
    variants = {}
    for name, change in [
        ("directx", lambda t: np.stack([t[..., 0], 255 - t[..., 1], t[..., 2]], -1)),
        ("strength", lambda t: np.stack([127.5 + (t[..., 0] - 127.5) * 0.5, 127.5 + (t[..., 1] - 127.5) * 0.5, t[..., 2]], -1)),
    ]:
        path = os.path.join(out, f"bricks_normal_{name}.png")
        mi.Bitmap(np.round(change(stored)).astype(np.uint8)).write(path)
        variants[name] = path
    cases = [
        ("opengl", source, "", source),
        ("directx", source, ', convention: "directx"', variants["directx"]),
        ("strength", source, ", strength: 0.5", variants["strength"]),
        ("flat", None, "", None),
    ]
    print(f"normal map on a diffuse square, {SIZE}x{SIZE}, {spp} spp: TSL against Mitsuba 3 normalmap")
    print(f"{'case':12} {'tsl mean':>9} {'mitsuba':>9} {'mean |diff|':>12} {'rmse':>8}")
    for name, tsl_map, extra, mitsuba_map in cases:
        scene = os.path.join(out, f"normal_map_{name}.tsl")
        with open(scene, "w") as f:
            f.write(tsl_scene(tsl_map, extra))
        ref = mitsuba_render(mi, mitsuba_map, spp)
        compare(mi, tslc, scene, ref, os.path.join(out, f"normal_map_{name}"), name, spp)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
