//! Names, types, the material interface and the generic-color rules.
//!
//! `check` takes a loaded program and returns a [`Program`] (the syntax trees
//! plus a type for every expression) and all diagnostics. It never stops at
//! the first error: an ill-typed expression gets [`Ty::Error`], which
//! converts silently to every type, so each mistake is reported once.
//!
//! Architecture invariant: checking does no I/O and knows nothing of code
//! generation. A program without error diagnostics is well typed, recursion
//! free (shade trees are DAGs) and has only bounded loops.

mod builtins;
mod interface;
mod scene;
mod ty;

pub use builtins::{BUILTINS, Builtin, BuiltinFn, BuiltinParam, TreeNode};
pub use interface::{GLOBALS, INTERFACE, InterfaceMethod, interface_method};
pub use ty::{SAMPLE_FIELDS, Ty};

use crate::diag::{Diagnostic, Span, did_you_mean};
use crate::load::Loaded;
use crate::syntax::ast::*;
use crate::texture::{Encoding, Filter, MipMap, Wrap};
use builtins::{ArgError, builtin, elementwise, type_builtin, unify};
use std::collections::HashMap;
use std::sync::Arc;

/// The most elements an array may have.
pub const MAX_ARRAY_LEN: u32 = 4096;

/// The most iterations one `for` loop runs: the IR's limit, which the
/// checker reports when constant bounds exceed it.
pub use crate::ir::MAX_LOOP_ITERATIONS;

/// A checked program: the loaded modules, the global symbols and the type of
/// every expression, keyed by its span.
#[derive(Debug, Clone, Default)]
pub struct Program {
    pub loaded: Loaded,
    pub symbols: HashMap<String, Symbol>,
    /// The prelude's own names: prelude code resolves against these, so a
    /// user definition that shadows a prelude name does not change the
    /// prelude's behaviour.
    pub prelude_symbols: HashMap<String, Symbol>,
    pub expr_types: HashMap<Span, Ty>,
    /// The global item each name or call resolved to, keyed by its span.
    pub resolutions: HashMap<Span, Symbol>,
    /// The builtin each call to one resolved to, keyed by the callee's span
    /// (a user function of the same name is an error, so names alone would
    /// do; the lowering matches on the enum instead of on strings).
    pub builtin_calls: HashMap<Span, BuiltinFn>,
    /// The images `texture` calls name, each once per file and encoding.
    pub images: Vec<ImageUse>,
    /// Every `texture` / `texture_float` call, keyed by its span.
    pub texture_calls: HashMap<Span, TextureCall>,
}

/// An image named by a `texture` call. Checking records the path as
/// written; the front end then resolves and loads it (`image`).
#[derive(Debug, Clone)]
pub struct ImageUse {
    /// The string literal naming the file.
    pub span: Span,
    pub path: String,
    pub encoding: Encoding,
    /// The loaded pyramid, once the front end has read the file.
    pub image: Option<Arc<MipMap>>,
}

/// What one `texture` call reads and how.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct TextureCall {
    /// Index into [`Program::images`].
    pub image: usize,
    pub filter: Filter,
    /// Address modes along s and t.
    pub wrap: [Wrap; 2],
}

/// A material written in the checked program, named by where it is: a
/// handle that later stages (the scene description, the embedding API)
/// pass around instead of syntax; [`Program::material_expr`] finds the
/// expression.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MaterialRef {
    /// The body of material tree `item` of `module`.
    TreeBody { module: usize, item: usize },
    /// The value of property `prop` of block `entry` of the scene that is
    /// item `item` of `module` (a scene object's `material`).
    SceneValue { module: usize, item: usize, entry: usize, prop: usize },
}

impl Program {
    /// The expression `r` names, if it names one of this program.
    pub fn material_expr(&self, r: MaterialRef) -> Option<&Expr> {
        match r {
            MaterialRef::TreeBody { module, item } => match self.loaded.modules.get(module)?.ast.items.get(item)? {
                Item::MaterialTree(t) => Some(&t.body),
                _ => None,
            },
            MaterialRef::SceneValue { module, item, entry, prop } => {
                match self.loaded.modules.get(module)?.ast.items.get(item)? {
                    Item::Scene(scene) => match scene.entries.get(entry)? {
                        SceneEntry::Block(b) => b.props.get(prop)?.value.as_ref(),
                        SceneEntry::Prop(_) => None,
                    },
                    _ => None,
                }
            }
        }
    }
}

/// A global name and the item that defines it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Symbol {
    pub kind: SymbolKind,
    pub module: usize,
    pub item: usize,
    pub span: Span,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SymbolKind {
    Function,
    Material,
    MaterialTree,
    Const,
}

impl SymbolKind {
    fn describe(self) -> &'static str {
        match self {
            SymbolKind::Function => "function",
            SymbolKind::Material => "material",
            SymbolKind::MaterialTree => "material tree",
            SymbolKind::Const => "constant",
        }
    }
}

/// Checks a loaded program.
pub fn check(loaded: Loaded) -> (Program, Vec<Diagnostic>) {
    let mut diags = Vec::new();
    let (symbols, prelude_symbols) = collect_symbols(&loaded, &mut diags);
    let mut checker = Checker {
        loaded: &loaded,
        symbols: &symbols,
        prelude_symbols: &prelude_symbols,
        in_prelude: false,
        current: (0, 0),
        resolutions: HashMap::new(),
        reads_globals: HashMap::new(),
        diags: &mut diags,
        expr_types: HashMap::new(),
        graph: HashMap::new(),
        body: Body::default(),
        images: Vec::new(),
        texture_calls: HashMap::new(),
        string_options: HashMap::new(),
        string_args: Vec::new(),
        builtin_calls: HashMap::new(),
    };
    checker.check_items();
    checker.report_string_options();
    checker.report_recursion();
    checker.report_varying_constants();
    let expr_types = std::mem::take(&mut checker.expr_types);
    let resolutions = std::mem::take(&mut checker.resolutions);
    let images = std::mem::take(&mut checker.images);
    let texture_calls = std::mem::take(&mut checker.texture_calls);
    let builtin_calls = std::mem::take(&mut checker.builtin_calls);
    (Program { loaded, symbols, prelude_symbols, expr_types, resolutions, builtin_calls, images, texture_calls }, diags)
}

type Symbols = HashMap<String, Symbol>;

/// Builds the global namespaces: the one user code sees (user items shadow
/// prelude items of the same name) and the prelude's own. Two definitions in
/// the same layer are an error.
fn collect_symbols(loaded: &Loaded, diags: &mut Vec<Diagnostic>) -> (Symbols, Symbols) {
    let mut symbols: HashMap<String, Symbol> = HashMap::new();
    let mut prelude: HashMap<String, Symbol> = HashMap::new();
    let mut from_prelude: HashMap<String, bool> = HashMap::new();
    for (m, module) in loaded.modules.iter().enumerate() {
        for (i, item) in module.ast.items.iter().enumerate() {
            let (kind, name) = match item {
                Item::Function(f) => (SymbolKind::Function, &f.name),
                Item::Material(d) => (SymbolKind::Material, &d.name),
                Item::MaterialTree(t) => (SymbolKind::MaterialTree, &t.name),
                Item::Const(c) => (SymbolKind::Const, &c.name),
                Item::Import { .. } | Item::Scene(_) => continue,
            };
            if builtin(&name.name).is_some() {
                diags.push(
                    Diagnostic::error(
                        name.span,
                        format!("`{}` is a builtin function and cannot be redefined", name.name),
                    )
                    .with_help("choose another name"),
                );
                continue;
            }
            if interface::global(&name.name).is_some() {
                diags.push(Diagnostic::error(
                    name.span,
                    format!("`{}` is a shading global and cannot be redefined", name.name),
                ));
                continue;
            }
            let symbol = Symbol { kind, module: m, item: i, span: name.span };
            match symbols.get(&name.name) {
                Some(_) if from_prelude[&name.name] && !module.is_prelude => {
                    // A user definition shadows the prelude's.
                    symbols.insert(name.name.clone(), symbol);
                    from_prelude.insert(name.name.clone(), false);
                }
                Some(prev) => {
                    diags.push(
                        Diagnostic::error(name.span, format!("`{}` is defined more than once", name.name))
                            .with_primary(format!("{} redefined here", kind.describe()))
                            .with_label(prev.span, format!("first defined here as a {}", prev.kind.describe())),
                    );
                }
                None => {
                    symbols.insert(name.name.clone(), symbol);
                    from_prelude.insert(name.name.clone(), module.is_prelude);
                }
            }
            if module.is_prelude {
                prelude.entry(name.name.clone()).or_insert(symbol);
            }
        }
    }
    (symbols, prelude)
}

