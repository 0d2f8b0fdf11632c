//! Progress bars for long stages, only on a terminal and only once a stage has run for a
//! moment, so quick builds print nothing but their summary.

use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};

const SHOW_AFTER: Duration = Duration::from_millis(300);

pub struct Progress {
    label: String,
    start: Instant,
    enabled: bool,
    bar: Mutex<Option<ProgressBar>>,
}

impl Progress {
    pub fn new(label: &str, enabled: bool) -> Self {
        Progress {
            label: label.to_string(),
            start: Instant::now(),
            enabled: enabled && std::io::stderr().is_terminal(),
            bar: Mutex::new(None),
        }
    }

    pub fn update(&self, done: u64, total: u64) {
        if !self.enabled || self.start.elapsed() < SHOW_AFTER {
            return;
        }
        let mut guard = self.bar.lock().expect("progress lock");
        let bar = guard.get_or_insert_with(|| {
            let b = ProgressBar::new(total);
            if let Ok(style) = ProgressStyle::with_template("{msg:>24} [{bar:30}] {pos}/{len} {elapsed}") {
                b.set_style(style.progress_chars("=> "));
            }
            b.set_message(self.label.clone());
            b
        });
        bar.set_length(total);
        bar.set_position(done);
    }

    pub fn finish(&self) {
        if let Some(b) = self.bar.lock().expect("progress lock").take() {
            b.finish_and_clear();
        }
    }
}
