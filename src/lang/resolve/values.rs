//! Type checking of one value: params substituted, numbers with their units and ranges,
//! integers read exactly, sizes, vectors, paths, directories and enums.

use std::path::{Path, PathBuf};

use super::axis::Axis;
use super::load::normalize;
use super::namespace::Checker;
use crate::lang::ast::{self, ValueKind};
use crate::lang::diag::{suggest, Diagnostic};
use crate::lang::ir::Val;
use crate::lang::schema::{Range, Ty, Unit};
use crate::lang::source::Span;

/// The largest side of any raster a scene may ask for: 16384² f32 pixels is already 1 GiB
/// per channel, and a typo should not be able to exhaust the machine's memory.
const MAX_SIDE: f64 = 16384.0;

/// The largest magnitude of a number: stages compute in f32, and a larger f64 would reach
/// them as an infinity (reported as "inf", far from the number the user wrote).
const MAX_NUMBER: f64 = f32::MAX as f64;

/// The largest integer a property may hold: 2^53, up to which every integer is exactly an
/// f64 (integers also serve as numbers, and params pass through the same values).
const MAX_EXACT_INT: i64 = 1 << 53;

/// The exact value of an integer literal (`12`, `-3`, `1.5e3`, `20.0`) from its digits:
/// `None` if the text is not a whole number, `Some(None)` if it is one too large for i128.
fn integer_literal(text: &str) -> Option<Option<i128>> {
    let (negative, t) = match text.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, text),
    };
    let (mantissa, exponent) = match t.find(['e', 'E']) {
        Some(i) => (&t[..i], &t[i + 1..]),
        None => (t, "0"),
    };
    let (int, frac) = mantissa.split_once('.').unwrap_or((mantissa, ""));
    // An exponent too long for i64 makes the value certainly too large (or below 1).
    let exponent: i64 = exponent.parse().unwrap_or(if exponent.starts_with('-') { i64::MIN / 2 } else { i64::MAX / 2 });
    let digits: String = format!("{int}{frac}");
    let digits = digits.trim_start_matches('0');
    if digits.is_empty() {
        return Some(Some(0));
    }
    // value = digits × 10^scale
    let scale = exponent - frac.len() as i64;
    let (whole, rest) = if scale >= 0 {
        (digits.to_string(), "")
    } else {
        let cut = digits.len() as i64 + scale;
        if cut <= 0 {
            return None; // 0 < value < 1
        }
        (digits[..cut as usize].to_string(), &digits[cut as usize..])
    };
    if rest.bytes().any(|b| b != b'0') {
        return None;
    }
    if whole.len() as i64 + scale.max(0) > 38 {
        return Some(None);
    }
    let n: i128 = whole.parse().ok()?;
    let n = n * 10i128.pow(scale.max(0) as u32);
    Some(Some(if negative { -n } else { n }))
}

