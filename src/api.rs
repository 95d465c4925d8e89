//! The embedding API: compile TSL source to native code and call materials
//! and generators from a host.
//!
//! ```
//! use tsl::{ColorModel, Compiler, ShadingGlobals};
//!
//! let src = r#"
//!     float rings(float scale = 8) { return fract(length(vec2(Pl.x, Pl.z)) * scale); }
//!     material wood = mix(rings(), lambert(kd: rgb(0.6, 0.4, 0.2)), lambert(kd: rgb(0.35, 0.2, 0.08)));
//! "#;
//! let program = Compiler::new().color_model(ColorModel::Rgb).source("wood.tsl", src).compile()?;
//! let wood = program.material("wood")?;
//! let g = ShadingGlobals { n: [0.0, 0.0, 1.0], pl: [0.1, 0.0, 0.0], ..Default::default() };
//! let light = program.rgb(1.0, 1.0, 1.0);
//! let c = wood.reflection(&g, [0.0, 0.0, 1.0], &light, [0.0, 0.0, 1.0]);
//! assert!(c.to_rgb()[0] > 0.0);
//! # Ok::<(), tsl::Error>(())
//! ```

use crate::check::{self, MaterialRef, SymbolKind};
use crate::color::{self, ColorModel, MAX_SAMPLES};
use crate::diag::Diagnostic;
use crate::globals::ShadingGlobals;
use crate::ir::lower::{Entry, lower_entries};
use crate::ir::{Function as IrFunction, Module as IrModule};
use crate::jit::{EntryFn, Jit, JitOptions};
use crate::load::LoadOptions;
use crate::scene::SceneDesc;
use crate::syntax::ast::{Expr, Item};
use std::collections::HashMap;
use std::fmt;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, RwLock};

mod batch;
mod bound;
mod error;
mod material;
mod outputs;
mod param_value;
mod prepared;
mod profile;
mod shader;
mod surface;
mod surface_batch;
mod surfaces;
mod typed;

pub use crate::ir::lower::HitMethod;
pub use batch::{Column, Layout, MAX_BATCH_WORDS, ShadingBatch};
pub use bound::MAX_BOUND_COMBINATIONS;
pub use error::{Error, MAX_DEBUG_DIAGNOSTICS};
pub use material::{Material, MaterialFacts, SampledDir};
pub use outputs::{BsdfSample, DeltaLobe, DeltaLobes, EvalPdf, Lanes};
pub use param_value::{ParamType, ParamValue};
use prepared::worth_preparing;
pub use prepared::{HitMaterial, PATH_METHODS, PreparedHit, WHITTED_METHODS};
pub use shader::{Instance, ParamInfo, Shader};
pub use surface::{Surface, SurfaceRecord};
pub use surface_batch::{ColorBatch, DeltaLobesBatch, EvalPdfBatch, SampleBatch, SurfaceBatch};
pub use surfaces::{HitCalls, MaterialSource, SurfaceOptions};
pub use typed::{TslParams, TslType, TypedFunction};

/// Builds a [`Program`] from TSL source.
#[derive(Debug, Clone, Default)]
pub struct Compiler {
    source: Option<(String, String)>,
    file: Option<PathBuf>,
    /// The color model too (`options.color_model`): checking describes the
    /// scene in it.
    options: LoadOptions,
    keep_clif: bool,
    optimize_large: bool,
    eager: bool,
    eager_prelude: bool,
}

impl Compiler {
    pub fn new() -> Self {
        Self::default()
    }

    /// RGB (3 floats) or spectral (N samples over 380–780 nm).
    pub fn color_model(mut self, model: ColorModel) -> Self {
        self.options.color_model = model;
        self
    }

    /// The root source text; `name` appears in diagnostics and anchors imports.
    pub fn source(mut self, name: &str, text: &str) -> Self {
        self.source = Some((name.to_string(), text.to_string()));
        self
    }

    /// The root source file.
    pub fn file(mut self, path: impl Into<PathBuf>) -> Self {
        self.file = Some(path.into());
        self
    }

    /// Adds a directory to search for imports.
    pub fn import_path(mut self, dir: impl Into<PathBuf>) -> Self {
        self.options.import_paths.push(dir.into());
        self
    }

    /// Loads images through `manager` instead of the process-wide
    /// [`TextureManager::global`](crate::texture::TextureManager::global).
    /// Programs compiled with one manager share each image.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use tsl::{Compiler, texture::TextureManager};
    /// let textures = Arc::new(TextureManager::new());
    /// let program = Compiler::new().texture_manager(textures.clone()).source("m.tsl", "material m = lambert;").compile()?;
    /// assert_eq!(textures.loaded(), 0); // no texture() calls, no images
    /// # let _ = program;
    /// # Ok::<(), tsl::Error>(())
    /// ```
    pub fn texture_manager(mut self, manager: Arc<crate::texture::TextureManager>) -> Self {
        self.options.textures = manager;
        self
    }

