//! Compilers, programs and shaders: compile from a path or a string with a
//! colour model, list the material templates and their parameters.

use super::{TslError, TslStatus, TslStr, guard, guard_value, handle, handle_mut, invalid, put, str_arg};
use crate::{ColorModel, Compiler, ParamType, ParamValue, Program, Shader};
use std::ffi::c_char;
use std::path::PathBuf;

/// What to compile and how: a builder the caller owns (`tsl_compiler_new`,
/// `tsl_compiler_free`). Not for concurrent use; several compilers may
/// compile on several threads at once.
pub struct TslCompiler {
    color_model: ColorModel,
    source: Option<(String, String)>,
    file: Option<PathBuf>,
    import_paths: Vec<PathBuf>,
}

/// A compiled program. Immutable and thread-safe: every function taking a
/// `const TslProgram *` may be called from many threads at once. Shaders
/// and materials made from it keep what they need alive, so it may be
/// freed before them.
pub struct TslProgram {
    pub(crate) program: Program,
    shaders: Vec<Shader>,
}

/// A material template of a program: its name, documentation and
/// parameters. Immutable and thread-safe.
pub struct TslShader {
    pub(crate) shader: Shader,
}

/// The type of a shader parameter.
#[repr(C)]
#[allow(non_camel_case_types)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TslParamType {
    TSL_TYPE_FLOAT,
    TSL_TYPE_INT,
    TSL_TYPE_BOOL,
    TSL_TYPE_COLOR,
    TSL_TYPE_VECTOR,
    TSL_TYPE_POINT,
    TSL_TYPE_NORMAL,
    TSL_TYPE_VEC2,
    TSL_TYPE_MATRIX,
    /// A sampled direction: hosts cannot set one.
    TSL_TYPE_BSDF_SAMPLE,
    TSL_TYPE_STRING,
    TSL_TYPE_MATERIAL,
}

/// What a `TslValue` holds.
#[repr(C)]
#[allow(non_camel_case_types)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TslValueKind {
    /// No value: a required parameter, or a default that is not one
    /// constant (it reads the shading point, or is a material or array).
    TSL_VALUE_NONE,
    /// `floats[0]`.
    TSL_VALUE_FLOAT,
    /// `int_value`.
    TSL_VALUE_INT,
    /// `int_value`, 0 or 1.
    TSL_VALUE_BOOL,
    /// `floats[0..3]`: a vector, point or normal.
    TSL_VALUE_VECTOR,
    /// `floats[0..3]`: a color as linear sRGB.
    TSL_VALUE_COLOR,
    /// `floats[0..2]`.
    TSL_VALUE_VEC2,
    /// `floats[0..12]`: a matrix's twelve words as compiled code stores them.
    TSL_VALUE_MATRIX,
    /// `string`.
    TSL_VALUE_STRING,
}

/// A parameter's default value.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct TslValue {
    pub kind: TslValueKind,
    pub int_value: i32,
    pub floats: [f32; 12],
    pub string: TslStr,
}

/// One parameter of a shader; its strings are owned by the shader handle.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct TslParam {
    pub name: TslStr,
    pub ty: TslParamType,
    /// The element count of an array parameter, 0 for a single value.
    pub array_len: u32,
    /// The default as written in the source (`gray(0.5)`), `{NULL, 0}`
    /// for a required parameter.
    pub default_source: TslStr,
    /// The default evaluated in the program's colour model.
    pub default_value: TslValue,
    /// The `///` comment above the declaration, `{NULL, 0}` when none.
    pub doc: TslStr,
    /// The values a `string` parameter accepts (`tsl_shader_param_option`),
    /// 0 when it declares none.
    pub option_count: usize,
}

/// A new compiler: RGB colour model, no source yet. Free it with
/// `tsl_compiler_free`. Never null.
/// Thread-safe.
#[unsafe(no_mangle)]
pub extern "C" fn tsl_compiler_new() -> *mut TslCompiler {
    let compiler = TslCompiler { color_model: ColorModel::Rgb, source: None, file: None, import_paths: Vec::new() };
    Box::into_raw(Box::new(compiler))
}

/// Frees a compiler (null is ignored).
/// Threads: not while another call uses the handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_compiler_free(compiler: *mut TslCompiler) {
    super::free(compiler);
}

/// Sets the colour model by the CLI's names: `rgb`, `spectral` (= `hero`),
/// `spectralN` or `smitsN` with N in 1..=64.
/// Threads: not while another call uses `compiler`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_compiler_color_model(
    compiler: *mut TslCompiler,
    name: *const c_char,
    name_len: usize,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let compiler = handle_mut(compiler, "compiler")?;
        let name = str_arg(name, name_len, "name")?;
        let Some(model) = ColorModel::parse(name) else {
            return invalid(format!(
                "`{name}` is not a color model: use rgb, spectral (= hero), spectralN or smitsN with N in 1..=64"
            ));
        };
        compiler.color_model = model;
        Ok(())
    })
}

