#!/usr/bin/env python3
"""Convert a lat-long environment image from TSL's convention to Mitsuba 3's,
and check that both renderers then see the same radiance in every direction.

    envmap_for_mitsuba.py TSL.exr MITSUBA.exr [SCENE.xml]

TSL (src/render/scene.rs, Background::Environment) looks direction d up at
u = 0.5 + atan2(d.x, -d.z) / 2 pi across and v = acos(d.y) / pi down, with
texel centres at ((i + 0.5) / W, (j + 0.5) / H), bilinearly, wrapping across
and clamped at the poles. Mitsuba's envmap (src/emitters/envmap.cpp) takes
u = atan2(d.x, -d.z) / 2 pi with the same column centres, but rows at
v = j / (H - 1): the first and last rows sit on the poles.

So an emitter with to_world = rotate 180 degrees about y (u shifted by a
half turn) and a map of 2H + 1 rows, row 2j + 1 = TSL's row j, row 2j =
the mean of TSL's rows j - 1 and j (the poles: TSL's first and last
rows), interpolates exactly what TSL interpolates: a function linear
between TSL's rows is sampled at twice the rate and interpolated linearly
again. With SCENE.xml (default envlight.xml beside this script), the check
loads that scene with envmap=MITSUBA.exr, evaluates its emitter in 4,000
directions (half of them near the brightest texel) and compares them with
TSL's lookup; it exits 1 if any differs by more than 1e-4 relative plus
3e-5 of the largest texel blended there (float32 directions and blends
beside the sun).
"""
import os
import sys

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")


def load_rgb(path):
    bmp = mi.Bitmap(path).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False)
    return np.array(bmp, dtype=np.float64)


def to_mitsuba(tsl):
    h, w, _ = tsl.shape
    out = np.empty((2 * h + 1, w, 3))
    out[1::2] = tsl
    out[2:-1:2] = 0.5 * (tsl[:-1] + tsl[1:])
    out[0], out[-1] = tsl[0], tsl[-1]
    return out


def tsl_lookup(tsl, d):
    """TSL's Background::radiance for unit direction d (numpy port), and the
    largest of the four texels it blends."""
    h, w, _ = tsl.shape
    u = 0.5 + np.arctan2(d[0], -d[2]) / (2 * np.pi)
    v = np.arccos(np.clip(d[1], -1, 1)) / np.pi
    x, y = u * w - 0.5, v * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = x - x0, y - y0
    col = lambda i: int(i) % w
    row = lambda j: min(max(int(j), 0), h - 1)
    corners = [tsl[row(y0), col(x0)], tsl[row(y0), col(x0 + 1)], tsl[row(y0 + 1), col(x0)], tsl[row(y0 + 1), col(x0 + 1)]]
    weights = [(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy]
    return sum(w * c for w, c in zip(weights, corners)), np.max(corners, axis=0)


def directions(tsl, n, rng):
    """n unit directions: half uniform, half within 3 degrees of the peak."""
    h, w, _ = tsl.shape
    lum = tsl @ [0.2126, 0.7152, 0.0722]
    j, i = np.unravel_index(np.argmax(lum), lum.shape)
    phi, theta = 2 * np.pi * ((i + 0.5) / w - 0.5), np.pi * (j + 0.5) / h
    peak = np.array([np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)])
    out = []
    for k in range(n):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        if k % 2:
            d = peak + np.radians(3) * d
            d /= np.linalg.norm(d)
        out.append(d)
    return out


def check(tsl, scene_path, mitsuba_path):
    scene = mi.load_file(scene_path, envmap=os.path.abspath(mitsuba_path), spp=1)
    emitter = [e for e in scene.emitters() if e.is_environment()][0]
    worst, worst_rel = 0.0, 0.0
    for d in directions(tsl, 4000, np.random.default_rng(1)):
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*(-d))
        got = np.array(emitter.eval(si), dtype=np.float64)
        want, corner = tsl_lookup(tsl, d)
        err = np.abs(got - want)
        # Single precision: Mitsuba's direction and blend are float32, so
        # beside the sun a value of 1 blends texels of thousands.
        worst = max(worst, float(np.max(err / (1e-4 * np.abs(want) + 3e-5 * corner + 1e-6))))
        worst_rel = max(worst_rel, float(np.max(err / np.maximum(np.abs(want), 1e-6))))
    return worst, worst_rel


def main(argv):
    if len(argv) not in (3, 4):
        print(__doc__, file=sys.stderr)
        return 2
    tsl = load_rgb(argv[1])
    mi.Bitmap(to_mitsuba(tsl).astype(np.float32)).write(argv[2])
    scene = argv[3] if len(argv) == 4 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "envlight.xml")
    worst, worst_rel = check(tsl, scene, argv[2])
    verdict = "agree" if worst <= 1 else "DISAGREE"
    print(
        f"{argv[2]}: Mitsuba's emitter and TSL's lookup {verdict} in 4000 directions: largest difference "
        f"{worst_rel:.1e} relative, {worst:.2f} of the tolerance (1e-4 relative + 3e-5 of the largest texel blended)"
    )
    return 0 if worst <= 1 else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
