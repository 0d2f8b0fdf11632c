//! `tessera fmt`: one canonical layout, so scenes diff well. Only layout changes: numbers
//! keep their digits, comments stay where they were (own line or end of line), and the
//! order of items and properties is the user's.

use super::ast::*;
use super::parse::{escape, parse_file};
use super::source::FileId;
use super::Diagnostic;

/// Formats a scene file's text, or returns its syntax error.
pub fn format_source(text: &str) -> Result<String, Diagnostic> {
    let file = parse_file(text, FileId(0))?;
    let mut f = Formatter { text, out: String::new() };
    // A byte order mark is kept: formatting changes layout, not the file's encoding marks.
    if text.starts_with('\u{feff}') {
        f.out.push('\u{feff}');
    }
    f.items(&file.items);
    Ok(f.out)
}

struct Formatter<'a> {
    text: &'a str,
    out: String,
}

impl Formatter<'_> {
    fn line_of(&self, pos: usize) -> usize {
        self.text[..pos].bytes().filter(|&b| b == b'\n').count()
    }

    /// Whether the source had an empty line between two positions.
    fn blank_between(&self, end: usize, start: usize) -> bool {
        self.line_of(start) > self.line_of(end) + 1
            && self.text[end..start].lines().skip(1).any(|l| l.trim().is_empty())
    }

    fn items(&mut self, items: &[Item]) {
        let mut prev: Option<&Item> = None;
        for item in items {
            let (start, end) = item_range(item);
            if let Some(p) = prev {
                let (_, pend) = item_range(p);
                if let Item::Comment(_) = item {
                    if self.line_of(start) == self.line_of(pend) {
                        self.trailing_comment(item);
                        prev = Some(item);
                        continue;
                    }
                }
                let decl_boundary =
                    matches!(item, Item::Decl(_)) && !matches!(p, Item::Comment(_)) || matches!(p, Item::Decl(_));
                if decl_boundary || self.blank_between(pend, start) {
                    self.out.push('\n');
                }
            }
            match item {
                Item::Comment(c) => self.out.push_str(&c.text),
                Item::Import(i) => {
                    self.out.push_str("import ");
                    self.out.push_str(&escape(&i.path));
                }
                Item::Param(p) => {
                    self.out.push_str("param ");
                    self.out.push_str(&p.name.text);
                    self.out.push_str(" = ");
                    self.value(&p.value, 0);
                }
                Item::Decl(d) => {
                    self.out.push_str(&d.kind.text);
                    if let Some(n) = &d.name {
                        self.out.push(' ');
                        self.out.push_str(&if n.quoted { escape(&n.text) } else { n.text.clone() });
                    }
                    self.out.push(' ');
                    self.block(&d.block, 0);
                }
            }
            self.out.push('\n');
            let _ = end;
            prev = Some(item);
        }
    }

    fn trailing_comment(&mut self, item: &Item) {
        if let Item::Comment(c) = item {
            if self.out.ends_with('\n') {
                self.out.pop();
            }
            self.out.push_str("  ");
            self.out.push_str(&c.text);
            self.out.push('\n');
        }
    }

    fn block(&mut self, b: &Block, depth: usize) {
        if b.entries.is_empty() {
            self.out.push_str("{}");
            return;
        }
        self.out.push_str("{\n");
        let pad = "  ".repeat(depth + 1);
        let mut prev_end: Option<usize> = Some(b.span.start);
        for e in &b.entries {
            match e {
                Entry::Comment(c) => {
                    let same_line = prev_end.is_some_and(|pe| self.line_of(pe) == self.line_of(c.span.start));
                    if same_line && self.out.ends_with('\n') && prev_end != Some(b.span.start) {
                        self.out.pop();
                        self.out.push_str("  ");
                    } else {
                        self.blank_if(prev_end, c.span.start, b.span.start);
                        self.out.push_str(&pad);
                    }
                    self.out.push_str(&c.text);
                    self.out.push('\n');
                    prev_end = Some(c.span.end);
                }
                Entry::Property(p) => {
                    self.blank_if(prev_end, p.span.start, b.span.start);
                    self.out.push_str(&pad);
                    self.out.push_str(&p.name.text);
                    if let ValueKind::Block(inner) = &p.value.kind {
                        self.out.push(' ');
                        self.block(inner, depth + 1);
                    } else {
                        self.out.push_str(" = ");
                        self.value(&p.value, depth + 1);
                    }
                    self.out.push('\n');
                    prev_end = Some(p.span.end);
                }
            }
        }
        self.out.push_str(&"  ".repeat(depth));
        self.out.push('}');
    }

    fn blank_if(&mut self, prev_end: Option<usize>, start: usize, block_start: usize) {
        if let Some(pe) = prev_end {
            if pe != block_start && self.blank_between(pe, start) {
                self.out.push('\n');
            }
        }
    }

    fn value(&mut self, v: &Value, depth: usize) {
        match &v.kind {
            ValueKind::Number { text, unit, .. } => {
                self.out.push_str(text);
                match unit.as_deref() {
                    Some("%") => self.out.push('%'),
                    Some(u) => {
                        self.out.push(' ');
                        self.out.push_str(u);
                    }
                    None => {}
                }
            }
            ValueKind::Size { w_text, h_text, .. } => {
                self.out.push_str(w_text);
                self.out.push_str(" x ");
                self.out.push_str(h_text);
            }
            ValueKind::Bool(b) => self.out.push_str(if *b { "true" } else { "false" }),
            ValueKind::Str(s) => self.out.push_str(&escape(s)),
            ValueKind::Ident(s) => self.out.push_str(s),
            ValueKind::Vector(items) => {
                self.out.push('[');
                for (i, it) in items.iter().enumerate() {
                    if i > 0 {
                        self.out.push_str(", ");
                    }
                    self.value(it, depth);
                }
                self.out.push(']');
            }
            ValueKind::Call { name, args } => {
                self.out.push_str(&name.text);
                self.out.push('(');
                for (i, a) in args.iter().enumerate() {
                    if i > 0 {
                        self.out.push_str(", ");
                    }
                    if let Some(n) = &a.name {
                        self.out.push_str(&n.text);
                        self.out.push_str(" = ");
                    }
                    self.value(&a.value, depth);
                }
                self.out.push(')');
            }
            ValueKind::Block(b) => self.block(b, depth.saturating_sub(1)),
            ValueKind::Chain { first, rest } => {
                self.value(first, depth);
                for (op, v) in rest {
                    self.out.push(' ');
                    self.out.push_str(op.symbol());
                    self.out.push(' ');
                    self.value(v, depth);
                }
            }
            ValueKind::Neg(v) => {
                self.out.push('-');
                self.value(v, depth);
            }
            ValueKind::Paren(v) => {
                self.out.push('(');
                self.value(v, depth);
                self.out.push(')');
            }
            ValueKind::Field { base, field } => {
                self.out.push_str(&base.text);
                self.out.push('.');
                self.out.push_str(&field.text);
            }
        }
    }
}

