//! `tessera build`, `check`, `bless` and `review`: every named scene in turn, each built,
//! claimed against the others' outputs, written, then checked or blessed; a failing scene is
//! reported and the rest still run. With `--report`, the stage reports of all scenes go to
//! one JSON file.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use super::messages;
use super::print::{self, print_failed};
use super::{review, Global, Outcome, Reported};
use crate::graph::progress::ScenesBar;
use crate::lang::diag::suggest;
use crate::project::{self, preview, Built, CheckRow, CheckStatus, Failed, Project};

/// What happens to a scene once it is built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Write its outputs.
    Build,
    /// Write its outputs and compare them with the goldens.
    Check,
    /// Write its outputs and make them (or the selected ones) the goldens; with `prune`,
    /// also remove the goldens of outputs the scene no longer declares.
    Bless { prune: bool },
    /// Check, then walk the failing outputs one by one (`tessera review`).
    Review,
    /// Write its outputs, compare them with the goldens, and show everything on a static
    /// page (`tessera gallery`); differences are shown, not failures.
    Gallery,
}

impl Mode {
    /// The command's name: `build`, `check`, `bless` or `review`.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Build => "build",
            Mode::Check => "check",
            Mode::Bless { .. } => "bless",
            Mode::Review => "review",
            Mode::Gallery => "gallery",
        }
    }
}

/// Outputs picked by `SCENE:OUTPUT` arguments, by scene name; a scene absent here is whole.
#[derive(Default)]
struct Selection {
    outputs: HashMap<String, Vec<String>>,
}

impl Selection {
    fn of(&self, scene: &str) -> Option<&[String]> {
        self.outputs.get(scene).map(Vec::as_slice)
    }
}

/// Builds the scenes named by `paths` (every scene of the repository when empty).
pub fn scenes(g: &Global, paths: &[PathBuf], mode: Mode) -> Outcome {
    let mut p = g.open()?;
    p.sets_may_miss = true;
    run(g, &p, paths, mode, &Selection::default())
}

/// `tessera bless [SCENE[:OUTPUT]]...`: blesses whole scenes, or only the outputs named after
/// a scene file and a colon.
pub fn bless(g: &Global, targets: &[String], prune: bool) -> Outcome {
    let mut p = g.open()?;
    p.sets_may_miss = true;
    let (paths, selection) = select(&p, targets).map_err(|f| print_failed(&f))?;
    run(g, &p, &paths, Mode::Bless { prune }, &selection)
}

/// Splits `SCENE:OUTPUT` targets (a target that exists as a file or directory is a scene,
/// colon or not): the scene paths, each once, and the outputs picked in each scene.
fn select(p: &Project, targets: &[String]) -> Result<(Vec<PathBuf>, Selection), Failed> {
    let mut paths: Vec<PathBuf> = Vec::new();
    let mut whole = Vec::new();
    let mut picked: Vec<(PathBuf, String)> = Vec::new();
    for t in targets {
        let (scene, output) = match t.split_once(':') {
            Some((s, o)) if !Path::new(t).exists() => (PathBuf::from(s), Some(o.to_string())),
            _ => (PathBuf::from(t), None),
        };
        if !scene.exists() {
            return Err(unknown_scene(p, &scene));
        }
        match output {
            Some(o) if scene.is_file() => picked.push((scene.clone(), o)),
            Some(_) => {
                return Err(project::plain_error(format!(
                    "`{t}`: `{}` is a directory; name a scene file before the `:`",
                    scene.display()
                )))
            }
            None => whole.push(scene.clone()),
        }
        if !paths.contains(&scene) {
            paths.push(scene);
        }
    }
    // `scene_files` of no path lists every scene: no whole scene was named then.
    let whole: HashSet<String> = if whole.is_empty() {
        HashSet::new()
    } else {
        p.scene_files(&whole)?.iter().filter_map(|f| p.scene_name(f).ok()).collect()
    };
    let mut selection = Selection::default();
    for (scene, output) in picked {
        let name = p.scene_name(&scene)?;
        if !whole.contains(&name) {
            selection.outputs.entry(name).or_default().push(output);
        }
    }
    Ok((paths, selection))
}

/// A scene path that does not exist, with the closest scene file as a suggestion.
fn unknown_scene(p: &Project, scene: &Path) -> Failed {
    let known: Vec<String> =
        p.scene_files(&[]).unwrap_or_default().iter().map(|f| print::shown(f).display().to_string()).collect();
    let hint = suggest(&scene.display().to_string(), known.iter().map(String::as_str))
        .map(|s| format!("; did you mean `{s}`?"))
        .unwrap_or_default();
    project::plain_error(format!("no such scene file or directory: `{}`{hint}", scene.display()))
}

