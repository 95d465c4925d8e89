#!/usr/bin/env python3
"""Equal-time comparison of two renderers for scripts/compare-peers.sh.

    equal_time.py REFERENCE.exr LADDER.tsv

LADDER.tsv has one line per render: `renderer spp wall_seconds
render_seconds cpu_seconds image.exr` (wall: the whole process; render: the
renderer's own render time, without start-up: Python, imports, compiling,
loading; cpu: user + system time of the whole process, which other work on
a shared machine disturbs less than wall time).
For each renderer, prints RMSE against REFERENCE at every rung, fits
log RMSE = a + b log t by least squares (b is near -0.5 for an unbiased
estimator; a flatter slope shows bias or a noisy reference), and then,
with each of the three times, compares the first renderer (tslc in
compare-peers.sh) with the second (Mitsuba):

- RMSE ratio first / second at a common time (the geometric middle of the
  times both ladders cover), by piecewise-linear interpolation on log-log
  axes, and from the fits;
- time ratio first / second at a common RMSE (the geometric middle of the
  RMSEs both cover), likewise.

Values outside a ladder's range are taken from its fit and marked `(fit)`.
"""
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import numpy as np  # noqa: E402

from compare_images import load, stats  # noqa: E402


def interp(x, xs, ys, fit):
    """ys(x) on log-log axes: piecewise linear inside xs, the fit outside."""
    lx, lxs, lys = math.log(x), np.log(xs), np.log(ys)
    if lxs[0] <= lx <= lxs[-1]:
        return math.exp(np.interp(lx, lxs, lys)), ""
    return math.exp(fit[0] + fit[1] * lx), " (fit)"


def main(argv):
    if len(argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    ref = load(argv[1])
    ladders = {}
    for line in open(argv[2]):
        if not line.strip():
            continue
        name, spp, wall, render, cpu, path = line.split()
        rmse = stats(load(path), ref)[0]
        ladders.setdefault(name, []).append((int(spp), float(wall), float(render), rmse, float(cpu)))
    if not 1 <= len(ladders) <= 2:
        sys.exit(f"{argv[2]}: expected one or two renderers, found {list(ladders)}")
    for name, rungs in ladders.items():
        print(f"{name}: spp, wall s, render s, start-up s (wall - render), cpu s, rmse")
        for spp, wall, render, rmse, cpu in sorted(rungs):
            print(f"  {spp:6d} {wall:8.3f} {render:8.3f} {wall - render:7.3f} {cpu:8.3f}  {rmse:.5f}")
        startup = [r[1] - r[2] for r in rungs]
        print(f"  start-up: median {np.median(startup):.3f} s")
        per_spp = np.polyfit([r[0] for r in rungs], [r[1] for r in rungs], 1)
        print(f"  wall = {per_spp[1]:.3f} s + {1000 * per_spp[0]:.2f} ms per spp (least squares)")
    clocks = (("wall (whole process)", 1), ("render only (start-up excluded)", 2), ("cpu (whole process)", 4))
    for clock, col in clocks:
        print(f"-- time = {clock}")
        curves = {}
        for name, rungs in ladders.items():
            rungs = sorted(rungs, key=lambda r: r[col])
            t = np.array([r[col] for r in rungs])
            e = np.array([r[3] for r in rungs])
            slope, icept = np.polyfit(np.log(t), np.log(e), 1)
            curves[name] = (t, e, (icept, slope))
            print(f"  {name}: rmse = {math.exp(icept):.4g} * t^{slope:.3f}")
        if len(curves) < 2:
            continue
        (a, (ta, ea, fa)), (b, (tb, eb, fb)) = curves.items()
        lo, hi = max(ta[0], tb[0]), min(ta[-1], tb[-1])
        t0 = math.sqrt(lo * hi) if lo <= hi else math.sqrt(ta[-1] * tb[0])
        ra, ma = interp(t0, ta, ea, fa)
        rb, mb = interp(t0, tb, eb, fb)
        fit_ratio = math.exp(fa[0] + fa[1] * math.log(t0)) / math.exp(fb[0] + fb[1] * math.log(t0))
        print(
            f"  at {t0:.3f} s: rmse {a} {ra:.5f}{ma}, {b} {rb:.5f}{mb}; "
            f"ratio {a}/{b} {ra / rb:.3f} (fits: {fit_ratio:.3f})"
        )
        # Time at a given RMSE: the same curves with the axes swapped
        # (RMSE falls with time, so reverse to increasing RMSE).
        lo, hi = max(ea.min(), eb.min()), min(ea.max(), eb.max())
        e0 = math.sqrt(lo * hi) if lo <= hi else math.sqrt(ea.min() * eb.max())
        inv = lambda f: (-f[0] / f[1], 1 / f[1])  # noqa: E731
        sa, sb = np.argsort(ea), np.argsort(eb)
        xa, na = interp(e0, ea[sa], ta[sa], inv(fa))
        xb, nb = interp(e0, eb[sb], tb[sb], inv(fb))
        print(f"  at rmse {e0:.5f}: time {a} {xa:.3f} s{na}, {b} {xb:.3f} s{nb}; ratio {a}/{b} {xa / xb:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
