"""tsl.compile, programs, shaders and their parameters, errors."""

import pytest

import tsl

TREE = """
/// A red-ish diffuse tree.
material tinted(
    /// how red
    float redness = 0.5,
    color base = rgb(0.1, 0.2, 0.3),
) = lambert(kd: mix(redness, base, rgb(1, 0, 0)));

material plain = lambert(kd: gray(0.5));
"""


def test_compile_from_source_lists_own_materials_in_order():
    program = tsl.compile(source=TREE)
    assert program.materials == ["tinted", "plain"]
    assert program.color_model == "rgb"


def test_compile_from_path(tmp_path):
    path = tmp_path / "tree.tsl"
    path.write_text(TREE)
    program = tsl.compile(path=str(path), color_model="spectral16")
    assert program.materials == ["tinted", "plain"]
    assert program.color_model == "spectral16"
    assert tsl.compile(path=path, color_model="hero").color_model == "hero"


def test_compile_error_has_text_and_located_diagnostics():
    with pytest.raises(tsl.CompileError) as caught:
        tsl.compile(source="material m = lambert;\nmaterial n = lamberd;\n", name="bad.tsl")
    err = caught.value
    assert isinstance(err, tsl.Error)
    text = str(err)
    assert "cannot find value `lamberd` in this scope" in text
    assert "bad.tsl:2:14" in text and "did you mean `lambert`?" in text
    [d] = err.diagnostics
    assert (d.file, d.line, d.column, d.severity) == ("bad.tsl", 2, 14, "error")
    assert d.message == "cannot find value `lamberd` in this scope"
    assert str(d) == "bad.tsl:2:14: error: cannot find value `lamberd` in this scope"


def test_compile_error_from_a_file_names_the_users_path(tmp_path):
    path = tmp_path / "broken.tsl"
    path.write_text("float f() { return nope; }\n")
    with pytest.raises(tsl.CompileError) as caught:
        tsl.compile(path=str(path))
    [d] = caught.value.diagnostics
    assert d.file.endswith("broken.tsl") and (d.line, d.column) == (1, 20)


def test_bad_arguments_raise_value_errors():
    with pytest.raises(ValueError, match="not a color model"):
        tsl.compile(source=TREE, color_model="cmyk")
    with pytest.raises(ValueError, match="one of `path` and `source`"):
        tsl.compile()
    with pytest.raises(ValueError, match="one of `path` and `source`"):
        tsl.compile(path="x.tsl", source=TREE)


def test_unknown_names_raise_compile_errors_with_a_suggestion():
    program = tsl.compile(source=TREE)
    with pytest.raises(tsl.CompileError, match="did you mean `rough_conductor`"):
        program.shader("rough_conductr")
    with pytest.raises(tsl.CompileError, match="no material named `tintd`"):
        program.material("tintd")
    with pytest.raises(tsl.CompileError, match="no generator named `nothing`"):
        program.generator("nothing")


def test_shader_parameters_have_name_type_default_doc():
    program = tsl.compile(source=TREE)
    shader = program.shader("tinted")
    assert shader.name == "tinted" and shader.doc == "A red-ish diffuse tree."
    redness, base = shader.parameters
    assert (redness.name, redness.type, redness.doc, redness.required) == ("redness", "float", "how red", False)
    assert redness.default == 0.5
    assert base.type == "color" and base.default_source == "rgb(0.1, 0.2, 0.3)"
    assert base.default == pytest.approx((0.1, 0.2, 0.3))
    metal = program.shader("rough_conductor")
    by_name = {p.name: p for p in metal.parameters}
    assert by_name["alpha"].default == pytest.approx(0.1) and by_name["alpha"].doc == "microfacet roughness"
    assert by_name["distribution"].options == ["beckmann", "ggx"]
    assert by_name["distribution"].default == "beckmann"
    assert any(s.name == "rough_conductor" for s in program.shaders)


def test_instances_set_values_checked_and_all_or_nothing():
    program = tsl.compile(source=TREE)
    metal = program.shader("rough_conductor").instance(alpha=0.3, eta=(0.2, 0.9, 1.1))
    assert isinstance(metal, tsl.Material)
    assert metal.values["alpha"] == pytest.approx(0.3)
    assert metal.values["eta"] == pytest.approx((0.2, 0.9, 1.1))
    assert metal.set(distribution="ggx") is metal
    assert metal.source.startswith("rough_conductor(alpha: 0.30000001192092896, distribution: \"ggx\"")
    with pytest.raises(tsl.ParameterError, match="did you mean `alpha`"):
        metal.set(alpah=0.5)
    with pytest.raises(tsl.ParameterError, match="did you mean \"ggx\""):
        metal.set(alpha=0.9, distribution="gxx")
    # Neither value of the refused call was set.
    assert metal.values["alpha"] == pytest.approx(0.3) and metal.values["distribution"] == "ggx"
    with pytest.raises(tsl.ParameterError, match="is a `float`, not a string"):
        metal.set(alpha="rough")
    with pytest.raises(TypeError, match="sequence of 2 or 3 numbers"):
        metal.set(eta=(1, 2, 3, 4))


def test_a_required_parameter_is_an_error_when_missing():
    program = tsl.compile(source="material needs(float k) = lambert(kd: gray(k));")
    shader = program.shader("needs")
    assert shader.parameters[0].required and shader.parameters[0].default is None
    with pytest.raises(tsl.ParameterError):
        shader.instance()
    assert shader.instance(k=0.5).values == {"k": 0.5}


def test_include_adds_import_directories(tmp_path):
    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "shades.tsl").write_text("material shade = lambert(kd: gray(0.25));\n")
    (tmp_path / "main.tsl").write_text('import "shades.tsl";\nmaterial mine = shade;\n')
    with pytest.raises(tsl.CompileError):
        tsl.compile(path=tmp_path / "main.tsl")
    assert set(tsl.compile(path=tmp_path / "main.tsl", include=[lib]).materials) == {"shade", "mine"}
