"""Generators called over arrays of points."""

import numpy as np
import pytest

import tsl

SOURCE = """
float scaled(float k) { return u * k; }
color tint(color c, float t) { return c * t; }
vector offset(vector d) { return P + d; }
int band(float width) { return int(floor(u / width)); }
bool above(float h, bool flip) { return flip != (P[2] > h); }
vec2 swap() { return vec2(v, u); }
float facet() { return float(face) + 0.5 * float(frame); }
"""


@pytest.fixture(scope="module")
def program():
    return tsl.compile(source=SOURCE)


def test_a_float_generator_by_name_and_by_position(program):
    scaled = program.generator("scaled")
    assert scaled.name == "scaled" and scaled.parameters == [("k", "float")] and scaled.result_type == "float"
    u = np.linspace(0, 1, 11, dtype=np.float32)
    out = scaled(k=8.0, u=u)
    assert out.shape == (11,) and out.dtype == np.float32
    np.testing.assert_array_equal(out, u * np.float32(8))
    np.testing.assert_array_equal(scaled(np.full(11, 2.0), u=u), u * np.float32(2))
    with pytest.raises(TypeError, match="needs its argument `k`"):
        scaled(u=u)
    with pytest.raises(TypeError, match="given by position and by name"):
        scaled(1.0, k=2.0)


def test_colors_vectors_ints_bools_and_vec2s(program):
    n = 6
    t = np.arange(n, dtype=np.float32)
    np.testing.assert_allclose(program.generator("tint")((0.5, 0.25, 1.0), t), np.outer(t, [0.5, 0.25, 1.0]), rtol=1e-6)
    p = np.arange(3 * n, dtype=np.float32).reshape(n, 3)
    np.testing.assert_array_equal(program.generator("offset")(d=(1, 2, 3), P=p), p + np.array([1, 2, 3], np.float32))
    band = program.generator("band")(0.25, u=np.linspace(0, 0.99, n))
    assert band.dtype == np.int32
    np.testing.assert_array_equal(band, np.floor(np.linspace(0, 0.99, n) / 0.25).astype(np.int32))
    above = program.generator("above")(h=2.5, flip=np.array([False, True] * 3), P=p)
    assert above.dtype == bool
    np.testing.assert_array_equal(above, (p[:, 2] > 2.5) != np.array([False, True] * 3))
    swapped = program.generator("swap")(u=t, v=-t)
    np.testing.assert_array_equal(swapped, np.stack([-t, t], axis=1))


def test_spectral_color_generators_return_rgb():
    program = tsl.compile(source=SOURCE, color_model="spectral32")
    out = program.generator("tint")(np.array([[0.2, 0.4, 0.6]] * 3), 1.0)
    assert out.shape == (3, 3)
    np.testing.assert_allclose(out, [[0.2, 0.4, 0.6]] * 3, atol=0.02)


def test_a_prelude_generator_agrees_with_the_same_call_in_tsl():
    program = tsl.compile(source=SOURCE + "float marble() { return fbm(P * 2, 5); }\n")
    fbm = program.generator("fbm")
    assert fbm.parameters == [("p", "point"), ("octaves", "int"), ("lacunarity", "float"), ("gain", "float")]
    p = np.random.default_rng(0).uniform(-4, 4, size=(5000, 3)).astype(np.float32)
    out = fbm(p * 2, 5, 2.0, 0.5)
    assert out.shape == (5000,) and np.all((out >= 0) & (out <= 1)) and out.std() > 0.01
    np.testing.assert_array_equal(out, program.generator("marble")(P=p))


def test_int_globals_are_passed_as_ints(program):
    facet = program.generator("facet")
    np.testing.assert_array_equal(facet(face=np.arange(6), frame=2), np.arange(6, dtype=np.float32) + 1)
    np.testing.assert_array_equal(facet(face=3), [3.0])
