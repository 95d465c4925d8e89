//! Generators as typed functions (wasmi's `TypedFunc`): a host names the
//! Rust types of a generator's parameters and result once, the signature
//! is checked then ([`Program::typed_function`]), and every call after
//! takes and returns Rust values, with no words to pack.

use super::batch::{Column, Layout, ShadingBatch};
use super::{Backend, Color, Error, Function, Program};
use crate::check::Ty;
use crate::color::{ColorModel, MAX_SAMPLES};
use crate::globals::ShadingGlobals;
use std::marker::PhantomData;

/// A Rust type that carries one TSL value: `f32` (float), `i32` (int),
/// `bool`, `[f32; 2]` (vec2), `[f32; 3]` (vector, point, normal) and
/// [`Color`] (color, in the program's model).
pub trait TslType: Copy + private::Sealed {
    /// Whether a TSL value of type `ty` is this type.
    fn accepts(ty: &Ty) -> bool;
    /// The TSL type's name, for messages.
    fn tsl_name() -> &'static str;
    /// The words this value takes in `model`.
    fn words(model: ColorModel) -> usize;
    /// Writes the value's words (exactly [`TslType::words`]).
    fn write(&self, model: ColorModel, out: &mut [u32]);
    fn read(model: ColorModel, words: &[u32]) -> Self;
}

mod private {
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for i32 {}
    impl Sealed for bool {}
    impl Sealed for [f32; 2] {}
    impl Sealed for [f32; 3] {}
    impl Sealed for super::Color {}
}

impl TslType for f32 {
    fn accepts(ty: &Ty) -> bool {
        *ty == Ty::Float
    }
    fn tsl_name() -> &'static str {
        "float"
    }
    fn words(_: ColorModel) -> usize {
        1
    }
    fn write(&self, _: ColorModel, out: &mut [u32]) {
        out[0] = self.to_bits();
    }
    fn read(_: ColorModel, words: &[u32]) -> Self {
        f32::from_bits(words[0])
    }
}

impl TslType for i32 {
    fn accepts(ty: &Ty) -> bool {
        *ty == Ty::Int
    }
    fn tsl_name() -> &'static str {
        "int"
    }
    fn words(_: ColorModel) -> usize {
        1
    }
    fn write(&self, _: ColorModel, out: &mut [u32]) {
        out[0] = *self as u32;
    }
    fn read(_: ColorModel, words: &[u32]) -> Self {
        words[0] as i32
    }
}

impl TslType for bool {
    fn accepts(ty: &Ty) -> bool {
        *ty == Ty::Bool
    }
    fn tsl_name() -> &'static str {
        "bool"
    }
    fn words(_: ColorModel) -> usize {
        1
    }
    fn write(&self, _: ColorModel, out: &mut [u32]) {
        out[0] = u32::from(*self);
    }
    fn read(_: ColorModel, words: &[u32]) -> Self {
        words[0] != 0
    }
}

impl TslType for [f32; 2] {
    fn accepts(ty: &Ty) -> bool {
        *ty == Ty::Vec2
    }
    fn tsl_name() -> &'static str {
        "vec2"
    }
    fn words(_: ColorModel) -> usize {
        2
    }
    fn write(&self, _: ColorModel, out: &mut [u32]) {
        out[0] = self[0].to_bits();
        out[1] = self[1].to_bits();
    }
    fn read(_: ColorModel, words: &[u32]) -> Self {
        [f32::from_bits(words[0]), f32::from_bits(words[1])]
    }
}

impl TslType for [f32; 3] {
    fn accepts(ty: &Ty) -> bool {
        matches!(ty, Ty::Vector | Ty::Point | Ty::Normal)
    }
    fn tsl_name() -> &'static str {
        "vector"
    }
    fn words(_: ColorModel) -> usize {
        3
    }
    fn write(&self, _: ColorModel, out: &mut [u32]) {
        for (w, x) in out.iter_mut().zip(self) {
            *w = x.to_bits();
        }
    }
    fn read(_: ColorModel, words: &[u32]) -> Self {
        [0, 1, 2].map(|k| f32::from_bits(words[k]))
    }
}

