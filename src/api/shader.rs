//! Shaders: a program's material templates described for a host (what
//! OSL's `oslquery` and MaterialX's node definitions give), and instances
//! of them whose values are checked once.
//!
//! A [`Shader`] is a material definition (`material phong(...) { ... }`)
//! or a material tree with parameters (`material car_paint(...) = ...;`),
//! of the prelude or the program. Its [`ParamInfo`]s come from the
//! declarations: the type, the default (its source text, and its value
//! evaluated in the program's color model when it is a constant), the
//! `///` doc comment and a `string` parameter's declared options.
//!
//! An [`Instance`] holds typed values by parameter index, each checked when
//! set (name, type, option). [`Instance::specialise`] compiles it with the
//! values folded in: the call is written as TSL text
//! (`rough_conductor(alpha: 0.2)`), checked as if written in the root
//! file ([`check_material_expr`]) and lowered as a scene object's material
//! is, so it compiles exactly as that call in source would.
//! [`Instance::bind`] (`bound`) instead reads the numeric, vector, color
//! and bool values from a parameter block at run time, from code compiled
//! once per combination of material and string values.

use super::param_value::{ParamType, ParamValue};
use super::{Error, Material, Program};
use crate::check::{self, SymbolKind, Ty, check_material_expr};
use crate::diag::{Diagnostic, Span, did_you_mean};
use crate::syntax::ast::{Expr, ExprKind, Item, Param};
use std::fmt;
use std::sync::Arc;

/// One parameter of a [`Shader`].
#[derive(Debug, Clone, PartialEq)]
pub struct ParamInfo {
    pub name: String,
    pub ty: ParamType,
    /// `Some(n)` for an array of `n` elements of `ty`.
    pub array_len: Option<u32>,
    /// The default as written (`gray(0.5)`); `None` for a required
    /// parameter.
    pub default_source: Option<String>,
    /// The default evaluated in the program's color model; `None` when
    /// the parameter is required, or its default is not one constant (it
    /// reads the shading point, is a material or an array).
    pub default: Option<ParamValue>,
    /// The `///` comment above the declaration.
    pub doc: Option<String>,
    /// The values a `string` parameter declares it accepts (`in ("a",
    /// "b")`); empty when it declares none.
    pub options: Vec<String>,
    /// Where the parameter is declared.
    span: Span,
}

impl ParamInfo {
    /// Whether an instance must give this parameter a value.
    pub fn required(&self) -> bool {
        self.default_source.is_none()
    }

    /// The declared type as TSL writes it: `float`, `color[4]`.
    pub fn type_text(&self) -> String {
        match self.array_len {
            Some(n) => format!("{}[{n}]", self.ty),
            None => self.ty.to_string(),
        }
    }
}

/// A material template of a program: its name, documentation and
/// parameters. Cheap to clone; it keeps its program alive.
#[derive(Clone)]
pub struct Shader {
    program: Program,
    desc: Arc<ShaderDesc>,
}

struct ShaderDesc {
    name: String,
    doc: Option<String>,
    params: Vec<ParamInfo>,
    in_prelude: bool,
    /// Where its name is declared.
    span: Span,
}

impl fmt::Debug for Shader {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Shader").field("name", &self.desc.name).field("params", &self.desc.params).finish()
    }
}

impl Program {
    /// Every material template the program's own code can call, the
    /// prelude's included ([`Shader::in_prelude`]), in definition order
    /// (the prelude's first).
    ///
    /// ```
    /// let program = tsl::Compiler::new().source("m.tsl", "material tinted(color c = gray(0.3)) = lambert(kd: c);").compile()?;
    /// let shaders = program.shaders();
    /// assert!(shaders.iter().any(|s| s.name() == "rough_conductor" && s.in_prelude()));
    /// assert_eq!(shaders.iter().filter(|s| !s.in_prelude()).map(|s| s.name()).collect::<Vec<_>>(), ["tinted"]);
    /// # Ok::<(), tsl::Error>(())
    /// ```
    pub fn shaders(&self) -> Vec<Shader> {
        let checked = self.checked();
        let mut symbols: Vec<(&String, &check::Symbol)> =
            checked.symbols.iter().filter(|(_, s)| is_template(checked, s)).collect();
        symbols.sort_by_key(|(_, s)| (s.module, s.item));
        symbols.into_iter().map(|(name, sym)| self.describe_shader(name, *sym)).collect()
    }

