//! `tessera watch`: rebuild a scene whenever a file it read changes.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime};

use super::{Built, Emitted, Failed, Project};
use crate::graph::watch::Watcher;
use crate::graph::MemoryCache;

/// What happened on one pass of the loop, for the caller to print.
pub enum WatchEvent<'a> {
    Built {
        built: &'a Built,
        emitted: &'a [Emitted],
        millis: f64,
    },
    Failed {
        failed: &'a Failed,
    },
    /// Some files cannot be watched (no permission, the system's limit on watches) and are
    /// polled instead: slower to notice, never deaf.
    Warning(String),
}

/// Builds `scene`, then rebuilds on every change of a file the last build read, forever.
/// A failed build keeps the previous outputs and is retried on the next change; the files it
/// tried to read are followed too, so creating a missing one (or its directory) rebuilds.
pub fn watch(project: &mut Project, scene: &Path, debounce: Duration, mut on: impl FnMut(&Project, WatchEvent)) {
    project.memory.get_or_insert_with(MemoryCache::default);
    let mut watcher = Watcher::new();
    // The scene is followed before the first build, and each build's files before its
    // report: an edit made while building, or by someone reacting to the report, is queued
    // and seen by the next wait rather than lost.
    watcher.follow([scene.to_path_buf()], None);
    loop {
        let started = SystemTime::now();
        let start = Instant::now();
        project.world.begin_build();
        let result = project.build(scene).and_then(|b| project.emit(&b).map(|e| (b, e)));
        let millis = start.elapsed().as_secs_f64() * 1000.0;
        let mut files: Vec<PathBuf> = project.world.accessed();
        files.push(scene.to_path_buf());
        watcher.follow(files, Some(started));
        for w in watcher.take_warnings() {
            on(project, WatchEvent::Warning(w));
        }
        match &result {
            Ok((built, emitted)) => on(project, WatchEvent::Built { built, emitted, millis }),
            Err(failed) => on(project, WatchEvent::Failed { failed }),
        }
        watcher.wait(debounce);
    }
}
