//! Completion: names in scope, builtins and the stdlib with their
//! parameter lists, named arguments at a call, interface methods inside
//! a material, and scene blocks and properties inside `scene { }`.

use super::analysis::{Analysis, item_params, type_text};
use super::context::{Call, Context, Place};
use super::hover::{builtin_hover, builtin_signature};
use crate::check::{
    BUILTINS, GLOBALS, INTERFACE, SAMPLE_FIELDS, Symbol, SymbolKind, builtin, scene_blocks, scene_kinds,
    scene_properties,
};
use crate::syntax::ast::Item;
use lsp_types::{
    CompletionItem, CompletionItemKind, CompletionItemLabelDetails, Documentation, InsertTextFormat, MarkupContent,
    MarkupKind,
};

const TYPES: &[&str] =
    &["float", "int", "bool", "color", "vector", "point", "normal", "vec2", "matrix", "bsdf_sample", "string"];
const STATEMENT_KEYWORDS: &[&str] = &["return", "if", "else", "for", "in", "break", "continue", "true", "false"];
const ITEM_KEYWORDS: &[&str] = &["material", "const", "scene", "import", "void"];

/// How items are inserted: snippets with placeholders when the client takes them.
pub struct Completer<'a> {
    pub analysis: &'a Analysis,
    pub snippets: bool,
}

fn markdown(value: String) -> Documentation {
    Documentation::MarkupContent(MarkupContent { kind: MarkupKind::Markdown, value })
}

fn item(label: &str, kind: CompletionItemKind, sort: u8) -> CompletionItem {
    CompletionItem {
        label: label.to_string(),
        kind: Some(kind),
        sort_text: Some(format!("{sort}{label}")),
        ..CompletionItem::default()
    }
}

