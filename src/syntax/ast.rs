//! The spanned syntax tree. It knows nothing of types: `check` gives it meaning.
//!
//! Invariant: every expression and statement knows its nesting depth, and the
//! parser refuses trees deeper than [`MAX_NESTING`]. The left operand of a
//! binary operation does not count: a chain `a + b + … + z` is one level,
//! however long, as a person reads it. So the passes that recurse into
//! operands (checking, lowering, and `Expr`'s own clone, comparison, debug
//! print and drop) run under [`with_stack`], which grows the stack on
//! demand.

use crate::diag::Span;
use std::sync::Arc;

/// The deepest nesting of expressions or statements the parser accepts.
pub const MAX_NESTING: u32 = 256;

/// Runs `f` with at least 128 KiB of stack left, switching to a fresh
/// 2 MiB segment when less is. Recursive passes over expressions call it
/// once per level, so their depth is bounded by memory, not by the
/// thread's stack (a left-leaning chain of binary operations can be as
/// long as the source file).
pub fn with_stack<R>(f: impl FnOnce() -> R) -> R {
    stacker::maybe_grow(128 * 1024, 2 * 1024 * 1024, f)
}

/// A name with the span where it is written.
#[derive(Debug, Clone, PartialEq)]
pub struct Ident {
    pub name: Name,
    pub span: Span,
}

/// An identifier's text. The lexer interns them per file, so the
/// occurrences of one name share one allocation (a generated scene writes
/// `object sphere { ... material red; }` a million times), behind a thin
/// pointer (an `Arc<str>` is two words: a million-sphere scene has five
/// names an object). Compares, hashes, prints and dereferences as its
/// `str`.
#[derive(Clone, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
#[allow(clippy::rc_buffer)]
pub struct Name(Arc<String>);

impl Name {
    pub fn as_str(&self) -> &str {
        self.0.as_str()
    }
}

impl std::ops::Deref for Name {
    type Target = str;
    fn deref(&self) -> &str {
        self.0.as_str()
    }
}

impl std::borrow::Borrow<str> for Name {
    fn borrow(&self) -> &str {
        self.0.as_str()
    }
}

impl AsRef<str> for Name {
    fn as_ref(&self) -> &str {
        self.0.as_str()
    }
}

impl std::fmt::Debug for Name {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Debug::fmt(self.0.as_str(), f)
    }
}

impl std::fmt::Display for Name {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.0.as_str())
    }
}

impl From<&str> for Name {
    fn from(s: &str) -> Name {
        Name(Arc::new(s.to_string()))
    }
}

impl From<String> for Name {
    fn from(s: String) -> Name {
        Name(Arc::new(s))
    }
}

impl From<Name> for String {
    fn from(n: Name) -> String {
        n.0.to_string()
    }
}

impl PartialEq<str> for Name {
    fn eq(&self, other: &str) -> bool {
        self.0.as_str() == other
    }
}

impl PartialEq<&str> for Name {
    fn eq(&self, other: &&str) -> bool {
        self.0.as_str() == *other
    }
}

impl PartialEq<String> for Name {
    fn eq(&self, other: &String) -> bool {
        self.0.as_str() == *other
    }
}

impl PartialEq<Name> for str {
    fn eq(&self, other: &Name) -> bool {
        self == other.0.as_str()
    }
}

impl PartialEq<Name> for &str {
    fn eq(&self, other: &Name) -> bool {
        *self == other.0.as_str()
    }
}

impl PartialEq<Name> for String {
    fn eq(&self, other: &Name) -> bool {
        *self == other.0.as_str()
    }
}

/// The names met in one file, each allocated once.
#[derive(Debug, Default)]
pub struct Names(rustc_hash::FxHashSet<Name>);

impl Names {
    pub fn intern(&mut self, s: &str) -> Name {
        if let Some(n) = self.0.get(s) {
            return n.clone();
        }
        let n = Name::from(s);
        self.0.insert(n.clone());
        n
    }
}

/// One parsed `.tsl` file.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SourceFile {
    pub items: Vec<Item>,
}

#[derive(Debug, Clone, PartialEq)]
pub enum Item {
    /// `import "file.tsl";`
    Import { path: String, span: Span },
    /// `float rings(float scale = 8) { ... }`
    Function(Function),
    /// `material phong(params) { methods }`: a material model.
    Material(MaterialDef),
    /// `material wood = mix(...);` or, with parameters, a texture-tree template
    /// `material checkered(material a, material b) = mix(checker(), a, b);`
    MaterialTree(MaterialTree),
    /// `const float PI = 3.14159;`
    Const(ConstDef),
    /// `scene { ... }`
    Scene(Scene),
}

/// The written form of a type: a base type, optionally an array of it.
#[derive(Debug, Clone, PartialEq)]
pub struct TypeExpr {
    pub base: BaseType,
    /// `float[4]`: the length and the span of `[4]`.
    pub array_len: Option<(u32, Span)>,
    pub span: Span,
}

