//! Constants: each evaluated once, in dependency order.
//!
//! A constant's value reads nothing but literals, other constants,
//! functions and the frame globals (the checker refuses shading globals and
//! textures in constants), so it can be computed at the top of the function
//! being built, where it dominates every use. The first use lowers it there
//! ([`Builder::outermost`]) and remembers it in the outermost memo scope;
//! every later use, in any scope, reads it back. A constant that folds to
//! literal words (most do) is also remembered for the whole lowering, so
//! other entry points and scene values only copy its words.
//!
//! Before a constant is lowered, the constants its value names that are
//! not known yet are lowered first, deepest first (an iterative
//! depth-first search): a chain of 100,000 constants never recurses through
//! more than one constant, and a constant that uses the previous one twice
//! costs one lowering, not 2^n. (Constants reached through a function's
//! body are lowered when the body is, under `ast::with_stack`.)

use super::*;
use std::cell::RefCell;

/// A constant's value as compile-time words, valid in every function.
#[derive(Debug, Clone)]
pub(super) enum Folded {
    Lanes(Vec<Const>),
    Elems(Vec<Vec<Const>>),
    Str(Rc<str>),
}

/// Where a constant is: (module, item).
type ConstId = (usize, usize);

/// The coordinate context constants are lowered in: they read no point
/// global, so one context (an id no other context has) lets the function
/// calls of all constants share the memo.
fn constants_ctx() -> Ctx {
    Ctx { id: 0, overrides: Rc::new(HashMap::default()) }
}