    /// Compiles the program's own materials and generators up front, so
    /// that [`Compiler::compile`] reports every lowering error and
    /// [`Program::functions`] lists them all. By default each name is
    /// lowered and compiled on first use ([`Program::material`],
    /// [`Program::function`], a scene object's material), so a file of
    /// 10,000 materials whose scene uses one compiles one.
    ///
    /// ```
    /// let src = "material a = lambert; material b = mirror;";
    /// let lazy = tsl::Compiler::new().source("m.tsl", src).compile()?;
    /// assert!(lazy.functions().is_empty());
    /// let eager = tsl::Compiler::new().eager(true).source("m.tsl", src).compile()?;
    /// assert_eq!(eager.functions().len(), 2 * tsl::check::INTERFACE.len());
    /// # Ok::<(), tsl::Error>(())
    /// ```
    pub fn eager(mut self, eager: bool) -> Self {
        self.eager = eager;
        self
    }

    /// Compiles every prelude material and generator up front as well (see
    /// [`Compiler::eager`]; by default they too are compiled on first use).
    pub fn eager_prelude(mut self, eager: bool) -> Self {
        self.eager_prelude = eager;
        self
    }

    /// Keeps the Cranelift IR text of each function (see [`Program::clif`]).
    pub fn keep_clif(mut self, keep: bool) -> Self {
        self.keep_clif = keep;
        self
    }

    /// Compiles large functions (deep texture trees) with Cranelift's
    /// optimiser and best register allocator as well, as small ones always
    /// are: about twice the compile time for about 1.3x faster code, for
    /// hosts whose shaders run long. The results are the same bits.
    /// (`tslc render` chooses this by the image's sample count.)
    ///
    /// ```
    /// let program = tsl::Compiler::new()
    ///     .source("m.tsl", "material m = mix(fbm(P), lambert(), phong());")
    ///     .optimize_large(true)
    ///     .compile()?;
    /// assert!(program.material("m").is_ok());
    /// # Ok::<(), tsl::Error>(())
    /// ```
    pub fn optimize_large(mut self, optimize: bool) -> Self {
        self.optimize_large = optimize;
        self
    }

    /// For a one-shot render of one frame: the syntax, types and name
    /// resolutions of the scene's objects are dropped once the scene is
    /// described, except what materials compile from (a generated scene of
    /// a million spheres then renders in half the memory).
    /// [`Program::scene_at`] can then describe no other frame.
    pub fn lean(mut self, lean: bool) -> Self {
        self.options.lean = lean;
        self
    }

    /// Parses, checks, lowers and JIT-compiles the program.
    pub fn compile(self) -> Result<Program, Error> {
        let checked = match (&self.file, &self.source) {
            (Some(path), _) => crate::check_file(path, &self.options),
            (None, Some((name, text))) => crate::check_source(name, text, &self.options),
            (None, None) => return Err(Error::plain("no source given to the compiler".into())),
        };
        self.compile_checked(checked)
    }

    /// Lowers and JIT-compiles a program checked already (by
    /// [`check_file`](crate::check_file) with the same load options), so a
    /// tool that shows the checker's warnings as well checks once. The
    /// compiler's source and file are not used.
    ///
    /// ```
    /// let checked = tsl::check_source("m.tsl", "material m = lambert;", &tsl::LoadOptions::default());
    /// assert!(checked.diagnostics.is_empty());
    /// let program = tsl::Compiler::new().compile_checked(checked)?;
    /// assert!(program.material("m").is_ok());
    /// # Ok::<(), tsl::Error>(())
    /// ```
    pub fn compile_checked(self, checked: crate::Checked) -> Result<Program, Error> {
        if !checked.is_ok() {
            return Err(Error { diagnostics: checked.diagnostics, sources: checked.program.loaded.sources });
        }
        let model = self.options.color_model;
        // A scene checked in another model evaluates its colors again (the
        // files it read are reused); the first description goes at once.
        let mut scene = match checked.scene {
            Some(scene) if scene.model == crate::scene::description_model(model) => Some(scene),
            previous => {
                let (scene, diags) = crate::scene::describe(&checked.program, model, previous.as_ref());
                if diags.iter().any(Diagnostic::is_error) {
                    return Err(Error { diagnostics: diags, sources: checked.program.loaded.sources });
                }
                scene
            }
        };
        let mut program = checked.program;
        let lean =
            self.options.lean && scene.as_mut().is_some_and(|d| crate::scene::drop_object_syntax(&mut program, d));
        let jit_options = JitOptions { keep_clif: self.keep_clif, optimize_large: self.optimize_large };
        let mut parts = Vec::new();
        if self.eager || self.eager_prelude {
            let (own, prelude) = (self.eager, self.eager_prelude);
            let first = compile_part(&program, model, &jit_options, |_, sym| {
                if program.loaded.modules[sym.module].is_prelude { prelude } else { own }
            })?;
            parts.push(Arc::new(first));
        }
        // Names compiled up front are never compiled again on first use.
        let compiled = program
            .symbols
            .iter()
            .filter(
                |(_, sym)| if program.loaded.modules[sym.module].is_prelude { self.eager_prelude } else { self.eager },
            )
            .map(|(name, _)| (name.clone(), None))
            .collect();
        Ok(Program {
            inner: Arc::new(Inner {
                model,
                program,
                scene,
                lean,
                jit_options,
                compiled_functions: AtomicUsize::new(parts.iter().map(|p| p.ir.functions.len()).sum()),
                instance_code: Mutex::default(),
                parts: RwLock::new(parts),
                compiled: Mutex::new(compiled),
            }),
        })
    }
}

