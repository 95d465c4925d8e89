//! Where the cursor is, from the tokens before it: completion and
//! signature help are asked while a line is half typed, when the parser
//! has nothing to say about it. One pass over the tokens tracks open
//! brackets (what each `{` opened: the scene, a scene block, a material's
//! body, code), the call each `(` belongs to and its arguments so far,
//! and the locals declared in the blocks still open.

use crate::syntax::lexer::{Lexer, Tok};

/// What the cursor is in.
#[derive(Debug, Clone, PartialEq)]
pub enum Place {
    /// Between items.
    TopLevel,
    /// Directly inside `scene { }`, where blocks and the scene's own
    /// properties go.
    Scene,
    /// After `light` or `object` in a scene, where its kind goes.
    SceneKind(String),
    /// Inside a scene block, where its properties go; `given` are those
    /// already written.
    SceneBlock { keyword: String, kind: Option<String>, given: Vec<String> },
    /// The value of a scene property (`block` is `None` in the scene itself).
    SceneValue { block: Option<(String, Option<String>)>, prop: String },
    /// Inside `material name(...) { }` between methods; `defined` are the
    /// interface methods it already has, `return_type` the type just
    /// written before the method's name, if any.
    MaterialBody { defined: Vec<String>, return_type: Option<String> },
    /// Inside code: a body, a tree or constant's value, a default.
    Code { in_material: bool },
}

/// The innermost call whose argument list holds the cursor.
#[derive(Debug, Clone, PartialEq)]
pub struct Call {
    /// The function, material, builtin or type keyword called.
    pub callee: String,
    /// Arguments before the current one.
    pub index: usize,
    /// Names given to arguments so far (`name:`), the current one's too.
    pub named: Vec<String>,
    /// The current argument's name, when it starts with `name:`.
    pub current_name: Option<String>,
    /// Whether the cursor is where an argument starts (nothing but the
    /// word being typed since `(` or `,`), so `name:` may be offered.
    pub at_start: bool,
    /// Whether the call is the innermost bracket (not inside `[...]` or a
    /// nested tuple of the argument).
    pub innermost: bool,
}

/// A local declared before the cursor in a block still open.
#[derive(Debug, Clone, PartialEq)]
pub struct Local {
    pub name: String,
    pub ty: String,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Context {
    pub place: Place,
    pub call: Option<Call>,
    /// The word being typed and its byte start (empty at a fresh position).
    pub prefix: String,
    pub prefix_start: usize,
    /// After `base.`: the name or call before the dot (`None` for other
    /// expressions).
    pub member_of: Option<Option<String>>,
    pub locals: Vec<Local>,
}

#[derive(Debug, Clone)]
enum Frame {
    Scene,
    SceneBlock { keyword: String, kind: Option<String>, given: Vec<String> },
    Material { defined: Vec<String> },
    Code,
    Paren { callee: Option<String>, definition: bool, commas: usize, named: Vec<String>, arg_start: usize },
    Bracket,
}

impl Frame {
    fn is_brace(&self) -> bool {
        !matches!(self, Frame::Paren { .. } | Frame::Bracket)
    }
}

/// The type a keyword names (its text, from the lexer), if it names one.
fn type_keyword(t: &Tok) -> Option<&'static str> {
    use Tok::*;
    let names_a_type = matches!(
        t,
        KwFloat
            | KwInt
            | KwBool
            | KwColor
            | KwVector
            | KwPoint
            | KwNormal
            | KwVec2
            | KwUv
            | KwMatrix
            | KwBsdfSample
            | KwString
            | KwVoid
            | Material
    );
    names_a_type.then(|| t.text())
}

fn ident(t: &Tok) -> Option<&str> {
    match t {
        Tok::Ident(s) => Some(s),
        _ => None,
    }
}

