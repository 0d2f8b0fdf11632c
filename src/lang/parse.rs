//! Text → syntax tree, with pest doing the recognition and this module building the AST.

use pest::iterators::Pair;
use pest::Parser;

use super::ast::*;
use super::diag::Diagnostic;
use super::source::{FileId, Span};

#[derive(pest_derive::Parser)]
#[grammar = "../grammar/tessera.pest"]
struct SceneParser;

/// Parses a whole scene file.
pub fn parse_file(text: &str, file: FileId) -> Result<File, Diagnostic> {
    // Track expected literal tokens (`)`, `,`, `=`) too, not only rules, so that a
    // syntax error can say "expected `,` or `)`".
    pest::set_error_detail(true);
    let mut pairs = SceneParser::parse(Rule::file, text).map_err(|e| syntax_error(e, file))?;
    let root = pairs.next().expect("pest yields the file rule");
    let b = Builder { file };
    let items = root.into_inner().filter(|p| p.as_rule() != Rule::EOI).map(|p| b.item(p)).collect();
    Ok(File { items })
}

/// Parses a lone value, as given on the command line by `--set name=value`.
pub fn parse_value(text: &str, file: FileId) -> Result<Value, Diagnostic> {
    // A value rule anchored at both ends: wrap in a tiny file so the grammar stays single-rooted.
    let mut pairs = SceneParser::parse(Rule::value, text).map_err(|e| syntax_error(e, file))?;
    let pair = pairs.next().expect("pest yields the value rule");
    let consumed = pair.as_span().end();
    if text[consumed..].trim().is_empty() {
        Ok(Builder { file }.value(pair))
    } else {
        Err(Diagnostic::error(format!("unexpected `{}` after the value", text[consumed..].trim()))
            .with_label(Span::new(file, consumed, text.len()), "not part of the value"))
    }
}

fn syntax_error(e: pest::error::Error<Rule>, file: FileId) -> Diagnostic {
    use pest::error::{ErrorVariant, InputLocation};
    let (start, end) = match e.location {
        InputLocation::Pos(p) => (p, p),
        InputLocation::Span((a, b)) => (a, b),
    };
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
                rules.iter().map(|r| describe_rule(r).to_string()).chain(tokens.iter().cloned()).collect();
            for p in candidates {
                if !parts.contains(&p) {
                    parts.push(p);
                }
            }
            join_alternatives(&parts)
        }
        ErrorVariant::CustomError { message } => message.clone(),
    };
    Diagnostic::error(format!("syntax error: expected {expected}"))
        .with_code("tessera::syntax")
        .with_label(Span::new(file, start, end), "here")
}

fn join_alternatives(parts: &[String]) -> String {
    match parts {
        [] => "something else".into(),
        [one] => one.clone(),
        [rest @ .., last] => format!("{} or {}", rest.join(", "), last),
    }
}

fn describe_rule(rule: &Rule) -> &'static str {
    match rule {
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
        Rule::call => "a call",
        Rule::unit => "a unit",
        Rule::boolean => "`true` or `false`",
        _ => "something else",
    }
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
                let span = self.span(&p);
                let mut it = p.into_inner();
                let name = self.ident(it.next().expect("param name"));
                let value = self.value(it.next().expect("param value"));
                Item::Param(Param { name, value, span })
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
        Property { name, value, span }
    }

    fn value(&self, p: Pair<Rule>) -> Value {
        let span = self.span(&p);
        let inner = if p.as_rule() == Rule::value { p.into_inner().next().expect("value") } else { p };
        let kind = match inner.as_rule() {
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

    #[test]
    fn set_values_parse_alone() {
        let v = parse_value("1.3", FileId(0)).unwrap();
        assert!(matches!(v.kind, ValueKind::Number { value, .. } if value == 1.3));
        assert!(parse_value("1.3 junk", FileId(0)).is_err());
    }
}