/// Lowers and JIT-compiles the entry points of the names `keep` accepts.
fn compile_part(
    program: &check::Program,
    model: ColorModel,
    options: &JitOptions,
    keep: impl Fn(&str, &check::Symbol) -> bool,
) -> Result<Part, Error> {
    let (ir, entries, diags) = lower_entries(program, model, keep);
    if !diags.is_empty() {
        return Err(Error { diagnostics: diags, sources: program.loaded.sources.clone() });
    }
    let jit = crate::jit::compile(&ir, options).map_err(Error::plain)?;
    Ok(Part::new(ir, entries, jit))
}

/// Entry points compiled together into one JIT module.
struct Part {
    ir: IrModule,
    entries: Vec<Entry>,
    jit: Jit,
    /// By function: its batch entry, compiled when first asked for.
    batches: Box<[std::sync::OnceLock<Result<crate::jit::BatchCode, String>>]>,
}

impl Part {
    fn new(ir: IrModule, entries: Vec<Entry>, jit: Jit) -> Part {
        let batches = ir.functions.iter().map(|_| std::sync::OnceLock::new()).collect();
        Part { ir, entries, jit, batches }
    }
}

/// The compiled interface methods `ENTRY.method` of `part`, by [`check::Method`]:
/// what a material compiled from one expression is made of.
fn interface_functions(part: &Arc<Part>, entry: &str) -> Result<Vec<Function>, Error> {
    check::Method::ALL
        .iter()
        .map(|method| {
            let fname = format!("{entry}.{}", method.name());
            let index = part.ir.functions.iter().position(|f| f.name == fname);
            match (index, part.jit.function(&fname)) {
                (Some(index), Some(native)) => Ok(Function::new(part.clone(), index, native)),
                _ => Err(Error::plain(format!("internal error: `{fname}` was not compiled"))),
            }
        })
        .collect()
}

struct Inner {
    model: ColorModel,
    /// The checked program, kept to compile prelude entries on first use.
    program: check::Program,
    /// The program's scene, described in the program's color model.
    scene: Option<SceneDesc>,
    /// The scene's object syntax was dropped ([`Compiler::lean`]).
    lean: bool,
    jit_options: JitOptions,
    /// The parts compiled so far: up front, then as names are first used.
    parts: RwLock<Vec<Arc<Part>>>,
    /// Names already compiled (or found to have no entries), with the
    /// error lowering them gave, if any.
    compiled: Mutex<HashMap<String, Option<Error>>>,
    /// Functions JIT-compiled so far ([`Program::compiled_functions`]).
    compiled_functions: AtomicUsize,
    /// Run-time-bound instance code, by shader and code-changing values
    /// (see `bound`).
    instance_code: Mutex<HashMap<String, Arc<bound::InstanceCode>>>,
}

/// A compiled program: cheap to clone, `Send + Sync`, callable from many
/// threads at once.
#[derive(Clone)]
pub struct Program {
    inner: Arc<Inner>,
}

impl fmt::Debug for Program {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Program").field("model", &self.inner.model).field("entries", &self.entries().len()).finish()
    }
}

/// What one argument or result word of [`Function::call_words`] holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum WordType {
    /// An `f32`, as its bits (`f32::to_bits`).
    F32,
    /// An `i32`, as its two's-complement bits.
    I32,
    /// A bool: 0 or 1.
    Bool,
}

impl WordType {
    /// The word type of an IR scalar (the IR is not public API, so this is
    /// no `From` impl).
    pub(crate) fn of(s: crate::ir::Scalar) -> WordType {
        match s {
            crate::ir::Scalar::F32 => WordType::F32,
            crate::ir::Scalar::I32 => WordType::I32,
            crate::ir::Scalar::Bool => WordType::Bool,
        }
    }
}

/// Which back end runs a function: the JIT, or the reference interpreter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Backend {
    Jit,
    Interpreter,
}

