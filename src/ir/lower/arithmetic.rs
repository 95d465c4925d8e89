//! Scalar constants computed from their syntax, without IR: the scene
//! description's shortcut.
//!
//! A scene value reads constants (`radius 1 + c100000 * 0`), and a file of
//! 100,000 constants would otherwise lower 100,000 values through the
//! builder (types, folding, memo) only to read back their folded words.
//! A constant whose value is `int` and `float` arithmetic (`+ - * / %`,
//! negation) on literals and constants already folded is computed here,
//! step by step as the builder folds the IR lowering would emit
//! (`Builder::fold`): the same words. Anything else (a call, a global, a
//! vector, a constant that did not fold) is `None`, and the constant is
//! lowered as usual.
//!
//! Only the scene description uses it (`ValueLowerer`): compiled functions
//! keep one lowering path, whose IR (value numbers included) the golden
//! tests pin.

use super::builder::Const;
use super::constants::Folded;
use super::*;
use crate::ir::semantics::{int_div, int_rem};

impl<'p> Lowerer<'p> {
    /// The words of constant `sym`'s value when it is scalar arithmetic on
    /// numbers and folded constants (see the module's rule).
    pub(super) fn evaluate_constant(&self, sym: Symbol) -> Option<Folded> {
        let Item::Const(c) = self.item(sym) else { return None };
        let to = Ty::from_ast(&c.ty);
        if !matches!(to, Ty::Int | Ty::Float) {
            return None;
        }
        let prelude = self.is_prelude(sym);
        let value = self.evaluate(prelude, &c.value)?;
        // `expr_as`'s coercion: an int value of a float constant.
        let value = match (to, value) {
            (Ty::Float, Const::I(i)) => Const::F(i as f32),
            (Ty::Float, v @ Const::F(_)) | (Ty::Int, v @ Const::I(_)) => v,
            _ => return None,
        };
        Some(Folded::Lanes(vec![value]))
    }

    /// `e`'s value as the lowering folds it, of the type the checker gave it.
    fn evaluate(&self, prelude: bool, e: &Expr) -> Option<Const> {
        // The types of the constant being evaluated (`evaluate_directly`).
        let ty = self.constant_types?.get(&e.span)?;
        let value = match &e.kind {
            ExprKind::Int(i) => Const::I(*i),
            ExprKind::Float(x) => Const::F(*x as f32),
            ExprKind::Name(n) => {
                // A shading global is not a constant's name.
                if globals::word_of(n).is_some() {
                    return None;
                }
                let sym = self.symbol(prelude, n).filter(|s| s.kind == SymbolKind::Const)?;
                match self.folded_consts.get(&(sym.module, sym.item))? {
                    Folded::Lanes(lanes) => match lanes[..] {
                        [c] => c,
                        _ => return None,
                    },
                    _ => return None,
                }
            }
            ExprKind::Unary { op: UnaryOp::Neg, operand } => {
                match crate::syntax::ast::with_stack(|| self.evaluate(prelude, operand))? {
                    Const::I(i) if *ty == Ty::Int => Const::I(i.wrapping_neg()),
                    Const::F(x) if *ty == Ty::Float => Const::F(-x),
                    _ => return None,
                }
            }
            ExprKind::Binary { op, lhs, rhs } => {
                use BinaryOp::*;
                if !matches!(op, Add | Sub | Mul | Div | Rem) {
                    return None;
                }
                // A chain `a + b + ...` nests on its left without bound.
                let (l, r) = crate::syntax::ast::with_stack(|| {
                    Some((self.evaluate(prelude, lhs)?, self.evaluate(prelude, rhs)?))
                })?;
                match (ty, l, r) {
                    (Ty::Int, Const::I(x), Const::I(y)) => Const::I(match op {
                        Add => x.wrapping_add(y),
                        Sub => x.wrapping_sub(y),
                        Mul => x.wrapping_mul(y),
                        Div => int_div(x, y),
                        _ => int_rem(x, y),
                    }),
                    (Ty::Float, l, r) => {
                        // `float_lanes`: an int operand converted first.
                        let (x, y) = (as_float(l)?, as_float(r)?);
                        Const::F(match op {
                            Add => x + y,
                            Sub => x - y,
                            Mul => x * y,
                            Div => x / y,
                            // C's fmod, as `binary` lowers it.
                            _ => x - y * (x / y).trunc(),
                        })
                    }
                    _ => return None,
                }
            }
            _ => return None,
        };
        // The value has the checker's type (an int literal is an int).
        match (ty, value) {
            (Ty::Int, Const::I(_)) | (Ty::Float, Const::F(_)) => Some(value),
            _ => None,
        }
    }
}

fn as_float(c: Const) -> Option<f32> {
    match c {
        Const::F(x) => Some(x),
        Const::I(i) => Some(i as f32),
        Const::B(_) => None,
    }
}
