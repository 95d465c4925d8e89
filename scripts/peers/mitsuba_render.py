#!/usr/bin/env python3
"""Render a Mitsuba 3 scene to a linear EXR, for compare-peers.sh.

    mitsuba_render.py SCENE.xml OUT.exr SPP SEED [NAME=VALUE...]

NAME=VALUE pairs set the scene's other <default> parameters (envmap=...).
MITSUBA_VARIANT chooses the variant (default scalar_rgb; scalar_spectral for
the spectral comparison).
Renders on MITSUBA_THREADS threads (default 2, as tslc's comparison runs).
Prints one line to stdout: `render_seconds S`, the time of mi.render
alone; the rest of the process (Python start, import, scene load, EXR
write) is Mitsuba's start-up cost.
"""
import os
import sys
import time


def main(argv):
    if len(argv) < 5:
        print(__doc__, file=sys.stderr)
        return 2
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(os.environ.get("MITSUBA_VARIANT", "scalar_rgb"))
    dr.set_thread_count(int(os.environ.get("MITSUBA_THREADS", "2")))
    params = dict(kv.split("=", 1) for kv in argv[5:])
    scene = mi.load_file(argv[1], spp=argv[3], seed=argv[4], **params)
    start = time.perf_counter()
    image = mi.render(scene)
    seconds = time.perf_counter() - start
    mi.Bitmap(image).write(argv[2])
    print(f"render_seconds {seconds:.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
