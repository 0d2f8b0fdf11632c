//! The `tessera` command line: arguments in, one call into `project::commands`, exit code
//! out. Everything a command does or prints lives there.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use clap::{CommandFactory, Parser, Subcommand};

use tessera::project::commands::{self, Global, MessageFormat, Mode, Shell};
use tessera::project::texture::{Fourier, SimilarOptions};

#[derive(Parser)]
#[command(name = "tessera", version, about = "A compiler for example-driven surface detail")]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Worker threads (default: one per core). Outputs do not depend on it.
    #[arg(short = 'j', long = "jobs", global = true)]
    jobs: Option<usize>,
    /// Override a scene `param`: `--set scale=1.3` (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE", global = true, value_parser = parse_set)]
    sets: Vec<(String, String)>,
    /// Print each stage's time and cache state.
    #[arg(long, global = true)]
    timings: bool,
    /// Write the stage report of every scene as JSON to this file.
    #[arg(long, value_name = "FILE", global = true)]
    report: Option<PathBuf>,
    /// Print nothing but errors.
    #[arg(short, long, global = true)]
    quiet: bool,
    /// How to report: `human`, or `json` (one object per line on stdout; see
    /// docs/message-format.md).
    #[arg(long, value_enum, value_name = "FORMAT", global = true, default_value_t = FormatArg::Human)]
    message_format: FormatArg,
    /// Memory budget of a build (`4GiB`, `512MiB`, bytes); default: `[limits] max_memory` in
    /// tessera.toml, else half the machine's memory.
    #[arg(long, value_name = "SIZE", global = true, value_parser = commands::parse_bytes)]
    max_memory: Option<u64>,
    /// Build every scene with this seed instead of its own (to explore variations).
    #[arg(long, global = true)]
    seed: Option<u64>,
    /// A shared cache under the local one, over Bazel's HTTP remote-cache protocol
    /// (`http://host:port/prefix`), instead of `[cache] remote` in tessera.toml. Credentials
    /// come from TESSERA_REMOTE_CACHE_TOKEN or TESSERA_REMOTE_CACHE_BASIC.
    #[arg(long, value_name = "URL", global = true)]
    remote_cache: Option<String>,
    /// Read from the remote cache but never upload to it.
    #[arg(long, global = true)]
    remote_read_only: bool,
    /// Use no remote cache, whatever tessera.toml says.
    #[arg(long, global = true, conflicts_with = "remote_cache")]
    no_remote_cache: bool,
}

#[derive(Subcommand)]
enum Command {
    /// Build scenes and write their outputs (default: every scene of the repository).
    Build { paths: Vec<PathBuf> },
    /// Build a scene, then rebuild it whenever a file it read changes.
    Watch {
        scene: PathBuf,
        /// Quiet time after a change before rebuilding, in milliseconds.
        #[arg(long, default_value_t = 30)]
        debounce: u64,
        /// Also serve a live preview page of the outputs at this address (default
        /// 127.0.0.1 and a free port; the URL is printed).
        #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = "127.0.0.1:0")]
        serve: Option<String>,
    },
    /// Build scenes and compare their outputs with the goldens.
    Check { paths: Vec<PathBuf> },
    /// Build scenes and write their outputs as the new goldens: whole scenes, or single
    /// outputs as `SCENE:OUTPUT` (`scenes/wall.tess:labels.png`).
    Bless {
        #[arg(value_name = "SCENE[:OUTPUT]")]
        targets: Vec<String>,
        /// Also remove the goldens of outputs the scenes no longer declare, and (with no scene
        /// named) the golden directories of scenes that are gone.
        #[arg(long)]
        prune: bool,
    },
    /// Build and check scenes, then write every output beside its golden and the difference
    /// as a static web page, `out/.gallery/index.html` (a CI artefact, a README picture).
    Gallery { paths: Vec<PathBuf> },
    /// Check scenes, then walk the failing outputs one by one: accept (bless it), reject,
    /// skip or quit, answered on stdin.
    Review { paths: Vec<PathBuf> },
    /// Rewrite scene files in the canonical layout.
    Fmt {
        paths: Vec<PathBuf>,
        /// Only report files that are not formatted; exit 1 if any.
        #[arg(long)]
        check: bool,
    },
    /// Run the language server on stdin and stdout (for editors: diagnostics, hover,
    /// completion, definition, rename, formatting).
    Lsp,
    /// Print a declaration kind's properties, types, defaults and docs.
    Explain {
        kind: Option<String>,
        /// Every kind as Markdown (the reference section of docs/language.md).
        #[arg(long)]
        markdown: bool,
    },
    /// Print a scene's stage graph with cache state.
    Graph {
        scene: PathBuf,
        /// Graphviz DOT instead of text.
        #[arg(long)]
        dot: bool,
    },
    /// Rank the images of a directory by similarity to a target image (colour histogram and
    /// Fourier features, Welsman-Dinelle Eq. 4.5) and print the table.
    Similar {
        /// The library directory (its `.png` and `.exr` files).
        dir: PathBuf,
        /// The image to match.
        target: PathBuf,
        /// Number of candidates.
        #[arg(short, default_value_t = 8)]
        k: usize,
        /// 0: the k nearest in order; 1: k drawn uniformly; between: weighted draws.
        #[arg(long, default_value_t = 0.0)]
        randomness: f64,
        /// Seed of the draws.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Fourier comparison.
        #[arg(long, value_enum, default_value_t = FourierArg::Reim)]
        fourier: FourierArg,
        /// Leave the colour histogram out.
        #[arg(long)]
        no_colour: bool,
        /// Also compare dominant orientations.
        #[arg(long)]
        orientation: bool,
        /// Scale axes by fixed bounds instead of this query's largest distance.
        #[arg(long)]
        fixed: bool,
        /// Colour histogram bins per axis.
        #[arg(long, default_value_t = 32)]
        bins: usize,
        /// Fourier analysis size (a power of two).
        #[arg(long, default_value_t = 128)]
        size: usize,
    },
    /// Print texture distances of image A against image B: power spectrum, Laplacian
    /// pyramid, colour histogram, and bidirectional patch similarity.
    Compare { a: PathBuf, b: PathBuf },
    /// Inspect the cache.
    Cache {
        #[command(subcommand)]
        action: CacheAction,
    },
    /// Remove cache entries that no current scene uses.
    Gc {
        /// Remove every entry.
        #[arg(long)]
        all: bool,
    },
    /// Print a shell completion script: `tessera completions bash > /etc/bash_completion.d/tessera`.
    Completions {
        #[arg(value_enum)]
        shell: Shell,
    },
    /// Print the man page (roff): `tessera man > tessera.1`.
    Man,
}

