"""Surface calls over numpy arrays: closed forms, shapes, layouts, dtypes,
broadcasting, chunking across cores, run-time parameters."""

import numpy as np
import pytest

import tsl

GRAY = "material m = lambert(kd: rgb(0.5, 0.25, 1.0));\nmaterial lamp = emitter(radiance: rgb(2, 3, 4));\n"
KD = np.array([0.5, 0.25, 1.0], dtype=np.float32)


def directions(n, seed=1):
    """`n` unit vectors in the upper hemisphere (z > 0.05)."""
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2]) + 0.05
    return (v / np.linalg.norm(v, axis=1, keepdims=True)).astype(np.float32)


@pytest.fixture(scope="module")
def program():
    return tsl.compile(source=GRAY)


def test_lambert_at_normal_incidence_is_kd_over_pi_times_the_light(program):
    m = program.material("m")
    up = np.array([[0.0, 0.0, 1.0]] * 4, dtype=np.float32)
    light = np.array([[1, 1, 1], [2, 2, 2], [0.5, 1, 2], [0, 3, 0]], dtype=np.float32)
    out = m.reflection(up, up, light)
    assert out.shape == (4, 3) and out.dtype == np.float32
    np.testing.assert_allclose(out, KD / np.pi * light, rtol=1e-6)
    # White light by default.
    np.testing.assert_allclose(m.reflection(up, up), np.tile(KD / np.pi, (4, 1)), rtol=1e-6)


def test_lambert_follows_the_cosine_and_vanishes_below(program):
    m = program.material("m")
    wi = directions(100)
    wo = directions(100, seed=2)
    out = m.reflection(wi, wo)
    np.testing.assert_allclose(out, KD[None, :] * wi[:, 2:3] / np.pi, rtol=1e-5)
    below = wi * np.array([1, 1, -1], dtype=np.float32)
    assert np.all(m.reflection(below, wo) == 0)


def test_sample_and_pdf_agree_with_cosine_sampling(program):
    m = program.material("m")
    n = 500
    rng = np.random.default_rng(3)
    wo = directions(n)
    s = m.sample(wo, rng.random(n, dtype=np.float32), rng.random((n, 2), dtype=np.float32))
    assert isinstance(s, tuple) and s._fields == ("wi", "weight", "pdf", "delta")
    assert s.wi.shape == (n, 3) and s.weight.shape == (n, 3) and s.pdf.shape == (n,) and s.delta.dtype == bool
    assert not s.delta.any()
    np.testing.assert_allclose(s.weight, np.tile(KD, (n, 1)), rtol=1e-6)
    np.testing.assert_allclose(s.pdf, s.wi[:, 2] / np.pi, rtol=1e-4, atol=1e-6)
    np.testing.assert_array_equal(m.pdf(s.wi, wo), s.pdf)


def test_eval_pdf_is_reflection_and_pdf_in_one_call(program):
    m = program.material("m")
    wi, wo = directions(300), directions(300, seed=8)
    value, pdf = m.eval_pdf(wi, wo)
    np.testing.assert_allclose(value, m.reflection(wi, wo), rtol=1e-6)
    np.testing.assert_allclose(pdf, m.pdf(wi, wo), rtol=1e-6)


def test_the_package_docstring_example_holds():
    import doctest

    result = doctest.testmod(tsl, raise_on_error=True)
    assert result.attempted == 5 and result.failed == 0


def test_emission(program):
    lamp = program.material("lamp")
    wo = np.array([[0, 0, 1], [0, 0, -1]], dtype=np.float32)
    np.testing.assert_array_equal(lamp.emission(wo), [[2, 3, 4], [0, 0, 0]])
    assert np.all(program.material("m").emission(wo) == 0)


def test_albedo_is_what_the_material_reflects():
    # Lambert reflects kd from every direction.
    m = tsl.compile(source=GRAY).material("m")
    np.testing.assert_allclose(m.albedo(directions(50)), np.tile(KD, (50, 1)), rtol=1e-6)
    # A rough metal reflects the mean of its sample weights: against 20000
    # samples toward one direction.
    metal = tsl.compile(source="material m = rough_conductor(alpha: 0.4);\n").material("m")
    n = 20000
    rng = np.random.default_rng(4)
    wo = np.tile(np.array([[0.6, 0.0, 0.8]], dtype=np.float32), (n, 1))
    s = metal.sample(wo, rng.random(n, dtype=np.float32), rng.random((n, 2), dtype=np.float32))
    albedo = metal.albedo(wo[:1])[0]
    assert np.all(albedo > 0.5) and np.all(albedo <= 1)
    np.testing.assert_allclose(albedo, s.weight.mean(axis=0), rtol=0.02)


