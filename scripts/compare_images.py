#!/usr/bin/env python3
"""Compare linear images (EXR) for scripts/compare-peers.sh.

    compare_images.py REFERENCE IMAGE [IMAGE...] [--objects AOV.exr --labels a,b,... [--per-channel]]

Prints, for each IMAGE against REFERENCE: the RMSE of linear radiance per
channel and overall, the relative MSE (mean of (I - R)^2 / (R^2 + 0.01),
which a few very bright pixels dominate less than the RMSE), the mean
radiance of both, and their relative difference; with two or more images, the RMSE of the last over the first's
(compare-peers.sh passes Mitsuba's image first, then tslc's).

With --objects, also per object: AOV.exr is a `tslc render --aov` EXR whose
`object` layer gives the index of the object each pixel centre sees (-1:
none); --labels names the objects in scene order (unnamed ones are shown by
index). Every image is compared inside the same masks, which is right when
the scenes have the same geometry.

Reads EXR through Mitsuba's Bitmap (pip install mitsuba), which the
comparison needs anyway; PNGs are decoded from sRGB.
"""
import argparse
import os
import sys

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")


def load(path):
    bmp = mi.Bitmap(path)
    if path.lower().endswith(".png"):
        bmp = bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False)
    c = channels(bmp)
    if all(k in c for k in "RGB"):
        return np.stack([c[k] for k in "RGB"], axis=-1)
    return np.stack(list(c.values())[:3], axis=-1)


def channels(bmp):
    """The bitmap's channels by name (an EXR's own names: R, object, ...)."""
    a = np.array(bmp, dtype=np.float64)
    if a.ndim == 2:
        a = a[:, :, None]
    s = bmp.struct_()
    return {s[k].name: a[:, :, k] for k in range(len(s))}


def object_ids(path):
    c = channels(mi.Bitmap(path))
    if "object" not in c:
        sys.exit(f"{path} has no object layer (render it with tslc render --aov)")
    return np.rint(c["object"]).astype(np.int64)


def stats(img, ref, mask=None):
    if mask is not None:
        img, ref = img[mask], ref[mask]
    diff = img - ref
    rmse_c = np.sqrt(np.mean(diff**2, axis=tuple(range(diff.ndim - 1))))
    rmse = float(np.sqrt(np.mean(diff**2)))
    m_img, m_ref = float(img.mean()), float(ref.mean())
    rel = (m_img - m_ref) / m_ref if m_ref else float("nan")
    return rmse, rmse_c, m_img, m_ref, rel


def main(argv):
    p = argparse.ArgumentParser(add_help=True, usage=__doc__)
    p.add_argument("reference")
    p.add_argument("images", nargs="+")
    p.add_argument("--objects")
    p.add_argument("--labels", default="")
    p.add_argument(
        "--per-channel",
        action="store_true",
        help="per object, each channel's mean against the reference's (spectral comparisons)",
    )
    a = p.parse_args(argv[1:])
    ref = load(a.reference)
    images = []
    for path in a.images:
        img = load(path)
        if img.shape != ref.shape:
            print(f"{path}: size {img.shape} differs from the reference {ref.shape}")
            continue
        rmse, rmse_c, m_img, m_ref, rel = stats(img, ref)
        relmse = float(np.mean((img - ref) ** 2 / (ref**2 + 0.01)))
        print(
            f"{path}: rmse {rmse:.5f} (r {rmse_c[0]:.5f} g {rmse_c[1]:.5f} b {rmse_c[2]:.5f}), "
            f"relmse {relmse:.5f}, mean {m_img:.5f} vs {m_ref:.5f} ({100 * rel:+.2f}%)"
        )
        images.append((path, img, rmse))
    if len(images) >= 2:
        (first, _, r0), (last, _, r1) = images[0], images[-1]
        if r0 > 0:
            print(f"rmse ratio {os.path.basename(last)} / {os.path.basename(first)}: {r1 / r0:.3f}")
    if a.objects:
        ids = object_ids(a.objects)
        if ids.shape != ref.shape[:2]:
            sys.exit(f"{a.objects}: {ids.shape} object layer for a {ref.shape[:2]} reference")
        labels = [s for s in a.labels.split(",") if s]
        names = [os.path.basename(path) for path, _, _ in images]
        width = max(len(n) for n in names)
        print(f"per object (masks from {a.objects}; rmse, mean vs reference):")
        for k in sorted(set(ids.flat)):
            mask = ids == k
            label = "background" if k < 0 else (labels[k] if k < len(labels) else f"object {k}")
            print(f"  {label} ({mask.sum()} pixels, reference mean {ref[mask].mean():.5f})")
            rmses = []
            for name, (path, img, _) in zip(names, images):
                rmse, _, m_img, m_ref, rel = stats(img, ref, mask)
                rmses.append(rmse)
                print(f"    {name:<{width}}  rmse {rmse:.5f}  mean {m_img:.5f} ({100 * rel:+.2f}%)")
                if a.per_channel:
                    means, refs = img[mask].mean(axis=0), ref[mask].mean(axis=0)
                    cells = "  ".join(
                        f"{c} {m:.5f} ({100 * (m - r) / r:+.2f}%)" for c, m, r in zip("rgb", means, refs)
                    )
                    print(f"    {'':<{width}}  {cells}")
            if len(rmses) >= 2 and rmses[0] > 0:
                print(f"    {'rmse ratio last / first':<{width}}  {rmses[-1] / rmses[0]:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
