//! The checks a blend's inputs pass before any work: matching sizes and channels, finite
//! values, a selector that fits the sources, and solver parameters in range.

use rayon::prelude::*;

use crate::raster::Image;
use crate::synth::blend::params::{BlendError, BlendParams, Param, Selector, Topology};

pub(crate) fn validate(
    sources: &[&Image],
    selector: &Selector<'_>,
    params: &BlendParams,
    warm: Option<&Image>,
) -> Result<(), BlendError> {
    let first = *sources.first().ok_or(BlendError::NoSources)?;
    let (w, h, c) = (first.width, first.height, first.channels);
    if w == 0 || h == 0 || c == 0 {
        return Err(BlendError::Empty { what: "source 0".into() });
    }
    for (i, s) in sources.iter().enumerate() {
        let what = format!("source {i}");
        if !s.same_size(first) {
            return Err(BlendError::SizeMismatch { what, expected: (w, h), found: (s.width, s.height) });
        }
        if s.channels != c {
            return Err(BlendError::ChannelMismatch { what, expected: c, found: s.channels });
        }
        check_finite(s, &what)?;
    }
    match selector {
        Selector::Binary(m) | Selector::Soft(m) => {
            if sources.len() != 2 {
                return Err(BlendError::SourceCount { expected: 2, found: sources.len() });
            }
            if m.width == 0 || m.height == 0 || m.channels == 0 {
                return Err(BlendError::Empty { what: "mask".into() });
            }
            if !m.same_size(first) {
                return Err(BlendError::SizeMismatch {
                    what: "mask".into(),
                    expected: (w, h),
                    found: (m.width, m.height),
                });
            }
            if m.channels != 1 && m.channels != c {
                return Err(BlendError::ChannelMismatch { what: "mask".into(), expected: c, found: m.channels });
            }
            check_finite(m, "mask")?;
        }
        Selector::Labels(l) => {
            if l.len() != w * h {
                return Err(BlendError::BadParameter {
                    name: Param::Labels,
                    reason: format!("has {} entries; the sources are {w}x{h} = {}", l.len(), w * h),
                });
            }
            if let Some(i) = l.iter().position(|&v| v as usize >= sources.len()) {
                return Err(BlendError::LabelOutOfRange { x: i % w, y: i / w, label: l[i], sources: sources.len() });
            }
        }
    }
    if let Some(wm) = warm {
        if !wm.same_size(first) {
            return Err(BlendError::SizeMismatch {
                what: "warm start".into(),
                expected: (w, h),
                found: (wm.width, wm.height),
            });
        }
        if wm.channels != c {
            return Err(BlendError::ChannelMismatch { what: "warm start".into(), expected: c, found: wm.channels });
        }
        check_finite(wm, "warm start")?;
    }
    let s = &params.solver;
    if !(s.tol > 0.0 && s.tol.is_finite()) {
        return Err(BlendError::BadParameter {
            name: Param::Tol,
            reason: format!("{} is not a positive number", s.tol),
        });
    }
    if s.max_tol.is_nan() || s.max_tol <= 0.0 {
        return Err(BlendError::BadParameter { name: Param::MaxTol, reason: format!("{} is not positive", s.max_tol) });
    }
    if s.max_iter == 0 {
        return Err(BlendError::BadParameter { name: Param::MaxIter, reason: "must be at least 1".into() });
    }
    if s.smooth == 0 {
        return Err(BlendError::BadParameter { name: Param::Smooth, reason: "must be at least 1".into() });
    }
    if let Topology::Rim { source } = params.topology {
        if source >= sources.len() {
            return Err(BlendError::BadParameter {
                name: Param::RimSource,
                reason: format!("source {source} does not exist ({} given)", sources.len()),
            });
        }
    }
    Ok(())
}

fn check_finite(img: &Image, what: &str) -> Result<(), BlendError> {
    const CHUNK: usize = 1 << 14;
    let all_finite = |c: &[f32]| c.iter().fold(true, |ok, v| ok & v.is_finite());
    if let Some(ci) = img.data.par_chunks(CHUNK).position_first(|c| !all_finite(c)) {
        let i = ci * CHUNK + img.data[ci * CHUNK..].iter().position(|v| !v.is_finite()).unwrap_or(0);
        let n = img.plane_len();
        let (c, p) = (i / n, i % n);
        return Err(BlendError::NonFinite { what: what.into(), x: p % img.width, y: p / img.width, channel: c });
    }
    Ok(())
}
