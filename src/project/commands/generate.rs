//! `tessera completions SHELL` and `tessera man`: shell completion scripts and a roff man
//! page, generated from the command line's clap definitions (which `main.rs` hands over).

use super::{Outcome, Reported};

/// The shells `tessera completions` writes scripts for.
pub use clap_complete::Shell;

/// `tessera completions SHELL`: the completion script of `cli` for `shell`, on stdout.
pub fn completions(mut cli: clap::Command, shell: Shell) -> Outcome {
    let name = cli.get_name().to_string();
    let mut out = std::io::stdout().lock();
    clap_complete::generate(shell, &mut cli, name, &mut out);
    Ok(())
}

/// `tessera man`: the man page of `cli` (roff, section 1), on stdout.
pub fn man(cli: clap::Command) -> Outcome {
    let mut out = std::io::stdout().lock();
    clap_mangen::Man::new(cli).render(&mut out).map_err(|e| {
        eprintln!("error: cannot write the man page: {e}");
        Reported
    })
}