def test_globals_by_name_shade_a_texture_tree():
    program = tsl.compile(source="material stripes = lambert(kd: gray(u));\nmaterial side = lambert(kd: gray(P[0]));\n")
    up = np.array([0.0, 0.0, 1.0])
    u = np.linspace(0, 1, 7, dtype=np.float32)
    out = program.material("stripes").reflection(up, up, u=u)
    np.testing.assert_allclose(out[:, 0], u / np.pi, rtol=1e-6)
    p = np.stack([u, np.zeros(7), np.zeros(7)], axis=1)
    np.testing.assert_allclose(program.material("side").reflection(up, up, P=p)[:, 1], u / np.pi, rtol=1e-6)
    with pytest.raises(TypeError, match="`dpdu`: not a shading global; did you mean `dPdu`"):
        program.material("side").reflection(up, up, dpdu=p)
    with pytest.raises(TypeError, match="`Q`: not a shading global; the globals are P, Pl, N, Ng, u, v"):
        program.material("side").reflection(up, up, Q=p)


def test_normals_flip_the_hemisphere(program):
    m = program.material("m")
    down = np.array([[0.0, 0.0, -1.0]] * 3)
    # Seen and lit from below a surface whose normal points down: lit.
    np.testing.assert_allclose(m.reflection(down, down, N=down), np.tile(KD / np.pi, (3, 1)), rtol=1e-6)


def test_strided_float64_and_broadcast_inputs_give_the_same_bits(program):
    m = program.material("m")
    wi, wo = directions(64), directions(64, seed=5)
    want = m.reflection(wi, wo)
    # A strided view (every other row of a wider array), no copy needed.
    wide = np.zeros((128, 5), dtype=np.float32)
    wide[::2, 1:4] = wi
    view = wide[::2, 1:4]
    assert not view.flags.c_contiguous
    np.testing.assert_array_equal(m.reflection(view, wo), want)
    # Fortran order and float64 are read too.
    np.testing.assert_array_equal(m.reflection(np.asfortranarray(wi), wo.astype(np.float64)), want)
    # A reversed array (negative strides) is copied, with the same bits.
    np.testing.assert_array_equal(m.reflection(wi[::-1], wo[::-1]), want[::-1])
    # One direction for every point.
    one = m.reflection(wi, wo[7])
    np.testing.assert_array_equal(one[7], want[7])
    np.testing.assert_array_equal(one, m.reflection(wi, np.tile(wo[7], (64, 1))))
    np.testing.assert_array_equal(m.reflection(wi, np.broadcast_to(wo[7], (64, 3))), one)
    # Lists, tuples and a scalar `eta`.
    np.testing.assert_array_equal(m.reflection(wi.tolist(), tuple(wo[0]), eta=1.0), m.reflection(wi, wo[0]))


def test_all_uniform_arguments_shade_one_point(program):
    out = program.material("m").reflection((0, 0, 1), (0, 0, 1))
    assert out.shape == (1, 3)


def test_empty_batches(program):
    empty = np.zeros((0, 3), dtype=np.float32)
    assert program.material("m").reflection(empty, empty).shape == (0, 3)
    assert program.material("m").pdf(empty, empty).shape == (0,)


def test_shapes_that_disagree_name_the_argument(program):
    m = program.material("m")
    with pytest.raises(ValueError, match=r"`wo` has 4 points and `wi` has 5"):
        m.reflection(directions(5), directions(4))
    with pytest.raises(ValueError, match=r"`wi` must have shape \(N, 3\) or \(3,\), not \(5, 2\)"):
        m.reflection(np.zeros((5, 2)), directions(5))
    with pytest.raises(ValueError, match=r"`u` must have shape \(N,\) or a scalar, not \(5, 2\)"):
        m.reflection(directions(5), directions(5), u=np.zeros((5, 2)))
    with pytest.raises(ValueError, match=r"`light` has 3 points"):
        m.reflection(directions(5), directions(5), np.ones((3, 3)))
    with pytest.raises(ValueError, match=r"`u2` must have shape \(N, 2\)"):
        m.sample(directions(5), np.zeros(5), np.zeros((5, 3)))
    with pytest.raises(TypeError, match="`wi` is not an array of numbers"):
        m.reflection("up", directions(5))


