//! The `scene { ... }` block: which blocks, kinds and properties exist, and
//! the type each property takes. Rendering gives them meaning later; here
//! they are only checked.

use super::{Checker, FrameGlobals, Node, Ty};
use crate::diag::{Diagnostic, Span, did_you_mean};
use crate::syntax::ast::{Expr, ExprKind, Scene, SceneBlock, SceneEntry, SceneProp, UnaryOp};
use smallvec::SmallVec;

/// What a property's value must be.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Want {
    /// A float that must be positive when written as a literal.
    Positive,
    /// A float that must not be negative when written as a literal.
    NonNegative,
    Float,
    /// An int that must be positive when written as a literal.
    Count,
    Int,
    Color,
    Point,
    Vector,
    Matrix,
    String,
    Material,
    ColorOrString,
    FloatOrVector,
    /// One of a fixed set of string literals.
    Choice(&'static [&'static str]),
}

impl Want {
    fn describe(self) -> String {
        match self {
            Want::Positive => "a positive float".into(),
            Want::NonNegative => "a float that is not negative".into(),
            Want::Float => "a float".into(),
            Want::Count => "a positive int".into(),
            Want::Int => "an int".into(),
            Want::Color => "a color".into(),
            Want::Point => "a point such as (0, 1, 0)".into(),
            Want::Vector => "a vector such as (0, 1, 0)".into(),
            Want::Matrix => "a matrix".into(),
            Want::String => "a string".into(),
            Want::Material => "a material".into(),
            Want::ColorOrString => "a color or an image file name".into(),
            Want::FloatOrVector => "a float or a vector".into(),
            Want::Choice(c) => {
                format!("one of {}", c.iter().map(|s| format!("\"{s}\"")).collect::<Vec<_>>().join(", "))
            }
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct Prop {
    name: &'static str,
    want: Want,
    required: bool,
    /// Transforms may be given several times; they apply in order.
    repeats: bool,
    /// Properties with the same non-zero group are alternatives: exactly
    /// one of them must be given (`intensity` or `power`) in group
    /// [`EXACTLY_ONE`], at most one in group [`AT_MOST_ONE`].
    group: u8,
    /// Which of `frame` and `time` the value may read.
    frame: FrameGlobals,
}

const EXACTLY_ONE: u8 = 1;
const AT_MOST_ONE: u8 = 2;

const fn req(name: &'static str, want: Want) -> Prop {
    Prop { name, want, required: true, repeats: false, group: 0, frame: FrameGlobals::Both }
}
const fn opt(name: &'static str, want: Want) -> Prop {
    Prop { name, want, required: false, repeats: false, group: 0, frame: FrameGlobals::Both }
}
const fn many(name: &'static str, want: Want) -> Prop {
    Prop { name, want, required: false, repeats: true, group: 0, frame: FrameGlobals::Both }
}
/// One of a group of alternatives (see `Prop::group`).
const fn alt(name: &'static str, want: Want) -> Prop {
    Prop { name, want, required: false, repeats: false, group: EXACTLY_ONE, frame: FrameGlobals::Both }
}
/// A render setting: the same for every frame, so it reads neither `frame`
/// nor `time`.
const fn setting(name: &'static str, want: Want) -> Prop {
    Prop { name, want, required: false, repeats: false, group: 0, frame: FrameGlobals::Neither }
}

const TOP: &[Prop] = &[opt("background", Want::ColorOrString)];

const CAMERA: &[Prop] = &[
    req("from", Want::Point),
    req("to", Want::Point),
    opt("up", Want::Vector),
    opt("fov", Want::Positive),
    opt("aperture", Want::Float),
    opt("focus", Want::Positive),
];

const RENDER: &[Prop] = &[
    setting("width", Want::Count),
    setting("height", Want::Count),
    setting("spp", Want::Count),
    setting("max_depth", Want::Count),
    setting("seed", Want::Int),
    setting("integrator", Want::Choice(&["whitted", "path"])),
    setting("light_sampling", Want::Choice(&["all", "power"])),
    // A frame's time: `frame / fps`, or the `time` mapping of `frame`.
    Prop { group: AT_MOST_ONE, ..setting("fps", Want::Positive) },
    Prop { group: AT_MOST_ONE, frame: FrameGlobals::FrameOnly, ..setting("time", Want::Float) },
];

const LIGHTS: &[(&str, &[Prop])] = &[
    ("point", &[req("at", Want::Point), alt("intensity", Want::Color), alt("power", Want::Color)]),
    (
        "spot",
        &[
            req("at", Want::Point),
            req("to", Want::Point),
            alt("intensity", Want::Color),
            alt("power", Want::Color),
            opt("cone", Want::Positive),
            opt("falloff", Want::Float),
        ],
    ),
    ("directional", &[req("direction", Want::Vector), req("irradiance", Want::Color)]),
    (
        "rect",
        &[
            req("corner", Want::Point),
            req("edge1", Want::Vector),
            req("edge2", Want::Vector),
            alt("radiance", Want::Color),
            alt("power", Want::Color),
        ],
    ),
    (
        "sphere",
        &[
            req("center", Want::Point),
            req("radius", Want::Positive),
            alt("radiance", Want::Color),
            alt("power", Want::Color),
        ],
    ),
    (
        "environment",
        &[
            alt("file", Want::String),
            alt("radiance", Want::Color),
            opt("scale", Want::NonNegative),
            opt("rotate", Want::Vector),
        ],
    ),
];

/// Properties every object takes besides its shape's own.
const OBJECT_COMMON: &[Prop] = &[
    req("material", Want::Material),
    many("translate", Want::Vector),
    many("rotate", Want::Vector),
    many("scale", Want::FloatOrVector),
    many("transform", Want::Matrix),
];

const SHAPES: &[(&str, &[Prop])] = &[
    ("sphere", &[req("center", Want::Point), req("radius", Want::Positive)]),
    ("plane", &[req("point", Want::Point), req("normal", Want::Vector), opt("tile", Want::Positive)]),
    ("quad", &[req("corner", Want::Point), req("edge1", Want::Vector), req("edge2", Want::Vector)]),
    ("disk", &[req("center", Want::Point), req("normal", Want::Vector), req("radius", Want::Positive)]),
    ("box", &[req("min", Want::Point), req("max", Want::Point)]),
    (
        "cylinder",
        &[
            req("base", Want::Point),
            opt("axis", Want::Vector),
            req("radius", Want::Positive),
            req("height", Want::Positive),
        ],
    ),
    ("mesh", &[req("file", Want::String)]),
];

const BLOCKS: &[&str] = &["camera", "render", "light", "object"];

/// One property of the scene schema, as editors show it.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneProperty {
    pub name: &'static str,
    /// What the value must be, in words: "a positive float".
    pub takes: String,
    pub required: bool,
    /// Whether it may be given several times (object transforms).
    pub repeats: bool,
    /// Whether it is one of alternatives of which one must be given
    /// (`intensity` or `power`).
    pub alternative: bool,
    /// The string literals it accepts, for a property that takes one of a set.
    pub choices: &'static [&'static str],
}

/// The block keywords of a scene: `camera`, `render`, `light`, `object`.
pub fn scene_blocks() -> &'static [&'static str] {
    BLOCKS
}

