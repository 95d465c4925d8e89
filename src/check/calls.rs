//! Checking calls: binding arguments to parameters, user functions and
//! materials, builtins, and the string options and literals some take.

use super::*;
use crate::texture::is_udim_pattern;

impl<'a> Checker<'a> {
    /// Matches call arguments to parameters. Returns, per parameter, the
    /// argument bound to it, or `None` when the call is malformed.
    pub(super) fn bind_args<'e>(
        &mut self,
        callee: &str,
        params: &[ParamInfo<'_>],
        args: &'e [Arg],
        span: Span,
    ) -> Option<Vec<Option<&'e Expr>>> {
        let mut bound: Vec<Option<&Expr>> = vec![None; params.len()];
        let mut ok = true;
        let mut seen_named = false;
        for (i, arg) in args.iter().enumerate() {
            match &arg.name {
                None => {
                    if seen_named {
                        self.error(
                            Diagnostic::error(arg.value.span, "positional argument after a named one")
                                .with_help("put positional arguments first"),
                        );
                        ok = false;
                    } else if i >= params.len() {
                        let n = params.len();
                        self.error(
                            Diagnostic::error(
                                arg.value.span,
                                format!("`{callee}` takes {n} argument{}, but {} were given", plural(n), args.len()),
                            )
                            .with_label(span, "in this call"),
                        );
                        return None;
                    } else {
                        bound[i] = Some(&arg.value);
                    }
                }
                Some(name) => {
                    seen_named = true;
                    match params.iter().position(|p| p.name == name.name) {
                        Some(p) if bound[p].is_some() => {
                            let mut d =
                                Diagnostic::error(name.span, format!("argument `{}` is given twice", name.name));
                            if let Some(first) = bound[p] {
                                d = d.with_label(first.span, "first given here");
                            }
                            self.error(d);
                            ok = false;
                        }
                        Some(p) => bound[p] = Some(&arg.value),
                        None => {
                            let mut d = Diagnostic::error(
                                name.span,
                                format!("`{callee}` has no parameter named `{}`", name.name),
                            );
                            d = match did_you_mean(&name.name, params.iter().map(|p| p.name)) {
                                Some(s) => d.with_help(format!("did you mean `{s}`?")),
                                None => d.with_help(format!(
                                    "its parameters are: {}",
                                    params.iter().map(|p| p.name).collect::<Vec<_>>().join(", ")
                                )),
                            };
                            self.error(d);
                            ok = false;
                        }
                    }
                }
            }
        }
        if !ok {
            return None;
        }
        let missing: Vec<&str> =
            params.iter().zip(&bound).filter(|(p, b)| p.required && b.is_none()).map(|(p, _)| p.name).collect();
        if !missing.is_empty() {
            self.error(
                Diagnostic::error(
                    span,
                    format!("missing argument{} to `{callee}`: {}", plural(missing.len()), missing.join(", ")),
                )
                .with_help(format!(
                    "`{callee}` takes {} argument{}",
                    params.len(),
                    plural(params.len())
                )),
            );
            ok = false;
        }
        ok.then_some(bound)
    }

    pub(super) fn call(&mut self, callee: &Ident, args: &[Arg], span: Span) -> Ty {
        let name = callee.name.as_str();
        // 1. A sibling method inside a material.
        if self.body.material.is_some()
            && let Some(im) = interface_method(name)
        {
            let params: Vec<ParamInfo> =
                im.params.iter().map(|(n, t)| ParamInfo { name: n, ty: Some(t.clone()), required: true }).collect();
            if let Some(from) = self.body.node {
                self.edge(from, Node::Method(self.current, im.name), callee.span);
            }
            self.typed_args(name, &params, args, span);
            return im.ret.clone();
        }
        // 2. A local of that name.
        if self.lookup_local(name).is_some() {
            self.error(Diagnostic::error(callee.span, format!("`{name}` is a variable, not a function")));
            self.untyped_args(args);
            return Ty::Error;
        }
        // 3. A user or prelude item.
        if let Some(sym) = self.symbol(name) {
            self.use_item(sym, callee.span);
            let item = self.item(sym);
            let (params, ret): (&[Param], Ty) = match item {
                Item::Function(f) => (&f.params, Ty::from_ast(&f.ret)),
                Item::Material(d) => (&d.params, Ty::Material),
                Item::MaterialTree(t) => match &t.params {
                    Some(ps) => (ps, Ty::Material),
                    None => {
                        self.error(
                            Diagnostic::error(span, format!("`{name}` is a material tree without parameters"))
                                .with_help(format!("use it without parentheses: `{name}`")),
                        );
                        self.untyped_args(args);
                        return Ty::Error;
                    }
                },
                _ => {
                    self.error(Diagnostic::error(callee.span, format!("`{name}` is a constant, not a function")));
                    self.untyped_args(args);
                    return Ty::Error;
                }
            };
            let infos: Vec<ParamInfo> = params
                .iter()
                .map(|p| ParamInfo { name: &p.name.name, ty: Some(Ty::from_ast(&p.ty)), required: p.default.is_none() })
                .collect();
            self.typed_args(name, &infos, args, span);
            self.note_string_args(sym, name, params, args);
            return if ret == Ty::Material { self.material_value(span) } else { ret };
        }
        // 4. A builtin.
        if let Some(b) = builtin(name) {
            self.builtin_calls.insert(callee.span, b.func);
            return self.builtin_call(b, args, span);
        }
        self.unknown(name, callee.span, "function");
        self.untyped_args(args);
        Ty::Error
    }

    /// The options declared for a parameter (`in ("a", "b")`): on a
    /// `string` parameter only, at least one, each once, its default among
    /// them.
    pub(super) fn check_declared_options(&mut self, p: &Param, ty: &Ty, options: &ParamOptions) {
        if *ty != Ty::String {
            if !ty.is_error() {
                self.error(
                    Diagnostic::error(
                        options.span,
                        format!("only `string` parameters have options; `{}` is a `{ty}`", p.name.name),
                    )
                    .with_help("remove the options, or make the parameter a `string`"),
                );
            }
            return;
        }
        if options.values.is_empty() {
            self.error(
                Diagnostic::error(options.span, format!("`{}` has no options", p.name.name))
                    .with_help("list the values the parameter accepts: `in (\"a\", \"b\")`, or remove `in ()`"),
            );
            return;
        }
        for (k, (value, span)) in options.values.iter().enumerate() {
            if let Some((_, first)) = options.values[..k].iter().find(|(v, _)| v == value) {
                self.error(
                    Diagnostic::error(*span, format!("the option \"{value}\" is listed twice"))
                        .with_label(*first, "first listed here"),
                );
            }
        }
        if let Some(Expr { kind: ExprKind::Str(value), span, .. }) = &p.default {
            self.check_option(value, *span, &p.name.name, None, options);
        }
    }

    /// Reports `value` (a literal at `span`) when it is not one of the
    /// `options` declared for parameter `param` (of `callee`, in a call).
    pub(super) fn check_option(
        &mut self,
        value: &str,
        span: Span,
        param: &str,
        callee: Option<&str>,
        options: &ParamOptions,
    ) {
        if options.contains(value) {
            return;
        }
        let whose = callee.map(|c| format!(" of `{c}`")).unwrap_or_default();
        let mut d = Diagnostic::error(span, format!("`{param}`{whose} has no option \"{value}\""))
            .with_note(format!("the options are {}", options.listed()));
        if let Some(s) = did_you_mean(value, options.values.iter().map(|(v, _)| v.as_str())) {
            d = d.with_help(format!("did you mean \"{s}\"?"));
        }
        if callee.is_some() {
            d = d.with_label(options.span, "declared here");
        }
        self.error(d);
    }

    /// The options declared for parameter `name` of the item being checked.
    fn own_declared_options(&self, name: &str) -> Option<&'a ParamOptions> {
        let (m, i) = self.current;
        let params = match self.loaded.modules.get(m)?.ast.items.get(i)? {
            Item::Function(f) => &f.params[..],
            Item::Material(d) => &d.params[..],
            Item::MaterialTree(t) => t.params.as_deref()?,
            Item::Const(_) | Item::Import { .. } | Item::Scene(_) => return None,
        };
        params.iter().find(|p| p.name.name == name)?.options.as_ref()
    }

    /// `p == "literal"` (either way round) where `p` is a `string`
    /// parameter of the item being checked: "literal" is one of p's options
    /// (and must be one of those it declares, if it declares them: a
    /// comparison with another would always be false).
    pub(super) fn record_string_option(&mut self, lhs: &Expr, rhs: &Expr) {
        let (name, literal, span) = match (&lhs.kind, &rhs.kind) {
            (ExprKind::Name(n), ExprKind::Str(s)) => (n, s, rhs.span),
            (ExprKind::Str(s), ExprKind::Name(n)) => (n, s, lhs.span),
            _ => return,
        };
        if self.lookup_local(name).is_some_and(|l| l.kind == LocalKind::Param) {
            if let Some(options) = self.own_declared_options(name) {
                self.check_option(literal, span, name, None, options);
                return;
            }
            let options = self.string_options.entry((self.current, name.to_string())).or_default();
            if !options.contains(literal) {
                options.push(literal.clone());
            }
        }
    }

    /// Remembers the string literals of a call for [`Self::report_string_options`].
    pub(super) fn note_string_args(&mut self, sym: Symbol, callee: &str, params: &[Param], args: &[Arg]) {
        let infos: Vec<(&str, Ty)> = params.iter().map(|p| (p.name.name.as_str(), Ty::from_ast(&p.ty))).collect();
        for (k, a) in args.iter().enumerate() {
            let slot = match &a.name {
                Some(n) => infos.iter().position(|(p, _)| *p == n.name),
                None => Some(k),
            };
            let (Some(slot), ExprKind::Str(literal)) = (slot, &a.value.kind) else { continue };
            let Some(p) = params.get(slot).filter(|p| Ty::from_ast(&p.ty) == Ty::String) else { continue };
            if let Some(options) = &p.options {
                // Declared: checked now, against the declaration alone.
                self.check_option(literal, a.value.span, &p.name.name, Some(callee), options);
                continue;
            }
            let default = match p.default.as_ref().map(|d| &d.kind) {
                Some(ExprKind::Str(d)) => Some(d.clone()),
                _ => None,
            };
            self.string_args.push(StringArg {
                callee: (sym.module, sym.item),
                callee_name: callee.to_string(),
                param: p.name.name.to_string(),
                literal: literal.clone(),
                default,
                span: a.value.span,
            });
        }
    }

    /// A `string` option must be one its item tells apart: a literal its
    /// body compares the parameter with, or its default.
    pub(super) fn report_string_options(&mut self) {
        for arg in std::mem::take(&mut self.string_args) {
            let Some(options) = self.string_options.get(&(arg.callee, arg.param.clone())) else { continue };
            let mut known: Vec<&str> = arg.default.iter().map(String::as_str).collect();
            known.extend(options.iter().map(String::as_str).filter(|o| Some(*o) != arg.default.as_deref()));
            if known.contains(&arg.literal.as_str()) {
                continue;
            }
            let list: Vec<String> = known.iter().map(|o| format!("\"{o}\"")).collect();
            let mut d = Diagnostic::error(
                arg.span,
                format!("`{}` of `{}` has no option \"{}\"", arg.param, arg.callee_name, arg.literal),
            )
            .with_note(format!("the options are {}", list.join(", ")));
            if let Some(s) = did_you_mean(&arg.literal, known.iter().copied()) {
                d = d.with_help(format!("did you mean \"{s}\"?"));
            }
            self.error(d);
        }
    }

    pub(super) fn untyped_args(&mut self, args: &[Arg]) {
        for a in args {
            self.expr(&a.value, None);
        }
    }

    pub(super) fn typed_args(&mut self, callee: &str, params: &[ParamInfo], args: &[Arg], span: Span) {
        let Some(bound) = self.bind_args(callee, params, args, span) else {
            self.untyped_args(args);
            return;
        };
        for (p, arg) in params.iter().zip(bound) {
            if let (Some(arg), Some(want)) = (arg, &p.ty) {
                let found = self.expr(arg, Some(want));
                self.expect_ty(arg, &found, want, &format!("argument `{}`", p.name));
            }
        }
    }

    pub(super) fn builtin_call(&mut self, b: &Builtin, args: &[Arg], span: Span) -> Ty {
        let params: Vec<ParamInfo> =
            b.params.iter().map(|p| ParamInfo { name: p.name, ty: None, required: !p.optional() }).collect();
        let Some(bound) = self.bind_args(b.name, &params, args, span) else {
            self.untyped_args(args);
            return Ty::Error;
        };
        let mut tys: Vec<Option<Ty>> = Vec::with_capacity(bound.len());
        for arg in &bound {
            tys.push(arg.map(|a| self.expr(a, None)));
        }
        if b.func.tree_node().is_some_and(|n| n != TreeNode::Scale)
            || (b.func == BuiltinFn::Scale && bound[1].is_some())
        {
            // Texture-tree nodes over materials are material values.
            if tys.iter().flatten().any(|t| *t == Ty::Material || matches!(t, Ty::Array(e, _) if **e == Ty::Material))
                && !self.body.materials_allowed
            {
                return self.material_value(span);
            }
        }
        let result = match type_builtin(b.func, &tys) {
            Ok(t) => t,
            Err(ArgError { arg, message, help }) => {
                let at = arg.and_then(|i| bound.get(i).copied().flatten()).map_or(span, |e| e.span);
                let mut d = Diagnostic::error(at, message).with_note(format!("expected {}", b.synopsis));
                if at != span {
                    d = d.with_label(span, format!("in this call to `{}`", b.name));
                }
                if let Some(h) = help {
                    d = d.with_help(h);
                }
                self.error(d);
                return Ty::Error;
            }
        };
        match b.func {
            BuiltinFn::Mix => {
                if let Some(only) = b.arg(&bound, "only") {
                    self.check_only(only);
                }
            }
            BuiltinFn::Spectrum => {
                if let Some(samples) = b.arg(&bound, "samples") {
                    self.check_spectrum(samples);
                }
            }
            BuiltinFn::Texture | BuiltinFn::TextureFloat | BuiltinFn::TextureVector => {
                self.check_texture(b, &bound, span)
            }
            BuiltinFn::Triplanar => {
                self.check_point_reader(b.name, span, "it projects along the shading point's position and normal");
            }
            BuiltinFn::NormalMap => {
                let names = NormalMapConvention::NAMES;
                self.option_literal(b.arg(&bound, "convention"), "convention", names, NormalMapConvention::from_name);
            }
            _ => {}
        }
        result
    }

    /// A `texture` call: the file and the options are string literals
    /// naming things that exist; the call is recorded for loading and
    /// lowering. It depends on the shading point (its footprint).
    pub(super) fn check_texture(&mut self, b: &Builtin, bound: &[Option<&Expr>], span: Span) {
        let (name, color) = (b.name, b.func == BuiltinFn::Texture);
        let arg = |param: &str| b.arg(bound, param);
        if !self.check_point_reader(name, span, "a texture lookup depends on the shading point and its pixel footprint")
        {
            return;
        }
        let filter = self.option_literal(arg("filter"), "filter", Filter::NAMES, Filter::from_name);
        let wrap = self.option_literal(arg("wrap"), "wrap", Wrap::NAMES, Wrap::from_name);
        let swrap = self.option_literal(arg("swrap"), "swrap", Wrap::NAMES, Wrap::from_name);
        let twrap = self.option_literal(arg("twrap"), "twrap", Wrap::NAMES, Wrap::from_name);
        // texture_float and texture_vector have no colorspace parameter:
        // they read stored values.
        let encoding = self.option_literal(arg("colorspace"), "colorspace", &["srgb", "linear"], |n| match n {
            "srgb" => Some(Encoding::Srgb),
            "linear" => Some(Encoding::Raw),
            _ => None,
        });
        // A constant channel out of 0..=3 would read a clamped neighbour.
        if let Some(c) = arg("channel")
            && let Some(k) = const_int(c)
            && !(0..=3).contains(&k)
        {
            self.error(
                Diagnostic::error(c.span, format!("there is no channel {k}"))
                    .with_help("channels are 0, 1, 2 (red, green, blue) and 3 (alpha)"),
            );
        }
        let Some(file) = arg("file") else { return };
        let ExprKind::Str(path) = &file.kind else {
            self.error(
                Diagnostic::error(file.span, "the image must be a string literal naming a file")
                    .with_help(format!("for example `{name}(\"wood.png\", (u, v))`")),
            );
            return;
        };
        let (Some(filter), Some(wrap), Some(swrap), Some(twrap), Some(encoding)) =
            (filter, wrap, swrap, twrap, encoding)
        else {
            return;
        };
        let encoding = encoding.unwrap_or(if color { Encoding::Srgb } else { Encoding::Raw });
        // A tile set's tiles meet edge to edge, so by default a tile's
        // filter reads its own edge texels there, not the opposite edge.
        let wrap = wrap.unwrap_or(if is_udim_pattern(path) { Wrap::Clamp } else { Wrap::Repeat });
        let image = match self
            .images
            .iter()
            .position(|i| i.path == *path && i.encoding == encoding && i.span.file == file.span.file)
        {
            Some(k) => k,
            None => {
                self.images.push(ImageUse { span: file.span, path: path.clone(), encoding, image: None });
                self.images.len() - 1
            }
        };
        let call = TextureCall {
            image,
            filter: filter.unwrap_or(Filter::Trilinear),
            wrap: [swrap.unwrap_or(wrap), twrap.unwrap_or(wrap)],
        };
        self.texture_calls.insert(span, call);
    }

    /// A builtin that reads the shading point itself (a texture lookup,
    /// `triplanar`): allowed where the globals are, and recorded as reading
    /// them; else an error with `help`, and false.
    fn check_point_reader(&mut self, name: &str, span: Span, help: &str) -> bool {
        if !self.body.globals_allowed {
            self.error(
                Diagnostic::error(span, format!("`{name}` cannot be used in {}", self.body.context)).with_help(help),
            );
            return false;
        }
        if let Some(node) = &self.body.node {
            self.reads_globals.entry(*node).or_insert(span);
        }
        true
    }

    /// An optional string-literal option: `Some(None)` when absent,
    /// `Some(Some(x))` when it names a known choice, `None` after an error.
    pub(super) fn option_literal<T>(
        &mut self,
        arg: Option<&Expr>,
        option: &str,
        names: &[&str],
        parse: impl Fn(&str) -> Option<T>,
    ) -> Option<Option<T>> {
        let Some(arg) = arg else { return Some(None) };
        let list = names.iter().map(|n| format!("\"{n}\"")).collect::<Vec<_>>().join(", ");
        match &arg.kind {
            ExprKind::Str(s) => match parse(s) {
                Some(x) => Some(Some(x)),
                None => {
                    let mut d = Diagnostic::error(arg.span, format!("unknown {option} `{s}`"));
                    d = match did_you_mean(s, names.iter().copied()) {
                        Some(m) => d.with_help(format!("did you mean `{m}`? the choices are {list}")),
                        None => d.with_help(format!("the choices are {list}")),
                    };
                    self.error(d);
                    None
                }
            },
            _ => {
                self.error(
                    Diagnostic::error(arg.span, format!("`{option}:` must be a string literal"))
                        .with_help(format!("the choices are {list}")),
                );
                None
            }
        }
    }

    /// `mix(t, a, b, only: "method")` names an interface method.
    pub(super) fn check_only(&mut self, only: &Expr) {
        match &only.kind {
            ExprKind::Str(s) if interface_method(s).is_some() => {}
            ExprKind::Str(s) => {
                let mut d = Diagnostic::error(only.span, format!("`{s}` is not a method of the material interface"));
                if let Some(m) = did_you_mean(s, INTERFACE.iter().map(|m| m.name)) {
                    d = d.with_help(format!("did you mean `{m}`?"));
                }
                self.error(d);
            }
            _ => self.error(
                Diagnostic::error(only.span, "`only:` must be a string literal naming an interface method")
                    .with_help("for example `only: \"refraction_index\"`"),
            ),
        }
    }

    /// Literal spectra: wavelengths increase and lie in the visible-ish range.
    pub(super) fn check_spectrum(&mut self, samples: &Expr) {
        let ExprKind::Array(items) = &samples.kind else {
            return;
        };
        if items.len() < 2 {
            self.error(
                Diagnostic::error(samples.span, "a spectrum needs at least two samples")
                    .with_help("for a constant spectrum use gray(value)"),
            );
        }
        let mut prev: Option<f64> = None;
        for item in items {
            let ExprKind::Tuple(pair) = &item.kind else {
                continue;
            };
            let Some(nm) = pair.first().and_then(const_number) else {
                continue;
            };
            if !(300.0..=1000.0).contains(&nm) {
                self.error(
                    Diagnostic::error(pair[0].span, format!("wavelength {nm} nm is outside 300..1000 nm"))
                        .with_help("spectrum samples are (wavelength in nanometres, value)"),
                );
            }
            if let Some(p) = prev
                && nm <= p
            {
                self.error(Diagnostic::error(
                    pair[0].span,
                    format!("wavelengths must increase: {nm} nm follows {p} nm"),
                ));
            }
            prev = Some(nm);
        }
    }
}
