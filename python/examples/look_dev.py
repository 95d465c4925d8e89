"""Look development in a few cells: a texture tree shaded over a sphere of
pixels with numpy, a parameter swept at run time, and a scene rendered.

    python python/examples/look_dev.py [SIZE]

Each block is a notebook cell; with matplotlib, `plt.imshow(image ** (1 / 2.2))`
shows any of the images.
"""

import pathlib
import sys
import time

import numpy as np

import tsl

REPO = pathlib.Path(__file__).resolve().parents[2]
SIZE = int(sys.argv[1]) if len(sys.argv) > 1 else 64

# %% A texture tree: marble veins in a plastic coat, and a metal to bind.
program = tsl.compile(
    source="""
    /// Veined marble under a clear coat.
    material marble(float veins = 6, color vein = rgb(0.15, 0.12, 0.1)) = plastic(
        diffuse_reflectance: mix(smoothstep(0.3, 0.7, fbm(P * veins)), rgb(0.9, 0.88, 0.85), vein),
    );
    """,
    name="look_dev.tsl",
)
print("materials:", program.materials)
for p in program.shader("rough_conductor").parameters:
    print(f"  {p.type:8} {p.name:22} = {p.default!r:28} {p.doc or ''}")

# %% A sphere seen from +z: one shading point per pixel, as arrays.
ys, xs = np.mgrid[1 : -1 : SIZE * 1j, -1 : 1 : SIZE * 1j]
inside = xs**2 + ys**2 < 1
n = np.stack([xs[inside], ys[inside], np.sqrt(1 - xs[inside] ** 2 - ys[inside] ** 2)], axis=1).astype(np.float32)
view = np.array([0, 0, 1], dtype=np.float32)  # toward the camera, for every point
light = np.array([0.5, 0.7, 0.5], dtype=np.float32)
light /= np.linalg.norm(light)


def shade(material):
    """The sphere lit by one distant white light of radiance pi: an (SIZE, SIZE, 3) image."""
    image = np.zeros((SIZE, SIZE, 3), dtype=np.float32)
    image[inside] = material.reflection(light, view, (np.pi,) * 3, P=n, N=n)
    return image


start = time.perf_counter()
marble = shade(program.shader("marble").instance(veins=4.0))
print(f"marble: {inside.sum()} points in {1e3 * (time.perf_counter() - start):.1f} ms, mean {marble[inside].mean():.3f}")

# %% Roughness swept at run time: one compile, a bind per value.
metal = program.shader("rough_conductor").instance(distribution="ggx")
compiled = program.compiled_functions
for alpha in (0.05, 0.2, 0.5):
    image = shade(metal.set(alpha=alpha))
    print(f"metal alpha {alpha:4}: peak {image.max():7.3f}, mean {image[inside].mean():.3f}")
assert program.compiled_functions == compiled, "binding compiles nothing"

# %% The same directions sampled: Monte Carlo estimate of the albedo at normal incidence.
rng = np.random.default_rng(0)
samples = metal.sample(view, rng.random(20000), rng.random((20000, 2)))
print("albedo of the metal at normal incidence:", samples.weight.mean(axis=0).round(3))
print("and as the material's own albedo(wo):", metal.albedo(view)[0].round(3))

# %% A whole scene, as `tslc render` renders it.
image = tsl.render(REPO / "examples" / "cornell.tsl", spp=4, res=(SIZE, SIZE * 3 // 4))
print("cornell:", image.shape, "mean radiance", image.mean(axis=(0, 1)).round(3))

# %% An ASCII preview of the marble sphere.
ramp = " .:-=+*#%@"
luminance = marble @ np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)
for row in luminance[:: max(1, SIZE // 24)]:
    print("".join(ramp[min(int(v * 2 * len(ramp)), len(ramp) - 1)] for v in row[:: max(1, SIZE // 48)]))
