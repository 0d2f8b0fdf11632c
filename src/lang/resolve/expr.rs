//! Arithmetic in numeric values: `+ - * /`, brackets, unary minus, `min`/`max`/`clamp`,
//! params, lengths relative to the declaration's extent (`40%`, `surface.width`) and the
//! scene's (`scene.height`), checked for units as they are evaluated.
//!
//! A number without a unit is free: it takes the dimension it meets (`scene.width / 8 + 2`
//! is a length), and in an angle it counts degrees, as everywhere in the language. Lengths
//! multiply only with free numbers (`px * px` has no meaning here) and a length divided by a
//! length is free.

use std::path::Path;

use super::axis::Axis;
use super::namespace::Checker;
use crate::lang::ast::{self, Op, ValueKind};
use crate::lang::diag::Diagnostic;
use crate::lang::ir::Val;
use crate::lang::schema::{Extent, Ty, Unit, OWN_EXTENT, SCENE_SIZE};
use crate::lang::source::Span;

/// How deep params may refer to params inside an expression.
const MAX_PARAM_DEPTH: usize = 16;

/// Most operands one value may evaluate, params expanded: params that each use the next
/// several times would otherwise grow exponentially (`param a = b + b`, `param b = c + c`, ...).
const MAX_STEPS: usize = 100_000;

/// The dimension of an evaluated quantity.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Dim {
    Free,
    Length,
    Angle,
}

impl Dim {
    fn noun(self) -> &'static str {
        match self {
            Dim::Free => "a plain number",
            Dim::Length => "a length",
            Dim::Angle => "an angle",
        }
    }
}

/// A value with its dimension; lengths in pixels, angles in radians.
#[derive(Clone, Copy, Debug)]
struct Q {
    v: f64,
    dim: Dim,
}

const FUNCTIONS: &[&str] = &["min", "max", "clamp"];

