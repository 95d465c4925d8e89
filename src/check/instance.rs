//! Checking one material expression given after the program was checked:
//! what a host's instance of a material template becomes (the embedding
//! API writes the call `rough_conductor(alpha: 0.2)` and compiles it as
//! the same call written in the root file would compile).

use super::*;

/// A material expression checked against a checked program.
#[derive(Debug, Clone)]
pub struct CheckedExpr {
    /// The program with the expression's source file, types and name
    /// resolutions added: what lowering reads, and what the diagnostics
    /// point into.
    pub program: Program,
    /// The expression; `None` when it did not parse as one.
    pub expr: Option<Expr>,
    pub diagnostics: Vec<Diagnostic>,
}

impl CheckedExpr {
    /// The expression, when it checked without errors.
    pub fn ok(&self) -> Option<&Expr> {
        self.expr.as_ref().filter(|_| !self.diagnostics.iter().any(Diagnostic::is_error))
    }
}

/// Checks the material expression `text` (named `name` in diagnostics) as
/// if it were the body of a material tree in the program's root file: it
/// sees the root's names, and every rule of a call written there holds
/// (argument types, declared string options). `program` must have checked
/// without errors. The program is cloned (its syntax trees are shared), so
/// the expression's file and entries are added to a copy.
///
/// ```
/// let checked = tsl::check_source("m.tsl", "material m = lambert;", &tsl::LoadOptions::default());
/// let ok = tsl::check::check_material_expr(&checked.program, "<instance>", "phong(ns: 8)");
/// assert!(ok.ok().is_some());
/// let wrong = tsl::check::check_material_expr(&checked.program, "<instance>", "phong(ns: true)");
/// assert_eq!(wrong.diagnostics[0].message, "mismatched types: expected `float`, found `bool`");
/// ```
pub fn check_material_expr(program: &Program, name: &str, text: &str) -> CheckedExpr {
    let mut ext = program.clone();
    let source = format!("material instance = {text};");
    let file = ext.loaded.sources.add(name, source.clone());
    let whole = Span::new(file, 0, source.len());
    let (ast, diags) = crate::syntax::parse(file, &source);
    let expr = match ast.items.into_iter().next() {
        Some(Item::MaterialTree(t)) if t.params.is_none() && ast_is_one(&diags) => t.body,
        _ => {
            let mut diagnostics = diags;
            if diagnostics.is_empty() {
                diagnostics.push(Diagnostic::error(whole, "not a material expression"));
            }
            return CheckedExpr { program: ext, expr: None, diagnostics };
        }
    };
    let mut diags = Vec::new();
    let root = ext.loaded.modules.iter().position(|m| !m.is_prelude).unwrap_or(0);
    // The new file comes after every other, so the tables' entries for it
    // arrive in span order.
    let mut checker = Checker {
        loaded: &ext.loaded,
        symbols: &ext.symbols,
        prelude_symbols: &ext.prelude_symbols,
        in_prelude: false,
        current: (root, usize::MAX),
        resolutions: std::mem::take(&mut ext.resolutions),
        local_uses: FxHashMap::default(),
        reads_globals: FxHashMap::default(),
        reads_frame: FxHashMap::default(),
        frame_limits: FxHashMap::default(),
        diags: &mut diags,
        expr_types: std::mem::take(&mut ext.expr_types),
        graph: FxHashMap::default(),
        body: Body {
            scopes: vec![Vec::new()],
            context: "a material instance",
            globals_allowed: true,
            materials_allowed: true,
            ..Body::default()
        },
        images: Vec::new(),
        texture_calls: HashMap::new(),
        string_options: HashMap::new(),
        string_args: Vec::new(),
        builtin_calls: HashMap::new(),
    };
    let ty = checker.expr(&expr, Some(&Ty::Material));
    checker.expect_ty(&expr, &ty, &Ty::Material, "a material instance");
    let (mut resolutions, mut expr_types) =
        (std::mem::take(&mut checker.resolutions), std::mem::take(&mut checker.expr_types));
    let (builtin_calls, images) = (std::mem::take(&mut checker.builtin_calls), checker.images.len());
    drop(checker);
    if images > 0 {
        diags.push(Diagnostic::error(whole, "a material instance cannot read images of its own"));
    }
    resolutions.finish();
    expr_types.finish();
    ext.resolutions = resolutions;
    ext.expr_types = expr_types;
    ext.builtin_calls.extend(builtin_calls);
    CheckedExpr { program: ext, expr: Some(expr), diagnostics: diags }
}

/// Whether parsing gave no error (a recovered tree is not the text).
fn ast_is_one(diags: &[Diagnostic]) -> bool {
    !diags.iter().any(Diagnostic::is_error)
}