    /// The material template `name` (see [`Program::shaders`]); an error,
    /// with a did-you-mean, for a name that is not one.
    ///
    /// ```
    /// let program = tsl::Compiler::new().source("m.tsl", "material m = lambert;").compile()?;
    /// let shader = program.shader("rough_conductor")?;
    /// let alpha = shader.param("alpha").unwrap();
    /// assert_eq!((alpha.ty, alpha.doc.as_deref()), (tsl::ParamType::Float, Some("microfacet roughness")));
    /// assert_eq!(alpha.default, Some(tsl::ParamValue::Float(0.1)));
    /// let err = program.shader("rough_conductr").unwrap_err();
    /// assert!(err.to_string().contains("did you mean `rough_conductor`?"));
    /// # Ok::<(), tsl::Error>(())
    /// ```
    pub fn shader(&self, name: &str) -> Result<Shader, Error> {
        let checked = self.checked();
        match checked.symbols.get(name) {
            Some(sym) if is_template(checked, sym) => Ok(self.describe_shader(name, *sym)),
            found => {
                let templates =
                    checked.symbols.iter().filter(|(_, s)| is_template(checked, s)).map(|(n, _)| n.as_str());
                let mut message = match found {
                    Some(sym) if sym.kind == SymbolKind::MaterialTree => {
                        format!("`{name}` is a material tree without parameters, not a material template")
                    }
                    Some(_) => format!("`{name}` is not a material template"),
                    None => format!("no material template named `{name}`"),
                };
                if let Some(s) = did_you_mean(name, templates).filter(|_| found.is_none()) {
                    message.push_str(&format!(" (did you mean `{s}`?)"));
                }
                Err(Error::plain(message))
            }
        }
    }

    fn describe_shader(&self, name: &str, sym: check::Symbol) -> Shader {
        let checked = self.checked();
        let module = &checked.loaded.modules[sym.module];
        let text = checked.loaded.sources.text(module.file);
        let (params, start): (&[Param], usize) = match &module.ast.items[sym.item] {
            Item::Material(d) => (&d.params, d.span.start as usize),
            Item::MaterialTree(t) => (t.params.as_deref().unwrap_or(&[]), t.span.start as usize),
            _ => (&[], sym.span.start as usize),
        };
        let params = params.iter().map(|p| self.describe_param(p, text, module.is_prelude)).collect();
        let desc = ShaderDesc {
            name: name.to_string(),
            doc: crate::syntax::doc_comment(text, start),
            params,
            in_prelude: module.is_prelude,
            span: sym.span,
        };
        Shader { program: self.clone(), desc: Arc::new(desc) }
    }

    fn describe_param(&self, p: &Param, text: &str, in_prelude: bool) -> ParamInfo {
        let checked_ty = Ty::from_ast(&p.ty);
        // Parameters are checked: every declared type has a parameter type.
        let (ty, array_len) = ParamType::of(&checked_ty).unwrap_or((ParamType::Float, None));
        let default_source =
            p.default.as_ref().map(|d| text.get(d.span.start as usize..d.span.end as usize).unwrap_or("").to_string());
        let default = p.default.as_ref().and_then(|d| self.default_value(d, &checked_ty, ty, in_prelude));
        ParamInfo {
            name: p.name.name.to_string(),
            ty,
            array_len,
            default_source,
            default,
            doc: crate::syntax::doc_comment(text, p.span.start as usize),
            options: p.options.iter().flat_map(|o| o.values.iter().map(|(v, _)| v.clone())).collect(),
            span: p.name.span,
        }
    }

