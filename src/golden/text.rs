//! Comparison of text outputs (JSON meshes and statistics, SVG drawings): the text around
//! numbers must match exactly, and numbers may differ by a tolerance. A float printed on
//! another platform may differ in its last digit; a changed word or structure may not.

/// The result of comparing two texts.
#[derive(Clone, Debug, PartialEq)]
pub struct TextComparison {
    pub pass: bool,
    /// Largest absolute difference between corresponding numbers.
    pub max_abs: f64,
    pub numbers: usize,
    pub failing_numbers: usize,
    /// Where the texts first differ beyond numbers, as a short excerpt.
    pub mismatch: Option<String>,
}

#[derive(Debug, PartialEq)]
enum Token<'a> {
    Text(&'a str),
    Number(f64),
}

fn tokens(s: &str) -> Vec<Token<'_>> {
    let b = s.as_bytes();
    let mut out = Vec::new();
    let (mut i, mut text_start) = (0, 0);
    while i < b.len() {
        let starts_number = b[i].is_ascii_digit()
            || (b[i] == b'-' && i + 1 < b.len() && (b[i + 1].is_ascii_digit() || b[i + 1] == b'.'))
            || (b[i] == b'.' && i + 1 < b.len() && b[i + 1].is_ascii_digit());
        // A digit inside a word (`C4`, `x2`) is text, not a number.
        let in_word = i > 0 && (b[i - 1].is_ascii_alphabetic() || b[i - 1] == b'_');
        if starts_number && !in_word {
            let mut j = i + 1;
            while j < b.len() && (b[j].is_ascii_digit() || b[j] == b'.') {
                j += 1;
            }
            if j < b.len() && (b[j] == b'e' || b[j] == b'E') {
                let mut k = j + 1;
                if k < b.len() && (b[k] == b'+' || b[k] == b'-') {
                    k += 1;
                }
                if k < b.len() && b[k].is_ascii_digit() {
                    j = k;
                    while j < b.len() && b[j].is_ascii_digit() {
                        j += 1;
                    }
                }
            }
            if let Ok(v) = s[i..j].parse::<f64>() {
                if text_start < i {
                    out.push(Token::Text(&s[text_start..i]));
                }
                out.push(Token::Number(v));
                text_start = j;
                i = j;
                continue;
            }
        }
        i += 1;
    }
    if text_start < b.len() {
        out.push(Token::Text(&s[text_start..]));
    }
    out
}

/// Compares `actual` with `golden`: equal text between numbers, numbers within `tolerance`.
pub fn compare_text(actual: &str, golden: &str, tolerance: f64) -> TextComparison {
    let (a, g) = (tokens(actual), tokens(golden));
    let mut r = TextComparison { pass: true, max_abs: 0.0, numbers: 0, failing_numbers: 0, mismatch: None };
    for (i, (x, y)) in a.iter().zip(&g).enumerate() {
        match (x, y) {
            (Token::Number(p), Token::Number(q)) => {
                r.numbers += 1;
                let d = (p - q).abs();
                let d = if d.is_nan() { f64::INFINITY } else { d };
                r.max_abs = r.max_abs.max(d);
                if d > tolerance {
                    r.failing_numbers += 1;
                }
            }
            (Token::Text(p), Token::Text(q)) if p == q => {}
            (Token::Text(p), Token::Text(q)) => {
                // Show where they part, not their common start.
                let at = p
                    .char_indices()
                    .zip(q.chars())
                    .find(|&((_, a), b)| a != b)
                    .map_or(p.len().min(q.len()), |((k, _), _)| k);
                let at = at.min(q.len());
                let from = |s: &'_ str| -> String {
                    format!("{:?}", s[at.min(s.len())..].chars().take(40).collect::<String>())
                };
                r.mismatch = Some(format!("token {i}, character {at}: found {}, golden has {}", from(p), from(q)));
                break;
            }
            _ => {
                r.mismatch = Some(format!("token {i}: found {}, golden has {}", excerpt(x), excerpt(y)));
                break;
            }
        }
    }
    if r.mismatch.is_none() && a.len() != g.len() {
        r.mismatch = Some(format!("{} tokens, golden has {}", a.len(), g.len()));
    }
    r.pass = r.mismatch.is_none() && r.failing_numbers == 0;
    r
}

fn excerpt(t: &Token) -> String {
    match t {
        Token::Number(v) => format!("number {v}"),
        Token::Text(s) => {
            let s: String = s.chars().take(40).collect();
            format!("{s:?}")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_text_mismatch_shows_where_the_texts_part() {
        let r = compare_text(
            "status = \"matched\"\nshader = \"bar\"\n",
            "status = \"matched\"\nshader = \"circle\"\n",
            1.0,
        );
        assert!(!r.pass);
        let m = r.mismatch.unwrap();
        assert!(m.contains("found \"bar") && m.contains("golden has \"circle"), "{m}");
    }

    #[test]
    fn numbers_within_tolerance_pass() {
        let r = compare_text(r#"{"x": [1.0000001, -2e-3]}"#, r#"{"x": [1.0, -0.002]}"#, 1e-6);
        assert!(r.pass, "{r:?}");
        assert_eq!(r.numbers, 2);
    }

    #[test]
    fn numbers_beyond_tolerance_fail() {
        let r = compare_text("<path d=\"M 1 2 L 3 4\"/>", "<path d=\"M 1 2 L 3 4.5\"/>", 1e-3);
        assert!(!r.pass);
        assert_eq!(r.failing_numbers, 1);
        assert!((r.max_abs - 0.5).abs() < 1e-12);
    }

    #[test]
    fn text_changes_fail() {
        let r = compare_text(r#"{"a": 1}"#, r#"{"b": 1}"#, 1.0);
        assert!(!r.pass && r.mismatch.is_some());
        let r = compare_text("[1, 2]", "[1, 2, 3]", 1.0);
        assert!(!r.pass);
    }

    #[test]
    fn digits_inside_words_are_text() {
        let r = compare_text("C4 x2", "C5 x2", 10.0);
        assert!(!r.pass);
    }
}
