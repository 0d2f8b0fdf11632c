//! The typed schema of declaration kinds: every property's type, default and doc line.
//!
//! The language knows how to check a declaration against a `KindSpec`, but not which kinds
//! exist: each module in `kinds/` declares its kind's spec next to the code that plans its
//! stages, and the registry is handed to the resolver. Adding a kind is one file.

/// How a declaration of this kind is named.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Naming {
    /// `scene { ... }`: no name, at most one per scene.
    Anonymous,
    /// `map density { ... }`: an identifier other declarations refer to.
    Ident,
    /// `output "a.png" { ... }`: a quoted output path.
    Path,
}

#[derive(Debug)]
pub struct KindSpec {
    pub name: &'static str,
    pub doc: &'static str,
    pub naming: Naming,
    pub props: &'static [PropSpec],
    /// What a reference to a declaration of this kind can stand for.
    pub produces: &'static [Value],
    /// Properties that set scene-wide settings (the scene block's `seed` and `size`).
    pub settings: &'static [(Setting, &'static str)],
    /// What relative lengths (`40%`, `surface.width`) of a declaration of this kind are of.
    pub extent: Extent,
}

/// In arithmetic, `scene.width` and `scene.height` are the scene's size: a keyword of the
/// language, which wins over a declaration of that name.
pub const SCENE_SIZE: &str = "scene";

/// In arithmetic, `surface.width` and `surface.height` are the extent of the declaration
/// being checked (see [`Extent`]): a keyword, which wins over a declaration of that name.
pub const OWN_EXTENT: &str = "surface";

/// The size a declaration's relative lengths are taken of: `40%` of its width or height (of
/// the shorter side for a length with no axis), and what `surface.width` names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Extent {
    /// It has none: relative lengths are refused.
    None,
    /// The scene's `size`.
    Scene,
    /// Its own size property (which defaults to the scene's size).
    Prop(&'static str),
    /// The extent of the declaration its reference property names; the scene's when absent.
    Ref(&'static str),
}

/// What a reference to a declaration yields. Kinds say what they produce and properties
/// what they accept, so a new kind producing an image is accepted wherever an image is,
/// with no list of kind names to edit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Value {
    /// A colour image in a declared colour space (a photo, a synthesised layer).
    Image,
    /// A scalar map or a 2-channel vector field.
    Map,
    /// A target surface's plane and occupancy.
    Plane,
    /// A synthesised planar structure (regions, mesh).
    Structure,
    /// A structure to learn from: a structure file or a label image.
    Example,
    /// An indexed texture library.
    Library,
    /// A photometric capture: images of one surface under known lights.
    Capture,
    /// A patch: a colour image with a height layer of its size (and a mask), Frasson's unit of
    /// depth synthesis.
    Patch,
    /// A relieved mesh: displaced geometry and its texture.
    Model,
    /// A procedural texture fitted by example: its parameters.
    Procedural,
    /// A shader and parameters matched to a target image.
    Match,
    /// A sequence of frames between key textures.
    Transform,
}

impl Value {
    pub fn describe(self) -> &'static str {
        match self {
            Value::Image => "an image",
            Value::Map => "a map",
            Value::Plane => "a surface",
            Value::Structure => "a structure",
            Value::Example => "a structure example",
            Value::Library => "a library",
            Value::Capture => "a photometric capture",
            Value::Patch => "a patch (a sample with a `height` layer)",
            Value::Model => "a model",
            Value::Procedural => "a procedural texture",
            Value::Match => "a match",
            Value::Transform => "a transformation",
        }
    }
}

/// A scene-wide setting a kind's property may set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Setting {
    /// The seed every random stream derives from.
    Seed,
    /// The default size of rasters (`Default::SceneSize`).
    Size,
}

/// The names of an enum property and the values they stand for, in one table: the schema
/// lists `names`, the kinds convert with [`Choices::get`], and neither can drift from the
/// other (there is no fallback for a name the table does not hold).
pub struct Choices<T: 'static> {
    pub names: &'static [&'static str],
    pub values: &'static [T],
}

impl<T: Copy> Choices<T> {
    /// The value of `name`, which the schema has already checked is one of `names`.
    pub fn get(&self, name: &str) -> T {
        let i = self.names.iter().position(|n| *n == name).unwrap_or_else(|| {
            panic!("`{name}` is not one of {:?}: the schema admits only this table's names", self.names)
        });
        self.values[i]
    }

