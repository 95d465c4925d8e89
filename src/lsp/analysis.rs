//! One document checked for the editor's questions: the compiler's own
//! front end (load, parse, check) over the unsaved text, what is under a
//! position, and what a name refers to.
//!
//! Unlike `tsl::check_source`, the checker runs even when the text has
//! syntax errors: the items lalrpop's recovery kept still get symbols and
//! types, so hover and go-to-definition keep working while a line is
//! half typed. Its diagnostics are not shown (the diagnostics pass is
//! `check_source`'s, in `diagnostics.rs`).

use super::line_index::LineIndex;
use crate::check::{self, BuiltinFn, InterfaceMethod, Symbol, SymbolKind, Ty, interface_method};
use crate::diag::{FileId, Span};
use crate::load::{self, LoadOptions, Module};
use crate::syntax::ast::*;
use std::cell::OnceCell;

/// A document's text checked with its imports and the prelude.
pub struct Analysis {
    pub program: check::Program,
    /// The module of the document itself.
    pub root: usize,
    /// Each file's line index, built the first time a position in it is
    /// asked for (so once per version of the document).
    line_indexes: Vec<OnceCell<LineIndex>>,
}

impl Analysis {
    /// Checks `text` loaded as `name`. A document that is one of the
    /// prelude's files (`prelude_name`, unchanged) is analysed as the
    /// prelude module itself, so its definitions are not seen twice.
    pub fn new(name: &str, text: &str, options: &LoadOptions, prelude_name: Option<&str>) -> Analysis {
        let prelude_view = prelude_name.filter(|p| load::PRELUDE.iter().any(|(n, t)| n == p && *t == text));
        let (loaded, _) = load::load_source(name, if prelude_view.is_some() { " " } else { text }, options);
        let root = match prelude_view {
            Some(p) => loaded.modules.iter().position(|m| m.is_prelude && loaded.sources.name(m.file) == p),
            None => loaded.modules.iter().position(|m| !m.is_prelude),
        }
        .unwrap_or(0);
        let (program, _) = check::check(loaded);
        let line_indexes = (0..program.loaded.sources.len()).map(|_| OnceCell::new()).collect();
        Analysis { program, root, line_indexes }
    }

    /// The LSP range of a span, in its own file.
    pub fn range(&self, span: Span) -> lsp_types::Range {
        let text = self.text(span.file);
        let index = match self.line_indexes.get(span.file.0 as usize) {
            Some(cell) => cell.get_or_init(|| LineIndex::new(text)),
            None => &LineIndex::new(text),
        };
        index.range(text, span.start as usize, span.end as usize)
    }

    pub fn module(&self) -> &Module {
        &self.program.loaded.modules[self.root]
    }

    pub fn file(&self) -> FileId {
        self.module().file
    }

    pub fn text(&self, file: FileId) -> &str {
        self.program.loaded.sources.text(file)
    }

    /// The module a file belongs to.
    pub fn module_of(&self, file: FileId) -> Option<&Module> {
        self.program.loaded.modules.iter().find(|m| m.file == file)
    }

    pub fn item(&self, sym: Symbol) -> Option<&Item> {
        self.program.loaded.modules.get(sym.module)?.ast.items.get(sym.item)
    }

    /// A global name as the document sees it.
    pub fn symbol(&self, name: &str) -> Option<Symbol> {
        let table = if self.module().is_prelude { &self.program.prelude_symbols } else { &self.program.symbols };
        table.get(name).copied()
    }

    /// The symbol of item `item` of the document (its own definitions).
    pub fn own_symbol(&self, item: usize) -> Option<Symbol> {
        let (kind, name) = item_name(self.module().ast.items.get(item)?)?;
        Some(Symbol { kind, module: self.root, item, span: name.span })
    }

    /// The type checked for an expression, if any.
    pub fn type_of(&self, span: Span) -> Option<&Ty> {
        self.program.expr_types.get(&span).filter(|t| !t.is_error())
    }

    /// The source text of a span.
    pub fn snippet(&self, span: Span) -> &str {
        self.text(span.file).get(span.range()).unwrap_or("")
    }
}

/// An item's symbol kind and name, for items that define a global name.
pub fn item_name(item: &Item) -> Option<(SymbolKind, &Ident)> {
    Some(match item {
        Item::Function(f) => (SymbolKind::Function, &f.name),
        Item::Material(d) => (SymbolKind::Material, &d.name),
        Item::MaterialTree(t) => (SymbolKind::MaterialTree, &t.name),
        Item::Const(c) => (SymbolKind::Const, &c.name),
        Item::Import { .. } | Item::Scene(_) => return None,
    })
}