/// Compiles `text`, named `name` in diagnostics, instead of a file.
/// Threads: not while another call uses `compiler`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_compiler_source(
    compiler: *mut TslCompiler,
    name: *const c_char,
    name_len: usize,
    text: *const c_char,
    text_len: usize,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let compiler = handle_mut(compiler, "compiler")?;
        let name = str_arg(name, name_len, "name")?;
        let text = str_arg(text, text_len, "text")?;
        compiler.source = Some((name.to_string(), text.to_string()));
        compiler.file = None;
        Ok(())
    })
}

/// Compiles the file at `path` (UTF-8) instead of a string.
/// Threads: not while another call uses `compiler`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_compiler_file(
    compiler: *mut TslCompiler,
    path: *const c_char,
    path_len: usize,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let compiler = handle_mut(compiler, "compiler")?;
        compiler.file = Some(PathBuf::from(str_arg(path, path_len, "path")?));
        compiler.source = None;
        Ok(())
    })
}

/// Adds a folder to search for `import`s.
/// Threads: not while another call uses `compiler`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_compiler_import_path(
    compiler: *mut TslCompiler,
    dir: *const c_char,
    dir_len: usize,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let compiler = handle_mut(compiler, "compiler")?;
        compiler.import_paths.push(PathBuf::from(str_arg(dir, dir_len, "dir")?));
        Ok(())
    })
}

/// Compiles the compiler's source into a new program in `*out` (free it
/// with `tsl_program_free`). A compile error is `TSL_ERROR` with the
/// diagnostics in `*error`. The compiler may be used again.
/// Threads: safe with other compiles of `compiler`, not with its setters.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_compiler_compile(
    compiler: *const TslCompiler,
    out: *mut *mut TslProgram,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let c = handle(compiler, "compiler")?;
        let mut builder = Compiler::new().color_model(c.color_model);
        for dir in &c.import_paths {
            builder = builder.import_path(dir.clone());
        }
        builder = match (&c.file, &c.source) {
            (Some(path), _) => builder.file(path.clone()),
            (None, Some((name, text))) => builder.source(name, text),
            (None, None) => builder,
        };
        let program = builder.compile()?;
        let shaders = program.shaders();
        put(out, TslProgram { program, shaders }, "out")
    })
}

/// Frees a program (null is ignored).
/// Threads: not while another call uses the handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_program_free(program: *mut TslProgram) {
    super::free(program);
}

/// The number of floats in one of the program's colours: 3 in RGB, N in
/// `spectralN`, 4 in `hero`. Every colour a surface call takes or gives
/// has this many lanes. 0 for a null program.
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_program_lanes(program: *const TslProgram) -> usize {
    guard_value(0, || handle(program, "program").map_or(0, |p| p.program.color_model().lanes()))
}

/// The colour of linear sRGB `(r, g, b)` in the program's colour model
/// (upsampled to a spectrum in the spectral models), into `out`, which
/// holds `lanes` floats (`tsl_program_lanes`).
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_program_rgb(
    program: *const TslProgram,
    r: f32,
    g: f32,
    b: f32,
    out: *mut f32,
    lanes: usize,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let p = handle(program, "program")?;
        let color = p.program.rgb(r, g, b);
        super::surface::check_lanes(&p.program.color_model(), lanes)?;
        super::slice_out(out, lanes, "out")?.copy_from_slice(color.lanes());
        Ok(())
    })
}

/// A colour of the program's model (`lanes` floats at `color`) as linear
/// sRGB, into `rgb` (3 floats).
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_program_to_rgb(
    program: *const TslProgram,
    color: *const f32,
    lanes: usize,
    rgb: *mut f32,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let p = handle(program, "program")?;
        let color = super::surface::color_arg(&p.program, color, lanes, "color")?;
        super::slice_out(rgb, 3, "rgb")?.copy_from_slice(&color.to_rgb());
        Ok(())
    })
}

/// The number of material templates (shaders) of the program, the
/// standard library's included, in declaration order.
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_program_shader_count(program: *const TslProgram) -> usize {
    guard_value(0, || handle(program, "program").map_or(0, |p| p.shaders.len()))
}

/// The name of shader `index` (below `tsl_program_shader_count`), owned by
/// the program; `{NULL, 0}` past the end.
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_program_shader_name(program: *const TslProgram, index: usize) -> TslStr {
    guard_value(TslStr::NONE, || {
        handle(program, "program")
            .ok()
            .and_then(|p| p.shaders.get(index))
            .map_or(TslStr::NONE, |s| TslStr::of(s.name()))
    })
}

/// Whether shader `index` comes from the standard library (false past the
/// end).
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_program_shader_in_prelude(program: *const TslProgram, index: usize) -> bool {
    guard_value(false, || {
        handle(program, "program").ok().and_then(|p| p.shaders.get(index)).is_some_and(|s| s.in_prelude())
    })
}