impl Program {
    pub fn color_model(&self) -> ColorModel {
        self.inner.model
    }

    fn parts(&self) -> Vec<Arc<Part>> {
        self.inner.parts.read().map(|p| p.clone()).unwrap_or_default()
    }

    /// The entry points compiled so far: all of the program's own with
    /// [`Compiler::eager`], otherwise those of the names already used.
    pub(crate) fn entries(&self) -> Vec<Entry> {
        self.parts().iter().flat_map(|p| p.entries.iter().cloned()).collect()
    }

    /// The functions compiled so far, in the order they were compiled: all
    /// of the program's own with [`Compiler::eager`], otherwise those of
    /// the names already used (a material's interface methods, as
    /// `name.method`). A count of them tells a host whether an operation
    /// compiled anything.
    ///
    /// ```
    /// let p = tsl::Compiler::new().source("t.tsl", "float half(float x) { return x / 2; }").compile()?;
    /// assert!(p.functions().is_empty());
    /// p.function("half").expect("compiled on first use");
    /// let names: Vec<String> = p.functions().iter().map(|f| f.name().to_string()).collect();
    /// assert_eq!(names, ["half"]);
    /// # Ok::<(), tsl::Error>(())
    /// ```
    pub fn functions(&self) -> Vec<Function> {
        let mut out = Vec::new();
        for part in self.parts() {
            for (index, f) in part.ir.functions.iter().enumerate() {
                if let Some(native) = part.jit.function(&f.name) {
                    out.push(Function::new(part.clone(), index, native));
                }
            }
        }
        out
    }

    /// Cranelift IR text per function, when compiled with `keep_clif`.
    pub fn clif(&self) -> Vec<(String, String)> {
        self.parts().iter().flat_map(|p| p.jit.clif.iter().cloned()).collect()
    }

    /// A color from RGB in this program's color model.
    pub fn rgb(&self, r: f32, g: f32, b: f32) -> Color {
        Color::from_lanes(self.inner.model, &color::rgb_to_lanes(self.inner.model, [r, g, b]))
    }

    /// The checked program: its syntax trees, symbols and expression types.
    pub fn checked(&self) -> &check::Program {
        &self.inner.program
    }

    /// An error pointing into this program's sources.
    pub(crate) fn error(&self, diagnostic: Diagnostic) -> Error {
        Error { diagnostics: vec![diagnostic], sources: self.inner.program.loaded.sources.clone() }
    }

    /// What lowering reported, as an error into this program's sources.
    fn lowering_errors(&self, diags: Vec<Diagnostic>) -> Result<(), Error> {
        if diags.is_empty() {
            return Ok(());
        }
        Err(Error { diagnostics: diags, sources: self.inner.program.loaded.sources.clone() })
    }

    /// Lowered entries compiled into one JIT module.
    /// How many functions (entry points) the program has JIT-compiled so
    /// far, up front and on first use: a host can check that binding an
    /// instance or changing its values compiled nothing.
    ///
    /// ```
    /// let program = tsl::Compiler::new().source("m.tsl", "material m = lambert;").compile()?;
    /// let before = program.compiled_functions();
    /// let _ = program.material("m")?;
    /// assert!(program.compiled_functions() > before);
    /// # Ok::<(), tsl::Error>(())
    /// ```
    pub fn compiled_functions(&self) -> usize {
        self.inner.compiled_functions.load(Ordering::Relaxed)
    }

    fn jit_part(&self, ir: IrModule, entries: Vec<Entry>) -> Result<Arc<Part>, Error> {
        self.jit_part_with(ir, entries, &self.inner.jit_options)
    }

    /// [`Program::jit_part`] with other code generation options.
    fn jit_part_with(&self, ir: IrModule, entries: Vec<Entry>, options: &JitOptions) -> Result<Arc<Part>, Error> {
        let jit = crate::jit::compile(&ir, options).map_err(Error::plain)?;
        self.inner.compiled_functions.fetch_add(ir.functions.len(), Ordering::Relaxed);
        Ok(Arc::new(Part::new(ir, entries, jit)))
    }

    /// The program's `scene { }` block as checked plain data, its colors in
    /// the program's color model; `None` without a scene.
    pub fn scene(&self) -> Option<&SceneDesc> {
        self.inner.scene.as_ref()
    }

    /// Takes the described scene out of the program, for a caller that
    /// builds it once and wants its memory back as soon as it is placed
    /// ([`Scene::build_owned`](crate::render::Scene::build_owned)); `None`
    /// without a scene or when the program is shared (cloned).
    /// [`Program::scene`] is `None` afterwards.
    pub fn take_scene(&mut self) -> Option<SceneDesc> {
        Arc::get_mut(&mut self.inner)?.scene.take()
    }