/// What is under a position in the document's syntax tree.
#[derive(Clone, Copy)]
pub enum Node<'a> {
    /// The name of a top-level definition: its index and the name's span.
    ItemName(usize, Span),
    /// A method's name in a material definition.
    MethodName(&'a Function),
    /// A parameter's name.
    Param(&'a Param),
    /// A local variable's name where it is declared (`None`: a loop variable, an `int`).
    LocalDecl(&'a Ident, Option<&'a TypeExpr>),
    /// A name used as a value.
    Name(&'a Expr, &'a str),
    /// The function or material a call names.
    Callee(&'a Ident),
    /// `name:` of a named argument, and the call's callee.
    ArgName(&'a Ident, &'a Ident),
    /// A field read, `base.field`.
    Field(&'a Expr, &'a Ident),
    /// A type keyword used as a constructor: `vector(...)`.
    Construct(BaseType, Span),
    /// Any other expression.
    Expr(&'a Expr),
    /// `import "path";`
    Import(&'a str, Span),
    /// A scene block's keyword or kind.
    SceneBlock(&'a SceneBlock),
    /// A scene property's name, in its block (`None`: the scene's own).
    SceneProp(Option<&'a SceneBlock>, &'a SceneProp),
}

fn covers(span: Span, offset: usize) -> bool {
    (span.start as usize) <= offset && offset <= span.end as usize
}

/// The innermost node of `module` at byte `offset`.
pub fn node_at(module: &Module, offset: usize) -> Option<Node<'_>> {
    module.ast.items.iter().enumerate().find_map(|(i, item)| in_item(i, item, offset))
}

fn in_item(index: usize, item: &Item, at: usize) -> Option<Node<'_>> {
    match item {
        Item::Import { path, span } => covers(*span, at).then_some(Node::Import(path, *span)),
        Item::Function(f) => {
            if covers(f.name.span, at) {
                return Some(Node::ItemName(index, item_name(item).map_or(Span::default(), |n| n.1.span)));
            }
            in_function(f, at)
        }
        Item::Material(d) => {
            if covers(d.name.span, at) {
                return Some(Node::ItemName(index, item_name(item).map_or(Span::default(), |n| n.1.span)));
            }
            in_params(&d.params, at).or_else(|| {
                d.methods
                    .iter()
                    .find_map(|m| if covers(m.name.span, at) { Some(Node::MethodName(m)) } else { in_function(m, at) })
            })
        }
        Item::MaterialTree(t) => {
            if covers(t.name.span, at) {
                return Some(Node::ItemName(index, item_name(item).map_or(Span::default(), |n| n.1.span)));
            }
            t.params.as_deref().and_then(|ps| in_params(ps, at)).or_else(|| in_expr(&t.body, at))
        }
        Item::Const(c) => {
            if covers(c.name.span, at) {
                return Some(Node::ItemName(index, item_name(item).map_or(Span::default(), |n| n.1.span)));
            }
            in_expr(&c.value, at)
        }
        Item::Scene(s) => s.entries.iter().find_map(|entry| match entry {
            SceneEntry::Block(b) => {
                if covers(b.keyword.span, at) || b.kind.as_ref().is_some_and(|k| covers(k.span, at)) {
                    return Some(Node::SceneBlock(b));
                }
                b.props.iter().find_map(|p| in_prop(Some(b), p, at))
            }
            SceneEntry::Prop(p) => in_prop(None, p, at),
        }),
    }
}

fn in_prop<'a>(block: Option<&'a SceneBlock>, p: &'a SceneProp, at: usize) -> Option<Node<'a>> {
    if covers(p.name.span, at) {
        return Some(Node::SceneProp(block, p));
    }
    p.value.as_ref().and_then(|v| in_expr(v, at))
}

fn in_params(params: &[Param], at: usize) -> Option<Node<'_>> {
    params.iter().find_map(|p| {
        if covers(p.name.span, at) {
            return Some(Node::Param(p));
        }
        p.default.as_ref().and_then(|d| in_expr(d, at))
    })
}

fn in_function(f: &Function, at: usize) -> Option<Node<'_>> {
    in_params(&f.params, at).or_else(|| in_block(&f.body, at))
}

fn in_block(b: &Block, at: usize) -> Option<Node<'_>> {
    if !covers(b.span, at) {
        return None;
    }
    b.stmts.iter().find_map(|s| in_stmt(s, at))
}

