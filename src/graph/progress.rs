//! Progress display for long stages, only on a terminal and only once a stage has run for a
//! moment, so quick builds print nothing but their summary. Stages that report progress
//! get a bar; the others a spinner with their name and elapsed time. A command that builds
//! several scenes shows a bar of scenes above them ([`ScenesBar`]); every bar is drawn by
//! one `MultiProgress`, so stage bars nest under the scene bar.

use std::io::IsTerminal;
use std::sync::{Arc, Condvar, Mutex, OnceLock};
use std::time::Duration;

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

const SHOW_AFTER: Duration = Duration::from_millis(400);

/// The one set of bars on stderr: two `MultiProgress`es would draw over each other.
fn bars() -> &'static MultiProgress {
    static BARS: OnceLock<MultiProgress> = OnceLock::new();
    BARS.get_or_init(|| MultiProgress::with_draw_target(ProgressDrawTarget::stderr()))
}

/// The scenes of a multi-scene command: `[===>   ] 3/45 scenes/wall.tess`, drawn above the
/// stage bars. Shown only on a terminal, only when enabled and only for two or more scenes.
pub struct ScenesBar {
    bar: Option<ProgressBar>,
}

impl ScenesBar {
    pub fn new(scenes: usize, enabled: bool) -> Self {
        if !enabled || scenes < 2 || !std::io::stderr().is_terminal() {
            return ScenesBar { bar: None };
        }
        let bar = ProgressBar::with_draw_target(Some(scenes as u64), ProgressDrawTarget::hidden());
        if let Ok(style) = ProgressStyle::with_template("{prefix:>24} [{bar:30}] {pos}/{len} {msg}") {
            bar.set_style(style.progress_chars("=> "));
        }
        bar.set_prefix("scenes");
        let bar = bars().add(bar);
        ScenesBar { bar: Some(bar) }
    }

    /// Scene `name` is being built.
    pub fn start(&self, name: &str) {
        if let Some(b) = &self.bar {
            b.set_message(name.to_string());
        }
    }

    /// The current scene is done.
    pub fn advance(&self) {
        if let Some(b) = &self.bar {
            b.inc(1);
        }
    }

    /// Runs `f` (which prints) with the bars hidden, so its lines do not tear them.
    pub fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        match &self.bar {
            Some(_) => bars().suspend(f),
            None => f(),
        }
    }
}

impl Drop for ScenesBar {
    fn drop(&mut self) {
        if let Some(b) = self.bar.take() {
            b.finish_and_clear();
            bars().remove(&b);
        }
    }
}

#[derive(Default)]
struct Shared {
    done: bool,
    bar: Option<ProgressBar>,
    /// Latest (done, total) reported by the stage.
    position: Option<(u64, u64)>,
}

pub struct Progress {
    state: Option<Arc<(Mutex<Shared>, Condvar)>>,
}

impl Progress {
    pub fn new(label: &str, enabled: bool) -> Self {
        if !enabled || !std::io::stderr().is_terminal() {
            return Progress { state: None };
        }
        let state = Arc::new((Mutex::new(Shared::default()), Condvar::new()));
        let watcher = state.clone();
        let label = label.to_string();
        // Waits until the stage has run for SHOW_AFTER; a stage that finishes first
        // wakes it and nothing is ever drawn.
        std::thread::spawn(move || {
            let (lock, cvar) = &*watcher;
            let Ok(guard) = lock.lock() else { return };
            let Ok((mut shared, _)) = cvar.wait_timeout_while(guard, SHOW_AFTER, |s| !s.done) else { return };
            if shared.done {
                return;
            }
            // Styled while hidden, then added to the set: drawn before, it would leave a
            // stray line in the default style.
            let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::hidden());
            bar.set_message(label);
            match shared.position {
                Some((done, total)) => {
                    bar.set_style(bar_style());
                    bar.set_length(total);
                    bar.set_position(done);
                }
                None => {
                    if let Ok(style) = ProgressStyle::with_template("{spinner} {msg} {elapsed}") {
                        bar.set_style(style);
                    }
                }
            }
            let bar = bars().add(bar);
            bar.enable_steady_tick(Duration::from_millis(120));
            shared.bar = Some(bar);
        });
        Progress { state: Some(state) }
    }

    pub fn update(&self, done: u64, total: u64) {
        let Some(state) = &self.state else { return };
        let Ok(mut shared) = state.0.lock() else { return };
        shared.position = Some((done, total));
        if let Some(bar) = &shared.bar {
            if bar.length().is_none() {
                bar.set_style(bar_style());
            }
            bar.set_length(total);
            bar.set_position(done);
        }
    }

    pub fn finish(&self) {
        let Some(state) = &self.state else { return };
        let (lock, cvar) = &**state;
        if let Ok(mut shared) = lock.lock() {
            shared.done = true;
            if let Some(b) = shared.bar.take() {
                b.finish_and_clear();
                bars().remove(&b);
            }
        }
        cvar.notify_all();
    }
}

fn bar_style() -> ProgressStyle {
    ProgressStyle::with_template("{msg:>24} [{bar:30}] {pos}/{len} {elapsed}")
        .map(|s| s.progress_chars("=> "))
        .unwrap_or_else(|_| ProgressStyle::default_bar())
}