    /// A default's value when it is one constant of a plain type.
    fn default_value(&self, d: &Expr, checked_ty: &Ty, ty: ParamType, in_prelude: bool) -> Option<ParamValue> {
        match (&d.kind, ty) {
            (ExprKind::Str(s), ParamType::String) => return Some(ParamValue::String(s.clone())),
            (_, ParamType::String | ParamType::Material | ParamType::BsdfSample) => return None,
            _ if matches!(checked_ty, Ty::Array(..)) => return None,
            _ => {}
        }
        let checked = self.checked();
        // Values are lowered as root code; a prelude default naming a
        // prelude item the program shadows would mean the program's.
        if in_prelude && shadows_a_name_of(checked, d) {
            return None;
        }
        let (f, diags) = crate::ir::lower::lower_value(checked, self.color_model(), "default", d, checked_ty, false);
        if !diags.is_empty() {
            return None;
        }
        ParamValue::from_words(ty, &f.constant_results()?, self.color_model())
    }
}

/// Whether the symbol is a material template: a definition, or a tree
/// with parameters.
fn is_template(checked: &check::Program, sym: &check::Symbol) -> bool {
    match sym.kind {
        SymbolKind::Material => true,
        SymbolKind::MaterialTree => matches!(
            &checked.loaded.modules[sym.module].ast.items[sym.item],
            Item::MaterialTree(t) if t.params.is_some()
        ),
        SymbolKind::Function | SymbolKind::Const => false,
    }
}

/// Whether `d` (prelude code) names, as a whole word, a prelude item that
/// the program's own definitions shadow.
fn shadows_a_name_of(checked: &check::Program, d: &Expr) -> bool {
    let text = checked.loaded.sources.text(d.span.file);
    let written = text.get(d.span.start as usize..d.span.end as usize).unwrap_or("");
    let mut words = written.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_'));
    words.any(|w| checked.prelude_symbols.get(w).is_some_and(|p| checked.symbols.get(w) != Some(p)))
}

impl Shader {
    /// The template's name: `rough_conductor`.
    pub fn name(&self) -> &str {
        &self.desc.name
    }

    /// The `///` comment above the template, if any.
    pub fn doc(&self) -> Option<&str> {
        self.desc.doc.as_deref()
    }

    /// The parameters, in declaration order (an instance's values are
    /// indexed alike).
    pub fn params(&self) -> &[ParamInfo] {
        &self.desc.params
    }

    /// The parameter `name`.
    pub fn param(&self, name: &str) -> Option<&ParamInfo> {
        self.desc.params.iter().find(|p| p.name == name)
    }

    /// Whether the template is the standard library's.
    pub fn in_prelude(&self) -> bool {
        self.desc.in_prelude
    }

    /// The program the template belongs to.
    pub fn program(&self) -> &Program {
        &self.program
    }

    /// A new instance, every parameter at its default.
    pub fn instance(&self) -> Instance {
        Instance { shader: self.clone(), values: vec![None; self.desc.params.len()] }
    }

    /// An error at the declaration of `at` (a parameter's name, or the
    /// template's).
    pub(super) fn error(&self, at: Span, message: String, help: Option<String>) -> Error {
        let mut d = Diagnostic::error(at, message);
        if let Some(help) = help {
            d = d.with_help(help);
        }
        self.program.error(d)
    }
}