impl Checker<'_> {
    fn mismatch(&mut self, v: &ast::Value, ty: &Ty) -> Option<Val> {
        self.errors.push(
            Diagnostic::error(format!("expected {}, found {}", ty.describe(), v.kind.describe_shape()))
                .with_code("tessera::type")
                .with_label(v.span, format!("expected {}", ty.describe())),
        );
        None
    }

    pub(super) fn check_value(&mut self, v: &ast::Value, ty: &Ty, dir: &Path, depth: usize) -> Option<Val> {
        // A bare name that is a `param` stands for the param's value, unless a declaration
        // is expected and one of that name exists.
        if let ValueKind::Ident(name) = &v.kind {
            let wants_ref = matches!(ty, Ty::Ref(_) | Ty::Refs(_) | Ty::Source { .. });
            if !(wants_ref && self.kinds.contains_key(name)) {
                if let Some(def) = self.params.get(name) {
                    if depth > 16 {
                        self.errors.push(
                            Diagnostic::error(format!("param `{name}` refers to itself"))
                                .with_code("tessera::reference_cycle")
                                .with_label(def.span, "in this param"),
                        );
                        return None;
                    }
                    let value = def.value.clone();
                    return self.check_value(&value, ty, dir, depth + 1);
                }
            }
        }
        if let Some(val) = self.arithmetic(v, ty, dir) {
            return val;
        }
        if let (Ty::Pixels(range), ValueKind::Number { text, unit, .. }) = (ty, &v.kind) {
            let text = match unit {
                Some(u) => format!("{text} {u}"),
                None => text.clone(),
            };
            let val = self.check_value(v, &Ty::Number(Unit::Length, *range), dir, depth + 1)?;
            if let Val::Num(x) = val {
                if x.fract() != 0.0 {
                    self.errors.push(
                        Diagnostic::error(format!("`{text}` is not a whole number of pixels"))
                            .with_code("tessera::whole_pixels")
                            .with_label(v.span, format!("{x} pixels"))
                            .with_help(format!("this property counts pixels: use `{} px`", x.round())),
                    );
                    return None;
                }
            }
            return Some(val);
        }
        match (ty, &v.kind) {
            (Ty::Number(unit, range), ValueKind::Number { value, unit: u, text }) => {
                if !value.is_finite() || value.abs() > MAX_NUMBER {
                    self.errors.push(
                        Diagnostic::error(format!("`{text}` is too large: numbers lie within ±{MAX_NUMBER:.1e}"))
                            .with_code("tessera::range")
                            .with_label(v.span, "beyond the range of numbers")
                            .with_help("tessera computes in 32-bit floats, whose largest value is about 3.4e38"),
                    );
                    return None;
                }
                let x = self.convert_unit(*value, u.as_deref(), *unit, v.span)?;
                self.number(x, text, *unit, *range, v.span)
            }
            (Ty::Int(lo, hi), ValueKind::Number { text, unit: None, .. }) => {
                // Integers are read from their digits, not through an f64 (which rounds
                // 9007199254740993 to ...992), and are kept within ±2^53 so that any use
                // of them as a number is exact too.
                let (lo, hi) = ((*lo).max(-MAX_EXACT_INT), (*hi).min(MAX_EXACT_INT));
                match integer_literal(text) {
                    Some(Some(n)) if (i128::from(lo)..=i128::from(hi)).contains(&n) => Some(Val::Int(n as i64)),
                    found => {
                        let label = if found.is_none() { "not a whole number" } else { "out of range" };
                        let mut d = Diagnostic::error(format!("expected an integer from {lo} to {hi}, found {text}"))
                            .with_code("tessera::range")
                            .with_label(v.span, label);
                        if hi == MAX_EXACT_INT {
                            d = d.with_help(
                                "integers are limited to 2^53, the largest range a 64-bit float holds exactly",
                            );
                        }
                        self.errors.push(d);
                        None
                    }
                }
            }
            (Ty::Bool, ValueKind::Bool(b)) => Some(Val::Bool(*b)),
            (Ty::Size, ValueKind::Size { w, h, .. }) => {
                let ok = |x: f64| x.fract() == 0.0 && (1.0..=MAX_SIDE).contains(&x);
                if !ok(*w) || !ok(*h) {
                    self.errors.push(
                        Diagnostic::error(format!("sizes are whole numbers of pixels from 1 to {MAX_SIDE}"))
                            .with_code("tessera::range")
                            .with_label(v.span, "invalid size"),
                    );
                    return None;
                }
                Some(Val::Size(*w as u32, *h as u32))
            }
            (Ty::Vec2(unit), ValueKind::Vector(items)) => {
                if items.len() != 2 {
                    self.errors.push(
                        Diagnostic::error(format!("expected a vector of 2 numbers, found {}", items.len()))
                            .with_code("tessera::type")
                            .with_label(v.span, "expected `[x, y]`"),
                    );
                    return None;
                }
                self.numbers(items, *unit, crate::lang::schema::ANY).map(Val::Numbers)
            }
            (Ty::Colour, ValueKind::Vector(items)) => {
                if items.len() != 3 {
                    self.errors.push(
                        Diagnostic::error(format!("a colour is three numbers `[r, g, b]`, not {}", items.len()))
                            .with_code("tessera::type")
                            .with_label(v.span, "expected `[r, g, b]`"),
                    );
                    return None;
                }
                self.numbers(items, Unit::Plain, crate::lang::schema::UNIT).map(Val::Numbers)
            }
            (Ty::Numbers(unit, range), ValueKind::Vector(items)) => {
                self.numbers(items, *unit, *range).map(Val::Numbers)
            }
            (Ty::Points, ValueKind::Vector(items)) => {
                let mut pts = Vec::new();
                for it in items {
                    match &it.kind {
                        ValueKind::Vector(xy) if xy.len() == 2 => {
                            let n = self.numbers(xy, Unit::Length, crate::lang::schema::ANY)?;
                            pts.push([n[0], n[1]]);
                        }
                        _ => return self.mismatch(it, &Ty::Vec2(Unit::Length)),
                    }
                }
                Some(Val::Points(pts))
            }
            (Ty::Str, ValueKind::Str(s)) => Some(Val::Str(s.clone())),
            (Ty::Path, ValueKind::Str(s)) => {
                if s.is_empty() {
                    self.errors.push(
                        Diagnostic::error("empty file path").with_code("tessera::type").with_label(v.span, "here"),
                    );
                    return None;
                }
                Some(Val::Path(normalize(&dir.join(s))))
            }
            (Ty::Dir(extensions), ValueKind::Str(s)) => self.directory(s, v.span, dir, extensions),
            (Ty::Files(extensions), ValueKind::Str(s)) => self.files_matching(s, v.span, dir, extensions),
            (Ty::Files(extensions), ValueKind::Vector(items)) => {
                let (mut files, mut spans) = (Vec::with_capacity(items.len()), Vec::with_capacity(items.len()));
                for it in items {
                    let ValueKind::Str(s) = &it.kind else { return self.mismatch(it, &Ty::Path) };
                    let path = self.file_path(s, it.span, dir, extensions)?;
                    files.push(path);
                    spans.push(it.span);
                }
                if files.is_empty() {
                    self.errors.push(
                        Diagnostic::error("the list of files is empty")
                            .with_code("tessera::type")
                            .with_label(v.span, "name at least one file"),
                    );
                    return None;
                }
                Some(Val::Files(files, spans))
            }
            (Ty::Enum(options), ValueKind::Ident(name)) => {
                if options.contains(&name.as_str()) {
                    Some(Val::Enum(name.clone()))
                } else {
                    let mut d = Diagnostic::error(format!("`{name}` is not {}", ty.describe()))
                        .with_code("tessera::enum")
                        .with_label(v.span, "unknown option");
                    if let Some(s) = suggest(name, options.iter().copied()) {
                        d = d.with_help(format!("did you mean `{s}`?"));
                    }
                    self.errors.push(d);
                    None
                }
            }
            (Ty::Ref(kinds), ValueKind::Ident(name)) => self.reference(name, v.span, kinds).map(Val::Ref),
            (Ty::Refs(kinds), ValueKind::Vector(items)) => {
                let mut out = Vec::new();
                for it in items {
                    match &it.kind {
                        ValueKind::Ident(n) => out.push(self.reference(n, it.span, kinds)?),
                        _ => return self.mismatch(it, &Ty::Ref(kinds)),
                    }
                }
                Some(Val::Refs(out))
            }
            (Ty::Source { refs, .. }, ValueKind::Ident(name)) if !refs.is_empty() => {
                self.reference(name, v.span, refs).map(Val::Ref)
            }
            (Ty::Source { calls, .. }, ValueKind::Call { name, args }) => self.call(calls, name, args, v.span, dir),
            (Ty::Calls(calls), ValueKind::Call { name, args }) => match self.call(calls, name, args, v.span, dir)? {
                Val::Call(c) => Some(Val::Calls(vec![c])),
                _ => None,
            },
            (Ty::Calls(calls), ValueKind::Vector(items)) => {
                let mut out = Vec::with_capacity(items.len());
                let mut ok = true;
                for it in items {
                    match &it.kind {
                        ValueKind::Call { name, args } => match self.call(calls, name, args, it.span, dir) {
                            Some(Val::Call(c)) => out.push(c),
                            _ => ok = false,
                        },
                        _ => {
                            self.mismatch(it, &Ty::Source { calls, refs: &[] });
                            ok = false;
                        }
                    }
                }
                ok.then_some(Val::Calls(out))
            }
            (Ty::Block(specs), ValueKind::Block(b)) => {
                Some(Val::Block(self.check_block(b, specs, dir, v.span, "block")))
            }
            (Ty::Block(_), _) => self.mismatch(v, ty),
            (_, ValueKind::Ident(name)) if !matches!(ty, Ty::Enum(_)) && !self.kinds.contains_key(name) => {
                self.unknown_name(name, v.span, ty)
            }
            _ => self.mismatch(v, ty),
        }
    }

    /// A converted number's checks: finite, not lost in 32-bit floats, in range.
    fn number(&mut self, x: f64, text: &str, unit: Unit, range: Range, span: Span) -> Option<Val> {
        if !x.is_finite() || x.abs() > MAX_NUMBER {
            self.errors.push(
                Diagnostic::error(format!("`{text}` overflows when converted to {}", unit.canonical()))
                    .with_code("tessera::range")
                    .with_label(span, "too large once converted"),
            );
            return None;
        }
        if x != 0.0 && (x.abs() as f32) < f32::MIN_POSITIVE {
            self.errors.push(
                Diagnostic::error(format!("`{text}` is too small: it rounds to 0 in 32-bit floats"))
                    .with_code("tessera::range")
                    .with_label(span, "below the smallest normal 32-bit float (about 1.2e-38)")
                    .with_help("write `0` if zero is meant"),
            );
            return None;
        }
        self.in_range(x, range, unit, span)
    }

    /// `Some` when `v` is arithmetic where a number is wanted (see [`Checker::is_arithmetic`]):
    /// its checked value, or `Some(None)` after an error. A computed whole-pixel length is
    /// rounded to the nearest pixel (a written fraction is refused instead); a computed
    /// integer must come out whole.
    fn arithmetic(&mut self, v: &ast::Value, ty: &Ty, dir: &Path) -> Option<Option<Val>> {
        let unit = match ty {
            Ty::Number(unit, _) => *unit,
            Ty::Pixels(_) => Unit::Length,
            Ty::Int(..) => Unit::Plain,
            _ => return None,
        };
        if !Self::is_arithmetic(v, unit) {
            return None;
        }
        let text = self.sources.slice(v.span).to_string();
        let Some(x) = self.evaluate(v, unit, dir) else { return Some(None) };
        Some(match ty {
            Ty::Number(unit, range) => self.number(x, &text, *unit, *range, v.span),
            Ty::Pixels(range) => self.number(x.round(), &text, Unit::Length, *range, v.span),
            Ty::Int(lo, hi) => {
                let (lo, hi) = ((*lo).max(-MAX_EXACT_INT), (*hi).min(MAX_EXACT_INT));
                if x.fract() != 0.0 || x < lo as f64 || x > hi as f64 {
                    self.errors.push(
                        Diagnostic::error(format!("expected an integer from {lo} to {hi}, found {x}"))
                            .with_code("tessera::range")
                            .with_label(v.span, format!("this is {x}")),
                    );
                    None
                } else {
                    Some(Val::Int(x as i64))
                }
            }
            _ => unreachable!("only numeric types are evaluated"),
        })
    }

    fn unknown_name(&mut self, name: &str, span: Span, ty: &Ty) -> Option<Val> {
        let mut d = Diagnostic::error(format!("unknown name `{name}`"))
            .with_code("tessera::unknown_name")
            .with_label(span, format!("expected {}", ty.describe()));
        let candidates: Vec<&str> = self.params.keys().map(|k| k.as_str()).collect();
        if let Some(s) = suggest(name, candidates) {
            d = d.with_help(format!("did you mean the param `{s}`?"));
        }
        self.errors.push(d);
        None
    }

    /// A directory and the files in it with one of `extensions`, sorted by name.
    fn directory(&mut self, s: &str, span: Span, dir: &Path, extensions: &[&str]) -> Option<Val> {
        let path = normalize(&dir.join(s));
        let listed = match self.loader.list(&path) {
            Ok(l) => l,
            Err(e) => {
                self.errors.push(
                    Diagnostic::error(format!("cannot read the directory `{}`: {e}", path.display()))
                        .with_code("tessera::directory")
                        .with_label(span, "this directory"),
                );
                return None;
            }
        };
        let mut files: Vec<PathBuf> = listed
            .into_iter()
            .filter(|f| {
                f.extension()
                    .and_then(|e| e.to_str())
                    .is_some_and(|e| extensions.iter().any(|x| x.eq_ignore_ascii_case(e)))
            })
            .collect();
        files.sort();
        if files.is_empty() {
            let list = extensions.iter().map(|e| format!("`.{e}`")).collect::<Vec<_>>().join(", ");
            self.errors.push(
                Diagnostic::error(format!("the directory `{}` holds no {list} files", path.display()))
                    .with_code("tessera::empty_directory")
                    .with_label(span, "this directory is empty")
                    .with_help("put at least one image in it, or name another directory"),
            );
            return None;
        }
        Some(Val::Dir(path, files))
    }

    /// One path of a files property: not empty, with one of the extensions.
    fn file_path(&mut self, s: &str, span: Span, dir: &Path, extensions: &[&str]) -> Option<PathBuf> {
        let path = normalize(&dir.join(s));
        let ok = !s.is_empty()
            && path
                .extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| extensions.iter().any(|x| x.eq_ignore_ascii_case(e)));
        if !ok {
            let list = extensions.iter().map(|e| format!("`.{e}`")).collect::<Vec<_>>().join(", ");
            self.errors.push(
                Diagnostic::error(format!("expected a {list} file, found `{s}`"))
                    .with_code("tessera::type")
                    .with_label(span, "not one of these files"),
            );
            return None;
        }
        Some(path)
    }

    /// A files property written as one string: the file it names, or the files its pattern
    /// matches (`*` and `?` in the file name only), sorted by name.
    fn files_matching(&mut self, s: &str, span: Span, dir: &Path, extensions: &[&str]) -> Option<Val> {
        let (folder, pattern) = match s.rfind('/') {
            Some(i) => (&s[..i], &s[i + 1..]),
            None => ("", s),
        };
        if folder.contains(['*', '?']) {
            self.errors.push(
                Diagnostic::error("a file pattern may use `*` and `?` in the file name only")
                    .with_code("tessera::pattern")
                    .with_label(span, "wildcard in a directory name"),
            );
            return None;
        }
        if !pattern.contains(['*', '?']) {
            let path = self.file_path(s, span, dir, extensions)?;
            return Some(Val::Files(vec![path], vec![span]));
        }
        let folder = normalize(&dir.join(if folder.is_empty() { "." } else { folder }));
        let listed = match self.loader.list(&folder) {
            Ok(l) => l,
            Err(e) => {
                self.errors.push(
                    Diagnostic::error(format!("cannot read the directory `{}`: {e}", folder.display()))
                        .with_code("tessera::directory")
                        .with_label(span, "this pattern's directory"),
                );
                return None;
            }
        };
        let mut files: Vec<PathBuf> = listed
            .into_iter()
            .filter(|f| {
                let name = f.file_name().and_then(|n| n.to_str()).unwrap_or("");
                wildcard_match(pattern.as_bytes(), name.as_bytes())
                    && f.extension()
                        .and_then(|e| e.to_str())
                        .is_some_and(|e| extensions.iter().any(|x| x.eq_ignore_ascii_case(e)))
            })
            .map(|f| normalize(&f))
            .collect();
        files.sort();
        if files.is_empty() {
            self.errors.push(
                Diagnostic::error(format!("no file in `{}` matches `{pattern}`", folder.display()))
                    .with_code("tessera::empty_pattern")
                    .with_label(span, "matches nothing"),
            );
            return None;
        }
        let spans = vec![span; files.len()];
        Some(Val::Files(files, spans))
    }

    /// The numbers of a vector; a relative length in it is a part of the width at even
    /// positions and of the height at odd ones (`[x, y]`, `[x, y, w, h]`).
    fn numbers(&mut self, items: &[ast::Value], unit: Unit, range: Range) -> Option<Vec<f64>> {
        let mut out = Vec::with_capacity(items.len());
        let outer = self.axis;
        for (i, it) in items.iter().enumerate() {
            self.axis = if i % 2 == 0 { Axis::X } else { Axis::Y };
            let checked = self.check_value(it, &Ty::Number(unit, range), Path::new(""), 0);
            self.axis = outer;
            match checked? {
                Val::Num(x) => out.push(x),
                _ => return None,
            }
        }
        Some(out)
    }

    fn convert_unit(&mut self, x: f64, written: Option<&str>, unit: Unit, span: Span) -> Option<f64> {
        let v = match (unit, written) {
            (Unit::Length, None | Some("px")) => Some(x),
            (Unit::Angle, None | Some("deg")) => Some(x.to_radians()),
            (Unit::Angle, Some("rad")) => Some(x),
            (Unit::Fraction, None) => Some(x),
            (Unit::Fraction, Some("%")) => Some(x / 100.0),
            (Unit::Plain, None) => Some(x),
            _ => None,
        };
        if v.is_none() {
            let w = written.unwrap_or("");
            let help = match unit {
                Unit::Length => "lengths are in pixels: write `px` or no unit",
                Unit::Angle => "angles take `deg` (the default) or `rad`",
                Unit::Fraction => "fractions are plain numbers or percentages",
                Unit::Plain => "remove the unit",
            };
            self.errors.push(
                Diagnostic::error(format!("unit `{w}` does not fit here: expected {}", unit.describe()))
                    .with_code("tessera::unit")
                    .with_label(span, "wrong unit")
                    .with_help(help),
            );
        }
        v
    }

    fn in_range(&mut self, x: f64, r: Range, unit: Unit, span: Span) -> Option<Val> {
        if !x.is_finite() {
            self.errors.push(
                Diagnostic::error("number too large")
                    .with_code("tessera::range")
                    .with_label(span, "not a finite number"),
            );
            return None;
        }
        if x >= r.min && x <= r.max {
            return Some(Val::Num(x));
        }
        let compact = |b: f64| {
            if b != 0.0 && !(1e-4..1e9).contains(&b.abs()) {
                format!("{b:e}")
            } else {
                format!("{b}")
            }
        };
        let shown = |b: f64| if unit == Unit::Angle { format!("{} deg", compact(b.to_degrees())) } else { compact(b) };
        let msg = if r.max == f64::INFINITY && r.min == f64::MIN_POSITIVE {
            "must be greater than 0".to_string()
        } else if r.max == f64::INFINITY {
            format!("must be at least {}", shown(r.min))
        } else {
            format!("must be from {} to {}", shown(r.min), shown(r.max))
        };
        self.errors.push(
            Diagnostic::error(format!("value out of range: {msg}")).with_code("tessera::range").with_label(span, msg),
        );
        None
    }
}

