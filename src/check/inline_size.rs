//! How large a material is once inlined: the number of material
//! definitions (`lambert(...)`, `mirror`, ...) its code holds, counted
//! without building any code, so `tslc check` refuses a tree that would
//! take minutes and gigabytes to compile.
//!
//! Lowering (`ir::lower`) inlines a whole tree into each method. A node's
//! children that are the same material (`mix(t, m, m)`, `blend(t, [m, m])`,
//! by name or through a template parameter) are compiled once; other
//! children are compiled each on its own, since `sample` draws each in its
//! own branch. So a material's size is the sum over its distinct children,
//! and a tree that uses the previous one twice in different children (or
//! under `transform` or `bump`) doubles at every level. Counting follows
//! that rule exactly, each named tree once (memoised, deepest first), each
//! template once per distinct binding of its material parameters; counts
//! saturate instead of overflowing.

use super::{MAX_INLINED_MATERIALS, Program, SymbolKind, TreeNode};
use crate::diag::{Diagnostic, Span};
use crate::syntax::ast::{Arg, Expr, ExprKind, Item, MaterialTree, SceneEntry};
use rustc_hash::FxHashMap;
use std::cell::RefCell;

/// Where an item is: (module, item index).
type ItemId = (usize, usize);

/// What a template's material parameter is bound to: one material (its
/// identity, when it is a plain name, and its size), or the items of a
/// `material[N]` argument.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
enum Bound {
    One(Option<ItemId>, u64),
    Many(Vec<(Option<ItemId>, u64)>),
}

type Env = FxHashMap<String, Bound>;

struct Sizes<'a> {
    program: &'a Program,
    /// Named trees without parameters, by item.
    trees: FxHashMap<ItemId, u64>,
    /// Template calls, by template and the bindings of its material
    /// parameters (in parameter order).
    templates: FxHashMap<(ItemId, Vec<Option<Bound>>), u64>,
}

/// Reports every named material tree, and every material of the root
/// scene that is not a plain name, that inlines more than
/// [`MAX_INLINED_MATERIALS`] material definitions. A tree built on one
/// that is reported is not reported again. Run on a program without
/// errors.
pub(super) fn report_inline_sizes(program: &Program, diags: &mut Vec<Diagnostic>) {
    let mut sizes = Sizes { program, trees: FxHashMap::default(), templates: FxHashMap::default() };
    // The trees over the bound; only those built on none are reported.
    let mut over: rustc_hash::FxHashSet<ItemId> = Default::default();
    for id in sizes.trees_deepest_first() {
        let Some(tree) = sizes.tree_item(id) else { continue };
        if sizes.tree(id) <= MAX_INLINED_MATERIALS {
            continue;
        }
        if !sizes.named_in(&tree.body).iter().any(|n| over.contains(n)) {
            let what = format!("material `{}`", tree.name.name);
            diags.push(too_large_diagnostic(tree.name.span, &what, sizes.tree(id)));
        }
        over.insert(id);
    }
    for (expr, span) in sizes.scene_materials() {
        let size = sizes.count(expr, &Env::default());
        if size > MAX_INLINED_MATERIALS && !sizes.named_in(expr).iter().any(|n| over.contains(n)) {
            diags.push(too_large_diagnostic(span, "this material", size));
        }
    }
}

fn too_large_diagnostic(at: Span, what: &str, size: u64) -> Diagnostic {
    // Counts saturate: 2^64 - 1 stands for anything larger.
    let size = if size == u64::MAX { "more than 10^19".to_string() } else { size.to_string() };
    Diagnostic::error(at, format!("{what} is too large to compile"))
        .with_primary(format!("inlined, it holds {size} material definitions; the most is {MAX_INLINED_MATERIALS}"))
        .with_note(
            "children that are the same material (`mix(t, m, m)`) are compiled once; other children each \
             on their own, so a tree that uses the previous one in two different children (or under \
             `transform` or `bump`) doubles at every level",
        )
        .with_help("use one material where the children may be the same, or build the tree with fewer levels")
}

