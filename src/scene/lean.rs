//! What a one-shot tool (`tslc check`, `tslc render`) drops of a generated
//! scene once it no longer needs it: a million `object sphere { ... }`
//! blocks are most of the program's memory. Editors keep everything (they
//! hover over the values), and so does a program that describes the scene
//! at other frames.

use super::{MaterialRef, SceneDesc, Surface};
use crate::check::{Program, SymbolKind};
use crate::diag::Span;
use crate::syntax::ast::{Expr, ExprKind, Item, SceneEntry, UnaryOp};
use rustc_hash::FxHashMap;
use std::sync::Arc;

/// The value expressions of scene objects whose types and resolutions
/// nothing reads after checking, in span order: numbers and triples of
/// numbers of shape properties (the description reads them as written),
/// and material names an earlier object names too (a named material is
/// compiled once, from its first object). The description must not have
/// been made yet; it reads nothing that [`Program::forget_exprs`] of these
/// drops.
pub fn forgettable_spans(program: &Program) -> Vec<Span> {
    fn number(e: &Expr) -> bool {
        match &e.kind {
            ExprKind::Int(_) | ExprKind::Float(_) => true,
            ExprKind::Unary { op: UnaryOp::Neg, operand } => number(operand),
            _ => false,
        }
    }
    let Some((_, _, entries)) = root_scene(program) else { return Vec::new() };
    let mut spans = Vec::new();
    let mut named: rustc_hash::FxHashSet<&str> = Default::default();
    for entry in entries {
        let SceneEntry::Block(b) = entry else { continue };
        if b.keyword.name.as_str() != "object" {
            continue;
        }
        for p in &b.props {
            let Some(e) = &p.value else { continue };
            // As `Describer::shape` reads them: `vec3` and `float`, whose
            // literals `literal_words` takes as written.
            let forget = match p.name.name.as_str() {
                "center" | "point" | "normal" | "corner" | "edge1" | "edge2" | "min" | "max" | "base" | "axis" => {
                    matches!(&e.kind, ExprKind::Tuple(items) if items.len() == 3 && items.iter().all(number))
                }
                "radius" | "tile" | "height" => number(e),
                "material" => match &e.kind {
                    ExprKind::Name(n) => {
                        let material = program
                            .symbols
                            .get(n.as_str())
                            .is_some_and(|s| matches!(s.kind, SymbolKind::Material | SymbolKind::MaterialTree));
                        material && !named.insert(n.as_str())
                    }
                    _ => false,
                },
                _ => false,
            };
            if forget {
                spans.push(e.span);
            }
        }
    }
    spans
}

/// Drops the syntax of the scene's objects that `desc` (the program's
/// scene, described) no longer needs, with the types and resolutions of
/// their expressions: every object block but those whose material a
/// renderer compiles from the syntax (a material that is not a plain name,
/// and the first object of each material name). Objects naming a material
/// an earlier object names get that object's [`MaterialRef`]. The scene
/// can then not be described again (at another frame); returns whether
/// anything was dropped (not when the program's syntax is shared).
pub fn drop_object_syntax(program: &mut Program, desc: &mut SceneDesc) -> bool {
    let Some((module, item, _)) = root_scene(program) else { return false };
    let Some(ast) = Arc::get_mut(&mut program.loaded.modules[module].ast) else { return false };
    let Some(Item::Scene(scene)) = ast.items.get_mut(item) else { return false };
    let object_entry = |m: &MaterialRef| match *m {
        MaterialRef::SceneValue { module: m, item: i, entry, .. } if (m as usize, i as usize) == (module, item) => {
            Some(entry as usize)
        }
        _ => None,
    };
    // The entries kept: every one that is not an object block, and the
    // objects whose materials are compiled from their syntax.
    let mut keep: Vec<bool> = scene
        .entries
        .iter()
        .map(|e| !matches!(e, SceneEntry::Block(b) if b.keyword.name.as_str() == "object"))
        .collect();
    let mut first_of: FxHashMap<Arc<str>, MaterialRef> = FxHashMap::default();
    for o in &desc.objects {
        let Surface::Material(m) = &o.surface else { continue };
        let Some(entry) = object_entry(&m.material) else { continue };
        let first = match &m.name {
            Some(name) => !first_of.contains_key(name),
            None => true,
        };
        if first {
            keep[entry] = true;
            if let Some(name) = &m.name {
                first_of.insert(name.clone(), m.material);
            }
        }
    }
    // The new index of each kept entry, by its old one.
    let mut new_index = vec![u32::MAX; keep.len()];
    let mut dropped = Vec::new();
    let old = std::mem::take(&mut scene.entries);
    for (k, entry) in old.into_iter().enumerate() {
        if keep[k] {
            new_index[k] = scene.entries.len() as u32;
            scene.entries.push(entry);
        } else if let SceneEntry::Block(b) = &entry {
            dropped.push(b.span);
        }
    }
    scene.entries.shrink_to_fit();
    let renumber = |m: MaterialRef| match m {
        MaterialRef::SceneValue { module, item, entry, prop } => {
            MaterialRef::SceneValue { module, item, entry: new_index[entry as usize], prop }
        }
        other => other,
    };
    for o in &mut desc.objects {
        let Surface::Material(m) = &mut o.surface else { continue };
        if object_entry(&m.material).is_none() {
            continue;
        }
        m.material = match m.name.as_ref().and_then(|n| first_of.get(n)) {
            Some(first) => renumber(*first),
            None => renumber(m.material),
        };
    }
    program.forget_exprs(&dropped);
    true
}

/// The root program's scene's module, item and entries.
fn root_scene(program: &Program) -> Option<(usize, usize, &[SceneEntry])> {
    super::root_scene(program).map(|(m, i, scene)| (m, i, &scene.entries[..]))
}