/// The type keywords.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BaseType {
    Float,
    Int,
    Bool,
    Color,
    Vector,
    Point,
    Normal,
    Vec2,
    Matrix,
    /// A sampled direction of a material (`sample` in the interface).
    BsdfSample,
    String,
    Material,
    Void,
}

impl BaseType {
    pub fn keyword(self) -> &'static str {
        match self {
            BaseType::Float => "float",
            BaseType::Int => "int",
            BaseType::Bool => "bool",
            BaseType::Color => "color",
            BaseType::Vector => "vector",
            BaseType::Point => "point",
            BaseType::Normal => "normal",
            BaseType::Vec2 => "vec2",
            BaseType::Matrix => "matrix",
            BaseType::BsdfSample => "bsdf_sample",
            BaseType::String => "string",
            BaseType::Material => "material",
            BaseType::Void => "void",
        }
    }
}

/// A parameter of a function, material or material tree. Its
/// documentation is the `///` comment on the lines above it, read from the
/// source text by [`doc_comment`](crate::syntax::doc_comment).
#[derive(Debug, Clone, PartialEq)]
pub struct Param {
    pub ty: TypeExpr,
    pub name: Ident,
    pub default: Option<Expr>,
    /// `in ("beckmann", "ggx")`: the values a `string` parameter accepts.
    pub options: Option<ParamOptions>,
    pub span: Span,
}

/// The options declared for a `string` parameter, in their order.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamOptions {
    /// Each option's text and the span of its literal.
    pub values: Vec<(String, Span)>,
    /// From `in` to the closing parenthesis.
    pub span: Span,
}

impl ParamOptions {
    /// Whether `value` is one of the options.
    pub fn contains(&self, value: &str) -> bool {
        self.values.iter().any(|(v, _)| v == value)
    }

    /// The options as the user writes them: `"beckmann", "ggx"`.
    pub fn listed(&self) -> String {
        self.values.iter().map(|(v, _)| format!("\"{v}\"")).collect::<Vec<_>>().join(", ")
    }
}

