//! The syntax tree: what the user wrote, with spans, before any meaning is attached.
//!
//! Numbers keep their source text so that `tessera fmt` never rewrites `0.50` into `0.5`
//! behind the user's back; the formatter only changes layout.

use super::source::Span;

#[derive(Clone, Debug)]
pub struct File {
    pub items: Vec<Item>,
}

#[derive(Clone, Debug)]
pub enum Item {
    Comment(Comment),
    Import(Import),
    Param(Param),
    Decl(Decl),
}

#[derive(Clone, Debug)]
pub struct Comment {
    pub text: String,
    pub span: Span,
}

#[derive(Clone, Debug)]
pub struct Import {
    pub path: String,
    pub path_span: Span,
    pub span: Span,
}

#[derive(Clone, Debug)]
pub struct Param {
    pub name: Ident,
    pub value: Value,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Ident {
    pub text: String,
    pub span: Span,
}

/// A declaration's name: a bare identifier (`map density`) or a string (`output "a.png"`).
#[derive(Clone, Debug)]
pub struct DeclName {
    pub text: String,
    pub quoted: bool,
    pub span: Span,
}

#[derive(Clone, Debug)]
pub struct Decl {
    pub kind: Ident,
    pub name: Option<DeclName>,
    pub block: Block,
    pub span: Span,
}

#[derive(Clone, Debug)]
pub struct Block {
    pub entries: Vec<Entry>,
    pub span: Span,
}

impl Block {
    pub fn properties(&self) -> impl Iterator<Item = &Property> {
        self.entries.iter().filter_map(|e| match e {
            Entry::Property(p) => Some(p),
            Entry::Comment(_) => None,
        })
    }
}

#[derive(Clone, Debug)]
pub enum Entry {
    Comment(Comment),
    Property(Property),
}

#[derive(Clone, Debug)]
pub struct Property {
    pub name: Ident,
    pub value: Value,
    pub span: Span,
}

#[derive(Clone, Debug)]
pub struct Value {
    pub kind: ValueKind,
    pub span: Span,
}

#[derive(Clone, Debug)]
pub enum ValueKind {
    Number {
        value: f64,
        text: String,
        unit: Option<String>,
    },
    Size {
        w: f64,
        w_text: String,
        h: f64,
        h_text: String,
    },
    Bool(bool),
    Str(String),
    Vector(Vec<Value>),
    Ident(String),
    Call {
        name: Ident,
        args: Vec<Arg>,
    },
    Block(Block),
    /// Operands joined by operators of one precedence level, evaluated left to right
    /// (`a + b - c`, or `a * b / c`); a level binds tighter when it is an operand.
    Chain {
        first: Box<Value>,
        rest: Vec<(Op, Value)>,
    },
    /// `-x` where `x` is not a number literal (`-3` is a `Number`).
    Neg(Box<Value>),
    /// `( ... )`, kept so that `tessera fmt` writes the expression as it was written.
    Paren(Box<Value>),
    /// `scene.width`, `surface.height`, `facade.width`: a size of the scene or of a declaration.
    Field {
        base: Ident,
        field: Ident,
    },
}

/// An arithmetic operator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Op {
    Add,
    Sub,
    Mul,
    Div,
}

impl Op {
    pub fn symbol(self) -> &'static str {
        match self {
            Op::Add => "+",
            Op::Sub => "-",
            Op::Mul => "*",
            Op::Div => "/",
        }
    }
}

#[derive(Clone, Debug)]
pub struct Arg {
    pub name: Option<Ident>,
    pub value: Value,
}

impl ValueKind {
    /// Like `describe`, with a vector's shape, so that a wrong vector is not reported as
    /// "expected a vector, found a vector": `[[1, 2]]` is "a vector of 1 vector of 2 numbers".
    pub fn describe_shape(&self) -> String {
        match self {
            ValueKind::Vector(items) if items.is_empty() => "an empty vector".into(),
            ValueKind::Vector(items) => format!("a vector of {}", vector_contents(items)),
            k => k.describe().into(),
        }
    }

    /// A short noun for diagnostics: "expected a size, found a string".
    pub fn describe(&self) -> &'static str {
        match self {
            ValueKind::Number { unit: Some(_), .. } => "a number with a unit",
            ValueKind::Number { .. } => "a number",
            ValueKind::Size { .. } => "a size",
            ValueKind::Bool(_) => "a boolean",
            ValueKind::Str(_) => "a string",
            ValueKind::Vector(_) => "a vector",
            ValueKind::Ident(_) => "a name",
            ValueKind::Call { .. } => "a constructor call",
            ValueKind::Block(_) => "a block",
            ValueKind::Chain { .. } | ValueKind::Neg(_) | ValueKind::Paren(_) => "an expression",
            ValueKind::Field { .. } => "a size of the scene or a declaration",
        }
    }
}

/// "2 numbers", "1 vector of 2 numbers", "3 values": what a non-empty vector holds. Only the
/// first element's chain is followed, so the cost is the nesting depth, not the size.
fn vector_contents(items: &[Value]) -> String {
    let n = items.len();
    let s = if n == 1 { "" } else { "s" };
    if items.iter().all(|i| matches!(i.kind, ValueKind::Number { .. })) {
        return format!("{n} number{s}");
    }
    if let ValueKind::Vector(first) = &items[0].kind {
        let m = first.len();
        if items.iter().all(|i| matches!(&i.kind, ValueKind::Vector(v) if v.len() == m)) {
            return if m == 0 {
                format!("{n} empty vector{s}")
            } else {
                format!("{n} vector{s} of {}", vector_contents(first))
            };
        }
    }
    format!("{n} value{s}")
}