impl TslType for Color {
    fn accepts(ty: &Ty) -> bool {
        *ty == Ty::Color
    }
    fn tsl_name() -> &'static str {
        "color"
    }
    fn words(model: ColorModel) -> usize {
        model.lanes()
    }
    /// The program's lanes of the color (a color of another model gives
    /// its own lanes, zeros past them: make colors with [`Program::rgb`]).
    fn write(&self, model: ColorModel, out: &mut [u32]) {
        for (k, w) in out[..model.lanes()].iter_mut().enumerate() {
            *w = self.lanes.get(k).copied().unwrap_or(0.0).to_bits();
        }
    }
    fn read(model: ColorModel, words: &[u32]) -> Self {
        let lanes: Vec<f32> = words[..model.lanes()].iter().map(|w| f32::from_bits(*w)).collect();
        Color::from_lanes(model, &lanes)
    }
}

/// A generator's parameters as a tuple of [`TslType`]s: `()`, `(f32,)`,
/// `(f32, [f32; 3])`, ... (up to six).
pub trait TslParams: Copy + private_params::Sealed {
    /// Whether the parameter types are these, in order.
    fn accepts(tys: &[Ty]) -> bool;
    fn tsl_names() -> Vec<&'static str>;
    fn words(model: ColorModel) -> usize;
    fn write(&self, model: ColorModel, out: &mut [u32]);
}

mod private_params {
    pub trait Sealed {}
}

macro_rules! params {
    ($($t:ident $i:tt),*) => {
        impl<$($t: TslType),*> private_params::Sealed for ($($t,)*) {}
        impl<$($t: TslType),*> TslParams for ($($t,)*) {
            #[allow(unused_variables, unused_mut)]
            fn accepts(tys: &[Ty]) -> bool {
                let mut k = 0;
                $( if tys.get(k).is_none_or(|ty| !$t::accepts(ty)) { return false; } k += 1; )*
                k == tys.len()
            }
            fn tsl_names() -> Vec<&'static str> {
                vec![$($t::tsl_name()),*]
            }
            #[allow(unused_variables)]
            fn words(model: ColorModel) -> usize {
                0 $(+ $t::words(model))*
            }
            #[allow(unused_variables, unused_mut, unused_assignments)]
            fn write(&self, model: ColorModel, out: &mut [u32]) {
                let mut at = 0;
                $(
                    let n = $t::words(model);
                    self.$i.write(model, &mut out[at..at + n]);
                    at += n;
                )*
            }
        }
    };
}

params!();
params!(A 0);
params!(A 0, B 1);
params!(A 0, B 1, C 2);
params!(A 0, B 1, C 2, D 3);
params!(A 0, B 1, C 2, D 3, E 4);
params!(A 0, B 1, C 2, D 3, E 4, F 5);

/// The most argument words a typed call packs: six colors of the widest
/// model.
const MAX_TYPED_ARG_WORDS: usize = 6 * MAX_SAMPLES;

/// A generator whose signature was checked once ([`Program::typed_function`]):
/// calls take `P` and return `R`. Cheap to clone, `Send + Sync`.
pub struct TypedFunction<P, R> {
    function: Function,
    model: ColorModel,
    // `fn(P) -> R`: the handle owns no `P` or `R`, and is Send and Sync.
    types: PhantomData<fn(P) -> R>,
}

impl<P, R> std::fmt::Debug for TypedFunction<P, R> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TypedFunction").field("name", &self.function.ir().name).finish()
    }
}

impl<P, R> Clone for TypedFunction<P, R> {
    fn clone(&self) -> Self {
        TypedFunction { function: self.function.clone(), model: self.model, types: PhantomData }
    }
}

impl<P: TslParams, R: TslType> TypedFunction<P, R> {
    /// Calls the compiled code at the shading point `g`.
    #[inline]
    pub fn call(&self, g: &ShadingGlobals, args: P) -> R {
        self.call_on(Backend::Jit, g, args)
    }

    /// [`TypedFunction::call`] through either back end (the interpreter is
    /// the JIT's reference).
    pub fn call_on(&self, backend: Backend, g: &ShadingGlobals, args: P) -> R {
        let mut words = [0u32; MAX_TYPED_ARG_WORDS];
        let n = P::words(self.model);
        args.write(self.model, &mut words[..n]);
        let mut out = [0u32; MAX_SAMPLES];
        // The signature was checked when the handle was made: the lengths
        // are the function's own, so the call cannot fail.
        let _ = self.function.call_words(backend, g, &words[..n], &mut out);
        R::read(self.model, &out)
    }