/// The kinds a block keyword takes (`light` → `point`, `spot`, ...); none
/// for `camera` and `render`.
pub fn scene_kinds(keyword: &str) -> Vec<&'static str> {
    match keyword {
        "light" => LIGHTS.iter().map(|k| k.0).collect(),
        "object" => SHAPES.iter().map(|k| k.0).collect(),
        _ => Vec::new(),
    }
}

/// The properties of a scene block (`keyword` and `kind`), or of the scene
/// itself when `keyword` is `None`: the schema the checker applies.
pub fn scene_properties(keyword: Option<&str>, kind: Option<&str>) -> Vec<SceneProperty> {
    let of_kind = |kinds: &[(&'static str, &'static [Prop])]| -> &'static [Prop] {
        kinds.iter().find(|k| Some(k.0) == kind).map_or(&[], |k| k.1)
    };
    let (own, common): (&[Prop], &[Prop]) = match keyword {
        None => (TOP, &[]),
        Some("camera") => (CAMERA, &[]),
        Some("render") => (RENDER, &[]),
        Some("light") => (of_kind(LIGHTS), &[]),
        Some("object") => (of_kind(SHAPES), OBJECT_COMMON),
        Some(_) => (&[], &[]),
    };
    own.iter()
        .chain(common)
        .map(|p| SceneProperty {
            name: p.name,
            takes: p.want.describe(),
            required: p.required,
            repeats: p.repeats,
            alternative: p.group != 0,
            choices: match p.want {
                Want::Choice(c) => c,
                _ => &[],
            },
        })
        .collect()
}