impl Completer<'_> {
    fn snippet(&self, mut c: CompletionItem, snippet: String, plain: &str) -> CompletionItem {
        if self.snippets {
            c.insert_text = Some(snippet);
            c.insert_text_format = Some(InsertTextFormat::SNIPPET);
        } else if plain != c.label {
            c.insert_text = Some(plain.to_string());
        }
        c
    }

    /// The completions at a context.
    pub fn complete(&self, cx: &Context) -> Vec<CompletionItem> {
        if let Some(base) = &cx.member_of {
            return self.fields(cx, base.as_deref());
        }
        match &cx.place {
            Place::TopLevel => self.top_level(),
            Place::Scene => self.scene(),
            Place::SceneKind(keyword) => self.scene_kinds(keyword),
            Place::SceneBlock { keyword, kind, given } => self.scene_props(Some(keyword), kind.as_deref(), given),
            Place::SceneValue { block, prop } => self.scene_value(block.as_ref(), prop),
            Place::MaterialBody { defined, return_type } => self.methods(defined, return_type.as_deref()),
            Place::Code { in_material } => self.code(cx, *in_material),
        }
    }

    fn top_level(&self) -> Vec<CompletionItem> {
        let mut out: Vec<CompletionItem> =
            ITEM_KEYWORDS.iter().map(|k| item(k, CompletionItemKind::KEYWORD, 1)).collect();
        out.extend(TYPES.iter().map(|t| item(t, CompletionItemKind::KEYWORD, 1)));
        out
    }

    fn code(&self, cx: &Context, in_material: bool) -> Vec<CompletionItem> {
        let mut out = Vec::new();
        if let Some(call) = cx.call.as_ref().filter(|c| c.at_start && c.innermost) {
            out.extend(self.named_args(call));
        }
        for local in cx.locals.iter().rev() {
            if out.iter().any(|c: &CompletionItem| c.label == local.name) {
                continue;
            }
            let mut c = item(&local.name, CompletionItemKind::VARIABLE, 1);
            c.detail = Some(format!("{} {}", local.ty, local.name));
            out.push(c);
        }
        for (name, ty, meaning) in GLOBALS {
            let mut c = item(name, CompletionItemKind::VARIABLE, 3);
            c.detail = Some(format!("{ty} {name}"));
            c.documentation = Some(markdown(format!("shading global: {meaning}")));
            out.push(c);
        }
        if in_material {
            for m in INTERFACE {
                let mut c = item(m.name, CompletionItemKind::METHOD, 2);
                c.detail = Some(m.signature());
                c.documentation =
                    Some(markdown(format!("this material's own `{}` (its default: `{}`)", m.name, m.default)));
                out.push(self.call_snippet(c, m.name, m.params.iter().map(|p| p.0)));
            }
        }
        out.extend(self.items(|_| true));
        out.extend(self.builtins());
        out.extend(TYPES.iter().map(|t| item(t, CompletionItemKind::KEYWORD, 5)));
        out.extend(STATEMENT_KEYWORDS.iter().map(|k| item(k, CompletionItemKind::KEYWORD, 5)));
        out
    }

    /// `name(required, ...)` with placeholders for the required parameters.
    fn call_snippet<'p>(
        &self,
        c: CompletionItem,
        name: &str,
        required: impl Iterator<Item = &'p str>,
    ) -> CompletionItem {
        let params: Vec<String> = required.enumerate().map(|(k, p)| format!("${{{}:{p}}}", k + 1)).collect();
        let snippet =
            if params.is_empty() { format!("{name}($0)") } else { format!("{name}({})$0", params.join(", ")) };
        self.snippet(c, snippet, name)
    }

    /// The global definitions the document sees (its own, imported and
    /// the prelude's), with signatures and documentation.
    fn items(&self, keep: impl Fn(&Symbol) -> bool) -> Vec<CompletionItem> {
        let a = self.analysis;
        let table = if a.module().is_prelude { &a.program.prelude_symbols } else { &a.program.symbols };
        let mut out = Vec::new();
        for (name, sym) in table {
            if !keep(sym) {
                continue;
            }
            let prelude = a.program.loaded.modules.get(sym.module).is_some_and(|m| m.is_prelude);
            let kind = match sym.kind {
                SymbolKind::Function => CompletionItemKind::FUNCTION,
                SymbolKind::Material => CompletionItemKind::CLASS,
                SymbolKind::MaterialTree => CompletionItemKind::VALUE,
                SymbolKind::Const => CompletionItemKind::CONSTANT,
            };
            let mut c = item(name, kind, if prelude { 3 } else { 2 });
            c.detail = a.signature(*sym);
            let mut doc = a.doc(*sym).map(|d| format!("```text\n{d}\n```\n\n")).unwrap_or_default();
            doc.push_str(&format!("`{}`", a.file_name(sym.span)));
            c.documentation = Some(markdown(doc));
            let params = a.item(*sym).and_then(item_params);
            if let Some(params) = params {
                let names: Vec<&str> = params.iter().map(|p| p.name.name.as_str()).collect();
                c.label_details = Some(CompletionItemLabelDetails {
                    detail: Some(format!("({})", names.join(", "))),
                    description: Some(a.file_name(sym.span).to_string()),
                });
            }
            let required: Vec<&str> =
                params.unwrap_or(&[]).iter().filter(|p| p.default.is_none()).map(|p| p.name.name.as_str()).collect();
            // A material whose parameters all have defaults is a value by
            // its bare name; a function is always called.
            let called = match sym.kind {
                SymbolKind::Function => true,
                SymbolKind::Material | SymbolKind::MaterialTree => !required.is_empty(),
                SymbolKind::Const => false,
            };
            out.push(if called { self.call_snippet(c, name, required.into_iter()) } else { c });
        }
        out
    }

    fn builtins(&self) -> Vec<CompletionItem> {
        BUILTINS
            .iter()
            .map(|b| {
                let mut c = item(b.name, CompletionItemKind::FUNCTION, 4);
                c.detail = Some(b.synopsis.to_string());
                c.documentation = Some(markdown(builtin_hover(b.func)));
                let names: Vec<&str> = b.params.iter().map(|p| p.name).collect();
                c.label_details = Some(CompletionItemLabelDetails {
                    detail: Some(format!("({})", names.join(", "))),
                    description: Some("builtin".into()),
                });
                let required = b.params.iter().filter(|p| !p.optional()).map(|p| p.name);
                self.call_snippet(c, b.name, required)
            })
            .collect()
    }

    /// `name:` for each parameter of the call's callee not given yet.
    fn named_args(&self, call: &Call) -> Vec<CompletionItem> {
        let a = self.analysis;
        let params: Vec<(String, String, Option<String>)> = if let Some(sym) = a.symbol(&call.callee) {
            let Some(item) = a.item(sym) else { return Vec::new() };
            let doc = a.doc(sym);
            item_params(item)
                .unwrap_or(&[])
                .iter()
                .map(|p| {
                    let meaning = doc.as_deref().and_then(|d| super::docs::param_doc(d, &p.name.name));
                    (p.name.name.to_string(), a.param_text(p), meaning)
                })
                .collect()
        } else if let Some(b) = builtin(&call.callee) {
            b.params
                .iter()
                .map(|p| {
                    let text = p.default.map_or(p.name.to_string(), |d| format!("{} = {d}", p.name));
                    (p.name.to_string(), text, None)
                })
                .collect()
        } else {
            return Vec::new();
        };
        params
            .into_iter()
            .enumerate()
            // Positional arguments before the cursor bind the first parameters.
            .filter(|(k, (name, _, _))| *k >= call.index.saturating_sub(call.named.len()) && !call.named.contains(name))
            .map(|(k, (name, text, meaning))| {
                let label = format!("{name}:");
                let mut c = item(&label, CompletionItemKind::FIELD, 0);
                c.sort_text = Some(format!("0{k:03}"));
                c.filter_text = Some(name.clone());
                c.detail = Some(text);
                c.documentation = meaning.map(markdown);
                c.insert_text = Some(format!("{name}: "));
                c.preselect = Some(k == 0);
                c
            })
            .collect()
    }

    /// Interface methods a material does not define yet, with their
    /// signatures and an empty body; after a return type, those returning it.
    fn methods(&self, defined: &[String], return_type: Option<&str>) -> Vec<CompletionItem> {
        INTERFACE
            .iter()
            .filter(|m| !defined.iter().any(|d| d == m.name))
            .filter(|m| return_type.is_none_or(|t| m.ret.to_string() == t))
            .map(|m| {
                let mut c = item(m.name, CompletionItemKind::METHOD, 0);
                c.detail = Some(m.signature());
                let meaning = super::docs::method_doc(m.name).unwrap_or_default();
                c.documentation = Some(markdown(format!("{meaning}\n\nDefault: `{}`", m.default)));
                let signature = m.signature();
                let head = match return_type {
                    Some(_) => signature.split_once(' ').map_or(signature.as_str(), |s| s.1),
                    None => &signature,
                };
                self.snippet(c, format!("{head} {{\n\t$0\n}}"), head)
            })
            .collect()
    }

    fn fields(&self, cx: &Context, base: Option<&str>) -> Vec<CompletionItem> {
        let a = self.analysis;
        let ty: Option<String> = base.and_then(|name| {
            cx.locals.iter().rev().find(|l| l.name == name).map(|l| l.ty.clone()).or_else(|| {
                GLOBALS.iter().find(|g| g.0 == name).map(|g| g.1.to_string()).or_else(|| {
                    let sym = a.symbol(name)?;
                    match a.item(sym)? {
                        Item::Const(c) => Some(type_text(&c.ty)),
                        _ => None,
                    }
                })
            })
        });
        let triple = [("x", "float"), ("y", "float"), ("z", "float")];
        let fields: Vec<(String, String)> = match ty.as_deref() {
            Some("vector" | "point" | "normal") => triple.iter().map(|(n, t)| (n.to_string(), t.to_string())).collect(),
            Some("vec2" | "uv") => triple[..2].iter().map(|(n, t)| (n.to_string(), t.to_string())).collect(),
            Some("bsdf_sample") => SAMPLE_FIELDS.iter().map(|(n, t)| (n.to_string(), t.to_string())).collect(),
            Some(_) => Vec::new(),
            None => triple
                .iter()
                .map(|(n, t)| (n.to_string(), t.to_string()))
                .chain(SAMPLE_FIELDS.iter().map(|(n, t)| (n.to_string(), t.to_string())))
                .collect(),
        };
        fields
            .into_iter()
            .map(|(name, ty)| {
                let mut c = item(&name, CompletionItemKind::FIELD, 0);
                c.detail = Some(format!("{ty} {name}"));
                c
            })
            .collect()
    }

    /// Scene blocks (each kind with its required properties) and the
    /// scene's own properties.
    fn scene(&self) -> Vec<CompletionItem> {
        let mut out = Vec::new();
        for keyword in scene_blocks() {
            let kinds = scene_kinds(keyword);
            if kinds.is_empty() {
                out.push(self.block_snippet(keyword, None));
            }
            for kind in kinds {
                out.push(self.block_snippet(keyword, Some(kind)));
            }
        }
        out.extend(self.scene_props(None, None, &[]));
        out
    }

    fn block_snippet(&self, keyword: &str, kind: Option<&str>) -> CompletionItem {
        let head = kind.map_or(keyword.to_string(), |k| format!("{keyword} {k}"));
        let props = scene_properties(Some(keyword), kind);
        let mut lines = Vec::new();
        let mut alternative_given = false;
        for p in &props {
            let needed = p.required || (p.alternative && !alternative_given);
            alternative_given |= p.alternative;
            if needed {
                lines.push(format!("\t{} ${{{}}};", p.name, lines.len() + 1));
            }
        }
        let mut c = item(&head, CompletionItemKind::MODULE, 0);
        c.filter_text = Some(head.clone());
        c.detail = Some(format!("{head} {{ ... }}"));
        let described: Vec<String> = props.iter().map(|p| format!("- `{}`: {}", p.name, p.takes)).collect();
        c.documentation = Some(markdown(described.join("\n")));
        let body = if lines.is_empty() { "\t$0".to_string() } else { lines.join("\n") };
        self.snippet(c, format!("{head} {{\n{body}\n}}"), &head)
    }

    fn scene_kinds(&self, keyword: &str) -> Vec<CompletionItem> {
        scene_kinds(keyword)
            .into_iter()
            .map(|kind| {
                let mut c = self.block_snippet(keyword, Some(kind));
                // Only the kind and the body remain to be written.
                if let Some(text) = c.insert_text.take() {
                    c.insert_text = Some(text.trim_start_matches(keyword).trim_start().to_string());
                }
                c.label = kind.to_string();
                c.filter_text = Some(kind.to_string());
                c.sort_text = Some(format!("0{kind}"));
                c
            })
            .collect()
    }

    fn scene_props(&self, keyword: Option<&str>, kind: Option<&str>, given: &[String]) -> Vec<CompletionItem> {
        scene_properties(keyword.map(|k| k as &str), kind)
            .into_iter()
            .filter(|p| p.repeats || !given.iter().any(|g| g == p.name))
            .map(|p| {
                let mut c = item(p.name, CompletionItemKind::PROPERTY, if p.required { 0 } else { 1 });
                let need = if p.required {
                    "required"
                } else if p.alternative {
                    "this or an alternative is required"
                } else {
                    "optional"
                };
                c.detail = Some(format!("{}: {} ({need})", p.name, p.takes));
                self.snippet(c, format!("{} $0;", p.name), p.name)
            })
            .collect()
    }

    fn scene_value(&self, block: Option<&(String, Option<String>)>, prop: &str) -> Vec<CompletionItem> {
        let (keyword, kind) = block.map_or((None, None), |(k, kind)| (Some(k.as_str()), kind.as_deref()));
        let props = scene_properties(keyword, kind);
        let choices = props.iter().find(|p| p.name == prop).map_or(&[][..], |p| p.choices);
        if !choices.is_empty() {
            return choices
                .iter()
                .map(|choice| {
                    let mut c = item(&format!("\"{choice}\""), CompletionItemKind::ENUM_MEMBER, 0);
                    c.detail = Some(format!("{prop} \"{choice}\""));
                    c
                })
                .collect();
        }
        if prop == "material" {
            let mut out = self.items(|s| matches!(s.kind, SymbolKind::Material | SymbolKind::MaterialTree));
            out.extend(BUILTINS.iter().filter(|b| b.func.tree_node().is_some()).map(|b| {
                let mut c = item(b.name, CompletionItemKind::FUNCTION, 4);
                c.detail = Some(builtin_signature(b.func));
                self.call_snippet(c, b.name, b.params.iter().filter(|p| !p.optional()).map(|p| p.name))
            }));
            return out;
        }
        let mut out = self.items(|s| !matches!(s.kind, SymbolKind::Material | SymbolKind::MaterialTree));
        out.extend(self.builtins());
        out
    }
}
