//! Diagnostics: what went wrong, where in the scene, and what to do about it.
//!
//! The compiler collects `Diagnostic`s with spans into any source file; `render` turns them
//! into `miette` reports. Labels that point into a second file (a duplicate declared in an
//! imported file, say) become related reports with their own source snippet.

use std::fmt;
use std::sync::Arc;

use miette::{LabeledSpan, NamedSource, SourceCode};

use super::source::{SourceMap, Span};

#[derive(Clone, Debug)]
pub struct Diagnostic {
    pub code: &'static str,
    pub message: String,
    /// Primary label first.
    pub labels: Vec<(Span, String)>,
    pub help: Option<String>,
}

impl Diagnostic {
    pub fn error(message: impl Into<String>) -> Self {
        Diagnostic { code: "tessera::error", message: message.into(), labels: Vec::new(), help: None }
    }

    pub fn with_code(mut self, code: &'static str) -> Self {
        self.code = code;
        self
    }

    pub fn with_label(mut self, span: Span, text: impl Into<String>) -> Self {
        self.labels.push((span, text.into()));
        self
    }

    pub fn with_help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }

    pub fn primary_span(&self) -> Option<Span> {
        self.labels.first().map(|l| l.0)
    }
}

/// One or more diagnostics from one compilation, ready to print.
#[derive(Debug)]
pub struct Diagnostics {
    pub items: Vec<Diagnostic>,
    pub sources: SourceMap,
}

impl Diagnostics {
    pub fn new(items: Vec<Diagnostic>, sources: SourceMap) -> Self {
        Diagnostics { items, sources }
    }

    pub fn reports(&self) -> Vec<miette::Report> {
        self.items.iter().map(|d| miette::Report::new(render(d, &self.sources))).collect()
    }
}

impl fmt::Display for Diagnostics {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, d) in self.items.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "{}", d.message)?;
        }
        Ok(())
    }
}

impl std::error::Error for Diagnostics {}

/// A diagnostic bound to the text of one file: what miette needs to draw it.
#[derive(Debug)]
pub struct Rendered {
    code: &'static str,
    message: String,
    help: Option<String>,
    source: Option<NamedSource<Arc<str>>>,
    labels: Vec<LabeledSpan>,
    related: Vec<Rendered>,
}

pub fn render(d: &Diagnostic, sources: &SourceMap) -> Rendered {
    let primary_file = d.primary_span().map(|s| s.file);
    let mut labels = Vec::new();
    let mut related = Vec::new();
    for (i, (span, text)) in d.labels.iter().enumerate() {
        let label = if i == 0 {
            LabeledSpan::new_primary_with_span(Some(text.clone()), *span)
        } else {
            LabeledSpan::new_with_span(Some(text.clone()), *span)
        };
        if Some(span.file) == primary_file {
            labels.push(label);
        } else {
            related.push(Rendered {
                code: d.code,
                message: text.clone(),
                help: None,
                source: Some(sources.named_source(span.file)),
                labels: vec![LabeledSpan::new_primary_with_span(None, *span)],
                related: Vec::new(),
            });
        }
    }
    Rendered {
        code: d.code,
        message: d.message.clone(),
        help: d.help.clone(),
        source: primary_file.map(|f| sources.named_source(f)),
        labels,
        related,
    }
}

impl fmt::Display for Rendered {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Rendered {}

impl miette::Diagnostic for Rendered {
    fn code<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        Some(Box::new(self.code))
    }

    fn help<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        self.help.as_ref().map(|h| Box::new(h) as Box<dyn fmt::Display>)
    }

    fn source_code(&self) -> Option<&dyn SourceCode> {
        self.source.as_ref().map(|s| s as &dyn SourceCode)
    }

    fn labels(&self) -> Option<Box<dyn Iterator<Item = LabeledSpan> + '_>> {
        if self.labels.is_empty() {
            None
        } else {
            Some(Box::new(self.labels.iter().cloned()))
        }
    }

    fn related<'a>(&'a self) -> Option<Box<dyn Iterator<Item = &'a dyn miette::Diagnostic> + 'a>> {
        if self.related.is_empty() {
            None
        } else {
            Some(Box::new(self.related.iter().map(|r| r as &dyn miette::Diagnostic)))
        }
    }
}

/// Edit distance with adjacent transpositions (optimal string alignment), for "did you
/// mean" suggestions: `sacle` is one slip away from `scale`, not two.
pub fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().collect();
    let b: Vec<char> = b.chars().collect();
    let mut d = vec![vec![0usize; b.len() + 1]; a.len() + 1];
    for (i, row) in d.iter_mut().enumerate() {
        row[0] = i;
    }
    for (j, cell) in d[0].iter_mut().enumerate() {
        *cell = j;
    }
    for i in 1..=a.len() {
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            d[i][j] = (d[i - 1][j] + 1).min(d[i][j - 1] + 1).min(d[i - 1][j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                d[i][j] = d[i][j].min(d[i - 2][j - 2] + 1);
            }
        }
    }
    d[a.len()][b.len()]
}

/// The closest candidate within a distance that still looks like a typo.
pub fn suggest<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let limit = (name.chars().count() / 3).clamp(1, 3);
    candidates.into_iter().map(|c| (edit_distance(name, c), c)).filter(|(d, _)| *d <= limit).min().map(|(_, c)| c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suggests_close_names_only() {
        assert_eq!(suggest("iteratons", ["iterations", "tolerance"]), Some("iterations"));
        assert_eq!(suggest("zzz", ["iterations", "tolerance"]), None);
        assert_eq!(suggest("sacle", ["scale", "seed"]), Some("scale"));
    }
}