def test_big_batches_split_across_cores_give_the_same_bits_as_small_ones(program):
    m = program.material("m")
    n = 3 * 4096 + 17
    wi, wo = directions(n), directions(n, seed=9)
    whole = m.reflection(wi, wo)
    parts = np.concatenate([m.reflection(wi[k : k + 1000], wo[k : k + 1000]) for k in range(0, n, 1000)])
    np.testing.assert_array_equal(whole, parts)


def test_run_time_parameters_change_results_without_recompiling():
    program = tsl.compile(source="material m = lambert;")
    metal = program.shader("rough_conductor").instance(alpha=0.05)
    wi = directions(32)
    wo = wi * np.array([-1, -1, 1], dtype=np.float32)  # mirror directions
    sharp = metal.reflection(wi, wo)
    compiled = program.compiled_functions
    rough = metal.set(alpha=0.6).reflection(wi, wo)
    assert program.compiled_functions == compiled
    assert np.all(rough < sharp)
    # The bound values agree with the values compiled in.
    np.testing.assert_allclose(metal.specialise().reflection(wi, wo), rough, rtol=1e-5, atol=1e-7)
    lambert = program.shader("lambert").instance(kd=(0.2, 0.4, 0.6))
    up = np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(lambert.reflection(up, up)[0], np.array([0.2, 0.4, 0.6]) / np.pi, rtol=1e-6)
    lambert.set(kd=(1, 1, 1))
    np.testing.assert_allclose(lambert.reflection(up, up)[0], np.ones(3) / np.pi, rtol=1e-6)


def test_spectral_programs_return_rgb():
    program = tsl.compile(source="material m = lambert(kd: gray(0.5));", color_model="spectral16")
    up = np.array([[0.0, 0.0, 1.0]])
    out = program.material("m").reflection(up, up)
    assert out.shape == (1, 3)
    np.testing.assert_allclose(out[0], 0.5 / np.pi, rtol=2e-3)
    light = np.array([[1.0, 0.5, 0.25], [1.0, 0.5, 0.25]])
    np.testing.assert_allclose(program.material("m").reflection(up[0], up[0], light)[1], [0.5 / np.pi, 0.25 / np.pi, 0.125 / np.pi], rtol=2e-2)


def test_threads_share_a_material(program):
    from concurrent.futures import ThreadPoolExecutor

    m = program.material("m")
    wi, wo = directions(20000), directions(20000, seed=11)
    want = m.reflection(wi, wo)
    with ThreadPoolExecutor(4) as pool:
        results = list(pool.map(lambda _: m.reflection(wi, wo), range(8)))
    for got in results:
        np.testing.assert_array_equal(got, want)


def test_the_sample_type_is_exported(program):
    s = program.material("m").sample((0, 0, 1), 0.5, (0.25, 0.75))
    assert type(s) is tsl.BsdfSample


def test_an_instance_set_from_another_thread_while_shading():
    import threading

    program = tsl.compile(source="material m = lambert;")
    metal = program.shader("rough_conductor").instance(alpha=0.1)
    wi = directions(50000)
    wo = wi * np.array([-1, -1, 1], dtype=np.float32)
    sharp = metal.reflection(wi, wo)
    errors = []

    def sweep():
        try:
            for alpha in np.linspace(0.2, 0.6, 20):
                metal.set(alpha=float(alpha))
        except Exception as e:  # noqa: BLE001 - reported below
            errors.append(e)

    thread = threading.Thread(target=sweep)
    thread.start()
    results = [metal.reflection(wi, wo) for _ in range(3)]
    thread.join()
    assert not errors
    # Each call shaded with one binding throughout: sharp, or one of the rough ones.
    for r in results:
        assert np.array_equal(r, sharp) or np.all(r[wi[:, 2] > 0.5] <= sharp[wi[:, 2] > 0.5])
    assert metal.values["alpha"] == pytest.approx(0.6)
