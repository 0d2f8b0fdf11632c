//! How a long algorithm tells its caller how far it is, without knowing who listens: the
//! caller passes a callback (a terminal bar, a test's counter) or nothing. Reporting never
//! changes a result.

use std::fmt;

/// A progress callback `(done, total)`, or none. Cheap to copy into parameter structs.
#[derive(Clone, Copy, Default)]
pub struct Progress<'a>(Option<&'a (dyn Fn(u64, u64) + Sync)>);

impl<'a> Progress<'a> {
    pub fn new(report: &'a (dyn Fn(u64, u64) + Sync)) -> Self {
        Progress(Some(report))
    }

    /// Nobody listens.
    pub fn none() -> Self {
        Progress(None)
    }

    pub fn report(&self, done: usize, total: usize) {
        if let Some(f) = self.0 {
            f(done as u64, total as u64);
        }
    }
}

impl fmt::Debug for Progress<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(if self.0.is_some() { "Progress(reported)" } else { "Progress(none)" })
    }
}