impl<'a> Sizes<'a> {
    fn tree_item(&self, (m, i): ItemId) -> Option<&'a MaterialTree> {
        match self.program.loaded.modules.get(m)?.ast.items.get(i)? {
            Item::MaterialTree(t) if t.params.is_none() => Some(t),
            _ => None,
        }
    }

    /// The size of named tree `id`, computed once.
    fn tree(&mut self, id: ItemId) -> u64 {
        if let Some(size) = self.trees.get(&id) {
            return *size;
        }
        let size = match self.tree_item(id) {
            Some(t) => self.count(&t.body, &Env::default()),
            None => 0,
        };
        self.trees.insert(id, size);
        size
    }

    /// Every named tree without parameters of the program, each after the
    /// named trees its body uses (an iterative search, so a chain of
    /// 100,000 trees never recurses through more than one of them).
    fn trees_deepest_first(&self) -> Vec<ItemId> {
        let mut order = Vec::new();
        let mut seen: rustc_hash::FxHashSet<ItemId> = Default::default();
        for (m, module) in self.program.loaded.modules.iter().enumerate() {
            for i in 0..module.ast.items.len() {
                let Some(tree) = self.tree_item((m, i)) else { continue };
                if !seen.insert((m, i)) {
                    continue;
                }
                let mut stack: Vec<(ItemId, Vec<ItemId>)> = vec![((m, i), self.named_in(&tree.body))];
                while let Some((_, next)) = stack.last_mut() {
                    match next.pop() {
                        Some(dep) => {
                            if seen.insert(dep)
                                && let Some(t) = self.tree_item(dep)
                            {
                                let deps = self.named_in(&t.body);
                                stack.push((dep, deps));
                            }
                        }
                        None => {
                            if let Some((done, _)) = stack.pop() {
                                order.push(done);
                            }
                        }
                    }
                }
            }
        }
        order
    }

    /// The named trees without parameters `e` names.
    fn named_in(&self, e: &Expr) -> Vec<ItemId> {
        let found = RefCell::new(Vec::new());
        e.any(&|x: &Expr| {
            if let ExprKind::Name(_) = x.kind
                && let Some(sym) = self.program.resolutions.get(&x.span)
                && sym.kind == SymbolKind::MaterialTree
                && self.tree_item((sym.module, sym.item)).is_some()
            {
                found.borrow_mut().push((sym.module, sym.item));
            }
            false
        });
        found.into_inner()
    }

    /// The materials of the root scene's blocks that are not plain names,
    /// with their spans.
    fn scene_materials(&self) -> Vec<(&'a Expr, Span)> {
        let program = self.program;
        let mut out = Vec::new();
        let scene =
            program.loaded.modules.iter().filter(|m| !m.is_prelude).flat_map(|m| &m.ast.items).find_map(|item| {
                match item {
                    Item::Scene(s) => Some(s),
                    _ => None,
                }
            });
        for entry in scene.map(|s| s.entries.as_slice()).unwrap_or(&[]) {
            let SceneEntry::Block(block) = entry else { continue };
            // Only `material` takes a material; a plain name is counted
            // where the tree is defined.
            for prop in block.props.iter().filter(|p| p.name.name == "material") {
                if let Some(value) = &prop.value
                    && !matches!(value.kind, ExprKind::Name(_))
                    && program.expr_types.get(&value.span) == Some(&super::Ty::Material)
                {
                    out.push((value, value.span));
                }
            }
        }
        out
    }

    /// The number of material definitions material expression `e`
    /// inlines, with template parameters bound by `env`.
    fn count(&mut self, e: &Expr, env: &Env) -> u64 {
        crate::syntax::ast::with_stack(|| self.count_unguarded(e, env))
    }

    fn count_unguarded(&mut self, e: &Expr, env: &Env) -> u64 {
        match &e.kind {
            ExprKind::Name(n) => {
                if let Some(bound) = env.get(n.as_str()) {
                    return match bound {
                        Bound::One(_, size) => *size,
                        Bound::Many(items) => distinct_sum(items),
                    };
                }
                match self.program.resolutions.get(&e.span) {
                    Some(sym) if sym.kind == SymbolKind::Material => 1,
                    Some(sym) if sym.kind == SymbolKind::MaterialTree => self.tree((sym.module, sym.item)),
                    _ => 0,
                }
            }
            ExprKind::Ternary { then_expr, else_expr, .. } => {
                let items = [self.bound_one(then_expr, env), self.bound_one(else_expr, env)];
                distinct_sum(&items)
            }
            ExprKind::Index { base, .. } => match self.items(Some(base), env) {
                Some(items) => distinct_sum(&items),
                None => 0,
            },
            ExprKind::Call { callee, args } => {
                if let Some(sym) = self.program.resolutions.get(&callee.span).copied() {
                    return match sym.kind {
                        SymbolKind::Material => 1,
                        SymbolKind::MaterialTree => self.template((sym.module, sym.item), args, env),
                        _ => 0,
                    };
                }
                let node = self.program.builtin_calls.get(&callee.span).and_then(|f| f.tree_node());
                let Some(node) = node else { return 0 };
                let names: Vec<&str> = node.builtin().params.iter().map(|p| p.name).collect();
                let bound = bind(&names, args);
                let child = |k: usize| bound.get(k).copied().flatten();
                match node {
                    TreeNode::Mix => {
                        let items: Vec<_> =
                            [child(1), child(2)].into_iter().flatten().map(|c| self.bound_one(c, env)).collect();
                        distinct_sum(&items)
                    }
                    TreeNode::Blend | TreeNode::Select => match self.items(child(1), env) {
                        Some(items) => distinct_sum(&items),
                        None => 0,
                    },
                    TreeNode::Bump => child(2).map_or(0, |c| self.count(c, env)),
                    TreeNode::NormalMap => child(1).map_or(0, |c| self.count(c, env)),
                    TreeNode::Scale | TreeNode::Transform => child(1).map_or(0, |c| self.count(c, env)),
                    // Both children are lowered, even when they are the same material.
                    TreeNode::Layer => {
                        let (top, base) =
                            (child(0).map_or(0, |c| self.count(c, env)), child(1).map_or(0, |c| self.count(c, env)));
                        top.saturating_add(base)
                    }
                }
            }
            _ => 0,
        }
    }

    /// A material child: its identity and size.
    fn bound_one(&mut self, e: &Expr, env: &Env) -> (Option<ItemId>, u64) {
        (self.identity(e, env), self.count(e, env))
    }

    /// The materials of a `material[N]` value: an array literal, or such a
    /// template parameter passed on.
    fn items(&mut self, e: Option<&Expr>, env: &Env) -> Option<Vec<(Option<ItemId>, u64)>> {
        match &e?.kind {
            ExprKind::Array(items) => Some(items.iter().map(|it| self.bound_one(it, env)).collect()),
            ExprKind::Name(n) => match env.get(n.as_str()) {
                Some(Bound::Many(items)) => Some(items.clone()),
                _ => None,
            },
            _ => None,
        }
    }

    /// The material a plain name stands for, as lowering identifies
    /// children (`Lowerer::mat_identity`).
    fn identity(&self, e: &Expr, env: &Env) -> Option<ItemId> {
        let ExprKind::Name(n) = &e.kind else { return None };
        if let Some(bound) = env.get(n.as_str()) {
            return match bound {
                Bound::One(id, _) => *id,
                Bound::Many(_) => None,
            };
        }
        let sym = self.program.resolutions.get(&e.span)?;
        match sym.kind {
            SymbolKind::Material => Some((sym.module, sym.item)),
            SymbolKind::MaterialTree if self.tree_item((sym.module, sym.item)).is_some() => {
                Some((sym.module, sym.item))
            }
            _ => None,
        }
    }

    /// A call of a template: its body with its material parameters bound
    /// to the call's arguments (or their defaults), once per binding.
    fn template(&mut self, id: ItemId, args: &[Arg], env: &Env) -> u64 {
        let Some(Item::MaterialTree(t)) = self.program.loaded.modules.get(id.0).and_then(|m| m.ast.items.get(id.1))
        else {
            return 0;
        };
        let params = t.params.as_deref().unwrap_or(&[]);
        let names: Vec<&str> = params.iter().map(|p| p.name.name.as_str()).collect();
        let given = bind(&names, args);
        let mut bindings = Vec::with_capacity(params.len());
        for (p, a) in params.iter().zip(given) {
            let ty = super::Ty::from_ast(&p.ty);
            // A default is written in the template's own code: no bindings.
            let (expr, source) = match (a, &p.default) {
                (Some(a), _) => (a, env),
                (None, Some(d)) => (d, &Env::default()),
                (None, None) => {
                    bindings.push(None);
                    continue;
                }
            };
            let bound = match ty {
                super::Ty::Material => {
                    let source = source.clone();
                    let (id, size) = self.bound_one(expr, &source);
                    Some(Bound::One(id, size))
                }
                super::Ty::Array(elem, _) if *elem == super::Ty::Material => {
                    let source = source.clone();
                    self.items(Some(expr), &source).map(Bound::Many)
                }
                _ => None,
            };
            bindings.push(bound);
        }
        let key = (id, bindings);
        if let Some(size) = self.templates.get(&key) {
            return *size;
        }
        let inner: Env =
            params.iter().zip(&key.1).filter_map(|(p, b)| Some((p.name.name.to_string(), b.clone()?))).collect();
        let size = self.count(&t.body, &inner);
        self.templates.insert(key, size);
        size
    }
}

/// The sum of the sizes of `items`, each material counted once.
fn distinct_sum(items: &[(Option<ItemId>, u64)]) -> u64 {
    let mut seen: rustc_hash::FxHashSet<ItemId> = Default::default();
    let mut total: u64 = 0;
    for (id, size) in items {
        if id.is_some_and(|id| !seen.insert(id)) {
            continue;
        }
        total = total.saturating_add(*size);
    }
    total
}

/// Matches call arguments to parameters by position and name.
fn bind<'e>(params: &[&str], args: &'e [Arg]) -> Vec<Option<&'e Expr>> {
    let mut bound: Vec<Option<&Expr>> = vec![None; params.len()];
    for (k, a) in args.iter().enumerate() {
        let slot = match &a.name {
            Some(n) => params.iter().position(|p| *p == n.name.as_str()),
            None => Some(k),
        };
        if let Some(s) = slot.filter(|s| *s < bound.len()) {
            bound[s] = Some(&a.value);
        }
    }
    bound
}
