//! Shade trees are DAGs: cycles among items, and constants that vary
//! from one shading point to the next.

use super::*;
use rustc_hash::FxHashSet;

impl<'a> Checker<'a> {
    /// Shade trees are DAGs: any cycle among functions, materials, methods,
    /// trees and constants is an error, reported once per cycle.
    pub(super) fn report_recursion(&mut self) {
        let mut nodes: Vec<Node> = self.graph.keys().cloned().collect();
        // Distinct keys: an unstable sort gives the one order.
        nodes.sort_unstable();
        let mut state: FxHashMap<Node, u8> = FxHashMap::default();
        for start in nodes {
            if state.contains_key(&start) {
                continue;
            }
            let mut stack: Vec<(Node, usize, Option<Span>)> = vec![(start, 0, None)];
            state.insert(start, 1);
            while let Some((node, next, _)) = stack.last().cloned() {
                let out = self.dependencies(&node);
                if let Some((to, span)) = out.get(next).cloned() {
                    if let Some(top) = stack.last_mut() {
                        top.1 += 1;
                    }
                    match state.get(&to).copied().unwrap_or(0) {
                        0 => {
                            state.insert(to, 1);
                            stack.push((to, 0, Some(span)));
                        }
                        1 => {
                            let pos = stack.iter().position(|(n, _, _)| *n == to).unwrap_or(0);
                            let mut path: Vec<String> = stack[pos..].iter().map(|(n, _, _)| self.describe(n)).collect();
                            path.push(self.describe(&to));
                            let cycle: Vec<&Node> = stack[pos..].iter().map(|(n, _, _)| n).collect();
                            let d = self.cycle_diagnostic(&cycle, &to, span, path);
                            self.diags.push(d);
                        }
                        _ => {}
                    }
                } else {
                    state.insert(node, 2);
                    stack.pop();
                }
            }
        }
    }

    /// What `node` uses, in the order of first use.
    fn dependencies(&self, node: &Node) -> &[(Node, Span)] {
        self.graph.get(node).map_or(&[], |e| e.list.as_slice())
    }

    pub(super) fn is_const(&self, node: &Node) -> bool {
        let (m, i) = node.id();
        matches!(node, Node::Item(..)) && matches!(self.loaded.modules[m].ast.items[i], Item::Const(_))
    }

    pub(super) fn cycle_diagnostic(&self, cycle: &[&Node], to: &Node, span: Span, path: Vec<String>) -> Diagnostic {
        if cycle.iter().all(|n| self.is_const(n)) {
            let msg = if cycle.len() == 1 {
                format!("constant {} is defined in terms of itself", self.describe(to))
            } else {
                "these constants are defined in terms of each other".to_string()
            };
            return Diagnostic::error(span, msg).with_note(format!("cycle: {}", path.join(" -> ")));
        }
        let msg = if cycle.len() == 1 {
            format!("{} calls itself: recursion is not allowed", self.describe(to))
        } else {
            "recursion is not allowed: these definitions call each other".to_string()
        };
        let mut d = Diagnostic::error(span, msg).with_note(format!("cycle: {}", path.join(" -> ")));
        // The default `ambient` calls `diffuse`; say so when that closes the cycle.
        let default_ambient = cycle.iter().find_map(|n| match n {
            Node::Method((m, i), "ambient") => match &self.loaded.modules[*m].ast.items[*i] {
                Item::Material(def) if !def.methods.iter().any(|f| f.name.name == "ambient") => {
                    Some(def.name.name.clone())
                }
                _ => None,
            },
            _ => None,
        });
        if let Some(material) = default_ambient {
            d = d
                .with_note(format!("`{material}` does not define `ambient`; its default is `light * diffuse()`"))
                .with_help(format!("define `ambient` in `{material}`, or do not call `ambient` from `diffuse`"));
        } else {
            d = d
                .with_help("shade trees are acyclic so every shader terminates; compute iteratively with a `for` loop");
        }
        d
    }

    /// The path of dependencies from `start` to the first node `reads`
    /// gives a span for (depth first; constants on the way are skipped
    /// when `skip_consts`, as they are reported for themselves), with that
    /// span and the span of `start`'s first step on the path.
    fn path_to(
        &self,
        start: &Node,
        skip_consts: bool,
        reads: impl Fn(&Node) -> Option<Span>,
    ) -> Option<(Vec<Node>, Span, Span)> {
        let mut seen: rustc_hash::FxHashSet<Node> = Default::default();
        let mut stack: Vec<(Node, usize)> = vec![(*start, 0)];
        seen.insert(*start);
        while let Some((node, next)) = stack.last().cloned() {
            if let Some(read) = reads(&node).filter(|_| stack.len() > 1) {
                let path: Vec<Node> = stack.iter().map(|(n, _)| *n).collect();
                let out = self.dependencies(start);
                let first_use = out.iter().find(|(n, _)| path.get(1) == Some(n)).map(|(_, span)| *span)?;
                return Some((path, read, first_use));
            }
            let out = self.dependencies(&node);
            match out.get(next) {
                Some((to, _)) => {
                    if let Some(top) = stack.last_mut() {
                        top.1 += 1;
                    }
                    if seen.insert(*to) && !(skip_consts && self.is_const(to)) {
                        stack.push((*to, 0));
                    }
                }
                None => {
                    stack.pop();
                }
            }
        }
        None
    }

