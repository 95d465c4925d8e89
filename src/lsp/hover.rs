//! Hover: the type of what is under the cursor, and for definitions,
//! builtins and interface methods their signature and documentation.

use super::analysis::{Analysis, Node, Target, item_params};
use super::docs;
use crate::check::{self, BuiltinFn, GLOBALS, SAMPLE_FIELDS, scene_properties};
use crate::syntax::ast::{BaseType, SceneBlock};

/// Markdown for the hover at byte `offset` of the document, and the byte
/// range it is about.
pub fn hover(analysis: &Analysis, offset: usize) -> Option<(String, (usize, usize))> {
    let node = super::analysis::node_at(analysis.module(), offset)?;
    let range = node_range(&node)?;
    let text = match (node, analysis.target(node)) {
        (_, Some(target)) => target_hover(analysis, target, &node)?,
        (Node::Field(e, field), None) => {
            let ty = analysis.type_of(e.span).map_or(String::new(), |t| format!("{t} "));
            let sample = SAMPLE_FIELDS.iter().any(|(n, _)| *n == field.name);
            let note = if sample { "a field of `bsdf_sample`" } else { "a component" };
            format!("{}\n\n{note}", code(&format!("{ty}{}", field.name)))
        }
        (Node::Construct(ty, _), None) => construct_hover(ty),
        (Node::Expr(e), None) => code(&analysis.type_of(e.span)?.to_string()),
        (Node::Import(path, _), None) => format!("imports `{path}`: its definitions are visible here"),
        (Node::SceneBlock(b), None) => scene_block_hover(b),
        (Node::SceneProp(block, p), None) => {
            let (keyword, kind) = block.map_or((None, None), |b| (Some(b.keyword.name.as_str()), b.kind.as_ref()));
            let props = scene_properties(keyword, kind.map(|k| k.name.as_str()));
            let prop = props.iter().find(|q| q.name == p.name.name)?;
            format!("{}\n\ntakes {}", code(prop.name), prop.takes)
        }
        _ => return None,
    };
    Some((text, range))
}

fn node_range(node: &Node<'_>) -> Option<(usize, usize)> {
    let span = match node {
        Node::ItemName(_, span) | Node::Construct(_, span) => *span,
        Node::MethodName(m) => m.name.span,
        Node::Param(p) => p.name.span,
        Node::LocalDecl(name, _) => name.span,
        Node::Name(e, _) | Node::Expr(e) => e.span,
        Node::Callee(c) => c.span,
        Node::ArgName(name, _) => name.span,
        Node::Field(_, f) => f.span,
        Node::Import(_, span) => *span,
        Node::SceneBlock(b) => b.keyword.span,
        Node::SceneProp(_, p) => p.name.span,
    };
    Some((span.start as usize, span.end as usize))
}

/// A fenced TSL code block.
pub fn code(text: &str) -> String {
    format!("```tsl\n{text}\n```")
}

/// A doc block as shown: preformatted (stdlib docs are aligned tables).
fn doc_block(doc: &str) -> String {
    format!("```text\n{doc}\n```")
}