pub(super) fn check_scene(cx: &mut Checker<'_>, scene: &Scene) {
    let mut cameras = Vec::new();
    let mut renders = Vec::new();
    let mut top_props: Vec<&SceneProp> = Vec::new();
    // `light environment` blocks and `background`: at most one in all.
    let mut environments: Vec<Span> = Vec::new();
    for (k, entry) in scene.entries.iter().enumerate() {
        // A block's values are only checked in the blocks that exist.
        let name = match entry {
            SceneEntry::Prop(_) => "scene",
            SceneEntry::Block(b) => BLOCKS.iter().find(|&&k| k == b.keyword.name).copied().unwrap_or("scene"),
        };
        cx.body.scene_entry = Some((k, name));
        match entry {
            SceneEntry::Prop(p) => {
                if p.name.name == "background" {
                    environments.push(p.name.span);
                }
                top_props.push(p);
            }
            SceneEntry::Block(b) => match b.keyword.name.as_str() {
                "camera" => {
                    no_kind(cx, b);
                    cameras.push(b);
                    check_props(cx, b.props.iter().collect(), CAMERA, &[], "the camera", b);
                }
                "render" => {
                    no_kind(cx, b);
                    renders.push(b);
                    check_props(cx, b.props.iter().collect(), RENDER, &[], "render settings", b);
                }
                "light" => {
                    if b.kind.as_ref().is_some_and(|k| k.name == "environment") {
                        environments.push(b.keyword.span);
                    }
                    if let Some(props) = kind_props(cx, b, LIGHTS, "light") {
                        check_props(cx, b.props.iter().collect(), props, &[], "this light", b);
                    }
                }
                "object" => {
                    if let Some(props) = kind_props(cx, b, SHAPES, "shape") {
                        check_props(cx, b.props.iter().collect(), props, OBJECT_COMMON, "this object", b);
                    }
                }
                other => {
                    let mut d = Diagnostic::error(b.keyword.span, format!("unknown scene block `{other}`"));
                    d = match did_you_mean(other, BLOCKS.iter().copied()) {
                        Some(s) => d.with_help(format!("did you mean `{s}`?")),
                        None => d.with_help(format!("scene blocks are: {}", BLOCKS.join(", "))),
                    };
                    cx.error(d);
                }
            },
        }
    }
    cx.body.scene_entry = Some((usize::MAX, "scene"));
    check_prop_list(cx, &top_props, TOP, &[]);
    cx.body.scene_entry = None;
    if cameras.is_empty() {
        cx.error(
            Diagnostic::error(Span { end: scene.span.start + 5, ..scene.span }, "the scene has no camera")
                .with_help("add `camera { from (0, 1, -4); to (0, 1, 0); fov 40; }`"),
        );
    }
    for extra in environments.iter().skip(1) {
        cx.error(
            Diagnostic::error(*extra, "a scene has one environment")
                .with_label(environments[0], "the first is here")
                .with_help("`background` and `light environment { }` both set the environment: keep one"),
        );
    }
    for (what, blocks) in [("camera", &cameras), ("render block", &renders)] {
        for extra in blocks.iter().skip(1) {
            cx.error(
                Diagnostic::error(extra.keyword.span, format!("a scene has one {what}"))
                    .with_label(blocks[0].keyword.span, "the first is here"),
            );
        }
    }
}

fn no_kind(cx: &mut Checker<'_>, b: &SceneBlock) {
    if let Some(kind) = &b.kind {
        cx.error(Diagnostic::error(kind.span, format!("`{}` takes no kind", b.keyword.name)));
    }
}

fn kind_props(
    cx: &mut Checker<'_>,
    b: &SceneBlock,
    kinds: &[(&'static str, &'static [Prop])],
    what: &str,
) -> Option<&'static [Prop]> {
    // Only for messages: a block that is right allocates nothing.
    let names = || kinds.iter().map(|k| k.0).collect::<Vec<&str>>();
    let Some(kind) = &b.kind else {
        let names = names();
        cx.error(
            Diagnostic::error(b.keyword.span, format!("`{}` needs a {what} kind", b.keyword.name)).with_help(format!(
                "write `{} {} {{ ... }}`; kinds: {}",
                b.keyword.name,
                names[0],
                names.join(", ")
            )),
        );
        return None;
    };
    if let Some((_, props)) = kinds.iter().find(|k| k.0 == kind.name) {
        return Some(props);
    }
    let names = names();
    let mut d = Diagnostic::error(kind.span, format!("unknown {what} `{}`", kind.name));
    d = match did_you_mean(&kind.name, names.iter().copied()) {
        Some(s) => d.with_help(format!("did you mean `{s}`?")),
        None => d.with_help(format!("{what}s are: {}", names.join(", "))),
    };
    cx.error(d);
    None
}