fn in_stmt(s: &Stmt, at: usize) -> Option<Node<'_>> {
    if !covers(s.span, at) {
        return None;
    }
    match &s.kind {
        StmtKind::Let { ty, name, init } => {
            if covers(name.span, at) {
                return Some(Node::LocalDecl(name, Some(ty)));
            }
            init.as_ref().and_then(|e| in_expr(e, at))
        }
        StmtKind::Assign { target, value, .. } => in_expr(target, at).or_else(|| in_expr(value, at)),
        StmtKind::Expr(e) => in_expr(e, at),
        StmtKind::If { cond, then_block, else_branch } => in_expr(cond, at)
            .or_else(|| in_block(then_block, at))
            .or_else(|| else_branch.as_ref().and_then(|e| in_stmt(e, at))),
        StmtKind::For { var, start, end, body } => {
            if covers(var.span, at) {
                return Some(Node::LocalDecl(var, None));
            }
            in_expr(start, at).or_else(|| in_expr(end, at)).or_else(|| in_block(body, at))
        }
        StmtKind::While { cond, body } => in_expr(cond, at).or_else(|| in_block(body, at)),
        StmtKind::Return(e) => e.as_ref().and_then(|e| in_expr(e, at)),
        StmtKind::Block(b) => in_block(b, at),
        StmtKind::Break | StmtKind::Continue => None,
    }
}

fn in_args<'a>(callee: Option<&'a Ident>, args: &'a [Arg], at: usize) -> Option<Node<'a>> {
    args.iter().find_map(|a| match (&a.name, callee) {
        (Some(name), Some(callee)) if covers(name.span, at) => Some(Node::ArgName(name, callee)),
        _ => in_expr(&a.value, at),
    })
}

fn in_expr(e: &Expr, at: usize) -> Option<Node<'_>> {
    if !covers(e.span, at) {
        return None;
    }
    with_stack(|| {
        let inner = match &e.kind {
            ExprKind::Int(_) | ExprKind::Float(_) | ExprKind::Bool(_) | ExprKind::Str(_) => None,
            ExprKind::Name(n) => return Some(Node::Name(e, n)),
            ExprKind::Call { callee, args } => {
                if covers(callee.span, at) {
                    return Some(Node::Callee(callee));
                }
                in_args(Some(callee), args, at)
            }
            ExprKind::Construct { ty, ty_span, args } => {
                if covers(*ty_span, at) {
                    return Some(Node::Construct(*ty, *ty_span));
                }
                in_args(None, args, at)
            }
            ExprKind::Member { base, field } => {
                if covers(field.span, at) {
                    return Some(Node::Field(e, field));
                }
                in_expr(base, at)
            }
            ExprKind::Index { base, index } => in_expr(base, at).or_else(|| in_expr(index, at)),
            ExprKind::Unary { operand, .. } => in_expr(operand, at),
            ExprKind::Binary { lhs, rhs, .. } => in_expr(lhs, at).or_else(|| in_expr(rhs, at)),
            ExprKind::Ternary { cond, then_expr, else_expr } => {
                in_expr(cond, at).or_else(|| in_expr(then_expr, at)).or_else(|| in_expr(else_expr, at))
            }
            ExprKind::Array(items) | ExprKind::Tuple(items) => items.iter().find_map(|i| in_expr(i, at)),
        };
        Some(inner.unwrap_or(Node::Expr(e)))
    })
}

