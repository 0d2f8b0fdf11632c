//! Text → syntax tree, with pest doing the recognition and this module building the AST.

use pest::iterators::Pair;
use pest::Parser;

use super::ast::*;
use super::diag::Diagnostic;
use super::source::{FileId, Span};

#[derive(pest_derive::Parser)]
#[grammar = "../grammar/tessera.pest"]
struct SceneParser;

/// How deeply `{`, `[` and `(` may nest. Scenes written by hand nest a handful of levels;
/// the limit is checked before anything recursive runs (pest, the AST builder, the resolver,
/// the formatter, even dropping the tree), so no input can exhaust the stack.
pub const MAX_NESTING: usize = 64;

/// Parses a whole scene file.
pub fn parse_file(text: &str, file: FileId) -> Result<File, Diagnostic> {
    let brackets = scan_brackets(text, file)?;
    // Track expected literal tokens (`)`, `,`, `=`) too, not only rules, so that a
    // syntax error can say "expected `,` or `)`".
    pest::set_error_detail(true);
    let mut pairs = SceneParser::parse(Rule::file, text).map_err(|e| syntax_error(e, text, file, brackets))?;
    let root = pairs.next().expect("pest yields the file rule");
    let b = Builder { file };
    let items = root.into_inner().filter(|p| p.as_rule() != Rule::EOI).map(|p| b.item(p)).collect();
    Ok(File { items })
}

/// Parses a lone value, as given on the command line by `--set name=value`.
pub fn parse_value(text: &str, file: FileId) -> Result<Value, Diagnostic> {
    let brackets = scan_brackets(text, file)?;
    // A value rule anchored at both ends: wrap in a tiny file so the grammar stays single-rooted.
    let mut pairs = SceneParser::parse(Rule::value, text).map_err(|e| syntax_error(e, text, file, brackets))?;
    let pair = pairs.next().expect("pest yields the value rule");
    let consumed = pair.as_span().end();
    if text[consumed..].trim().is_empty() {
        Ok(Builder { file }.value(pair))
    } else {
        Err(Diagnostic::error(format!("unexpected `{}` after the value", text[consumed..].trim()))
            .with_label(Span::new(file, consumed, text.len()), "not part of the value"))
    }
}

/// The first bracket that does not pair up, found by a scan that skips strings and comments.
/// It is reported only when pest fails too, and only if pest's failure comes at or after
/// `origin`: an unbalanced bracket makes pest fail somewhere after it, at a place that
/// says nothing about the bracket ("expected `{` or `=`" on the next declaration).
struct BracketError {
    origin: usize,
    diagnostic: Diagnostic,
}

fn closer_of(open: u8) -> u8 {
    match open {
        b'{' => b'}',
        b'[' => b']',
        _ => b')',
    }
}

/// Checks the nesting depth (an error at once: it guards everything recursive) and finds
/// the first unbalanced bracket (kept for the syntax error, if pest fails).
fn scan_brackets(text: &str, file: FileId) -> Result<Option<BracketError>, Diagnostic> {
    let b = text.as_bytes();
    let at = |i: usize| Span::new(file, i, i + 1);
    let mut open: Vec<(u8, usize)> = Vec::new();
    let mut first: Option<BracketError> = None;
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            // A string runs to its closing quote or, unterminated, to the end of the line.
            b'"' => {
                i += 1;
                while i < b.len() && b[i] != b'"' && b[i] != b'\n' {
                    if b[i] == b'\\' && i + 1 < b.len() && b[i + 1] != b'\n' {
                        i += 1;
                    }
                    i += 1;
                }
            }
            b'#' => {
                while i < b.len() && b[i] != b'\n' {
                    i += 1;
                }
            }
            b'/' if b.get(i + 1) == Some(&b'/') => {
                while i < b.len() && b[i] != b'\n' {
                    i += 1;
                }
            }
            c @ (b'{' | b'[' | b'(') => {
                if open.len() >= MAX_NESTING {
                    return Err(Diagnostic::error(format!(
                        "nesting too deep: more than {MAX_NESTING} levels of brackets"
                    ))
                    .with_code("tessera::nesting")
                    .with_label(at(i), format!("this `{}` opens level {}", c as char, open.len() + 1))
                    .with_help(format!(
                        "blocks, vectors and calls may nest at most {MAX_NESTING} deep; \
                         move inner parts into declarations or params of their own"
                    )));
                }
                open.push((c, i));
            }
            c @ (b'}' | b']' | b')') => match open.pop() {
                Some((o, _)) if closer_of(o) == c => {}
                Some((o, oi)) if first.is_none() => {
                    first = Some(BracketError {
                        origin: oi,
                        diagnostic: Diagnostic::error(format!(
                            "mismatched `{}`: the `{}` opened before it is not closed",
                            c as char, o as char
                        ))
                        .with_code("tessera::syntax")
                        .with_label(at(i), format!("expected `{}` before this", closer_of(o) as char))
                        .with_label(at(oi), format!("this `{}` is not closed", o as char)),
                    });
                }
                None if first.is_none() => {
                    first = Some(BracketError {
                        origin: i,
                        diagnostic: Diagnostic::error(format!("unexpected `{}`: nothing is open here", c as char))
                            .with_code("tessera::syntax")
                            .with_label(at(i), "this closes nothing")
                            .with_help("remove it, or add the opening bracket it was meant to close"),
                    });
                }
                _ => {}
            },
            _ => {}
        }
        i += 1;
    }
    if first.is_none() {
        if let Some(&(o, oi)) = open.first() {
            // The outermost unclosed bracket: an inner one left open is usually closed, wrongly,
            // by the `}` meant for its parent, which leaves the parent open.
            let mut d = Diagnostic::error(format!("unclosed `{}`", o as char))
                .with_code("tessera::syntax")
                .with_label(at(oi), format!("this `{}` is never closed", o as char))
                .with_help(format!(
                    "add the missing `{}`; a closing bracket further down may be closing another one",
                    closer_of(o) as char
                ));
            for &(o2, oi2) in open.iter().skip(1) {
                d = d.with_label(at(oi2), format!("nor is this `{}`", o2 as char));
            }
            first = Some(BracketError { origin: oi, diagnostic: d });
        }
    }
    Ok(first)
}

