//! Progress display for long stages, only on a terminal and only once a stage has run for a
//! moment, so quick builds print nothing but their summary. Stages that report progress
//! get a bar; the others a spinner with their name and elapsed time.

use std::io::IsTerminal;
use std::sync::{Arc, Condvar, Mutex};
use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};

const SHOW_AFTER: Duration = Duration::from_millis(400);

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
            let bar = match shared.position {
                Some((done, total)) => {
                    let b = ProgressBar::new(total);
                    b.set_position(done);
                    b.set_style(bar_style());
                    b
                }
                None => {
                    let b = ProgressBar::new_spinner();
                    if let Ok(style) = ProgressStyle::with_template("{spinner} {msg} {elapsed}") {
                        b.set_style(style);
                    }
                    b
                }
            };
            bar.set_message(label);
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