    /// The program's scene described at one frame of an animation: values
    /// that read `frame` or `time` take that frame's values, and the
    /// files it names are not read again. `Ok(None)` without a scene; an
    /// error where a value is invalid at that frame (a camera that looks
    /// at its own position at frame 12), at the property.
    ///
    /// ```
    /// use tsl::scene::FrameRequest;
    /// let src = "scene { camera { from (0, 1, -4 + time); to (0, 1, 0); } render { fps 4; } }";
    /// let program = tsl::Compiler::new().source("anim.tsl", src).compile()?;
    /// let desc = program.scene_at(&FrameRequest { frame: 2, fps: None })?.unwrap();
    /// assert_eq!((desc.frame.number, desc.frame.time), (2, 0.5));
    /// assert_eq!(desc.camera.from.value.z, -3.5);
    /// # Ok::<(), tsl::Error>(())
    /// ```
    pub fn scene_at(&self, request: &crate::scene::FrameRequest) -> Result<Option<SceneDesc>, Error> {
        let reuse = self.inner.scene.as_ref();
        if reuse.is_some_and(|d| d.frame.number == request.frame) && request.fps.is_none() {
            return Ok(reuse.cloned());
        }
        if self.inner.lean {
            let message =
                "internal error: a lean program (`Compiler::lean`) describes its scene at its first frame only";
            return Err(Error::plain(message.into()));
        }
        let (desc, diags) = crate::scene::describe_frame(&self.inner.program, self.inner.model, reuse, request);
        if diags.iter().any(Diagnostic::is_error) {
            let at = format!("at frame {}", request.frame);
            let diagnostics = diags.into_iter().map(|d| d.with_note(at.clone())).collect();
            return Err(Error { diagnostics, sources: self.inner.program.loaded.sources.clone() });
        }
        Ok(desc)
    }

