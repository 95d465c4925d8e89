//! Names, types, the material interface and the generic-color rules.
//!
//! `check` takes a loaded program and returns a [`Program`] (the syntax trees
//! plus a type for every expression) and all diagnostics. It never stops at
//! the first error: an ill-typed expression gets [`Ty::Error`], which
//! converts silently to every type, so each mistake is reported once.
//!
//! The checker's state and driver live here; its parts are `items`
//! (functions, materials, trees, constants), `stmt`, `expr`, `calls`
//! (arguments, builtins, options) and `cycles` (recursion and varying
//! constants), beside the tables of `builtins`, `interface` and `scene`.
//!
//! Architecture invariant: checking does no I/O and knows nothing of code
//! generation. A program without error diagnostics is well typed, recursion
//! free (shade trees are DAGs) and has only bounded loops.

mod builtins;
mod calls;
mod cycles;
mod expr;
mod inline_size;
mod instance;
mod interface;
mod items;
mod scene;
mod span_map;
mod stmt;
mod ty;
mod types;

pub use builtins::{BUILTINS, Builtin, BuiltinFn, BuiltinParam, NormalMapConvention, TreeNode, builtin};
pub use instance::{CheckedExpr, check_material_expr};
pub use interface::{FRAME_GLOBALS, GLOBALS, INTERFACE, InterfaceMethod, Method, interface_method};
pub use scene::{SceneProperty, scene_blocks, scene_kinds, scene_properties};
pub use span_map::{SpanMap, SpanSlice};
pub use ty::{SAMPLE_FIELDS, Ty};
pub use types::{ExprTypes, ExprTypesWithin};

use crate::diag::{Diagnostic, Span, did_you_mean};
use crate::load::Loaded;
use crate::syntax::ast::*;
use crate::texture::{Encoding, Filter, TextureImage, Wrap};
use builtins::{ArgError, elementwise, type_builtin, unify};
use rustc_hash::FxHashMap;
use std::collections::HashMap;

/// The most elements an array may have.
pub const MAX_ARRAY_LEN: u32 = 4096;

/// The most material definitions (`lambert(...)`, `mirror`, ...) one
/// material may hold once its tree is inlined: 256, sixteen times the
/// largest example (texture_tree's `cube` holds 16). Children that are the
/// same material count once; other children each count, so a tree that
/// uses the previous one in two different children at every level doubles
/// per level. `tslc check` counts without compiling, so such a tree is
/// refused before a compile would take minutes and gigabytes (a tree of
/// 610 took 1 s and 600 MB to compile; each definition inlined costs about
/// 200 IR instructions in `sample` alone).
pub const MAX_INLINED_MATERIALS: u64 = 256;

/// The most iterations one `for` loop runs: the IR's limit, which the
/// checker reports when constant bounds exceed it.
pub use crate::ir::{MAX_CALL_ITERATIONS, MAX_LOOP_ITERATIONS};

/// A checked program: the loaded modules, the global symbols and the type of
/// every expression, keyed by its span.
#[derive(Debug, Clone, Default)]
pub struct Program {
    pub loaded: Loaded,
    /// The global items user code sees, by name. FxHash, not SipHash: every
    /// name in the program is looked up here, several times.
    pub symbols: FxHashMap<String, Symbol>,
    /// The prelude's own names: prelude code resolves against these, so a
    /// user definition that shadows a prelude name does not change the
    /// prelude's behaviour.
    pub prelude_symbols: FxHashMap<String, Symbol>,
    pub expr_types: ExprTypes,
    /// The global item each name or call resolved to, keyed by its span.
    pub resolutions: SpanMap<Symbol>,
    /// The local variable or parameter each name resolved to: the span of
    /// the use to the span of the declared name (for editors).
    pub local_uses: FxHashMap<Span, Span>,
    /// The builtin each call to one resolved to, keyed by the callee's span
    /// (a user function of the same name is an error, so names alone would
    /// do; the lowering matches on the enum instead of on strings).
    pub builtin_calls: HashMap<Span, BuiltinFn>,
    /// The images `texture` calls name, each once per file and encoding.
    pub images: Vec<ImageUse>,
    /// Every `texture` / `texture_float` / `texture_vector` call, keyed by
    /// its span.
    pub texture_calls: HashMap<Span, TextureCall>,
}