/// The context of byte `offset` of `text`.
pub fn context_at(text: &str, offset: usize) -> Context {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &text[..offset];
    let mut tokens: Vec<(usize, Tok, usize)> = Lexer::new(before).filter_map(Result::ok).collect();
    // The word being typed is not context.
    let (prefix, prefix_start) = match tokens.last() {
        Some((s, t, e)) if *e == offset && (ident(t).is_some() || type_keyword(t).is_some() || is_keyword(t)) => {
            let word = before[*s..*e].to_string();
            let start = *s;
            tokens.pop();
            (word, start)
        }
        _ => (String::new(), offset),
    };
    let mut scan = Scan::default();
    for k in 0..tokens.len() {
        scan.token(&tokens, k);
    }
    let member_of = match tokens.last() {
        Some((_, Tok::Dot, _)) => Some(match tokens.len().checked_sub(2).map(|k| &tokens[k].1) {
            Some(Tok::Ident(name)) => Some(name.to_string()),
            _ => None,
        }),
        _ => None,
    };
    let statement = scan.statement_tokens(&tokens);
    let place = scan.place(&tokens, statement);
    let call = scan.call(&tokens);
    let locals = scan.locals.iter().map(|(l, _)| l.clone()).collect();
    Context { place, call, prefix, prefix_start, member_of, locals }
}

fn is_keyword(t: &Tok) -> bool {
    matches!(
        t,
        Tok::Import
            | Tok::Scene
            | Tok::Const
            | Tok::If
            | Tok::Else
            | Tok::For
            | Tok::In
            | Tok::While
            | Tok::Break
            | Tok::Continue
            | Tok::Return
            | Tok::True
            | Tok::False
    )
}

#[derive(Default)]
struct Scan {
    stack: Vec<Frame>,
    /// Locals and the number of braces open where they were declared;
    /// parameters count one more (the body they belong to).
    locals: Vec<(Local, usize)>,
    /// Index of the token after the last `;`, `{` or `}` at each depth:
    /// where the current statement started.
    statement_start: usize,
}

impl Scan {
    fn braces(&self) -> usize {
        self.stack.iter().filter(|f| f.is_brace()).count()
    }

    fn token(&mut self, toks: &[(usize, Tok, usize)], k: usize) {
        let tok = &toks[k].1;
        let prev = |n: usize| k.checked_sub(n).map(|i| &toks[i].1);
        match tok {
            Tok::LBrace => {
                let frame = self.brace_kind(toks, k);
                self.stack.push(frame);
                self.statement_start = k + 1;
            }
            Tok::RBrace => {
                if let Some(at) = self.stack.iter().rposition(Frame::is_brace) {
                    self.stack.truncate(at);
                }
                let depth = self.braces();
                self.locals.retain(|(_, d)| *d <= depth);
                self.statement_start = k + 1;
                self.note_method_end(toks, k);
            }
            Tok::LParen => {
                let (callee, definition) = match (prev(1), prev(2)) {
                    (Some(Tok::Ident(name)), p2) => {
                        let definition = p2.is_some_and(|t| type_keyword(t).is_some() || *t == Tok::RBracket);
                        (Some(name.to_string()), definition)
                    }
                    (Some(t), _) if type_keyword(t).is_some() => (type_keyword(t).map(String::from), false),
                    _ => (None, false),
                };
                self.stack.push(Frame::Paren { callee, definition, commas: 0, named: Vec::new(), arg_start: k + 1 });
            }
            Tok::RParen => {
                if let Some(at) = self.stack.iter().rposition(|f| matches!(f, Frame::Paren { .. })) {
                    self.stack.truncate(at);
                }
            }
            Tok::LBracket => self.stack.push(Frame::Bracket),
            Tok::RBracket => {
                if let Some(at) = self.stack.iter().rposition(|f| matches!(f, Frame::Bracket)) {
                    self.stack.truncate(at);
                }
            }
            Tok::Comma => {
                if let Some(Frame::Paren { commas, arg_start, .. }) = self.stack.last_mut() {
                    *commas += 1;
                    *arg_start = k + 1;
                }
            }
            Tok::Colon => {
                if let (Some(Tok::Ident(name)), Some(Frame::Paren { named, arg_start, .. })) =
                    (prev(1), self.stack.last_mut())
                    && *arg_start + 1 == k
                {
                    named.push(name.to_string());
                }
            }
            Tok::Semi => {
                self.statement_start = k + 1;
                // Parameters of a tree template end with its item.
                let depth = self.braces();
                if !self.stack.last().is_some_and(|f| matches!(f, Frame::Paren { .. })) {
                    self.locals.retain(|(_, d)| *d <= depth);
                }
                let first = toks.get(self.statement_start_of(toks, k)).map(|t| &t.1);
                if let Some(Frame::SceneBlock { given, .. }) = self.stack.last_mut()
                    && let Some(name) = first.and_then(prop_name)
                {
                    given.push(name);
                }
            }
            Tok::Ident(name) => self.declaration(toks, k, name),
            _ => {}
        }
    }