#[cfg(test)]
mod tests {
    use super::integer_literal;

    #[test]
    fn integer_literals_are_read_exactly() {
        assert_eq!(integer_literal("9007199254740993"), Some(Some(9_007_199_254_740_993)));
        assert_eq!(integer_literal("-12"), Some(Some(-12)));
        assert_eq!(integer_literal("1.5e3"), Some(Some(1500)));
        assert_eq!(integer_literal("20.000"), Some(Some(20)));
        assert_eq!(integer_literal("0.0"), Some(Some(0)));
        assert_eq!(integer_literal("1200e-2"), Some(Some(12)));
        assert_eq!(integer_literal("1.5"), None);
        assert_eq!(integer_literal("9007199254740992.5"), None);
        assert_eq!(integer_literal("5e-1"), None);
        assert_eq!(integer_literal("1e400"), Some(None));
        assert_eq!(integer_literal("1e99999999999999999999"), Some(None));
        assert_eq!(integer_literal("1e-99999999999999999999"), None);
    }
}

/// Whether `name` matches `pattern`: `*` any run of bytes, `?` one byte. Linear in the
/// product of the lengths at worst (the last `*` is the only backtracking point).
fn wildcard_match(pattern: &[u8], name: &[u8]) -> bool {
    let (mut p, mut n) = (0, 0);
    let mut star: Option<(usize, usize)> = None;
    while n < name.len() {
        if p < pattern.len() && (pattern[p] == b'?' || pattern[p] == name[n]) {
            p += 1;
            n += 1;
        } else if p < pattern.len() && pattern[p] == b'*' {
            star = Some((p, n));
            p += 1;
        } else if let Some((sp, sn)) = star {
            p = sp + 1;
            n = sn + 1;
            star = Some((sp, sn + 1));
        } else {
            return false;
        }
    }
    pattern[p..].iter().all(|&c| c == b'*')
}

#[cfg(test)]
mod wildcard_tests {
    use super::wildcard_match;

    #[test]
    fn stars_and_question_marks() {
        let m = |p: &str, n: &str| wildcard_match(p.as_bytes(), n.as_bytes());
        assert!(m("img_*.png", "img_030_45.png"));
        assert!(m("*", "anything.exr"));
        assert!(m("a?c.png", "abc.png"));
        assert!(!m("a?c.png", "ac.png"));
        assert!(m("*_*_*.png", "a_b_c.png"));
        assert!(!m("*.png", "a.png.bak"));
        assert!(m("**a", "aaa"));
        assert!(!m("img_*.png", "im_1.png"));
    }
}
