//! Diagnostics: what went wrong, where in the scene, and what to do about it.
//!
//! The compiler collects `Diagnostic`s with spans into any source file; `render` turns them
//! into `miette` reports. Labels that point into a second file (a duplicate declared in an
//! imported file, say) become related reports with their own source snippet.

use std::fmt;
use std::sync::Arc;

use miette::{LabeledSpan, MietteError, MietteSpanContents, SourceCode, SourceSpan, SpanContents};

use super::source::{FileId, SourceMap, Span};

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

    /// Each diagnostic drawn as miette draws it (source excerpt, labels, help) in `theme`,
    /// `width` columns wide, one after another.
    pub fn draw(&self, theme: miette::GraphicalTheme, width: usize) -> Vec<String> {
        let handler = miette::GraphicalReportHandler::new_themed(theme).with_width(width);
        self.items
            .iter()
            .map(|item| {
                let mut out = String::new();
                match handler.render_report(&mut out, &render(item, &self.sources)) {
                    Ok(()) => out,
                    Err(_) => format!("error: {}", item.message),
                }
            })
            .collect()
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
    source: Option<Excerpt>,
    labels: Vec<LabeledSpan>,
    related: Vec<Rendered>,
}

pub fn render(d: &Diagnostic, sources: &SourceMap) -> Rendered {
    let primary_file = d.primary_span().map(|s| s.file);
    let excerpt = |file: FileId, spans: &[Span]| {
        let f = sources.get(file);
        let points: Vec<usize> = spans.iter().flat_map(|s| [s.start, s.end]).collect();
        Excerpt::new(f.display.clone(), &f.text, &points)
    };
    let primary_spans: Vec<Span> = d.labels.iter().map(|l| l.0).filter(|s| Some(s.file) == primary_file).collect();
    let source = primary_file.map(|f| excerpt(f, &primary_spans));
    let mut labels = Vec::new();
    let mut related = Vec::new();
    for (i, (span, text)) in d.labels.iter().enumerate() {
        if Some(span.file) == primary_file {
            let at = source.as_ref().expect("the primary file has an excerpt").span(*span);
            labels.push(if i == 0 {
                LabeledSpan::new_primary_with_span(Some(text.clone()), at)
            } else {
                LabeledSpan::new_with_span(Some(text.clone()), at)
            });
        } else {
            let other = excerpt(span.file, &[*span]);
            let at = other.span(*span);
            related.push(Rendered {
                code: d.code,
                message: text.clone(),
                help: None,
                source: Some(other),
                labels: vec![LabeledSpan::new_primary_with_span(None, at)],
                related: Vec::new(),
            });
        }
    }
    Rendered { code: d.code, message: d.message.clone(), help: d.help.clone(), source, labels, related }
}

/// Lines up to this many bytes are shown whole.
const LONG_LINE: usize = 160;
/// On a longer line, the bytes kept on each side of a label's start and end.
const WINDOW: usize = 32;
const ELLIPSIS: &str = "…";

/// The text of a file as a diagnostic shows it: every line longer than `LONG_LINE` cut
/// down to windows around the labels' ends, the rest elided. miette draws whole lines and
/// pads them with `{:width$}`, which panics past 65 535 columns (a format width is 16
/// bits); and a 100 kB line is no help to the reader. Newlines are all kept, so line
/// numbers are the file's; columns are mapped back to the file's in the header.
#[derive(Debug)]
struct Excerpt {
    name: String,
    text: String,
    /// The file's text, for columns.
    original: Arc<str>,
    /// Kept pieces in order: (start, end) in the file and the start in `text`.
    kept: Vec<(usize, usize, usize)>,
}

