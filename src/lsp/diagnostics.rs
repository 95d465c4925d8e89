//! Diagnostics of a document: exactly what `tslc check` reports for its
//! unsaved text (`tsl::check_source`: syntax, types, images, the scene;
//! run by the server's diagnostics workers), as LSP diagnostics. Errors
//! inside an imported file are shown at the import that brings them in,
//! pointing to where they are.

use super::documents::Workspace;
use super::line_index::LineIndex;
use crate::Checked;
use crate::diag::{Diagnostic, FileId, Severity, SourceMap, Span};
use crate::syntax::ast::Item;
use lsp_types::{DiagnosticRelatedInformation, DiagnosticSeverity, Location, NumberOrString};
use std::collections::HashMap;
use std::path::Path;

/// The diagnostics of a document's text, checked (`tsl::check_source`).
pub fn diagnostics(workspace: &Workspace, checked: &Checked, text: &str) -> Vec<lsp_types::Diagnostic> {
    let sources = &checked.program.loaded.sources;
    let modules = &checked.program.loaded.modules;
    let Some(root) = modules.iter().find(|m| !m.is_prelude).map(|m| m.file) else {
        return Vec::new();
    };
    let imports: Vec<(&str, Span)> = modules
        .iter()
        .find(|m| m.file == root)
        .map(|m| {
            m.ast
                .items
                .iter()
                .filter_map(|i| match i {
                    Item::Import { path, span } => Some((path.as_str(), *span)),
                    _ => None,
                })
                .collect()
        })
        .unwrap_or_default();
    // The document and each file a label points into are indexed once.
    let mut indexes: HashMap<FileId, LineIndex> = HashMap::from([(root, LineIndex::new(text))]);
    for d in &checked.diagnostics {
        for file in d.labels.iter().map(|l| l.span.file).chain([d.span.file]) {
            if (file.0 as usize) < sources.len() {
                indexes.entry(file).or_insert_with(|| LineIndex::new(sources.text(file)));
            }
        }
    }
    let index = &indexes[&root];
    let located = |span: Span| -> Option<Location> {
        let is_prelude = modules.iter().any(|m| m.file == span.file && m.is_prelude);
        let uri = workspace.uri_of(sources.name(span.file), is_prelude)?;
        let file_text = sources.text(span.file);
        let range = indexes.get(&span.file)?.range(file_text, span.start as usize, span.end as usize);
        Some(Location { uri, range })
    };
    checked
        .diagnostics
        .iter()
        .map(|d| {
            if d.span.file == root {
                return to_lsp(d, index.range(text, d.span.start as usize, d.span.end as usize), sources, &located);
            }
            // In another file: at the import of it (or the first import),
            // else at the top of the document.
            let elsewhere = sources.name(d.span.file);
            let at = imports
                .iter()
                .find(|(path, _)| Path::new(elsewhere).ends_with(path))
                .or(imports.first())
                .map_or(Span { file: root, start: 0, end: 0 }, |(_, span)| *span);
            let (line, col) = sources.line_col(d.span.file, d.span.start);
            let mut shown = d.clone();
            shown.message = format!("in `{elsewhere}` ({line}:{col}): {}", d.message);
            shown.labels.insert(0, crate::diag::Label { span: d.span, message: d.message.clone() });
            to_lsp(&shown, index.range(text, at.start as usize, at.end as usize), sources, &located)
        })
        .collect()
}

fn to_lsp(
    d: &Diagnostic,
    range: lsp_types::Range,
    sources: &SourceMap,
    located: &dyn Fn(Span) -> Option<Location>,
) -> lsp_types::Diagnostic {
    let mut message = d.message.clone();
    if !d.primary_label.is_empty() {
        message.push_str(&format!("\n{}", d.primary_label));
    }
    for note in &d.notes {
        message.push_str(&format!("\nnote: {note}"));
    }
    if let Some(help) = &d.help {
        message.push_str(&format!("\nhelp: {help}"));
    }
    let related: Vec<DiagnosticRelatedInformation> = d
        .labels
        .iter()
        .filter(|l| (l.span.file.0 as usize) < sources.len())
        .filter_map(|l| Some(DiagnosticRelatedInformation { location: located(l.span)?, message: l.message.clone() }))
        .collect();
    lsp_types::Diagnostic {
        range,
        severity: Some(match d.severity {
            Severity::Error => DiagnosticSeverity::ERROR,
            Severity::Warning => DiagnosticSeverity::WARNING,
        }),
        code: None::<NumberOrString>,
        source: Some("tslc".into()),
        message,
        related_information: (!related.is_empty()).then_some(related),
        ..lsp_types::Diagnostic::default()
    }
}