/// Values for a [`Shader`]'s parameters, checked as they are set, by
/// parameter index (`None` keeps the default). Cheap to clone; setting a
/// value compiles nothing.
///
/// ```
/// use tsl::{Compiler, ShadingGlobals};
/// let program = Compiler::new().source("m.tsl", "material m = lambert;").compile()?;
/// let mut metal = program.shader("rough_conductor")?.instance();
/// metal.set("alpha", 0.2)?.set("distribution", "ggx")?;
/// assert_eq!(metal.source(), "rough_conductor(alpha: 0.20000000298023224, distribution: \"ggx\")");
/// let err = metal.set("distribution", "gxx").unwrap_err();
/// assert!(err.to_string().contains("did you mean \"ggx\"?"));
/// let material = metal.specialise()?;
/// let g = ShadingGlobals { n: [0.0, 0.0, 1.0], ..Default::default() };
/// let c = material.reflection(&g, [0.0, 0.0, 1.0], &program.rgb(1.0, 1.0, 1.0), [0.0, 0.0, 1.0]);
/// assert!(c.to_rgb()[0] > 0.0);
/// # Ok::<(), tsl::Error>(())
/// ```
#[derive(Clone)]
pub struct Instance {
    shader: Shader,
    values: Vec<Option<ParamValue>>,
}

impl fmt::Debug for Instance {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.source())
    }
}

impl PartialEq for Instance {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.shader.program.inner, &other.shader.program.inner)
            && self.shader.name() == other.shader.name()
            && self.values == other.values
    }
}

impl Instance {
    /// The shader this is an instance of.
    pub fn shader(&self) -> &Shader {
        &self.shader
    }

    /// The values set so far, by parameter index; `None` where the
    /// default holds.
    pub fn values(&self) -> &[Option<ParamValue>] {
        &self.values
    }

    /// The value set for parameter `name`, if one was.
    pub fn value(&self, name: &str) -> Option<&ParamValue> {
        let k = self.shader.params().iter().position(|p| p.name == name)?;
        self.values[k].as_ref()
    }

    /// Sets parameter `name`, checked now: an unknown name (with a
    /// did-you-mean), a value of the wrong type, a string outside the
    /// declared options, or a non-finite number is an error and the
    /// instance is unchanged. A `float` parameter takes an `f32` or an
    /// `i32`; a `color` RGB as `[f32; 3]` or a [`Color`](crate::Color) of
    /// the program's model, its lanes used as given (not in the `Hero`
    /// model, whose lanes' wavelengths change per camera sample: it takes
    /// RGB); a vector, point or normal `[f32; 3]`; a `material` an instance
    /// of a shader of the same program (whose colors, if it has spectral
    /// ones, must be RGB: only an instance's own call folds lanes in).
    /// Array and matrix parameters are set in TSL source.
    pub fn set(&mut self, name: &str, value: impl Into<ParamValue>) -> Result<&mut Self, Error> {
        let value = value.into();
        let shader = &self.shader;
        let Some(k) = shader.params().iter().position(|p| p.name == name) else {
            let names = shader.params().iter().map(|p| p.name.as_str());
            let help = match did_you_mean(name, names) {
                Some(s) => format!("did you mean `{s}`?"),
                None => format!("its parameters are: {}", list(shader.params().iter().map(|p| p.name.as_str()))),
            };
            let message = format!("`{}` has no parameter named `{name}`", shader.name());
            return Err(shader.error(shader.desc.span, message, Some(help)));
        };
        let value = self.checked(&shader.params()[k], value)?;
        self.values[k] = Some(value);
        Ok(self)
    }