fn target_hover(analysis: &Analysis, target: Target, node: &Node<'_>) -> Option<String> {
    Some(match target {
        Target::Item(sym) => {
            let mut out = code(&analysis.signature(sym)?);
            if let Some(doc) = analysis.doc(sym) {
                out.push_str(&format!("\n\n{}", doc_block(&doc)));
            }
            if sym.span.file != analysis.file() {
                out.push_str(&format!("\n\n`{}`", analysis.file_name(sym.span)));
            }
            out
        }
        Target::Local(decl) => {
            let (ty, kind) = match analysis.local_decl(decl) {
                Some(found) => found,
                None => {
                    let ty = match node {
                        Node::Name(e, _) => analysis.type_of(e.span).map(|t| t.to_string()),
                        _ => None,
                    };
                    (ty.unwrap_or_default(), "local")
                }
            };
            let mut out = format!("{}\n\n{kind}", code(&format!("{ty} {}", analysis.snippet(decl))));
            if let Node::Param(p) = node
                && let Some(doc) = param_doc_comment(analysis, p)
            {
                out.push_str(&format!(": {doc}"));
            }
            out
        }
        Target::Param(sym, k) => {
            let param = item_params(analysis.item(sym)?)?.get(k)?;
            let owner = analysis.snippet(sym.span);
            let mut declared = analysis.param_text(param);
            if let Some(options) = &param.options {
                declared.push_str(&format!(" in ({})", options.listed()));
            }
            let mut out = format!("{}\n\nparameter of `{owner}`", code(&declared));
            // Its `///` comment, else its row in a stdlib file's table.
            let meaning = param_doc_comment(analysis, param)
                .or_else(|| analysis.doc(sym).and_then(|d| docs::param_doc(&d, &param.name.name)));
            if let Some(meaning) = meaning {
                out.push_str(&format!(": {meaning}"));
            }
            out
        }
        Target::Builtin(f) => builtin_hover(f),
        Target::BuiltinParam(f, k) => {
            let p = f.builtin().params.get(k)?;
            let default = p.default.map_or(String::from("required"), |d| format!("default: {d}"));
            format!("{}\n\nparameter of the builtin `{}`; {default}", code(p.name), f.name())
        }
        Target::Global(name) => {
            let (_, ty, meaning) = GLOBALS.iter().find(|g| g.0 == name)?;
            format!("{}\n\nshading global: {meaning}", code(&format!("{ty} {name}")))
        }
        Target::Method(m) => {
            let meaning = docs::method_doc(m.name).map_or(String::new(), |d| format!("{d}\n\n"));
            format!("{}\n\ninterface method: {meaning}default: `{}`", code(&m.signature()), m.default)
        }
    })
}

/// The `///` comment above a parameter's declaration.
fn param_doc_comment(analysis: &Analysis, p: &crate::syntax::ast::Param) -> Option<String> {
    let before = analysis.snippet(crate::diag::Span { start: 0, end: p.span.start, ..p.span });
    crate::syntax::doc_comment(before, before.len())
}

/// A builtin's parameters with their defaults, its typing synopsis and
/// what the language reference says of it.
pub fn builtin_signature(f: BuiltinFn) -> String {
    let b = f.builtin();
    let params: Vec<String> = b
        .params
        .iter()
        .map(|p| match p.default {
            Some(d) => format!("{} = {d}", p.name),
            None => p.name.to_string(),
        })
        .collect();
    format!("{}({})", b.name, params.join(", "))
}

pub fn builtin_hover(f: BuiltinFn) -> String {
    let mut out = format!("{}\n\n{}", code(&builtin_signature(f)), code(f.builtin().synopsis));
    if let Some(doc) = docs::builtin_doc(f.name()) {
        out.push_str(&format!("\n\n{doc}"));
    }
    out.push_str("\n\nbuiltin function");
    out
}

fn construct_hover(ty: BaseType) -> String {
    let doc = docs::builtin_doc(ty.keyword()).unwrap_or_default();
    format!("{}\n\n{doc}", code(&format!("{}(...)", ty.keyword())))
}

fn scene_block_hover(b: &SceneBlock) -> String {
    let kind = b.kind.as_ref().map(|k| k.name.as_str());
    let props = scene_properties(Some(&b.keyword.name), kind);
    let title = match kind {
        Some(k) => format!("{} {k}", b.keyword.name),
        None => b.keyword.name.to_string(),
    };
    if props.is_empty() {
        let kinds = check::scene_kinds(&b.keyword.name);
        return format!("{}\n\nkinds: {}", code(&title), kinds.join(", "));
    }
    let lines: Vec<String> = props
        .iter()
        .map(|p| {
            let need = if p.required {
                " (required)"
            } else if p.alternative {
                " (one of the alternatives)"
            } else {
                ""
            };
            format!("- `{}`: {}{need}", p.name, p.takes)
        })
        .collect();
    format!("{}\n\n{}", code(&title), lines.join("\n"))
}
