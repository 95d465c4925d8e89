#!/usr/bin/env python3
"""Write a copy of a Mitsuba scene whose RGB reflectance is replaced by the
sigmoid spectrum that round-trips it exactly in Mitsuba 3's own spectral
pipeline, for compare-peers.sh spectral.

    exact_reflectance.py SCENE.xml OUT.xml "R, G, B"

Mitsuba's `srgb` reflectance reads its spectrum's coefficients from a 64^3
table, interpolated; for saturated colors the result is off the given RGB
(the Cornell red wall 0.570068, 0.0430135, 0.0443706 renders green and blue
0.39% low). Here the coefficients are refined by Newton's method, starting
from the table's, until the spectrum lit by Mitsuba's D65 and integrated
against its CIE 1931 table (360-830 nm) over its XYZ -> sRGB matrix is the
RGB to 1e-12, and the spectrum is written as a 1 nm `<spectrum>`. Prints
the table's and the exact spectrum's RGB.
"""
import sys

import numpy as np


def main(argv):
    if len(argv) != 4:
        print(__doc__, file=sys.stderr)
        return 2
    import mitsuba as mi

    mi.set_variant("scalar_spectral")
    scene, out, value = argv[1], argv[2], argv[3]
    rgb = np.array([float(v) for v in value.split(",")])
    nm = np.linspace(360.0, 830.0, 4701)  # 0.1 nm
    cmf = np.array([list(mi.cie1931_xyz(float(x))) for x in nm])
    d65 = np.array([mi.cie_d65(float(x)) for x in nm])
    to_srgb = np.array([[3.240479, -1.537150, -0.498535], [-0.969256, 1.875991, 0.041556], [0.055648, -0.204043, 1.057311]])
    weights = cmf * d65[:, None] * np.gradient(nm)[:, None] * mi.MI_CIE_Y_NORMALIZATION
    weights[[0, -1]] *= 0.5  # trapezoid

    def spectrum(c):
        x = np.polyval(c, nm)
        return 0.5 + x / (2 * np.sqrt(1 + x * x))

    def color(c):
        return to_srgb @ (weights.T @ spectrum(c))

    table = np.array(list(mi.srgb_model_fetch(list(rgb))), dtype=float)
    c = table.copy()
    for _ in range(50):
        f = color(c) - rgb
        if np.abs(f).max() < 1e-12:
            break
        steps = [1e-9, 1e-6, 1e-3]
        jac = np.stack([(color(c + np.eye(3)[j] * steps[j]) - color(c) ) / steps[j] for j in range(3)], 1)
        c = c - np.linalg.solve(jac, f)
    print(f"table {color(table)}, exact {color(c)} (wanted {rgb})")
    fine = spectrum(c)
    pairs = ", ".join(f"{l}:{fine[10 * (l - 360)]:.7f}" for l in range(360, 831))
    text = open(scene).read()
    old = f'<rgb name="reflectance" value="{value}"/>'
    if old not in text:
        print(f"{scene} has no {old}", file=sys.stderr)
        return 1
    open(out, "w").write(text.replace(old, f'<spectrum name="reflectance" value="{pairs}"/>'))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