impl Checker<'_> {
    /// Whether `v`, met where a number in `unit` is wanted, is arithmetic to evaluate rather
    /// than a literal to check (`40%` is arithmetic in a length: a part of the extent).
    pub(super) fn is_arithmetic(v: &ast::Value, unit: Unit) -> bool {
        match &v.kind {
            ValueKind::Chain { .. } | ValueKind::Neg(_) | ValueKind::Paren(_) | ValueKind::Field { .. } => true,
            ValueKind::Number { unit: Some(u), .. } => u == "%" && unit == Unit::Length,
            ValueKind::Call { name, .. } => FUNCTIONS.contains(&name.text.as_str()),
            _ => false,
        }
    }

    /// The value of the arithmetic `v` in the canonical units of `unit` (pixels, radians,
    /// fractions), or `None` after reporting why it has none.
    pub(super) fn evaluate(&mut self, v: &ast::Value, unit: Unit, dir: &Path) -> Option<f64> {
        self.steps = 0;
        let q = self.eval(v, unit, dir, 0)?;
        let x = match (unit, q.dim) {
            (Unit::Length, Dim::Free | Dim::Length) => q.v,
            (Unit::Angle, Dim::Angle) => q.v,
            (Unit::Angle, Dim::Free) => q.v.to_radians(),
            (Unit::Fraction | Unit::Plain, Dim::Free) => q.v,
            (_, dim) => {
                self.errors.push(
                    Diagnostic::error(format!("expected {}, found {}", unit.describe(), dim.noun()))
                        .with_code("tessera::unit")
                        .with_label(v.span, format!("this is {}", dim.noun())),
                );
                return None;
            }
        };
        Some(x)
    }

    fn eval(&mut self, v: &ast::Value, want: Unit, dir: &Path, depth: usize) -> Option<Q> {
        self.steps += 1;
        if self.steps == MAX_STEPS {
            self.errors.push(
                Diagnostic::error(format!("this value takes more than {MAX_STEPS} steps to evaluate"))
                    .with_code("tessera::expression")
                    .with_label(v.span, "evaluation stopped here")
                    .with_help("params that use other params several times grow exponentially; simplify them"),
            );
        }
        if self.steps >= MAX_STEPS {
            return None;
        }
        match &v.kind {
            ValueKind::Number { value, unit, .. } => self.literal(*value, unit.as_deref(), want, v.span),
            ValueKind::Paren(inner) => self.eval(inner, want, dir, depth),
            ValueKind::Neg(inner) => self.eval(inner, want, dir, depth).map(|q| Q { v: -q.v, ..q }),
            ValueKind::Field { base, field } => self.field(base, field, v.span),
            ValueKind::Ident(name) => self.param(name, v.span, want, dir, depth),
            ValueKind::Call { name, args } if FUNCTIONS.contains(&name.text.as_str()) => {
                self.function(&name.text, args, v.span, want, dir, depth)
            }
            ValueKind::Chain { first, rest } => {
                let mut acc = self.eval(first, want, dir, depth)?;
                let mut span = first.span;
                for (op, operand) in rest {
                    let q = self.eval(operand, want, dir, depth)?;
                    acc = self.apply(*op, acc, q, span, operand.span)?;
                    span = span.to(operand.span);
                }
                Some(acc)
            }
            other => {
                self.errors.push(
                    Diagnostic::error(format!("{} has no place in arithmetic", other.describe()))
                        .with_code("tessera::type")
                        .with_label(v.span, "expected a number"),
                );
                None
            }
        }
    }

    fn literal(&mut self, x: f64, unit: Option<&str>, want: Unit, span: Span) -> Option<Q> {
        let q = match unit {
            None => Q { v: x, dim: Dim::Free },
            Some("px") => Q { v: x, dim: Dim::Length },
            Some("deg") => Q { v: x.to_radians(), dim: Dim::Angle },
            Some("rad") => Q { v: x, dim: Dim::Angle },
            Some("%") if want == Unit::Length => {
                let extent = self.axis_extent(span)?;
                Q { v: x / 100.0 * extent, dim: Dim::Length }
            }
            Some("%") => Q { v: x / 100.0, dim: Dim::Free },
            Some(u) => {
                self.errors.push(
                    Diagnostic::error(format!("unit `{u}` does not fit in arithmetic"))
                        .with_code("tessera::unit")
                        .with_label(span, "wrong unit")
                        .with_help("numbers take `px`, `deg`, `rad` or `%`"),
                );
                return None;
            }
        };
        Some(q)
    }

    /// The side of the current declaration's extent that `40%` here is a part of.
    fn axis_extent(&mut self, span: Span) -> Option<f64> {
        let Some((w, h)) = self.extent else {
            self.errors.push(
                Diagnostic::error("a relative length needs a surface, and this declaration has none")
                    .with_code("tessera::relative")
                    .with_label(span, "relative to what?")
                    .with_help("give the length in pixels, or relative to the scene: `scene.width * 0.4`"),
            );
            return None;
        };
        Some(match self.axis {
            Axis::X => w,
            Axis::Y => h,
            Axis::Short => w.min(h),
        })
    }

    /// `scene.width`, `surface.height` (the declaration's own extent), `NAME.width`.
    fn field(&mut self, base: &ast::Ident, field: &ast::Ident, span: Span) -> Option<Q> {
        let extent = match base.text.as_str() {
            b if b == SCENE_SIZE => Some((self.size.0 as f64, self.size.1 as f64)),
            b if b == OWN_EXTENT => self.extent,
            name => match self.decls.iter().position(|d| d.name == name) {
                Some(i) => self.extent_of(i, 0),
                None => {
                    self.errors.push(
                        Diagnostic::error(format!("unknown name `{name}`"))
                            .with_code("tessera::unknown_name")
                            .with_label(base.span, "not `scene`, `surface` or a declaration"),
                    );
                    return None;
                }
            },
        };
        let Some((w, h)) = extent else {
            self.errors.push(
                Diagnostic::error(format!("`{}` has no size", base.text))
                    .with_code("tessera::relative")
                    .with_label(base.span, "neither a surface nor sized")
                    .with_help("sizes belong to the scene, surfaces, maps, and what is synthesised on a surface"),
            );
            return None;
        };
        match field.text.as_str() {
            "width" => Some(Q { v: w, dim: Dim::Length }),
            "height" => Some(Q { v: h, dim: Dim::Length }),
            other => {
                self.errors.push(
                    Diagnostic::error(format!("`{other}` is not a size: write `.width` or `.height`"))
                        .with_code("tessera::unknown_name")
                        .with_label(field.span.to(span), "here"),
                );
                None
            }
        }
    }

    fn param(&mut self, name: &str, span: Span, want: Unit, dir: &Path, depth: usize) -> Option<Q> {
        let Some(def) = self.params.get(name) else {
            self.errors.push(
                Diagnostic::error(format!("unknown name `{name}` in arithmetic"))
                    .with_code("tessera::unknown_name")
                    .with_label(span, "not a `param`")
                    .with_help(
                        "arithmetic reads numbers, params, `scene.width`/`.height` and `surface.width`/`.height`",
                    ),
            );
            return None;
        };
        if depth >= MAX_PARAM_DEPTH {
            let at = def.span;
            self.errors.push(
                Diagnostic::error(format!("param `{name}` refers to itself"))
                    .with_code("tessera::reference_cycle")
                    .with_label(at, "in this param"),
            );
            return None;
        }
        let value = def.value.clone();
        self.eval(&value, want, dir, depth + 1)
    }

    fn function(
        &mut self,
        name: &str,
        args: &[ast::Arg],
        span: Span,
        want: Unit,
        dir: &Path,
        depth: usize,
    ) -> Option<Q> {
        if let Some(named) = args.iter().find_map(|a| a.name.as_ref()) {
            self.errors.push(
                Diagnostic::error(format!("`{name}` takes its arguments by position"))
                    .with_code("tessera::argument")
                    .with_label(named.span, "remove this name"),
            );
            return None;
        }
        let count_ok = if name == "clamp" { args.len() == 3 } else { !args.is_empty() };
        if !count_ok {
            let wanted = if name == "clamp" { "`clamp(x, low, high)`: three values" } else { "at least one value" };
            self.errors.push(
                Diagnostic::error(format!("`{name}` takes {wanted}"))
                    .with_code("tessera::argument")
                    .with_label(span, format!("{} given", args.len())),
            );
            return None;
        }
        let mut values = Vec::with_capacity(args.len());
        for a in args {
            values.push((self.eval(&a.value, want, dir, depth)?, a.value.span));
        }
        if name == "clamp" {
            let (x, lo) = self.unify(values[0].0, values[1].0, values[0].1, values[1].1, name)?;
            let (x, hi) = self.unify(x, values[2].0, values[0].1, values[2].1, name)?;
            let (lo, hi) = self.unify(lo, hi, values[1].1, values[2].1, name)?;
            if lo.v > hi.v {
                self.errors.push(
                    Diagnostic::error("`clamp` has its low bound above its high bound")
                        .with_code("tessera::range")
                        .with_label(values[1].1, "low")
                        .with_label(values[2].1, "high"),
                );
                return None;
            }
            return Some(Q { v: x.v.clamp(lo.v, hi.v), dim: x.dim });
        }
        let (mut acc, first_span) = values[0];
        for &(q, at) in &values[1..] {
            let (a, b) = self.unify(acc, q, first_span, at, name)?;
            acc = Q { v: if name == "max" { a.v.max(b.v) } else { a.v.min(b.v) }, dim: a.dim };
        }
        Some(acc)
    }

    /// The extent of declaration `i` (see [`Extent`]), `None` if it has none. Its size
    /// property is read without reporting: its own check reports what is wrong with it.
    pub(super) fn extent_of(&mut self, i: usize, depth: usize) -> Option<(f64, f64)> {
        let scene = Some((self.size.0 as f64, self.size.1 as f64));
        let (spec, decl, file) = (self.decls[i].spec, self.decls[i].decl, self.decls[i].file);
        let written = |name: &str| decl.block.properties().find(|p| p.name.text == name).map(|p| p.value.clone());
        match spec.extent {
            Extent::None => None,
            Extent::Scene => scene,
            Extent::Prop(prop) => {
                let Some(v) = written(prop) else { return scene };
                let (errors, deps) = (self.errors.len(), self.deps.len());
                let size = self.check_value(&v, &Ty::Size, &self.dir_of(file), 0);
                self.errors.truncate(errors);
                self.deps.truncate(deps);
                match size {
                    Some(Val::Size(w, h)) => Some((w as f64, h as f64)),
                    _ => None,
                }
            }
            Extent::Ref(prop) => {
                let Some(mut v) = written(prop) else { return scene };
                // Through params to the name of a declaration.
                for _ in 0..MAX_PARAM_DEPTH {
                    let ValueKind::Ident(name) = &v.kind else { return None };
                    if let Some(j) = self.decls.iter().position(|d| &d.name == name) {
                        return if depth >= MAX_PARAM_DEPTH { None } else { self.extent_of(j, depth + 1) };
                    }
                    v = self.params.get(name)?.value.clone();
                }
                None
            }
        }
    }

    /// Two operands of one dimension (a free number takes the other's; in an angle it counts
    /// degrees), for `+`, `-`, `min`, `max` and `clamp`.
    fn unify(&mut self, a: Q, b: Q, a_at: Span, b_at: Span, what: &str) -> Option<(Q, Q)> {
        let lift = |q: Q, dim: Dim| match (q.dim, dim) {
            (Dim::Free, Dim::Angle) => Q { v: q.v.to_radians(), dim },
            (Dim::Free, _) => Q { v: q.v, dim },
            _ => q,
        };
        match (a.dim, b.dim) {
            (x, y) if x == y => Some((a, b)),
            (Dim::Free, d) => Some((lift(a, d), b)),
            (d, Dim::Free) => Some((a, lift(b, d))),
            (x, y) => {
                self.dims_mismatch(format!("`{what}` of {} and {}", x.noun(), y.noun()), (x, a_at), (y, b_at), None);
                None
            }
        }
    }

    /// Two operands whose dimensions do not combine: each labelled with its own.
    fn dims_mismatch(&mut self, message: String, (x, a_at): (Dim, Span), (y, b_at): (Dim, Span), help: Option<&str>) {
        let mut d =
            Diagnostic::error(message).with_code("tessera::unit").with_label(a_at, x.noun()).with_label(b_at, y.noun());
        if let Some(h) = help {
            d = d.with_help(h);
        }
        self.errors.push(d);
    }

    fn apply(&mut self, op: Op, a: Q, b: Q, a_at: Span, b_at: Span) -> Option<Q> {
        match op {
            Op::Add | Op::Sub => {
                let (a, b) = self.unify(a, b, a_at, b_at, op.symbol())?;
                Some(Q { v: if op == Op::Add { a.v + b.v } else { a.v - b.v }, dim: a.dim })
            }
            Op::Mul => match (a.dim, b.dim) {
                (Dim::Free, dim) | (dim, Dim::Free) => Some(Q { v: a.v * b.v, dim }),
                (x, y) => {
                    let help = "multiply a length or an angle by plain numbers only";
                    self.dims_mismatch(
                        format!("{} times {} has no meaning here", x.noun(), y.noun()),
                        (x, a_at),
                        (y, b_at),
                        Some(help),
                    );
                    None
                }
            },
            Op::Div => {
                if b.v == 0.0 {
                    self.errors.push(
                        Diagnostic::error("division by zero")
                            .with_code("tessera::division_by_zero")
                            .with_label(b_at, "this is 0"),
                    );
                    return None;
                }
                let dim = match (a.dim, b.dim) {
                    (dim, Dim::Free) => dim,
                    (x, y) if x == y => Dim::Free,
                    (x, y) => {
                        self.dims_mismatch(
                            format!("{} divided by {} has no meaning here", x.noun(), y.noun()),
                            (x, a_at),
                            (y, b_at),
                            None,
                        );
                        return None;
                    }
                };
                Some(Q { v: a.v / b.v, dim })
            }
        }
    }
}