impl<'p> Lowerer<'p> {
    /// The value of constant `sym`, lowered at most once per function.
    pub(super) fn constant(&mut self, b: &mut Builder, sym: Symbol) -> Val<'p> {
        if let Some(v) = self.known_constant(b, sym) {
            return v;
        }
        let mut value = None;
        let ctx = constants_ctx();
        for dep in self.constants_to_lower(b, sym) {
            if let Some(folded) = self.evaluate_directly(b, dep) {
                self.folded_consts.insert((dep.module, dep.item), folded);
                continue;
            }
            let v = self.lower_constant(b, dep, &ctx);
            self.remember_constant(b, dep, &v);
            if (dep.module, dep.item) == (sym.module, sym.item) {
                value = Some(v);
            }
        }
        value.or_else(|| self.known_constant(b, sym)).unwrap_or_else(|| {
            ruled_out!("constant {sym:?} is not among the constants it needs");
            Val::Unit
        })
    }

    /// Constant `sym`'s words computed without IR, where the lowering allows
    /// it (`evaluate_constants`, see `arithmetic`).
    fn evaluate_directly(&mut self, b: &Builder, sym: Symbol) -> Option<Folded> {
        if !self.evaluate_constants || self.stopped(b) {
            return None;
        }
        let Item::Const(c) = self.item(sym) else { return None };
        let outer = self.constant_types.replace(self.program.expr_types.within(&c.value.span));
        let folded = self.evaluate_constant(sym);
        self.constant_types = outer;
        folded
    }

    /// The value of `sym` if it was lowered before: its folded words, or
    /// the values remembered at the top of this function.
    fn known_constant(&mut self, b: &mut Builder, sym: Symbol) -> Option<Val<'p>> {
        let id = (sym.module, sym.item);
        if let Some(folded) = self.folded_consts.get(&id) {
            return Some(match folded.clone() {
                Folded::Lanes(cs) => Val::Lanes(cs.into_iter().map(|c| b.constant(c)).collect()),
                Folded::Elems(es) => Val::Array(ArrayVal::Elems(
                    es.into_iter().map(|e| e.into_iter().map(|c| b.constant(c)).collect()).collect(),
                )),
                Folded::Str(s) => Val::Str(s),
            });
        }
        let words = b.memo.get_outermost(&MemoKey::Constant(id))?.to_vec();
        let Item::Const(c) = self.item(sym) else { return None };
        match Ty::from_ast(&c.ty) {
            Ty::Array(elem, len) => {
                let n = self.lanes_of(&elem);
                let elems: Vec<Vec<Value>> = words.chunks(n.max(1)).map(<[Value]>::to_vec).collect();
                (n > 0 && elems.len() == len as usize).then_some(Val::Array(ArrayVal::Elems(elems)))
            }
            _ => Some(Val::Lanes(words)),
        }
    }

    /// Whether [`Self::known_constant`] has `sym` (without copying it in).
    fn is_known(&self, b: &Builder, sym: Symbol) -> bool {
        let id = (sym.module, sym.item);
        self.folded_consts.contains_key(&id) || b.memo.get_outermost(&MemoKey::Constant(id)).is_some()
    }

    /// `sym` and the constants it needs that are not known yet, each once,
    /// every constant after those its value names (`sym` last).
    fn constants_to_lower(&self, b: &Builder, sym: Symbol) -> Vec<Symbol> {
        let mut order = Vec::new();
        let mut seen: HashSet<ConstId> = HashSet::default();
        seen.insert((sym.module, sym.item));
        // Each constant with the constants its value names still to visit.
        let mut stack: Vec<(Symbol, Vec<Symbol>)> = vec![(sym, self.named_constants(sym))];
        while let Some((_, deps)) = stack.last_mut() {
            match deps.pop() {
                Some(dep) => {
                    if seen.insert((dep.module, dep.item)) && !self.is_known(b, dep) {
                        let next = self.named_constants(dep);
                        stack.push((dep, next));
                    }
                }
                None => {
                    if let Some((done, _)) = stack.pop() {
                        order.push(done);
                    }
                }
            }
        }
        order
    }

    /// The constants constant `sym`'s value names, as its own code
    /// resolves names (a prelude constant sees the prelude's).
    fn named_constants(&self, sym: Symbol) -> Vec<Symbol> {
        let Item::Const(c) = self.item(sym) else { return Vec::new() };
        let prelude = self.is_prelude(sym);
        let found = RefCell::new(Vec::new());
        c.value.any(&|e: &Expr| {
            if let ExprKind::Name(n) = &e.kind
                && let Some(s) = self.symbol(prelude, n).filter(|s| s.kind == SymbolKind::Const)
            {
                found.borrow_mut().push(s);
            }
            false
        });
        let mut found = found.into_inner();
        // Visited in the order written (the search pops from the end).
        found.reverse();
        found
    }

    /// Lowers the value of constant `sym` at the top of the function.
    fn lower_constant(&mut self, b: &mut Builder, sym: Symbol, ctx: &Ctx) -> Val<'p> {
        let Item::Const(c) = self.item(sym) else {
            ruled_out!("the constant {sym:?} is not a constant item");
            return Val::Unit;
        };
        let ty = Ty::from_ast(&c.ty);
        let prelude = self.is_prelude(sym);
        // A constant that reads another lowers it inside (through a
        // function's body): each keeps its own types while lowered.
        let outer = self.constant_types.replace(self.program.expr_types.within(&c.value.span));
        let v = b.outermost(|b| {
            let mut fr = self.new_frame(prelude, HashSet::default());
            self.expr_as(b, &mut fr, ctx, &c.value, &ty)
        });
        self.constant_types = outer;
        v
    }

    /// Remembers a constant's value: as words for the whole lowering when
    /// it folded, else at the top of this function. An array held in IR
    /// arrays is not remembered (it is lowered again at each use).
    fn remember_constant(&mut self, b: &mut Builder, sym: Symbol, v: &Val<'p>) {
        let id = (sym.module, sym.item);
        // Literal words only: a condition known in the scope being built
        // (`Builder::facts`) holds there, not everywhere.
        let words = |lanes: &[Value]| lanes.iter().map(|x| b.consts.get(x).copied()).collect::<Option<Vec<Const>>>();
        let folded = match v {
            Val::Lanes(l) => words(l).map(Folded::Lanes),
            Val::Array(ArrayVal::Elems(es)) => es.iter().map(|e| words(e)).collect::<Option<_>>().map(Folded::Elems),
            Val::Str(s) => Some(Folded::Str(s.clone())),
            _ => None,
        };
        if let Some(folded) = folded {
            self.folded_consts.insert(id, folded);
            return;
        }
        match v {
            Val::Lanes(l) => b.memo.insert_at(0, MemoKey::Constant(id), l),
            Val::Array(ArrayVal::Elems(es)) if es.iter().all(|e| e.len() == es[0].len()) => {
                b.memo.insert_at(0, MemoKey::Constant(id), &es.concat());
            }
            _ => {}
        }
    }
}