/// A function, or a method inside a material definition.
#[derive(Debug, Clone, PartialEq)]
pub struct Function {
    pub ret: TypeExpr,
    pub name: Ident,
    pub params: Vec<Param>,
    pub body: Block,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub struct MaterialDef {
    pub name: Ident,
    pub params: Vec<Param>,
    pub methods: Vec<Function>,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub struct MaterialTree {
    pub name: Ident,
    /// `None` for a plain binding `material m = ...;`.
    pub params: Option<Vec<Param>>,
    pub body: Expr,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub struct ConstDef {
    pub ty: TypeExpr,
    pub name: Ident,
    pub value: Expr,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    pub entries: Vec<SceneEntry>,
    pub span: Span,
}

/// `camera { ... }`, `light point { ... }`, `object sphere { ... }` or a
/// property such as `background rgb(0, 0, 0);`.
#[derive(Debug, Clone, PartialEq)]
pub enum SceneEntry {
    Block(SceneBlock),
    Prop(SceneProp),
}

#[derive(Debug, Clone, PartialEq)]
pub struct SceneBlock {
    /// `camera`, `light`, `object`, `render`.
    pub keyword: Ident,
    /// `point` in `light point`, `sphere` in `object sphere`.
    pub kind: Option<Ident>,
    pub props: Vec<SceneProp>,
    pub span: Span,
}

/// `name value;` inside a scene block; the value is optional for flags.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneProp {
    pub name: Ident,
    pub value: Option<Expr>,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    pub stmts: Vec<Stmt>,
    pub span: Span,
    pub depth: u32,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Stmt {
    pub kind: StmtKind,
    pub span: Span,
    pub depth: u32,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AssignOp {
    Set,
    Add,
    Sub,
    Mul,
    Div,
}

impl AssignOp {
    /// The binary operator a compound assignment applies.
    pub fn binary(self) -> Option<BinaryOp> {
        match self {
            AssignOp::Set => None,
            AssignOp::Add => Some(BinaryOp::Add),
            AssignOp::Sub => Some(BinaryOp::Sub),
            AssignOp::Mul => Some(BinaryOp::Mul),
            AssignOp::Div => Some(BinaryOp::Div),
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub enum StmtKind {
    /// `float x = 1;` (a declaration without initialiser starts at zero).
    Let {
        ty: TypeExpr,
        name: Ident,
        init: Option<Expr>,
    },
    /// `x = e;`, `c.x += e;`, `a[i] *= e;`
    Assign {
        target: Expr,
        op: AssignOp,
        value: Expr,
    },
    Expr(Expr),
    If {
        cond: Expr,
        then_block: Block,
        else_branch: Option<Box<Stmt>>,
    },
    /// `for i in lo..hi { ... }`: `i` runs over `lo, lo+1, ..., hi-1`.
    For {
        var: Ident,
        start: Expr,
        end: Expr,
        body: Block,
    },
    /// Parsed so the checker can explain why it is refused.
    While {
        cond: Expr,
        body: Block,
    },
    Break,
    Continue,
    Return(Option<Expr>),
    Block(Block),
}

/// An expression. Its clone, comparison, debug print and drop recurse
/// under [`with_stack`], like every pass over operands.
pub struct Expr {
    pub kind: ExprKind,
    pub span: Span,
    pub depth: u32,
}

impl Clone for Expr {
    fn clone(&self) -> Self {
        with_stack(|| Expr { kind: self.kind.clone(), span: self.span, depth: self.depth })
    }
}

impl PartialEq for Expr {
    fn eq(&self, other: &Self) -> bool {
        with_stack(|| self.kind == other.kind && self.span == other.span && self.depth == other.depth)
    }
}

impl std::fmt::Debug for Expr {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        with_stack(|| {
            f.debug_struct("Expr")
                .field("kind", &self.kind)
                .field("span", &self.span)
                .field("depth", &self.depth)
                .finish()
        })
    }
}

impl Drop for Expr {
    fn drop(&mut self) {
        if matches!(self.kind, ExprKind::Binary { .. }) {
            let kind = std::mem::replace(&mut self.kind, ExprKind::Bool(false));
            with_stack(move || drop(kind));
        }
    }
}

/// A call argument, positional or `name: value`.
#[derive(Debug, Clone, PartialEq)]
pub struct Arg {
    pub name: Option<Ident>,
    pub value: Expr,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UnaryOp {
    Neg,
    Not,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BinaryOp {
    Add,
    Sub,
    Mul,
    Div,
    Rem,
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
    And,
    Or,
}

impl BinaryOp {
    /// How tightly the operator binds: `||` 0, `&&` 1, `==` `!=` 2, `<`
    /// `<=` `>` `>=` 3, `+` `-` 4, `*` `/` `%` 5. All are left-associative.
    pub fn precedence(self) -> u8 {
        match self {
            BinaryOp::Or => 0,
            BinaryOp::And => 1,
            BinaryOp::Eq | BinaryOp::Ne => 2,
            BinaryOp::Lt | BinaryOp::Le | BinaryOp::Gt | BinaryOp::Ge => 3,
            BinaryOp::Add | BinaryOp::Sub => 4,
            BinaryOp::Mul | BinaryOp::Div | BinaryOp::Rem => 5,
        }
    }

    pub fn symbol(self) -> &'static str {
        match self {
            BinaryOp::Add => "+",
            BinaryOp::Sub => "-",
            BinaryOp::Mul => "*",
            BinaryOp::Div => "/",
            BinaryOp::Rem => "%",
            BinaryOp::Eq => "==",
            BinaryOp::Ne => "!=",
            BinaryOp::Lt => "<",
            BinaryOp::Le => "<=",
            BinaryOp::Gt => ">",
            BinaryOp::Ge => ">=",
            BinaryOp::And => "&&",
            BinaryOp::Or => "||",
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub enum ExprKind {
    Int(i32),
    Float(f64),
    Bool(bool),
    Str(String),
    Name(Name),
    /// `f(a, name: b)`; also builtins and material instances.
    /// The callee is boxed, as the member's field: expressions are
    /// smaller (a generated scene holds millions of literals).
    Call {
        callee: Box<Ident>,
        args: Box<[Arg]>,
    },
    /// `vector(1, 0, 0)`, `vec2(u, v)`: a type keyword used as a constructor.
    Construct {
        ty: BaseType,
        ty_span: Span,
        args: Box<[Arg]>,
    },
    Member {
        base: Box<Expr>,
        field: Box<Ident>,
    },
    Index {
        base: Box<Expr>,
        index: Box<Expr>,
    },
    Unary {
        op: UnaryOp,
        operand: Box<Expr>,
    },
    Binary {
        op: BinaryOp,
        lhs: Box<Expr>,
        rhs: Box<Expr>,
    },
    Ternary {
        cond: Box<Expr>,
        then_expr: Box<Expr>,
        else_expr: Box<Expr>,
    },
    /// `[a, b, c]`
    Array(Vec<Expr>),
    /// `(x, y, z)`: a vector, point or vec2 written as a tuple.
    Tuple(Vec<Expr>),
}

impl Expr {
    /// Whether `pred` holds for this expression or any inside it. Only a
    /// binary operation's left operand may nest without limit (flat chains,
    /// see `MAX_NESTING`): that one is followed in a loop, the rest
    /// recursively.
    pub fn any(&self, pred: &impl Fn(&Expr) -> bool) -> bool {
        let mut e = self;
        loop {
            if pred(e) {
                return true;
            }
            let any_arg = |args: &[Arg]| args.iter().any(|a| a.value.any(pred));
            match &e.kind {
                ExprKind::Int(_) | ExprKind::Float(_) | ExprKind::Bool(_) | ExprKind::Str(_) | ExprKind::Name(_) => {
                    return false;
                }
                ExprKind::Call { args, .. } | ExprKind::Construct { args, .. } => return any_arg(args),
                ExprKind::Member { base, .. } => return base.any(pred),
                ExprKind::Index { base, index } => return base.any(pred) || index.any(pred),
                ExprKind::Unary { operand, .. } => return operand.any(pred),
                ExprKind::Ternary { cond, then_expr, else_expr } => {
                    return cond.any(pred) || then_expr.any(pred) || else_expr.any(pred);
                }
                ExprKind::Array(es) | ExprKind::Tuple(es) => return es.iter().any(|x| x.any(pred)),
                ExprKind::Binary { lhs, rhs, .. } => {
                    if rhs.any(pred) {
                        return true;
                    }
                    e = lhs;
                }
            }
        }
    }
}

impl ExprKind {
    /// The deepest nesting among the direct children.
    fn child_depth(&self) -> u32 {
        let args = |args: &[Arg]| args.iter().map(|a| a.value.depth).max().unwrap_or(0);
        let exprs = |es: &[Expr]| es.iter().map(|e| e.depth).max().unwrap_or(0);
        match self {
            ExprKind::Int(_) | ExprKind::Float(_) | ExprKind::Bool(_) | ExprKind::Str(_) | ExprKind::Name(_) => 0,
            ExprKind::Call { args: a, .. } | ExprKind::Construct { args: a, .. } => args(a),
            ExprKind::Member { base, .. } => base.depth,
            ExprKind::Index { base, index } => base.depth.max(index.depth),
            ExprKind::Unary { operand, .. } => operand.depth,
            ExprKind::Binary { lhs, rhs, .. } => lhs.depth.max(rhs.depth),
            ExprKind::Ternary { cond, then_expr, else_expr } => cond.depth.max(then_expr.depth).max(else_expr.depth),
            ExprKind::Array(es) | ExprKind::Tuple(es) => exprs(es),
        }
    }
}

/// The nesting limit was exceeded at this span.
#[derive(Debug, Clone, PartialEq)]
pub struct TooDeep(pub Span);

impl Expr {
    /// Builds a node, refusing one nested deeper than [`MAX_NESTING`].
    pub fn new(kind: ExprKind, span: Span) -> Result<Expr, TooDeep> {
        let depth = match &kind {
            // A chain's left operand is the chain so far, not nesting.
            ExprKind::Binary { lhs, rhs, .. } => lhs.depth.max(rhs.depth + 1),
            _ => kind.child_depth() + 1,
        };
        if depth > MAX_NESTING {
            return Err(TooDeep(span));
        }
        Ok(Expr { kind, span, depth })
    }
}

/// Parentheses add no node but count as a nesting level.
pub fn parenthesized(mut e: Expr, span: Span) -> Result<Expr, TooDeep> {
    e.depth += 1;
    if e.depth > MAX_NESTING {
        return Err(TooDeep(span));
    }
    Ok(e)
}

impl Block {
    pub fn new(stmts: Vec<Stmt>, span: Span) -> Result<Block, TooDeep> {
        let depth = stmts.iter().map(|s| s.depth).max().unwrap_or(0) + 1;
        if depth > MAX_NESTING {
            return Err(TooDeep(span));
        }
        Ok(Block { stmts, span, depth })
    }
}

impl Stmt {
    pub fn new(kind: StmtKind, span: Span) -> Result<Stmt, TooDeep> {
        // A block statement is one level, not two.
        let own = u32::from(!matches!(kind, StmtKind::Block(_)));
        let depth = own
            + match &kind {
                StmtKind::Let { init, .. } => init.as_ref().map_or(0, |e| e.depth),
                StmtKind::Assign { target, value, .. } => target.depth.max(value.depth),
                StmtKind::Expr(e) => e.depth,
                StmtKind::If { cond, then_block, else_branch } => {
                    cond.depth.max(then_block.depth).max(else_branch.as_ref().map_or(0, |s| s.depth))
                }
                StmtKind::For { start, end, body, .. } => start.depth.max(end.depth).max(body.depth),
                StmtKind::While { cond, body } => cond.depth.max(body.depth),
                StmtKind::Break | StmtKind::Continue => 0,
                StmtKind::Return(e) => e.as_ref().map_or(0, |e| e.depth),
                StmtKind::Block(b) => b.depth,
            };
        if depth > MAX_NESTING {
            return Err(TooDeep(span));
        }
        Ok(Stmt { kind, span, depth })
    }
}