    /// The first token of the statement that ends at `end` (a `;`).
    fn statement_start_of(&self, toks: &[(usize, Tok, usize)], end: usize) -> usize {
        (0..end).rev().find(|&i| matches!(toks[i].1, Tok::Semi | Tok::LBrace | Tok::RBrace)).map_or(0, |i| i + 1)
    }

    /// `type name` declares a local (or a parameter, inside a definition's
    /// parentheses); `for name in` a loop variable. Definitions of
    /// functions and methods (`type name(`) declare nothing local.
    fn declaration(&mut self, toks: &[(usize, Tok, usize)], k: usize, name: &str) {
        let next = toks.get(k + 1).map(|t| &t.1);
        if next == Some(&Tok::LParen) {
            return;
        }
        let mut j = k;
        // `float[3] weights`
        if j >= 3 && toks[j - 1].1 == Tok::RBracket && toks[j - 3].1 == Tok::LBracket {
            j -= 3;
        }
        let depth = self.braces();
        let in_definition = matches!(self.stack.last(), Some(Frame::Paren { definition: true, .. }));
        let declared = match j.checked_sub(1).map(|i| &toks[i].1) {
            Some(t) if type_keyword(t).is_some() => {
                let array = if j < k { format!("[{}]", slice_text(toks, j + 1)) } else { String::new() };
                Some(format!("{}{array}", type_keyword(t).unwrap_or("")))
            }
            Some(Tok::For) => Some("int".to_string()),
            _ => None,
        };
        let top_level = depth == 0 && !in_definition;
        let for_loop = j.checked_sub(1).is_some_and(|i| toks[i].1 == Tok::For);
        if let (Some(ty), false) = (declared, top_level) {
            // Parameters and a loop's variable belong to the body that follows.
            let depth = if in_definition || for_loop { depth + 1 } else { depth };
            self.locals.push((Local { name: name.to_string(), ty }, depth));
        }
    }

    /// What a `{` at `k` opens, from the tokens before it.
    fn brace_kind(&self, toks: &[(usize, Tok, usize)], k: usize) -> Frame {
        let prev = |n: usize| k.checked_sub(n).map(|i| &toks[i].1);
        match self.stack.last() {
            Some(Frame::Scene) => {
                let words: Vec<&str> = toks[self.statement_start..k].iter().filter_map(|t| ident(&t.1)).collect();
                return Frame::SceneBlock {
                    keyword: words.first().map_or(String::new(), |w| w.to_string()),
                    kind: words.get(1).map(|w| w.to_string()),
                    given: Vec::new(),
                };
            }
            None if prev(1) == Some(&Tok::Scene) => return Frame::Scene,
            // `material name(params) {`: the item starts with `material`.
            None if prev(1) == Some(&Tok::RParen)
                && toks.get(self.statement_start).map(|t| &t.1) == Some(&Tok::Material)
                && toks.get(self.statement_start + 2).map(|t| &t.1) == Some(&Tok::LParen) =>
            {
                return Frame::Material { defined: Vec::new() };
            }
            _ => {}
        }
        Frame::Code
    }