    /// The expressions `materials` name, with their entry names.
    fn material_exprs<'p>(&'p self, materials: &[(String, MaterialRef)]) -> Result<Vec<(String, &'p Expr)>, Error> {
        materials
            .iter()
            .map(|(name, r)| match self.inner.program.material_expr(*r) {
                Some(e) => Ok((name.clone(), e)),
                None => Err(Error::plain(format!("internal error: `{name}` names no material of the program"))),
            })
            .collect()
    }

    /// Compiles, for each material expression of the root program, the
    /// entry `NAME.reflection_sum{lights}`: the sum of `reflection` over
    /// `lights` lights in one call, with the texture evaluated once
    /// (parameters `wi_1, light_1, ..., wi_K, light_K, wo`).
    fn compile_reflection_sums(
        &self,
        materials: &[(String, MaterialRef)],
        lights: usize,
    ) -> Result<Vec<Function>, Error> {
        let exprs = self.material_exprs(materials)?;
        self.compile_lowered(crate::ir::lower::lower_reflection_sums(
            &self.inner.program,
            self.inner.model,
            &exprs,
            lights,
        ))
    }

    /// Compiles, for each material expression of the root program, the
    /// entry `NAME.delta_lobes`: both perfect directions and their weights
    /// in one call (see `ir::lower::lower_delta_lobes`).
    fn compile_delta_lobes(&self, materials: &[(String, MaterialRef)]) -> Result<Vec<Function>, Error> {
        let exprs = self.material_exprs(materials)?;
        self.compile_lowered(crate::ir::lower::lower_delta_lobes(&self.inner.program, self.inner.model, &exprs))
    }

    /// Compiles lowered entries into a part of the program, one
    /// [`Function`] per IR function.
    fn compile_lowered(
        &self,
        (ir, entries, diags): (IrModule, Vec<Entry>, Vec<Diagnostic>),
    ) -> Result<Vec<Function>, Error> {
        self.lowering_errors(diags)?;
        let part = self.jit_part(ir, entries)?;
        let mut out = Vec::with_capacity(part.ir.functions.len());
        for (index, f) in part.ir.functions.iter().enumerate() {
            let native = part
                .jit
                .function(&f.name)
                .ok_or_else(|| Error::plain(format!("internal error: `{}` was not compiled", f.name)))?;
            out.push(Function::new(part.clone(), index, native));
        }
        if let Ok(mut parts) = self.inner.parts.write() {
            parts.push(part);
        }
        Ok(out)
    }

    /// For each named material of the program (as [`Program::material`]
    /// accepts), the entry `NAME.reflection_sum{lights}`: `reflection`
    /// summed over `lights` light directions in one call, for hosts and tests.
    pub fn reflection_sums(&self, names: &[&str], lights: usize) -> Result<Vec<Function>, Error> {
        self.compile_reflection_sums(&self.material_tree_bodies(names)?, lights)
    }

    /// Compiles, for each material expression of the root program, the
    /// entry `NAME.eval_pdf`: `f · cos` and `pdf` of a light direction in
    /// one call (see `ir::lower::lower_eval_pdf`).
    fn compile_eval_pdf(&self, materials: &[(String, MaterialRef)]) -> Result<Vec<Function>, Error> {
        let exprs = self.material_exprs(materials)?;
        self.compile_lowered(crate::ir::lower::lower_eval_pdf(&self.inner.program, self.inner.model, &exprs))
    }

    /// For each named material of the program, the entry `NAME.eval_pdf`:
    /// `f · cos` and `pdf` of a light direction in one call, for hosts and
    /// tests.
    pub fn eval_pdf(&self, names: &[&str]) -> Result<Vec<Function>, Error> {
        self.compile_eval_pdf(&self.material_tree_bodies(names)?)
    }

    /// For each named material of the program, the entry
    /// `NAME.delta_lobes`: both perfect directions and their weights, for
    /// hosts and tests.
    pub fn delta_lobes(&self, names: &[&str]) -> Result<Vec<Function>, Error> {
        self.compile_delta_lobes(&self.material_tree_bodies(names)?)
    }

    /// The bodies of material trees without parameters, by name.
    fn material_tree_bodies(&self, names: &[&str]) -> Result<Vec<(String, MaterialRef)>, Error> {
        let mut refs = Vec::new();
        for name in names {
            let sym = self
                .inner
                .program
                .symbols
                .get(*name)
                .ok_or_else(|| Error::plain(format!("no material named `{name}`")))?;
            let item = &self.inner.program.loaded.modules[sym.module].ast.items[sym.item];
            match item {
                Item::MaterialTree(t) if t.params.is_none() => refs.push((
                    name.to_string(),
                    MaterialRef::TreeBody { module: sym.module as u32, item: sym.item as u32 },
                )),
                _ => return Err(Error::plain(format!("`{name}` is not a material tree without parameters"))),
            }
        }
        Ok(refs)
    }

    /// A material defined in the program (a material tree, or a material
    /// model whose parameters all have defaults), compiled on first use.
    pub fn material(&self, name: &str) -> Result<Material, Error> {
        let is_material = self
            .inner
            .program
            .symbols
            .get(name)
            .is_some_and(|s| matches!(s.kind, SymbolKind::Material | SymbolKind::MaterialTree));
        if is_material {
            self.compile_name(name)?;
        }
        let methods = crate::check::Method::ALL.map(|m| self.find(&format!("{name}.{}", m.name())));
        if methods.iter().all(Option::is_some) {
            return Ok(Material::new(self.clone(), material::Code::methods_only(name.to_string(), methods)));
        }
        let known: Vec<&str> = self
            .inner
            .program
            .symbols
            .iter()
            .filter(|(_, s)| matches!(s.kind, SymbolKind::Material | SymbolKind::MaterialTree))
            .map(|(n, _)| n.as_str())
            .collect();
        let hint = crate::diag::did_you_mean(name, known.iter().copied())
            .map(|s| format!(" (did you mean `{s}`?)"))
            .unwrap_or_default();
        Err(Error::plain(format!("no material named `{name}`{hint}")))
    }

    /// A compiled function by its entry name (`rings` or `wood.reflection`),
    /// compiled on first use; `None` when the program has no such entry or
    /// lowering it failed (see [`Program::try_function`]).
    pub fn function(&self, name: &str) -> Option<Function> {
        self.try_function(name).ok().flatten()
    }

    /// [`Program::function`], with the error of lowering the name it
    /// belongs to (the part before the first `.`).
    pub fn try_function(&self, name: &str) -> Result<Option<Function>, Error> {
        if let Some(f) = self.find(name) {
            return Ok(Some(f));
        }
        let base = name.split('.').next().unwrap_or(name);
        if self.inner.program.symbols.contains_key(base) {
            self.compile_name(base)?;
        }
        Ok(self.find(name))
    }

    /// Lowers and compiles every entry of the program's name `base` (all
    /// methods of a material, or a generator), once: later calls return
    /// what the first gave, whether or not `base` had entries (a constant
    /// has none).
    fn compile_name(&self, base: &str) -> Result<(), Error> {
        let mut compiled = self.inner.compiled.lock().map_err(|_| Error::plain("a compile panicked".into()))?;
        if let Some(outcome) = compiled.get(base) {
            return outcome.clone().map_or(Ok(()), Err);
        }
        let part = compile_part(&self.inner.program, self.inner.model, &self.inner.jit_options, |n, _| n == base);
        let outcome = match part {
            Ok(part) => {
                self.inner.compiled_functions.fetch_add(part.ir.functions.len(), Ordering::Relaxed);
                if !part.entries.is_empty()
                    && let Ok(mut parts) = self.inner.parts.write()
                {
                    parts.push(Arc::new(part));
                }
                None
            }
            Err(e) => Some(e),
        };
        compiled.insert(base.to_string(), outcome.clone());
        outcome.map_or(Ok(()), Err)
    }

    fn find(&self, name: &str) -> Option<Function> {
        self.parts().into_iter().find_map(|part| {
            let index = part.ir.functions.iter().position(|f| f.name == name)?;
            let native = part.jit.function(name)?;
            Some(Function::new(part, index, native))
        })
    }
}