fn syntax_error(e: pest::error::Error<Rule>, text: &str, file: FileId, brackets: Option<BracketError>) -> Diagnostic {
    use pest::error::{ErrorVariant, InputLocation};
    let (start, end) = match e.location {
        InputLocation::Pos(p) => (p, p),
        InputLocation::Span((a, b)) => (a, b),
    };
    if let Some(b) = brackets {
        if start >= b.origin {
            return b.diagnostic;
        }
    }
    if let Some(d) = non_ascii_name(text, start, file) {
        return d;
    }
    let tokens: Vec<String> = e
        .parse_attempts()
        .map(|a| {
            a.expected_tokens()
                .into_iter()
                .map(|t| t.to_string())
                // Punctuation only: letters, digits and comment starts are never the fix.
                .filter(|t| matches!(t.as_str(), ")" | "," | "=" | "{" | "}" | "]" | "("))
                .map(|t| format!("`{t}`"))
                .collect()
        })
        .unwrap_or_default();
    let expected = match &e.variant {
        ErrorVariant::ParsingError { positives, .. } => {
            // Optional trailers (a unit after a number, a comment) are never what is missing.
            let rules: Vec<Rule> =
                positives.iter().copied().filter(|r| !matches!(r, Rule::unit | Rule::comment)).collect();
            let mut parts: Vec<String> = Vec::new();
            let candidates: Vec<String> =
                rules.iter().filter_map(describe_rule).map(str::to_string).chain(tokens.iter().cloned()).collect();
            for p in candidates {
                if !parts.contains(&p) {
                    parts.push(p);
                }
            }
            parts
        }
        // pest's own guards ("stack limit reached", "call limit reached"): the depth check
        // above keeps scenes from reaching them, but a caller on a small stack might.
        ErrorVariant::CustomError { .. } => {
            return Diagnostic::error("the scene is nested too deeply to parse")
                .with_code("tessera::nesting")
                .with_label(Span::new(file, start, end), "the parser gave up here")
                .with_help("flatten the nested values, or move parts into declarations of their own");
        }
    };
    let found = found_at(text, start);
    let message = if expected.is_empty() {
        format!("syntax error: unexpected {found}")
    } else {
        format!("syntax error: expected {}", join_alternatives(&expected))
    };
    let label = if expected.is_empty() { "not valid here".to_string() } else { "here".to_string() };
    Diagnostic::error(message).with_code("tessera::syntax").with_label(Span::new(file, start, end), label)
}

/// What the text holds at `pos`, for "unexpected …".
fn found_at(text: &str, pos: usize) -> String {
    match text.get(pos..).and_then(|t| t.chars().next()) {
        None => "end of file".into(),
        Some(c) if c.is_control() || c.is_whitespace() || c == '\u{feff}' => {
            format!("character {}", c.escape_unicode())
        }
        Some(c) => format!("`{c}`"),
    }
}