/// An image named by a `texture` call. Checking records the path as
/// written; the front end then resolves and loads it (`image`): a path
/// with the `<UDIM>` token becomes a tile set, its tiles listed but not
/// read.
#[derive(Debug, Clone)]
pub struct ImageUse {
    /// The string literal naming the file.
    pub span: Span,
    pub path: String,
    pub encoding: Encoding,
    /// The loaded pyramid (or tile set), once the front end has found it.
    pub image: Option<TextureImage>,
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
// u32 indices: one of these is in each object of a scene's description
// (a source file is at most 256 MiB, so its indices fit).
pub enum MaterialRef {
    /// The body of material tree `item` of `module`.
    TreeBody { module: u32, item: u32 },
    /// The value of property `prop` of block `entry` of the scene that is
    /// item `item` of `module` (a scene object's `material`).
    SceneValue { module: u32, item: u32, entry: u32, prop: u32 },
}

impl Program {
    /// The expression `r` names, if it names one of this program.
    pub fn material_expr(&self, r: MaterialRef) -> Option<&Expr> {
        match r {
            MaterialRef::TreeBody { module, item } => {
                match self.loaded.modules.get(module as usize)?.ast.items.get(item as usize)? {
                    Item::MaterialTree(t) => Some(&t.body),
                    _ => None,
                }
            }
            MaterialRef::SceneValue { module, item, entry, prop } => {
                match self.loaded.modules.get(module as usize)?.ast.items.get(item as usize)? {
                    Item::Scene(scene) => match scene.entries.get(entry as usize)? {
                        SceneEntry::Block(b) => b.props.get(prop as usize)?.value.as_ref(),
                        SceneEntry::Prop(_) => None,
                    },
                    _ => None,
                }
            }
        }
    }
}

impl Program {
    /// Forgets the type and the resolution of every expression inside one
    /// of `spans` (in span order, none inside another): what a one-shot
    /// tool drops once nothing will read them (see
    /// [`scene::forgettable_spans`](crate::scene::forgettable_spans)).
    pub fn forget_exprs(&mut self, spans: &[Span]) {
        if spans.is_empty() {
            return;
        }
        // Both tables are in span order: one pass each, moving along `spans`.
        fn inside(spans: &[Span]) -> impl FnMut(&Span) -> bool + '_ {
            let mut at = 0;
            move |s: &Span| {
                let before = |a: &Span| a.file.0 < s.file.0 || (a.file == s.file && a.end <= s.start);
                while at < spans.len() && before(&spans[at]) {
                    at += 1;
                }
                spans.get(at).is_some_and(|a| a.file == s.file && a.start <= s.start && s.end <= a.end)
            }
        }
        let mut drop = inside(spans);
        self.expr_types.retain(|s| !drop(s));
        let mut drop = inside(spans);
        self.resolutions.retain(|s| !drop(s));
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
        resolutions: SpanMap::default(),
        local_uses: FxHashMap::default(),
        reads_globals: FxHashMap::default(),
        reads_frame: FxHashMap::default(),
        frame_limits: FxHashMap::default(),
        diags: &mut diags,
        expr_types: ExprTypes::default(),
        graph: FxHashMap::default(),
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
    checker.report_varying_values();
    let mut expr_types = std::mem::take(&mut checker.expr_types);
    expr_types.finish();
    let mut resolutions = std::mem::take(&mut checker.resolutions);
    resolutions.finish();
    let local_uses = std::mem::take(&mut checker.local_uses);
    let images = std::mem::take(&mut checker.images);
    let texture_calls = std::mem::take(&mut checker.texture_calls);
    let builtin_calls = std::mem::take(&mut checker.builtin_calls);
    let program = Program {
        loaded,
        symbols,
        prelude_symbols,
        expr_types,
        resolutions,
        local_uses,
        builtin_calls,
        images,
        texture_calls,
    };
    // Counting needs a well-formed program (no cycle among trees).
    if !diags.iter().any(Diagnostic::is_error) {
        inline_size::report_inline_sizes(&program, &mut diags);
    }
    (program, diags)
}

type Symbols = FxHashMap<String, Symbol>;

/// Builds the global namespaces: the one user code sees (user items shadow
/// prelude items of the same name) and the prelude's own. Two definitions in
/// the same layer are an error.
fn collect_symbols(loaded: &Loaded, diags: &mut Vec<Diagnostic>) -> (Symbols, Symbols) {
    let mut symbols = Symbols::default();
    let mut prelude = Symbols::default();
    let mut from_prelude: FxHashMap<&str, bool> = FxHashMap::default();
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
            if let Some((_, _, meaning)) = GLOBALS.iter().find(|g| g.0 == name.name) {
                diags.push(
                    Diagnostic::error(
                        name.span,
                        format!("`{}` is a shading global and cannot be redefined", name.name),
                    )
                    .with_note(format!("`{}` is {meaning}", name.name))
                    .with_help("choose another name"),
                );
                continue;
            }
            let symbol = Symbol { kind, module: m, item: i, span: name.span };
            match symbols.get(name.name.as_str()) {
                Some(_) if from_prelude[name.name.as_str()] && !module.is_prelude => {
                    // A user definition shadows the prelude's.
                    symbols.insert(name.name.as_str().to_owned(), symbol);
                    from_prelude.insert(name.name.as_str(), false);
                }
                Some(prev) => {
                    diags.push(
                        Diagnostic::error(name.span, format!("`{}` is defined more than once", name.name))
                            .with_primary(format!("{} redefined here", kind.describe()))
                            .with_label(prev.span, format!("first defined here as a {}", prev.kind.describe())),
                    );
                }
                None => {
                    // Not `to_string`, which formats: 100,000 names cost.
                    symbols.insert(name.name.as_str().to_owned(), symbol);
                    from_prelude.insert(name.name.as_str(), module.is_prelude);
                }
            }
            if module.is_prelude {
                prelude.entry(name.name.as_str().to_owned()).or_insert(symbol);
            }
        }
    }
    (symbols, prelude)
}

