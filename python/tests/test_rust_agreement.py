"""The package against the Rust API, bit for bit: the same points shaded by
`tsl` (batches split across cores, strided inputs, defaults for the
unspecified globals) and by python/tests/reference.rs (`Material::at`,
one point at a time)."""

import subprocess

import numpy as np
import pytest

import tsl

TREE = """
/// A marbled plastic: a texture tree over P, u and v.
material marbled = rough_plastic(
    diffuse_reflectance: mix(clamp(noise(P * 4) + 0.5, 0, 1), rgb(0.8, 0.7, 0.6), rgb(0.2, 0.1, 0.1)),
    alpha: 0.1 + 0.3 * u,
);

/// The same tree as a template whose scale and colours a host binds.
material veined(float scale = 4, color vein = rgb(0.2, 0.1, 0.1), float roughness = 0.2) = rough_plastic(
    diffuse_reflectance: mix(clamp(noise(P * scale) + 0.5, 0, 1), rgb(0.8, 0.7, 0.6), vein),
    alpha: roughness * (0.5 + u),
);
"""


def points(n, seed=0):
    rng = np.random.default_rng(seed)

    def unit(v):
        v[:, 2] = np.abs(v[:, 2]) + 0.05
        return v / np.linalg.norm(v, axis=1, keepdims=True)

    wi, wo = unit(rng.normal(size=(n, 3))), unit(rng.normal(size=(n, 3)))
    p = rng.uniform(-1, 1, size=(n, 3))
    normal = unit(rng.normal(size=(n, 3)) * 0.2 + np.array([0, 0, 1]))
    uv = rng.random((n, 2))
    lobe, u2 = rng.random(n), rng.random((n, 2))
    record = np.concatenate([wi, wo, p, normal, uv, lobe[:, None], u2], axis=1).astype(np.float32)
    return record


def rust(reference, path, name, params=(), color=None, record=None):
    args = [str(reference), str(path), name, *params] + (["--color", color] if color else [])
    out = subprocess.run(args, input=record.tobytes(), capture_output=True, check=True).stdout
    return np.frombuffer(out, dtype=np.float32).reshape(-1, 12)


def python(material, record):
    wi, wo, p, n = record[:, 0:3], record[:, 3:6], record[:, 6:9], record[:, 9:12]
    u, v, lobe, u2 = record[:, 12], record[:, 13], record[:, 14], record[:, 15:17]
    g = dict(P=p, N=n, u=u, v=v)
    reflection = material.reflection(wi, wo, **g)
    pdf = material.pdf(wi, wo, **g)
    s = material.sample(wo, lobe, u2, **g)
    return np.concatenate(
        [reflection, pdf[:, None], s.wi, s.weight, s.pdf[:, None], s.delta[:, None].astype(np.float32)], axis=1
    )


@pytest.mark.parametrize("color", [None, "spectral16"])
def test_a_texture_tree_matches_the_rust_api_bit_for_bit(tmp_path, reference, color):
    path = tmp_path / "tree.tsl"
    path.write_text(TREE)
    record = points(9000)  # three chunks on the Python side
    program = tsl.compile(path=path, color_model=color or "rgb")
    ours = python(program.material("marbled"), record)
    theirs = rust(reference, path, "marbled", color=color, record=record)
    assert np.any(ours[:, 0] > 0) and np.any(ours[:, 4:7] != 0)
    np.testing.assert_array_equal(ours.view(np.uint32), theirs.view(np.uint32))


def test_an_instance_bound_at_run_time_matches_the_rust_api(tmp_path, reference):
    path = tmp_path / "tree.tsl"
    path.write_text(TREE)
    record = points(500, seed=4)
    program = tsl.compile(path=path)
    metal = program.shader("rough_conductor").instance(alpha=0.05)
    metal.set(alpha=0.35, distribution="ggx", eta=(0.2, 0.9, 1.1))
    ours = python(metal, record)
    theirs = rust(reference, path, "rough_conductor", ["alpha=0.35", "distribution=ggx", "eta=0.2,0.9,1.1"], record=record)
    np.testing.assert_array_equal(ours.view(np.uint32), theirs.view(np.uint32))


@pytest.mark.parametrize("color", [None, "spectral16"])
def test_a_texture_tree_template_bound_at_run_time_matches_the_rust_api(tmp_path, reference, color):
    path = tmp_path / "tree.tsl"
    path.write_text(TREE)
    record = points(5000, seed=6)
    program = tsl.compile(path=path, color_model=color or "rgb")
    veined = program.shader("veined").instance(scale=2.0)
    before = python(veined, record)
    compiled = program.compiled_functions
    veined.set(scale=7.5, vein=(0.3, 0.2, 0.1), roughness=0.35)
    ours = python(veined, record)
    assert program.compiled_functions == compiled
    assert not np.array_equal(ours, before)
    params = ["scale=7.5", "vein=0.3,0.2,0.1", "roughness=0.35"]
    theirs = rust(reference, path, "veined", params, color=color, record=record)
    np.testing.assert_array_equal(ours.view(np.uint32), theirs.view(np.uint32))
