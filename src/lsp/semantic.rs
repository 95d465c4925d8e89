//! Semantic tokens: what the TextMate grammar cannot know, from the
//! checker's resolutions: which names are functions, materials, constants,
//! parameters, locals, builtins and shading globals, and scene properties.

use super::analysis::{Analysis, item_name};
use super::documents::Document;
use crate::check::{GLOBALS, SymbolKind};
use crate::diag::Span;
use crate::syntax::ast::*;
use lsp_types::{SemanticToken, SemanticTokenModifier, SemanticTokenType, SemanticTokens, SemanticTokensLegend};
use std::collections::{HashMap, HashSet};

const TYPES: &[SemanticTokenType] = &[
    SemanticTokenType::FUNCTION,
    SemanticTokenType::CLASS,
    SemanticTokenType::VARIABLE,
    SemanticTokenType::PARAMETER,
    SemanticTokenType::PROPERTY,
    SemanticTokenType::KEYWORD,
    SemanticTokenType::TYPE,
];
const FUNCTION: u32 = 0;
const CLASS: u32 = 1;
const VARIABLE: u32 = 2;
const PARAMETER: u32 = 3;
const PROPERTY: u32 = 4;
const KEYWORD: u32 = 5;
const TYPE: u32 = 6;

const MODIFIERS: &[SemanticTokenModifier] =
    &[SemanticTokenModifier::DECLARATION, SemanticTokenModifier::READONLY, SemanticTokenModifier::DEFAULT_LIBRARY];
const DECLARATION: u32 = 1;
const READONLY: u32 = 2;
const LIBRARY: u32 = 4;

pub fn legend() -> SemanticTokensLegend {
    SemanticTokensLegend { token_types: TYPES.to_vec(), token_modifiers: MODIFIERS.to_vec() }
}

fn symbol_class(kind: SymbolKind) -> (u32, u32) {
    match kind {
        SymbolKind::Function => (FUNCTION, 0),
        SymbolKind::Material | SymbolKind::MaterialTree => (CLASS, 0),
        SymbolKind::Const => (VARIABLE, READONLY),
    }
}

/// The semantic tokens of the document.
pub fn tokens(analysis: &Analysis, doc: &Document) -> SemanticTokens {
    let file = analysis.file();
    let p = &analysis.program;
    let mut classes: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
    let mut put = |span: Span, class: (u32, u32)| {
        if span.file == file && span.end > span.start {
            classes.entry((span.start, span.end)).or_insert(class);
        }
    };
    declarations(analysis, &mut put);
    for (span, sym) in &p.resolutions {
        let prelude = p.loaded.modules.get(sym.module).is_some_and(|m| m.is_prelude);
        let (class, modifiers) = symbol_class(sym.kind);
        put(*span, (class, modifiers | if prelude { LIBRARY } else { 0 }));
    }
    for span in p.builtin_calls.keys() {
        put(*span, (FUNCTION, LIBRARY));
    }
    let params: HashSet<Span> = parameter_spans(analysis).into_iter().collect();
    for (span, decl) in &p.local_uses {
        put(*span, (if params.contains(decl) { PARAMETER } else { VARIABLE }, 0));
    }
    for (span, ty) in &p.expr_types {
        let name = analysis.snippet(*span);
        if !ty.is_error() && GLOBALS.iter().any(|g| g.0 == name) && !p.local_uses.contains_key(span) {
            put(*span, (VARIABLE, READONLY | LIBRARY));
        }
    }
    let mut sorted: Vec<((u32, u32), (u32, u32))> = classes.into_iter().collect();
    sorted.sort();
    let mut data = Vec::with_capacity(sorted.len());
    let (mut line, mut character) = (0, 0);
    for ((start, end), (class, modifiers)) in sorted {
        let at = doc.index.position(&doc.text, start as usize);
        let to = doc.index.position(&doc.text, end as usize);
        if to.line != at.line {
            continue;
        }
        let delta_start = if at.line == line { at.character - character } else { at.character };
        data.push(SemanticToken {
            delta_line: at.line - line,
            delta_start,
            length: to.character - at.character,
            token_type: class,
            token_modifiers_bitset: modifiers,
        });
        (line, character) = (at.line, at.character);
    }
    SemanticTokens { result_id: None, data }
}

