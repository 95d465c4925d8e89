//! The lowerer's own state and the entry points it builds: the program's
//! items and their symbols, the lanes of each type, parameters read from
//! argument words and results written back, one function per generator and
//! one per interface method of each material.

use super::*;

impl<'p> Lowerer<'p> {
    pub(super) fn new(program: &'p Program, model: ColorModel) -> Lowerer<'p> {
        Lowerer {
            program,
            model,
            lanes: model.lanes(),
            diags: Vec::new(),
            next_id: 0,
            samplers: HashMap::default(),
            direction_only: false,
            absolute_spectra: false,
            types: Default::default(),
            constant_types: None,
            evaluate_constants: false,
            folded_consts: HashMap::default(),
            default_methods: Default::default(),
            gave_up: false,
            instance_block: None,
        }
    }

    pub(super) fn item(&self, sym: Symbol) -> &'p Item {
        &self.program.loaded.modules[sym.module].ast.items[sym.item]
    }

    pub(super) fn is_prelude(&self, sym: Symbol) -> bool {
        self.program.loaded.modules[sym.module].is_prelude
    }

    pub(super) fn id(&mut self) -> u32 {
        self.next_id += 1;
        self.next_id
    }

    /// Types that scalarize: everything but arrays, strings, materials, void.
    pub(super) fn is_plain(&self, t: &Ty) -> bool {
        !matches!(t, Ty::Array(..) | Ty::String | Ty::Material | Ty::Void | Ty::Error)
    }

    pub(super) fn lanes_of(&self, t: &Ty) -> usize {
        match t {
            Ty::Float | Ty::Int | Ty::Bool => 1,
            Ty::Vec2 => 2,
            Ty::Vector | Ty::Point | Ty::Normal => 3,
            Ty::Color => self.lanes,
            Ty::Matrix => 12,
            Ty::BsdfSample => SampleLayout { lanes: self.lanes }.words(),
            _ => 0,
        }
    }

    /// Which lanes of a value of type `ty` member `field` is.
    pub(super) fn field_lanes(&self, ty: &Ty, field: &str) -> std::ops::Range<usize> {
        if *ty == Ty::BsdfSample
            && let Some(range) = (SampleLayout { lanes: self.lanes }).field(field)
        {
            return range;
        }
        let k = match field {
            "x" => 0,
            "y" => 1,
            _ => 2,
        };
        k..k + 1
    }

    /// `s.delta` is stored as a float lane, 1 for true.
    pub(super) fn is_flag_field(ty: &Ty, field: &str) -> bool {
        *ty == Ty::BsdfSample && field == "delta"
    }

    pub(super) fn scalar_of(t: &Ty) -> Scalar {
        match t {
            Ty::Int => Scalar::I32,
            Ty::Bool => Scalar::Bool,
            _ => Scalar::F32,
        }
    }

    pub(super) fn words(&self, t: &Ty) -> Vec<Scalar> {
        vec![Self::scalar_of(t); self.lanes_of(t)]
    }

    pub(super) fn root_ctx(&mut self) -> Ctx {
        let id = self.id();
        Ctx { id, overrides: Rc::new(HashMap::default()) }
    }

    /// Reads parameters from the argument words, as lanes: each parameter
    /// takes the next `lanes_of` words.
    pub(super) fn method_args(&self, b: &mut Builder, params: &[(String, Ty)]) -> Vec<Vec<Value>> {
        // After the words already read: a hit group reads several lists.
        let mut word = b.func.params.len() as u32;
        let mut out = Vec::new();
        for (_, ty) in params {
            let scalar = Self::scalar_of(ty);
            let lanes: Vec<Value> = (0..self.lanes_of(ty))
                .map(|_| {
                    b.func.params.push(scalar);
                    word += 1;
                    b.def(scalar, Op::Param(word - 1))
                })
                .collect();
            out.push(lanes);
        }
        out
    }