fn run(g: &Global, p: &Project, paths: &[PathBuf], mode: Mode, selection: &Selection) -> Outcome {
    let scenes = p.scene_files(paths).map_err(|f| print_failed(&f))?;
    let names = p.scene_names();
    takers_of_sets(p, &scenes, g.quiet)?;
    let mut failed = false;
    let mut rows = Vec::new();
    let mut reports = Vec::new();
    let mut builts = Vec::new();
    let mut built_names = Vec::new();
    let mut claims = project::Claims::default();
    let mut tally = print::Tally { scenes: scenes.len(), ..Default::default() };
    let mut views = Vec::new();
    let mut links = p.gallery_links();
    let bar = ScenesBar::new(scenes.len(), p.progress);
    for scene in &scenes {
        bar.start(&print::shown(scene).display().to_string());
        p.world.begin_build();
        let built = build_and_emit(g, p, scene, &mut claims, &mut tally, &bar);
        bar.advance();
        let built = match built {
            Ok(built) => built,
            Err(f) => {
                failed = true;
                if mode == Mode::Gallery {
                    views.push(preview::failed_view(&print::shown(scene), None, &f));
                }
                continue;
            }
        };
        built_names.push(built.name.clone());
        reports.push(serde_json::json!({
            "scene": scene.display().to_string(),
            "millis": built.millis,
            "stages": built.report.stages,
        }));
        let done = bar.suspend(|| match mode {
            Mode::Build => Ok(()),
            Mode::Bless { prune } => bless_scene(g, p, &built, selection.of(&built.name), prune, &names),
            Mode::Check | Mode::Review => check_scene(p, &built, &names, mode == Mode::Check, &mut rows),
            Mode::Gallery => p.check(&built).map_err(|f| print_failed(&f)).map(|r| {
                views.push(p.scene_view(&built, &r, &mut links));
                rows.extend(r);
            }),
        });
        failed |= done.is_err();
        if mode == Mode::Review {
            builts.push(built);
        }
    }
    drop(bar);
    if mode != Mode::Build {
        failed |= orphans(g, p, &names, &built_names, mode, paths.is_empty()).is_err();
    }
    if let Some(path) = &g.report {
        if write_report(path, serde_json::json!({ "scenes": reports })).is_err() {
            failed = true;
        }
    }
    match mode {
        Mode::Check => {
            print::check_table(&rows, g.quiet);
            failed |= rows.iter().any(|r| r.status != CheckStatus::Pass);
        }
        Mode::Review => failed |= review::walk(g, p, &builts, &rows).is_err(),
        Mode::Gallery => match links.finish().and_then(|()| preview::write_gallery(p, views)) {
            Ok(index) if !g.quiet && !messages::json() => println!("gallery: {}", print::shown(&index).display()),
            Ok(_) => {}
            Err(f) => {
                print_failed(&f);
                failed = true;
            }
        },
        Mode::Build | Mode::Bless { .. } => {}
    }
    tally.built = reports.len();
    let checked = matches!(mode, Mode::Check | Mode::Review | Mode::Gallery).then_some(&rows[..]);
    print::summary(mode.name(), &tally, checked, failed);
    if failed {
        Err(Reported)
    } else {
        Ok(())
    }
}

/// Goldens of scenes that no longer exist: reported by `check` and `bless`, removed by
/// `bless --prune` of the whole repository (`whole`). A scene built in this run names its
/// directory too, wherever its file lies.
fn orphans(g: &Global, p: &Project, names: &[String], built: &[String], mode: Mode, whole: bool) -> Outcome {
    let scenes: Vec<String> = names.iter().chain(built).cloned().collect();
    let orphans = p.orphan_goldens(&scenes);
    if mode == (Mode::Bless { prune: true }) && whole {
        let removed = p.prune_orphans(&orphans).map_err(|f| print_failed(&f))?;
        if !g.quiet && !messages::json() {
            for path in removed {
                println!("  pruned {}", print::shown(&path).display());
            }
        }
        return Ok(());
    }
    let how = if whole {
        "`tessera bless --prune` removes them"
    } else {
        "`tessera bless --prune` (of every scene) removes them"
    };
    for (dir, files) in orphans {
        eprintln!(
            "warning: `{}/` holds {} golden(s) of no scene (its scene file is gone or renamed); {how}",
            print::shown(&dir).display(),
            files.len()
        );
    }
    Ok(())
}

