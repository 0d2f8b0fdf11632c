//! What the text around a position is, read from the text alone: an editor asks for
//! completions in the middle of typing, when the scene does not parse. One scan from the
//! start to the position follows brackets, strings and comments (as `parse::scan_brackets`
//! does) and records what each open bracket belongs to: a declaration of a kind, a property's
//! block, a constructor call, a vector. The statement the position ends says the rest.

/// What an open bracket belongs to.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Frame {
    /// `kind name {`: a declaration's block.
    Decl { kind: String },
    /// `prop = {`: a nested property block.
    Block { prop: String },
    /// `prop = name(` (or `name(` as a positional value): a constructor call.
    Call { prop: Option<String>, name: String },
    /// `prop = [` or `(`: a vector or a parenthesised expression.
    Group { prop: Option<String> },
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Context {
    /// The start of a top-level item: a kind, `import` or `param`.
    Item { prefix: String },
    /// A property name inside the innermost frame.
    Property { frames: Vec<Frame>, prefix: String },
    /// A value of `prop` (of the innermost frame, or the enclosing vector's property).
    Value { frames: Vec<Frame>, prop: Option<String>, prefix: String },
    /// Inside a string literal: `content` is what precedes the position, from byte `start`.
    Str { frames: Vec<Frame>, prop: Option<String>, import: bool, content: String, start: usize },
    /// A comment, a declaration's name, or nothing recognisable.
    Nothing,
}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// The identifier that ends `s` (possibly empty).
fn trailing_ident(s: &str) -> &str {
    let start = s.rfind(|c: char| !is_ident(c)).map_or(0, |i| i + 1);
    &s[start..]
}

/// `prop = rest` → (`prop`, `rest`).
fn assignment(stmt: &str) -> Option<(&str, &str)> {
    let (lhs, rest) = stmt.split_once('=')?;
    let lhs = lhs.trim();
    (!lhs.is_empty() && lhs.chars().all(is_ident)).then_some((lhs, rest))
}

/// The context at byte `offset` of `text` (clamped to the text), and where the innermost
/// open bracket's contents start.
pub fn context_at(text: &str, offset: usize) -> (Context, Option<usize>) {
    let mut open = None;
    let ctx = context(text, offset, &mut open);
    (ctx, open)
}

fn context(text: &str, offset: usize, innermost: &mut Option<usize>) -> Context {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let b = text.as_bytes();
    // Each open frame with where its current statement started; the top level is `top`.
    let mut frames: Vec<(Frame, usize)> = Vec::new();
    let mut opens: Vec<usize> = Vec::new();
    let mut top = 0usize;
    let stmt_start = |frames: &Vec<(Frame, usize)>, top: usize| frames.last().map_or(top, |f| f.1);
    let mut i = 0;
    while i < offset {
        match b[i] {
            b'"' => {
                let open = i;
                i += 1;
                while i < b.len() && b[i] != b'"' && b[i] != b'\n' {
                    if b[i] == b'\\' && i + 1 < b.len() && b[i + 1] != b'\n' {
                        i += 1;
                    }
                    i += 1;
                }
                // The position is inside the string (or on its unterminated rest).
                if offset <= i {
                    *innermost = opens.last().copied();
                    let stmt = &text[stmt_start(&frames, top)..open];
                    let import = frames.is_empty() && stmt.trim() == "import";
                    let prop = statement_prop(&frames, stmt);
                    let frames = frames.into_iter().map(|f| f.0).collect();
                    return Context::Str {
                        frames,
                        prop,
                        import,
                        content: text[open + 1..offset].to_string(),
                        start: open + 1,
                    };
                }
                if i < b.len() && b[i] == b'"' {
                    i += 1;
                }
                continue;
            }
            b'#' => {
                while i < b.len() && b[i] != b'\n' {
                    i += 1;
                }
                if offset <= i {
                    return Context::Nothing;
                }
                continue;
            }
            b'/' if b.get(i + 1) == Some(&b'/') => {
                while i < b.len() && b[i] != b'\n' {
                    i += 1;
                }
                if offset <= i {
                    return Context::Nothing;
                }
                continue;
            }
            c @ (b'{' | b'[' | b'(') => {
                let stmt = &text[stmt_start(&frames, top)..i];
                let frame = match c {
                    b'{' if frames.is_empty() => {
                        Frame::Decl { kind: stmt.split_whitespace().next().unwrap_or("").to_string() }
                    }
                    b'{' => Frame::Block {
                        prop: assignment(stmt).map(|(p, _)| p).unwrap_or_else(|| stmt.trim()).to_string(),
                    },
                    b'(' if !trailing_ident(stmt.trim_end()).is_empty() => Frame::Call {
                        prop: assignment(stmt).map(|(p, _)| p.to_string()),
                        name: trailing_ident(stmt.trim_end()).to_string(),
                    },
                    _ => Frame::Group { prop: statement_prop(&frames, stmt) },
                };
                frames.push((frame, i + 1));
                opens.push(i + 1);
            }
            b'}' | b']' | b')' => {
                opens.pop();
                frames.pop();
                if frames.is_empty() {
                    top = i + 1;
                }
            }
            b'\n' | b',' => match frames.last_mut() {
                Some((Frame::Decl { .. } | Frame::Block { .. } | Frame::Call { .. }, start)) => *start = i + 1,
                Some((Frame::Group { .. }, start)) if b[i] == b',' => *start = i + 1,
                Some(_) => {}
                None => top = i + 1,
            },
            _ => {}
        }
        i += 1;
    }
    *innermost = opens.last().copied();
    let stmt = &text[stmt_start(&frames, top)..offset];
    let prefix = trailing_ident(stmt).to_string();
    let head = stmt[..stmt.len() - prefix.len()].trim();
    let Some((last, _)) = frames.last() else {
        return if head.is_empty() { Context::Item { prefix } } else { Context::Nothing };
    };
    let in_group = matches!(last, Frame::Group { .. });
    if head.is_empty() && !in_group {
        return Context::Property { frames: frames.into_iter().map(|f| f.0).collect(), prefix };
    }
    let prop = statement_prop(&frames, stmt);
    Context::Value { frames: frames.into_iter().map(|f| f.0).collect(), prop, prefix }
}