    /// The name of `value`.
    pub fn name(&self, value: T) -> &'static str
    where
        T: PartialEq,
    {
        let i = self.values.iter().position(|v| *v == value).expect("every value has a name");
        self.names[i]
    }
}

/// Defines a [`Choices`] table: `choices!(pub METRIC: Metric { "ssd" => Metric::Ssd, ... })`.
#[macro_export]
macro_rules! choices {
    ($(#[$m:meta])* $vis:vis $name:ident: $ty:ty { $($text:literal => $value:expr),+ $(,)? }) => {
        $(#[$m])*
        $vis const $name: $crate::lang::schema::Choices<$ty> =
            $crate::lang::schema::Choices { names: &[$($text),+], values: &[$($value),+] };
    };
}

#[derive(Debug)]
pub struct PropSpec {
    pub name: &'static str,
    pub ty: Ty,
    pub default: Default,
    pub doc: &'static str,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Default {
    /// The user must give a value.
    Required,
    /// Optional; when absent, the property has no value at all.
    Absent,
    /// Source text of the default value, checked like user input.
    Text(&'static str),
    /// The scene's `size`.
    SceneSize,
}

/// Which units a number accepts, and the canonical unit it is stored in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unit {
    /// Pixels: `px` or no unit.
    Length,
    /// Angles, stored in radians: `deg` (the default when no unit is written) or `rad`.
    Angle,
    /// A fraction, stored in [0, 1] units: plain (`0.25`) or percent (`25 %`).
    Fraction,
    /// A plain number with no unit.
    Plain,
}

impl Unit {
    /// The unit values are stored in, for messages.
    pub fn canonical(self) -> &'static str {
        match self {
            Unit::Length => "pixels",
            Unit::Angle => "radians",
            Unit::Fraction => "a fraction",
            Unit::Plain => "a number",
        }
    }

    pub fn describe(self) -> &'static str {
        match self {
            Unit::Length => "a length (`px`)",
            Unit::Angle => "an angle (`deg` or `rad`)",
            Unit::Fraction => "a fraction (plain or `%`)",
            Unit::Plain => "a plain number",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    pub min: f64,
    pub max: f64,
}

pub const ANY: Range = Range { min: f64::NEG_INFINITY, max: f64::INFINITY };
pub const NON_NEG: Range = Range { min: 0.0, max: f64::INFINITY };
pub const POSITIVE: Range = Range { min: f64::MIN_POSITIVE, max: f64::INFINITY };
pub const UNIT: Range = Range { min: 0.0, max: 1.0 };

#[derive(Debug)]
pub enum Ty {
    Number(Unit, Range),
    /// A length in whole pixels (`px` or no unit): a fraction is a diagnostic, never rounded.
    Pixels(Range),
    Int(i64, i64),
    Bool,
    /// `W x H`, whole pixels from 1 to 16384.
    Size,
    /// `[x, y]`.
    Vec2(Unit),
    /// `[a, b, ...]` of any length, each number in the range.
    Numbers(Unit, Range),
    /// `[[x, y], [x, y], ...]`.
    Points,
    Str,
    /// A string naming a file, relative to the declaring scene file.
    Path,
    /// A string naming a directory; resolved to its files with these extensions.
    Dir(&'static [&'static str]),
    /// Files with these extensions: a vector of path strings, or one string that is a path
    /// or a pattern whose file name holds `*` (any run of characters) or `?` (one character).
    Files(&'static [&'static str]),
    Enum(&'static [&'static str]),
    /// A reference to a declaration producing one of these values.
    Ref(&'static [Value]),
    /// A vector of references.
    Refs(&'static [Value]),
    /// A constructor call from `calls`, or a reference to a declaration producing one of `refs`.
    Source {
        calls: &'static [CallSpec],
        refs: &'static [Value],
    },
    /// An RGB colour: a vector of three numbers, each in `[0, 1]`.
    Colour,
    /// A nested property block.
    Block(&'static [PropSpec]),
    /// A vector of constructor calls, e.g. a list of edits `[insert(...), delete(...)]`.
    Calls(&'static [CallSpec]),
}

impl Ty {
    pub fn describe(&self) -> String {
        match self {
            Ty::Number(u, _) => u.describe().to_string(),
            Ty::Pixels(_) => "a whole number of pixels (`px`)".into(),
            Ty::Int(..) => "an integer".into(),
            Ty::Bool => "`true` or `false`".into(),
            Ty::Size => "a size `W x H`".into(),
            Ty::Vec2(_) => "a vector `[x, y]`".into(),
            Ty::Numbers(..) => "a vector of numbers".into(),
            Ty::Colour => "an RGB colour `[r, g, b]`, each in [0, 1]".into(),
            Ty::Points => "a list of points `[[x, y], ...]`".into(),
            Ty::Str => "a string".into(),
            Ty::Path => "a file path string".into(),
            Ty::Dir(exts) => format!(
                "a directory path string (its {} files)",
                exts.iter().map(|e| format!("`.{e}`")).collect::<Vec<_>>().join(", ")
            ),
            Ty::Files(exts) => format!(
                "file paths: a vector of strings, or a pattern string such as `\"dir/*.png\"` ({})",
                exts.iter().map(|e| format!("`.{e}`")).collect::<Vec<_>>().join(", ")
            ),
            Ty::Enum(vs) => format!("one of {}", list(vs)),
            Ty::Ref(vs) => format!("a reference to {}", values(vs)),
            Ty::Refs(vs) => format!("a vector of references to {}", values(vs)),
            Ty::Source { calls, refs } => {
                let mut alts: Vec<String> = calls.iter().map(|c| format!("`{}(...)`", c.name)).collect();
                if !refs.is_empty() {
                    alts.push(format!("the name of {}", values(refs)));
                }
                format!("one of {}", alts.join(", "))
            }
            Ty::Block(_) => "a block `{ ... }`".into(),
            Ty::Calls(calls) => format!(
                "one or a vector of {}",
                calls.iter().map(|c| format!("`{}(...)`", c.name)).collect::<Vec<_>>().join(", ")
            ),
        }
    }
}

/// `an image or a map`.
pub fn values(vs: &[Value]) -> String {
    vs.iter().map(|v| v.describe()).collect::<Vec<_>>().join(" or ")
}

fn list(vs: &[&str]) -> String {
    vs.iter().map(|v| format!("`{v}`")).collect::<Vec<_>>().join(", ")
}

/// A constructor such as `image("a.png")` or `radial(center = [0, 0])`. Arguments are
/// properties; leading required ones may also be given by position.
#[derive(Debug)]
pub struct CallSpec {
    pub name: &'static str,
    pub doc: &'static str,
    pub args: &'static [PropSpec],
}

impl KindSpec {
    pub fn prop(&self, name: &str) -> Option<&PropSpec> {
        self.props.iter().find(|p| p.name == name)
    }
}

/// Renders a kind's schema as text, for `tessera explain`.
pub fn explain(spec: &KindSpec) -> String {
    let mut out = String::new();
    let name_hint = match spec.naming {
        Naming::Anonymous => "",
        Naming::Ident => " NAME",
        Naming::Path => " \"FILE\"",
    };
    out.push_str(&format!("{}{} {{ ... }}\n\n{}\n\nProperties:\n", spec.name, name_hint, spec.doc));
    explain_props(spec.props, 1, &mut out);
    out
}

fn explain_props(props: &[PropSpec], depth: usize, out: &mut String) {
    let pad = "  ".repeat(depth);
    for p in props {
        out.push_str(&format!("{pad}{:<12} {}; {}\n", p.name, p.ty.describe(), default_text(p.default)));
        out.push_str(&format!("{pad}{:<12} {}\n", "", p.doc));
        match &p.ty {
            Ty::Block(inner) => explain_props(inner, depth + 1, out),
            Ty::Source { calls, .. } | Ty::Calls(calls) => {
                for c in calls.iter() {
                    let args: Vec<&str> = c.args.iter().map(|a| a.name).collect();
                    out.push_str(&format!("{pad}  {}({}): {}\n", c.name, args.join(", "), c.doc));
                    explain_props(c.args, depth + 2, out);
                }
            }
            _ => {}
        }
    }
}

/// How `tessera explain` states a property's default: `required`, `optional`, `default 8`.
pub fn default_text(default: Default) -> String {
    match default {
        Default::Required => "required".to_string(),
        Default::Absent => "optional".to_string(),
        Default::Text(t) => format!("default {t}"),
        Default::SceneSize => "default: the scene size".to_string(),
    }
}

/// The bounds a numeric type admits, when it has any: `from 0 to 1`, `at least 1`.
pub fn range_text(ty: &Ty) -> Option<String> {
    let (min, max) = match ty {
        Ty::Number(_, r) | Ty::Pixels(r) | Ty::Numbers(_, r) => (r.min, r.max),
        Ty::Int(a, b) => (*a as f64, *b as f64),
        _ => return None,
    };
    let bounded = |x: f64| x.is_finite() && x.abs() < 1e15 && x != f64::MIN_POSITIVE;
    match (bounded(min), bounded(max)) {
        (true, true) => Some(format!("from {min} to {max}")),
        (true, false) => Some(format!("at least {min}")),
        (false, true) => Some(format!("at most {max}")),
        (false, false) if min == f64::MIN_POSITIVE => Some("greater than 0".into()),
        (false, false) => None,
    }
}

/// One property as Markdown, for an editor's hover: its type, default, bounds and doc, and
/// the constructors it takes.
pub fn property_markdown(p: &PropSpec) -> String {
    let mut out = format!("`{}`: {}; {}", p.name, p.ty.describe(), default_text(p.default));
    if let Some(r) = range_text(&p.ty) {
        out.push_str(&format!("; {r}"));
    }
    out.push_str(&format!("\n\n{}", p.doc));
    if let Ty::Source { calls, .. } | Ty::Calls(calls) = &p.ty {
        out.push('\n');
        for c in calls.iter() {
            out.push_str(&format!("\n- {}\n", call_line(c)));
        }
    }
    out
}

/// `radial(center, radius)`: what a constructor does.
pub fn call_line(c: &CallSpec) -> String {
    let args: Vec<&str> = c.args.iter().map(|a| a.name).collect();
    format!("`{}({})`: {}", c.name, args.join(", "), c.doc)
}

/// Renders a kind's schema as Markdown, for the language reference.
pub fn markdown(spec: &KindSpec) -> String {
    let mut out = String::new();
    let name_hint = match spec.naming {
        Naming::Anonymous => "",
        Naming::Ident => " name",
        Naming::Path => " \"file\"",
    };
    out.push_str(&format!("### `{}{} {{ … }}`\n\n{}\n\n", spec.name, name_hint, spec.doc));
    markdown_props(spec.props, &mut out);
    markdown_nested(spec.props, "", &mut out);
    out
}

/// The blocks and constructors a property table mentions, each with its own table; `path`
/// names the enclosing block (`lloyd.` …) so nested headings stay unambiguous.
fn markdown_nested(props: &[PropSpec], path: &str, out: &mut String) {
    for p in props {
        match &p.ty {
            Ty::Source { calls, .. } | Ty::Calls(calls) => {
                out.push_str(&format!("\nConstructors for `{path}{}`:\n\n", p.name));
                for (i, c) in calls.iter().enumerate() {
                    let args: Vec<&str> = c.args.iter().map(|a| a.name).collect();
                    let gap = if i == 0 { "" } else { "\n" };
                    out.push_str(&format!("{gap}#### `{}({})`\n\n{}\n\n", c.name, args.join(", "), c.doc));
                    markdown_props(c.args, out);
                    markdown_nested(c.args, &format!("{}.", c.name), out);
                }
            }
            Ty::Block(inner) => {
                out.push_str(&format!("\n#### `{path}{} {{ … }}`\n\n{}\n\n", p.name, p.doc));
                markdown_props(inner, out);
                markdown_nested(inner, &format!("{path}{}.", p.name), out);
            }
            _ => {}
        }
    }
}

fn markdown_props(props: &[PropSpec], out: &mut String) {
    out.push_str("| property | type | default | meaning |\n|---|---|---|---|\n");
    for p in props {
        let default = match p.default {
            Default::Required => "required".to_string(),
            Default::Absent => "none".to_string(),
            Default::Text(t) => format!("`{t}`"),
            Default::SceneSize => "scene size".to_string(),
        };
        let ty = p.ty.describe().replace('|', "\\|");
        out.push_str(&format!("| `{}` | {} | {} | {} |\n", p.name, ty, default, p.doc.replace('|', "\\|")));
    }
}