    /// `value` for `param`, converted where TSL converts (an int to a
    /// float), or the error saying why it does not fit.
    fn checked(&self, param: &ParamInfo, value: ParamValue) -> Result<ParamValue, Error> {
        let shader = &self.shader;
        let whose = Whose(&param.name, shader.name());
        let wrong = |help: Option<String>| {
            let message = format!("{whose} is a `{}`, not {}", param.type_text(), value.describe());
            Err(shader.error(param.span, message, help))
        };
        if param.array_len.is_some() || matches!(param.ty, ParamType::Matrix | ParamType::BsdfSample) {
            let message = format!("{whose} is a `{}`: set it in TSL source", param.type_text());
            return Err(shader.error(param.span, message, None));
        }
        let finite = |xs: &[f32]| xs.iter().all(|x| x.is_finite());
        let not_finite = || {
            let message = format!("{whose} must be finite, not {value}");
            Err(shader.error(param.span, message, None))
        };
        let model = shader.program.color_model();
        match (param.ty, &value) {
            (ParamType::Float, ParamValue::Float(x)) if !x.is_finite() => not_finite(),
            (ParamType::Float, ParamValue::Int(i)) => Ok(ParamValue::Float(*i as f32)),
            (ParamType::Float, ParamValue::Float(_))
            | (ParamType::Int, ParamValue::Int(_))
            | (ParamType::Bool, ParamValue::Bool(_)) => Ok(value),
            (ParamType::Color | ParamType::Vector | ParamType::Point | ParamType::Normal, ParamValue::Triple(t)) => {
                if finite(t) {
                    Ok(value)
                } else {
                    not_finite()
                }
            }
            (ParamType::Vec2, ParamValue::Vec2(v)) => {
                if finite(v) {
                    Ok(value)
                } else {
                    not_finite()
                }
            }
            (ParamType::Color, ParamValue::Color(c)) => {
                if c.model() != model || c.lanes().len() != model.lanes() {
                    let message = format!(
                        "{whose} takes a color of the program's model ({model:?}, {} lanes), not {:?} ({} lanes)",
                        model.lanes(),
                        c.model(),
                        c.lanes().len()
                    );
                    let help = "make it with `Program::rgb` or `Color::from_lanes` in the program's model, or give RGB as `[f32; 3]`";
                    Err(shader.error(param.span, message, Some(help.into())))
                } else if model == crate::ColorModel::Hero {
                    let message = format!(
                        "{whose}: a Hero program's lanes are at wavelengths drawn per camera sample: it takes a color's RGB ([f32; 3])"
                    );
                    Err(shader.error(param.span, message, None))
                } else if !finite(c.lanes()) {
                    not_finite()
                } else {
                    Ok(value)
                }
            }
            (ParamType::String, ParamValue::String(s)) => self.checked_option(param, &whose, s).map(|()| value),
            (ParamType::Material, ParamValue::Material(m)) => {
                if !Arc::ptr_eq(&m.shader.program.inner, &shader.program.inner) {
                    let message = format!("{whose} takes an instance of a shader of the same program");
                    Err(shader.error(param.span, message, None))
                } else if let Some(inner) = m.lanes_only_value() {
                    let message = format!(
                        "{whose}: the instance's `{inner}` is a spectral color, whose lanes only an instance's own call takes"
                    );
                    Err(shader.error(param.span, message, Some(format!("give `{inner}` as RGB ([f32; 3])"))))
                } else {
                    Ok(value)
                }
            }
            (ParamType::Color, _) => wrong(Some("give a `Color` or RGB as `[f32; 3]`".into())),
            _ => wrong(None),
        }
    }

    fn checked_option(&self, param: &ParamInfo, whose: &Whose<'_>, s: &str) -> Result<(), Error> {
        let shader = &self.shader;
        if s.contains(['"', '\n', '\r']) {
            let message = format!("{whose} cannot hold quotes or line breaks, as TSL strings cannot");
            return Err(shader.error(param.span, message, None));
        }
        if param.options.is_empty() || param.options.iter().any(|o| o == s) {
            return Ok(());
        }
        let help = did_you_mean(s, param.options.iter().map(String::as_str)).map(|o| format!("did you mean \"{o}\"?"));
        let options = list(param.options.iter().map(|o| format!("\"{o}\"")));
        let message = format!("{whose} has no option \"{s}\" (the options are {options})");
        Err(shader.error(param.span, message, help))
    }

    /// The name of the first parameter whose value TSL has no text for (a
    /// spectral [`Color`](crate::Color)), in this instance or a material
    /// value of it.
    fn lanes_only_value(&self) -> Option<String> {
        self.shader.params().iter().zip(&self.values).find_map(|(p, v)| match v.as_ref()? {
            ParamValue::Material(m) => m.lanes_only_value().map(|inner| format!("{}.{inner}", p.name)),
            v if v.source(p.ty).is_none() => Some(p.name.clone()),
            _ => None,
        })
    }

