//! `tessera explain`: the declaration kinds, one kind's properties, or every kind as the
//! Markdown reference of docs/language.md.

use super::{Outcome, Reported};
use crate::lang;

/// Lists the kinds (`kind` absent), explains one, or prints all as Markdown.
pub fn explain(kind: Option<&str>, markdown: bool) -> Outcome {
    let registry = crate::kinds::registry();
    if markdown {
        for k in &registry {
            println!("{}", lang::schema::markdown(k));
        }
        return Ok(());
    }
    match kind {
        None => {
            println!("Declaration kinds (tessera explain KIND for details):");
            for k in &registry {
                println!("  {:<10} {}", k.name, k.doc);
            }
            Ok(())
        }
        Some(name) => match registry.iter().find(|k| k.name == name) {
            Some(k) => {
                print!("{}", lang::schema::explain(k));
                Ok(())
            }
            None => {
                let names: Vec<&str> = registry.iter().map(|k| k.name).collect();
                let hint = lang::diag::suggest(name, names.iter().copied())
                    .map(|s| format!("; did you mean `{s}`?"))
                    .unwrap_or_default();
                eprintln!("error: unknown kind `{name}`{hint} (kinds: {})", names.join(", "));
                Err(Reported)
            }
        },
    }
}
