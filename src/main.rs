//! The `tessera` command line: arguments in, library calls, exit codes out.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

use clap::{Parser, Subcommand};
use miette::{GraphicalReportHandler, GraphicalTheme};

use tessera::graph::Status;
use tessera::lang::{self, Diagnostics};
use tessera::project::{self, CheckStatus, Failed, Project, WatchEvent};

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
    /// Memory budget of a build (`4GiB`, `512MiB`, bytes); default: `[limits] max_memory` in
    /// tessera.toml, else half the machine's memory.
    #[arg(long, value_name = "SIZE", global = true, value_parser = tessera::graph::budget::parse_bytes)]
    max_memory: Option<u64>,
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
    },
    /// Build scenes and compare their outputs with the goldens.
    Check { paths: Vec<PathBuf> },
    /// Build scenes and write their outputs as the new goldens.
    Bless { paths: Vec<PathBuf> },
    /// Rewrite scene files in the canonical layout.
    Fmt {
        paths: Vec<PathBuf>,
        /// Only report files that are not formatted; exit 1 if any.
        #[arg(long)]
        check: bool,
    },
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
    /// Remove cache entries that no current scene uses.
    Gc {
        /// Remove every entry.
        #[arg(long)]
        all: bool,
    },
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
        let _ = rayon::ThreadPoolBuilder::new().num_threads(j.max(1)).build_global();
    }
    let cwd = std::env::current_dir().unwrap_or_else(|_| PathBuf::from("."));
    let result = match &cli.command {
        Command::Explain { kind, markdown } => explain(kind.as_deref(), *markdown),
        Command::Fmt { paths, check } => fmt(&cwd, paths, *check, cli.max_memory),
        Command::Similar { .. } | Command::Compare { .. } => texture_tool(&cli.command),
        _ => Project::open(&cwd).map_err(|f| print_failed(&f)).and_then(|mut p| {
            p.sets = cli.sets.clone();
            p.progress = !cli.quiet;
            if let Some(m) = cli.max_memory {
                p.set_budget(tessera::graph::Budget::new(m));
            }
            run(&cli, &mut p)
        }),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(code) => code,
    }
}

type CmdResult = Result<(), ExitCode>;

