//! What the tests see of a quilting run: a trace of each placed block with the engine's own
//! error definitions, and a switch to the plain sequential raster order.

#[cfg(test)]
use crate::synth::quilt::result::BlockRecord;
#[cfg(test)]
use crate::synth::quilt::search::{direct_error, Model, Source, Template};

/// What a test observer sees after each placed block.
#[cfg(test)]
pub(crate) struct Trace<'a> {
    pub model: &'a Model,
    pub sources: &'a [Source],
    pub template: &'a Template,
    pub eligible: &'a [usize],
    pub record: &'a BlockRecord,
}

#[cfg(test)]
impl Trace<'_> {
    /// The error of any candidate against this block's template (the engine's own definition).
    pub fn error(&self, source: usize, qx: usize, qy: usize) -> f64 {
        direct_error(self.model, self.template, &self.sources[source], qx, qy)
    }

    /// Allowed candidates of the eligible sources in index order, as `(source, qx, qy)`.
    pub fn candidates(&self) -> Vec<(usize, usize, usize)> {
        let mut v = Vec::new();
        for &s in self.eligible {
            let src = &self.sources[s];
            v.extend(src.allowed.iter().map(|&i| (s, i as usize % src.cw, i as usize / src.cw)));
        }
        v
    }

    /// Overlap error of one channel only (the per-channel SAD/SSD of Dong Eq. 6.2.2).
    pub fn channel_error(&self, c: usize, source: usize, qx: usize, qy: usize) -> f64 {
        let src = &self.sources[source];
        let (w, plane, c_n) = (src.w(), src.w() * src.h(), self.model.channels);
        let mut acc = 0.0;
        for (k, &(dx, dy)) in self.template.ov_off.iter().enumerate() {
            let d =
                f64::from(src.work[c * plane + (qy + dy) * w + qx + dx]) - f64::from(self.template.ov_val[k * c_n + c]);
            acc += self.template.ov_coef[k * c_n + c] * self.model.dist(d);
        }
        acc
    }
}

#[cfg(test)]
thread_local! {
    /// Test switch: one block per wave, i.e. the plain sequential raster order.
    pub(crate) static RASTER_ORDER: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

#[cfg(test)]
pub(super) type Observer<'o> = Option<&'o mut dyn FnMut(&Trace)>;
#[cfg(not(test))]
pub(super) type Observer<'o> = Option<std::marker::PhantomData<&'o ()>>;