/// A syntax error at a non-ASCII letter is a name written with non-ASCII characters (the
/// grammar's names are ASCII); say so, at the whole word.
fn non_ascii_name(text: &str, pos: usize, file: FileId) -> Option<Diagnostic> {
    let c = text.get(pos..)?.chars().next()?;
    if c.is_ascii() || !c.is_alphanumeric() {
        return None;
    }
    let word = |ch: char| ch.is_alphanumeric() || ch == '_' || ch == '-';
    let start = text[..pos].char_indices().rev().take_while(|&(_, ch)| word(ch)).last().map_or(pos, |(i, _)| i);
    let end = text[pos..].char_indices().find(|&(_, ch)| !word(ch)).map_or(text.len(), |(i, _)| pos + i);
    let name = &text[start..end];
    Some(
        Diagnostic::error(format!("names are ASCII: `{name}` contains `{c}`"))
            .with_code("tessera::syntax")
            .with_label(Span::new(file, start, end), "not an ASCII name")
            .with_help(
                "names are made of ASCII letters, digits, `_` and `-`; other text belongs in strings or comments",
            ),
    )
}

fn join_alternatives(parts: &[String]) -> String {
    match parts {
        [] => "something else".into(),
        [one] => one.clone(),
        [rest @ .., last] => format!("{} or {}", rest.join(", "), last),
    }
}

/// A rule as the user would name it; `None` for rules that say nothing useful.
fn describe_rule(rule: &Rule) -> Option<&'static str> {
    Some(match rule {
        Rule::EOI => "end of file",
        Rule::item | Rule::decl | Rule::kind => "a declaration",
        Rule::import => "`import`",
        Rule::param => "`param`",
        Rule::comment => "a comment",
        Rule::block => "`{`",
        Rule::property => "a property",
        Rule::ident | Rule::decl_name => "a name",
        Rule::value | Rule::arg | Rule::named_arg => "a value",
        Rule::string | Rule::string_inner => "a string",
        Rule::number | Rule::quantity => "a number",
        Rule::size => "a size",
        Rule::vector => "a vector",
        Rule::sum | Rule::product | Rule::unary | Rule::atom | Rule::paren => "a value",
        Rule::field => "a name",
        Rule::add_op | Rule::mul_op | Rule::neg => "an operator",
        Rule::call => "a call",
        Rule::unit => "a unit",
        Rule::boolean => "`true` or `false`",
        _ => return None,
    })
}

struct Builder {
    file: FileId,
}

impl Builder {
    fn span(&self, p: &Pair<Rule>) -> Span {
        let s = p.as_span();
        Span::new(self.file, s.start(), s.end())
    }

    fn item(&self, p: Pair<Rule>) -> Item {
        match p.as_rule() {
            Rule::comment => Item::Comment(self.comment(p)),
            Rule::import => {
                let span = self.span(&p);
                let s = p.into_inner().next().expect("import has a string");
                Item::Import(Import { path_span: self.span(&s), path: unescape(&s), span })
            }
            Rule::param => {
                let start = self.span(&p);
                let mut it = p.into_inner();
                let name = self.ident(it.next().expect("param name"));
                let value = self.value(it.next().expect("param value"));
                // Up to the value's end: an arithmetic rule's span takes in the blanks after it.
                Item::Param(Param { name, span: Span { end: value.span.end, ..start }, value })
            }
            Rule::decl => Item::Decl(self.decl(p)),
            r => unreachable!("unexpected top-level rule {r:?}"),
        }
    }

    fn comment(&self, p: Pair<Rule>) -> Comment {
        Comment { text: p.as_str().trim_end().to_string(), span: self.span(&p) }
    }

    fn ident(&self, p: Pair<Rule>) -> Ident {
        Ident { text: p.as_str().to_string(), span: self.span(&p) }
    }

    fn decl(&self, p: Pair<Rule>) -> Decl {
        let span = self.span(&p);
        let mut kind = None;
        let mut name = None;
        let mut block = None;
        for c in p.into_inner() {
            match c.as_rule() {
                Rule::kind => kind = Some(self.ident(c)),
                Rule::decl_name => {
                    let inner = c.into_inner().next().expect("decl name");
                    let quoted = inner.as_rule() == Rule::string;
                    let text = if quoted { unescape(&inner) } else { inner.as_str().to_string() };
                    name = Some(DeclName { text, quoted, span: self.span(&inner) });
                }
                Rule::block => block = Some(self.block(c)),
                r => unreachable!("unexpected rule in declaration {r:?}"),
            }
        }
        Decl { kind: kind.expect("kind"), name, block: block.expect("block"), span }
    }