/// The property a value in statement `stmt` belongs to: `prop = …`, or inside a vector the
/// vector's.
fn statement_prop(frames: &[(Frame, usize)], stmt: &str) -> Option<String> {
    match assignment(stmt) {
        Some((p, _)) => Some(p.to_string()),
        None => match frames.last() {
            Some((Frame::Group { prop }, _)) => prop.clone(),
            _ => None,
        },
    }
}

/// The identifier around byte `offset` (touching it on either side), as a byte range.
pub fn word_at(text: &str, offset: usize) -> Option<(usize, usize)> {
    let offset = offset.min(text.len());
    if !text.is_char_boundary(offset) {
        return None;
    }
    let start = text[..offset].rfind(|c: char| !is_ident(c)).map_or(0, |i| i + 1);
    let end = text[offset..].find(|c: char| !is_ident(c)).map_or(text.len(), |i| offset + i);
    (start < end).then_some((start, end))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The context at the `|` of `marked`.
    fn at(marked: &str) -> Context {
        let offset = marked.find('|').expect("a `|` marks the position");
        let text = marked.replacen('|', "", 1);
        context_at(&text, offset).0
    }

    fn decl(kind: &str) -> Frame {
        Frame::Decl { kind: kind.into() }
    }

    #[test]
    fn the_start_of_an_item_asks_for_a_kind() {
        assert_eq!(at("ma|"), Context::Item { prefix: "ma".into() });
        assert_eq!(at("sample a { image = \"a.png\" }\n|"), Context::Item { prefix: "".into() });
        assert_eq!(at("quilt wa|"), Context::Nothing, "a declaration's name is the user's");
    }

    #[test]
    fn a_line_in_a_block_asks_for_a_property_of_its_kind() {
        let c = at("layer wall {\n  source = a\n  ite|\n}");
        assert_eq!(c, Context::Property { frames: vec![decl("layer")], prefix: "ite".into() });
        let c = at("layer wall { a = 1, |");
        assert_eq!(c, Context::Property { frames: vec![decl("layer")], prefix: "".into() });
    }

    #[test]
    fn after_equals_asks_for_a_value_of_that_property() {
        let c = at("layer wall {\n  mode = qu|");
        assert_eq!(c, Context::Value { frames: vec![decl("layer")], prop: Some("mode".into()), prefix: "qu".into() });
        let c = at("layer w { lloyd = {\n  iterations = |");
        let frames = vec![decl("layer"), Frame::Block { prop: "lloyd".into() }];
        assert_eq!(c, Context::Value { frames, prop: Some("iterations".into()), prefix: "".into() });
    }

    #[test]
    fn calls_and_vectors_are_frames() {
        let c = at("map m {\n  from = radial(radius = 3 px, cen|");
        let call = Frame::Call { prop: Some("from".into()), name: "radial".into() };
        assert_eq!(c, Context::Property { frames: vec![decl("map"), call], prefix: "cen".into() });
        let c = at("layer b {\n  sources = [a, b|");
        let group = Frame::Group { prop: Some("sources".into()) };
        assert_eq!(
            c,
            Context::Value { frames: vec![decl("layer"), group], prop: Some("sources".into()), prefix: "b".into() }
        );
    }

    #[test]
    fn strings_and_comments() {
        let c = at("sample s {\n  image = \"samples/br|\"\n}");
        match c {
            Context::Str { prop, content, import, .. } => {
                assert_eq!((prop.as_deref(), content.as_str(), import), (Some("image"), "samples/br", false))
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(at("import \"_co|"), Context::Str { import: true, .. }));
        assert_eq!(at("map m { # a comment, ite|\n}"), Context::Nothing);
        // A `{` inside a string or a comment opens nothing.
        let c = at("map m { a = \"{[(\" # {\n  |");
        assert_eq!(c, Context::Property { frames: vec![decl("map")], prefix: "".into() });
    }

    #[test]
    fn closed_blocks_are_left() {
        assert_eq!(at("map m { a = (1 + 2) }\nsam|"), Context::Item { prefix: "sam".into() });
        assert_eq!(at("}}}|"), Context::Item { prefix: "".into() }, "stray closers are ignored");
    }

    #[test]
    fn words() {
        let t = "from = wall_2 }";
        assert_eq!(word_at(t, 9), Some((7, 13)));
        assert_eq!(word_at(t, 13), Some((7, 13)));
        assert_eq!(word_at(t, 14), None);
        assert_eq!(word_at(t, 99), None);
    }
}
