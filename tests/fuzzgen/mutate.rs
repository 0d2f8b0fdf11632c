//! Token-level mutations of the bundled scenes: delete, duplicate, swap and replace tokens,
//! splice boundary numbers in place of numbers, and move lines between scenes. The
//! bundled scenes reach every kind with meaningful values, so their mutants get deep.

use super::Rng;

/// The bundled scenes, read once: `(file name, text)`.
pub fn corpus(scenes_dir: &std::path::Path) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut entries: Vec<_> = std::fs::read_dir(scenes_dir).expect("scenes dir").flatten().map(|e| e.path()).collect();
    entries.sort();
    for p in entries {
        // A match of the whole library builds thirteen catalogues, tens of seconds of CPU, and
        // the transformations' catalogues and jump points take over ten: past the fuzz limit
        // for every mutant. Their own tests and the golden check cover those scenes.
        let slow = p.ends_with("match.tess") || p.ends_with("transform.tess");
        if p.extension().is_some_and(|e| e == "tess") && !slow {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            out.push((name, std::fs::read_to_string(&p).expect("scene text")));
        }
    }
    out
}

#[derive(Clone, Copy, PartialEq)]
enum Class {
    Space,
    Word,
    Number,
    Str,
    Punct,
}

fn tokens(src: &str) -> Vec<(Class, &str)> {
    let b = src.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let start = i;
        let c = b[i];
        let class = if c.is_ascii_whitespace() {
            while i < b.len() && b[i].is_ascii_whitespace() {
                i += 1;
            }
            Class::Space
        } else if c == b'"' {
            i += 1;
            while i < b.len() && b[i] != b'"' && b[i] != b'\n' {
                i += 1;
            }
            i = (i + 1).min(b.len());
            Class::Str
        } else if c.is_ascii_digit() || (c == b'-' && b.get(i + 1).is_some_and(u8::is_ascii_digit)) {
            i += 1;
            while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'.' || b[i] == b'e') {
                i += 1;
            }
            Class::Number
        } else if c.is_ascii_alphabetic() || c == b'_' {
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_' || b[i] == b'-') {
                i += 1;
            }
            Class::Word
        } else {
            // One character (UTF-8 aware).
            i += src[i..].chars().next().map_or(1, char::len_utf8);
            Class::Punct
        };
        out.push((class, &src[start..i]));
    }
    out
}

const NUMBERS: &[&str] =
    &["0", "-1", "1e-30", "1e308", "1e309", "0.0001", "16384", "100000", "-0", "9007199254740993", "1.5", "2", "1e-4"];

/// One mutant of `src`; `others` lends lines to splice in.
pub fn mutate(rng: &mut Rng, src: &str, others: &[(String, String)]) -> String {
    let mut toks: Vec<String> = tokens(src).into_iter().map(|(_, t)| t.to_string()).collect();
    let classes: Vec<Class> = tokens(src).into_iter().map(|(c, _)| c).collect();
    let mut classes = classes;
    let words: Vec<String> =
        toks.iter().zip(&classes).filter(|(_, c)| **c == Class::Word).map(|(t, _)| t.clone()).collect();
    for _ in 0..1 + rng.below(4) {
        if toks.is_empty() {
            break;
        }
        let i = rng.below(toks.len());
        match rng.below(8) {
            0 => {
                toks.remove(i);
                classes.remove(i);
            }
            1 => {
                let end = (i + 1 + rng.below(12)).min(toks.len());
                let piece: Vec<String> = toks[i..end].to_vec();
                let pc: Vec<Class> = classes[i..end].to_vec();
                let at = rng.below(toks.len() + 1);
                toks.splice(at..at, piece);
                classes.splice(at..at, pc);
            }
            2 => {
                let j = rng.below(toks.len());
                toks.swap(i, j);
                classes.swap(i, j);
            }
            3 | 4 => {
                // Splice a boundary number over a number.
                let nums: Vec<usize> = (0..toks.len()).filter(|&k| classes[k] == Class::Number).collect();
                if !nums.is_empty() {
                    let k = *rng.pick(&nums);
                    toks[k] = rng.pick(NUMBERS).to_string();
                }
            }
            5 if !words.is_empty() => {
                let ws: Vec<usize> = (0..toks.len()).filter(|&k| classes[k] == Class::Word).collect();
                if !ws.is_empty() {
                    let k = *rng.pick(&ws);
                    toks[k] = rng.pick(&words).clone();
                }
            }
            6 if !others.is_empty() => {
                // A line of another scene, at a line break.
                let other = &rng.pick(others).1;
                let lines: Vec<&str> = other.lines().collect();
                if !lines.is_empty() {
                    let line = format!("\n{}\n", rng.pick(&lines));
                    toks.insert(i, line);
                    classes.insert(i, Class::Space);
                }
            }
            _ => {
                let c = *rng.pick(&["{", "}", "[", "]", "(", ")", ",", "=", "x", "\"", "#", "px", "%"]);
                toks.insert(i, c.to_string());
                classes.insert(i, Class::Punct);
            }
        }
    }
    toks.concat()
}