    /// A method's body closed inside a material: the material has it.
    fn note_method_end(&mut self, toks: &[(usize, Tok, usize)], k: usize) {
        let Some(Frame::Material { defined }) = self.stack.last_mut() else {
            return;
        };
        // The method's name: the identifier before the first `(` of its
        // statement, which starts after the previous `}` or `{`.
        let start = (0..k)
            .rev()
            .scan(0i32, |depth, i| {
                match toks[i].1 {
                    Tok::RBrace => *depth += 1,
                    Tok::LBrace => *depth -= 1,
                    _ => {}
                }
                Some((i, *depth))
            })
            .find(|&(_, d)| d < 0)
            .map(|(i, _)| i);
        let Some(open) = start else {
            return;
        };
        let head_start = (0..open).rev().find(|&i| matches!(toks[i].1, Tok::RBrace | Tok::LBrace | Tok::Semi));
        let head = &toks[head_start.map_or(0, |i| i + 1)..open];
        if let Some(name) = head.windows(2).find(|w| w[1].1 == Tok::LParen).and_then(|w| ident(&w[0].1)) {
            defined.push(name.to_string());
        }
    }

    /// The tokens of the current statement, at the innermost brace.
    fn statement_tokens<'t>(&self, toks: &'t [(usize, Tok, usize)]) -> &'t [(usize, Tok, usize)] {
        &toks[self.statement_start.min(toks.len())..]
    }

    fn place(&self, toks: &[(usize, Tok, usize)], statement: &[(usize, Tok, usize)]) -> Place {
        let in_material = self.stack.iter().any(|f| matches!(f, Frame::Material { .. }));
        let open_parens = self.stack.iter().rev().take_while(|f| !f.is_brace()).count();
        if open_parens > 0 {
            return Place::Code { in_material };
        }
        match self.stack.last() {
            None => {
                let in_value = statement.iter().any(|t| t.1 == Tok::Assign);
                if in_value { Place::Code { in_material } } else { Place::TopLevel }
            }
            Some(Frame::Scene) => match statement {
                [] => Place::Scene,
                [(_, Tok::Ident(kw), _)] if kw == "light" || kw == "object" => Place::SceneKind(kw.to_string()),
                [(_, Tok::Ident(prop), _), ..] => Place::SceneValue { block: None, prop: prop.to_string() },
                _ => Place::Scene,
            },
            Some(Frame::SceneBlock { keyword, kind, given }) => match statement {
                [] => Place::SceneBlock { keyword: keyword.clone(), kind: kind.clone(), given: given.clone() },
                [(_, first, _), ..] if prop_name(first).is_some() => Place::SceneValue {
                    block: Some((keyword.clone(), kind.clone())),
                    prop: prop_name(first).unwrap_or_default(),
                },
                _ => Place::Code { in_material },
            },
            Some(Frame::Material { defined }) => match statement {
                [] => Place::MaterialBody { defined: defined.clone(), return_type: None },
                [(_, t, _)] if type_keyword(t).is_some() => {
                    Place::MaterialBody { defined: defined.clone(), return_type: type_keyword(t).map(String::from) }
                }
                _ => Place::Code { in_material },
            },
            Some(_) => {
                let _ = toks;
                Place::Code { in_material }
            }
        }
    }

    /// The innermost call around the cursor (not a definition's parameter list).
    fn call(&self, toks: &[(usize, Tok, usize)]) -> Option<Call> {
        let (at, frame) = self.stack.iter().enumerate().rev().find(|(_, f)| matches!(f, Frame::Paren { .. }))?;
        if self.stack[at + 1..].iter().any(Frame::is_brace) {
            return None;
        }
        let Frame::Paren { callee: Some(callee), definition: false, commas, named, arg_start } = frame else {
            return None;
        };
        let current = &toks[(*arg_start).min(toks.len())..];
        let current_name = match current {
            [(_, Tok::Ident(n), _), (_, Tok::Colon, _), ..] => Some(n.to_string()),
            _ => None,
        };
        Some(Call {
            callee: callee.clone(),
            index: *commas,
            named: named.clone(),
            current_name,
            at_start: current.is_empty(),
            innermost: at + 1 == self.stack.len(),
        })
    }
}

/// A scene property's name: a word, or `material` (a keyword).
fn prop_name(t: &Tok) -> Option<String> {
    match t {
        Tok::Ident(name) => Some(name.to_string()),
        Tok::Material => Some("material".into()),
        _ => None,
    }
}

