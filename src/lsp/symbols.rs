//! Document symbols: functions, materials (with their methods), material
//! trees, constants, and the scene (with its blocks and properties).

use super::analysis::{Analysis, one_line, type_text};
use super::documents::Document;
use crate::diag::Span;
use crate::syntax::ast::{Item, SceneEntry, SceneProp};
use lsp_types::{DocumentSymbol, SymbolKind};

#[allow(deprecated)] // `DocumentSymbol::deprecated` must be written out.
fn symbol(
    doc: &Document,
    name: String,
    detail: Option<String>,
    kind: SymbolKind,
    whole: Span,
    name_span: Span,
    children: Vec<DocumentSymbol>,
) -> DocumentSymbol {
    let range = doc.range(whole.start as usize, whole.end as usize);
    let mut selection_range = doc.range(name_span.start as usize, name_span.end as usize);
    // The selection must lie inside the range, which recovery can break.
    if selection_range.start < range.start || selection_range.end > range.end {
        selection_range = range;
    }
    DocumentSymbol {
        name: if name.is_empty() { "?".into() } else { name },
        detail,
        kind,
        tags: None,
        deprecated: None,
        range,
        selection_range,
        children: (!children.is_empty()).then_some(children),
    }
}

/// The outline of the document.
pub fn document_symbols(analysis: &Analysis, doc: &Document) -> Vec<DocumentSymbol> {
    let params = |ps: &[crate::syntax::ast::Param]| {
        let list: Vec<String> = ps.iter().map(|p| format!("{} {}", type_text(&p.ty), p.name.name)).collect();
        format!("({})", list.join(", "))
    };
    analysis
        .module()
        .ast
        .items
        .iter()
        .map(|item| match item {
            Item::Import { path, span } => {
                symbol(doc, format!("import \"{path}\""), None, SymbolKind::FILE, *span, *span, Vec::new())
            }
            Item::Function(f) => symbol(
                doc,
                f.name.name.to_string(),
                Some(format!("{} {}", type_text(&f.ret), params(&f.params))),
                SymbolKind::FUNCTION,
                f.span,
                f.name.span,
                Vec::new(),
            ),
            Item::Material(d) => {
                let methods = d
                    .methods
                    .iter()
                    .map(|m| {
                        let detail = format!("{} {}", type_text(&m.ret), params(&m.params));
                        symbol(
                            doc,
                            m.name.name.to_string(),
                            Some(detail),
                            SymbolKind::METHOD,
                            m.span,
                            m.name.span,
                            vec![],
                        )
                    })
                    .collect();
                let detail = Some(format!("material {}", params(&d.params)));
                symbol(doc, d.name.name.to_string(), detail, SymbolKind::CLASS, d.span, d.name.span, methods)
            }
            Item::MaterialTree(t) => {
                let detail = Some(one_line(analysis.snippet(t.body.span), 60));
                symbol(doc, t.name.name.to_string(), detail, SymbolKind::OBJECT, t.span, t.name.span, Vec::new())
            }
            Item::Const(c) => symbol(
                doc,
                c.name.name.to_string(),
                Some(type_text(&c.ty)),
                SymbolKind::CONSTANT,
                c.span,
                c.name.span,
                Vec::new(),
            ),
            Item::Scene(s) => {
                let prop = |p: &SceneProp| {
                    let detail = p.value.as_ref().map(|v| one_line(analysis.snippet(v.span), 40));
                    symbol(doc, p.name.name.to_string(), detail, SymbolKind::PROPERTY, p.span, p.name.span, vec![])
                };
                let entries = s
                    .entries
                    .iter()
                    .map(|e| match e {
                        SceneEntry::Prop(p) => prop(p),
                        SceneEntry::Block(b) => {
                            let name = match &b.kind {
                                Some(k) => format!("{} {}", b.keyword.name, k.name),
                                None => b.keyword.name.to_string(),
                            };
                            let children = b.props.iter().map(prop).collect();
                            symbol(doc, name, None, SymbolKind::STRUCT, b.span, b.keyword.span, children)
                        }
                    })
                    .collect();
                let head = Span { end: s.span.start + 5, ..s.span };
                symbol(doc, "scene".into(), None, SymbolKind::NAMESPACE, s.span, head, entries)
            }
        })
        .collect()
}
