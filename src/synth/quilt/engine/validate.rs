//! The checks a quilting call's inputs pass before any work: sizes, channel counts, finite
//! values and parameter ranges of the samples, guide, maps and options.

use crate::raster::Image;
use crate::synth::quilt::params::{
    check_finite_image, check_range, check_size, Coherence, Input, QuiltError, QuiltOptions, QuiltParams, SampleChoice,
};

pub(super) fn validate(samples: &[&Image], p: &QuiltParams, o: &QuiltOptions) -> Result<(), QuiltError> {
    match o.choice {
        SampleChoice::Density(_) if samples.len() != 2 => {
            return Err(QuiltError::SampleCount { got: samples.len(), expected: "exactly 2 for a density map" })
        }
        _ if samples.is_empty() => return Err(QuiltError::SampleCount { got: 0, expected: "at least 1" }),
        _ => {}
    }
    if p.width == 0 || p.height == 0 {
        return Err(QuiltError::Empty { what: Input::Output });
    }
    if p.block == 0 {
        return Err(QuiltError::Empty { what: Input::Block });
    }
    if p.overlap >= p.block {
        return Err(QuiltError::OverlapTooLarge { overlap: p.overlap, block: p.block });
    }
    if p.tileable && p.overlap == 0 {
        return Err(QuiltError::TileableZeroOverlap);
    }
    if p.tileable && (p.width < p.block || p.height < p.block) {
        return Err(QuiltError::TileableTooSmall { block: p.block, width: p.width, height: p.height });
    }
    check_range(Input::Tolerance, p.tolerance, 0.0, f32::MAX, "a finite number ≥ 0")?;
    if p.candidate_stride == 0 {
        return Err(QuiltError::Invalid { name: Input::CandidateStride, value: 0.0, expected: "an integer ≥ 1" });
    }
    if let Coherence::On { forced_search } = p.coherence {
        check_range(Input::ForcedSearch, forced_search, 0.0, 1.0, "a probability in [0, 1]")?;
    }
    let t = o.terms;
    for (name, v) in [(Input::OverlapWeight, t.overlap), (Input::GuideWeight, t.guide), (Input::DepthWeight, t.depth)] {
        check_range(name, v, 0.0, f32::MAX, "a finite number ≥ 0")?;
    }
    // Each weight is finite and ≥ 0 here.
    if t.overlap + t.guide + t.depth <= 0.0 {
        return Err(QuiltError::Invalid { name: Input::TermWeights, value: 0.0, expected: "a positive sum" });
    }
    let channels = samples[0].channels;
    for (i, s) in samples.iter().enumerate() {
        if s.width == 0 || s.height == 0 || s.channels == 0 {
            return Err(QuiltError::Empty { what: Input::Sample });
        }
        if s.channels != channels {
            return Err(QuiltError::ChannelMismatch {
                what: Input::SampleChannels,
                expected: channels,
                got: s.channels,
            });
        }
        check_finite_image(Input::Sample, s)?;
        if p.block > s.width || p.block > s.height {
            return Err(QuiltError::BlockTooLarge { block: p.block, sample: i, width: s.width, height: s.height });
        }
    }
    if let Some(w) = &p.channel_weights {
        if w.len() != channels {
            return Err(QuiltError::ChannelMismatch { what: Input::ChannelWeights, expected: channels, got: w.len() });
        }
        for &v in w {
            check_range(Input::ChannelWeight, v, 0.0, f32::MAX, "a finite number ≥ 0")?;
        }
    }
    if let Some(&c) = o.depth_channels.iter().find(|&&c| c >= channels) {
        return Err(QuiltError::ChannelMismatch { what: Input::DepthChannel, expected: channels, got: c });
    }
    let scalar_map = |what: Input, img: &Image| -> Result<(), QuiltError> {
        check_size(what, img, p.width, p.height)?;
        if img.channels != 1 {
            return Err(QuiltError::ChannelMismatch { what, expected: 1, got: img.channels });
        }
        check_finite_image(what, img)
    };
    if let Some(m) = o.occupancy {
        scalar_map(Input::Occupancy, m)?;
    }
    if let Some(g) = &o.guide {
        check_size(Input::Guide, g.image, p.width, p.height)?;
        check_finite_image(Input::Guide, g.image)?;
        if let Some(wt) = g.weights {
            scalar_map(Input::GuideWeights, wt)?;
            if wt.data.iter().any(|&v| v < 0.0) {
                return Err(QuiltError::Invalid { name: Input::GuideWeight, value: -1.0, expected: "values ≥ 0" });
            }
        }
        match g.channels {
            Some(map) => {
                if map.len() != g.image.channels {
                    return Err(QuiltError::ChannelMismatch {
                        what: Input::GuideChannelMap,
                        expected: g.image.channels,
                        got: map.len(),
                    });
                }
                if let Some(&c) = map.iter().find(|&&c| c >= channels) {
                    return Err(QuiltError::ChannelMismatch {
                        what: Input::GuideChannelIndex,
                        expected: channels,
                        got: c,
                    });
                }
            }
            None if g.image.channels > channels => {
                return Err(QuiltError::ChannelMismatch {
                    what: Input::GuideChannels,
                    expected: channels,
                    got: g.image.channels,
                })
            }
            None => {}
        }
    }
    match o.choice {
        SampleChoice::Density(map) => scalar_map(Input::Density, map)?,
        SampleChoice::NearestMean { lab } => match &o.guide {
            None => {
                return Err(QuiltError::Invalid {
                    name: Input::Guide,
                    value: 0.0,
                    expected: "a guide for nearest-mean",
                })
            }
            Some(g) if lab && g.image.channels != 3 => {
                return Err(QuiltError::ChannelMismatch { what: Input::LabGuide, expected: 3, got: g.image.channels })
            }
            _ => {}
        },
        SampleChoice::All => {}
    }
    if let Some(or) = &o.orientation {
        check_size(Input::Orientation, or.field, p.width, p.height)?;
        if or.field.channels != 1 && or.field.channels != 2 {
            return Err(QuiltError::ChannelMismatch { what: Input::Orientation, expected: 2, got: or.field.channels });
        }
        check_finite_image(Input::Orientation, or.field)?;
        if or.copies == 0 {
            return Err(QuiltError::Invalid { name: Input::OrientationCopies, value: 0.0, expected: "at least 1" });
        }
    }
    if o.allowed.len() > samples.len() {
        return Err(QuiltError::SampleCount { got: o.allowed.len(), expected: "one allowed map per sample at most" });
    }
    for (m, s) in o.allowed.iter().zip(samples) {
        if let Some(m) = m {
            check_size(Input::AllowedPositions, m, s.width, s.height)?;
            check_finite_image(Input::AllowedPositions, m)?;
        }
    }
    if o.ignore.len() > samples.len() {
        return Err(QuiltError::SampleCount { got: o.ignore.len(), expected: "one mask per sample at most" });
    }
    for (m, s) in o.ignore.iter().zip(samples) {
        if let Some(m) = m {
            check_size(Input::IgnoreMask, m, s.width, s.height)?;
            if m.channels != 1 {
                return Err(QuiltError::ChannelMismatch { what: Input::IgnoreMask, expected: 1, got: m.channels });
            }
            check_finite_image(Input::IgnoreMask, m)?;
        }
    }
    Ok(())
}