/// What a node refers to.
#[derive(Debug, Clone, Copy)]
pub enum Target {
    /// A global definition: function, material, tree or constant.
    Item(Symbol),
    /// A local variable or parameter, by the span of its declared name.
    Local(Span),
    /// Parameter `index` of a definition (a named argument names it).
    Param(Symbol, usize),
    Builtin(BuiltinFn),
    /// Parameter `index` of a builtin.
    BuiltinParam(BuiltinFn, usize),
    /// A shading global (`P`, `N`, ...).
    Global(&'static str),
    /// An interface method (a method's name, or a call of a sibling method).
    Method(&'static InterfaceMethod),
}

impl Analysis {
    /// What `node` refers to, by the checker's resolutions where it made
    /// them, else by name as the document sees it.
    pub fn target(&self, node: Node<'_>) -> Option<Target> {
        let p = &self.program;
        match node {
            Node::ItemName(i, _) => self.own_symbol(i).map(Target::Item),
            Node::MethodName(m) => interface_method(&m.name.name).map(Target::Method),
            Node::Param(param) => Some(Target::Local(param.name.span)),
            Node::LocalDecl(name, _) => Some(Target::Local(name.span)),
            Node::Name(e, name) => {
                if let Some(decl) = p.local_uses.get(&e.span) {
                    return Some(Target::Local(*decl));
                }
                if let Some(sym) = p.resolutions.get(&e.span) {
                    return Some(Target::Item(*sym));
                }
                if let Some(g) = check::GLOBALS.iter().find(|g| g.0 == name) {
                    return Some(Target::Global(g.0));
                }
                self.symbol(name).map(Target::Item)
            }
            Node::Callee(callee) => self.callee_target(callee),
            Node::ArgName(name, callee) => match self.callee_target(callee)? {
                Target::Item(sym) => {
                    let params = item_params(self.item(sym)?)?;
                    params.iter().position(|q| q.name.name == name.name).map(|k| Target::Param(sym, k))
                }
                Target::Builtin(f) => {
                    f.builtin().params.iter().position(|q| q.name == name.name).map(|k| Target::BuiltinParam(f, k))
                }
                _ => None,
            },
            Node::Field(..) | Node::Construct(..) | Node::Expr(_) | Node::Import(..) => None,
            Node::SceneBlock(_) | Node::SceneProp(..) => None,
        }
    }

    fn callee_target(&self, callee: &Ident) -> Option<Target> {
        let p = &self.program;
        if let Some(sym) = p.resolutions.get(&callee.span) {
            return Some(Target::Item(*sym));
        }
        if let Some(f) = p.builtin_calls.get(&callee.span) {
            return Some(Target::Builtin(*f));
        }
        if self.in_material(callee.span)
            && let Some(m) = interface_method(&callee.name)
        {
            return Some(Target::Method(m));
        }
        if let Some(sym) = self.symbol(&callee.name) {
            return Some(Target::Item(sym));
        }
        check::BUILTINS.iter().find(|b| b.name == callee.name).map(|b| Target::Builtin(b.func))
    }

    /// Whether a span of the document is inside a material definition.
    fn in_material(&self, span: Span) -> bool {
        self.module()
            .ast
            .items
            .iter()
            .any(|i| matches!(i, Item::Material(d) if d.span.start <= span.start && span.end <= d.span.end))
    }

    /// Where a target is defined, when it is written in a source.
    pub fn definition(&self, target: Target) -> Option<Span> {
        match target {
            Target::Item(sym) => Some(sym.span),
            Target::Local(span) => Some(span),
            Target::Param(sym, k) => Some(item_params(self.item(sym)?)?.get(k)?.name.span),
            Target::Builtin(_) | Target::BuiltinParam(..) | Target::Global(_) | Target::Method(_) => None,
        }
    }

    /// Every use of a target in the program (its own files, imports and
    /// the prelude), in source order, with its definition when asked.
    pub fn references(&self, target: Target, with_definition: bool) -> Vec<Span> {
        let p = &self.program;
        let mut spans: Vec<Span> = match target {
            Target::Item(sym) => p
                .resolutions
                .iter()
                .filter(|(_, s)| s.module == sym.module && s.item == sym.item)
                .map(|(span, _)| *span)
                .collect(),
            Target::Local(decl) => p.local_uses.iter().filter(|(_, d)| **d == decl).map(|(span, _)| *span).collect(),
            Target::Builtin(f) => p.builtin_calls.iter().filter(|(_, g)| **g == f).map(|(span, _)| *span).collect(),
            Target::Param(..) | Target::BuiltinParam(..) | Target::Global(_) | Target::Method(_) => Vec::new(),
        };
        if with_definition && let Some(def) = self.definition(target) {
            spans.push(def);
        }
        spans.sort_by_key(|s| (s.file, s.start));
        spans.dedup();
        spans
    }

    /// The declared type and kind of a local, found by its name's span.
    pub fn local_decl(&self, decl: Span) -> Option<(String, &'static str)> {
        let module = self.module();
        match node_at(module, decl.start as usize)? {
            Node::Param(p) if p.name.span == decl => Some((type_text(&p.ty), "parameter")),
            Node::LocalDecl(name, Some(ty)) if name.span == decl => Some((type_text(ty), "local variable")),
            Node::LocalDecl(name, None) if name.span == decl => Some(("int".into(), "loop variable")),
            _ => None,
        }
    }
}

/// The parameters of a definition that takes arguments.
pub fn item_params(item: &Item) -> Option<&[Param]> {
    match item {
        Item::Function(f) => Some(&f.params),
        Item::Material(d) => Some(&d.params),
        Item::MaterialTree(t) => t.params.as_deref(),
        _ => None,
    }
}

/// A type as written: `float`, `vec2[8]`.
pub fn type_text(t: &TypeExpr) -> String {
    match t.array_len {
        Some((n, _)) => format!("{}[{n}]", t.base.keyword()),
        None => t.base.keyword().to_string(),
    }
}

impl Analysis {
    /// A parameter as written: `int octaves = 6`.
    pub fn param_text(&self, p: &Param) -> String {
        match &p.default {
            Some(d) => format!("{} {} = {}", type_text(&p.ty), p.name.name, self.snippet(d.span)),
            None => format!("{} {}", type_text(&p.ty), p.name.name),
        }
    }

    /// The signature of a definition as written:
    /// `float fbm(point p, int octaves = 6, ...)`, `material phong(...)`,
    /// `material wood = ...`, `const float PI = 3.14159265358979`.
    pub fn signature(&self, sym: Symbol) -> Option<String> {
        let params = |ps: &[Param]| ps.iter().map(|p| self.param_text(p)).collect::<Vec<_>>().join(", ");
        Some(match self.item(sym)? {
            Item::Function(f) => format!("{} {}({})", type_text(&f.ret), f.name.name, params(&f.params)),
            Item::Material(d) => format!("material {}({})", d.name.name, params(&d.params)),
            Item::MaterialTree(t) => {
                let body = one_line(self.snippet(t.body.span), 80);
                match &t.params {
                    Some(ps) => format!("material {}({}) = {body}", t.name.name, params(ps)),
                    None => format!("material {} = {body}", t.name.name),
                }
            }
            Item::Const(c) => {
                format!("const {} {} = {}", type_text(&c.ty), c.name.name, one_line(self.snippet(c.value.span), 80))
            }
            Item::Import { .. } | Item::Scene(_) => return None,
        })
    }

    /// The file a definition is in, as shown to people (`stdlib/materials.tsl`).
    /// A definition's file as shown: `stdlib/x.tsl` for the prelude, an
    /// import relative to the document's directory when it is under it.
    pub fn file_name(&self, span: Span) -> String {
        let sources = &self.program.loaded.sources;
        let name = std::path::Path::new(sources.name(span.file));
        let dir = std::path::Path::new(sources.name(self.file())).parent();
        dir.and_then(|d| name.strip_prefix(d).ok())
            .filter(|rest| !rest.as_os_str().is_empty())
            .unwrap_or(name)
            .display()
            .to_string()
    }

    /// The documentation of a definition: its entry in a stdlib file's doc
    /// block, else its `///` doc comment, else the comments right above it.
    pub fn doc(&self, sym: Symbol) -> Option<String> {
        let module = self.program.loaded.modules.get(sym.module)?;
        let text = self.text(module.file);
        let name = self.snippet(sym.span);
        let from_header = if module.is_prelude { super::docs::stdlib_doc(text, name) } else { None };
        let start = item_start(self.item(sym)?)?;
        from_header
            .or_else(|| crate::syntax::doc_comment(text, start))
            .or_else(|| super::docs::comment_above(text, start))
    }

    /// A parameter's own `///` doc comment.
    pub fn param_doc(&self, param: &Param) -> Option<String> {
        crate::syntax::doc_comment(self.text(param.span.file), param.span.start as usize)
    }
}

/// Where an item's text starts (its type or keyword).
fn item_start(item: &Item) -> Option<usize> {
    Some(match item {
        Item::Function(f) => f.span.start,
        Item::Material(d) => d.span.start,
        Item::MaterialTree(t) => t.span.start,
        Item::Const(c) => c.span.start,
        Item::Import { .. } | Item::Scene(_) => return None,
    } as usize)
}

/// Text on one line, shortened to `max` characters with an ellipsis.
/// Reads no more of `text` than it shows (a value may be megabytes).
pub fn one_line(text: &str, max: usize) -> String {
    let mut flat = text
        .split_whitespace()
        .enumerate()
        .flat_map(|(k, word)| (k > 0).then_some(' ').into_iter().chain(word.chars()));
    let shown: String = flat.by_ref().take(max).collect();
    if flat.next().is_some() { format!("{shown} ...") } else { shown }
}