impl Excerpt {
    fn new(name: String, original: &Arc<str>, points: &[usize]) -> Excerpt {
        let t: &str = original;
        let floor = |mut i: usize| {
            while !t.is_char_boundary(i) {
                i -= 1;
            }
            i
        };
        let ceil = |mut i: usize| {
            while !t.is_char_boundary(i) {
                i += 1;
            }
            i
        };
        let mut pieces: Vec<(usize, usize)> = Vec::new();
        let mut start = 0;
        for line in t.split_inclusive('\n') {
            let end = start + line.len();
            if line.len() <= LONG_LINE {
                pieces.push((start, end));
            } else {
                let content = start + line.trim_end_matches(['\n', '\r']).len();
                let mut here: Vec<usize> = points.iter().copied().filter(|&p| p >= start && p <= content).collect();
                if here.is_empty() {
                    here.push(start);
                }
                for p in here {
                    pieces.push((floor(p.saturating_sub(WINDOW).max(start)), ceil((p + WINDOW).min(content))));
                }
                pieces.push((content, end));
            }
            start = end;
        }
        pieces.sort_unstable();
        let mut text = String::new();
        let mut kept: Vec<(usize, usize, usize)> = Vec::new();
        let mut shown_to = 0;
        for (a, b) in pieces {
            if let Some(last) = kept.last_mut() {
                if a <= last.1 {
                    if b > last.1 {
                        push_printable(&mut text, &t[last.1..b]);
                        last.1 = b;
                    }
                    shown_to = last.1;
                    continue;
                }
            }
            if a > shown_to {
                text.push_str(ELLIPSIS);
            }
            kept.push((a, b, text.len()));
            push_printable(&mut text, &t[a..b]);
            shown_to = b;
        }
        if shown_to < t.len() {
            text.push_str(ELLIPSIS);
        }
        Excerpt { name, text, original: original.clone(), kept }
    }

    /// A file offset in `text`; an offset in an elided stretch lands on its ellipsis.
    fn map(&self, off: usize) -> usize {
        let i = self.kept.partition_point(|k| k.0 <= off);
        match i.checked_sub(1).map(|i| self.kept[i]) {
            Some((a, b, at)) => at + off.min(b) - a,
            None => 0,
        }
    }

    /// A `text` offset in the file.
    fn unmap(&self, at: usize) -> usize {
        let i = self.kept.partition_point(|k| k.2 <= at);
        match i.checked_sub(1).map(|i| self.kept[i]) {
            Some((a, b, start)) => (a + (at - start)).min(b),
            None => 0,
        }
    }

    fn span(&self, s: Span) -> SourceSpan {
        let (a, b) = (self.map(s.start), self.map(s.end));
        (a, b.max(a) - a).into()
    }
}

/// Control characters (a stray NUL, an escape) would act on the terminal; each becomes a
/// `?` of the same byte length, so offsets stay put.
fn push_printable(out: &mut String, s: &str) {
    for c in s.chars() {
        if c.is_control() && !matches!(c, '\t' | '\n' | '\r') {
            out.extend(std::iter::repeat_n('?', c.len_utf8()));
        } else {
            out.push(c);
        }
    }
}

impl SourceCode for Excerpt {
    fn read_span<'a>(
        &'a self,
        span: &SourceSpan,
        context_lines_before: usize,
        context_lines_after: usize,
    ) -> Result<Box<dyn SpanContents<'a> + 'a>, MietteError> {
        let inner = self.text.read_span(span, context_lines_before, context_lines_after)?;
        let column = if context_lines_before == 0 {
            let off = self.unmap(span.offset());
            off - self.original[..off].rfind('\n').map_or(0, |i| i + 1)
        } else {
            inner.column()
        };
        Ok(Box::new(MietteSpanContents::new_named(
            self.name.clone(),
            inner.data(),
            *inner.span(),
            inner.line(),
            column,
            inner.line_count(),
        )))
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
    fn long_lines_are_cut_around_the_labels() {
        let text: Arc<str> = format!("a = 1\n{}x = 2\nb = 3\n", " ".repeat(100_000)).into();
        let x = text.find('x').unwrap();
        let e = Excerpt::new("f".into(), &text, &[x, x + 1]);
        assert!(e.text.len() < 200, "{}", e.text.len());
        assert!(e.text.starts_with("a = 1\n…"));
        assert!(e.text.ends_with("x = 2\nb = 3\n"));
        assert_eq!(&e.text[e.map(x)..e.map(x + 1)], "x");
        assert_eq!(e.unmap(e.map(x)), x);
        let c = e.read_span(&e.span(Span::new(FileId(0), x, x + 1)), 0, 0).unwrap();
        assert_eq!((c.line(), c.column()), (1, 100_000));
    }

    #[test]
    fn short_files_are_shown_whole() {
        let text: Arc<str> = "map a {\n  from = 1\n}\n".into();
        let e = Excerpt::new("f".into(), &text, &[8, 12]);
        assert_eq!(e.text, &*text);
        assert_eq!(e.map(12), 12);
    }

    #[test]
    fn suggests_close_names_only() {
        assert_eq!(suggest("iteratons", ["iterations", "tolerance"]), Some("iterations"));
        assert_eq!(suggest("zzz", ["iterations", "tolerance"]), None);
        assert_eq!(suggest("sacle", ["scale", "seed"]), Some("scale"));
    }
}