fn check_props(
    cx: &mut Checker<'_>,
    props: Vec<&SceneProp>,
    own: &[Prop],
    common: &[Prop],
    what: &str,
    b: &SceneBlock,
) {
    let given = check_prop_list(cx, &props, own, common);
    for group in [EXACTLY_ONE, AT_MOST_ONE] {
        // Nothing is allocated for a block that is right (a generated
        // scene has millions).
        let alternatives = || own.iter().filter(move |p| p.group == group).map(|p| p.name);
        let Some(first_alternative) = alternatives().next() else { continue };
        let mut named = alternatives().filter(|n| given.contains_key(n));
        let list = || alternatives().map(|n| format!("`{n}`")).collect::<Vec<_>>().join(" or ");
        match (named.next(), named.next()) {
            (None, _) if group == EXACTLY_ONE => cx.error(
                Diagnostic::error(b.span, format!("{what} needs {}", list()))
                    .with_help(format!("add `{first_alternative} ...;` inside the block")),
            ),
            (Some(first), Some(second)) => cx.error(
                Diagnostic::error(given.get(second).name.span, format!("give {}, not both", list()))
                    .with_label(given.get(first).name.span, "already given here"),
            ),
            _ => {}
        }
    }
    for p in own.iter().chain(common) {
        if p.required && !given.contains_key(p.name) {
            cx.error(
                Diagnostic::error(b.span, format!("{what} is missing `{}`", p.name))
                    .with_primary(format!("`{}` takes {}", p.name, p.want.describe()))
                    .with_help(format!("add `{} ...;` inside the block", p.name)),
            );
        }
    }
}

/// The properties given in a block, by name: the last of each name. A
/// block has a few, so a list on the stack beats hashing.
struct Given<'p>(SmallVec<[(&'p str, &'p SceneProp); 8]>);

impl<'p> Given<'p> {
    fn contains_key(&self, name: &str) -> bool {
        self.0.iter().any(|(n, _)| *n == name)
    }

    fn get(&self, name: &str) -> &'p SceneProp {
        self.0.iter().find(|(n, _)| *n == name).map(|(_, p)| *p).expect("a property given")
    }

    /// Records `p`; returns the property of that name given before.
    fn insert(&mut self, name: &'p str, p: &'p SceneProp) -> Option<&'p SceneProp> {
        match self.0.iter_mut().find(|(n, _)| *n == name) {
            Some(slot) => Some(std::mem::replace(&mut slot.1, p)),
            None => {
                self.0.push((name, p));
                None
            }
        }
    }
}