fn run(cli: &Cli, p: &mut Project) -> CmdResult {
    match &cli.command {
        Command::Build { paths } => build(cli, p, paths, Mode::Build),
        Command::Check { paths } => build(cli, p, paths, Mode::Check),
        Command::Bless { paths } => build(cli, p, paths, Mode::Bless),
        Command::Watch { scene, debounce } => {
            watch(cli, p, scene, Duration::from_millis(*debounce));
            Ok(())
        }
        Command::Graph { scene, dot } => {
            let (_, plan) = p.compile(scene).map_err(|f| print_failed(&f))?;
            let keys = p.keys(&plan).map_err(|f| print_failed(&f))?;
            let text = if *dot {
                project::graph_dot(&plan, &keys, &p.cache)
            } else {
                project::graph_text(&plan, &keys, &p.cache)
            };
            print!("{text}");
            Ok(())
        }
        Command::Gc { all } => {
            let scenes = if *all { Vec::new() } else { p.scene_files(&[]).map_err(|f| print_failed(&f))? };
            let r = p.gc(&scenes, *all).map_err(|f| print_failed(&f))?;
            if !cli.quiet {
                println!(
                    "gc: kept {} entries, removed {} ({:.1} KiB freed)",
                    r.kept,
                    r.removed,
                    r.freed_bytes as f64 / 1024.0
                );
            }
            if !r.foreign.is_empty() {
                eprintln!(
                    "warning: {} file(s) in the cache directory are not cache entries and were left alone, e.g. `{}`",
                    r.foreign.len(),
                    r.foreign[0].display()
                );
            }
            Ok(())
        }
        Command::Explain { .. } | Command::Fmt { .. } | Command::Similar { .. } | Command::Compare { .. } => {
            unreachable!("handled before opening the project")
        }
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Mode {
    Build,
    Check,
    Bless,
}

fn build(cli: &Cli, p: &Project, paths: &[PathBuf], mode: Mode) -> CmdResult {
    let scenes = p.scene_files(paths).map_err(|f| print_failed(&f))?;
    let mut failed = false;
    let mut rows = Vec::new();
    let mut reports = Vec::new();
    let mut claims = project::Claims::default();
    for scene in &scenes {
        p.world.begin_build();
        let built = match p.build(scene) {
            Ok(b) => b,
            Err(f) => {
                print_failed(&f);
                failed = true;
                continue;
            }
        };
        if let Err(f) = claims.claim(&built) {
            print_failed(&f);
            failed = true;
            continue;
        }
        let emitted = match p.emit(&built) {
            Ok(e) => e,
            Err(f) => {
                print_failed(&f);
                failed = true;
                continue;
            }
        };
        print_warnings(&built.report);
        if !cli.quiet {
            let ran = built.report.ran().count();
            let written = emitted.iter().filter(|e| e.written).count();
            println!(
                "{}: {} stages, {} ran, {} cached; {} of {} outputs written ({:.1} ms)",
                scene.display(),
                built.report.stages.len(),
                ran,
                built.report.stages.len() - ran,
                written,
                emitted.len(),
                built.millis
            );
            if cli.timings {
                print!("{}", project::timings_table(&built.report));
            }
        }
        reports.push(serde_json::json!({
            "scene": scene.display().to_string(),
            "millis": built.millis,
            "stages": built.report.stages,
        }));
        match mode {
            Mode::Build => {}
            Mode::Bless => match p.bless(&built) {
                Ok(paths) => {
                    if !cli.quiet {
                        for path in paths {
                            println!("  blessed {}", path.display());
                        }
                    }
                }
                Err(f) => {
                    print_failed(&f);
                    failed = true;
                }
            },
            Mode::Check => match p.check(&built) {
                Ok(r) => rows.extend(r),
                Err(f) => {
                    print_failed(&f);
                    failed = true;
                }
            },
        }
    }
    if let Some(path) = &cli.report {
        let json = serde_json::to_string_pretty(&serde_json::json!({ "scenes": reports })).expect("report serialises");
        if let Err(e) = std::fs::write(path, json) {
            eprintln!("error: cannot write the report to {}: {e}", path.display());
            failed = true;
        }
    }
    if mode == Mode::Check {
        print_check_table(&rows);
        if rows.iter().any(|r| r.status != CheckStatus::Pass) {
            failed = true;
        }
    }
    if failed {
        Err(ExitCode::FAILURE)
    } else {
        Ok(())
    }
}

fn print_warnings(report: &tessera::graph::Report) {
    for s in &report.stages {
        for w in &s.warnings {
            eprintln!("warning: {}: {w}", s.label);
        }
    }
}

fn print_check_table(rows: &[project::CheckRow]) {
    println!(
        "\n{:<6} {:<20} {:<28} {:>10} {:>10} {:>14}",
        "status", "scene", "output", "max diff", "tolerance", "failing px"
    );
    for r in rows {
        let status = match r.status {
            CheckStatus::Pass => "ok",
            CheckStatus::Fail => "FAIL",
            CheckStatus::Missing => "MISS",
        };
        println!(
            "{:<6} {:<20} {:<28} {:>10.5} {:>10.5} {:>14}",
            status,
            r.scene,
            r.output,
            r.max_abs,
            r.tolerance,
            format!("{}/{}", r.failing_pixels, r.total_pixels)
        );
        if r.exact {
            println!("       compared exactly: its values are identities");
        } else if let (Some(bits), Some(tol)) = (r.bits, r.tolerance_steps) {
            if r.status == CheckStatus::Fail {
                println!(
                    "       in {bits}-bit steps: max diff {}, tolerance {tol} (the fraction rounded down to whole steps)",
                    r.max_steps.unwrap_or(0)
                );
            }
        }
        if let Some(n) = &r.note {
            println!("       {n}");
        }
        if let Some(d) = &r.diff {
            println!("       diff image: {}", d.display());
        }
    }
    let pass = rows.iter().filter(|r| r.status == CheckStatus::Pass).count();
    println!("\ncheck: {} passed, {} failed", pass, rows.len() - pass);
}

fn watch(cli: &Cli, p: &mut Project, scene: &Path, debounce: Duration) {
    let quiet = cli.quiet;
    let timings = cli.timings;
    project::watch(p, scene, debounce, |ev| {
        match ev {
            WatchEvent::Built { built, emitted, millis } => {
                print_warnings(&built.report);
                if !quiet {
                    let ran: Vec<String> = built
                        .report
                        .stages
                        .iter()
                        .filter(|s| matches!(s.status, Status::Ran | Status::Rebuilt))
                        .map(|s| s.label.clone())
                        .collect();
                    let written = emitted.iter().filter(|e| e.written).count();
                    println!(
                        "[watch] built {} in {:.1} ms: ran {} stage(s){}; {} output(s) written",
                        scene.display(),
                        millis,
                        ran.len(),
                        if ran.is_empty() { String::new() } else { format!(" ({})", ran.join(", ")) },
                        written
                    );
                    if timings {
                        print!("{}", project::timings_table(&built.report));
                    }
                }
            }
            WatchEvent::Failed { failed } => {
                print_failed(failed);
                println!("[watch] build failed; keeping the previous outputs");
            }
            WatchEvent::Warning(w) => eprintln!("warning: {w}"),
        }
        let _ = std::io::stdout().flush();
    });
}

fn texture_tool(command: &Command) -> CmdResult {
    use tessera::synth::library::{FourierMode, Normalise};
    let result = match command {
        Command::Similar { dir, target, k, randomness, seed, fourier, no_colour, orientation, fixed, bins, size } => {
            let options = project::texture::SimilarOptions {
                k: *k,
                randomness: *randomness,
                seed: *seed,
                colour: !no_colour,
                fourier: match fourier {
                    FourierArg::Reim => Some(FourierMode::ReIm),
                    FourierArg::Modulus => Some(FourierMode::Modulus),
                    FourierArg::Magnitude => Some(FourierMode::Magnitude),
                    FourierArg::Radial => Some(FourierMode::Radial),
                    FourierArg::Off => None,
                },
                orientation: *orientation,
                normalise: if *fixed { Normalise::Fixed } else { Normalise::PerQueryMax },
                bins: *bins,
                size: *size,
            };
            project::texture::similar(dir, target, &options)
        }
        Command::Compare { a, b } => project::texture::compare(a, b),
        _ => unreachable!("not a texture tool"),
    };
    match result {
        Ok(table) => {
            print!("{table}");
            Ok(())
        }
        Err(e) => {
            eprintln!("error: {e}");
            Err(ExitCode::FAILURE)
        }
    }
}

fn explain(kind: Option<&str>, markdown: bool) -> CmdResult {
    let registry = tessera::kinds::registry();
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
                Err(ExitCode::FAILURE)
            }
        },
    }
}

