//! Go to definition, find references and document highlights, across the
//! document's imports and into the prelude.

use super::analysis::{Analysis, Node, node_at};
use super::documents::Workspace;
use crate::diag::Span;
use lsp_types::{DocumentHighlight, DocumentHighlightKind, Location};
use std::path::Path;

/// A span as an LSP location: its file's URI (a prelude file from the
/// prelude directory) and range.
pub fn location(workspace: &Workspace, analysis: &Analysis, span: Span) -> Option<Location> {
    let module = analysis.module_of(span.file)?;
    let name = analysis.program.loaded.sources.name(span.file);
    let uri = workspace.uri_of(name, module.is_prelude)?;
    Some(Location { uri, range: analysis.range(span) })
}

/// Where what is at `offset` is defined: the definition of a name, a
/// parameter for a named argument, the file of an import.
pub fn definition(workspace: &Workspace, analysis: &Analysis, offset: usize) -> Option<Location> {
    let node = node_at(analysis.module(), offset)?;
    if let Node::Import(path, _) = node {
        return imported_file(workspace, analysis, path);
    }
    let span = analysis.definition(analysis.target(node)?)?;
    location(workspace, analysis, span)
}

/// The start of the file an import names, among the modules loaded.
fn imported_file(workspace: &Workspace, analysis: &Analysis, path: &str) -> Option<Location> {
    let sources = &analysis.program.loaded.sources;
    let module = analysis
        .program
        .loaded
        .modules
        .iter()
        .enumerate()
        .find(|(k, m)| *k != analysis.root && !m.is_prelude && Path::new(sources.name(m.file)).ends_with(path))?;
    location(workspace, analysis, Span { file: module.1.file, start: 0, end: 0 })
}

/// Every reference to what is at `offset`, in every file of the program.
pub fn references(workspace: &Workspace, analysis: &Analysis, offset: usize, with_definition: bool) -> Vec<Location> {
    let Some(target) = node_at(analysis.module(), offset).and_then(|n| analysis.target(n)) else {
        return Vec::new();
    };
    analysis
        .references(target, with_definition)
        .into_iter()
        .filter_map(|span| location(workspace, analysis, span))
        .collect()
}

/// The references in the document itself, the definition marked as written.
pub fn highlights(analysis: &Analysis, offset: usize) -> Vec<(Span, DocumentHighlightKind)> {
    let Some(target) = node_at(analysis.module(), offset).and_then(|n| analysis.target(n)) else {
        return Vec::new();
    };
    let definition = analysis.definition(target);
    analysis
        .references(target, true)
        .into_iter()
        .filter(|s| s.file == analysis.file())
        .map(|s| (s, if Some(s) == definition { DocumentHighlightKind::WRITE } else { DocumentHighlightKind::READ }))
        .collect()
}

/// [`highlights`] as LSP values.
pub fn document_highlights(analysis: &Analysis, offset: usize) -> Vec<DocumentHighlight> {
    highlights(analysis, offset)
        .into_iter()
        .map(|(s, kind)| DocumentHighlight { range: analysis.range(s), kind: Some(kind) })
        .collect()
}