#[derive(Subcommand)]
enum CacheAction {
    /// Print the hit rates of past builds: local hits, remote hits, computed stages, bytes
    /// moved.
    Stats,
    /// Upload to the remote cache the local entries of the scenes' stages that it lacks
    /// (stages built before the remote was set, or while it was down).
    Push {
        /// Scene files or directories (default: the manifest's scenes directory).
        paths: Vec<PathBuf>,
    },
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum FormatArg {
    Human,
    Json,
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum FourierArg {
    Reim,
    Modulus,
    Magnitude,
    Radial,
    Off,
}

fn parse_set(s: &str) -> Result<(String, String), String> {
    let (k, v) = s.split_once('=').ok_or_else(|| format!("expected NAME=VALUE, found `{s}`"))?;
    Ok((k.trim().to_string(), v.trim().to_string()))
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    if let Some(j) = cli.jobs {
        commands::set_jobs(j);
    }
    commands::set_message_format(match cli.message_format {
        FormatArg::Human => MessageFormat::Human,
        FormatArg::Json => MessageFormat::Json,
    });
    let g = Global {
        sets: cli.sets,
        timings: cli.timings,
        report: cli.report,
        quiet: cli.quiet,
        max_memory: cli.max_memory,
        seed: cli.seed,
        remote_cache: cli.remote_cache,
        remote_read_only: cli.remote_read_only,
        no_remote_cache: cli.no_remote_cache,
    };
    let result = match cli.command {
        Command::Build { paths } => commands::scenes(&g, &paths, Mode::Build),
        Command::Check { paths } => commands::scenes(&g, &paths, Mode::Check),
        Command::Gallery { paths } => commands::scenes(&g, &paths, Mode::Gallery),
        Command::Bless { targets, prune } => commands::bless(&g, &targets, prune),
        Command::Review { paths } => commands::scenes(&g, &paths, Mode::Review),
        Command::Watch { scene, debounce, serve } => {
            commands::watch(&g, &scene, Duration::from_millis(debounce), serve.as_deref())
        }
        Command::Fmt { paths, check } => commands::fmt(&g, &paths, check),
        Command::Lsp => commands::lsp(),
        Command::Explain { kind, markdown } => commands::explain(kind.as_deref(), markdown),
        Command::Graph { scene, dot } => commands::graph(&g, &scene, dot),
        Command::Gc { all } => commands::gc(&g, all),
        Command::Cache { action: CacheAction::Stats } => commands::cache_stats(&g),
        Command::Cache { action: CacheAction::Push { paths } } => commands::cache_push(&g, &paths),
        Command::Similar { dir, target, k, randomness, seed, fourier, no_colour, orientation, fixed, bins, size } => {
            let fourier = match fourier {
                FourierArg::Reim => Some(Fourier::ReIm),
                FourierArg::Modulus => Some(Fourier::Modulus),
                FourierArg::Magnitude => Some(Fourier::Magnitude),
                FourierArg::Radial => Some(Fourier::Radial),
                FourierArg::Off => None,
            };
            let options =
                SimilarOptions { k, randomness, seed, colour: !no_colour, fourier, orientation, fixed, bins, size };
            commands::similar(&g, &dir, &target, &options)
        }
        Command::Compare { a, b } => commands::compare(&a, &b),
        Command::Completions { shell } => commands::completions(Cli::command(), shell),
        Command::Man => commands::man(Cli::command()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(commands::Reported) => ExitCode::FAILURE,
    }
}