/// Where an item is: (module, item index).
type ItemId = (usize, usize);

/// A node of the dependency graph: a global item, or a method of a
/// material. Nodes name items by position, since a user item and the
/// prelude item it shadows share a name.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
enum Node {
    Item(ItemId, String),
    Method(ItemId, String, &'static str),
}

impl Node {
    fn describe(&self) -> String {
        match self {
            Node::Item(_, n) => format!("`{n}`"),
            Node::Method(_, m, f) => format!("`{m}.{f}`"),
        }
    }

    fn id(&self) -> ItemId {
        match self {
            Node::Item(id, _) | Node::Method(id, _, _) => *id,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
enum LocalKind {
    Param,
    Var,
    LoopVar,
}

#[derive(Debug, Clone)]
struct Local {
    name: String,
    ty: Ty,
    span: Span,
    kind: LocalKind,
    used: bool,
}

/// What the body being checked is, which decides what it may see.
#[derive(Debug, Clone, Default)]
struct Body {
    scopes: Vec<Vec<Local>>,
    ret: Option<Ty>,
    loops: u32,
    /// Inside a material definition: its name and the methods it defines.
    material: Option<(String, Vec<&'static str>)>,
    globals_allowed: bool,
    /// Whether material values may appear (material trees only).
    materials_allowed: bool,
    /// What is being checked, for messages: "a function", "a constant", ...
    context: &'static str,
    node: Option<Node>,
}

struct Checker<'a> {
    loaded: &'a Loaded,
    symbols: &'a Symbols,
    prelude_symbols: &'a Symbols,
    /// Whether the item being checked is prelude code.
    in_prelude: bool,
    /// The item being checked.
    current: ItemId,
    resolutions: HashMap<Span, Symbol>,
    /// Items whose own code reads a shading global, with the first use.
    reads_globals: HashMap<Node, Span>,
    diags: &'a mut Vec<Diagnostic>,
    expr_types: HashMap<Span, Ty>,
    /// Dependencies between items, with the span of the first use.
    graph: HashMap<Node, Vec<(Node, Span)>>,
    body: Body,
    images: Vec<ImageUse>,
    texture_calls: HashMap<Span, TextureCall>,
    /// The literals each `string` parameter is compared with in its item's
    /// body (`distribution == "ggx"`): the options it accepts.
    string_options: HashMap<(ItemId, String), Vec<String>>,
    /// String literals passed for `string` parameters, checked against
    /// their options once every body has been seen.
    string_args: Vec<StringArg>,
    /// The builtin each call resolved to, by the callee's span.
    builtin_calls: HashMap<Span, BuiltinFn>,
}

/// A string literal given for a `string` parameter of an item.
struct StringArg {
    callee: ItemId,
    callee_name: String,
    param: String,
    literal: String,
    default: Option<String>,
    span: Span,
}

/// A callee's parameter, for binding arguments.
struct ParamInfo<'p> {
    name: &'p str,
    ty: Option<Ty>,
    required: bool,
}

impl<'a> Checker<'a> {
    fn error(&mut self, d: Diagnostic) {
        self.diags.push(d);
    }

    /// Whether item `i` of module `m` is the definition its layer sees
    /// (and not a rejected duplicate).
    fn is_active(&self, m: usize, i: usize, name: &str) -> bool {
        let table = if self.loaded.modules[m].is_prelude { self.prelude_symbols } else { self.symbols };
        table.get(name).is_some_and(|s| s.module == m && s.item == i)
    }

    /// Looks up a global name as the current item sees it.
    fn symbol(&self, name: &str) -> Option<Symbol> {
        let table = if self.in_prelude { self.prelude_symbols } else { self.symbols };
        table.get(name).copied()
    }

    fn item_node(sym: Symbol, name: &str) -> Node {
        Node::Item((sym.module, sym.item), name.to_string())
    }

    fn check_items(&mut self) {
        let loaded = self.loaded;
        let mut scenes: Vec<&Scene> = Vec::new();
        for (m, module) in loaded.modules.iter().enumerate() {
            self.in_prelude = module.is_prelude;
            for (i, item) in module.ast.items.iter().enumerate() {
                self.current = (m, i);
                match item {
                    Item::Import { .. } => {}
                    Item::Function(f) if self.is_active(m, i, &f.name.name) => self.check_function(f),
                    Item::Material(d) if self.is_active(m, i, &d.name.name) => self.check_material(d),
                    Item::MaterialTree(t) if self.is_active(m, i, &t.name.name) => self.check_tree(t),
                    Item::Const(c) if self.is_active(m, i, &c.name.name) => self.check_const(c),
                    // Rejected duplicates were reported when collecting names.
                    Item::Function(_) | Item::Material(_) | Item::MaterialTree(_) | Item::Const(_) => {}
                    Item::Scene(s) => {
                        if !module.is_prelude {
                            scenes.push(s);
                        }
                    }
                }
            }
        }
        for extra in scenes.iter().skip(1) {
            self.error(
                Diagnostic::error(Span { end: extra.span.start + 5, ..extra.span }, "a program has at most one scene")
                    .with_label(Span { end: scenes[0].span.start + 5, ..scenes[0].span }, "the first scene is here"),
            );
        }
        for s in scenes {
            self.in_prelude = false;
            self.body = Body { context: "the scene", ..Body::default() };
            scene::check_scene(self, s);
        }
    }

    // ------------------------------------------------------------ items

    fn begin(&mut self, node: Node, context: &'static str, globals_allowed: bool, materials_allowed: bool) {
        self.body = Body {
            node: Some(node),
            context,
            globals_allowed,
            materials_allowed,
            scopes: vec![Vec::new()],
            ..Body::default()
        };
    }

    /// Declares parameters in the current scope, checking their types and
    /// defaults.
    fn declare_params(&mut self, params: &[Param], what: &str) {
        let mut seen: HashMap<&str, Span> = HashMap::new();
        for p in params {
            let ty = self.resolve_type(&p.ty, what);
            if let Some(default) = &p.default {
                let found = self.expr(default, Some(&ty));
                self.expect_ty(default, &found, &ty, "the default value");
            }
            if let Some(prev) = seen.insert(&p.name.name, p.name.span) {
                self.error(
                    Diagnostic::error(p.name.span, format!("parameter `{}` is declared twice", p.name.name))
                        .with_label(prev, "first declared here"),
                );
                continue;
            }
            self.declare_param(&p.name, ty);
        }
    }

    fn check_function(&mut self, f: &Function) {
        self.begin(Node::Item(self.current, f.name.name.clone()), "a function", true, false);
        let ret = self.resolve_type(&f.ret, "a function");
        self.declare_params(&f.params, "a function");
        self.body.ret = Some(ret.clone());
        self.block_in_scope(&f.body);
        self.check_returns(f, &ret);
        self.end_scope();
    }

    fn check_returns(&mut self, f: &Function, ret: &Ty) {
        if *ret != Ty::Void && !ret.is_error() && !block_returns(&f.body) {
            let end = Span { start: f.body.span.end.saturating_sub(1), ..f.body.span };
            self.error(
                Diagnostic::error(end, format!("`{}` does not return a value on every path", f.name.name))
                    .with_primary(format!("the end of the body is reachable without a `return` of `{ret}`"))
                    .with_label(f.ret.span, "the declared return type")
                    .with_help("add a `return` at the end of the function"),
            );
        }
    }

    fn check_material(&mut self, d: &MaterialDef) {
        let name = d.name.name.clone();
        self.begin(Node::Item(self.current, name.clone()), "a material's parameters", true, false);
        self.declare_params(&d.params, "a material's parameter list");
        let params_scope = self.body.scopes.clone();

        // Which methods the material defines, for sibling calls.
        let mut defined: Vec<&'static str> = Vec::new();
        let mut seen: HashMap<&str, Span> = HashMap::new();
        for m in &d.methods {
            if let Some(prev) = seen.insert(&m.name.name, m.name.span) {
                self.error(
                    Diagnostic::error(m.name.span, format!("method `{}` is defined twice", m.name.name))
                        .with_label(prev, "first defined here"),
                );
            }
            match interface_method(&m.name.name) {
                Some(im) => defined.push(im.name),
                None => {
                    let names = INTERFACE.iter().map(|m| m.name);
                    let mut diag = Diagnostic::error(
                        m.name.span,
                        format!("`{}` is not a method of the material interface", m.name.name),
                    );
                    diag = match did_you_mean(&m.name.name, names) {
                        Some(s) => diag.with_help(format!("did you mean `{s}`?")),
                        None => diag.with_help(format!(
                            "the interface methods are: {}",
                            INTERFACE.iter().map(|m| m.name).collect::<Vec<_>>().join(", ")
                        )),
                    };
                    self.error(diag.with_note("helper functions go outside the material, at the top level"));
                }
            }
        }
        // The item depends on all of its methods; defaults add their own edges.
        let id = self.current;
        let item = Node::Item(id, name.clone());
        for im in INTERFACE {
            self.edge(item.clone(), Node::Method(id, name.clone(), im.name), d.name.span);
        }
        if !defined.contains(&"ambient") {
            self.edge(
                Node::Method(id, name.clone(), "ambient"),
                Node::Method(id, name.clone(), "diffuse"),
                d.name.span,
            );
        }

        for m in &d.methods {
            let Some(im) = interface_method(&m.name.name) else {
                continue;
            };
            self.check_method_signature(m, im);
            self.body = Body {
                scopes: params_scope.clone(),
                material: Some((name.clone(), defined.clone())),
                context: "a material method",
                globals_allowed: true,
                node: Some(Node::Method(id, name.clone(), im.name)),
                ..Body::default()
            };
            self.push_scope();
            // The body is checked against the signature as written: a wrong
            // signature is one error, not one per `return`.
            for p in &m.params {
                let ty = Ty::from_ast(&p.ty);
                self.declare_param(&p.name, ty);
            }
            let ret = Ty::from_ast(&m.ret);
            self.body.ret = Some(ret.clone());
            self.block_in_scope(&m.body);
            self.check_returns(m, &ret);
            self.end_scope();
            self.end_scope();
        }
    }

    fn check_method_signature(&mut self, m: &Function, im: &InterfaceMethod) {
        if let Some(d) = m.params.iter().find_map(|p| p.default.as_ref()) {
            self.error(
                Diagnostic::error(d.span, "interface method parameters cannot have default values")
                    .with_help("the renderer always passes every argument; remove the default"),
            );
            return;
        }
        let ret = Ty::from_ast(&m.ret);
        let params_ok = m.params.len() == im.params.len()
            && m.params
                .iter()
                .zip(im.params)
                .all(|(p, (_, t))| Ty::from_ast(&p.ty) == t.clone() && p.default.is_none());
        if ret != im.ret.clone() || !params_ok {
            let written: Vec<String> =
                m.params.iter().map(|p| format!("{} {}", Ty::from_ast(&p.ty), p.name.name)).collect();
            self.error(
                Diagnostic::error(m.name.span, format!("method `{}` has the wrong signature", im.name))
                    .with_primary(format!("found `{} {}({})`", ret, m.name.name, written.join(", ")))
                    .with_help(format!("the material interface expects `{}`", im.signature()))
                    .with_note("parameter names are free; the types, their order and the return type are fixed"),
            );
        }
    }

    fn check_tree(&mut self, t: &MaterialTree) {
        self.begin(Node::Item(self.current, t.name.name.clone()), "a material tree", true, true);
        if let Some(params) = &t.params {
            self.declare_params(params, "a material tree");
        }
        let ty = self.expr(&t.body, Some(&Ty::Material));
        self.expect_ty(&t.body, &ty, &Ty::Material, "a material tree");
        self.end_scope();
    }

    fn check_const(&mut self, c: &ConstDef) {
        self.begin(Node::Item(self.current, c.name.name.clone()), "a constant", false, false);
        let ty = self.resolve_type(&c.ty, "a constant");
        if ty.is_error() {
            return;
        }
        let found = self.expr(&c.value, Some(&ty));
        self.expect_ty(&c.value, &found, &ty, "the constant");
        self.end_scope();
    }

    /// Resolves a written type, refusing materials outside material trees.
    fn resolve_type(&mut self, t: &TypeExpr, what: &str) -> Ty {
        if let Some((n, span)) = t.array_len
            && (n == 0 || n > MAX_ARRAY_LEN)
        {
            self.error(Diagnostic::error(span, format!("array length must be between 1 and {MAX_ARRAY_LEN}")));
            return Ty::Error;
        }
        if t.base == BaseType::Material && !self.body.materials_allowed {
            self.error(Diagnostic::error(t.span, format!("`material` values cannot be used in {what}")).with_help(
                "materials are built by material trees: `material name(material a, float s = 1) = mix(s, a, mirror);`",
            ));
            return Ty::Error;
        }
        if t.base == BaseType::Void && t.array_len.is_some() {
            self.error(Diagnostic::error(t.span, "there are no arrays of `void`"));
            return Ty::Error;
        }
        Ty::from_ast(t)
    }

    // ------------------------------------------------------------ scopes

    fn push_scope(&mut self) {
        self.body.scopes.push(Vec::new());
    }

    fn end_scope(&mut self) {
        let Some(scope) = self.body.scopes.pop() else {
            return;
        };
        for l in scope {
            if l.kind == LocalKind::Var && !l.used && !l.name.starts_with('_') {
                self.error(
                    Diagnostic::warning(l.span, format!("unused variable `{}`", l.name))
                        .with_help(format!("remove it, or name it `_{}` if that is intended", l.name)),
                );
            }
        }
    }

    fn declare(&mut self, local: Local) {
        let Some(scope) = self.body.scopes.last_mut() else {
            return;
        };
        if let Some(prev) = scope.iter().find(|l| l.name == local.name) {
            let prev_span = prev.span;
            self.error(
                Diagnostic::error(local.span, format!("`{}` is already declared in this scope", local.name))
                    .with_label(prev_span, "previous declaration"),
            );
            return;
        }
        scope.push(local);
    }

    /// Parameters are never reported unused: interface methods often ignore some.
    fn declare_param(&mut self, name: &Ident, ty: Ty) {
        self.declare(Local { name: name.name.clone(), ty, span: name.span, kind: LocalKind::Param, used: true });
    }

    fn lookup_local(&mut self, name: &str) -> Option<&mut Local> {
        self.body.scopes.iter_mut().rev().flat_map(|s| s.iter_mut().rev()).find(|l| l.name == name)
    }

    fn edge(&mut self, from: Node, to: Node, span: Span) {
        let edges = self.graph.entry(from).or_default();
        if !edges.iter().any(|(n, _)| *n == to) {
            edges.push((to, span));
        }
    }

    /// Records that the current body uses a global item.
    fn use_item(&mut self, sym: Symbol, name: &str, span: Span) {
        self.resolutions.insert(span, sym);
        if let Some(from) = self.body.node.clone() {
            self.edge(from, Self::item_node(sym, name), span);
        }
    }

    // ------------------------------------------------------------ statements

    fn block_in_scope(&mut self, b: &Block) {
        for s in &b.stmts {
            self.stmt(s);
        }
    }

    fn block(&mut self, b: &Block) {
        self.push_scope();
        self.block_in_scope(b);
        self.end_scope();
    }

    fn stmt(&mut self, s: &Stmt) {
        match &s.kind {
            StmtKind::Let { ty, name, init } => {
                let ty = self.resolve_type(ty, "a local variable");
                // After a bad type, checking the initialiser or use would
                // only repeat the same mistake.
                let bad_type = ty.is_error();
                if let (Some(init), false) = (init, bad_type) {
                    let found = self.expr(init, Some(&ty));
                    self.expect_ty(init, &found, &ty, "the initial value");
                }
                self.warn_shadowed_global(name);
                let local =
                    Local { name: name.name.clone(), ty, span: name.span, kind: LocalKind::Var, used: bad_type };
                self.declare(local);
            }
            StmtKind::Assign { target, op, value } => self.assign(target, *op, value),
            StmtKind::Expr(e) => {
                self.expr(e, None);
                self.error(
                    Diagnostic::warning(e.span, "this expression has no effect")
                        .with_help("TSL functions are pure: assign the result to a variable or return it"),
                );
            }
            StmtKind::If { cond, then_block, else_branch } => {
                self.condition(cond, "an `if` condition");
                self.block(then_block);
                if let Some(e) = else_branch {
                    self.stmt(e);
                }
            }
            StmtKind::For { var, start, end, body } => {
                for bound in [start, end] {
                    let t = self.expr(bound, Some(&Ty::Int));
                    if !t.is_error() && t != Ty::Int {
                        self.error(
                            Diagnostic::error(bound.span, format!("loop bounds must be `int`, found `{t}`"))
                                .with_help("convert with int(x)"),
                        );
                    }
                }
                if let (Some(lo), Some(hi)) = (const_int(start), const_int(end))
                    && hi - lo > MAX_LOOP_ITERATIONS
                {
                    self.error(
                        Diagnostic::warning(start.span.to(end.span), format!("this loop would run {} times", hi - lo))
                            .with_note(format!("a loop stops after {MAX_LOOP_ITERATIONS} iterations")),
                    );
                }
                self.push_scope();
                self.warn_shadowed_global(var);
                self.declare(Local {
                    name: var.name.clone(),
                    ty: Ty::Int,
                    span: var.span,
                    kind: LocalKind::LoopVar,
                    used: true,
                });
                self.body.loops += 1;
                self.block(body);
                self.body.loops -= 1;
                self.end_scope();
            }
            StmtKind::While { cond, body } => {
                self.error(
                    Diagnostic::error(
                        Span { end: cond.span.end, ..s.span },
                        "`while` loops are not allowed: a shader must not hang its host",
                    )
                    .with_help("loop over a bounded range instead: `for i in 0..n { ... }`"),
                );
                self.condition(cond, "a `while` condition");
                self.body.loops += 1;
                self.block(body);
                self.body.loops -= 1;
            }
            StmtKind::Break | StmtKind::Continue => {
                if self.body.loops == 0 {
                    let what = if matches!(s.kind, StmtKind::Break) { "break" } else { "continue" };
                    self.error(Diagnostic::error(s.span, format!("`{what}` outside of a loop")));
                }
            }
            StmtKind::Return(value) => self.ret(s.span, value.as_ref()),
            StmtKind::Block(b) => self.block(b),
        }
    }

    fn warn_shadowed_global(&mut self, name: &Ident) {
        if interface::global(&name.name).is_some() {
            self.error(
                Diagnostic::warning(name.span, format!("`{}` shadows the shading global of the same name", name.name))
                    .with_help("rename the variable to keep the global visible"),
            );
        }
    }

    fn condition(&mut self, cond: &Expr, what: &str) {
        let t = self.expr(cond, Some(&Ty::Bool));
        if !t.is_error() && t != Ty::Bool {
            let mut d = Diagnostic::error(cond.span, format!("{what} must be `bool`, found `{t}`"));
            if t.is_numeric() {
                d = d.with_help("numbers are not truth values: compare explicitly, e.g. `x != 0`");
            }
            self.error(d);
        }
    }

    fn ret(&mut self, span: Span, value: Option<&Expr>) {
        let Some(want) = self.body.ret.clone() else {
            self.error(Diagnostic::error(span, "`return` outside of a function"));
            return;
        };
        match (value, &want) {
            (None, Ty::Void) => {}
            (None, want) => {
                self.error(Diagnostic::error(span, format!("`return` needs a value of type `{want}`")));
            }
            (Some(v), Ty::Void) => {
                self.expr(v, None);
                self.error(Diagnostic::error(v.span, "a `void` function cannot return a value"));
            }
            (Some(v), want) => {
                let found = self.expr(v, Some(want));
                self.expect_ty(v, &found, want, "the return value");
            }
        }
    }

    fn assign(&mut self, target: &Expr, op: AssignOp, value: &Expr) {
        let Some(target_ty) = self.lvalue(target) else {
            self.expr(value, None);
            return;
        };
        let found = self.expr(value, Some(&target_ty));
        match op.binary() {
            None => self.expect_ty(value, &found, &target_ty, "the assigned value"),
            Some(bop) => match binary_type(bop, &target_ty, &found) {
                Ok(result) if result.converts_to(&target_ty) => {}
                Ok(result) => self.error(Diagnostic::error(
                    value.span,
                    format!(
                        "`{target_ty} {}= {found}` gives `{result}`, which cannot be stored in `{target_ty}`",
                        bop.symbol()
                    ),
                )),
                Err((message, help)) => {
                    let mut d = Diagnostic::error(value.span, message);
                    if let Some(h) = help {
                        d = d.with_help(h);
                    }
                    self.error(d);
                }
            },
        }
    }

    /// Checks an assignment target and returns its type.
    fn lvalue(&mut self, e: &Expr) -> Option<Ty> {
        match &e.kind {
            ExprKind::Name(name) => {
                if let Some(local) = self.lookup_local(name) {
                    let (kind, ty) = (local.kind.clone(), local.ty.clone());
                    if kind == LocalKind::LoopVar {
                        self.error(
                            Diagnostic::error(e.span, format!("cannot assign to the loop variable `{name}`"))
                                .with_help("copy it into a local variable first"),
                        );
                        return None;
                    }
                    self.expr_types.insert(e.span, ty.clone());
                    return Some(ty);
                }
                let (msg, ty) = if let Some(ty) = interface::global(name) {
                    (format!("cannot assign to `{name}`: shading globals are read-only"), ty)
                } else if let Some(sym) = self.symbol(name).filter(|s| s.kind == SymbolKind::Const) {
                    (format!("cannot assign to the constant `{name}`"), self.const_type(sym))
                } else {
                    self.expr(e, None);
                    return None;
                };
                let copy = format!("my_{}", name.to_lowercase());
                self.error(
                    Diagnostic::error(e.span, msg)
                        .with_help(format!("declare a local copy and change that: `{ty} {copy} = {name};`")),
                );
                None
            }
            ExprKind::Member { base, .. } | ExprKind::Index { base, .. } => {
                self.lvalue(base)?;
                let t = self.expr(e, None);
                (!t.is_error()).then_some(t)
            }
            _ => {
                self.expr(e, None);
                self.error(Diagnostic::error(e.span, "this expression cannot be assigned to"));
                None
            }
        }
    }

    // ------------------------------------------------------------ expressions

    fn expect_ty(&mut self, e: &Expr, found: &Ty, want: &Ty, what: &str) {
        if found.converts_to(want) {
            return;
        }
        let mut d = Diagnostic::error(e.span, format!("mismatched types: expected `{want}`, found `{found}`"))
            .with_primary(format!("{what} must be `{want}`"));
        if *want == Ty::Color && found.is_numeric() {
            d = d.with_help("a number is not a color: write gray(x) for a uniform color, or rgb(r, g, b)");
        } else if *found == Ty::Color && (want.is_numeric() || want.is_triple()) {
            d = d.with_help(
                "a color hides its representation (RGB or spectral samples): convert explicitly with brightness(c) or to_rgb(c)",
            );
        } else if *want == Ty::Int && *found == Ty::Float {
            d = d.with_help("convert explicitly with int(x), which truncates");
        }
        self.error(d);
    }

    /// Types an expression, recording the result. `expected` guides tuples
    /// and array literals and is otherwise only a hint.
    fn expr(&mut self, e: &Expr, expected: Option<&Ty>) -> Ty {
        let ty = self.expr_inner(e, expected);
        self.expr_types.insert(e.span, ty.clone());
        ty
    }

    fn expr_inner(&mut self, e: &Expr, expected: Option<&Ty>) -> Ty {
        match &e.kind {
            ExprKind::Int(_) => Ty::Int,
            ExprKind::Float(_) => Ty::Float,
            ExprKind::Bool(_) => Ty::Bool,
            ExprKind::Str(_) => Ty::String,
            ExprKind::Name(name) => self.name(name, e.span),
            ExprKind::Call { callee, args } => self.call(callee, args, e.span),
            ExprKind::Construct { ty, ty_span, args } => self.construct(*ty, *ty_span, args, e.span),
            ExprKind::Member { base, field } => self.member(base, field),
            ExprKind::Index { base, index } => self.index(base, index),
            ExprKind::Unary { op, operand } => {
                let t = self.expr(operand, None);
                match (op, &t) {
                    (_, Ty::Error) => Ty::Error,
                    (UnaryOp::Neg, t) if t.is_numeric() || t.is_float_like() => {
                        if t.is_triple() {
                            Ty::Vector
                        } else {
                            t.clone()
                        }
                    }
                    (UnaryOp::Not, Ty::Bool) => Ty::Bool,
                    // Lane-wise, like `c1 - c2`: see `color_arith`.
                    (UnaryOp::Neg, Ty::Color) => Ty::Color,
                    (op, t) => {
                        let sym = if *op == UnaryOp::Neg { "-" } else { "!" };
                        self.error(Diagnostic::error(e.span, format!("cannot apply unary `{sym}` to `{t}`")));
                        Ty::Error
                    }
                }
            }
            ExprKind::Binary { op, lhs, rhs } => {
                let l = self.expr(lhs, None);
                let r = self.expr(rhs, None);
                if l == Ty::String && r == Ty::String {
                    for side in [lhs, rhs] {
                        let known = match &side.kind {
                            ExprKind::Str(_) => true,
                            ExprKind::Name(n) => self.lookup_local(n).is_some_and(|l| l.kind == LocalKind::Param),
                            _ => false,
                        };
                        if !known {
                            self.error(
                                Diagnostic::error(side.span, "only string literals and `string` parameters can be compared")
                                    .with_help("a string is an option chosen when the shader is compiled: compare a parameter with a literal, `mode == \"ggx\"`"),
                            );
                            return Ty::Error;
                        }
                    }
                    self.record_string_option(lhs, rhs);
                }
                match binary_type(*op, &l, &r) {
                    Ok(t) => t,
                    Err((message, help)) => {
                        let mut d = Diagnostic::error(e.span, message)
                            .with_label(lhs.span, format!("`{l}`"))
                            .with_label(rhs.span, format!("`{r}`"));
                        if let Some(h) = help {
                            d = d.with_help(h);
                        }
                        self.error(d);
                        Ty::Error
                    }
                }
            }
            ExprKind::Ternary { cond, then_expr, else_expr } => {
                self.condition(cond, "the condition of `?:`");
                let a = self.expr(then_expr, expected);
                let b = self.expr(else_expr, expected);
                match unify(&a, &b) {
                    Some(Ty::String) => {
                        self.error(
                            Diagnostic::error(e.span, "a string cannot be chosen while shading")
                                .with_help("strings are file names and options fixed when the shader is compiled; choose between the values they select instead"),
                        );
                        Ty::Error
                    }
                    Some(t) => t,
                    None => {
                        self.error(
                            Diagnostic::error(
                                e.span,
                                format!("the branches of `?:` have different types: `{a}` and `{b}`"),
                            )
                            .with_label(then_expr.span, format!("`{a}`"))
                            .with_label(else_expr.span, format!("`{b}`")),
                        );
                        Ty::Error
                    }
                }
            }
            ExprKind::Array(items) => self.array(items, e.span, expected),
            ExprKind::Tuple(items) => self.tuple(items, e.span, expected),
        }
    }

    fn name(&mut self, name: &str, span: Span) -> Ty {
        if let Some(local) = self.lookup_local(name) {
            local.used = true;
            return local.ty.clone();
        }
        if let Some(t) = interface::global(name) {
            if !self.body.globals_allowed {
                let help = if self.body.context == "the scene" {
                    "scene values are fixed before shading starts; only a `material` may vary over the surface"
                } else {
                    "constants are fixed before shading starts; use a function to compute a value per shading point"
                };
                self.error(
                    Diagnostic::error(
                        span,
                        format!("the shading global `{name}` cannot be used in {}", self.body.context),
                    )
                    .with_help(help),
                );
                return Ty::Error;
            }
            if let Some(node) = &self.body.node {
                self.reads_globals.entry(node.clone()).or_insert(span);
            }
            return t;
        }
        if let Some(sym) = self.symbol(name) {
            self.use_item(sym, name, span);
            return match sym.kind {
                SymbolKind::Const => self.const_type(sym),
                SymbolKind::MaterialTree | SymbolKind::Material => {
                    let needs_args = match self.item(sym) {
                        Item::MaterialTree(t) => t.params.as_ref().map(|ps| required_params(ps)).unwrap_or_default(),
                        Item::Material(d) => required_params(&d.params),
                        _ => Vec::new(),
                    };
                    if !needs_args.is_empty() {
                        self.error(
                            Diagnostic::error(span, format!("`{name}` needs arguments: {}", needs_args.join(", ")))
                                .with_help(format!("call it: `{name}(...)`")),
                        );
                        return Ty::Error;
                    }
                    self.material_value(span)
                }
                SymbolKind::Function => {
                    self.error(
                        Diagnostic::error(span, format!("`{name}` is a function, not a value"))
                            .with_help(format!("call it: `{name}()`")),
                    );
                    Ty::Error
                }
            };
        }
        if builtin(name).is_some() {
            self.error(
                Diagnostic::error(span, format!("`{name}` is a builtin function, not a value"))
                    .with_help(format!("call it: `{name}(...)`")),
            );
            return Ty::Error;
        }
        self.unknown(name, span, "value");
        Ty::Error
    }

    /// A material value where one appears; outside material trees that is
    /// an error.
    fn material_value(&mut self, span: Span) -> Ty {
        if self.body.materials_allowed {
            Ty::Material
        } else {
            self.error(
                Diagnostic::error(span, format!("a material cannot be used in {}", self.body.context))
                    .with_help("build texture trees at the top level: `material name = mix(...);`"),
            );
            Ty::Error
        }
    }

    fn item(&self, sym: Symbol) -> &'a Item {
        &self.loaded.modules[sym.module].ast.items[sym.item]
    }

    fn const_type(&mut self, sym: Symbol) -> Ty {
        match self.item(sym) {
            Item::Const(c) => Ty::from_ast(&c.ty),
            _ => Ty::Error,
        }
    }

    /// Reports an unknown name with the closest known one.
    fn unknown(&mut self, name: &str, span: Span, what: &str) {
        let mut candidates: Vec<&str> = Vec::new();
        for scope in &self.body.scopes {
            candidates.extend(scope.iter().map(|l| l.name.as_str()));
        }
        if self.body.globals_allowed {
            candidates.extend(GLOBALS.iter().map(|g| g.0));
        }
        let table = if self.in_prelude { self.prelude_symbols } else { self.symbols };
        candidates.extend(table.keys().map(String::as_str));
        if what == "function" {
            candidates.extend(BUILTINS.iter().map(|b| b.name));
            if let Some((_, _)) = &self.body.material {
                candidates.extend(INTERFACE.iter().map(|m| m.name));
            }
        }
        let mut d = Diagnostic::error(span, format!("cannot find {what} `{name}` in this scope"));
        if let Some(s) = did_you_mean(name, candidates) {
            d = d.with_help(format!("did you mean `{s}`?"));
        } else if interface_method(name).is_some() {
            d = d.with_help("interface methods can be called only inside a material definition");
        }
        self.error(d);
    }

    /// Matches call arguments to parameters. Returns, per parameter, the
    /// argument bound to it, or `None` when the call is malformed.
    fn bind_args<'e>(
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

    fn call(&mut self, callee: &Ident, args: &[Arg], span: Span) -> Ty {
        let name = callee.name.as_str();
        // 1. A sibling method inside a material.
        if let Some((material, _defined)) = self.body.material.clone()
            && let Some(im) = interface_method(name)
        {
            let params: Vec<ParamInfo> =
                im.params.iter().map(|(n, t)| ParamInfo { name: n, ty: Some(t.clone()), required: true }).collect();
            if let Some(from) = self.body.node.clone() {
                self.edge(from, Node::Method(self.current, material, im.name), callee.span);
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
            self.use_item(sym, name, callee.span);
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

    /// `p == "literal"` (either way round) where `p` is a `string`
    /// parameter of the item being checked: "literal" is one of p's options.
    fn record_string_option(&mut self, lhs: &Expr, rhs: &Expr) {
        let (name, literal) = match (&lhs.kind, &rhs.kind) {
            (ExprKind::Name(n), ExprKind::Str(s)) | (ExprKind::Str(s), ExprKind::Name(n)) => (n, s),
            _ => return,
        };
        if self.lookup_local(name).is_some_and(|l| l.kind == LocalKind::Param) {
            let options = self.string_options.entry((self.current, name.clone())).or_default();
            if !options.contains(literal) {
                options.push(literal.clone());
            }
        }
    }

    /// Remembers the string literals of a call for [`Self::report_string_options`].
    fn note_string_args(&mut self, sym: Symbol, callee: &str, params: &[Param], args: &[Arg]) {
        let infos: Vec<(&str, Ty)> = params.iter().map(|p| (p.name.name.as_str(), Ty::from_ast(&p.ty))).collect();
        for (k, a) in args.iter().enumerate() {
            let slot = match &a.name {
                Some(n) => infos.iter().position(|(p, _)| *p == n.name),
                None => Some(k),
            };
            let (Some(slot), ExprKind::Str(literal)) = (slot, &a.value.kind) else { continue };
            let Some(p) = params.get(slot).filter(|p| Ty::from_ast(&p.ty) == Ty::String) else { continue };
            let default = match p.default.as_ref().map(|d| &d.kind) {
                Some(ExprKind::Str(d)) => Some(d.clone()),
                _ => None,
            };
            self.string_args.push(StringArg {
                callee: (sym.module, sym.item),
                callee_name: callee.to_string(),
                param: p.name.name.clone(),
                literal: literal.clone(),
                default,
                span: a.value.span,
            });
        }
    }

    /// A `string` option must be one its item tells apart: a literal its
    /// body compares the parameter with, or its default.
    fn report_string_options(&mut self) {
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

    fn untyped_args(&mut self, args: &[Arg]) {
        for a in args {
            self.expr(&a.value, None);
        }
    }

    fn typed_args(&mut self, callee: &str, params: &[ParamInfo], args: &[Arg], span: Span) {
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

    fn builtin_call(&mut self, b: &Builtin, args: &[Arg], span: Span) -> Ty {
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
            BuiltinFn::Texture | BuiltinFn::TextureFloat => self.check_texture(b, &bound, span),
            _ => {}
        }
        result
    }

    /// A `texture` call: the file and the options are string literals
    /// naming things that exist; the call is recorded for loading and
    /// lowering. It depends on the shading point (its footprint).
    fn check_texture(&mut self, b: &Builtin, bound: &[Option<&Expr>], span: Span) {
        let (name, color) = (b.name, b.func == BuiltinFn::Texture);
        let arg = |param: &str| b.arg(bound, param);
        if !self.body.globals_allowed {
            self.error(
                Diagnostic::error(span, format!("`{name}` cannot be used in {}", self.body.context))
                    .with_help("a texture lookup depends on the shading point and its pixel footprint"),
            );
            return;
        }
        if let Some(node) = &self.body.node {
            self.reads_globals.entry(node.clone()).or_insert(span);
        }
        let filter = self.option_literal(arg("filter"), "filter", Filter::NAMES, Filter::from_name);
        let wrap = self.option_literal(arg("wrap"), "wrap", Wrap::NAMES, Wrap::from_name);
        let swrap = self.option_literal(arg("swrap"), "swrap", Wrap::NAMES, Wrap::from_name);
        let twrap = self.option_literal(arg("twrap"), "twrap", Wrap::NAMES, Wrap::from_name);
        // texture_float has no colorspace parameter: it reads stored values.
        let encoding = self.option_literal(arg("colorspace"), "colorspace", &["srgb", "linear"], |n| match n {
            "srgb" => Some(Encoding::Srgb),
            "linear" => Some(Encoding::Raw),
            _ => None,
        });
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
        let wrap = wrap.unwrap_or(Wrap::Repeat);
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

    /// An optional string-literal option: `Some(None)` when absent,
    /// `Some(Some(x))` when it names a known choice, `None` after an error.
    fn option_literal<T>(
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
    fn check_only(&mut self, only: &Expr) {
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
    fn check_spectrum(&mut self, samples: &Expr) {
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

    fn construct(&mut self, ty: BaseType, ty_span: Span, args: &[Arg], span: Span) -> Ty {
        // Inside a material, `normal()` is the interface method, not a constructor.
        if ty == BaseType::Normal && args.is_empty() && self.body.material.is_some() {
            let callee = Ident { name: "normal".into(), span: ty_span };
            return self.call(&callee, args, span);
        }
        for a in args {
            if let Some(n) = &a.name {
                self.error(Diagnostic::error(n.span, "type constructors take positional arguments only"));
            }
        }
        let tys: Vec<Ty> = args.iter().map(|a| self.expr(&a.value, None)).collect();
        if ty == BaseType::BsdfSample {
            return self.construct_sample(args, &tys, span);
        }
        let result = Ty::from_base(ty);
        let (counts, elem): (&[usize], Ty) = match ty {
            BaseType::Color => {
                self.error(
                    Diagnostic::error(ty_span, "colors have no component constructor")
                        .with_help("a color hides its representation: build one with rgb(r, g, b), hsv(h, s, v), xyz(x, y, z), gray(v), black() or spectrum([...])"),
                );
                return Ty::Error;
            }
            BaseType::Vector | BaseType::Point | BaseType::Normal => (&[1, 3], Ty::Float),
            BaseType::Vec2 => (&[1, 2], Ty::Float),
            BaseType::Float | BaseType::Int => (&[1], Ty::Float),
            BaseType::Matrix => (&[0, 1, 12], Ty::Float),
            _ => (&[], Ty::Error),
        };
        if !counts.contains(&tys.len()) {
            let want: Vec<String> = counts.iter().map(|c| c.to_string()).collect();
            self.error(
                Diagnostic::error(span, format!("`{}(...)` takes {} arguments, found {}", ty.keyword(), want.join(" or "), tys.len()))
                    .with_help(match ty {
                        BaseType::Matrix => "matrix() is the identity, matrix(s) scales, matrix(12 floats) gives the three rows of an affine transform",
                        BaseType::Vec2 => "vec2(s) repeats s; vec2(a, b) sets both",
                        _ => "vector(s) repeats s; vector(x, y, z) sets each",
                    }),
            );
            return Ty::Error;
        }
        for (a, t) in args.iter().zip(&tys) {
            let ok = if matches!(ty, BaseType::Float | BaseType::Int) {
                t.is_numeric() || t.is_error()
            } else {
                t.converts_to(&elem)
            };
            if !ok {
                let mut d = Diagnostic::error(a.value.span, format!("expected a number, found `{t}`"));
                if *t == Ty::Color {
                    d = d.with_help("a color has no components: use to_rgb(c) for an explicit conversion");
                }
                self.error(d);
                return Ty::Error;
            }
        }
        result
    }

    /// `bsdf_sample(vector wi, color weight, float pdf)`: a direction drawn
    /// from a density (see `delta_sample` for delta lobes).
    fn construct_sample(&mut self, args: &[Arg], tys: &[Ty], span: Span) -> Ty {
        const SIGNATURE: &str = "bsdf_sample(vector wi, color weight, float pdf)";
        if tys.len() != 3 {
            self.error(
                Diagnostic::error(span, format!("`bsdf_sample(...)` takes 3 arguments, found {}", tys.len()))
                    .with_note(format!("expected {SIGNATURE}"))
                    .with_help("a delta lobe's sample is delta_sample(wi, weight); no sample at all is no_sample()"),
            );
            return Ty::Error;
        }
        for (k, want) in [Ty::Vector, Ty::Color, Ty::Float].iter().enumerate() {
            if !tys[k].converts_to(want) {
                let mut d = Diagnostic::error(args[k].value.span, format!("expected `{want}`, found `{}`", tys[k]))
                    .with_note(format!("expected {SIGNATURE}"));
                if *want == Ty::Color && tys[k].is_numeric() {
                    d = d.with_help("a number is not a color: write gray(x) for a uniform color");
                }
                self.error(d);
                return Ty::Error;
            }
        }
        Ty::BsdfSample
    }

    fn member(&mut self, base: &Expr, field: &Ident) -> Ty {
        let t = self.expr(base, None);
        let fields: &[&str] = match &t {
            Ty::Error => return Ty::Error,
            t if t.is_triple() => &["x", "y", "z"],
            Ty::Vec2 => &["x", "y"],
            Ty::BsdfSample => {
                if let Some((_, ty)) = SAMPLE_FIELDS.iter().find(|(n, _)| *n == field.name) {
                    return ty.clone();
                }
                &["wi", "weight", "pdf", "delta"]
            }
            Ty::Color => {
                self.error(
                    Diagnostic::error(field.span, format!("cannot read component `{}` of a color", field.name))
                        .with_label(base.span, "this is a `color`")
                        .with_help("a color hides its representation (RGB or N spectral samples), so shaders run unchanged in both renderers: use brightness(c) for a scalar or to_rgb(c) for an explicit conversion"),
                );
                return Ty::Error;
            }
            _ => &[],
        };
        if fields.contains(&field.name.as_str()) {
            return Ty::Float;
        }
        let mut d = Diagnostic::error(field.span, format!("`{t}` has no field `{}`", field.name));
        if !fields.is_empty() {
            d = d.with_help(format!("the fields of `{t}` are {}", fields.join(", ")));
        }
        self.error(d);
        Ty::Error
    }

    fn index(&mut self, base: &Expr, index: &Expr) -> Ty {
        let t = self.expr(base, None);
        let i = self.expr(index, Some(&Ty::Int));
        if !i.is_error() && i != Ty::Int {
            self.error(
                Diagnostic::error(index.span, format!("an index must be `int`, found `{i}`"))
                    .with_help("convert with int(x)"),
            );
        }
        let (elem, len) = match &t {
            Ty::Error => return Ty::Error,
            Ty::Array(e, n) => ((**e).clone(), *n),
            t if t.is_triple() => (Ty::Float, 3),
            Ty::Vec2 => (Ty::Float, 2),
            Ty::Color => {
                self.error(
                    Diagnostic::error(index.span, "cannot index a color")
                        .with_label(base.span, "this is a `color`")
                        .with_help("a color hides its representation (RGB or N spectral samples): use brightness(c) or to_rgb(c)"),
                );
                return Ty::Error;
            }
            t => {
                self.error(Diagnostic::error(base.span, format!("`{t}` cannot be indexed")));
                return Ty::Error;
            }
        };
        if let Some(k) = const_int(index)
            && (k < 0 || k >= i64::from(len))
        {
            self.error(
                Diagnostic::error(index.span, format!("index {k} is out of bounds"))
                    .with_label(base.span, format!("this has {len} elements")),
            );
        }
        elem
    }

    fn array(&mut self, items: &[Expr], span: Span, expected: Option<&Ty>) -> Ty {
        let mut wrong_len = false;
        let want_elem = match expected {
            Some(Ty::Array(e, n)) => {
                if items.len() != *n as usize {
                    self.error(Diagnostic::error(
                        span,
                        format!("expected an array of {n} items, found {}", items.len()),
                    ));
                    wrong_len = true;
                }
                Some((**e).clone())
            }
            _ => None,
        };
        if items.is_empty() {
            if want_elem.is_none() {
                self.error(Diagnostic::error(span, "cannot infer the type of an empty array"));
            }
            return Ty::Error;
        }
        if items.len() > MAX_ARRAY_LEN as usize {
            self.error(Diagnostic::error(span, format!("an array has at most {MAX_ARRAY_LEN} items")));
            return Ty::Error;
        }
        let mut elem: Option<Ty> = None;
        for item in items {
            let t = self.expr(item, want_elem.as_ref());
            elem = match elem {
                None => Some(t),
                Some(prev) => match unify(&prev, &t) {
                    Some(u) => Some(u),
                    None => {
                        self.error(Diagnostic::error(
                            item.span,
                            format!("array items must share one type: expected `{prev}`, found `{t}`"),
                        ));
                        Some(Ty::Error)
                    }
                },
            };
        }
        let elem = elem.unwrap_or(Ty::Error);
        if elem == Ty::Material && !self.body.materials_allowed {
            return self.material_value(span);
        }
        if let Ty::Array(..) = elem {
            self.error(Diagnostic::error(span, "arrays of arrays are not supported"));
            return Ty::Error;
        }
        if wrong_len {
            return Ty::Error;
        }
        Ty::Array(Box::new(elem), items.len() as u32)
    }

    fn tuple(&mut self, items: &[Expr], span: Span, expected: Option<&Ty>) -> Ty {
        let result = match (expected, items.len()) {
            (Some(t), 3) if t.is_triple() => t.clone(),
            (Some(Ty::Vec2), 2) => Ty::Vec2,
            (_, 3) => Ty::Vector,
            (_, 2) => Ty::Vec2,
            (_, n) => {
                self.error(
                    Diagnostic::error(span, format!("a tuple of {n} values has no type"))
                        .with_help("tuples of two numbers are vec2, of three numbers vector/point/normal"),
                );
                self.untyped_exprs(items);
                return Ty::Error;
            }
        };
        for item in items {
            let t = self.expr(item, Some(&Ty::Float));
            if !t.converts_to(&Ty::Float) {
                self.error(Diagnostic::error(item.span, format!("tuple items must be numbers, found `{t}`")));
            }
        }
        result
    }

    fn untyped_exprs(&mut self, items: &[Expr]) {
        for item in items {
            self.expr(item, None);
        }
    }

    // ------------------------------------------------------------ recursion

    /// Shade trees are DAGs: any cycle among functions, materials, methods,
    /// trees and constants is an error, reported once per cycle.
    fn report_recursion(&mut self) {
        let mut nodes: Vec<Node> = self.graph.keys().cloned().collect();
        nodes.sort();
        let mut state: HashMap<Node, u8> = HashMap::new();
        for start in nodes {
            if state.contains_key(&start) {
                continue;
            }
            let mut stack: Vec<(Node, usize, Option<Span>)> = vec![(start.clone(), 0, None)];
            state.insert(start, 1);
            while let Some((node, next, _)) = stack.last().cloned() {
                let out = self.graph.get(&node).map(Vec::as_slice).unwrap_or(&[]);
                if let Some((to, span)) = out.get(next).cloned() {
                    if let Some(top) = stack.last_mut() {
                        top.1 += 1;
                    }
                    match state.get(&to).copied().unwrap_or(0) {
                        0 => {
                            state.insert(to.clone(), 1);
                            stack.push((to, 0, Some(span)));
                        }
                        1 => {
                            let pos = stack.iter().position(|(n, _, _)| *n == to).unwrap_or(0);
                            let mut path: Vec<String> = stack[pos..].iter().map(|(n, _, _)| n.describe()).collect();
                            path.push(to.describe());
                            let cycle: Vec<&Node> = stack[pos..].iter().map(|(n, _, _)| n).collect();
                            let d = self.cycle_diagnostic(&cycle, &to, span, path);
                            self.diags.push(d);
                        }
                        _ => {}
                    }
                } else {
                    state.insert(node, 2);
                    stack.pop();
                }
            }
        }
    }
}

impl Checker<'_> {
    fn is_const(&self, node: &Node) -> bool {
        let (m, i) = node.id();
        matches!(node, Node::Item(..)) && matches!(self.loaded.modules[m].ast.items[i], Item::Const(_))
    }

    fn cycle_diagnostic(&self, cycle: &[&Node], to: &Node, span: Span, path: Vec<String>) -> Diagnostic {
        if cycle.iter().all(|n| self.is_const(n)) {
            let msg = if cycle.len() == 1 {
                format!("constant {} is defined in terms of itself", to.describe())
            } else {
                "these constants are defined in terms of each other".to_string()
            };
            return Diagnostic::error(span, msg).with_note(format!("cycle: {}", path.join(" -> ")));
        }
        let msg = if cycle.len() == 1 {
            format!("{} calls itself: recursion is not allowed", to.describe())
        } else {
            "recursion is not allowed: these definitions call each other".to_string()
        };
        let mut d = Diagnostic::error(span, msg).with_note(format!("cycle: {}", path.join(" -> ")));
        // The default `ambient` calls `diffuse`; say so when that closes the cycle.
        let default_ambient = cycle.iter().find_map(|n| match n {
            Node::Method((m, i), name, "ambient") => match &self.loaded.modules[*m].ast.items[*i] {
                Item::Material(def) if !def.methods.iter().any(|f| f.name.name == "ambient") => Some(name.clone()),
                _ => None,
            },
            _ => None,
        });
        if let Some(material) = default_ambient {
            d = d
                .with_note(format!("`{material}` does not define `ambient`; its default is `light * diffuse()`"))
                .with_help(format!("define `ambient` in `{material}`, or do not call `ambient` from `diffuse`"));
        } else {
            d = d
                .with_help("shade trees are acyclic so every shader terminates; compute iteratively with a `for` loop");
        }
        d
    }

    /// A constant may not depend on the shading point, not even through the
    /// functions it calls.
    fn report_varying_constants(&mut self) {
        let mut consts: Vec<Node> = self.graph.keys().filter(|n| self.is_const(n)).cloned().collect();
        consts.sort();
        for start in consts {
            // Depth-first search for a node that reads a global, keeping the
            // path for the message.
            let mut seen: HashMap<Node, ()> = HashMap::new();
            let mut stack: Vec<(Node, usize)> = vec![(start.clone(), 0)];
            seen.insert(start.clone(), ());
            let mut found: Option<Vec<Node>> = None;
            while let Some((node, next)) = stack.last().cloned() {
                if self.reads_globals.contains_key(&node) {
                    found = Some(stack.iter().map(|(n, _)| n.clone()).collect());
                    break;
                }
                let out = self.graph.get(&node).map(Vec::as_slice).unwrap_or(&[]);
                match out.get(next) {
                    Some((to, _)) => {
                        if let Some(top) = stack.last_mut() {
                            top.1 += 1;
                        }
                        if seen.insert(to.clone(), ()).is_none() {
                            stack.push((to.clone(), 0));
                        }
                    }
                    None => {
                        stack.pop();
                    }
                }
            }
            let Some(path) = found else { continue };
            let Some(first_use) = self
                .graph
                .get(&start)
                .and_then(|out| out.iter().find(|(n, _)| path.get(1) == Some(n)).map(|(_, span)| *span))
            else {
                continue;
            };
            let reader = &path[path.len() - 1];
            let global_span = self.reads_globals[reader];
            let names: Vec<String> = path.iter().map(Node::describe).collect();
            self.diags.push(
                Diagnostic::error(first_use, format!("constant {} depends on the shading point", start.describe()))
                    .with_label(global_span, format!("{} reads a shading global here", reader.describe()))
                    .with_note(format!("through {}", names.join(" -> ")))
                    .with_help("a constant is fixed before shading starts; make it a function instead"),
            );
        }
    }
}

/// The type of `l op r`, or a message and help line.
fn binary_type(op: BinaryOp, l: &Ty, r: &Ty) -> Result<Ty, (String, Option<String>)> {
    use BinaryOp::*;
    if l.is_error() || r.is_error() {
        return Ok(if matches!(op, Eq | Ne | Lt | Le | Gt | Ge | And | Or) { Ty::Bool } else { Ty::Error });
    }
    let sym = op.symbol();
    let plain = |m: String| Err((m, None));
    let color_help = "a color hides its representation (RGB or spectral samples)";
    match op {
        And | Or => {
            if *l == Ty::Bool && *r == Ty::Bool {
                Ok(Ty::Bool)
            } else {
                Err((
                    format!("`{sym}` needs two `bool`s, found `{l}` and `{r}`"),
                    Some("compare numbers explicitly, e.g. `x != 0`".into()),
                ))
            }
        }
        Lt | Le | Gt | Ge => {
            if l.is_numeric() && r.is_numeric() {
                Ok(Ty::Bool)
            } else if *l == Ty::Color || *r == Ty::Color {
                Err((
                    format!("colors cannot be ordered with `{sym}`"),
                    Some(format!("{color_help}: compare brightness(a) {sym} brightness(b)")),
                ))
            } else {
                plain(format!("cannot compare `{l}` {sym} `{r}`"))
            }
        }
        Eq | Ne => {
            if (l.is_numeric() && r.is_numeric()) || (*l == Ty::Bool && *r == Ty::Bool) {
                Ok(Ty::Bool)
            } else if *l == Ty::String && *r == Ty::String {
                // Both are literals or string parameters, known when the
                // item is compiled: the comparison folds to a constant.
                Ok(Ty::Bool)
            } else if *l == Ty::Color || *r == Ty::Color {
                Err((
                    format!("colors cannot be compared with `{sym}`"),
                    Some(format!("{color_help}: compare brightness(a) and brightness(b)")),
                ))
            } else if elementwise(l, r).is_some() && l.is_float_like() && r.is_float_like() {
                Ok(Ty::Bool)
            } else {
                plain(format!("cannot compare `{l}` {sym} `{r}`"))
            }
        }
        Add | Sub | Mul | Div | Rem => {
            if *l == Ty::Color || *r == Ty::Color {
                return color_arith(op, l, r);
            }
            if *l == Ty::Matrix || *r == Ty::Matrix {
                return if op == Mul && l == r {
                    Ok(Ty::Matrix)
                } else {
                    Err((
                        format!("cannot apply `{sym}` to `{l}` and `{r}`"),
                        Some("matrices compose with `*`; apply one with transform_point, transform_vector or transform_normal".into()),
                    ))
                };
            }
            match elementwise(l, r) {
                Some(t) => Ok(t),
                None => {
                    let help = (*l == Ty::Material || *r == Ty::Material)
                        .then(|| "combine materials with texture-tree nodes: mix, blend, select, scale".to_string());
                    Err((format!("cannot apply `{sym}` to `{l}` and `{r}`"), help))
                }
            }
        }
    }
}

/// The generic color interface: `+`, `-`, `*` and `/` between colors (lane
/// by lane, so no component is ever named), `*` and `/` by a float. A
/// number is never a color: `c + 1` is an error (write `gray(1)`).
fn color_arith(op: BinaryOp, l: &Ty, r: &Ty) -> Result<Ty, (String, Option<String>)> {
    use BinaryOp::*;
    let (lc, rc) = (*l == Ty::Color, *r == Ty::Color);
    let ok = match op {
        Add | Sub => lc && rc,
        Mul => (lc && (rc || r.is_numeric())) || (l.is_numeric() && rc),
        Div => lc && (rc || r.is_numeric()),
        _ => false,
    };
    if ok {
        return Ok(Ty::Color);
    }
    let sym = op.symbol();
    let help = match op {
        Add | Sub if l.is_numeric() || r.is_numeric() => {
            "a number is not a color: write gray(x) for a uniform color".to_string()
        }
        Div if l.is_numeric() => {
            "a number cannot be divided by a color; divide two colors, or scale by 1 / x".to_string()
        }
        _ => "colors support `+`, `-`, `*` and `/` with colors, and `*` and `/` by a float".to_string(),
    };
    Err((format!("cannot apply `{sym}` to `{l}` and `{r}`"), Some(help)))
}

fn required_params(params: &[Param]) -> Vec<String> {
    params.iter().filter(|p| p.default.is_none()).map(|p| p.name.name.clone()).collect()
}

fn plural(n: usize) -> &'static str {
    if n == 1 { "" } else { "s" }
}

fn const_number(e: &Expr) -> Option<f64> {
    match &e.kind {
        ExprKind::Int(i) => Some(f64::from(*i)),
        ExprKind::Float(f) => Some(*f),
        ExprKind::Unary { op: UnaryOp::Neg, operand } => const_number(operand).map(|v| -v),
        _ => None,
    }
}

fn const_int(e: &Expr) -> Option<i64> {
    match &e.kind {
        ExprKind::Int(i) => Some(i64::from(*i)),
        ExprKind::Unary { op: UnaryOp::Neg, operand } => const_int(operand).map(|v| -v),
        _ => None,
    }
}

/// Whether every path through the block ends in `return`.
fn block_returns(b: &Block) -> bool {
    b.stmts.iter().any(stmt_returns)
}

fn stmt_returns(s: &Stmt) -> bool {
    match &s.kind {
        StmtKind::Return(_) => true,
        StmtKind::Block(b) => block_returns(b),
        StmtKind::If { then_block, else_branch: Some(e), .. } => block_returns(then_block) && stmt_returns(e),
        _ => false,
    }
}