    fn block(&self, p: Pair<Rule>) -> Block {
        let span = self.span(&p);
        let entries = p
            .into_inner()
            .map(|c| match c.as_rule() {
                Rule::comment => Entry::Comment(self.comment(c)),
                Rule::property => Entry::Property(self.property(c)),
                r => unreachable!("unexpected rule in block {r:?}"),
            })
            .collect();
        Block { entries, span }
    }

    fn property(&self, p: Pair<Rule>) -> Property {
        let span = self.span(&p);
        let mut it = p.into_inner();
        let name = self.ident(it.next().expect("property name"));
        let v = it.next().expect("property value");
        let value = if v.as_rule() == Rule::block {
            let b = self.block(v);
            Value { span: b.span, kind: ValueKind::Block(b) }
        } else {
            self.value(v)
        };
        // Up to the value's end: an arithmetic rule's span takes in the blanks after it.
        let span = Span { end: value.span.end, ..span };
        Property { name, value, span }
    }

    fn value(&self, p: Pair<Rule>) -> Value {
        let span = self.span(&p);
        let inner = if p.as_rule() == Rule::value { p.into_inner().next().expect("value") } else { p };
        let kind = match inner.as_rule() {
            // A chain of one operand is that operand: `12 px` stays a number, `a` a name.
            Rule::sum | Rule::product => {
                let mut it = inner.into_inner();
                let first = self.value(it.next().expect("operand"));
                let mut rest = Vec::new();
                while let (Some(op), Some(operand)) = (it.next(), it.next()) {
                    let op = match op.as_str() {
                        "+" => Op::Add,
                        "-" => Op::Sub,
                        "*" => Op::Mul,
                        _ => Op::Div,
                    };
                    rest.push((op, self.value(operand)));
                }
                if rest.is_empty() {
                    return first;
                }
                let span = first.span.to(rest.last().expect("an operand").1.span);
                return Value { kind: ValueKind::Chain { first: Box::new(first), rest }, span };
            }
            Rule::unary => {
                let mut it = inner.into_inner();
                let first = it.next().expect("operand");
                if first.as_rule() != Rule::neg {
                    return self.value(first);
                }
                ValueKind::Neg(Box::new(self.value(it.next().expect("negated operand"))))
            }
            Rule::atom => return self.value(inner.into_inner().next().expect("atom")),
            Rule::paren => ValueKind::Paren(Box::new(self.value(inner.into_inner().next().expect("inner")))),
            Rule::field => {
                let mut it = inner.into_inner();
                let base = self.ident(it.next().expect("base"));
                let field = self.ident(it.next().expect("field"));
                ValueKind::Field { base, field }
            }
            Rule::call => {
                let mut it = inner.into_inner();
                let name = self.ident(it.next().expect("call name"));
                let args = it
                    .map(|a| {
                        let a = a.into_inner().next().expect("arg");
                        if a.as_rule() == Rule::named_arg {
                            let mut it = a.into_inner();
                            let n = self.ident(it.next().expect("arg name"));
                            Arg { name: Some(n), value: self.value(it.next().expect("arg value")) }
                        } else {
                            Arg { name: None, value: self.value(a) }
                        }
                    })
                    .collect();
                ValueKind::Call { name, args }
            }
            Rule::size => {
                let mut it = inner.into_inner();
                let w = it.next().expect("width");
                let h = it.next().expect("height");
                ValueKind::Size {
                    w: num(w.as_str()),
                    w_text: w.as_str().into(),
                    h: num(h.as_str()),
                    h_text: h.as_str().into(),
                }
            }
            Rule::quantity => {
                let mut it = inner.into_inner();
                let n = it.next().expect("number");
                let unit = it.next().map(|u| u.as_str().to_string());
                ValueKind::Number { value: num(n.as_str()), text: n.as_str().into(), unit }
            }
            Rule::boolean => ValueKind::Bool(inner.as_str() == "true"),
            Rule::string => ValueKind::Str(unescape(&inner)),
            Rule::vector => ValueKind::Vector(inner.into_inner().map(|v| self.value(v)).collect()),
            Rule::ident => ValueKind::Ident(inner.as_str().into()),
            Rule::block => ValueKind::Block(self.block(inner)),
            r => unreachable!("unexpected value rule {r:?}"),
        };
        Value { kind, span }
    }
}

fn num(s: &str) -> f64 {
    // The grammar only admits decimal literals that Rust parses.
    s.parse().unwrap_or(f64::NAN)
}

fn unescape(p: &Pair<Rule>) -> String {
    let raw = p.clone().into_inner().next().map(|i| i.as_str()).unwrap_or("");
    let mut out = String::with_capacity(raw.len());
    let mut chars = raw.chars();
    while let Some(c) = chars.next() {
        if c == '\\' {
            match chars.next() {
                Some('n') => out.push('\n'),
                Some('t') => out.push('\t'),
                Some(o) => out.push(o),
                None => {}
            }
        } else {
            out.push(c);
        }
    }
    out
}