/// Which of `scenes` declare each `--set` param: a set no scene takes is an error (a typo
/// would otherwise go unnoticed); the others say which scenes took them. When a scene does
/// not compile, nothing is said: its build reports why.
fn takers_of_sets(p: &Project, scenes: &[PathBuf], quiet: bool) -> Outcome {
    if p.sets.is_empty() {
        return Ok(());
    }
    let declared: Vec<(&PathBuf, Vec<String>)> =
        scenes.iter().filter_map(|s| p.compile(s).ok().map(|(scene, _)| (s, scene.params))).collect();
    if declared.len() < scenes.len() {
        // A scene that does not compile (perhaps because of a set's value) may declare any
        // param; its build reports what is wrong with it.
        return Ok(());
    }
    let mut unknown = Vec::new();
    for (name, value) in &p.sets {
        let takers: Vec<String> =
            declared.iter().filter(|(_, params)| params.contains(name)).map(|(s, _)| s.display().to_string()).collect();
        if takers.is_empty() {
            unknown.push(name.as_str());
        } else if !quiet {
            println!("--set {name}={value}: taken by {}", takers.join(", "));
        }
    }
    if unknown.is_empty() {
        return Ok(());
    }
    let all: Vec<&str> = declared.iter().flat_map(|(_, params)| params.iter().map(|p| p.as_str())).collect();
    for name in unknown {
        let who = if scenes.len() == 1 { "the scene declares no" } else { "no scene declares" };
        eprintln!("error: `--set {name}=…`: {who} `param {name}`");
        if let Some(s) = crate::lang::diag::suggest(name, all.iter().copied()) {
            eprintln!("  help: did you mean `{s}`?");
        }
    }
    Err(Reported)
}

/// Builds one scene, claims its outputs against the other scenes' and writes them.
fn build_and_emit(
    g: &Global,
    p: &Project,
    scene: &Path,
    claims: &mut project::Claims,
    tally: &mut print::Tally,
    bar: &ScenesBar,
) -> Result<Built, Failed> {
    let built = p.build(scene);
    bar.suspend(|| {
        print::remote_warning(p);
        let printed = |f: Failed| {
            print_failed(&f);
            f
        };
        let built = built.map_err(printed)?;
        claims.claim(&built).map_err(printed)?;
        let emitted = p.emit(&built).map_err(printed)?;
        print::warnings(Some(&built.name), &built.report);
        tally.outputs += emitted.len();
        tally.written += emitted.iter().filter(|e| e.written).count();
        print::built(g, p, scene, &built, &emitted);
        Ok(built)
    })
}

/// Compares a scene's outputs with its goldens (rows added to `rows`; with `speak`, each
/// failure also a diagnostic at its output's declaration) and warns about goldens of outputs
/// it no longer declares.
fn check_scene(p: &Project, built: &Built, names: &[String], speak: bool, rows: &mut Vec<CheckRow>) -> Outcome {
    let r = p.check(built).map_err(|f| print_failed(&f))?;
    if speak {
        if let Some(d) = project::check_diagnostics(built, &r) {
            print::diagnostics(&d);
        }
    }
    rows.extend(r);
    for stale in p.stale_goldens(built, names) {
        eprintln!(
            "warning: `{}` is the golden of no output of `{}`; `tessera bless --prune` removes it",
            print::shown(&stale).display(),
            print::shown(&built.scene_path).display()
        );
    }
    Ok(())
}

/// Blesses a scene's outputs (those `only` names, or all), then prunes or reports its stale
/// goldens.
fn bless_scene(
    g: &Global,
    p: &Project,
    built: &Built,
    only: Option<&[String]>,
    prune: bool,
    names: &[String],
) -> Outcome {
    let paths = p.bless_outputs(built, only).map_err(|f| print_failed(&f))?;
    if messages::json() {
        messages::blessed(&built.name, &paths);
    } else if !g.quiet {
        for path in paths {
            println!("  blessed {}", path.display());
        }
    }
    let stale = p.stale_goldens(built, names);
    if prune {
        let removed = p.prune_goldens(built, &stale).map_err(|f| print_failed(&f))?;
        if !g.quiet {
            for path in removed {
                println!("  pruned {}", print::shown(&path).display());
            }
        }
    } else {
        for path in stale {
            eprintln!(
                "warning: `{}` is the golden of no output of `{}`; `--prune` removes it",
                print::shown(&path).display(),
                print::shown(&built.scene_path).display()
            );
        }
    }
    Ok(())
}

/// The `--report` file: `report` as pretty JSON.
pub(super) fn write_report(path: &Path, report: serde_json::Value) -> Outcome {
    let json = serde_json::to_string_pretty(&report).expect("report serialises");
    std::fs::write(path, json).map_err(|e| {
        eprintln!("error: cannot write the report to {}: {e}", path.display());
        Reported
    })
}