    /// The instance as the TSL call it stands for: the values set, by
    /// name, in declaration order (`rough_conductor(alpha: 0.05)`). A
    /// spectral [`Color`](crate::Color), which TSL cannot write, is
    /// written as the `rgb(...)` of its [`Color::to_rgb`](crate::Color::to_rgb);
    /// the instance's code uses the lanes themselves.
    pub fn source(&self) -> String {
        let args: Vec<String> = self
            .shader
            .params()
            .iter()
            .zip(&self.values)
            .filter_map(|(p, v)| {
                let v = v.as_ref()?;
                Some(format!("{}: {}", p.name, v.call_text(p.ty)))
            })
            .collect();
        format!("{}({})", self.shader.name(), args.join(", "))
    }

    /// Compiles the instance with its values folded in as constants: the
    /// same code as [`Instance::source`] written as a scene object's
    /// material, so the same results. A spectral [`Color`](crate::Color)
    /// is folded in as its lanes, the constants a literal's lanes are
    /// (so a color from [`Program::rgb`](crate::Program::rgb) gives what
    /// `rgb(...)` in source gives). Each call compiles again (a host
    /// keeps the [`Material`]); the code lives as long as the material.
    /// An error when a required parameter has no value.
    pub fn specialise(&self) -> Result<Material, Error> {
        self.check_required()?;
        let shader = &self.shader;
        let program = &shader.program;
        let name = format!("<instance of {}>", shader.name());
        let checked = check_material_expr(program.checked(), &name, &self.source());
        let to_error =
            |diagnostics: Vec<Diagnostic>| Error { diagnostics, sources: checked.program.loaded.sources.clone() };
        let Some(expr) = checked.ok() else {
            return Err(to_error(checked.diagnostics.clone()));
        };
        let entry = format!("@{}", shader.name());
        let model = program.color_model();
        // Values without TSL text (a spectral color's lanes) replace their
        // stand-in text as the constants of a block the code never reads.
        let lanes_only: Vec<bool> = (shader.params().iter().zip(&self.values))
            .map(|(p, v)| v.as_ref().is_some_and(|v| v.source(p.ty).is_none()))
            .collect();
        let (ir, entries, diags) = if lanes_only.contains(&true) {
            let block = self.constant_block(expr.span, &lanes_only)?;
            crate::ir::lower::lower_material_with_instance(&checked.program, model, &entry, expr, block)
        } else {
            crate::ir::lower::lower_material_exprs(&checked.program, model, &[(entry.clone(), expr)])
        };
        if !diags.is_empty() {
            return Err(to_error(diags));
        }
        let part = program.jit_part(ir, entries)?;
        let methods = super::interface_functions(&part, &entry)?.into_iter().map(Some);
        Ok(Material::new(program.clone(), super::material::Code::methods_only(entry, methods)))
    }

    /// An error naming the required parameters without a value.
    pub(super) fn check_required(&self) -> Result<(), Error> {
        let shader = &self.shader;
        let missing: Vec<&str> = shader
            .params()
            .iter()
            .zip(&self.values)
            .filter(|(p, v)| p.required() && v.is_none())
            .map(|(p, _)| p.name.as_str())
            .collect();
        if !missing.is_empty() {
            let message = format!(
                "`{}` needs a value for {} (no default)",
                shader.name(),
                list(missing.iter().map(|m| format!("`{m}`")))
            );
            return Err(shader.error(shader.desc.span, message, Some("set it with `Instance::set`".into())));
        }
        Ok(())
    }
}

/// `` `alpha` of `rough_conductor` ``: written only into an error, so a
/// value that fits costs no allocation.
struct Whose<'a>(&'a str, &'a str);

impl fmt::Display for Whose<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "`{}` of `{}`", self.0, self.1)
    }
}

fn list(items: impl Iterator<Item = impl AsRef<str>>) -> String {
    items.map(|s| s.as_ref().to_string()).collect::<Vec<_>>().join(", ")
}
