//! References between declarations: a name checked against the kinds that produce the value
//! wanted, recorded as a dependency, and the reference cycles found once all are known.

use std::collections::HashMap;

use super::namespace::Checker;
use crate::lang::diag::{suggest, Diagnostic};
use crate::lang::schema::{self, KindSpec, Value};
use crate::lang::source::Span;

/// `a sample, an appearance or a layer`.
fn with_articles(names: &[&str]) -> String {
    let one = |n: &str| {
        let vowel = n.starts_with(['a', 'e', 'i', 'o', 'u']);
        format!("{} {n}", if vowel { "an" } else { "a" })
    };
    let mut parts: Vec<String> = names.iter().map(|n| one(n)).collect();
    let last = parts.pop().unwrap_or_default();
    if parts.is_empty() {
        last
    } else {
        format!("{} or {last}", parts.join(", "))
    }
}

impl Checker<'_> {
    /// The kinds whose declarations produce one of `values`, for messages: `a sample, an
    /// appearance or a layer`.
    fn producers(&self, values: &[Value]) -> Vec<&'static str> {
        self.registry.iter().filter(|k| k.produces.iter().any(|v| values.contains(v))).map(|k| k.name).collect()
    }

    pub(super) fn reference(&mut self, name: &str, span: Span, values: &[Value]) -> Option<String> {
        let produces = |k: &KindSpec| k.produces.iter().any(|v| values.contains(v));
        match self.kinds.get(name) {
            Some(k) if produces(k) => {
                self.deps.push((name.to_string(), span));
                Some(name.to_string())
            }
            Some(k) => {
                let producers = self.producers(values);
                let mut d = Diagnostic::error(format!(
                    "`{name}` is a {}, but {} is expected here",
                    k.name,
                    schema::values(values)
                ))
                .with_code("tessera::wrong_kind")
                .with_label(span, format!("this is a {}", k.name));
                if producers.len() > 1 {
                    d = d.with_help(format!("{} comes from {}", schema::values(values), with_articles(&producers)));
                }
                self.errors.push(d);
                None
            }
            None => {
                let mut d = Diagnostic::error(format!("unknown name `{name}`"))
                    .with_code("tessera::unknown_name")
                    .with_label(span, format!("no {} of this name", self.producers(values).join(" or ")));
                let candidates: Vec<&str> =
                    self.kinds.iter().filter(|(_, k)| produces(k)).map(|(n, _)| n.as_str()).collect();
                if let Some(s) = suggest(name, candidates) {
                    d = d.with_help(format!("did you mean `{s}`?"));
                }
                self.errors.push(d);
                None
            }
        }
    }

    pub(super) fn check_cycles(&self, errors: &mut Vec<Diagnostic>) {
        // Colour DFS over declaration references; report each cycle once.
        let mut state: HashMap<&str, u8> = HashMap::new();
        let mut stack: Vec<(&str, Span)> = Vec::new();
        fn visit<'b>(
            c: &'b Checker,
            n: &'b str,
            state: &mut HashMap<&'b str, u8>,
            stack: &mut Vec<(&'b str, Span)>,
            errors: &mut Vec<Diagnostic>,
        ) {
            state.insert(n, 1);
            for (dep, span) in c.ref_spans.get(n).map(|v| v.as_slice()).unwrap_or(&[]) {
                match state.get(dep.as_str()) {
                    Some(1) => {
                        let start = stack.iter().position(|(s, _)| *s == dep.as_str()).unwrap_or(0);
                        let mut names: Vec<&str> = stack[start..].iter().map(|(s, _)| *s).collect();
                        names.push(n);
                        names.push(dep);
                        names.dedup();
                        let mut d = Diagnostic::error(format!("reference cycle: {}", names.join(" → ")))
                            .with_code("tessera::reference_cycle")
                            .with_label(*span, format!("`{n}` refers to `{dep}` here"))
                            .with_help("a declaration cannot depend on its own result; break the cycle");
                        for (s, sp) in stack[start..].iter().skip(1) {
                            d = d.with_label(*sp, format!("…which leads to `{s}`"));
                        }
                        errors.push(d);
                    }
                    Some(_) => {}
                    None => {
                        stack.push((dep, *span));
                        visit(c, dep, state, stack, errors);
                        stack.pop();
                    }
                }
            }
            state.insert(n, 2);
        }
        for d in &self.out {
            if !state.contains_key(d.name.as_str()) {
                stack.push((&d.name, d.name_span));
                visit(self, &d.name, &mut state, &mut stack, errors);
                stack.pop();
            }
        }
    }
}