fn item_range(item: &Item) -> (usize, usize) {
    let s = match item {
        Item::Comment(c) => c.span,
        Item::Import(i) => i.span,
        Item::Param(p) => p.span,
        Item::Decl(d) => d.span,
    };
    (s.start, s.end)
}

#[cfg(test)]
mod tests {
    use super::*;

    const MESSY: &str = r#"# A scene.
import   "common.tess"
param scale=1.0   # tweak me


scene{seed=7 size=64x32}
map   a { from = radial( center=[1,2] , radius = 10px) # trailing
  # own line
  invert=true
  lloyd{iterations=5 tolerance = 0.50 px}

  blur = 25%
}
output "x.png" { from = a }
"#;

    #[test]
    fn formats_canonically() {
        let got = format_source(MESSY).unwrap();
        let want = r#"# A scene.
import "common.tess"
param scale = 1.0  # tweak me

scene {
  seed = 7
  size = 64 x 32
}

map a {
  from = radial(center = [1, 2], radius = 10 px)  # trailing
  # own line
  invert = true
  lloyd {
    iterations = 5
    tolerance = 0.50 px
  }

  blur = 25%
}

output "x.png" {
  from = a
}
"#;
        assert_eq!(got, want);
    }

    #[test]
    fn is_idempotent() {
        let once = format_source(MESSY).unwrap();
        assert_eq!(format_source(&once).unwrap(), once);
    }

    #[test]
    fn keeps_every_comment() {
        let got = format_source(MESSY).unwrap();
        for c in ["# A scene.", "# tweak me", "# trailing", "# own line"] {
            assert!(got.contains(c), "lost {c}");
        }
    }
}
