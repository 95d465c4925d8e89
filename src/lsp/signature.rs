//! Signature help: the parameters of the call being typed, the current
//! one highlighted (by its name when the argument is `name:`).

use super::analysis::{Analysis, item_params};
use super::context::Call;
use super::docs;
use crate::check::{builtin, interface_method};
use lsp_types::{
    Documentation, MarkupContent, MarkupKind, ParameterInformation, ParameterLabel, SignatureHelp, SignatureInformation,
};

/// One parameter: how it is shown and what it means.
struct Shown {
    name: String,
    text: String,
    doc: Option<String>,
}

/// The signature of the call at the cursor.
pub fn signature_help(analysis: &Analysis, call: &Call, in_material: bool) -> Option<SignatureHelp> {
    let (head, ret, params, doc) = describe(analysis, &call.callee, in_material)?;
    let mut label = format!("{head}(");
    let mut parameters = Vec::new();
    for (k, p) in params.iter().enumerate() {
        if k > 0 {
            label.push_str(", ");
        }
        let start = label.encode_utf16().count() as u32;
        label.push_str(&p.text);
        let end = label.encode_utf16().count() as u32;
        parameters.push(ParameterInformation {
            label: ParameterLabel::LabelOffsets([start, end]),
            documentation: p.doc.clone().map(Documentation::String),
        });
    }
    label.push(')');
    label.push_str(&ret);
    let active = match &call.current_name {
        Some(name) => params.iter().position(|p| &p.name == name),
        // Positional arguments bind in order; after a named one, the
        // first parameter not named yet.
        None if call.named.is_empty() => Some(call.index),
        None => params.iter().position(|p| !call.named.contains(&p.name)),
    }
    .filter(|&k| k < params.len())
    .map(|k| k as u32);
    let documentation =
        doc.map(|value| Documentation::MarkupContent(MarkupContent { kind: MarkupKind::Markdown, value }));
    Some(SignatureHelp {
        signatures: vec![SignatureInformation {
            label,
            documentation,
            parameters: Some(parameters),
            active_parameter: active,
        }],
        active_signature: Some(0),
        active_parameter: active,
    })
}

type Described = (String, String, Vec<Shown>, Option<String>);

/// A callee's name as shown, its return, parameters and documentation.
fn describe(analysis: &Analysis, callee: &str, in_material: bool) -> Option<Described> {
    if in_material && let Some(m) = interface_method(callee) {
        let params =
            m.params.iter().map(|(n, t)| Shown { name: n.to_string(), text: format!("{t} {n}"), doc: None }).collect();
        let head = format!("{} {}", m.ret, m.name);
        return Some((head, String::new(), params, docs::method_doc(m.name)));
    }
    if let Some(sym) = analysis.symbol(callee) {
        let item = analysis.item(sym)?;
        let doc = analysis.doc(sym);
        let params = item_params(item)?
            .iter()
            .map(|p| Shown {
                name: p.name.name.to_string(),
                text: analysis.param_text(p),
                doc: analysis.param_doc(p).or_else(|| doc.as_deref().and_then(|d| docs::param_doc(d, &p.name.name))),
            })
            .collect();
        let head = match item {
            crate::syntax::ast::Item::Function(f) => format!("{} {callee}", super::analysis::type_text(&f.ret)),
            _ => format!("material {callee}"),
        };
        return Some((head, String::new(), params, doc.map(|d| format!("```text\n{d}\n```"))));
    }
    let b = builtin(callee)?;
    let params = b
        .params
        .iter()
        .map(|p| Shown {
            name: p.name.to_string(),
            text: p.default.map_or(p.name.to_string(), |d| format!("{} = {d}", p.name)),
            doc: p.default.map(|d| format!("default: {d}")),
        })
        .collect();
    let doc = format!("`{}`\n\n{}", b.synopsis, docs::builtin_doc(b.name).unwrap_or_default());
    Some((b.name.to_string(), String::new(), params, Some(doc)))
}
