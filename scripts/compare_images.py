#!/usr/bin/env python3
"""Compare linear images (EXR) for scripts/compare-peers.sh.

    compare_images.py REFERENCE IMAGE [IMAGE...]

Prints, for each IMAGE against REFERENCE: the RMSE of linear radiance per
channel and overall, the mean radiance of both, and their relative
difference. Reads EXR through Mitsuba's Bitmap (pip install mitsuba), which
the comparison needs anyway; PNGs are decoded from sRGB.
"""
import sys

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")


def load(path):
    bmp = mi.Bitmap(path)
    if path.lower().endswith(".png"):
        bmp = bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False)
    a = np.array(bmp, dtype=np.float64)
    if a.ndim == 2:
        a = a[:, :, None]
    return a[:, :, :3]


def main(argv):
    if len(argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    ref = load(argv[1])
    for path in argv[2:]:
        img = load(path)
        if img.shape != ref.shape:
            print(f"{path}: size {img.shape} differs from the reference {ref.shape}")
            continue
        diff = img - ref
        rmse_c = np.sqrt(np.mean(diff**2, axis=(0, 1)))
        rmse = float(np.sqrt(np.mean(diff**2)))
        m_img, m_ref = float(img.mean()), float(ref.mean())
        rel = (m_img - m_ref) / m_ref if m_ref else float("nan")
        print(
            f"{path}: rmse {rmse:.5f} (r {rmse_c[0]:.5f} g {rmse_c[1]:.5f} b {rmse_c[2]:.5f}), "
            f"mean {m_img:.5f} vs {m_ref:.5f} ({100 * rel:+.2f}%)"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