/// The text of the token at `k` (an array length).
fn slice_text(toks: &[(usize, Tok, usize)], k: usize) -> String {
    match toks.get(k).map(|t| &t.1) {
        Some(Tok::Int(n)) => n.to_string(),
        _ => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at_cursor(text: &str) -> Context {
        let at = text.find('|').expect("a cursor");
        let text = text.replacen('|', "", 1);
        context_at(&text, at)
    }

    #[test]
    fn calls_and_named_arguments() {
        let c = at_cursor("material m = phong(|");
        assert_eq!(c.place, Place::Code { in_material: false });
        let call = c.call.unwrap();
        assert_eq!((call.callee.as_str(), call.index, call.at_start), ("phong", 0, true));
        let call = at_cursor("material m = phong(kd: rgb(1, 0, 0), n|").call.unwrap();
        assert_eq!((call.callee.as_str(), call.index, call.named.clone()), ("phong", 1, vec!["kd".to_string()]));
        assert!(call.at_start, "a word being typed is still the start of the argument");
        let call = at_cursor("float f() { return fbm(P, octaves: |").call.unwrap();
        assert_eq!(call.current_name.as_deref(), Some("octaves"));
        let inner = at_cursor("float f() { return mix(0.5, rgb(1, |").call.unwrap();
        assert_eq!((inner.callee.as_str(), inner.index), ("rgb", 1));
        let array = at_cursor("material m = blend(t, [a, |").call.unwrap();
        assert_eq!((array.callee.as_str(), array.index, array.innermost), ("blend", 1, false));
        assert!(at_cursor("float f(float x|").call.is_none(), "a parameter list is not a call");
    }

    #[test]
    fn scene_blocks_and_properties() {
        assert_eq!(at_cursor("scene {\n    |").place, Place::Scene);
        assert_eq!(at_cursor("scene { light |").place, Place::SceneKind("light".into()));
        assert_eq!(at_cursor("scene { camera { from (0, 0, 0); f| }").prefix, "f");
        let c = at_cursor("scene { camera { from (0, 0, 0); | } }");
        assert_eq!(c.place, Place::SceneBlock { keyword: "camera".into(), kind: None, given: vec!["from".into()] });
        let c = at_cursor("scene { object sphere { radius 1; material |");
        assert_eq!(
            c.place,
            Place::SceneValue { block: Some(("object".into(), Some("sphere".into()))), prop: "material".into() }
        );
    }

    #[test]
    fn material_bodies_and_locals() {
        let c = at_cursor("material m(color kd = gray(1)) {\n    color diffuse() { return kd; }\n    |");
        assert_eq!(c.place, Place::MaterialBody { defined: vec!["diffuse".into()], return_type: None });
        let c = at_cursor("material m(color kd = gray(1)) { color |");
        assert_eq!(c.place, Place::MaterialBody { defined: vec![], return_type: Some("color".into()) });
        let c = at_cursor(
            "material m(color kd = gray(1)) { color reflection(vector wi, color light, vector wo) { float x = 1; |",
        );
        assert_eq!(c.place, Place::Code { in_material: true });
        let names: Vec<&str> = c.locals.iter().map(|l| l.name.as_str()).collect();
        assert_eq!(names, ["kd", "wi", "light", "wo", "x"]);
        let c = at_cursor("float f(float a) { { float inner = 1; } for i in 0..4 { | } }");
        let names: Vec<&str> = c.locals.iter().map(|l| l.name.as_str()).collect();
        assert_eq!(names, ["a", "i"], "a closed block's locals are gone");
        let c = at_cursor("float f() { for i in 0..4 { } return |");
        assert!(c.locals.is_empty(), "a loop's variable ends with the loop");
        let c = at_cursor("scene { object sphere { material m; radius 1; | } }");
        assert!(matches!(c.place, Place::SceneBlock { given, .. } if given == ["material", "radius"]));
        let c = at_cursor("float f(float a) { return a; }\nfloat g() { return |");
        assert!(c.locals.is_empty(), "another function's parameters are gone");
        assert_eq!(at_cursor("float f() { vector v = N; return v.|").member_of, Some(Some("v".into())));
        assert_eq!(at_cursor("fl|").place, Place::TopLevel);
    }
}