    /// The code (functions, materials, methods: not constants, not scene
    /// values) from which a path through such code reaches a read of a
    /// shading global: a search backwards from the readers, linear in the
    /// graph.
    fn reaching_point_readers(&self) -> FxHashSet<Node> {
        let mut callers: FxHashMap<&Node, Vec<&Node>> = FxHashMap::default();
        for (from, out) in &self.graph {
            // Constants and scene values are the roots asked about.
            if self.is_const(from) || matches!(from, Node::SceneValue(..)) {
                continue;
            }
            for (to, _) in &out.list {
                callers.entry(to).or_default().push(from);
            }
        }
        let mut found: FxHashSet<Node> = FxHashSet::default();
        let mut stack: Vec<&Node> = self.reads_globals.keys().filter(|n| !self.is_const(n)).collect();
        while let Some(n) = stack.pop() {
            if !found.insert(*n) {
                continue;
            }
            stack.extend(callers.get(n).into_iter().flatten().copied());
        }
        found
    }

    /// A constant or a scene value (other than a material) may not depend
    /// on the shading point, not even through the functions it calls; a
    /// render setting may not depend on the frame (the `time` mapping may
    /// read `frame`).
    ///
    /// Constants on the way are not followed: a constant that reads the
    /// point is reported for itself, once, and a value that uses it is not
    /// (as an ill-typed expression is reported once). So the search is
    /// linear in the graph, however many constants use one another.
    pub(super) fn report_varying_values(&mut self) {
        let is_root = |n: &Node| self.is_const(n) || matches!(n, Node::SceneValue(..));
        let varying = self.reaching_point_readers();
        // Only the roots that use varying code, in a fixed order.
        let mut roots: Vec<Node> = self
            .graph
            .iter()
            .filter(|(n, e)| is_root(n) && e.list.iter().any(|(to, _)| varying.contains(to)))
            .map(|(n, _)| *n)
            .collect();
        roots.sort();
        for start in roots {
            let scene = matches!(start, Node::SceneValue(..));
            // A direct read was refused where it is written.
            let Some((path, read, first_use)) = self.path_to(&start, true, |n| self.reads_globals.get(n).copied())
            else {
                continue;
            };
            let reader = &path[path.len() - 1];
            let names: Vec<String> = path.iter().map(|n| self.describe(n)).collect();
            let (what, help) = if scene {
                ("scene value", "scene values are fixed for a frame; only a `material` may vary over the surface")
            } else {
                ("constant", "a constant is fixed for a frame; make it a function instead")
            };
            self.diags.push(
                Diagnostic::error(first_use, format!("{what} {} depends on the shading point", self.describe(&start)))
                    .with_label(read, format!("{} reads a shading global here", self.describe(reader)))
                    .with_note(format!("through {}", names.join(" -> ")))
                    .with_help(help),
            );
        }
        let mut limited: Vec<(Node, FrameGlobals)> = self.frame_limits.iter().map(|(n, l)| (*n, *l)).collect();
        limited.sort_by_key(|a| a.0);
        for (start, limit) in limited {
            let refused = |name: &str| limit == FrameGlobals::Neither || name == "time";
            let reads =
                |n: &Node| FRAME_GLOBALS.iter().find_map(|g| self.reads_frame.get(&(*n, *g)).filter(|_| refused(g)));
            let Some((path, read, first_use)) = self.path_to(&start, false, |n| reads(n).map(|r| r.0)) else {
                continue;
            };
            let reader = &path[path.len() - 1];
            let global = reads(reader).map_or("frame", |r| r.1);
            let names: Vec<String> = path.iter().map(|n| self.describe(n)).collect();
            let (message, help) = if limit == FrameGlobals::FrameOnly {
                ("the `time` mapping depends on `time`".to_string(), "it defines `time`: compute it from `frame`")
            } else {
                (
                    format!("render setting {} depends on the frame", self.describe(&start)),
                    "render settings hold for every frame of an animation",
                )
            };
            self.diags.push(
                Diagnostic::error(first_use, message)
                    .with_label(read, format!("{} reads `{global}` here", self.describe(reader)))
                    .with_note(format!("through {}", names.join(" -> ")))
                    .with_help(help),
            );
        }
    }
}