/// One compiled entry point, callable through either back end. It keeps
/// its code alive.
#[derive(Clone)]
pub struct Function {
    part: Arc<Part>,
    index: usize,
    native: EntryFn,
    /// Argument, result and instance block words, kept here so that a
    /// call checks its slices without reaching into the part's IR.
    words: (usize, usize, usize),
    /// The instance parameter block the code reads (`Op::InstanceWord`):
    /// a run-time-bound instance's values, at least as many words as the
    /// IR function's `instance_words` (checked in [`Function::with_instance`]).
    instance: Option<Arc<[u32]>>,
}

impl Function {
    fn new(part: Arc<Part>, index: usize, native: EntryFn) -> Function {
        let f = &part.ir.functions[index];
        let words = (f.params.len(), f.results.len(), f.instance_words.len());
        Function { part, index, native, words, instance: None }
    }

    /// The function reading `block` as its instance parameter block: the
    /// same compiled code, no compilation. An error when the block is
    /// shorter than the words the code reads.
    pub(crate) fn with_instance(&self, block: Arc<[u32]>) -> Result<Function, String> {
        let needed = self.words.2;
        if block.len() < needed {
            return Err(format!(
                "`{}` reads {needed} instance words, but the block has {}",
                self.ir().name,
                block.len()
            ));
        }
        Ok(Function { instance: Some(block), ..self.clone() })
    }

    pub(crate) fn ir(&self) -> &IrFunction {
        &self.part.ir.functions[self.index]
    }

    /// The entry point's name: `rings`, or `wood.reflection`.
    pub fn name(&self) -> &str {
        &self.entry().name
    }

    /// The source-level parameters, by name and checked type, in order;
    /// [`Function::call_words`] takes their words in this order (a float
    /// or int one word, a vector three, a color one per lane of the
    /// program's color model).
    pub fn params(&self) -> &[(String, check::Ty)] {
        &self.entry().params
    }

    /// The source-level result type (`float`, `color`, a tuple, ...):
    /// how [`Function::result_types`]' words group into values.
    ///
    /// ```
    /// let p = tsl::Compiler::new().source("t.tsl", "color tint(float h) { return rgb(h, 0, 0); }").compile()?;
    /// assert_eq!(p.function("tint").expect("defined").result_type(), &tsl::check::Ty::Color);
    /// # Ok::<(), tsl::Error>(())
    /// ```
    pub fn result_type(&self) -> &check::Ty {
        &self.entry().ret
    }

    /// The function's IR as text (what `tslc emit ir` prints): for reading
    /// what the compiler made of a shader, not a stable format.
    ///
    /// ```
    /// let p = tsl::Compiler::new().source("t.tsl", "float twice(float x) { return x * 2; }").compile()?;
    /// let text = p.function("twice").expect("defined").ir_text();
    /// assert!(text.contains("twice"), "{text}");
    /// # Ok::<(), tsl::Error>(())
    /// ```
    pub fn ir_text(&self) -> String {
        self.ir().to_string()
    }

    /// How many argument words [`Function::call_words`] reads.
    pub fn arg_words(&self) -> usize {
        self.words.0
    }

    /// How many words of an instance parameter block the code reads: 0
    /// for a function with its values folded in (a specialised instance,
    /// a generator), more for a run-time-bound instance's methods, which
    /// read their values from the block ([`Instance::bind`]).
    ///
    /// ```
    /// let p = tsl::Compiler::new().source("t.tsl", "material m = lambert;").compile()?;
    /// let method = |m: &tsl::Material| m.method(tsl::check::Method::Reflection).expect("a method").instance_words();
    /// let rough = p.shader("rough_conductor")?;
    /// assert_eq!(method(&rough.instance().set("alpha", 0.3)?.specialise()?), 0);
    /// assert!(method(&rough.instance().set("alpha", 0.3)?.bind()?) > 0);
    /// # Ok::<(), tsl::Error>(())
    /// ```
    pub fn instance_words(&self) -> usize {
        self.words.2
    }

    /// What each result word [`Function::call_words`] writes holds, in
    /// order (its length is the number of result words).
    ///
    /// ```
    /// let p = tsl::Compiler::new().source("t.tsl", "vector up(float h) { return vector(0, h, 0); }").compile()?;
    /// let f = p.function("up").expect("defined");
    /// assert_eq!((f.name(), f.arg_words()), ("up", 1));
    /// assert_eq!(f.result_types(), [tsl::WordType::F32; 3]);
    /// # Ok::<(), tsl::Error>(())
    /// ```
    pub fn result_types(&self) -> Vec<WordType> {
        self.ir().results.iter().map(|&s| WordType::of(s)).collect()
    }