/// Re-escapes a string for printing back into scene syntax.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> File {
        parse_file(s, FileId(0)).unwrap_or_else(|e| panic!("{}", e.message))
    }

    #[test]
    fn parses_the_design_example_shapes() {
        let f = parse(
            r#"
import "common.tess"   # shared
param scale = 1.0
scene { seed = 7  size = 1024 x 768 }
map flow { from = radial(center = [512, 384]) }
structure stones {
  density = density scale = 1.2
  lloyd { iterations = 50  tolerance = 0.25 px }
}
output "a.png" { from = stones }
"#,
        );
        assert_eq!(f.items.len(), 7);
        let Item::Decl(d) = &f.items[3] else { panic!() };
        assert_eq!(d.kind.text, "scene");
        let props: Vec<_> = d.block.properties().collect();
        assert!(matches!(props[1].value.kind, ValueKind::Size { w, h, .. } if w == 1024.0 && h == 768.0));
        let Item::Decl(d) = &f.items[5] else { panic!() };
        let lloyd = d.block.properties().nth(2).unwrap();
        let ValueKind::Block(b) = &lloyd.value.kind else { panic!() };
        let tol = b.properties().nth(1).unwrap();
        assert!(matches!(&tol.value.kind, ValueKind::Number { unit: Some(u), .. } if u == "px"));
    }

    #[test]
    fn units_do_not_swallow_property_names() {
        let f = parse("map a { blur = 3 mask = 2 }");
        let Item::Decl(d) = &f.items[0] else { panic!() };
        assert_eq!(d.block.properties().count(), 2);
    }

    #[test]
    fn syntax_errors_point_at_the_problem() {
        let e = parse_file("map a { from = }", FileId(0)).unwrap_err();
        assert!(e.message.contains("expected"), "{}", e.message);
        assert_eq!(e.labels[0].0.start, 15);
    }

    #[test]
    fn strings_escape_round_trip() {
        let f = parse(r#"sample a { image = "a \"b\" \\ c" }"#);
        let Item::Decl(d) = &f.items[0] else { panic!() };
        let ValueKind::Str(s) = &d.block.properties().next().unwrap().value.kind else { panic!() };
        assert_eq!(s, "a \"b\" \\ c");
        assert_eq!(escape(s), r#""a \"b\" \\ c""#);
    }

    /// Nesting at the limit parses, builds its tree, formats and drops within a small
    /// stack (far less than a main thread's 8 MB), so the limit leaves a wide margin.
    #[test]
    fn nesting_at_the_limit_fits_a_small_stack() {
        let n = MAX_NESTING - 1;
        let text = format!("map a {{ from = {}1{} }}\n", "[".repeat(n), "]".repeat(n));
        std::thread::Builder::new()
            .stack_size(512 * 1024)
            .spawn(move || {
                let f = parse_file(&text, FileId(0)).unwrap_or_else(|e| panic!("{}", e.message));
                drop(f);
                crate::lang::fmt::format_source(&text).unwrap();
            })
            .unwrap()
            .join()
            .unwrap();
        let deeper = format!("map a {{ from = {}1{} }}\n", "[".repeat(n + 1), "]".repeat(n + 1));
        let e = parse_file(&deeper, FileId(0)).unwrap_err();
        assert_eq!(e.code, "tessera::nesting");
        assert_eq!(e.labels[0].0.start, "map a { from = ".len() + n);
    }

    #[test]
    fn brackets_in_strings_and_comments_do_not_count() {
        parse("# a { comment [ (\nsample a { image = \"{[(.png\" } // ]\n");
        let e = parse_file("sample a { image = \"x\\\"}\" \n", FileId(0)).unwrap_err();
        assert!(e.message.contains("unclosed `{`"), "{}", e.message);
    }

    #[test]
    fn a_syntax_error_before_an_unclosed_bracket_is_reported_first() {
        let e = parse_file("map a { from = }\nmap b {\n", FileId(0)).unwrap_err();
        assert!(e.message.contains("expected"), "{}", e.message);
        assert_eq!(e.labels[0].0.start, 15);
    }

    #[test]
    fn set_values_parse_alone() {
        let v = parse_value("1.3", FileId(0)).unwrap();
        assert!(matches!(v.kind, ValueKind::Number { value, .. } if value == 1.3));
        assert!(parse_value("1.3 junk", FileId(0)).is_err());
    }
}
