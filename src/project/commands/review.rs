//! `tessera review`: after a check, the failing outputs one at a time, each with the numbers
//! of its check row and where its diff image is, and an answer read from stdin: accept
//! (bless that output), reject (keep the golden and the diff), skip, or quit. Answers are
//! read line by line, so a script can pipe them; when stdin ends the review stops.

use std::io::{BufRead, Write};

use super::print::{self, print_failed};
use super::{Global, Outcome, Reported};
use crate::project::{Built, CheckRow, CheckStatus, Project};

/// What the user answered about one output.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Answer {
    Accept,
    Reject,
    Skip,
    Quit,
}

impl Answer {
    fn parse(line: &str) -> Option<Answer> {
        match line.trim().to_ascii_lowercase().as_str() {
            "a" | "accept" => Some(Answer::Accept),
            "r" | "reject" => Some(Answer::Reject),
            "s" | "skip" => Some(Answer::Skip),
            "q" | "quit" => Some(Answer::Quit),
            _ => None,
        }
    }
}

/// How many outputs got each answer.
#[derive(Default)]
struct Tally {
    accepted: usize,
    rejected: usize,
    skipped: usize,
}

/// Walks the rows that did not pass, asking about each; `builts` holds the outputs to
/// bless. Fails only when accepting an output could not write its golden.
pub(super) fn walk(g: &Global, p: &Project, builts: &[Built], rows: &[CheckRow]) -> Outcome {
    let failing: Vec<&CheckRow> = rows.iter().filter(|r| r.status != CheckStatus::Pass).collect();
    if failing.is_empty() {
        if !g.quiet {
            println!("\nreview: all {} outputs pass", rows.len());
        }
        return Ok(());
    }
    let mut lines = std::io::stdin().lock().lines();
    let mut tally = Tally::default();
    let mut failed = false;
    for (i, row) in failing.iter().enumerate() {
        println!("\n[{}/{}] {}", i + 1, failing.len(), print::row_summary(row));
        let Some(answer) = ask(&mut lines) else {
            println!("review: no more answers; {} outputs left as they are", failing.len() - i);
            break;
        };
        match answer {
            Answer::Accept => match accept(g, p, builts, row) {
                Ok(()) => tally.accepted += 1,
                Err(Reported) => failed = true,
            },
            Answer::Reject => tally.rejected += 1,
            Answer::Skip => tally.skipped += 1,
            Answer::Quit => break,
        }
    }
    if !g.quiet {
        println!("\nreview: {} accepted, {} rejected, {} skipped", tally.accepted, tally.rejected, tally.skipped);
    }
    if failed {
        Err(Reported)
    } else {
        Ok(())
    }
}

/// Prompts until a valid answer is read; `None` when stdin ends (or cannot be read).
fn ask(lines: &mut impl Iterator<Item = std::io::Result<String>>) -> Option<Answer> {
    loop {
        print!("[a]ccept / [r]eject / [s]kip / [q]uit? ");
        let _ = std::io::stdout().flush();
        let line = lines.next()?.ok()?;
        println!();
        match Answer::parse(&line) {
            Some(a) => return Some(a),
            None => println!("answer a, r, s or q (not `{}`)", line.trim()),
        }
    }
}

/// Blesses the output of `row` alone and removes its diff image, which no longer says
/// anything.
fn accept(g: &Global, p: &Project, builts: &[Built], row: &CheckRow) -> Outcome {
    let Some(built) = builts.iter().find(|b| b.name == row.scene) else { return Ok(()) };
    let written = p.bless_outputs(built, Some(std::slice::from_ref(&row.output))).map_err(|f| print_failed(&f))?;
    if let Some(diff) = &row.diff {
        let _ = std::fs::remove_file(diff);
    }
    if !g.quiet {
        for path in written {
            println!("  blessed {}", path.display());
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::Answer;

    #[test]
    fn answers_are_letters_or_words_in_any_case() {
        assert_eq!(Answer::parse("a\n"), Some(Answer::Accept));
        assert_eq!(Answer::parse(" Reject "), Some(Answer::Reject));
        assert_eq!(Answer::parse("S"), Some(Answer::Skip));
        assert_eq!(Answer::parse("quit"), Some(Answer::Quit));
        assert_eq!(Answer::parse("yes"), None);
        assert_eq!(Answer::parse(""), None);
    }
}