/// Where an item is: (module, item index).
type ItemId = (usize, usize);

/// A node of the dependency graph: a global item, or a method of a
/// material. Nodes name items by position, since a user item and the
/// prelude item it shadows share a name; they hold no text of the user's,
/// so a graph of 100,000 constants allocates no string per edge and its
/// hashes are not the user's to choose ([`Checker::describe`] names them).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
enum Node {
    Item(ItemId),
    /// A material's interface method.
    Method(ItemId, &'static str),
    /// A value of the scene (item `ItemId`): its entry (block or top-level
    /// property), the block's name and the property's.
    SceneValue(ItemId, usize, &'static str, &'static str),
}

impl Node {
    fn id(&self) -> ItemId {
        match self {
            Node::Item(id) | Node::Method(id, _) | Node::SceneValue(id, ..) => *id,
        }
    }
}

/// A node's dependencies, each once, in the order of first use (with the
/// span of that use).
#[derive(Debug, Default)]
struct Edges {
    list: Vec<(Node, Span)>,
    /// The targets, once there are many (a constant summing thousands of
    /// others): a repeated use is then found without a scan.
    index: Option<rustc_hash::FxHashSet<Node>>,
}

impl Edges {
    /// Lists past this many targets are indexed.
    const SCANNED: usize = 16;