/// The material template `name` into `*out` (free it with
/// `tsl_shader_free`); an unknown name is `TSL_ERROR` with a did-you-mean.
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_program_shader(
    program: *const TslProgram,
    name: *const c_char,
    name_len: usize,
    out: *mut *mut TslShader,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let p = handle(program, "program")?;
        let shader = p.program.shader(str_arg(name, name_len, "name")?)?;
        put(out, TslShader { shader }, "out")
    })
}

/// Frees a shader (null is ignored).
/// Threads: not while another call uses the handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_shader_free(shader: *mut TslShader) {
    super::free(shader);
}

/// The shader's name, owned by it.
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_shader_name(shader: *const TslShader) -> TslStr {
    guard_value(TslStr::NONE, || handle(shader, "shader").map_or(TslStr::NONE, |s| TslStr::of(s.shader.name())))
}

/// The `///` comment above the shader, `{NULL, 0}` when none.
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_shader_doc(shader: *const TslShader) -> TslStr {
    guard_value(TslStr::NONE, || handle(shader, "shader").map_or(TslStr::NONE, |s| TslStr::of_option(s.shader.doc())))
}

/// The number of parameters of the shader.
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_shader_param_count(shader: *const TslShader) -> usize {
    guard_value(0, || handle(shader, "shader").map_or(0, |s| s.shader.params().len()))
}

/// Parameter `index` (below `tsl_shader_param_count`) into `*out`, its
/// strings owned by the shader.
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_shader_param(
    shader: *const TslShader,
    index: usize,
    out: *mut TslParam,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let s = handle(shader, "shader")?;
        let params = s.shader.params();
        let Some(p) = params.get(index) else {
            return invalid(format!("parameter {index} of a shader with {}", params.len()));
        };
        let param = TslParam {
            name: TslStr::of(&p.name),
            ty: param_type(p.ty),
            array_len: p.array_len.unwrap_or(0),
            default_source: TslStr::of_option(p.default_source.as_deref()),
            default_value: value(p.default.as_ref()),
            doc: TslStr::of_option(p.doc.as_deref()),
            option_count: p.options.len(),
        };
        super::write(out, param, "out")
    })
}

/// Option `option` of parameter `index` (`in ("beckmann", "ggx")`), owned
/// by the shader; `{NULL, 0}` past the end.
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_shader_param_option(shader: *const TslShader, index: usize, option: usize) -> TslStr {
    guard_value(TslStr::NONE, || {
        handle(shader, "shader")
            .ok()
            .and_then(|s| s.shader.params().get(index))
            .and_then(|p| p.options.get(option))
            .map_or(TslStr::NONE, |o| TslStr::of(o))
    })
}

fn param_type(ty: ParamType) -> TslParamType {
    match ty {
        ParamType::Float => TslParamType::TSL_TYPE_FLOAT,
        ParamType::Int => TslParamType::TSL_TYPE_INT,
        ParamType::Bool => TslParamType::TSL_TYPE_BOOL,
        ParamType::Color => TslParamType::TSL_TYPE_COLOR,
        ParamType::Vector => TslParamType::TSL_TYPE_VECTOR,
        ParamType::Point => TslParamType::TSL_TYPE_POINT,
        ParamType::Normal => TslParamType::TSL_TYPE_NORMAL,
        ParamType::Vec2 => TslParamType::TSL_TYPE_VEC2,
        ParamType::Matrix => TslParamType::TSL_TYPE_MATRIX,
        ParamType::BsdfSample => TslParamType::TSL_TYPE_BSDF_SAMPLE,
        ParamType::String => TslParamType::TSL_TYPE_STRING,
        ParamType::Material => TslParamType::TSL_TYPE_MATERIAL,
    }
}

fn value(v: Option<&ParamValue>) -> TslValue {
    let mut out =
        TslValue { kind: TslValueKind::TSL_VALUE_NONE, int_value: 0, floats: [0.0; 12], string: TslStr::NONE };
    let mut floats = |kind, xs: &[f32]| {
        out.kind = kind;
        out.floats[..xs.len()].copy_from_slice(xs);
    };
    match v {
        None | Some(ParamValue::Material(_)) => {}
        Some(ParamValue::Float(x)) => floats(TslValueKind::TSL_VALUE_FLOAT, &[*x]),
        Some(ParamValue::Triple(t)) => floats(TslValueKind::TSL_VALUE_VECTOR, t),
        Some(ParamValue::Vec2(t)) => floats(TslValueKind::TSL_VALUE_VEC2, t),
        Some(ParamValue::Matrix(m)) => floats(TslValueKind::TSL_VALUE_MATRIX, m),
        Some(ParamValue::Color(c)) => floats(TslValueKind::TSL_VALUE_COLOR, &c.to_rgb()),
        Some(ParamValue::Int(i)) => {
            out.kind = TslValueKind::TSL_VALUE_INT;
            out.int_value = *i;
        }
        Some(ParamValue::Bool(b)) => {
            out.kind = TslValueKind::TSL_VALUE_BOOL;
            out.int_value = i32::from(*b);
        }
        Some(ParamValue::String(s)) => {
            out.kind = TslValueKind::TSL_VALUE_STRING;
            out.string = TslStr::of(s);
        }
    }
    out
}
