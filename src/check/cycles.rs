//! Shade trees are DAGs: cycles among items, and constants that vary
//! from one shading point to the next.

use super::*;

impl<'a> Checker<'a> {
    /// Shade trees are DAGs: any cycle among functions, materials, methods,
    /// trees and constants is an error, reported once per cycle.
    pub(super) fn report_recursion(&mut self) {
        let mut nodes: Vec<Node> = self.graph.keys().cloned().collect();
        nodes.sort();
        let mut state: HashMap<Node, u8> = HashMap::new();
        for start in nodes {
            if state.contains_key(&start) {
                continue;
            }
            let mut stack: Vec<(Node, usize, Option<Span>)> = vec![(start.clone(), 0, None)];
            state.insert(start, 1);
            while let Some((node, next, _)) = stack.last().cloned() {
                let out = self.graph.get(&node).map(Vec::as_slice).unwrap_or(&[]);
                if let Some((to, span)) = out.get(next).cloned() {
                    if let Some(top) = stack.last_mut() {
                        top.1 += 1;
                    }
                    match state.get(&to).copied().unwrap_or(0) {
                        0 => {
                            state.insert(to.clone(), 1);
                            stack.push((to, 0, Some(span)));
                        }
                        1 => {
                            let pos = stack.iter().position(|(n, _, _)| *n == to).unwrap_or(0);
                            let mut path: Vec<String> = stack[pos..].iter().map(|(n, _, _)| n.describe()).collect();
                            path.push(to.describe());
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

    pub(super) fn is_const(&self, node: &Node) -> bool {
        let (m, i) = node.id();
        matches!(node, Node::Item(..)) && matches!(self.loaded.modules[m].ast.items[i], Item::Const(_))
    }

    pub(super) fn cycle_diagnostic(&self, cycle: &[&Node], to: &Node, span: Span, path: Vec<String>) -> Diagnostic {
        if cycle.iter().all(|n| self.is_const(n)) {
            let msg = if cycle.len() == 1 {
                format!("constant {} is defined in terms of itself", to.describe())
            } else {
                "these constants are defined in terms of each other".to_string()
            };
            return Diagnostic::error(span, msg).with_note(format!("cycle: {}", path.join(" -> ")));
        }
        let msg = if cycle.len() == 1 {
            format!("{} calls itself: recursion is not allowed", to.describe())
        } else {
            "recursion is not allowed: these definitions call each other".to_string()
        };
        let mut d = Diagnostic::error(span, msg).with_note(format!("cycle: {}", path.join(" -> ")));
        // The default `ambient` calls `diffuse`; say so when that closes the cycle.
        let default_ambient = cycle.iter().find_map(|n| match n {
            Node::Method((m, i), name, "ambient") => match &self.loaded.modules[*m].ast.items[*i] {
                Item::Material(def) if !def.methods.iter().any(|f| f.name.name == "ambient") => Some(name.clone()),
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

    /// A constant may not depend on the shading point, not even through the
    /// functions it calls.
    pub(super) fn report_varying_constants(&mut self) {
        let mut consts: Vec<Node> = self.graph.keys().filter(|n| self.is_const(n)).cloned().collect();
        consts.sort();
        for start in consts {
            // Depth-first search for a node that reads a global, keeping the
            // path for the message.
            let mut seen: HashMap<Node, ()> = HashMap::new();
            let mut stack: Vec<(Node, usize)> = vec![(start.clone(), 0)];
            seen.insert(start.clone(), ());
            let mut found: Option<Vec<Node>> = None;
            while let Some((node, next)) = stack.last().cloned() {
                if self.reads_globals.contains_key(&node) {
                    found = Some(stack.iter().map(|(n, _)| n.clone()).collect());
                    break;
                }
                let out = self.graph.get(&node).map(Vec::as_slice).unwrap_or(&[]);
                match out.get(next) {
                    Some((to, _)) => {
                        if let Some(top) = stack.last_mut() {
                            top.1 += 1;
                        }
                        if seen.insert(to.clone(), ()).is_none() {
                            stack.push((to.clone(), 0));
                        }
                    }
                    None => {
                        stack.pop();
                    }
                }
            }
            let Some(path) = found else { continue };
            let Some(first_use) = self
                .graph
                .get(&start)
                .and_then(|out| out.iter().find(|(n, _)| path.get(1) == Some(n)).map(|(_, span)| *span))
            else {
                continue;
            };
            let reader = &path[path.len() - 1];
            let global_span = self.reads_globals[reader];
            let names: Vec<String> = path.iter().map(Node::describe).collect();
            self.diags.push(
                Diagnostic::error(first_use, format!("constant {} depends on the shading point", start.describe()))
                    .with_label(global_span, format!("{} reads a shading global here", reader.describe()))
                    .with_note(format!("through {}", names.join(" -> ")))
                    .with_help("a constant is fixed before shading starts; make it a function instead"),
            );
        }
    }
}