/// The spans of the document's parameters' names.
fn parameter_spans(analysis: &Analysis) -> Vec<Span> {
    let mut out = Vec::new();
    for item in &analysis.module().ast.items {
        let mut params = |ps: &[Param]| out.extend(ps.iter().map(|p| p.name.span));
        match item {
            Item::Function(f) => params(&f.params),
            Item::Material(d) => {
                params(&d.params);
                for m in &d.methods {
                    params(&m.params);
                }
            }
            Item::MaterialTree(t) => params(t.params.as_deref().unwrap_or(&[])),
            _ => {}
        }
    }
    out
}

/// Names where they are defined, named arguments and scene words.
fn declarations(analysis: &Analysis, put: &mut impl FnMut(Span, (u32, u32))) {
    for span in parameter_spans(analysis) {
        put(span, (PARAMETER, DECLARATION));
    }
    for item in &analysis.module().ast.items {
        if let Some((kind, name)) = item_name(item) {
            let (class, modifiers) = symbol_class(kind);
            put(name.span, (class, modifiers | DECLARATION));
        }
        match item {
            Item::Function(f) => block(&f.body, put),
            Item::Material(d) => {
                for m in &d.methods {
                    put(m.name.span, (FUNCTION, DECLARATION));
                    block(&m.body, put);
                }
                d.params.iter().filter_map(|p| p.default.as_ref()).for_each(|e| expr(e, put));
            }
            Item::MaterialTree(t) => expr(&t.body, put),
            Item::Const(c) => expr(&c.value, put),
            Item::Scene(s) => {
                for entry in &s.entries {
                    let props = match entry {
                        SceneEntry::Block(b) => {
                            put(b.keyword.span, (KEYWORD, 0));
                            if let Some(k) = &b.kind {
                                put(k.span, (TYPE, 0));
                            }
                            b.props.iter().collect::<Vec<_>>()
                        }
                        SceneEntry::Prop(p) => vec![p],
                    };
                    for p in props {
                        put(p.name.span, (PROPERTY, 0));
                        if let Some(v) = &p.value {
                            expr(v, put);
                        }
                    }
                }
            }
            Item::Import { .. } => {}
        }
    }
}

fn block(b: &Block, put: &mut impl FnMut(Span, (u32, u32))) {
    for s in &b.stmts {
        stmt(s, put);
    }
}

fn stmt(s: &Stmt, put: &mut impl FnMut(Span, (u32, u32))) {
    match &s.kind {
        StmtKind::Let { name, init, .. } => {
            put(name.span, (VARIABLE, DECLARATION));
            if let Some(e) = init {
                expr(e, put);
            }
        }
        StmtKind::Assign { target, value, .. } => {
            expr(target, put);
            expr(value, put);
        }
        StmtKind::Expr(e) | StmtKind::Return(Some(e)) => expr(e, put),
        StmtKind::If { cond, then_block, else_branch } => {
            expr(cond, put);
            block(then_block, put);
            if let Some(e) = else_branch {
                stmt(e, put);
            }
        }
        StmtKind::For { var, start, end, body } => {
            put(var.span, (VARIABLE, DECLARATION));
            expr(start, put);
            expr(end, put);
            block(body, put);
        }
        StmtKind::While { cond, body } => {
            expr(cond, put);
            block(body, put);
        }
        StmtKind::Block(b) => block(b, put),
        StmtKind::Return(None) | StmtKind::Break | StmtKind::Continue => {}
    }
}

fn expr(e: &Expr, put: &mut impl FnMut(Span, (u32, u32))) {
    with_stack(|| match &e.kind {
        ExprKind::Call { args, .. } | ExprKind::Construct { args, .. } => {
            for a in args {
                if let Some(name) = &a.name {
                    put(name.span, (PARAMETER, 0));
                }
                expr(&a.value, put);
            }
        }
        ExprKind::Member { base, field } => {
            put(field.span, (PROPERTY, 0));
            expr(base, put);
        }
        ExprKind::Index { base, index } => {
            expr(base, put);
            expr(index, put);
        }
        ExprKind::Unary { operand, .. } => expr(operand, put),
        ExprKind::Binary { lhs, rhs, .. } => {
            expr(lhs, put);
            expr(rhs, put);
        }
        ExprKind::Ternary { cond, then_expr, else_expr } => {
            expr(cond, put);
            expr(then_expr, put);
            expr(else_expr, put);
        }
        ExprKind::Array(items) | ExprKind::Tuple(items) => items.iter().for_each(|i| expr(i, put)),
        ExprKind::Int(_) | ExprKind::Float(_) | ExprKind::Bool(_) | ExprKind::Str(_) | ExprKind::Name(_) => {}
    });
}