fn fmt(cwd: &Path, paths: &[PathBuf], check: bool, max_memory: Option<u64>) -> CmdResult {
    let mut p = Project::open(cwd).map_err(|f| print_failed(&f))?;
    if let Some(m) = max_memory {
        p.set_budget(tessera::graph::Budget::new(m));
    }
    let max_file = p.budget.max_file();
    let files = p.scene_files(paths).map_err(|f| print_failed(&f))?;
    let mut bad = false;
    for file in files {
        let text = match tessera::graph::world::read_regular_text(&file, max_file) {
            Ok(t) => t,
            Err(e) => {
                eprintln!("error: cannot read {}: {e}", file.display());
                bad = true;
                continue;
            }
        };
        match lang::fmt::format_source(&text) {
            Ok(formatted) if formatted == text => {}
            Ok(formatted) if check => {
                println!("not formatted: {}", file.display());
                bad = true;
                let _ = formatted;
            }
            Ok(formatted) => {
                if let Err(e) = project::format::rewrite_scene(&file, &formatted) {
                    eprintln!("error: {e}");
                    bad = true;
                } else {
                    println!("formatted {}", file.display());
                }
            }
            Err(d) => {
                let mut sources = lang::source::SourceMap::default();
                sources.add(file.clone(), file.display().to_string(), text.into());
                print_diagnostics(&Diagnostics::new(vec![d], sources));
                bad = true;
            }
        }
    }
    if bad {
        Err(ExitCode::FAILURE)
    } else {
        Ok(())
    }
}

fn print_failed(f: &Failed) -> ExitCode {
    print_diagnostics(&f.diagnostics);
    ExitCode::FAILURE
}

fn print_diagnostics(d: &Diagnostics) {
    // Colour only on a terminal; plain unicode otherwise, so logs and tests read cleanly.
    let theme = if std::io::IsTerminal::is_terminal(&std::io::stderr()) && std::env::var_os("NO_COLOR").is_none() {
        GraphicalTheme::unicode()
    } else {
        GraphicalTheme::unicode_nocolor()
    };
    let handler = GraphicalReportHandler::new_themed(theme).with_width(100);
    for item in &d.items {
        let rendered = lang::diag::render(item, &d.sources);
        let mut out = String::new();
        if handler.render_report(&mut out, &rendered).is_ok() {
            eprintln!("{out}");
        } else {
            eprintln!("error: {}", item.message);
        }
    }
}