    fn add(&mut self, to: Node, span: Span) {
        let known = match &mut self.index {
            Some(index) => !index.insert(to),
            None => self.list.iter().any(|(n, _)| *n == to),
        };
        if known {
            return;
        }
        self.list.push((to, span));
        if self.index.is_none() && self.list.len() > Self::SCANNED {
            self.index = Some(self.list.iter().map(|(n, _)| *n).collect());
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
    /// The most iterations the enclosing loops can run together per call
    /// (1 outside loops), and whether a warning about them was given.
    loop_work: i64,
    loop_warned: bool,
    /// Inside a material definition: its name and the methods it defines.
    material: Option<(String, Vec<&'static str>)>,
    globals_allowed: bool,
    /// Which of the frame globals (`frame`, `time`) may be read.
    frame_globals: FrameGlobals,
    /// In the scene: the entry being checked and its name (`camera`), so
    /// each value is a node of the dependency graph.
    scene_entry: Option<(usize, &'static str)>,
    /// Whether material values may appear (material trees only).
    materials_allowed: bool,
    /// What is being checked, for messages: "a function", "a constant", ...
    context: &'static str,
    node: Option<Node>,
}

/// Where the frame globals may be read. They are the same at every point
/// of a frame, so shading code, constants and scene values may read them;
/// render settings hold for every frame and may not, except the `time`
/// mapping, which reads `frame`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
enum FrameGlobals {
    #[default]
    Both,
    FrameOnly,
    Neither,
}

struct Checker<'a> {
    loaded: &'a Loaded,
    symbols: &'a Symbols,
    prelude_symbols: &'a Symbols,
    /// Whether the item being checked is prelude code.
    in_prelude: bool,
    /// The item being checked.
    current: ItemId,
    resolutions: SpanMap<Symbol>,
    /// Name uses that are locals, to their declarations.
    local_uses: FxHashMap<Span, Span>,
    /// Items whose own code reads a shading global, with the first use.
    reads_globals: FxHashMap<Node, Span>,
    /// Items and scene values whose own code reads `frame` or `time`, by
    /// the global's name, with the first read and that name.
    reads_frame: FxHashMap<(Node, &'static str), (Span, &'static str)>,
    /// Scene values that may not depend on (all of) the frame globals: the
    /// render settings.
    frame_limits: FxHashMap<Node, FrameGlobals>,
    diags: &'a mut Vec<Diagnostic>,
    expr_types: ExprTypes,
    /// Dependencies between items, with the span of the first use.
    graph: FxHashMap<Node, Edges>,
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

    /// `node` for messages: `` `wood` ``, `` `phong.reflection` ``,
    /// `` `camera.fov` ``.
    fn describe(&self, node: &Node) -> String {
        let item_name = |(m, i): ItemId| match &self.loaded.modules[m].ast.items[i] {
            Item::Function(f) => f.name.name.to_string(),
            Item::Material(d) => d.name.name.to_string(),
            Item::MaterialTree(t) => t.name.name.to_string(),
            Item::Const(c) => c.name.name.to_string(),
            Item::Import { .. } | Item::Scene(_) => String::new(),
        };
        match *node {
            Node::Item(id) => format!("`{}`", item_name(id)),
            Node::Method(id, method) => format!("`{}.{method}`", item_name(id)),
            Node::SceneValue(_, _, block, property) => format!("`{block}.{property}`"),
        }
    }

    fn check_items(&mut self) {
        let loaded = self.loaded;
        let mut scenes: Vec<(ItemId, &Scene)> = Vec::new();
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
                            scenes.push(((m, i), s));
                        }
                    }
                }
            }
        }
        for (_, extra) in scenes.iter().skip(1) {
            self.error(
                Diagnostic::error(Span { end: extra.span.start + 5, ..extra.span }, "a program has at most one scene")
                    .with_label(
                        Span { end: scenes[0].1.span.start + 5, ..scenes[0].1.span },
                        "the first scene is here",
                    ),
            );
        }
        for (id, s) in scenes {
            self.in_prelude = false;
            self.current = id;
            self.body = Body { context: "the scene", ..Body::default() };
            scene::check_scene(self, s);
        }
    }
}

fn required_params(params: &[Param]) -> Vec<String> {
    params.iter().filter(|p| p.default.is_none()).map(|p| p.name.name.to_string()).collect()
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
