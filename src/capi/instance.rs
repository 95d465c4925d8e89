//! Instances of a shader with values set at run time, and the materials
//! they bind to (or a program's named materials).

use super::{TslError, TslShader, TslStatus, guard, handle, handle_mut, put, slice_arg, str_arg};
use crate::{Color, Instance, Material, ParamValue};
use std::ffi::c_char;

/// An instance of a shader: a value for some of its parameters, checked as
/// each is set. Owned by the caller (`tsl_instance_free`); not for use
/// from two threads at once while one of them sets a value.
pub struct TslInstance {
    instance: Instance,
}

/// A material ready to shade: a program's named material, or an instance
/// bound or specialised. Immutable and thread-safe: every surface call on
/// one material may run on many threads at once (each call keeps its own
/// scratch space).
pub struct TslMaterial {
    pub(crate) material: Material,
}

/// A new instance of `shader`, every parameter at its default, into
/// `*out` (free it with `tsl_instance_free`).
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_shader_instance(
    shader: *const TslShader,
    out: *mut *mut TslInstance,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let instance = handle(shader, "shader")?.shader.instance();
        put(out, TslInstance { instance }, "out")
    })
}

/// Frees an instance (null is ignored).
/// Threads: not while another call uses the handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_instance_free(instance: *mut TslInstance) {
    super::free(instance);
}

/// Sets parameter `name` to `value`, checked by [`Instance::set`].
fn set(instance: *mut TslInstance, name: *const c_char, name_len: usize, value: ParamValue) -> super::Outcome {
    let instance = handle_mut(instance, "instance")?;
    instance.instance.set(str_arg(name, name_len, "name")?, value)?;
    Ok(())
}

/// Sets a `float` parameter. As for every `tsl_instance_set_*`, an unknown
/// name (with a did-you-mean) or a value of the wrong type is `TSL_ERROR`,
/// and the instance is unchanged; materials bound before keep their values.
/// Threads: not while another call uses `instance`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_instance_set_float(
    instance: *mut TslInstance,
    name: *const c_char,
    name_len: usize,
    value: f32,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || set(instance, name, name_len, ParamValue::Float(value)))
}

/// Sets an `int` parameter.
/// Threads: not while another call uses `instance`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_instance_set_int(
    instance: *mut TslInstance,
    name: *const c_char,
    name_len: usize,
    value: i32,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || set(instance, name, name_len, ParamValue::Int(value)))
}

/// Sets a `bool` parameter.
/// Threads: not while another call uses `instance`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_instance_set_bool(
    instance: *mut TslInstance,
    name: *const c_char,
    name_len: usize,
    value: bool,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || set(instance, name, name_len, ParamValue::Bool(value)))
}

/// Sets a `vector`, `point` or `normal` parameter from 3 floats at `value`.
/// Threads: not while another call uses `instance`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_instance_set_vector(
    instance: *mut TslInstance,
    name: *const c_char,
    name_len: usize,
    value: *const f32,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || set(instance, name, name_len, ParamValue::Triple(super::vec3_arg(value, "value")?)))
}

/// Sets a `vec2` parameter from 2 floats at `value`.
/// Threads: not while another call uses `instance`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_instance_set_vec2(
    instance: *mut TslInstance,
    name: *const c_char,
    name_len: usize,
    value: *const f32,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let v = slice_arg(value, 2, "value")?;
        set(instance, name, name_len, ParamValue::Vec2([v[0], v[1]]))
    })
}

/// Sets a `color` parameter to linear sRGB `(r, g, b)` (upsampled in the
/// spectral models, as an `rgb(r, g, b)` literal is).
/// Threads: not while another call uses `instance`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_instance_set_rgb(
    instance: *mut TslInstance,
    name: *const c_char,
    name_len: usize,
    r: f32,
    g: f32,
    b: f32,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || set(instance, name, name_len, ParamValue::Triple([r, g, b])))
}

/// Sets a `color` parameter to a colour of the program's model: `lanes`
/// floats at `color` (`tsl_program_lanes`).
/// Threads: not while another call uses `instance`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_instance_set_color(
    instance: *mut TslInstance,
    name: *const c_char,
    name_len: usize,
    color: *const f32,
    lanes: usize,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let model = handle(instance, "instance")?.instance.shader().program().color_model();
        super::surface::check_lanes(&model, lanes)?;
        let color = Color::from_lanes(model, slice_arg(color, lanes, "color")?);
        set(instance, name, name_len, ParamValue::Color(color))
    })
}

/// Sets a `string` parameter (checked against its options, if any).
/// Threads: not while another call uses `instance`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_instance_set_string(
    instance: *mut TslInstance,
    name: *const c_char,
    name_len: usize,
    value: *const c_char,
    value_len: usize,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let value = str_arg(value, value_len, "value")?.to_string();
        set(instance, name, name_len, ParamValue::String(value))
    })
}

/// Sets a `material` parameter to a copy of another instance (of the
/// same program); changing `value` later does not change this one.
/// Threads: not while another call uses `instance`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_instance_set_material(
    instance: *mut TslInstance,
    name: *const c_char,
    name_len: usize,
    value: *const TslInstance,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let value = handle(value, "value")?.instance.clone();
        set(instance, name, name_len, ParamValue::Material(Box::new(value)))
    })
}

/// The instance as a material whose numeric, vector, colour and bool
/// values are read at run time (OSL's interactive parameters): binding new
/// values compiles nothing new (the code is compiled once per choice of
/// `string` and `material` values). Into `*out`; free with
/// `tsl_material_free`. The instance may change afterwards without
/// changing the material.
/// Threads: safe with other binds of `instance`, not with its setters.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_instance_bind(
    instance: *const TslInstance,
    out: *mut *mut TslMaterial,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let material = handle(instance, "instance")?.instance.bind()?;
        put(out, TslMaterial { material }, "out")
    })
}

/// The instance compiled with its values folded in as constants (fastest
/// to shade, one compile per call).
/// Threads: safe with other binds of `instance`, not with its setters.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_instance_specialise(
    instance: *const TslInstance,
    out: *mut *mut TslMaterial,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let material = handle(instance, "instance")?.instance.specialise()?;
        put(out, TslMaterial { material }, "out")
    })
}

/// The program's material `name` (a `material name = ...;` declaration).
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_program_material(
    program: *const super::TslProgram,
    name: *const c_char,
    name_len: usize,
    out: *mut *mut TslMaterial,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let material = handle(program, "program")?.program.material(str_arg(name, name_len, "name")?)?;
        put(out, TslMaterial { material }, "out")
    })
}

/// Frees a material (null is ignored).
/// Threads: not while another call uses the handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_material_free(material: *mut TslMaterial) {
    super::free(material);
}
