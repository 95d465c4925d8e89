//! Go to definition, find references and document highlights, across the
//! document's imports and into the prelude.

use super::analysis::{Analysis, Node, node_at};
use super::documents::Workspace;
use crate::diag::{FileId, Span};
use lsp_types::{DocumentHighlight, DocumentHighlightKind, Location, Url};
use std::path::Path;

/// A span as an LSP location: its file's URI (a prelude file from the
/// prelude directory) and range.
pub fn location(workspace: &Workspace, analysis: &Analysis, span: Span) -> Option<Location> {
    Some(Location { uri: file_uri(workspace, analysis, span.file)?, range: analysis.range(span) })
}

fn file_uri(workspace: &Workspace, analysis: &Analysis, file: FileId) -> Option<Url> {
    let module = analysis.module_of(file)?;
    workspace.uri_of(analysis.program.loaded.sources.name(file), module.is_prelude)
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
    // References are sorted by file: each file's URI is made once.
    let mut uri: Option<(FileId, Option<Url>)> = None;
    let mut out = Vec::new();
    for span in analysis.references(target, with_definition) {
        if uri.as_ref().is_none_or(|(file, _)| *file != span.file) {
            uri = Some((span.file, file_uri(workspace, analysis, span.file)));
        }
        if let Some((_, Some(uri))) = &uri {
            out.push(Location { uri: uri.clone(), range: analysis.range(span) });
        }
    }
    out
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