    /// [`Self::method_args`] as values.
    pub(super) fn params_from_args(&self, b: &mut Builder, params: &[(String, Ty)]) -> Vec<Val<'p>> {
        self.method_args(b, params).into_iter().map(Val::Lanes).collect()
    }

    pub(super) fn write_results(&self, b: &mut Builder, ret: &Ty, v: &[Value]) {
        b.func.results = self.words(ret);
        for (k, x) in v.iter().enumerate() {
            b.push(Inst::Output(k as u32, *x));
        }
    }

    /// Finishes the function of an entry point. One that grew past
    /// [`MAX_FUNCTION_VALUES`](crate::ir::MAX_FUNCTION_VALUES) while it was
    /// lowered (lowering then stopped inlining) is an error at `at`, the
    /// material or function the entry is for; the entries after it are not
    /// inlined either ([`Self::stopped`]), since the lowering has failed.
    pub(super) fn finish_entry(&mut self, b: Builder, at: Span, what: &str) -> Function {
        self.gave_up |= b.too_large;
        if b.too_large && !self.diags.iter().any(|d| d.span == at && d.message.ends_with(TOO_LARGE)) {
            let max = crate::ir::MAX_FUNCTION_VALUES;
            self.diags.push(
                Diagnostic::error(at, format!("{what} {TOO_LARGE}"))
                    .with_primary(format!("inlined, `{}` would define more than {max} IR values", b.func.name))
                    .with_note(
                        "every call of a function and every use of a material is inlined; a use that cannot share \
                         an earlier copy's code (other arguments, another `transform` or `bump`, another child to \
                         sample) is compiled again, so code that uses the level below twice that way doubles at \
                         every level",
                    )
                    .with_help(format!(
                        "compute what the uses share once and pass it on, or use fewer levels; the bound is {max} \
                         values per compiled function"
                    )),
            );
        }
        b.finish()
    }

    /// Whether lowering has stopped inlining: this function grew past the
    /// bound, or an earlier one did.
    pub(super) fn stopped(&self, b: &Builder) -> bool {
        b.too_large || self.gave_up
    }

    pub(super) fn lower_function_entry(
        &mut self,
        name: &str,
        sym: Symbol,
        f: &'p ast::Function,
        params: &[(String, Ty)],
        ret: &Ty,
    ) -> Function {
        let mut b = Builder::new(name);
        let args = self.params_from_args(&mut b, params);
        let ctx = self.root_ctx();
        let result = self.inline_function(&mut b, sym, f, args, &ctx);
        let lanes = self.lanes(&mut b, result, ret);
        self.write_results(&mut b, ret, &lanes);
        self.finish_entry(b, sym.span, &format!("function `{name}`"))
    }

    pub(super) fn material_entries(&mut self, name: &str, sym: Symbol, module: &mut Module, entries: &mut Vec<Entry>) {
        let expr = self.material_name_expr(sym);
        for im in INTERFACE {
            let fname = format!("{name}.{}", im.name);
            let mut b = Builder::new(&fname);
            let params: Vec<(String, Ty)> = im.params.iter().map(|(n, t)| (n.to_string(), t.clone())).collect();
            let args = self.method_args(&mut b, &params);
            let ctx = self.root_ctx();
            let mat = match expr {
                MatSource::Tree(e) => {
                    Mat { expr: e, env: Rc::new(HashMap::default()), in_prelude: self.is_prelude(sym) }
                }
                MatSource::Def => {
                    let inst = self.instance_from_def(&mut b, sym, &[], &ctx, &Rc::new(HashMap::default()), false);
                    let result = self.instance_method(&mut b, &inst, im, &args, &ctx);
                    self.write_results(&mut b, &im.ret, &result);
                    module.functions.push(self.finish_entry(b, sym.span, &format!("material `{name}`")));
                    entries.push(Entry { name: fname, kind: EntryKind::Method(im.name), params, ret: im.ret.clone() });
                    continue;
                }
            };
            let result = self.mat_method(&mut b, &mat, im, &args, &ctx);
            self.write_results(&mut b, &im.ret, &result);
            module.functions.push(self.finish_entry(b, sym.span, &format!("material `{name}`")));
            entries.push(Entry { name: fname, kind: EntryKind::Method(im.name), params, ret: im.ret.clone() });
        }
    }

    pub(super) fn material_name_expr(&self, sym: Symbol) -> MatSource<'p> {
        match self.item(sym) {
            Item::MaterialTree(t) => MatSource::Tree(&t.body),
            _ => MatSource::Def,
        }
    }
}

/// The end of the message for an entry point past the bound.
const TOO_LARGE: &str = "is too large to compile";

pub(super) enum MatSource<'p> {
    Tree(&'p Expr),
    Def,
}