/// Checks each property against the schema; returns the names given.
fn check_prop_list<'p>(cx: &mut Checker<'_>, props: &[&'p SceneProp], own: &[Prop], common: &[Prop]) -> Given<'p> {
    let mut given = Given(SmallVec::new());
    for p in props {
        let name = p.name.name.as_str();
        let Some(spec) = own.iter().chain(common).find(|s| s.name == name) else {
            let names: Vec<&str> = own.iter().chain(common).map(|s| s.name).collect();
            let mut d = Diagnostic::error(p.name.span, format!("unknown property `{name}`"));
            d = match did_you_mean(name, names.iter().copied()) {
                Some(s) => d.with_help(format!("did you mean `{s}`?")),
                None if names.is_empty() => d,
                None => d.with_help(format!("properties here: {}", names.join(", "))),
            };
            cx.error(d);
            if let Some(v) = &p.value {
                cx.body.globals_allowed = true;
                cx.body.materials_allowed = true;
                cx.body.frame_globals = FrameGlobals::Both;
                cx.expr(v, None);
            }
            continue;
        };
        if let Some(prev) = given.insert(name, p)
            && !spec.repeats
        {
            cx.error(
                Diagnostic::error(p.name.span, format!("`{name}` is given twice"))
                    .with_label(prev.name.span, "first given here"),
            );
        }
        let Some(value) = &p.value else {
            cx.error(
                Diagnostic::error(p.span, format!("`{name}` needs a value"))
                    .with_help(format!("`{name}` takes {}", spec.want.describe())),
            );
            continue;
        };
        check_value(cx, value, spec);
    }
    given
}

fn check_value(cx: &mut Checker<'_>, value: &Expr, spec: &Prop) {
    // Materials are evaluated per hit point, so they may read the globals;
    // everything else is fixed before rendering a frame starts.
    cx.body.globals_allowed = spec.want == Want::Material;
    cx.body.materials_allowed = spec.want == Want::Material;
    cx.body.frame_globals = spec.frame;
    // A value other than a material is fixed for a frame: the functions it
    // calls are followed to shading globals (`report_varying_values`).
    // Literal values (most of a generated scene's) name nothing to follow.
    let names_items = || value.any(&|e: &Expr| matches!(e.kind, ExprKind::Name(_) | ExprKind::Call { .. }));
    cx.body.node = match &cx.body.scene_entry {
        Some((entry, block)) if spec.want != Want::Material && names_items() => {
            Some(Node::SceneValue(cx.current, *entry, block, spec.name))
        }
        _ => None,
    };
    if let Some(node) = &cx.body.node
        && spec.frame != FrameGlobals::Both
    {
        cx.frame_limits.insert(*node, spec.frame);
    }
    let expected = match spec.want {
        Want::Positive | Want::NonNegative | Want::Float => Some(Ty::Float),
        Want::Count | Want::Int => Some(Ty::Int),
        Want::Color => Some(Ty::Color),
        Want::Point => Some(Ty::Point),
        Want::Vector => Some(Ty::Vector),
        Want::Matrix => Some(Ty::Matrix),
        Want::String | Want::Choice(_) => Some(Ty::String),
        Want::Material => Some(Ty::Material),
        Want::ColorOrString | Want::FloatOrVector => None,
    };
    let found = cx.expr(value, expected.as_ref());
    let ok = match spec.want {
        Want::ColorOrString => found == Ty::Color || found == Ty::String || found.is_error(),
        Want::FloatOrVector => found.converts_to(&Ty::Float) || found.is_triple() || found.is_error(),
        _ => expected.as_ref().is_none_or(|t| found.converts_to(t)),
    };
    if !ok {
        let mut d =
            Diagnostic::error(value.span, format!("`{}` takes {}, found `{found}`", spec.name, spec.want.describe()));
        if spec.want == Want::Color && found.is_numeric() {
            d = d.with_help("a number is not a color: write gray(x) or rgb(r, g, b)");
        }
        cx.error(d);
        return;
    }
    match spec.want {
        Want::Positive | Want::Count => {
            if let Some(v) = literal_number(value)
                && v <= 0.0
            {
                cx.error(Diagnostic::error(value.span, format!("`{}` must be positive, found {v}", spec.name)));
            }
        }
        Want::NonNegative => {
            if let Some(v) = literal_number(value)
                && v < 0.0
            {
                cx.error(Diagnostic::error(value.span, format!("`{}` must not be negative, found {v}", spec.name)));
            }
        }
        Want::Choice(choices) => match &value.kind {
            ExprKind::Str(s) if choices.contains(&s.as_str()) => {}
            ExprKind::Str(s) => {
                let mut d = Diagnostic::error(value.span, format!("unknown {} \"{s}\"", spec.name))
                    .with_note(format!("expected {}", spec.want.describe()));
                if let Some(m) = did_you_mean(s, choices.iter().copied()) {
                    d = d.with_help(format!("did you mean \"{m}\"?"));
                }
                cx.error(d);
            }
            _ => cx.error(Diagnostic::error(value.span, format!("`{}` takes {}", spec.name, spec.want.describe()))),
        },
        _ => {}
    }
    if spec.name == "fov"
        && let Some(v) = literal_number(value)
        && v >= 180.0
    {
        cx.error(Diagnostic::error(value.span, format!("a field of view of {v} degrees is not below 180")));
    }
}

fn literal_number(e: &Expr) -> Option<f64> {
    match &e.kind {
        ExprKind::Int(i) => Some(f64::from(*i)),
        ExprKind::Float(f) => Some(*f),
        ExprKind::Unary { op: UnaryOp::Neg, operand } => literal_number(operand).map(|v| -v),
        _ => None,
    }
}