    /// [`TypedFunction::call`] at every point of `points`, with one
    /// argument tuple per point, in one native call (see
    /// [`Function::call_batch`]): the same values as calls point by point.
    ///
    /// ```
    /// use tsl::{Compiler, ShadingBatch};
    /// let program = Compiler::new().source("t.tsl", "float ramp(float k) { return u * k; }").compile()?;
    /// let ramp = program.typed_function::<(f32,), f32>("ramp")?;
    /// let mut points = ShadingBatch::new(3);
    /// points.set_floats("u", &[0.0, 0.5, 1.0])?;
    /// assert_eq!(ramp.call_batch(&points, &[(2.0,), (2.0,), (4.0,)])?, [0.0, 1.0, 4.0]);
    /// assert_eq!(ramp.call_batch_uniform(&points, (2.0,))?, [0.0, 1.0, 2.0]);
    /// # Ok::<(), tsl::Error>(())
    /// ```
    ///
    /// An `args` of another length than the batch is an error.
    pub fn call_batch(&self, points: &ShadingBatch, args: &[P]) -> Result<Vec<R>, Error> {
        if args.len() != points.len() {
            return Err(Error::plain(format!(
                "`{}` was given {} argument tuples for a batch of {} points",
                self.function.name(),
                args.len(),
                points.len()
            )));
        }
        let width = P::words(self.model);
        let mut words = vec![0u32; args.len() * width];
        for (a, w) in args.iter().zip(words.chunks_exact_mut(width.max(1))) {
            a.write(self.model, w);
        }
        let columns: Vec<Column> = (0..width).map(|k| Column::words_strided(&words, k, width)).collect();
        self.run_batch(points, &columns)
    }

    /// [`TypedFunction::call_batch`] with the same arguments at every point.
    pub fn call_batch_uniform(&self, points: &ShadingBatch, args: P) -> Result<Vec<R>, Error> {
        let mut words = [0u32; MAX_TYPED_ARG_WORDS];
        let n = P::words(self.model);
        args.write(self.model, &mut words[..n]);
        let columns: Vec<Column> = words[..n].iter().map(|&w| Column::uniform_word(w)).collect();
        self.run_batch(points, &columns)
    }

    fn run_batch(&self, points: &ShadingBatch, columns: &[Column]) -> Result<Vec<R>, Error> {
        let width = R::words(self.model);
        let mut out = vec![0u32; points.len() * width];
        self.function.call_batch(Backend::Jit, points, columns, &mut out, Layout::PointMajor)?;
        Ok(out.chunks_exact(width.max(1)).take(points.len()).map(|w| R::read(self.model, w)).collect())
    }

    /// The untyped function.
    pub fn function(&self) -> &Function {
        &self.function
    }
}

impl Program {
    /// The generator `name` as a typed function, its signature checked
    /// here: a wrong parameter or result type, or a name that is no
    /// generator, is an error now rather than a wrong value later.
    ///
    /// ```
    /// use tsl::{Compiler, ShadingGlobals};
    /// let src = "float rings(float scale) { return fract(length(vec2(Pl.x, Pl.z)) * scale); }";
    /// let program = Compiler::new().source("wood.tsl", src).compile()?;
    /// let rings = program.typed_function::<(f32,), f32>("rings")?;
    /// let g = ShadingGlobals { pl: [0.1, 0.0, 0.0], ..Default::default() };
    /// assert!((rings.call(&g, (8.0,)) - 0.8).abs() < 1e-6);
    /// let wrong = program.typed_function::<([f32; 3],), f32>("rings").unwrap_err();
    /// assert!(wrong.to_string().contains("`rings` takes (float)"), "{wrong}");
    /// # Ok::<(), tsl::Error>(())
    /// ```
    pub fn typed_function<P: TslParams, R: TslType>(&self, name: &str) -> Result<TypedFunction<P, R>, Error> {
        let function = self.try_function(name)?.ok_or_else(|| Error::plain(format!("no generator named `{name}`")))?;
        let entry = function.entry();
        let tys: Vec<Ty> = entry.params.iter().map(|(_, t)| t.clone()).collect();
        let is_generator = entry.kind == crate::ir::lower::EntryKind::Function;
        if !is_generator || !P::accepts(&tys) || !R::accepts(&entry.ret) {
            let declared: Vec<String> = tys.iter().map(ToString::to_string).collect();
            let asked = P::tsl_names().join(", ");
            return Err(Error::plain(format!(
                "`{name}` takes ({}) and returns {}, not ({asked}) -> {}",
                declared.join(", "),
                entry.ret,
                R::tsl_name()
            )));
        }
        Ok(TypedFunction { function, model: self.color_model(), types: PhantomData })
    }
}