    #[cold]
    fn words_error(&self) -> String {
        let (params, results, _) = self.words;
        format!("`{}` takes {params} argument words and gives {results} result words", self.ir().name)
    }

    /// The instance parameter block the code reads. Code without instance
    /// words never reads it; code with them was given one long enough
    /// (`with_instance`), or has none: an error.
    #[inline]
    fn instance_block(&self) -> Result<&[u32], String> {
        let instance: &[u32] = self.instance.as_deref().unwrap_or(&[]);
        if instance.len() < self.words.2 {
            return Err(format!("`{}` reads an instance parameter block and was given none", self.ir().name));
        }
        Ok(instance)
    }

    pub(crate) fn entry(&self) -> &Entry {
        &self.part.entries[self.index]
    }

    /// Calls with raw argument and result words (f32 bits, i32, bool as 0/1).
    /// `args` and `out` must hold at least as many words as the function's
    /// parameters and results; shorter slices are an error, not a crash.
    // Inline: renderers call it per hit and light sample, and its own
    // prologue was half the cost of a short call.
    #[inline]
    pub fn call_words(
        &self,
        backend: Backend,
        g: &ShadingGlobals,
        args: &[u32],
        out: &mut [u32],
    ) -> Result<(), String> {
        let (params, results, _) = self.words;
        if args.len() < params || out.len() < results {
            return Err(self.words_error());
        }
        let instance = self.instance_block()?;
        match backend {
            Backend::Interpreter => crate::interp::run_instance(self.ir(), &g.words(), args, instance, out),
            Backend::Jit => {
                // SAFETY: the function was compiled from this IR function,
                // which reads at most `params.len()` argument words, the
                // 48-word globals record and `instance_words.len()` block
                // words, and writes `results.len()` words; the lengths were
                // checked above, and the code is alive as long as
                // `self.part` is.
                unsafe {
                    (self.native)(
                        (g as *const ShadingGlobals).cast(),
                        args.as_ptr(),
                        out.as_mut_ptr(),
                        instance.as_ptr(),
                    )
                }
            }
        }
        Ok(())
    }
}

/// A color in a program's color model: RGB or spectral samples.
#[derive(Clone, Copy, PartialEq)]
pub struct Color {
    model: ColorModel,
    lanes: [f32; MAX_SAMPLES],
}

impl fmt::Debug for Color {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Color({:?})", self.lanes())
    }
}

impl Color {
    /// The color of `model` whose lanes are `lanes` (RGB, or spectral
    /// samples at [`ColorModel::wavelengths`]): missing lanes are 0, extra
    /// ones are dropped, and a model of more than [`MAX_SAMPLES`] lanes
    /// (not [`ColorModel::is_valid`]) keeps its first `MAX_SAMPLES`.
    pub fn from_lanes(model: ColorModel, lanes: &[f32]) -> Color {
        let mut c = Color { model, lanes: [0.0; MAX_SAMPLES] };
        let n = model.lanes().min(lanes.len()).min(MAX_SAMPLES);
        c.lanes[..n].copy_from_slice(&lanes[..n]);
        c
    }

    /// All lanes 0.
    pub fn black(model: ColorModel) -> Color {
        Color { model, lanes: [0.0; MAX_SAMPLES] }
    }

    /// The model the lanes are in.
    pub fn model(&self) -> ColorModel {
        self.model
    }

    /// The color times `s`.
    pub fn scaled(&self, s: f32) -> Color {
        let mut c = *self;
        c.lanes.iter_mut().for_each(|x| *x *= s);
        c
    }

    /// RGB values, or spectral samples at the model's wavelengths.
    pub fn lanes(&self) -> &[f32] {
        &self.lanes[..self.model.lanes().min(MAX_SAMPLES)]
    }

    /// Linear sRGB, with the model's weights computed once per process
    /// ([`color::reduction_weights`]): tens of nanoseconds.
    ///
    /// ```
    /// use tsl::{Color, ColorModel};
    /// let grey = Color::from_lanes(ColorModel::Spectral { samples: 64 }, &[0.5; 64]);
    /// assert!(grey.to_rgb().iter().all(|c| (c - 0.5).abs() < 1e-5));
    /// ```
    pub fn to_rgb(&self) -> [f32; 3] {
        color::reduction_weights(self.model).rgb(self.lanes())
    }

    /// CIE Y (D65-relative, 1 for white), with the model's weights
    /// computed once per process, as [`Color::to_rgb`].
    pub fn brightness(&self) -> f32 {
        color::reduction_weights(self.model).brightness(self.lanes())
    }
}
